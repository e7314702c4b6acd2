//! The investigation in one call: static fit → diagnosis of the training stream → extension,
//! shipped only when it wins a forward test inside the training stream (and, where the static
//! curve is fitted on that stream, a test beyond the temperatures it was fitted on) → replay of
//! the static and the shipped model on the held-out stream → the gain.
//!
//! The held-out stream is touched once, to score: which causes to name and whether to ship their
//! extension are part of the model, so they come from the training data alone ([`choose`]).

use crate::progress::Progress;
use fog_data::blocks;
use fog_data::cause::Cause;
use fog_data::replay::{self, HostModel, Score};
use fog_data::stats::rms;
use fog_data::stream::{Handled, Stream, Window};
use serde::Serialize;

use crate::analysis::beyond::{self, BeyondChoice};
use crate::analysis::diagnose::{self, Diagnosis, joined};
use crate::analysis::extend::{self, Extended, Fitted};
use crate::analysis::uncertainty::{self, Calibration, SampleNoise, Source};
use crate::data::points::Points;
use crate::firmware::export::{self, Extension};
use crate::models::gp::{GpConfig, GpModel};

mod check;

use check::forward_check;
pub use check::{ForwardCheck, LegCheck, Sight, TemperatureCheck, splits, vote};

/// Makes the static points from part of a training stream as from all of it (a table's: as is).
pub type Rebuild<'a> = dyn Fn(&Stream) -> anyhow::Result<Points> + 'a;

/// Steps of an investigation: static fit, diagnosis, forward check, extended fit, replays.
pub const STEPS: u64 = 5;

/// Fewest 60 s blocks the earlier part of a forward check holds (an extension needs 30).
const EARLIER_MIN_BLOCKS: usize = 30;
/// Fewest 60 s blocks the later part of a forward check holds.
const LATER_MIN_BLOCKS: usize = 8;
/// Share of the training stream's blocks the earlier part holds, when it is long enough.
const EARLIER_SHARE: f64 = 2.0 / 3.0;
/// Share of the training stream's temperature span left out at each end by the temperature check
/// ([`TemperatureCheck`]): a fifth of the span in all, as a wider cut leaves a 40-minute log fewer
/// than the 30 blocks an extension needs inside.
const OUTER_SHARE: f64 = 0.1;
/// Fewest 60 s blocks of one heating/cooling leg a leg check fits on ([`LegCheck`]): a quarter
/// hour of the leg.
const LEG_MIN_BLOCKS: usize = 15;

/// The result (docs/design.md §6 names where they exist).
#[derive(Debug, Clone, Serialize)]
pub struct Investigation {
    /// The static model on the held-out stream.
    pub static_score: Score,
    /// Diagnosis of the static model on the training stream.
    pub diagnosis: Diagnosis,
    /// The extension's forward test inside the training stream (absent when nothing was named).
    pub forward_check: Option<ForwardCheck>,
    /// Which model was shipped: `extended` or `static`.
    pub shipped: Shipped,
    /// Why, in words.
    pub verdict: String,
    /// Inputs the shipped model adds (`--features` names).
    pub added_inputs: Vec<&'static str>,
    /// The extension fitted on the training stream (absent when the static model is shipped).
    pub extension: Option<Fitted>,
    /// The shipped model on the held-out stream.
    pub extended_score: Score,
    /// Static over shipped `rmse_60s_dps` on the held-out stream.
    pub gain: f64,
    /// What the static fit warned of ([`GpModel::warnings`]) and what the choice warned of.
    pub warnings: Vec<String>,
    /// Windows of the training stream where the unit was handled, left out (the held-out
    /// stream's are in its scores).
    pub train_handled: Vec<Handled>,
    /// The shipped model's σ, measured on the training data alone.
    pub calibration: Calibration,
    /// The static model's σ, the same way.
    pub static_calibration: Calibration,
    /// What both models' means do beyond the trained range, chosen on the training points.
    pub beyond: BeyondChoice,
}

impl Investigation {
    /// The first named cause.
    pub fn cause(&self) -> Cause {
        self.diagnosis.cause
    }
}

/// Which model an extension step ships.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum Shipped {
    /// The static model with the extension.
    Extended,
    /// The static model alone.
    Static,
}

/// The models an investigation produced.
pub struct Blobs {
    /// The static model.
    pub static_blob: Vec<u8>,
    /// The shipped model (the static one when nothing was added).
    pub extended_blob: Vec<u8>,
}

/// What a training stream supports: the causes, their forward check, and the model to ship.
pub struct Choice {
    /// The diagnosis of the static model on the training stream.
    pub diagnosis: Diagnosis,
    /// The causes whose inputs were fitted (asked for, or named).
    pub causes: Vec<Cause>,
    /// The forward check (absent when no cause was named or asked for, or the stream is too short).
    pub check: Option<ForwardCheck>,
    /// Which model to ship.
    pub shipped: Shipped,
    /// The extension fitted on the whole training stream (absent when nothing was named, or it
    /// could not be fitted and nothing was asked for).
    pub extended: Option<Extended>,
    /// Why the shipped model is the one it is, in words.
    pub verdict: String,
    /// The models fitted on part of the training stream, scored on the rest: the evidence of the
    /// forward check and of the σ's calibration.
    pub splits: Vec<Split>,
}

/// A model fitted on part of the training stream and the rest it is scored on.
pub struct Split {
    /// The test: forward in time, or across temperature.
    pub source: Source,
    /// The training stream with its reference only where scored (replayed whole, so the stateful
    /// inputs keep their history).
    pub scored: Stream,
    /// Hours from each sample to the data fitted (NaN where fitted).
    pub hours: Vec<f64>,
    /// The static model fitted without the scored part (a rate table's, where there is one).
    pub static_blob: Vec<u8>,
    /// The extension of the named causes fitted without it, where causes were named.
    pub extended_blob: Option<Vec<u8>>,
    /// For a leg split ([`Source::Leg`]): the leg fitted on, and the 60 s blocks fitted on and
    /// scored.
    pub leg: Option<(&'static str, usize, usize)>,
}

impl Split {
    /// `rmse_60s_dps` of the static model and of the extension (the static one's where none),
    /// and whether the scored part exercised the extension: its contribution (extended − static,
    /// 60 s means over the whole stream) moves in the scored blocks ([`diagnose::sees`]).
    fn scores(&self) -> anyhow::Result<(f64, f64, Sight)> {
        // The means alone: nothing here reads a variance, which costs O(m²) a sample.
        let run = |blob: &[u8]| -> anyhow::Result<replay::Means> {
            Ok(replay::means(
                &*fog_data::replay::decode(blob)?,
                &self.scored,
            ))
        };
        let rmse = |c: &replay::Means| c.rmse_60s_dps(&self.scored);
        let static_run = run(&self.static_blob)?;
        let ext_run = match &self.extended_blob {
            Some(b) => run(b)?,
            None => static_run.clone(),
        };
        let all: Vec<usize> = (0..self.scored.len()).collect();
        let blocks = blocks::half_filled(&self.scored, &all);
        let block_mean = |b: &[usize], f: &dyn Fn(usize) -> f64| {
            b.iter().map(|&i| f(i)).sum::<f64>() / b.len() as f64
        };
        let delta: Vec<f64> = blocks
            .iter()
            .map(|b| {
                block_mean(b, &|i| {
                    f64::from(ext_run.rate_dps[i]) - f64::from(static_run.rate_dps[i])
                })
            })
            .collect();
        let scored: Vec<usize> = blocks
            .iter()
            .enumerate()
            .filter(|(_, b)| {
                2 * b
                    .iter()
                    .filter(|&&i| self.scored.rate_dps[i].is_finite())
                    .count()
                    > b.len()
            })
            .map(|(k, _)| k)
            .collect();
        let centred = |c: &replay::Means| {
            let e: Vec<f64> = scored
                .iter()
                .map(|&k| {
                    let b: Vec<usize> = blocks[k]
                        .iter()
                        .copied()
                        .filter(|&i| self.scored.rate_dps[i].is_finite())
                        .collect();
                    block_mean(&b, &|i| f64::from(c.rate_dps[i]) - self.scored.rate_dps[i])
                })
                .collect();
            let m = e.iter().sum::<f64>() / e.len().max(1) as f64;
            rms(&e.iter().map(|v| v - m).collect::<Vec<_>>())
        };
        let sight = Sight {
            sees: self.extended_blob.is_some() && diagnose::sees(&delta, &scored),
            centred_rmse_60s_dps: [centred(&static_run), centred(&ext_run)],
        };
        Ok((rmse(&static_run), rmse(&ext_run), sight))
    }
}

/// The σ of a model chosen on a training stream, measured on the training data alone
/// ([`uncertainty`]): the table's groups left out (where the static model is a rate table's),
/// and the stream's splits scored by the model of the kind shipped, fitted without them. Where
/// the static model never saw the stream (a table's), the whole training stream is out of sample
/// for it, in hours since power-on. The sample noise is the white part of `shipped_blob`'s errors
/// on the training stream.
pub fn calibrate(
    points: &Points,
    static_model: &GpModel,
    static_blob: &[u8],
    shipped_blob: &[u8],
    kind: Shipped,
    train: &Stream,
    splits: &[Split],
) -> anyhow::Result<Calibration> {
    let fw = fog_data::replay::decode(shipped_blob)?;
    let comp = replay::means(&fw, train);
    let errors: Vec<f64> = (0..train.len())
        .map(|i| f64::from(comp.rate_dps[i]) - train.rate_dps[i])
        .collect();
    let noise = SampleNoise::from_errors(train, &errors).unwrap_or(SampleNoise {
        var: f64::from(fw.variances()[1]),
        interval_s: 0.0,
    });
    let mut series = Vec::new();
    if points.soaked {
        series.push(uncertainty::tables::table_series(static_model, points)?);
    }
    match (points.soaked, kind) {
        (true, Shipped::Static) => series.push(uncertainty::streams::stream_series(
            Source::Stream,
            static_blob,
            train,
            &uncertainty::streams::hours_on(train),
            noise,
        )?),
        _ => {
            // A leg split judges an extension, not the σ: its models are fitted on one leg and
            // asked about the other (an extension's transient fitted late asked what it was
            // early), which the shipped model, fitted on both, never is. With its residuals the
            // MEMS log's gyro y was 2.1× too wide held out (1.55 without); acc x and z narrower.
            for split in splits.iter().filter(|s| s.source != Source::Leg) {
                let blob = match kind {
                    Shipped::Static => Some(&split.static_blob),
                    Shipped::Extended => split.extended_blob.as_ref(),
                };
                if let Some(blob) = blob {
                    series.push(uncertainty::streams::stream_series(
                        split.source,
                        blob,
                        &split.scored,
                        &split.hours,
                        noise,
                    )?);
                }
            }
        }
    }
    let mut calibration =
        uncertainty::calibrate(&series, noise, uncertainty::Prior::of(static_model, points));
    calibration.set_legs(&uncertainty::streams::legs(train));
    Ok(calibration)
}

/// Diagnoses `train` against the static `model` (fitted on `points`), fits the named causes' (or
/// the `asked` causes') inputs, and checks them forward in time inside `train`: fitted on the
/// earlier part alone, scored on the later part. `rebuild` makes the static points from part of
/// the stream, as `points` were made from all of it; it is called only where the points are not
/// a rate table. Named causes ship only when the forward check shows a gain (an extension or a
/// check that cannot be fitted ships the static model, with the reason); asked-for causes ship
/// regardless, with a warning when the check shows none.
pub fn choose(
    points: &Points,
    model: &GpModel,
    fw: &HostModel,
    train: &Stream,
    cfg: &GpConfig,
    asked: Option<&[Cause]>,
    rebuild: &Rebuild<'_>,
) -> anyhow::Result<Choice> {
    let diagnosis = diagnose::diagnose_fitted(fw, model, points, train);
    let causes: Vec<Cause> = asked
        .unwrap_or(&diagnosis.causes)
        .iter()
        .copied()
        .filter(|c| *c != Cause::None)
        .collect();
    let static_choice = |diagnosis, causes, check, verdict, splits| Choice {
        diagnosis,
        causes,
        check,
        shipped: Shipped::Static,
        extended: None,
        verdict,
        splits,
    };
    if causes.is_empty() {
        let verdict = "nothing named: the static model is shipped".to_owned();
        let splits = splits(points, model, train, cfg, &[], rebuild)?;
        return Ok(static_choice(diagnosis, causes, None, verdict, splits));
    }
    let names = joined(&causes);
    let fitted = forward_check(points, model, train, cfg, &causes, rebuild)
        .and_then(|check| Ok((check, extend::fit(model, points, train, &causes)?)));
    let ((check, splits), extended) = match (fitted, asked) {
        (Ok(both), _) => both,
        (Err(e), Some(_)) => return Err(e),
        (Err(e), None) => {
            let verdict = format!(
                "{names} named, but its extension could not be fitted and checked ({e:#}): the \
                 static model is shipped"
            );
            let splits = splits(points, model, train, cfg, &[], rebuild)?;
            return Ok(static_choice(diagnosis, causes, None, verdict, splits));
        }
    };
    let (shipped, verdict) = decide(
        check.as_ref(),
        (&names, points.quantity.unit()),
        asked.is_some(),
    );
    if shipped == Shipped::Static && asked.is_none() && causes.len() > 1 {
        // Do no harm by nested fallback: a design refused whole may hold a part that helps.
        if let Some((causes, check, extended, verdict, splits)) =
            nested(points, model, train, cfg, &causes, rebuild, &verdict)?
        {
            return Ok(Choice {
                diagnosis,
                causes,
                check,
                shipped: Shipped::Extended,
                extended: Some(extended),
                verdict,
                splits,
            });
        }
    }
    Ok(Choice {
        diagnosis,
        causes,
        check,
        shipped,
        extended: Some(extended),
        verdict,
        splits,
    })
}

/// A nested design that ships: its causes, check, extension, verdict and splits.
type Nested = (
    Vec<Cause>,
    Option<ForwardCheck>,
    Extended,
    String,
    Vec<Split>,
);

/// The first of the nested designs of `causes` (each cause alone, in the order named) whose
/// extension passes the checks the whole design failed (`refused`, why it did); `None` when none
/// does. A nested design that cannot be fitted is passed over.
fn nested(
    points: &Points,
    model: &GpModel,
    train: &Stream,
    cfg: &GpConfig,
    causes: &[Cause],
    rebuild: &Rebuild<'_>,
    refused: &str,
) -> anyhow::Result<Option<Nested>> {
    for &cause in causes {
        let one = [cause];
        let Ok((check, splits)) = forward_check(points, model, train, cfg, &one, rebuild) else {
            continue;
        };
        let Ok(extended) = extend::fit(model, points, train, &one) else {
            continue;
        };
        let name = joined(&one);
        let (shipped, verdict) = decide(check.as_ref(), (&name, points.quantity.unit()), false);
        if shipped == Shipped::Extended {
            let verdict = format!(
                "{} named together: {refused}; nested, {name} alone: {verdict}",
                joined(causes)
            );
            return Ok(Some((one.to_vec(), check, extended, verdict, splits)));
        }
    }
    Ok(None)
}

/// Which model ships after the forward `check` of the extension by `names`, and why in words:
/// the extension where it helps on every check that can see it (or where it was `asked` for),
/// the static model otherwise, and where the stream is too short to check.
fn decide(
    check: Option<&ForwardCheck>,
    (names, unit): (&str, &str),
    asked: bool,
) -> (Shipped, String) {
    match (check, asked) {
        (None, true) => (
            Shipped::Extended,
            format!("{names} as asked; the training stream is too short to check it forward"),
        ),
        (None, false) => (
            Shipped::Static,
            format!(
                "{names} named, but the training stream is too short to check the extension \
                 forward in time ({EARLIER_MIN_BLOCKS} + {LATER_MIN_BLOCKS} blocks of 60 s \
                 needed): the static model is shipped"
            ),
        ),
        (Some(c), asked) => {
            let earlier = format!(
                "fitted on the first {:.0} min of the training stream",
                c.split_s / 60.0
            );
            let blind = |sight: &Sight| {
                if sight.sees {
                    String::new()
                } else {
                    let [s, e] = sight.centred_rmse_60s_dps;
                    format!(
                        " (its input barely moves there: that test cannot see it, and judges only \
                         harm, {e:.3e} against {s:.3e} with each model's mean taken out)"
                    )
                }
            };
            let mut figures = format!(
                "{earlier}, {names} scores {:.3e} {} on the {} later blocks against the static \
                 model's {:.3e}{}",
                c.extended_rmse_60s_dps,
                unit,
                c.later_blocks,
                c.static_rmse_60s_dps,
                blind(&c.sight)
            );
            if let Some(t) = &c.temperature {
                figures += &format!(
                    "; fitted inside {:.1}…{:.1} °C, {:.3e} against {:.3e} on the {} blocks \
                     outside{}",
                    t.inside_c.0,
                    t.inside_c.1,
                    t.extended_rmse_60s_dps,
                    t.static_rmse_60s_dps,
                    t.outside_blocks,
                    blind(&t.sight)
                );
            }
            for l in &c.legs {
                figures += &format!(
                    "; fitted on the {} leg, {:.3e} against {:.3e} on the {} blocks of the \
                     other{}",
                    l.fitted_on,
                    l.extended_rmse_60s_dps,
                    l.static_rmse_60s_dps,
                    l.scored_blocks,
                    blind(&l.sight)
                );
            }
            let forward_fails = !vote(c.static_rmse_60s_dps, c.extended_rmse_60s_dps, &c.sight);
            let elsewhere = match (
                c.temperature.as_ref().is_none_or(|t| t.extension_helps()),
                c.legs_pass(),
            ) {
                (false, true) => "outside the temperatures it was fitted on",
                (true, false) => "on both heating/cooling legs, each fitted on the other",
                _ => "outside the temperatures it was fitted on and on both legs",
            };
            match (c.extension_helps(), asked) {
                (true, _) => (
                    Shipped::Extended,
                    format!("{figures}: the extension is shipped"),
                ),
                (false, true) => (
                    Shipped::Extended,
                    format!("{figures}: shipped as asked, although it does no good there"),
                ),
                (false, false) if !forward_fails => (
                    Shipped::Static,
                    format!("{figures}: worse {elsewhere}, so the static model is shipped"),
                ),
                (false, false) if !c.sight.sees => (
                    Shipped::Static,
                    format!(
                        "{figures}: worse there by more than {:.0}%, so the static model is \
                         shipped",
                        100.0 * diagnose::HARM
                    ),
                ),
                (false, false) => (
                    Shipped::Static,
                    format!("{figures}: no gain there, so the static model is shipped"),
                ),
            }
        }
    }
}

/// A stream cut forward in time ([`forward`]).
pub(crate) struct Forward {
    /// Where it was cut, s from its first sample.
    pub split_s: f64,
    /// 60 s blocks before the cut.
    pub earlier_blocks: usize,
    /// 60 s blocks after it.
    pub later_blocks: usize,
    /// The part before the cut, to fit on.
    pub early: Stream,
    /// The whole stream with its reference kept only after the cut, to score on: replayed
    /// whole, the stateful inputs carry their history across the cut.
    pub later: Stream,
}

/// Cuts `stream` after [`EARLIER_SHARE`] of its 60 s blocks (at least [`EARLIER_MIN_BLOCKS`]);
/// `None` when fewer than [`LATER_MIN_BLOCKS`] would be left after the cut. Blocks are counted
/// as the diagnosis counts them (samples with a reference).
pub(crate) fn forward(stream: &Stream) -> Option<Forward> {
    let blocks = blocks::half_filled(stream, &stream.referenced());
    let n = blocks.len();
    let earlier = ((EARLIER_SHARE * n as f64).round() as usize).max(EARLIER_MIN_BLOCKS);
    if n < earlier + LATER_MIN_BLOCKS {
        return None;
    }
    let t0 = stream.time_s.first().copied().unwrap_or(0.0);
    let split_s = stream.time_s[blocks[earlier][0]] - t0;
    let early = stream.window(Window {
        start_s: None,
        end_s: Some(split_s),
    });
    let mut later = stream.clone();
    for (r, t) in later.rate_dps.iter_mut().zip(&stream.time_s) {
        if t - t0 < split_s {
            *r = f64::NAN;
        }
    }
    Some(Forward {
        split_s,
        earlier_blocks: earlier,
        later_blocks: n - earlier,
        early,
        later,
    })
}

/// Runs the investigation; `asked` overrides the inputs the diagnosis calls for. `rebuild` makes
/// the static points from part of the training stream ([`choose`]). `bar` counts its [`STEPS`].
pub fn investigate(
    points: &Points,
    train: &Stream,
    valid: &Stream,
    cfg: &GpConfig,
    asked: Option<&[Cause]>,
    rebuild: &Rebuild<'_>,
    bar: &dyn Progress,
) -> anyhow::Result<(Investigation, Blobs)> {
    bar.expect(STEPS);
    bar.stage(&format!("static fit on {} points", points.len()));
    let model = GpModel::fit(points.inputs(), &points.target(), cfg)?;
    let static_blob = export::points_blob(&model, points, &Extension::default())?;
    let (fw, _) =
        export::verify(&model, &static_blob, points, &Extension::default()).map_err(|e| {
            let warned = model.warnings();
            let e = anyhow::Error::from(e);
            if warned.is_empty() {
                e
            } else {
                e.context(format!("static fit (it warned: {})", warned.join("; ")))
            }
        })?;
    bar.advance(1);
    bar.stage("diagnosis of the training stream, extension, forward check");
    let choice = choose(points, &model, &fw, train, cfg, asked, rebuild)?;
    bar.advance(3);
    bar.stage("replay of the static and the shipped model on the held-out stream");
    let mut warnings = model.warnings();
    let (extension, extended_blob) = match (&choice.extended, choice.shipped) {
        (Some(ext), Shipped::Extended) => (Some(ext.fitted.clone()), ext.blob.clone()),
        _ => (None, static_blob.clone()),
    };
    if choice.check.as_ref().is_some_and(|c| !c.extension_helps()) {
        warnings.push(choice.verdict.clone());
    }
    let calibrated = |blob: &[u8], kind| {
        calibrate(
            points,
            &model,
            &static_blob,
            blob,
            kind,
            train,
            &choice.splits,
        )
    };
    let static_calibration = calibrated(&static_blob, Shipped::Static)?;
    let calibration = calibrated(&extended_blob, choice.shipped)?;
    let beyond = beyond::choose(points, cfg);
    let static_blob = export::with_beyond(&static_calibration.apply(&static_blob)?, beyond.rule)?;
    let extended_blob = export::with_beyond(&calibration.apply(&extended_blob)?, beyond.rule)?;
    let fw = fog_data::replay::decode(&static_blob)?;
    let static_score = replay::score(valid, &replay::replay(&fw, valid));
    let shipped = fog_data::replay::decode(&extended_blob)?;
    let extended_score = replay::score(valid, &replay::replay(&shipped, valid));
    let gain = static_score.rmse_60s_dps / extended_score.rmse_60s_dps;
    bar.advance(1);
    Ok((
        Investigation {
            static_score,
            added_inputs: match choice.shipped {
                Shipped::Extended => choice
                    .causes
                    .iter()
                    .filter_map(|c| extend::feature_name(*c))
                    .collect(),
                Shipped::Static => Vec::new(),
            },
            diagnosis: choice.diagnosis,
            forward_check: choice.check,
            shipped: choice.shipped,
            verdict: choice.verdict,
            extension,
            extended_score,
            gain,
            warnings,
            train_handled: train.handled.clone(),
            calibration,
            static_calibration,
            beyond,
        },
        Blobs {
            static_blob,
            extended_blob,
        },
    ))
}

#[cfg(test)]
mod tests;
