//! Diagnosis of rate tables recorded in time order: which transient input, on the bias or on the
//! scale factor, the static GP misses.
//!
//! Why a rate table needs one: on a heated turntable the temperature never settles (a bang-bang
//! heater swings it by degrees while the rates are swept), so each row is taken while the coil
//! lags the sensor or the fibre is strained by a gradient. The static map ω = f(T, V) cannot tell
//! those rows from a steady state; the GP then follows them with a short temperature length scale
//! and interpolates worse between sweeps (a left-out half-sweep of the UWRT FOG: 135 °/h against a
//! cubic polynomial's 79.5). A transient on the scale factor matters most here: a coil that lags
//! the sensor by τ sees S(T_coil) ≈ S(T) − S′·τ·dT/dt, an error that grows with rate.
//!
//! The candidates are firmware-core features computed over the rows in time order, exactly as the
//! firmware computes them on the gyro: the temperature rate through a first-order filter of τ
//! (acting on the bias, or times the output on the scale factor), the heating/cooling state of a
//! play of half-width w (both forms) and the time since the first row (bias). Each enters the GP's
//! prior mean as an extra column whose coefficient is marginalized with the basis
//! ([`GpModel::fit_with_terms`]), so the kernel keeps its length scales for what the terms do not
//! explain.
//!
//! The choice uses the training rows alone: candidates are added one at a time while each cuts the
//! closed-form leave-one-group-out error ([`crate::models::gp::exact::group_loo`], hyperparameters
//! held at the static fit's) by at least [`MIN_GAIN`]; the extended model is then fitted with its
//! own hyperparameters (searched from where the static fit's starts ended) and shipped only if its
//! own leave-one-group-out error is below the static model's. The static fit used for this is the
//! best end of its starts, not yet polished ([`GpModel::fit_grouped_unpolished`]): the polish
//! converges a model that ships, and the static one is polished only when it does. Scoring a
//! whole left-out group (a half-sweep, a plateau) rather than one row keeps a transient from
//! looking predictive by following its neighbours in time.

use firmware_core::Feature;
use firmware_core::features::{self, FeatureState, Sample};
use fog_data::cause::Cause;
use fog_data::stats::rms;
use nalgebra::DMatrix;
use serde::Serialize;

use crate::analysis::uncertainty::{self, Calibration};
use crate::data::points::Points;
use crate::firmware::export::{Extension, Term};
use crate::models::gp::{GpConfig, GpError, GpModel};

/// Least relative cut of the leave-one-group-out RMSE for a candidate to be added.
pub const MIN_GAIN: f64 = 0.1;

/// Most candidates one model carries.
pub const MAX_TERMS: usize = 3;

/// Filter time constants of the temperature-rate candidates, s.
const RATE_TAUS_S: [f32; 7] = [20.0, 40.0, 80.0, 160.0, 320.0, 640.0, 1280.0];

/// Half-widths of the heating/cooling play candidates, °C.
const PLAY_WIDTHS_C: [f32; 4] = [0.25, 0.5, 1.0, 2.0];

/// Errors of a rate-table diagnosis.
#[derive(Debug, thiserror::Error)]
pub enum TableError {
    /// The table has no time column.
    #[error(
        "the rate table has no time column: a diagnosis needs the time each row was recorded \
         (--map time_s=COLUMN, e.g. --map time_s=segment*21 for segments of 21 s)"
    )]
    Untimed,
    /// Fewer than three groups to leave out.
    #[error(
        "{0} groups in the training rows; choosing a transient needs at least 3 to leave out \
         (--group COLUMN names them, e.g. half_sweep)"
    )]
    TooFewGroups(usize),
    /// A GP fit failed.
    #[error(transparent)]
    Gp(#[from] GpError),
}

/// Where a transient acts.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, schemars::JsonSchema)]
#[serde(rename_all = "kebab-case")]
pub enum ActsOn {
    /// ω += c·x.
    Bias,
    /// ω += c·x·output: an error that grows with rate.
    ScaleFactor,
}

/// One transient input a table may lack.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, schemars::JsonSchema)]
pub struct Candidate {
    /// The cause it stands for.
    pub cause: Cause,
    /// The firmware feature that computes it.
    pub feature: Feature,
    /// Where it acts.
    pub acts_on: ActsOn,
}

impl Candidate {
    /// A short name: "thermal-rate (τ 80 s) on the scale factor".
    pub fn name(&self) -> String {
        let parameter = match self.feature {
            Feature::TemperatureRate { tau_s } => format!(" (τ {tau_s} s)"),
            Feature::ThermalState { width_c } => format!(" (play ±{width_c} °C)"),
            _ => String::new(),
        };
        let on = match self.acts_on {
            ActsOn::Bias => "bias",
            ActsOn::ScaleFactor => "scale factor",
        };
        format!("{}{parameter} on the {on}", self.cause)
    }

    /// Same cause, feature kind and form (differing at most in the parameter).
    fn same_family(&self, other: &Self) -> bool {
        self.cause == other.cause && self.acts_on == other.acts_on
    }
}

/// Every candidate, in a fixed order.
pub fn candidates() -> Vec<Candidate> {
    let mut out = Vec::new();
    for acts_on in [ActsOn::Bias, ActsOn::ScaleFactor] {
        out.extend(RATE_TAUS_S.iter().map(|&tau_s| Candidate {
            cause: Cause::ThermalRate,
            feature: Feature::TemperatureRate { tau_s },
            acts_on,
        }));
        out.extend(PLAY_WIDTHS_C.iter().map(|&width_c| Candidate {
            cause: Cause::Hysteresis,
            feature: Feature::ThermalState { width_c },
            acts_on,
        }));
    }
    out.push(Candidate {
        cause: Cause::TimeDrift,
        feature: Feature::TimeOn,
        acts_on: ActsOn::Bias,
    });
    out
}

/// Every candidate's column over the whole table, rows in time order: computed once, before any
/// split, because the firmware's filters run over every row the gyro saw (a left-out group's rows
/// shape the filter state of the rows after it, as on the gyro; no target enters).
#[derive(Debug, Clone)]
pub struct Transients {
    /// The candidates, one per column.
    pub candidates: Vec<Candidate>,
    /// n rows × candidates: the term's regressor (the feature, or feature × output).
    pub columns: DMatrix<f64>,
    /// The feature's value at each row (before the product), n × candidates.
    pub features: DMatrix<f64>,
}

impl Transients {
    /// Computes the candidates over a timed table.
    pub fn compute(points: &Points) -> Result<Self, TableError> {
        let time_s = points.time_s.as_ref().ok_or(TableError::Untimed)?;
        let candidates = candidates();
        let n = points.len();
        let mut feats = DMatrix::zeros(n, candidates.len());
        for (j, c) in candidates.iter().enumerate() {
            let mut state = FeatureState::default();
            let mut out = [0.0f32; 1];
            let mut last = 0.0;
            for i in 0..n {
                let sample = Sample {
                    time_s: time_s[i],
                    temp_c: points.temp_c[i] as f32,
                    output: points.voltage_v[i] as f32,
                };
                // A faulty row (never in a loaded table: temperatures are checked) holds the
                // last value, as the firmware's state does.
                if features::compute(&[c.feature], &sample, &mut state, &mut out)
                    != firmware_core::Status::Fault
                {
                    last = f64::from(out[0]);
                }
                feats[(i, j)] = last;
            }
        }
        let columns = DMatrix::from_fn(n, candidates.len(), |i, j| match candidates[j].acts_on {
            ActsOn::Bias => feats[(i, j)],
            ActsOn::ScaleFactor => feats[(i, j)] * points.voltage_v[i],
        });
        Ok(Self {
            candidates,
            columns,
            features: feats,
        })
    }

    /// The columns of `chosen` (candidate indices) at `rows`.
    fn design(&self, rows: &[usize], chosen: &[usize]) -> DMatrix<f64> {
        DMatrix::from_fn(rows.len(), chosen.len(), |i, j| {
            self.columns[(rows[i], chosen[j])]
        })
    }
}

/// A candidate's score on the training rows.
#[derive(Debug, Clone, Serialize, schemars::JsonSchema)]
pub struct TriedTerm {
    /// What was tried.
    pub name: String,
    /// Leave-one-group-out RMSE with it added, °/s.
    pub rmse_dps: f64,
}

/// What the diagnosis of a table found and did.
#[derive(Debug, Clone, Serialize, schemars::JsonSchema)]
pub struct TableDiagnosis {
    /// Closed-form leave-one-group-out RMSE of the static GP on the training rows, °/s, at the
    /// hyperparameters the candidates were scored at: the best end of its search's starts
    /// ([`GpModel::fit_grouped_unpolished`]; a static model that ships is polished from there).
    pub static_rmse_dps: f64,
    /// At each step, the best candidate of each family (cause and form), best first.
    pub steps: Vec<Vec<TriedTerm>>,
    /// The candidates added, in order.
    pub chosen: Vec<Candidate>,
    /// Their ids (`none` when nothing was added), for scripts.
    pub causes: Vec<Cause>,
    /// Leave-one-group-out RMSE of the extended GP at its own hyperparameters, °/s.
    pub extended_rmse_dps: Option<f64>,
    /// Whether the extension ships.
    pub shipped: bool,
    /// One sentence: what was chosen and why.
    pub verdict: String,
}

/// One term of a fitted table model.
#[derive(Debug, Clone, Copy, Serialize, schemars::JsonSchema)]
pub struct FittedTerm {
    /// The candidate.
    pub candidate: Candidate,
    /// ω += coefficient × regressor (°/s per feature unit, or per feature unit and output unit).
    pub coefficient: f64,
    /// Range of the feature over the training rows.
    pub range: (f64, f64),
    /// Column in [`Transients`].
    #[serde(skip)]
    column: usize,
}

/// A table's GP with the transients its diagnosis chose.
#[derive(Debug, Clone)]
pub struct TableModel {
    /// The GP on (T, V), conditioned on the target less the terms.
    pub gp: GpModel,
    /// The terms added to its mean (empty: the static model).
    pub terms: Vec<FittedTerm>,
    /// How they were chosen.
    pub diagnosis: TableDiagnosis,
}

impl TableModel {
    /// What the blob adds to the GP: the terms, on the bias or the scale factor.
    pub fn extension(&self) -> Extension {
        Extension {
            temperature: None,
            terms: self
                .terms
                .iter()
                .map(|t| Term {
                    feature: t.candidate.feature,
                    coefficient: t.coefficient,
                    range: t.range,
                    on_scale_factor: t.candidate.acts_on == ActsOn::ScaleFactor,
                })
                .collect(),
            offset: 0.0,
        }
    }

    /// Prediction at row `i` of the table the transients were computed on.
    pub fn predict(&self, points: &Points, transients: &Transients, i: usize) -> f64 {
        let x: Vec<f64> = match points.scale_factor {
            None => vec![points.temp_c[i], points.voltage_v[i]],
            Some(_) => vec![points.temp_c[i]],
        };
        let bias_model = points.scale_factor.map_or(0.0, |k| points.voltage_v[i] / k);
        self.gp.predict_mean(&x)
            + bias_model
            + self
                .terms
                .iter()
                .map(|t| t.coefficient * transients.columns[(i, t.column)])
                .sum::<f64>()
    }

    /// Closed-form leave-one-out errors (prediction − target) over the training rows, with the
    /// hyperparameters and the chosen terms held (the terms' coefficients re-estimated).
    pub fn loo_errors(
        &self,
        points: &Points,
        transients: &Transients,
        rows: &[usize],
    ) -> Result<Vec<f64>, GpError> {
        let train = points.select(rows);
        let chosen: Vec<usize> = self.terms.iter().map(|t| t.column).collect();
        let singles: Vec<Vec<usize>> = (0..rows.len()).map(|i| vec![i]).collect();
        self.gp.group_loo_with(
            train.inputs(),
            &train.target(),
            &transients.design(rows, &chosen),
            &singles,
        )
    }
}

impl TableModel {
    /// The σ its blob would state, measured on the training `rows` (their groups left out, closed
    /// form with the hyperparameters and terms held; [`uncertainty`]). The left-out variance is
    /// the GP's at the row, noise included.
    pub fn calibration(
        &self,
        points: &Points,
        transients: &Transients,
        rows: &[usize],
    ) -> Result<Calibration, GpError> {
        let train = points.select(rows);
        let (source, groups) = uncertainty::tables::table_groups(&self.gp, &train);
        let chosen: Vec<usize> = self.terms.iter().map(|t| t.column).collect();
        let errors = self.gp.group_loo_with(
            train.inputs(),
            &train.target(),
            &transients.design(rows, &chosen),
            &groups,
        )?;
        let loo: Vec<(f64, f64)> = errors
            .into_iter()
            .zip(train.inputs().row_iter())
            .map(|(e, x)| {
                let p = self.gp.predict(&x.iter().copied().collect::<Vec<_>>());
                (e, p.latent_var + p.noise_var)
            })
            .collect();
        let series = uncertainty::tables::series_of(&train, source, &groups, &loo);
        Ok(uncertainty::terms::calibrate(
            &[series],
            uncertainty::tables::table_noise(&train, &self.gp),
            uncertainty::Prior::of(&self.gp, &train),
        ))
    }
}

/// Fits the static GP on `rows` of the table, diagnoses which transients it lacks from those rows
/// alone (module doc) and returns the model that ships: extended when the extension wins its
/// leave-one-group-out test, static otherwise. With `offsets`, every GP gives each group its own
/// offset ([`GpModel::fit_grouped`]).
pub fn fit(
    points: &Points,
    transients: &Transients,
    rows: &[usize],
    (cfg, offsets): (&GpConfig, bool),
) -> Result<TableModel, TableError> {
    let train = points.select(rows);
    let offsets = train.offset_groups(offsets);
    let groups: Vec<Vec<usize>> = train.groups().into_iter().map(|(_, m)| m).collect();
    if groups.len() < 3 {
        return Err(TableError::TooFewGroups(groups.len()));
    }
    let x = train.inputs();
    let target = train.target();
    let gp = GpModel::fit_grouped_unpolished(x, &target, &offsets, cfg)?;
    let kinv = gp.covariance_inverse();
    let score = |chosen: &[usize]| -> Result<f64, GpError> {
        let e = gp.group_loo_given(&kinv, x, &target, &transients.design(rows, chosen), &groups)?;
        Ok(rms(&e))
    };
    let static_rmse = score(&[])?;
    let (chosen, current, steps) = search(transients, &score, static_rmse);
    let names = |c: &[usize]| {
        c.iter()
            .map(|&j| transients.candidates[j].name())
            .collect::<Vec<_>>()
            .join(" + ")
    };
    let static_model = |verdict: String, extended_rmse_dps: Option<f64>, tried: Vec<usize>| {
        Ok::<_, TableError>(TableModel {
            gp: gp.clone().polished(x, &target, &offsets, cfg)?,
            terms: Vec::new(),
            diagnosis: TableDiagnosis {
                static_rmse_dps: static_rmse,
                steps: steps.clone(),
                chosen: tried.iter().map(|&j| transients.candidates[j]).collect(),
                causes: vec![Cause::None],
                extended_rmse_dps,
                shipped: false,
                verdict,
            },
        })
    };
    if chosen.is_empty() {
        return static_model(none_verdict(&steps, static_rmse), None, Vec::new());
    }
    let terms = transients.design(rows, &chosen);
    let (extended, gamma) = GpModel::fit_with_terms(x, &terms, &target, &offsets, cfg, &gp)?;
    let own = rms(&extended.group_loo_with(x, &target, &terms, &groups)?);
    if own >= static_rmse {
        return static_model(
            format!(
                "static: {} cut the leave-one-group-out error to {current:.3e} °/s at the static \
                 hyperparameters, but refitted with its own it made {own:.3e} against the static \
                 model's {static_rmse:.3e}",
                names(&chosen)
            ),
            Some(own),
            chosen,
        );
    }
    let fitted = fitted_terms(transients, rows, &chosen, &gamma);
    Ok(TableModel {
        gp: extended,
        terms: fitted,
        diagnosis: TableDiagnosis {
            static_rmse_dps: static_rmse,
            steps,
            causes: chosen
                .iter()
                .map(|&j| transients.candidates[j].cause)
                .collect(),
            chosen: chosen.iter().map(|&j| transients.candidates[j]).collect(),
            extended_rmse_dps: Some(own),
            shipped: true,
            verdict: format!(
                "extended with {}: leaving one group out of the training rows, {own:.3e} °/s \
                 against the static model's {static_rmse:.3e} ({:.2}×)",
                names(&chosen),
                static_rmse / own
            ),
        },
    })
}

/// Why no transient was taken: the best candidate's cut of the static model's
/// leave-one-group-out error, against the [`MIN_GAIN`] needed.
fn none_verdict(steps: &[Vec<TriedTerm>], static_rmse: f64) -> String {
    let best = steps.first().and_then(|s| s.first()).map_or(
        String::from("no candidate could be scored"),
        |t| {
            format!(
                "the best, {}, cut it by {:.0}% (at least {:.0}% needed)",
                t.name,
                100.0 * (1.0 - t.rmse_dps / static_rmse),
                100.0 * MIN_GAIN
            )
        },
    );
    format!(
        "none: leaving one group out, the static model's error is {static_rmse:.3e} °/s; {best}"
    )
}

/// The `chosen` columns of the transients with their fitted coefficients `gamma`, each with the
/// range its feature spans over the training `rows`.
fn fitted_terms(
    transients: &Transients,
    rows: &[usize],
    chosen: &[usize],
    gamma: &[f64],
) -> Vec<FittedTerm> {
    chosen
        .iter()
        .zip(gamma)
        .map(|(&j, &coefficient)| {
            let f = rows.iter().map(|&i| transients.features[(i, j)]);
            let range = f.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), v| {
                (lo.min(v), hi.max(v))
            });
            FittedTerm {
                candidate: transients.candidates[j],
                coefficient,
                range,
                column: j,
            }
        })
        .collect()
}

/// The terms, one family at a time: each round scores every candidate of a family not yet taken
/// with those taken (`score`: the leave-one-group-out error), keeps the best while it cuts the
/// error by [`MIN_GAIN`], up to [`MAX_TERMS`]. The terms taken, the error with them, and each
/// round's best per family.
fn search(
    transients: &Transients,
    score: &dyn Fn(&[usize]) -> Result<f64, GpError>,
    static_rmse: f64,
) -> (Vec<usize>, f64, Vec<Vec<TriedTerm>>) {
    let mut chosen: Vec<usize> = Vec::new();
    let mut current = static_rmse;
    let mut steps = Vec::new();
    while chosen.len() < MAX_TERMS {
        let mut tried: Vec<(usize, f64)> = Vec::new();
        for (j, c) in transients.candidates.iter().enumerate() {
            if chosen
                .iter()
                .any(|&k| transients.candidates[k].same_family(c))
            {
                continue;
            }
            let mut with = chosen.clone();
            with.push(j);
            // A degenerate design (a constant column on these rows) is not a candidate.
            if let Ok(r) = score(&with) {
                tried.push((j, r));
            }
        }
        tried.sort_by(|a, b| a.1.total_cmp(&b.1));
        let mut best_per_family: Vec<(usize, f64)> = Vec::new();
        for &(j, r) in &tried {
            let c = &transients.candidates[j];
            if !best_per_family
                .iter()
                .any(|&(k, _)| transients.candidates[k].same_family(c))
            {
                best_per_family.push((j, r));
            }
        }
        steps.push(
            best_per_family
                .iter()
                .map(|&(j, r)| TriedTerm {
                    name: transients.candidates[j].name(),
                    rmse_dps: r,
                })
                .collect(),
        );
        match tried.first() {
            Some(&(j, r)) if r < current * (1.0 - MIN_GAIN) => {
                chosen.push(j);
                current = r;
            }
            _ => break,
        }
    }
    (chosen, current, steps)
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;
    use rand_distr::{Distribution, Normal};

    /// A turntable run: half-sweeps of 13 rates, 20 s per row, the temperature swinging ±3 °C
    /// with a rising trend; the coil follows the sensor with a 120 s lag, and the scale factor
    /// and bias follow the coil. `lag_s` 0: no transient.
    fn turntable(lag_s: f64, seed: u64) -> Points {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let noise = Normal::new(0.0, 2e-4).unwrap();
        let mut p = Points::new(
            Vec::new(),
            Vec::new(),
            Vec::new(),
            Vec::new(),
            None,
            false,
            Some(Vec::new()),
        );
        let (mut coil, mut t) = (40.0f64, 0.0f64);
        for sweep in 0..12 {
            for k in 0..13 {
                let w = if sweep % 2 == 0 { 10.0 } else { -10.0 } * k as f64;
                let temp = 40.0 + 3.0 * (t / 900.0).sin() + t / 3000.0;
                coil += if lag_s > 0.0 {
                    (1.0 - (-20.0 / lag_s).exp()) * (temp - coil)
                } else {
                    temp - coil
                };
                let s = 0.05 * (1.0 - 5e-3 * (coil - 40.0));
                let v = s * w + 1e-3 * (coil - 40.0) + noise.sample(&mut rng);
                p.temp_c.push(temp);
                p.voltage_v.push(v);
                p.rate_dps.push(w);
                p.group.push(sweep.to_string());
                p.run.push(0);
                if let Some(ts) = p.time_s.as_mut() {
                    ts.push(t);
                }
                t += 20.0;
            }
        }
        p
    }

    #[test]
    fn a_coil_lag_on_the_scale_factor_is_found_and_cuts_the_held_out_error() {
        let p = turntable(120.0, 1);
        let tr = Transients::compute(&p).unwrap();
        let all: Vec<usize> = (0..p.len()).collect();
        let m = fit(&p, &tr, &all, (&GpConfig::default(), false)).unwrap();
        let d = &m.diagnosis;
        assert!(d.shipped, "{}", d.verdict);
        assert_eq!(
            m.terms[0].candidate.acts_on,
            ActsOn::ScaleFactor,
            "{}",
            d.verdict
        );
        assert_eq!(m.terms[0].candidate.cause, Cause::ThermalRate);
        let own = d.extended_rmse_dps.unwrap();
        assert!(own < 0.5 * d.static_rmse_dps, "{}", d.verdict);
        // Held out: a later run of the same gyro, the model fitted on the first.
        let later = turntable(120.0, 2);
        let tl = Transients::compute(&later).unwrap();
        let e = |model: &TableModel| {
            rms(&(0..later.len())
                .map(|i| model.predict(&later, &tl, i) - later.rate_dps[i])
                .collect::<Vec<_>>())
        };
        let static_model = TableModel {
            terms: Vec::new(),
            gp: GpModel::fit(p.inputs(), &p.target(), &GpConfig::default()).unwrap(),
            diagnosis: d.clone(),
        };
        assert!(
            e(&m) < 0.5 * e(&static_model),
            "{} vs {}",
            e(&m),
            e(&static_model)
        );

        // The firmware computes the transient from its own filter over the rows in time order
        // and follows the host.
        let blob = crate::firmware::export::points_blob(&m.gp, &p, &m.extension()).unwrap();
        crate::firmware::export::verify(&m.gp, &blob, &p, &m.extension()).unwrap();
        let fw = fog_data::replay::decode(&blob).unwrap();
        let mut state = FeatureState::default();
        let mut scratch = vec![0.0f32; fw.dims().m];
        let time_s = p.time_s.clone().unwrap();
        let worst = (0..p.len())
            .map(|i| {
                let sample = Sample {
                    time_s: time_s[i],
                    temp_c: p.temp_c[i] as f32,
                    output: p.voltage_v[i] as f32,
                };
                let out = fw.compensate(&sample, &mut state, &mut scratch).unwrap();
                (f64::from(out.mean) - m.predict(&p, &tr, i)).abs()
            })
            .fold(0.0, f64::max);
        assert!(worst < 1e-4, "firmware differs by {worst} °/s");
    }

    #[test]
    fn a_table_without_a_transient_keeps_its_static_model() {
        let p = turntable(0.0, 3);
        let tr = Transients::compute(&p).unwrap();
        let all: Vec<usize> = (0..p.len()).collect();
        let m = fit(&p, &tr, &all, (&GpConfig::default(), false)).unwrap();
        assert!(m.terms.is_empty(), "{}", m.diagnosis.verdict);
        assert_eq!(m.diagnosis.causes, [Cause::None]);
    }

    #[test]
    fn an_untimed_table_is_refused_with_the_option_to_give() {
        let mut p = turntable(0.0, 4);
        p.time_s = None;
        let e = Transients::compute(&p).unwrap_err().to_string();
        assert!(e.contains("--map time_s="), "{e}");
    }
}
