//! The investigation in one call: static fit → diagnosis of the training stream → extension,
//! shipped only when it wins a forward test inside the training stream (and, where the static
//! curve is fitted on that stream, a test beyond the temperatures it was fitted on) → replay of
//! the static and the shipped model on the held-out stream → the gain.
//!
//! The held-out stream is touched once, to score: which causes to name and whether to ship their
//! extension are part of the model, so they come from the training data alone ([`choose`]).

use crate::progress::Progress;
use fog_data::cause::Cause;
use fog_data::channels::Datasheet;
use fog_data::replay::{self, HostModel, Score};
use fog_data::stream::{Handled, Stream};
use serde::Serialize;

use crate::analysis::basis::{self, BasisChoice};
use crate::analysis::beyond::{self, BeyondChoice};
use crate::analysis::capacity;
use crate::analysis::diagnose::{self, Diagnosis, Residual, joined};
use crate::analysis::extend::{self, Extended, ExtensionFit};
use crate::analysis::uncertainty::streams::WalkReading;
use crate::analysis::uncertainty::{self, Calibration, ResidualSource, SampleNoise};
use crate::data::points::Points;
use crate::firmware::export::{self, Extension};
use crate::models::gp::{GpConfig, GpModel};

mod check;
mod split;

use check::forward_check;
pub use check::{ForwardCheck, LegCheck, TemperatureCheck, vote};
use split::{EARLIER_MIN_BLOCKS, LATER_MIN_BLOCKS};
pub(crate) use split::{FORWARD_MIN_BLOCKS, Forward, forward};
pub use split::{Fitted, Rebuild, Sight, Split, power_on_splits, splits};

/// Steps of an investigation: static fit, diagnosis, forward check, extended fit, replays.
pub const STEPS: u64 = 5;

/// The result (docs/design.md §6 names where they exist).
#[derive(Debug, Clone, Serialize, schemars::JsonSchema)]
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
    pub extension: Option<ExtensionFit>,
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
    /// How `--mean auto` (the default) chose the prior mean's basis, on temperature bands left
    /// out (`null`: a basis asked for).
    pub basis_choice: Option<BasisChoice>,
    /// How the default size (`--inducing auto`) chose the firmware model's inducing points, as
    /// `fit` chooses them, on more points than a firmware model holds (`null`: the exact GP, or
    /// a size asked for).
    pub centres_choice: Option<capacity::Choice>,
}

impl Investigation {
    /// The first named cause.
    pub fn cause(&self) -> Cause {
        self.diagnosis.cause
    }
}

/// Which model an extension step ships.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, schemars::JsonSchema)]
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

/// The σ of a model chosen on a training stream, measured on the training data alone
/// ([`uncertainty`]): the table's groups left out (where the static model is a rate table's),
/// and the stream's splits scored by the model of the kind shipped, fitted without them. Where
/// the static model never saw the stream (a table's), the whole training stream is out of sample
/// for it, in hours since power-on. The sample noise is the white part of `shipped_blob`'s errors
/// on the training stream. What the data cannot show beyond the range is assumed for the rule
/// `beyond` ships ([`uncertainty::Prior::for_rule`]). The splits are scored as their blobs
/// export, the GP followed beyond the range, whatever rule ships: scored held, the simulated
/// warm-up of docs/uncertainty.md ("The mean beyond the trained range") showed holding's miss at
/// ±80 °/s in its temperature split, and the term fitted there, one number for every rate, made
/// its σ 8.4× its RMS error on the colder day (1.03 so). Their extrapolation term is then the
/// GP's miss, not the shipped rule's: under another rule it is assumed (`Prior::follows`).
/// The bias's random walk is also read from an Allan deviation, where the training stream's
/// reference holds still ([`uncertainty::streams::allan_walk`]): of `shipped_blob`'s errors over
/// the whole stream, and, where the σ is fitted on the splits (not a table's static model), of
/// the forward split's model's over the part it was not fitted on
/// ([`uncertainty::streams::part_walk`]), the larger; where the splits fit less, it ships.
pub fn calibrate(
    (points, static_model, static_blob): (&Points, &GpModel, &[u8]),
    shipped_blob: &[u8],
    kind: Shipped,
    train: &Stream,
    splits: &[Split],
    beyond: &BeyondChoice,
) -> anyhow::Result<Calibration> {
    let fw = replay::decode(shipped_blob)?;
    let errors = uncertainty::streams::errors(&fw, train);
    let noise = SampleNoise::from_streams(&[(train, &errors)]).unwrap_or(SampleNoise {
        var: f64::from(fw.variances()[1]),
        interval_s: 0.0,
    });
    let mut series = Vec::new();
    if points.soaked {
        series.push(uncertainty::tables::table_series(static_model, points)?);
    }
    let power_ons: Vec<&Split> = splits
        .iter()
        .filter(|s| s.source == ResidualSource::PowerOn)
        .collect();
    match (points.soaked, kind) {
        // The table's model never saw the stream: its power-ons, where it holds several, are
        // each one the model did not know, scored as its split is.
        (true, Shipped::Static) if !power_ons.is_empty() => {
            for split in power_ons {
                series.push(uncertainty::streams::stream_series(
                    split.source,
                    static_blob,
                    &split.scored,
                    &split.hours,
                    noise,
                )?);
            }
        }
        (true, Shipped::Static) => series.push(uncertainty::streams::stream_series(
            ResidualSource::Stream,
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
            // Where power-ons are left out, the others' residuals keep to the power-ons their
            // models saw: the bias of one they did not is measured on the power-ons.
            for split in splits.iter().filter(|s| s.source != ResidualSource::Leg) {
                let blob = split_blob(split, kind);
                let scored = if power_ons.is_empty() || split.source == ResidualSource::PowerOn {
                    split.scored.clone()
                } else {
                    split.within_power_ons_seen(train)
                };
                if let Some(blob) = blob {
                    series.push(uncertainty::streams::stream_series(
                        split.source,
                        blob,
                        &scored,
                        &split.hours,
                        noise,
                    )?);
                }
            }
        }
    }
    // The walk the shipped model's errors show over the whole log, and, where the σ is fitted on
    // the splits, the one the forward split's model shows over the part it was not fitted on:
    // the larger. (A table's static model never saw the stream: its errors are out of sample.)
    let noise_std = noise.var.sqrt();
    let mut walk = (
        uncertainty::streams::allan_walk(train, errors, noise_std),
        WalkReading::WholeLog,
    );
    let on_splits = !(points.soaked && matches!(kind, Shipped::Static));
    if on_splits && uncertainty::streams::holds_still(&train.rate_dps, noise_std) {
        for split in splits
            .iter()
            .filter(|s| s.source == ResidualSource::Forward)
        {
            if let Some(blob) = split_blob(split, kind) {
                let later = uncertainty::streams::errors(&*replay::decode(blob)?, &split.scored);
                let part = uncertainty::streams::part_walk(train, &split.scored, later, noise_std);
                if part > walk.0 {
                    walk = (part, WalkReading::ForwardSplit);
                }
            }
        }
    }
    let mut calibration = uncertainty::terms::calibrate(
        &series,
        noise,
        uncertainty::Prior::of(static_model, points)
            .for_rule(beyond)
            .with_walk(walk.0, walk.1),
    );
    calibration.set_legs(&uncertainty::streams::legs(train));
    calibration.set_heating(
        &uncertainty::heating::rates(train),
        uncertainty::heating::slopes(&fw, train, noise_std),
    );
    Ok(calibration)
}

/// The blob of `split`'s model of `kind`, fitted without its scored part: the static model's, or
/// the extension's where one was fitted.
fn split_blob(split: &Split, kind: Shipped) -> Option<&[u8]> {
    match kind {
        Shipped::Static => Some(&split.static_blob),
        Shipped::Extended => split.extended_blob.as_deref(),
    }
}

/// Diagnoses `train` against the static `model` (fitted on `points`), fits the named causes' (or
/// the `asked` causes') inputs, and checks them forward in time inside `train`: fitted on the
/// earlier part alone, scored on the later part. `rebuild` makes the static points from part of
/// the stream, as `points` were made from all of it; it is called only where the points are not
/// a rate table. Named causes ship only when the forward check shows a gain (an extension or a
/// check that cannot be fitted ships the static model, with the reason); asked-for causes ship
/// regardless, with a warning when the check shows none. The choice's splits hold the power-ons
/// left out for the σ ([`power_on_splits`]), of the design shipped.
pub fn choose(
    points: &Points,
    model: &GpModel,
    fw: &HostModel,
    train: &Stream,
    cfg: &GpConfig,
    asked: Option<&[Cause]>,
    rebuild: &Rebuild<'_>,
) -> anyhow::Result<Choice> {
    let mut choice = choose_design(points, model, fw, train, cfg, asked, rebuild)?;
    let causes: &[Cause] = if choice.extended.is_some() {
        &choice.causes
    } else {
        &[]
    };
    let fitted = Fitted {
        points,
        model,
        train,
        cfg,
        rebuild,
    };
    let power_ons = power_on_splits(fitted, causes)?;
    choice.splits.extend(power_ons);
    Ok(choice)
}

/// [`choose`] without the power-ons left out.
fn choose_design(
    points: &Points,
    model: &GpModel,
    fw: &HostModel,
    train: &Stream,
    cfg: &GpConfig,
    asked: Option<&[Cause]>,
    rebuild: &Rebuild<'_>,
) -> anyhow::Result<Choice> {
    // One residual for the diagnosis and the extension's fit: both read the same lags of it.
    let res = Residual::new(fw, train).fitted_on(model, points);
    let on = Fitted {
        points,
        model,
        train,
        cfg,
        rebuild,
    };
    let diagnosis = diagnose::diagnose_residual(&res, points.quantity);
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
        let splits = splits(on, &[])?;
        return Ok(static_choice(diagnosis, causes, None, verdict, splits));
    }
    let names = joined(&causes);
    let fitted = forward_check(on, &causes, res.spread_60s())
        .and_then(|check| Ok((check, extend::fit(model, points, &res, &causes)?)));
    let ((check, splits), extended) = match (fitted, asked) {
        (Ok(both), _) => both,
        (Err(e), Some(_)) => return Err(e),
        (Err(e), None) => {
            let verdict = format!(
                "{names} named, but its extension could not be fitted and checked ({e:#}): the \
                 static model is shipped"
            );
            let splits = splits(on, &[])?;
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
            nested(on, &res, &causes, &verdict)?
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
    on: Fitted<'_>,
    res: &Residual<'_>,
    causes: &[Cause],
    refused: &str,
) -> anyhow::Result<Option<Nested>> {
    let (points, model) = (on.points, on.model);
    for &cause in causes {
        let one = [cause];
        let Ok((check, splits)) = forward_check(on, &one, res.spread_60s()) else {
            continue;
        };
        let Ok(extended) = extend::fit(model, points, res, &one) else {
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

/// The forward check's figures in words: forward in time, beyond the temperatures fitted and
/// across the heating/cooling legs, each with what a test that cannot see the extension judged.
fn check_figures(c: &ForwardCheck, names: &str, unit: &str) -> String {
    let blind = |sight: &Sight| {
        if sight.sees {
            String::new()
        } else {
            let [s, e] = sight.centred_rmse_60s_dps;
            format!(
                " (its input barely moves there: that test cannot see it, and judges only harm, \
                 {e:.3e} against {s:.3e} with each model's mean taken out, beside the training \
                 stream's residual of {:.3e} about its mean)",
                c.residual_60s_dps
            )
        }
    };
    let mut figures = format!(
        "fitted on the training stream up to {:.0} min from the log's start, {names} scores \
         {:.3e} {unit} on the {} later blocks against the static model's {:.3e}{}",
        c.split_s / 60.0,
        c.extended_rmse_60s_dps,
        c.later_blocks,
        c.static_rmse_60s_dps,
        blind(&c.sight)
    );
    if let Some(t) = &c.temperature {
        figures += &format!(
            "; fitted inside {:.1}…{:.1} °C, {:.3e} against {:.3e} on the {} blocks outside{}",
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
            "; fitted on the {} leg, {:.3e} against {:.3e} on the {} blocks of the other{}",
            l.fitted_on,
            l.extended_rmse_60s_dps,
            l.static_rmse_60s_dps,
            l.scored_blocks,
            blind(&l.sight)
        );
    }
    figures
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
            let figures = check_figures(c, names, unit);
            let forward_fails = !vote(
                c.static_rmse_60s_dps,
                c.extended_rmse_60s_dps,
                &c.sight,
                c.residual_60s_dps,
            );
            let elsewhere = match (
                c.temperature
                    .as_ref()
                    .is_none_or(|t| t.extension_helps(c.residual_60s_dps)),
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

/// What an investigation is told beside its data.
#[derive(Debug, Clone, Copy, Default)]
pub struct Told<'a> {
    /// The causes to extend by; `None`: those the diagnosis names.
    pub asked: Option<&'a [Cause]>,
    /// A datasheet's figures, in both blobs' σ as `fit` states them ([`Calibration::state`]):
    /// where one is not stated, assumed as `fit` assumes it.
    pub sheet: Datasheet,
}

/// Runs the investigation; `told.asked` overrides the inputs the diagnosis calls for. `rebuild`
/// makes the static points from part of the training stream ([`choose`]). `valid` is scored as the
/// calibration's own power-on where `calibration_run` says it is (the later part of the training
/// log: [`replay::replay_run`]), else as another, as in service. `bar` counts its [`STEPS`].
pub fn investigate(
    points: &Points,
    train: &Stream,
    (valid, calibration_run): (&Stream, bool),
    cfg: &GpConfig,
    told: Told<'_>,
    rebuild: &Rebuild<'_>,
    bar: &dyn Progress,
) -> anyhow::Result<(Investigation, Blobs)> {
    let asked = told.asked;
    bar.expect(STEPS);
    bar.stage("the prior mean's basis, on temperature bands");
    let (cfg, basis_choice) = basis::resolve(points, cfg);
    // A log longer than a firmware model's centres needs the sparse GP `fit` would ship.
    let (cfg, centres_choice) = capacity::resolve(points, &cfg, |step| {
        bar.stage(&format!("choosing the firmware model's size: {step}"))
    })?;
    let cfg = &cfg;
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
    let beyond = beyond::choose(points, cfg);
    // The blobs state a datasheet's figures as `fit`'s do, or assume them.
    let calibrated = |blob: &[u8], kind| {
        calibrate(
            (points, &model, &static_blob),
            blob,
            kind,
            train,
            &choice.splits,
            &beyond,
        )
        .and_then(|mut c| {
            c.state(&told.sheet, blob, beyond.rule)?;
            Ok(c)
        })
    };
    // Where the static model ships, the shipped model is the static one: calibrated and scored
    // once.
    let same = choice.shipped == Shipped::Static && extended_blob == static_blob;
    let static_calibration = calibrated(&static_blob, Shipped::Static)?;
    let calibration = if same {
        static_calibration.clone()
    } else {
        calibrated(&extended_blob, choice.shipped)?
    };
    let static_blob = export::with_beyond(&static_calibration.apply(&static_blob)?, beyond.rule)?;
    let extended_blob = export::with_beyond(&calibration.apply(&extended_blob)?, beyond.rule)?;
    let fw = fog_data::replay::decode(&static_blob)?;
    let static_score = replay::score(valid, &replay::replay_run(&fw, valid, calibration_run));
    let extended_score = if same {
        static_score.clone()
    } else {
        let shipped = fog_data::replay::decode(&extended_blob)?;
        replay::score(valid, &replay::replay_run(&shipped, valid, calibration_run))
    };
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
            basis_choice,
            centres_choice,
        },
        Blobs {
            static_blob,
            extended_blob,
        },
    ))
}

#[cfg(test)]
mod tests;
