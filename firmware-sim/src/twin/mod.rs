//! A twin of a real gyro: the simulator's parameters identified from measured data, what the
//! simulation still gets wrong, and the hidden effects that close the gap.
//!
//! The twin is the simulator's own output map ([`crate::gyro::plant`]) with the parameters that
//! reproduce the measurements, written as a unit file that `generate paper|stream --unit FILE`
//! simulates. Identification is a weighted nonlinear least-squares fit (Levenberg–Marquardt) of
//! the measured output against the map at the measured temperature and reference rate, over the
//! parameters the data can determine; the others keep their nominal values, each with the reason
//! (a static log shows no scale factor, a table without fast rates no sine compression, …).
//!
//! What the twin gets wrong is the measured output minus the twin's, replayed over the measured
//! protocol. The simulator's hidden effects ([`crate::gyro::effects`]) are the candidate causes:
//! each is added to the twin with its strength fitted (a lag by a search over its time constant,
//! the biases as linear terms of the same fit), scored by a forward test inside the training data
//! (rolling origin: fitted on its first two, three and four fifths, scored on the fifth after
//! each), and chosen by the rule the diagnosis uses ([`fog_data::selection`]: the best
//! design of one, two, then three effects, while it removes enough of what the design before it
//! left). The data's last third in time is held out from all of this and scored once,
//! before and after: the twin's fidelity. With a rate table and a stream, the map comes from the
//! table (soaked points are its own data) and the stream adds the effects and its own bias offset
//! (a run's turn-on bias), so that no effect has to stand in for that offset.
//!
//! Fidelity is the RMS of the rate-equivalent difference, (measured − twin) / S(T), in °/h: per
//! point for a rate table, over 60 s block means for a stream (as the replay scores), where the
//! white noise would otherwise hide everything else.
//!
//! Here: the search and the report; the data it reads in `source`, the static parameters by name
//! and what the data determine of them in `params`, the least-squares fit in `fit`.

use serde::Serialize;

use crate::gyro::effects::Effect;
use crate::gyro::plant::GyroParams;
use crate::gyro::unit::Unit;
use firmware_core::units::SECONDS_PER_HOUR;
use fog_data::cause::Cause;
use fog_data::stats::Line;

use fog_data::allan;
use fog_data::minimize::golden_section;
use fog_data::selection;

mod error;
mod fit;
mod noise;
mod params;
mod source;

pub use error::IdentifyError;
use fit::{Free, LINEAR, OFFSET, Row, TwinFit, fidelity, fit, residual_dph, rows};
use fog_data::blocks;
use noise::{noise_parameters, noise_terms, other_parameters};
pub use params::Parameter;
use params::{Static, determinable};
pub use source::{Measured, Record, SourceKind, load_points};

/// Parts of the training data for the rolling-origin forward test.
const FOLDS: usize = 5;
/// Sensor-lag time constants tried, min.
const LAG_GRID_MIN: [f64; 12] = [
    0.25, 0.5, 0.75, 1.0, 1.5, 2.0, 3.0, 5.0, 8.0, 12.0, 20.0, 30.0,
];

/// A design of candidate effects, tried on the forward test inside the training data.
#[derive(Debug, Clone, PartialEq, Serialize, schemars::JsonSchema)]
pub struct TriedDesign {
    /// Its causes.
    pub causes: Vec<Cause>,
    /// Fitted strength of each (the effect's unit, `generate --strength`).
    pub strengths: Vec<f64>,
    /// Forward score with them, °/h (the training data's last third).
    pub forward_dph: f64,
    /// Forward score of the design taken before (none: the static twin), °/h.
    pub baseline_dph: f64,
    /// Kept in the twin.
    pub kept: bool,
}

/// What `identify --json` writes.
#[derive(Debug, Clone, PartialEq, Serialize, schemars::JsonSchema)]
pub struct Identification {
    /// The twin (fitted on all the data, with the effects the training data chose).
    pub unit: Unit,
    /// Every parameter: value, uncertainty, determined or why not.
    pub parameters: Vec<Parameter>,
    /// The noise terms read from the stream's residual Allan deviation.
    pub noise: Option<allan::Terms>,
    /// The data whose last third is held out.
    pub held_out: SourceKind,
    /// Measurements fitted on / held out.
    pub n_train: usize,
    /// Held out.
    pub n_held_out: usize,
    /// The twin without effects, held out, °/h.
    pub fidelity_before_dph: f64,
    /// With the effects kept, held out, °/h.
    pub fidelity_after_dph: f64,
    /// Effects kept, in the candidates' order (`none` when none helped).
    pub causes: Vec<Cause>,
    /// Every candidate tried.
    pub candidates: Vec<TriedDesign>,
    /// The held-out residual before and after, for the figure: (time or index, °/h, °/h).
    #[serde(skip)]
    pub residual: Vec<(f64, f64, f64)>,
    /// Where the held-out part starts on that axis.
    #[serde(skip)]
    pub split_at: f64,
}

/// A design tried: its causes, forward score and strengths, and the twin's lag and linear
/// effects with it.
struct Tried {
    causes: Vec<Cause>,
    score: f64,
    strengths: Vec<f64>,
    lag: Option<f64>,
    linear: Vec<usize>,
}

/// Identifies a twin from `points` and/or `stream`; `scale_factor` (output units per °/s) stands
/// in for a scale factor the data cannot show (a static log). `progress` is told each step.
pub fn identify(
    points: Option<&Measured>,
    stream: Option<&Measured>,
    scale_factor: Option<f64>,
    mut progress: impl FnMut(&str),
) -> Result<Identification, IdentifyError> {
    let twin = Twin::new(points, stream, scale_factor)?;
    let (primary, n, train_end) = (&*twin.primary, twin.n, twin.train_end);
    progress("the static twin");
    let found = if primary.timed() {
        twin.search(&mut progress)?
    } else {
        // Effects act along time: a source without it (soaked table points) keeps its readings.
        Found {
            baseline: twin.forward(None, &[])?.0,
            ..Found::default()
        }
    };
    let (lag, linear) = (found.lag, &found.linear);

    // Held out, once: the twin fitted on all the training data, without and with the effects.
    progress("the held-out test");
    let (before_e, before) = twin.held(None, &[])?;
    let (after_e, after) = twin.held(lag, linear)?;
    let axis = |i: usize| primary.records[i].time_s.unwrap_or(i as f64);
    let residual = (train_end..n)
        .zip(before_e.iter().zip(&after_e))
        .map(|(i, (b, a))| (axis(i), *b, *a))
        .collect();

    // The unit: refitted on all the data with the effects chosen, noise from the stream.
    progress("the unit, on all the data");
    let f = twin.fit_on(&rows(primary, lag, linear), linear)?;
    let mut params = f.params.clone();
    let mut parameters = twin.static_parameters(&f);
    let static_log = stream.filter(|s| {
        let first = s.records.first().map_or(0.0, |r| r.rate_dps);
        s.records.iter().all(|r| (r.rate_dps - first).abs() < 0.1)
    });
    let noise = static_log.map(|s| {
        let rows = rows(s, lag, linear);
        let e: Vec<f64> = residual_dph(&f, &rows)
            .iter()
            .map(|v| v / SECONDS_PER_HOUR)
            .collect();
        noise_terms(s, &e)
    });
    parameters.extend(noise_parameters(noise, stream.is_some(), &mut params));
    parameters.extend(other_parameters(points, stream, &mut params));
    let mut effects: Vec<Effect> = lag
        .map(|tau_min| Effect::SensorLag { tau_min })
        .into_iter()
        .collect();
    effects.extend(
        linear
            .iter()
            .map(|&l| linear_effect(LINEAR[l], f.strengths[l])),
    );
    Ok(Identification {
        unit: Unit { params, effects },
        parameters,
        noise,
        held_out: primary.kind,
        n_train: train_end + twin.other.map_or(0, |s| s.records.len()),
        n_held_out: n - train_end,
        fidelity_before_dph: before,
        fidelity_after_dph: after,
        causes: if found.causes.is_empty() {
            vec![Cause::None]
        } else {
            found.causes.iter().map(|(c, _)| *c).collect()
        },
        candidates: found.candidates,
        residual,
        split_at: axis(train_end.min(n - 1)),
    })
}

/// The effect of a linear cause at strength `s`.
fn linear_effect(cause: Cause, s: f64) -> Effect {
    match cause {
        Cause::ThermalRate => Effect::ThermalRate {
            k_dph_per_c_per_min: s,
        },
        Cause::WarmUp => Effect::WarmUp {
            amplitude_dph: s,
            tau_min: 15.0,
        },
        Cause::Hysteresis => Effect::Hysteresis { offset_dph: s },
        _ => Effect::TimeDrift { dph_per_h: s },
    }
}

/// What the search for effects kept: the forward score with them, the lag and the linear effects,
/// the causes with their strengths, and every candidate tried.
#[derive(Default)]
struct Found {
    baseline: f64,
    lag: Option<f64>,
    linear: Vec<usize>,
    causes: Vec<(Cause, f64)>,
    candidates: Vec<TriedDesign>,
}

/// Identification's data and fits: the source whose last third is held out (`primary`), the rate
/// table the map comes from where there is one (`other`), and the starting map with the static
/// parameters the data determine.
struct Twin<'a> {
    primary: std::borrow::Cow<'a, Measured>,
    other: Option<&'a Measured>,
    n: usize,
    train_end: usize,
    start: GyroParams,
    free_statics: Vec<Static>,
    fixed: Vec<(Static, String)>,
    /// The map fitted on the rate table, held while the effects are fitted on the stream.
    table_fit: Option<TwinFit>,
}

impl<'a> Twin<'a> {
    /// The split and the starting map. Untimed table points hold out every third point (their
    /// file order is the protocol's, not time); anything with a clock holds out its last third.
    fn new(
        points: Option<&'a Measured>,
        stream: Option<&'a Measured>,
        scale_factor: Option<f64>,
    ) -> Result<Self, IdentifyError> {
        use std::borrow::Cow;
        let (primary, other) = match (stream, points) {
            (Some(s), other) => (Cow::Borrowed(s), other),
            (None, Some(p)) if !p.timed() => {
                let (train, test): (Vec<usize>, Vec<usize>) =
                    (0..p.records.len()).partition(|i| i % 3 != 2);
                let interleaved = Measured {
                    kind: p.kind,
                    records: train.iter().chain(&test).map(|&i| p.records[i]).collect(),
                    setpoint_c: None,
                };
                (Cow::Owned(interleaved), None)
            }
            (None, Some(p)) => (Cow::Borrowed(p), None),
            (None, None) => return Err(IdentifyError::NoData),
        };
        let n = primary.records.len();
        if n < 12 {
            return Err(IdentifyError::TooFew(n));
        }
        let train_end = (n as f64 * 2.0 / 3.0).round() as usize;
        // The static map comes from the rate table where there is one (soaked points are the
        // map's own data), else from the training part of the one source.
        let map_records: Vec<&Record> = match other {
            Some(o) => o.records.iter().collect(),
            None => primary.records[..train_end].iter().collect(),
        };
        let (free_statics, fixed) = determinable(&map_records);
        let start = starting_map(&map_records, &free_statics, scale_factor)?;
        let table_fit = match other {
            Some(o) => {
                let free = Free {
                    statics: free_statics.clone(),
                    linear: Vec::new(),
                };
                Some(fit(&start, &free, &rows(o, None, &[]))?)
            }
            None => None,
        };
        Ok(Self {
            primary,
            other,
            n,
            train_end,
            start,
            free_statics,
            fixed,
            table_fit,
        })
    }

    /// A fit of the twin on `train` (rows of the primary source) with the linear effects
    /// `linear`: with a table, the map fitted on it is held and only the effects' strengths (and
    /// the stream's own bias offset) are fitted on the stream; without, everything on `train`.
    fn fit_on(&self, train: &[Row], linear: &[usize]) -> Result<TwinFit, IdentifyError> {
        match &self.table_fit {
            Some(t) => {
                let free = Free {
                    statics: Vec::new(),
                    linear: linear.iter().copied().chain([OFFSET]).collect(),
                };
                let f = fit(&t.params, &free, train)?;
                Ok(TwinFit {
                    std_errors: t.std_errors.clone(),
                    ..f
                })
            }
            None => {
                let free = Free {
                    statics: self.free_statics.clone(),
                    linear: linear.to_vec(),
                };
                fit(&self.start, &free, train)
            }
        }
    }

    /// The forward test inside the training data, rolling origin: fit on its first two, three,
    /// four fifths, score the fifth after each; the score is their RMS, with the last fit.
    fn forward(&self, lag: Option<f64>, linear: &[usize]) -> Result<(f64, TwinFit), IdentifyError> {
        let primary = &*self.primary;
        let rows = rows(primary, lag, linear);
        let fifth = self.train_end / FOLDS;
        let mut squares = 0.0;
        let mut last = None;
        for k in 2..FOLDS {
            let a = k * fifth;
            let b = if k + 1 == FOLDS {
                self.train_end
            } else {
                (k + 1) * fifth
            };
            let f = self.fit_on(&rows[..a], linear)?;
            let e = residual_dph(&f, &rows[a..b]);
            let score = fidelity(primary.kind, &primary.records[a..b], &e);
            squares += score * score;
            last = Some(f);
        }
        let f = last.ok_or(IdentifyError::TooFew(self.n))?;
        Ok(((squares / (FOLDS - 2) as f64).sqrt(), f))
    }

    /// The held-out residual (°/h) and fidelity of the twin fitted on all the training data.
    fn held(&self, lag: Option<f64>, linear: &[usize]) -> Result<(Vec<f64>, f64), IdentifyError> {
        let primary = &*self.primary;
        let rows = rows(primary, lag, linear);
        let f = self.fit_on(&rows[..self.train_end], linear)?;
        let e = residual_dph(&f, &rows[self.train_end..]);
        let score = fidelity(primary.kind, &primary.records[self.train_end..], &e);
        Ok((e, score))
    }

    /// The effects, by the project's rule for causes ([`selection`]): for one, two, then three
    /// effects, every design of the candidates is fitted and scored on the forward test, and the
    /// best kept when it removes [`selection::ONE_TEST`]'s share of the forward sum of squares the
    /// design before it left.
    fn search(&self, progress: &mut impl FnMut(&str)) -> Result<Found, IdentifyError> {
        let all: Vec<Cause> = [Cause::SensorLag].into_iter().chain(LINEAR).collect();
        let mut found = Found {
            baseline: self.forward(None, &[])?.0,
            ..Found::default()
        };
        for size in selection::sizes(all.len()) {
            let mut best: Option<Tried> = None;
            for design in selection::designs(all.len(), size) {
                let causes: Vec<Cause> = design.iter().map(|&i| all[i]).collect();
                progress(
                    &causes
                        .iter()
                        .map(|c| c.id())
                        .collect::<Vec<_>>()
                        .join(" + "),
                );
                let tried = self.try_design(&causes)?;
                found.candidates.push(TriedDesign {
                    causes,
                    strengths: tried.strengths.clone(),
                    forward_dph: tried.score,
                    baseline_dph: found.baseline,
                    kept: false,
                });
                if best.as_ref().is_none_or(|b| tried.score < b.score) {
                    best = Some(tried);
                }
            }
            let gain = |t: &Tried| selection::share(t.score.powi(2), found.baseline.powi(2));
            match best {
                Some(t) if gain(&t) >= selection::ONE_TEST.least(size) => {
                    if let Some(c) = found
                        .candidates
                        .iter_mut()
                        .rev()
                        .find(|c| c.causes == t.causes)
                    {
                        c.kept = true;
                    }
                    found.causes = t.causes.iter().copied().zip(t.strengths).collect();
                    found.baseline = t.score;
                    found.lag = t.lag;
                    found.linear = t.linear;
                }
                _ => break,
            }
        }
        Ok(found)
    }

    /// The design `causes` added to the twin, their strengths fitted: a lag by its grid, refined
    /// between the grid's neighbours in log τ, with the linear effects fitted at each τ; the
    /// linear effects as terms of the fit.
    fn try_design(&self, causes: &[Cause]) -> Result<Tried, IdentifyError> {
        let linear: Vec<usize> = causes
            .iter()
            .filter_map(|c| LINEAR.iter().position(|l| l == c))
            .collect();
        let lag = if causes.contains(&Cause::SensorLag) {
            Some(self.best_lag(&linear)?)
        } else {
            None
        };
        let (score, f) = self.forward(lag, &linear)?;
        let strengths = causes
            .iter()
            .map(|c| match LINEAR.iter().position(|l| l == c) {
                Some(l) => f.strengths[l],
                None => lag.unwrap_or(0.0),
            })
            .collect();
        Ok(Tried {
            causes: causes.to_vec(),
            score,
            strengths,
            lag,
            linear,
        })
    }

    /// The sensor lag, min, whose twin (with the linear effects `linear`) scores best forward:
    /// the best of the grid, refined between its neighbours in log τ.
    fn best_lag(&self, linear: &[usize]) -> Result<f64, IdentifyError> {
        let mut top: Option<(f64, f64)> = None;
        for tau in LAG_GRID_MIN {
            let (s, _) = self.forward(Some(tau), linear)?;
            if top.is_none_or(|(b, _)| s < b) {
                top = Some((s, tau));
            }
        }
        let (score, tau) = top.unwrap_or((f64::INFINITY, 1.0));
        let at = LAG_GRID_MIN.iter().position(|&g| g == tau).unwrap_or(0);
        let lo = LAG_GRID_MIN[at.saturating_sub(1)].ln();
        let hi = LAG_GRID_MIN[(at + 1).min(LAG_GRID_MIN.len() - 1)].ln();
        let at_log = |log_tau: f64| self.forward(Some(log_tau.exp()), linear).map(|f| f.0);
        Ok(
            match golden_section(at_log, (lo, hi), tau.ln(), 1e-3, 20)? {
                Some((log_tau, s)) if s < score => log_tau.exp(),
                _ => tau,
            },
        )
    }

    /// Every static parameter of a fit `f`: its value, and its uncertainty where fitted or why
    /// it is nominal.
    fn static_parameters(&self, f: &TwinFit) -> Vec<Parameter> {
        Static::ALL
            .into_iter()
            .map(|j| {
                let (determined, std_error, why) =
                    match self.free_statics.iter().position(|&k| k == j) {
                        Some(k) => {
                            let se = f.std_errors.get(k).copied();
                            let why = if se.is_some_and(|e| e > j.get(&f.params).abs()) {
                                "fitted, but its uncertainty exceeds its value: the data barely \
                                 tell it from the parameters it trades with (an offset and the \
                                 bias, at zero rate)"
                            } else {
                                "fitted"
                            };
                            (true, se, why.to_owned())
                        }
                        None => (
                            false,
                            None,
                            self.fixed
                                .iter()
                                .find(|(k, _)| *k == j)
                                .map_or_else(String::new, |(_, w)| w.clone()),
                        ),
                    };
                Parameter {
                    name: j.name().to_owned(),
                    value: j.get(&f.params),
                    std_error,
                    determined,
                    why,
                }
            })
            .collect()
    }
}

/// The map identification starts from: the scale factor and a first bias from a straight line
/// through the small rates (or the scale factor given, and the mean output less it, for data
/// that show none), the temperature coefficients the data determine at zero.
fn starting_map(
    records: &[&Record],
    free: &[Static],
    scale_factor: Option<f64>,
) -> Result<GyroParams, IdentifyError> {
    let mut start = GyroParams::nominal();
    start.bias_poly_dph = [0.0; 4];
    start.output_offset_v = 0.0;
    let rated: Vec<&&Record> = records.iter().filter(|r| r.rate_dps.abs() > 0.5).collect();
    let max_rate = rated.iter().map(|r| r.rate_dps.abs()).fold(0.0, f64::max);
    let small: Vec<&&&Record> = rated
        .iter()
        .filter(|r| r.rate_dps.abs() <= 0.3 * max_rate.max(1.0) + 1.0)
        .collect();
    let (s0, c0) = if free.contains(&Static::ScaleFactor) {
        let l = Line::fit(small.iter().map(|r| (r.rate_dps, r.output)));
        let mean_output = small.iter().map(|r| r.output).sum::<f64>() / small.len() as f64;
        l.map_or((1.0, mean_output), |l| (l.slope, l.intercept))
    } else {
        let k = scale_factor.ok_or(IdentifyError::NoScaleFactor)?;
        let mean = records
            .iter()
            .map(|r| r.output - k * r.rate_dps)
            .sum::<f64>()
            / records.len() as f64;
        (k, mean)
    };
    start.scale_factor_v_per_dps = s0;
    start.bias_poly_dph[0] = c0 / s0 * SECONDS_PER_HOUR;
    for j in [Static::SfTc, Static::SfTc2] {
        if free.contains(&j) {
            j.set(&mut start, 0.0);
        }
    }
    Ok(start)
}

/// A stream's held-out residual as one-minute means, time in hours from its start: what the
/// figure draws (single samples are the white noise).
pub fn minute_means(residual: &[(f64, f64, f64)]) -> Vec<(f64, f64, f64)> {
    let column = |k: usize| -> Vec<f64> { residual.iter().map(|r| [r.0, r.1, r.2][k]).collect() };
    let (time, before, after) = (column(0), column(1), column(2));
    let groups = blocks::group(&time, &(0..time.len()).collect::<Vec<_>>());
    let t0 = time.first().copied().unwrap_or(0.0);
    blocks::means(&time, &groups)
        .into_iter()
        .zip(blocks::means(&before, &groups))
        .zip(blocks::means(&after, &groups))
        .map(|((t, b), a)| ((t - t0) / SECONDS_PER_HOUR, b, a))
        .collect()
}

/// The identification as text: every parameter, the effects and the fidelity.
pub fn summary(id: &Identification) -> String {
    let mut s = String::from("parameter                      value          ± 1σ       source\n");
    for p in &id.parameters {
        s.push_str(&format!(
            "{:<28} {:>14.6e} {:>12} {}\n",
            p.name,
            p.value,
            p.std_error
                .map_or_else(|| "—".to_owned(), |e| format!("{e:.2e}")),
            if p.determined {
                p.why.clone()
            } else {
                format!("not determined: {}", p.why)
            }
        ));
    }
    for c in &id.candidates {
        let design: Vec<String> = c
            .causes
            .iter()
            .zip(&c.strengths)
            .map(|(cause, k)| format!("{} {k:.4}", cause.id()))
            .collect();
        s.push_str(&format!(
            "{:<52} forward {:>9.3} °/h (before {:>9.3}){}\n",
            design.join(" + "),
            c.forward_dph,
            c.baseline_dph,
            if c.kept { "  kept" } else { "" }
        ));
    }
    let held = match id.held_out {
        SourceKind::Stream => "the stream's last third in time, 60 s means",
        SourceKind::Points => {
            "the table's last third (in time where it has one, else every third point)"
        }
    };
    s.push_str(&format!(
        "effects: {}; held out ({held}, {} of {} measurements): {:.3} °/h static → {:.3} °/h with them",
        id.causes.iter().map(|c| c.id()).collect::<Vec<_>>().join(" + "),
        id.n_held_out,
        id.n_held_out + id.n_train,
        id.fidelity_before_dph,
        id.fidelity_after_dph
    ));
    s
}
