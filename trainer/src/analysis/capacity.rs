//! A model the firmware can hold, chosen from the data when there are more points than it holds.
//!
//! The firmware evaluates at most [`MAX_CENTRES`] centres, and an exact GP has one per training
//! point; a lab's calibration run often has more (the UWRT turntable runs: 695 and 773 segments).
//! Above that the default fit is a sparse GP, whose inducing points are its centres, with their
//! number chosen by a stated rule, measured on the data itself: every fifth point is held out,
//! a sparse GP with each of [`CANDIDATES`] inducing points is fitted on the rest, and the fewest
//! whose held-out error is within [`TOLERANCE`] of the best of them is chosen (fewer centres, fewer
//! instructions per prediction). The exact GP is fitted on the same split, to say what the choice
//! costs against it, and a choice more than [`WORSE_THAN_EXACT`] times worse than the exact GP is
//! not made. Where a prior mean other than the default was asked (the paper's constant), the
//! kernel carries what that mean leaves, and its inducing points can be so nearly dependent that
//! the firmware's f32 keeps only a few: the sizes are then tried again with the default
//! ([`MeanBasis::Physics`]), which carries the scale factor and the bias's curve itself, and that
//! mean is chosen if it comes within [`WORSE_THAN_EXACT`] of the exact GP asked for (a constant
//! mean's exact GP, on 2,000 scattered points 7.2 °/h held out; its best sparse size 136 °/h, the
//! default's 7.8). Failing that too, the most accurate size is, and the output says what it costs.
//! Above [`COMPARE_MAX`]
//! points the comparison is made on that many, evenly spaced (the exact GP costs O(n³)); the
//! chosen size is then fitted on all of them. Every command that fits the default model resolves
//! it here ([`resolve`]), so an evaluation evaluates what `fit` would ship.

use firmware_core::MAX_CENTRES;
use firmware_core::Quantity;
use serde::Serialize;

use crate::data::points::Points;
use crate::models::gp::{GpConfig, GpError, GpModel, Inducing};
use crate::models::prior::MeanBasis;

/// Inducing-point counts tried, all exportable.
pub const CANDIDATES: [usize; 5] = [24, 48, 96, 160, 256];
/// How much worse than the best candidate's held-out error the chosen one may be.
pub const TOLERANCE: f64 = 0.05;
/// Every `HOLD_OUT_EVERY`-th point is held out.
const HOLD_OUT_EVERY: usize = 5;
/// Most points the comparison is made on (module doc).
pub const COMPARE_MAX: usize = 2500;
/// How much worse than the exact GP held out a default may be before it says so and takes the
/// most accurate size instead.
pub const WORSE_THAN_EXACT: f64 = 1.5;

/// Instructions of one mean prediction on the Cortex-M4F with `m` centres (two inputs): about
/// 1,200 fixed and 73 per centre, as measured under QEMU (docs/firmware.md).
pub fn instructions(m: usize) -> f64 {
    1200.0 + 73.0 * m as f64
}

/// One model tried.
#[derive(Debug, Clone, PartialEq, Serialize, schemars::JsonSchema)]
pub struct TriedSize {
    /// Inducing points asked for (the training points for the exact GP).
    pub asked: usize,
    /// Centres the model has: a sparse fit drops inducing points its data cannot tell apart.
    pub centres: usize,
    /// `sparse` or `exact`.
    pub kind: &'static str,
    /// RMSE on the held-out points, °/s.
    pub held_out_rmse_dps: f64,
    /// Instructions per mean prediction on the Cortex-M4F (estimate, [`instructions`]).
    pub instructions: f64,
    /// Whether the firmware can hold it.
    pub exportable: bool,
    /// Fit time on the training part, s.
    pub fit_seconds: f64,
}

/// The choice, as `fit --json` reports it (`centres_choice`).
#[derive(Debug, Clone, PartialEq, Serialize, schemars::JsonSchema)]
pub struct Choice {
    /// The rule, in words.
    pub rule: String,
    /// Points in all.
    pub n: usize,
    /// Of which held out for the comparison.
    pub held_out: usize,
    /// Every sparse candidate.
    pub candidates: Vec<TriedSize>,
    /// The exact GP on the same split; its centres, instructions and exportability are those it
    /// would have on all the points (more than the firmware holds).
    pub exact: TriedSize,
    /// Inducing points asked for by the choice.
    pub chosen: usize,
    /// The prior mean of the choice: the one asked for, or the default where the one asked for
    /// keeps no size within [`WORSE_THAN_EXACT`] of the exact GP and the default does (module doc).
    pub mean: MeanBasis,
    /// The sizes tried with the default mean, where they were (else empty).
    pub default_mean_candidates: Vec<TriedSize>,
    /// What the choice costs against the exact GP, in words.
    pub verdict: String,
}

/// Whether the default fit of `n` points needs a choice: more than the firmware holds.
pub fn needed(inducing: Inducing, n: usize) -> bool {
    inducing == Inducing::Auto && n > MAX_CENTRES
}

/// `cfg` with its size resolved for `points` as the default fit resolves it: the exact GP where
/// the firmware holds it or the size was asked for, else the choice ([`choose`]), returned.
pub fn resolve(
    points: &Points,
    cfg: &GpConfig,
    progress: impl FnMut(&str),
) -> Result<(GpConfig, Option<Choice>), GpError> {
    if !needed(cfg.inducing, points.len()) {
        return Ok((cfg.clone(), None));
    }
    let choice = choose(points, cfg, progress)?;
    let resolved = GpConfig {
        inducing: Inducing::Count(choice.chosen),
        mean: choice.mean,
        ..cfg.clone()
    };
    Ok((resolved, Some(choice)))
}

/// The points a choice compares sizes on: at most [`COMPARE_MAX`] of them, evenly spaced, every
/// [`HOLD_OUT_EVERY`]th held out.
struct Comparison {
    fit_part: Points,
    test_part: Points,
    cfg: GpConfig,
}

impl Comparison {
    /// The comparison on `points`, each size fitted as `cfg` says.
    fn of(points: &Points, cfg: &GpConfig) -> Self {
        let stride = points.len().div_ceil(COMPARE_MAX);
        let compared: Vec<usize> = (0..points.len()).step_by(stride).collect();
        let held = |k: usize| k % HOLD_OUT_EVERY == HOLD_OUT_EVERY - 1;
        let pick = |out: bool| -> Vec<usize> {
            compared
                .iter()
                .enumerate()
                .filter(|(k, _)| held(*k) == out)
                .map(|(_, &i)| i)
                .collect()
        };
        Self {
            fit_part: points.select(&pick(false)),
            test_part: points.select(&pick(true)),
            cfg: cfg.clone(),
        }
    }

    /// The held-out RMSE, fit seconds and centres kept of a GP of size `inducing` with prior mean
    /// `mean`, fitted on the fit part.
    fn score(&self, inducing: Inducing, mean: MeanBasis) -> Result<(f64, f64, usize), GpError> {
        let cfg = GpConfig {
            inducing,
            mean,
            ..self.cfg.clone()
        };
        let model = GpModel::fit(self.fit_part.inputs(), &self.fit_part.target(), &cfg)?;
        let x = self.test_part.inputs();
        let target = self.test_part.target();
        let sq: f64 = (0..x.nrows())
            .map(|i| {
                let row: Vec<f64> = x.row(i).iter().copied().collect();
                (model.predict_mean(&row) - target[i]).powi(2)
            })
            .sum();
        Ok((
            (sq / x.nrows().max(1) as f64).sqrt(),
            model.fit_seconds,
            model.posterior.xs.nrows(),
        ))
    }

    /// Every sparse size of [`CANDIDATES`] below the fit part's points, with prior mean `mean`.
    fn sizes(
        &self,
        mean: MeanBasis,
        progress: &mut dyn FnMut(&str),
    ) -> Result<Vec<TriedSize>, GpError> {
        let mut tried = Vec::new();
        for &m in CANDIDATES.iter().filter(|&&m| m < self.fit_part.len()) {
            progress(&format!(
                "a sparse GP with {m} inducing points (--mean {mean})"
            ));
            let (rmse, secs, kept) = self.score(Inducing::Count(m), mean)?;
            tried.push(TriedSize {
                asked: m,
                centres: kept,
                kind: "sparse",
                held_out_rmse_dps: rmse,
                instructions: instructions(kept),
                exportable: true,
                fit_seconds: secs,
            });
        }
        Ok(tried)
    }
}

/// Chooses the inducing points for `points` (module doc); `progress` is told each fit.
pub fn choose(
    points: &Points,
    cfg: &GpConfig,
    mut progress: impl FnMut(&str),
) -> Result<Choice, GpError> {
    let n = points.len();
    let stride = n.div_ceil(COMPARE_MAX);
    let comparison = Comparison::of(points, cfg);
    let train = comparison.fit_part.len();
    let candidates = comparison.sizes(cfg.mean, &mut progress)?;
    progress(&format!("the exact GP on {train} points, for comparison"));
    let (rmse, secs, _) = comparison.score(Inducing::Exact, cfg.mean)?;
    let exact = TriedSize {
        asked: train,
        centres: n,
        kind: "exact",
        held_out_rmse_dps: rmse,
        instructions: instructions(n),
        exportable: n <= MAX_CENTRES,
        fit_seconds: secs,
    };
    let (mut pick, mut how) = rule(&candidates, &exact);
    let mut mean = cfg.mean;
    let mut default_mean_candidates = Vec::new();
    let limit = WORSE_THAN_EXACT * exact.held_out_rmse_dps;
    if pick.held_out_rmse_dps > limit && cfg.mean != MeanBasis::Physics {
        default_mean_candidates = comparison.sizes(MeanBasis::Physics, &mut progress)?;
        let (other, other_how) = rule(&default_mean_candidates, &exact);
        if other.held_out_rmse_dps <= limit {
            how = format!(
                "with the default mean (physics) instead of --mean {}: with it {:.1}× the \
                 exact GP's error at best, as its kernel carries what that mean leaves, in \
                 centres the firmware's f32 cannot tell apart; with the default, {other_how}",
                cfg.mean,
                pick.held_out_rmse_dps / exact.held_out_rmse_dps
            );
            (pick, mean) = (other, MeanBasis::Physics);
        }
    }
    let verdict = verdict(n, stride, (&pick, &how), &exact, points.quantity);
    Ok(Choice {
        rule: format!(
            "exact up to {MAX_CENTRES} points; above, the fewest of {:?} inducing points within \
             {:.0}% of the best held-out error (every {HOLD_OUT_EVERY}th point held out, of at \
             most {COMPARE_MAX}), unless that is more than {WORSE_THAN_EXACT}× the exact GP's: \
             then the most accurate",
            CANDIDATES,
            TOLERANCE * 100.0
        ),
        n,
        held_out: comparison.test_part.len(),
        candidates,
        exact,
        chosen: pick.asked,
        mean,
        default_mean_candidates,
        verdict,
    })
}

/// The rule's pick among the sparse `candidates`, beside the `exact` GP, and how it was picked
/// in words: the fewest inducing points within [`TOLERANCE`] of the best held-out error, unless
/// that is more than [`WORSE_THAN_EXACT`] times the exact GP's: then the most accurate.
fn rule(candidates: &[TriedSize], exact: &TriedSize) -> (TriedSize, String) {
    let best = candidates
        .iter()
        .map(|c| c.held_out_rmse_dps)
        .fold(f64::INFINITY, f64::min);
    let fewest = candidates
        .iter()
        .find(|c| c.held_out_rmse_dps <= (1.0 + TOLERANCE) * best)
        .unwrap_or(exact)
        .clone();
    let limit = WORSE_THAN_EXACT * exact.held_out_rmse_dps;
    if fewest.held_out_rmse_dps <= limit {
        (
            fewest,
            format!(
                "the fewest within {:.0}% of the best held-out error",
                TOLERANCE * 100.0
            ),
        )
    } else {
        let most = candidates
            .iter()
            .min_by(|a, b| a.held_out_rmse_dps.total_cmp(&b.held_out_rmse_dps))
            .unwrap_or(exact)
            .clone();
        let how = format!(
            "the most accurate: the fewest within {:.0}% of the best ({}) is {:.1}× worse than \
             the exact GP held out{}",
            TOLERANCE * 100.0,
            fewest.asked,
            fewest.held_out_rmse_dps / exact.held_out_rmse_dps,
            if most.held_out_rmse_dps > limit {
                let kept = candidates.iter().map(|c| c.centres).max().unwrap_or(0);
                let why = if 2 * kept < most.asked.max(1) {
                    format!(
                        "none keeps more than {kept} centres: the rest are nearly dependent in \
                         this model's metric, where the firmware's f32 cannot follow them (a \
                         prior mean that carries more of the signal, the default --mean \
                         physics, leaves the kernel less to do)"
                    )
                } else {
                    "these data want more centres than a firmware model has".to_owned()
                };
                format!(
                    ", and so is every size the firmware holds (the best, {}, {:.1}×): {why}",
                    most.asked,
                    most.held_out_rmse_dps / exact.held_out_rmse_dps
                )
            } else {
                String::new()
            }
        );
        (most, how)
    }
}

/// The choice in words: what was asked and kept, how, and its held-out error and cost against
/// the exact GP's.
fn verdict(
    n: usize,
    stride: usize,
    (pick, how): (&TriedSize, &str),
    exact: &TriedSize,
    quantity: Quantity,
) -> String {
    let (u, k, b) = (
        quantity.unit(),
        quantity.bias_per_unit(),
        quantity.bias_unit(),
    );
    let sampled = if stride > 1 {
        format!(" of every {stride}th of the {n} points")
    } else {
        String::new()
    };
    format!(
        "{n} points are more than the {MAX_CENTRES} centres a firmware model holds: a sparse GP \
         asking {} inducing points ({} kept), {how}, of {} (every {HOLD_OUT_EVERY}th{sampled} held \
         out). It scores {:.3e} {u} ({:.1} {b}) there against the exact GP's {:.3e} {u} ({:.1} \
         {b}), {:+.1}%, at about {:.0} instructions per prediction on the Cortex-M4F against the \
         exact GP's {:.0}",
        pick.asked,
        pick.centres,
        CANDIDATES
            .iter()
            .map(ToString::to_string)
            .collect::<Vec<_>>()
            .join("/"),
        pick.held_out_rmse_dps,
        pick.held_out_rmse_dps * k,
        exact.held_out_rmse_dps,
        exact.held_out_rmse_dps * k,
        (pick.held_out_rmse_dps / exact.held_out_rmse_dps - 1.0) * 100.0,
        pick.instructions,
        exact.instructions,
    )
}
