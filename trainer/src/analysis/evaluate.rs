//! The paper's evaluation: leave-one-out RMSE over all points, leave-one-temperature-out RMSE per
//! temperature (its Table 1), the first-order V-vs-T check per rate (its Fig. 2) and the normality
//! of residuals (its Q-Q plot, Fig. 4, as a correlation coefficient).
//!
//! LOO is closed-form for the GP (R&W eq. 5.12) and LS-SVR (Cawley & Talbot), with the fitted
//! hyperparameters, prior mean and normalization held fixed; the two-step model is cheap enough to
//! refit for every point. Leave-one-temperature-out always refits everything, hyperparameters
//! included, on the remaining temperatures: it is the honest test of interpolation in T.

use std::time::Instant;

use crate::progress::Progress;
use rayon::prelude::*;
use serde::Serialize;
use statrs::distribution::{ContinuousCDF, Normal};

use firmware_core::units::DPH_PER_DPS;
use fog_data::sigma::Coverage;
use fog_data::stats::rms;

use crate::analysis::table::{self, FittedTerm, TableDiagnosis, TableError, Transients};
use crate::analysis::uncertainty::{self, Calibration};
use crate::data::points::{PLATEAU_GAP_C, Points};
use crate::models::gp::{GpConfig, GpError, GpModel, Hyperparameters};
use crate::models::lssvr::{LssvrError, LssvrHyper, LssvrModel};
use crate::models::poly::{PolyError, PolyModel};
use crate::models::two_step::{TwoStepError, TwoStepModel};

/// The compared methods.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, schemars::JsonSchema)]
#[serde(rename_all = "kebab-case")]
pub enum Method {
    /// Gaussian-process regression (the paper's method).
    Gpr,
    /// Least-squares support-vector regression.
    Lssvr,
    /// Traditional two-step bias and scale-factor polynomials.
    TwoStep,
    /// One least-squares polynomial in output and temperature (the parametric baseline).
    Poly,
}

impl Method {
    /// The CLI / JSON name.
    pub fn name(self) -> &'static str {
        match self {
            Self::Gpr => "gpr",
            Self::Lssvr => "lssvr",
            Self::TwoStep => "two-step",
            Self::Poly => "poly",
        }
    }
}

/// Settings shared by all methods.
#[derive(Debug, Clone, Serialize, schemars::JsonSchema)]
pub struct EvalConfig {
    /// GP settings (its prior degree is also LS-SVR's).
    pub gp: GpConfig,
    /// Polynomial degree of the two-step model's B(T) and S(T).
    pub two_step_degree: usize,
    /// The GP gives each group of the points its own offset ([`GpModel::fit_grouped`]).
    pub offsets: bool,
}

impl Default for EvalConfig {
    fn default() -> Self {
        Self {
            gp: GpConfig::default(),
            two_step_degree: 3,
            offsets: false,
        }
    }
}

/// Errors of an evaluation.
#[derive(Debug, thiserror::Error)]
pub enum EvalError {
    /// GP failure.
    #[error(transparent)]
    Gp(#[from] GpError),
    /// LS-SVR failure.
    #[error(transparent)]
    Lssvr(#[from] LssvrError),
    /// Two-step failure.
    #[error(transparent)]
    TwoStep(#[from] TwoStepError),
    /// Polynomial failure.
    #[error(transparent)]
    Poly(#[from] PolyError),
    /// Rate-table diagnosis failure.
    #[error(transparent)]
    Table(#[from] TableError),
    /// Two runs share no temperature and rate range.
    #[error("the test points share no temperature and rate range with the training points")]
    NoOverlap,
    /// Every point in one group: there is nothing to leave out and fit on the rest.
    #[error(
        "all {n} points fall in one group ('{group}'): the temperatures form no separate plateaus \
         (a temperature that drifts through the run) or the --group column has one value; \
         leave-one-group-out needs two groups or more: give --group COLUMN naming sweeps, runs or \
         plateaus"
    )]
    OneGroup {
        /// The group's label.
        group: String,
        /// Points.
        n: usize,
    },
    /// Leaving a group out leaves too little to fit.
    #[error(
        "leaving out group '{group}' leaves {remaining} points spanning {span:.3} °C: too few to fit"
    )]
    FoldTooSmall {
        /// The group left out.
        group: String,
        /// Points left.
        remaining: usize,
        /// Temperature span left, °C.
        span: f64,
    },
}

/// A model of any method, fitted.
#[derive(Debug, Clone)]
pub enum MethodFit {
    /// GP.
    Gpr(Box<GpModel>),
    /// LS-SVR.
    Lssvr(Box<LssvrModel>),
    /// Two-step.
    TwoStep(TwoStepModel),
    /// Polynomial.
    Poly(PolyModel),
}

impl MethodFit {
    /// Fits `method` to points.
    pub fn fit(points: &Points, method: Method, cfg: &EvalConfig) -> Result<Self, EvalError> {
        Ok(match method {
            Method::Gpr => Self::Gpr(Box::new(GpModel::fit_grouped(
                points.inputs(),
                &points.target(),
                &points.offset_groups(cfg.offsets),
                &cfg.gp,
            )?)),
            Method::Lssvr => Self::Lssvr(Box::new(LssvrModel::fit(
                points.inputs(),
                &points.target(),
                cfg.gp.mean,
            )?)),
            Method::TwoStep => Self::TwoStep(TwoStepModel::fit(
                &points.temp_c,
                &points.voltage_v,
                &points.rate_dps,
                &points.group_ids(),
                cfg.two_step_degree,
            )?),
            Method::Poly => Self::Poly(PolyModel::fit(
                &points.temp_c,
                &points.voltage_v,
                &points.rate_dps,
            )?),
        })
    }

    /// Compensated rate at (T, V).
    pub fn predict(&self, temp_c: f64, voltage: f64) -> f64 {
        match self {
            Self::Gpr(m) => m.predict_mean(&[temp_c, voltage]),
            Self::Lssvr(m) => m.predict(&[temp_c, voltage]),
            Self::TwoStep(m) => m.predict(temp_c, voltage),
            Self::Poly(m) => m.predict(temp_c, voltage),
        }
    }

    /// The σ a GP's blob would state, measured on the points it was fitted on
    /// ([`uncertainty::tables::pooled_calibration`]: several runs pooled each left out); none for the
    /// methods that state no σ.
    pub fn calibration(
        &self,
        points: &Points,
        cfg: &EvalConfig,
    ) -> Result<Option<Calibration>, EvalError> {
        match self {
            Self::Gpr(m) => Ok(Some(uncertainty::tables::pooled_calibration(
                points, m, &cfg.gp, None, None,
            )?)),
            _ => Ok(None),
        }
    }

    /// The prediction at point `i` of `points`, with the σ `calibration` gives it (NaN without).
    pub fn predict_with_sigma(
        &self,
        points: &Points,
        i: usize,
        calibration: Option<&Calibration>,
    ) -> (f64, f64) {
        let mean = self.predict(points.temp_c[i], points.voltage_v[i]);
        let sigma = match (self, calibration) {
            (Self::Gpr(m), Some(c)) => {
                let x: Vec<f64> = points.inputs().row(i).iter().copied().collect();
                uncertainty::tables::point_sigma(m, c, &x)
            }
            _ => f64::NAN,
        };
        (mean, sigma)
    }

    /// What the fit warned of (a GP's [`GpModel::warnings`]; none for the others).
    pub fn warnings(&self) -> Vec<String> {
        match self {
            Self::Gpr(m) => m.warnings(),
            _ => Vec::new(),
        }
    }

    /// Hyperparameters or coefficients, for the JSON report.
    pub fn parameters(&self) -> Parameters {
        match self {
            Self::Gpr(m) => Parameters::Gpr(m.posterior.hyper.clone()),
            Self::Lssvr(m) => Parameters::Lssvr(m.hyper()),
            Self::TwoStep(m) => Parameters::TwoStep(m.clone()),
            Self::Poly(m) => Parameters::Poly(m.clone()),
        }
    }
}

/// A method's fitted hyperparameters or coefficients, as the JSON report shows them: the fields
/// of the method's own type, the method named beside them.
#[derive(Debug, Clone, Serialize, schemars::JsonSchema)]
#[serde(untagged)]
pub enum Parameters {
    /// The GP's hyperparameters (normalized units).
    Gpr(Hyperparameters),
    /// LS-SVR's length scales and regularization.
    Lssvr(LssvrHyper),
    /// The two-step model's coefficients.
    TwoStep(TwoStepModel),
    /// The polynomial's coefficients.
    Poly(PolyModel),
}

/// LOO errors (prediction − reference) for every point, °/s.
fn loo_errors(
    points: &Points,
    fitted: &MethodFit,
    method: Method,
    cfg: &EvalConfig,
) -> Result<Vec<f64>, EvalError> {
    Ok(match fitted {
        MethodFit::Gpr(m) => m.loo_errors(),
        MethodFit::Lssvr(m) => m.loo_errors(),
        MethodFit::TwoStep(_) | MethodFit::Poly(_) => (0..points.len())
            .map(|i| {
                let keep: Vec<usize> = (0..points.len()).filter(|&j| j != i).collect();
                let m = MethodFit::fit(&points.select(&keep), method, cfg)?;
                Ok(m.predict(points.temp_c[i], points.voltage_v[i]) - points.rate_dps[i])
            })
            .collect::<Result<Vec<_>, EvalError>>()?,
    })
}

/// RMSE of one left-out group.
#[derive(Debug, Clone, Serialize, schemars::JsonSchema)]
pub struct GroupRmse {
    /// Group label (plateau index, or the `--group` column's value).
    pub group: String,
    /// Mean temperature of the group, °C.
    pub temp_c: f64,
    /// Points in the group.
    pub n: usize,
    /// RMSE of the refitted model on the group, °/s.
    pub rmse_dps: f64,
    /// Same, °/h.
    pub rmse_dph: f64,
}

/// One method's evaluation.
#[derive(Debug, Clone, Serialize, schemars::JsonSchema)]
pub struct Evaluation {
    /// Method name.
    pub method: &'static str,
    /// Number of points.
    pub n: usize,
    /// Leave-one-out RMSE, °/s.
    pub rmse_dps: f64,
    /// Leave-one-out RMSE, °/h.
    pub rmse_dph: f64,
    /// Leave-one-group-out (default: temperature) RMSE per group.
    pub per_temperature: Vec<GroupRmse>,
    /// Leave-one-group-out RMSE over all points, °/s.
    pub group_rmse_dps: f64,
    /// Same, °/h.
    pub group_rmse_dph: f64,
    /// Correlation of sorted LOO errors with normal quantiles (1 = perfectly normal).
    pub qq_correlation: f64,
    /// LOO error of every point, °/s, in file order.
    pub loo_errors_dps: Vec<f64>,
    /// Fit on all points, s.
    pub fit_seconds: f64,
    /// LOO computation after the fit, s.
    pub loo_seconds: f64,
    /// Fitted hyperparameters or coefficients (`null` where the figures come from errors alone).
    pub parameters: Option<Parameters>,
    /// What the fit on all points warned of.
    pub warnings: Vec<String>,
    /// With `--features auto` on a timed table: what the diagnosis chose.
    pub diagnosis: Option<TableReport>,
    /// What could not be computed on these points, and why (a group that cannot be left out, or
    /// a single group): the rest is.
    pub skipped: Vec<String>,
    /// The GP's σ on each left-out group, its error model fitted inside the fold from the
    /// fold's own groups (null for the methods that state no σ).
    pub sigma_groups: Option<Coverage>,
    /// Every left-out (error, σ) behind `sigma_groups`, group by group (for the report's
    /// reliability diagram).
    #[serde(skip)]
    pub group_errors: Vec<(f64, f64)>,
    /// The σ of the model fitted on all points ([`Calibration`]), with its coverage of the
    /// point (or group) residuals it was measured on (null for the methods that state no σ).
    pub calibration: Option<Calibration>,
}

impl Evaluation {
    /// The figures from the point-LOO errors and the leave-one-group-out ones (per group, then
    /// all); no parameters, warnings or diagnosis.
    fn from_errors(
        method: &'static str,
        errors: Vec<f64>,
        left_out: LeftOut,
        [fit_seconds, loo_seconds]: [f64; 2],
    ) -> Self {
        let LeftOut {
            per_group: per_temperature,
            pooled,
            skipped,
        } = left_out;
        let group_errors = pooled.clone();
        let (pooled, sigmas): (Vec<f64>, Vec<f64>) = pooled.into_iter().unzip();
        // No group left out (one group): no figure, not a zero.
        let group_rmse = if pooled.is_empty() {
            f64::NAN
        } else {
            rms(&pooled)
        };
        let sigma_groups = (!sigmas.is_empty() && sigmas.iter().all(|s| s.is_finite()))
            .then(|| Coverage::of(&pooled, &sigmas));
        let r = rms(&errors);
        Self {
            method,
            n: errors.len(),
            rmse_dps: r,
            rmse_dph: r * DPH_PER_DPS,
            per_temperature,
            group_rmse_dps: group_rmse,
            group_rmse_dph: group_rmse * DPH_PER_DPS,
            qq_correlation: qq_correlation(&errors),
            loo_errors_dps: errors,
            fit_seconds,
            loo_seconds,
            parameters: None,
            warnings: Vec::new(),
            diagnosis: None,
            sigma_groups,
            group_errors,
            calibration: None,
            skipped,
        }
    }
}

/// Q-Q correlation: Pearson correlation of the sorted values with the normal quantiles at Blom's
/// plotting positions (i − 3/8)/(n + 1/4). About 0.99+ for normal samples of this size.
pub fn qq_correlation(values: &[f64]) -> f64 {
    let n = values.len();
    if n < 3 {
        return f64::NAN;
    }
    let mut v = values.to_vec();
    v.sort_by(f64::total_cmp);
    let Ok(normal) = Normal::new(0.0, 1.0) else {
        return f64::NAN;
    };
    let q: Vec<f64> = (0..n)
        .map(|i| normal.inverse_cdf((i as f64 + 1.0 - 0.375) / (n as f64 + 0.25)))
        .collect();
    let mean = |x: &[f64]| x.iter().sum::<f64>() / x.len() as f64;
    let (mv, mq) = (mean(&v), mean(&q));
    let cov: f64 = v.iter().zip(&q).map(|(a, b)| (a - mv) * (b - mq)).sum();
    let sv: f64 = v.iter().map(|a| (a - mv).powi(2)).sum::<f64>().sqrt();
    let sq: f64 = q.iter().map(|b| (b - mq).powi(2)).sum::<f64>().sqrt();
    cov / (sv * sq)
}

/// The points' groups that can be left out: none where there is only one (nothing could be
/// left out and fitted on the rest), with the reason.
fn groups(points: &Points) -> (Vec<(String, Vec<usize>)>, Option<EvalError>) {
    let groups = points.groups();
    if let [(group, members)] = groups.as_slice() {
        let why = EvalError::OneGroup {
            group: group.clone(),
            n: members.len(),
        };
        return (Vec::new(), Some(why));
    }
    (groups, None)
}

/// Each left-out group's RMSE, every (error, σ) group by group, and why the groups left out of
/// the test were (a group whose leaving out leaves too little to fit, or a single group).
struct LeftOut {
    per_group: Vec<GroupRmse>,
    pooled: Vec<(f64, f64)>,
    skipped: Vec<String>,
}

/// Leave-one-group-out: `fold(kept, left_out)` fits on the kept rows and predicts the left-out
/// ones, each with its σ (NaN for a method that states none). Every group that can be left out is
/// (one whose leaving out leaves too little to fit is skipped, with the reason); the test is
/// skipped, not failed, where there is one group.
fn leave_groups_out<F>(points: &Points, bar: &dyn Progress, fold: F) -> Result<LeftOut, EvalError>
where
    F: Fn(&[usize], &[usize]) -> Result<Vec<(f64, f64)>, EvalError> + Sync,
{
    let (groups, none) = groups(points);
    let mut skipped: Vec<String> = none.iter().map(ToString::to_string).collect();
    let per_group = groups
        .into_par_iter()
        .map(|(group, members)| {
            let keep: Vec<usize> = (0..points.len()).filter(|i| !members.contains(i)).collect();
            let span = crate::data::points::span(
                &keep.iter().map(|&i| points.temp_c[i]).collect::<Vec<_>>(),
            );
            if span <= PLATEAU_GAP_C || keep.len() < 4 {
                bar.advance(1);
                return Ok(Err(EvalError::FoldTooSmall {
                    group,
                    remaining: keep.len(),
                    span,
                }));
            }
            let e: Vec<(f64, f64)> = fold(&keep, &members)?
                .into_iter()
                .zip(&members)
                .map(|((p, sigma), &i)| (p - points.rate_dps[i], sigma))
                .collect();
            let r = rms(&e.iter().map(|(e, _)| *e).collect::<Vec<_>>());
            bar.advance(1);
            Ok(Ok((
                e,
                GroupRmse {
                    group,
                    temp_c: members.iter().map(|&i| points.temp_c[i]).sum::<f64>()
                        / members.len() as f64,
                    n: members.len(),
                    rmse_dps: r,
                    rmse_dph: r * DPH_PER_DPS,
                },
            )))
        })
        .collect::<Result<Vec<_>, EvalError>>()?;
    let mut done = Vec::new();
    for g in per_group {
        match g {
            Ok(g) => done.push(g),
            Err(why) => skipped.push(format!("{why}: that group is not scored")),
        }
    }
    Ok(LeftOut {
        pooled: done.iter().flat_map(|(e, _)| e.clone()).collect(),
        per_group: done.into_iter().map(|(_, g)| g).collect(),
        skipped,
    })
}

/// Evaluates one method on the points; `bar` counts its fits (the full one, then one per group).
pub fn evaluate(
    points: &Points,
    method: Method,
    cfg: &EvalConfig,
    bar: &dyn Progress,
) -> Result<Evaluation, EvalError> {
    bar.expect(1 + groups(points).0.len() as u64);
    bar.stage(&format!(
        "{}: fit on all {} points",
        method.name(),
        points.len()
    ));
    let t0 = Instant::now();
    let fitted = MethodFit::fit(points, method, cfg)?;
    let fit_seconds = t0.elapsed().as_secs_f64();
    let t1 = Instant::now();
    let errors = loo_errors(points, &fitted, method, cfg)?;
    let loo_seconds = t1.elapsed().as_secs_f64();
    bar.advance(1);
    bar.stage(&format!("{}: leave one group out", method.name()));
    let left_out = leave_groups_out(points, bar, |keep, members| {
        let train = points.select(keep);
        let m = MethodFit::fit(&train, method, cfg)?;
        let calibration = m.calibration(&train, cfg)?;
        Ok(members
            .iter()
            .map(|&i| m.predict_with_sigma(points, i, calibration.as_ref()))
            .collect())
    })?;
    Ok(Evaluation {
        parameters: Some(fitted.parameters()),
        warnings: fitted.warnings(),
        calibration: fitted.calibration(points, cfg)?,
        ..Evaluation::from_errors(method.name(), errors, left_out, [fit_seconds, loo_seconds])
    })
}

/// What the diagnosis of a timed table chose, on all rows and in every fold.
#[derive(Debug, Clone, Serialize, schemars::JsonSchema)]
pub struct TableReport {
    /// On all rows: the model `fit` would ship.
    pub all_rows: TableDiagnosis,
    /// Its terms.
    pub terms: Vec<FittedTerm>,
    /// In each leave-one-group-out fold, from that fold's training rows alone.
    pub per_group: Vec<FoldChoice>,
}

/// The choice made inside one fold.
#[derive(Debug, Clone, Serialize, schemars::JsonSchema)]
pub struct FoldChoice {
    /// The group left out.
    pub group: String,
    /// What shipped in that fold: the chosen candidates' names, empty for the static model.
    pub shipped: Vec<String>,
}

/// The GP with its rate-table diagnosis (`loo --features auto`, [`crate::analysis::table`])
/// evaluated as [`evaluate`] evaluates a method: leave-one-out closed-form on the model fitted on
/// all rows (hyperparameters and chosen terms held), and leave-one-group-out with the diagnosis and
/// the extension redone inside every fold from its training rows alone.
pub fn evaluate_table(
    points: &Points,
    cfg: &EvalConfig,
    bar: &dyn Progress,
) -> Result<Evaluation, EvalError> {
    let transients = Transients::compute(points)?;
    let (groups, _) = groups(points);
    bar.expect(1 + groups.len() as u64);
    bar.stage(&format!("gpr + diagnosis: all {} points", points.len()));
    let all: Vec<usize> = (0..points.len()).collect();
    let t0 = Instant::now();
    let model = table::fit(points, &transients, &all, (&cfg.gp, cfg.offsets))?;
    let fit_seconds = t0.elapsed().as_secs_f64();
    let t1 = Instant::now();
    let errors = model.loo_errors(points, &transients, &all)?;
    let loo_seconds = t1.elapsed().as_secs_f64();
    bar.advance(1);
    bar.stage("gpr + diagnosis: leave one group out");
    let choices = std::sync::Mutex::new(Vec::new());
    let left_out = leave_groups_out(points, bar, |keep, members| {
        let m = table::fit(points, &transients, keep, (&cfg.gp, cfg.offsets))?;
        let calibration = m.calibration(points, &transients, keep)?;
        if let Ok(mut c) = choices.lock() {
            c.push(FoldChoice {
                group: points.group[members[0]].clone(),
                shipped: m.terms.iter().map(|t| t.candidate.name()).collect(),
            });
        }
        Ok(members
            .iter()
            .map(|&i| {
                let x: Vec<f64> = points.inputs().row(i).iter().copied().collect();
                (
                    m.predict(points, &transients, i),
                    uncertainty::tables::point_sigma(&m.gp, &calibration, &x),
                )
            })
            .collect())
    })?;
    let mut per_group = choices.into_inner().unwrap_or_default();
    let order: Vec<String> = groups.into_iter().map(|(g, _)| g).collect();
    per_group.sort_by_key(|c| order.iter().position(|g| *g == c.group));
    Ok(Evaluation {
        parameters: Some(Parameters::Gpr(model.gp.posterior.hyper.clone())),
        warnings: model.gp.warnings(),
        calibration: Some(model.calibration(points, &transients, &all)?),
        diagnosis: Some(TableReport {
            all_rows: model.diagnosis,
            terms: model.terms,
            per_group,
        }),
        ..Evaluation::from_errors(
            Method::Gpr.name(),
            errors,
            left_out,
            [fit_seconds, loo_seconds],
        )
    })
}

/// The paper's Fig. 2 check at one rate.
#[derive(Debug, Clone, Serialize, schemars::JsonSchema)]
pub struct RateLineFit {
    /// Reference rate, °/s.
    pub rate_dps: f64,
    /// Worst |V − line(T)|, mV (output units × 1000).
    pub worst_mv: f64,
    /// Same, divided by the mean scale factor, °/s.
    pub worst_dps: f64,
}

/// The paper's Fig. 2 check: per rate, a first-order fit of V against T.
#[derive(Debug, Clone, Serialize, schemars::JsonSchema)]
pub struct Fig2 {
    /// Least-squares scale factor over all points, mV per °/s.
    pub scale_factor_mv_per_dps: f64,
    /// Per rate.
    pub per_rate: Vec<RateLineFit>,
    /// The worst rate's figures.
    pub worst: Option<RateLineFit>,
}

/// Runs the Fig. 2 check (rates grouped when equal to 1e-6 °/s).
pub fn fig2(points: &Points) -> Fig2 {
    let n = points.len() as f64;
    let mw = points.rate_dps.iter().sum::<f64>() / n;
    let mv = points.voltage_v.iter().sum::<f64>() / n;
    let sww: f64 = points.rate_dps.iter().map(|w| (w - mw).powi(2)).sum();
    let swv: f64 = points
        .rate_dps
        .iter()
        .zip(&points.voltage_v)
        .map(|(w, v)| (w - mw) * (v - mv))
        .sum();
    let sf = swv / sww;
    let mut rates: Vec<f64> = Vec::new();
    for &w in &points.rate_dps {
        if !rates.iter().any(|r| (r - w).abs() < 1e-6) {
            rates.push(w);
        }
    }
    rates.sort_by(f64::total_cmp);
    let per_rate: Vec<RateLineFit> = rates
        .iter()
        .filter_map(|&w| {
            let idx: Vec<usize> = (0..points.len())
                .filter(|&i| (points.rate_dps[i] - w).abs() < 1e-6)
                .collect();
            let m = idx.len() as f64;
            let mt = idx.iter().map(|&i| points.temp_c[i]).sum::<f64>() / m;
            let mvv = idx.iter().map(|&i| points.voltage_v[i]).sum::<f64>() / m;
            let stt: f64 = idx.iter().map(|&i| (points.temp_c[i] - mt).powi(2)).sum();
            if idx.len() < 3 || stt == 0.0 {
                return None;
            }
            let stv: f64 = idx
                .iter()
                .map(|&i| (points.temp_c[i] - mt) * (points.voltage_v[i] - mvv))
                .sum();
            let slope = stv / stt;
            let worst = idx
                .iter()
                .map(|&i| (points.voltage_v[i] - mvv - slope * (points.temp_c[i] - mt)).abs())
                .fold(0.0, f64::max);
            Some(RateLineFit {
                rate_dps: w,
                worst_mv: worst * 1e3,
                worst_dps: worst / sf.abs(),
            })
        })
        .collect();
    let worst = per_rate
        .iter()
        .max_by(|a, b| a.worst_mv.total_cmp(&b.worst_mv))
        .cloned();
    Fig2 {
        scale_factor_mv_per_dps: sf * 1e3,
        per_rate,
        worst,
    }
}

pub mod across_runs;

#[cfg(test)]
mod tests;
