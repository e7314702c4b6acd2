//! `trainer loo` as a library pipeline: one method left out a point and a group at a time on a
//! rate table, the size `fit` would ship resolved first, and (where another run is given) the
//! model fitted on all of it scored on that run inside the range both cover. Reading the tables,
//! and printing or writing what comes back, are the caller's.

use std::path::Path;

use fog_data::channels::Datasheet;
use serde::Serialize;

use crate::analysis::basis::{self, BasisChoice};
use crate::analysis::capacity::{self, Choice};
use crate::analysis::evaluate::across_runs::{self, CrossRun};
use crate::analysis::evaluate::{self, EvalConfig, EvalError, Evaluation, Method};
use crate::data::points::Points;
use crate::progress::Messages;

/// `trainer loo`'s settings, checked once by whoever built them.
#[derive(Clone, Debug)]
pub struct LooPlan {
    /// The method and its settings (the GP's, the two-step degree, offsets per group).
    pub cfg: EvalConfig,
    /// The method evaluated.
    pub method: Method,
    /// A table recorded in time order diagnosed for transients, the GP extended by those that
    /// win inside each fold (the GP only, on one table).
    pub transients: bool,
    /// A datasheet's bias repeatability, output units, stated in the σ scored on another run
    /// (`None`: assumed where the runs do not measure it, as `fit` assumes it).
    pub repeatability: Option<f64>,
    /// A datasheet's scale-factor repeatability, ppm, stated in the σ scored on another run.
    pub scale_repeatability: Option<f64>,
}

/// What `loo` measured, as `loo --json` writes it: the evaluation's fields, the cross-run test
/// where one was asked for and could be made (`null` otherwise), and how the size `fit` would
/// ship was chosen (more points than the firmware holds).
#[derive(Serialize, schemars::JsonSchema)]
pub struct Loo {
    /// The leave-one-out and leave-one-group-out figures.
    #[serde(flatten)]
    pub evaluation: Evaluation,
    /// Fitted on all points, scored on another run.
    pub cross_run: Option<CrossRun>,
    /// How the default chose the size `fit` would ship.
    pub centres_choice: Option<Choice>,
    /// How `--mean auto` (the default) chose the prior mean's basis `fit` would ship, on
    /// temperature bands left out: once, on every point, as the hyperparameters are (`null`:
    /// a basis asked for, or another method than the GP).
    pub basis_choice: Option<BasisChoice>,
}

impl LooPlan {
    /// The plan, or why its settings do not make one.
    pub fn new(
        cfg: EvalConfig,
        method: Method,
        transients: bool,
        (repeatability, scale_repeatability): (Option<f64>, Option<f64>),
    ) -> anyhow::Result<Self> {
        anyhow::ensure!(
            !transients || method == Method::Gpr,
            "--features auto evaluates the GP (--method gpr) on one table"
        );
        super::check_datasheet(&Datasheet {
            repeatability,
            scale_repeatability,
            ..Datasheet::default()
        })?;
        anyhow::ensure!(
            (repeatability.is_none() && scale_repeatability.is_none()) || method == Method::Gpr,
            "--repeatability and --scale-repeatability are stated in a σ, and of the methods only \
             the GP (--method gpr) states one"
        );
        Ok(Self {
            cfg,
            method,
            transients,
            repeatability,
            scale_repeatability,
        })
    }

    /// The evaluation of `points` (and, with `test`, the run read from its path, scored there),
    /// the choices said as they are made.
    pub fn run(
        &self,
        points: &Points,
        test: Option<(&Path, &Points)>,
        messages: &dyn Messages,
    ) -> anyhow::Result<Loo> {
        anyhow::ensure!(
            !self.transients || test.is_none(),
            "--features auto evaluates the GP on one table; --valid-points is not supported with it"
        );
        let mut cfg = self.cfg.clone();
        // What `fit` would ship: its basis chosen as `fit` chooses it (on every point: the
        // leave-one-out holds it, as it holds the hyperparameters, fitted on all of them), its
        // size resolved as the default fit resolves it, where it can be.
        let (basis_choice, centres_choice) = if self.method == Method::Gpr {
            let busy = messages.busy("choosing the prior mean's basis on temperature bands");
            let (gp, basis_choice) = basis::resolve(points, &cfg.gp);
            drop(busy);
            if let Some(c) = &basis_choice {
                messages.result(&format!("prior mean: {}", c.verdict));
            }
            cfg.gp = gp;
            (
                basis_choice,
                resolve_size(points, &mut cfg, self.transients, messages)?,
            )
        } else {
            cfg.gp.mean = cfg.gp.mean.or_physics();
            (None, None)
        };
        let progress = messages.counted();
        let cross_run = match test {
            Some((path, test)) => {
                let stated = (self.repeatability, self.scale_repeatability);
                match across_runs::score(points, test, self.method, &cfg, stated, &*progress) {
                    Err(e @ EvalError::NoOverlap) => {
                        messages.warn(&format!("skipped the test on {}: {e}", path.display()));
                        None
                    }
                    other => Some(other?),
                }
            }
            None => None,
        };
        let evaluation = if self.transients {
            evaluate::evaluate_table(points, &cfg, &*progress)?
        } else {
            evaluate::evaluate(points, self.method, &cfg, &*progress)?
        };
        Ok(Loo {
            evaluation,
            cross_run,
            centres_choice,
            basis_choice,
        })
    }
}

/// The size of the GP `loo` evaluates: what `fit` would ship ([`capacity::resolve`]), or, where
/// the evaluation needs the exact GP (`--features auto`, `--offsets`), the exact GP with a
/// warning where `fit` would refuse to export it.
fn resolve_size(
    points: &Points,
    cfg: &mut EvalConfig,
    transients: bool,
    messages: &dyn Messages,
) -> anyhow::Result<Option<Choice>> {
    if transients || cfg.offsets {
        if capacity::needed(cfg.gp.inducing, points.len()) {
            messages.warn(&format!(
                "{} points are more than the {} centres a firmware model holds, and {} needs the \
                 exact GP: these are the exact GP's figures, which `fit` would refuse to export",
                points.len(),
                firmware_core::MAX_CENTRES,
                if cfg.offsets {
                    "--offsets"
                } else {
                    "--features auto"
                }
            ));
        }
        return Ok(None);
    }
    let busy = messages.busy("choosing the model `fit` would ship");
    let (resolved, choice) = capacity::resolve(points, &cfg.gp, |step| {
        busy.stage(&format!("choosing the model `fit` would ship: {step}"));
    })?;
    drop(busy);
    if let Some(c) = &choice {
        messages.result(&format!(
            "evaluating what `fit` would ship (--inducing exact: the exact GP): {}",
            c.verdict
        ));
    }
    cfg.gp = resolved;
    Ok(choice)
}
