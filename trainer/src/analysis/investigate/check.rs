//! The forward check of an extension inside the training stream: fitted on the earlier part,
//! scored on the later part (and, where the static curve was fitted on the stream, beyond the
//! temperatures it was fitted on), with the blobs of each part; what each check found
//! ([`ForwardCheck`], its [`TemperatureCheck`] and [`LegCheck`]s) and the rule it votes by
//! ([`vote`]).

use fog_data::blocks;
use fog_data::cause::Cause;
use fog_data::stream::Stream;
use serde::Serialize;

use crate::analysis::uncertainty::{self, Source};
use crate::analysis::{diagnose, extend};
use crate::data::points::Points;
use crate::firmware::export::{self, Extension};
use crate::models::gp::{GpConfig, GpModel};

use super::{
    EARLIER_MIN_BLOCKS, Forward, LATER_MIN_BLOCKS, LEG_MIN_BLOCKS, OUTER_SHARE, Rebuild, Split,
    forward,
};

/// Do no harm: the extension of the named causes fitted on the earlier part of the training
/// stream (the static model too, where it was fitted on the stream), both scored on the later
/// part. The causes are those the whole training stream names: running the whole diagnosis again
/// on the earlier part was measured and is too conservative (docs/diagnosis.md).
#[derive(Debug, Clone, Serialize)]
pub struct ForwardCheck {
    /// Where the stream was cut, s from its first sample.
    pub split_s: f64,
    /// 60 s blocks before the cut.
    pub earlier_blocks: usize,
    /// 60 s blocks after it.
    pub later_blocks: usize,
    /// The causes fitted on the earlier part (named on the whole training stream, or asked for).
    pub causes: Vec<Cause>,
    /// Static `rmse_60s_dps` on the later part.
    pub static_rmse_60s_dps: f64,
    /// Extended `rmse_60s_dps` on the later part (the static one where nothing was named).
    pub extended_rmse_60s_dps: f64,
    /// What the later part could see of the extension ([`Sight`]).
    pub sight: Sight,
    /// The same test across temperature, where the static model is fitted on the stream itself
    /// (absent with a rate table, or where either side is too short).
    pub temperature: Option<TemperatureCheck>,
    /// The same test across the heating/cooling legs, each way the stream holds enough of both.
    pub legs: Vec<LegCheck>,
}

impl ForwardCheck {
    /// Whether the extension passes: better than the static model on the later part and outside
    /// the temperatures it was fitted on, each where that test could see it; no worse by more
    /// than [`diagnose::HARM`] where it could not ([`vote`]). The diagnosis' interleaved test,
    /// which named the causes, always sees them.
    pub fn extension_helps(&self) -> bool {
        !self.causes.is_empty()
            && vote(
                self.static_rmse_60s_dps,
                self.extended_rmse_60s_dps,
                &self.sight,
            )
            && self
                .temperature
                .as_ref()
                .is_none_or(|t| t.extension_helps())
            && self.legs_pass()
    }

    /// Whether the leg checks pass: none could be made, or the extension wins on at least one
    /// leg it was not fitted on ([`LegCheck`]).
    pub fn legs_pass(&self) -> bool {
        self.legs.is_empty() || self.legs.iter().any(LegCheck::extension_helps)
    }
}

/// Do no harm on the other heating/cooling leg: a firmware calibrated on a stream meets the leg
/// it holds less of (a cool-down after a warm-up), and a cause named on one leg can be the other
/// leg's difference in disguise (a warm-up that coincides with a log's first cooling). Both
/// models are fitted on the samples of one leg, as the firmware tracks it
/// (`firmware_core::FeatureState::leg`), and scored on the other's, the whole stream replayed,
/// each way the stream holds enough of both. The extension must win on at least one: a leg
/// scored before the one fitted asks a transient fitted late to say what it was early, which a
/// real warm-up fails as often as a false one (on the simulated cool-downs, every seed), but a
/// cause that loses on both legs explains neither (the MEMS log's acc.z, whose warm-up, named
/// on the training stream, is 1.5× worse than static held out).
#[derive(Debug, Clone, Serialize)]
pub struct LegCheck {
    /// The leg fitted on, `heating` or `cooling`; the other is scored.
    pub fitted_on: &'static str,
    /// 60 s blocks fitted on.
    pub fitted_blocks: usize,
    /// 60 s blocks of the other leg, scored.
    pub scored_blocks: usize,
    /// Static `rmse_60s_dps` on the other leg.
    pub static_rmse_60s_dps: f64,
    /// Extended `rmse_60s_dps` on the other leg.
    pub extended_rmse_60s_dps: f64,
    /// What the other leg could see of the extension ([`Sight`]).
    pub sight: Sight,
}

impl LegCheck {
    /// Whether the extension passes on the other leg ([`vote`]).
    pub fn extension_helps(&self) -> bool {
        vote(
            self.static_rmse_60s_dps,
            self.extended_rmse_60s_dps,
            &self.sight,
        )
    }
}

/// What a test could see of an extension.
#[derive(Debug, Clone, Copy, Serialize)]
pub struct Sight {
    /// Whether the scored part exercised it: the extension's contribution (extended − static,
    /// 60 s means) moves there by at least [`diagnose::VISIBLE`] of its spread over the training
    /// stream. A warm-up after the one power-on at a log's start has died out in its later part.
    pub sees: bool,
    /// Both models' `rmse_60s_dps` there with each one's mean error over the scored part taken
    /// out, static then extended: what a test that cannot see the extension judges harm on. Its
    /// input is flat there, so the two differ by the constant each was fitted with, and the
    /// extension's constant, fitted beside a transient on the earlier part alone, says nothing of
    /// the one fitted on the whole stream that ships. Harm the extension carries moves with its
    /// input, and a test that sees it counts it in full.
    pub centred_rmse_60s_dps: [f64; 2],
}

/// One test's vote on an extension: where it sees the extension, a gain; where it cannot, no
/// harm beyond [`diagnose::HARM`] in what it can measure ([`Sight`]): it abstains, and the
/// decision rests on the tests that could see (the diagnosis' interleaved test always does).
pub fn vote(static_rmse: f64, extended_rmse: f64, sight: &Sight) -> bool {
    if sight.sees {
        extended_rmse < static_rmse
    } else {
        let [s, e] = sight.centred_rmse_60s_dps;
        e <= s * (1.0 + diagnose::HARM)
    }
}

/// Do no harm beyond the trained temperatures: where the static curve is fitted on the stream
/// together with the extension, the extension also refits that curve, and a firmware meets
/// temperatures its training did not reach. Both models are fitted on the samples inside the
/// training span less a tenth of it at each end and scored on the samples outside (the whole
/// stream replayed, so stateful inputs keep their history). A state can win the forward test in
/// time and still fail beyond the trained temperatures, where a held-out part often lies
/// (docs/real-data.md, the MEMS thermal cycle's x axis).
#[derive(Debug, Clone, Serialize)]
pub struct TemperatureCheck {
    /// The temperatures fitted on, °C.
    pub inside_c: (f64, f64),
    /// 60 s blocks inside.
    pub inside_blocks: usize,
    /// 60 s blocks outside, scored.
    pub outside_blocks: usize,
    /// Static `rmse_60s_dps` outside.
    pub static_rmse_60s_dps: f64,
    /// Extended `rmse_60s_dps` outside.
    pub extended_rmse_60s_dps: f64,
    /// What the samples outside could see of the extension ([`Sight`]).
    pub sight: Sight,
}

impl TemperatureCheck {
    /// Whether the extension passes outside ([`vote`]).
    pub fn extension_helps(&self) -> bool {
        vote(
            self.static_rmse_60s_dps,
            self.extended_rmse_60s_dps,
            &self.sight,
        )
    }
}

/// The forward check of [`super::choose`] (`None` where the stream is too short for one), and the splits
/// it fitted. Blocks are counted as the diagnosis counts them (samples with a reference).
pub(super) fn forward_check(
    points: &Points,
    model: &GpModel,
    train: &Stream,
    cfg: &GpConfig,
    causes: &[Cause],
    rebuild: &Rebuild<'_>,
) -> anyhow::Result<(Option<ForwardCheck>, Vec<Split>)> {
    let splits = splits(points, model, train, cfg, causes, rebuild)?;
    let Some(Forward {
        split_s,
        earlier_blocks,
        later_blocks,
        ..
    }) = forward(train)
    else {
        return Ok((None, splits));
    };
    let scored = |source| splits.iter().find(|s| s.source == source);
    let Some(f) = scored(Source::Forward) else {
        return Ok((None, splits));
    };
    let (static_rmse, extended_rmse, sight) = f.scores()?;
    let temperature = match scored(Source::Temperature) {
        Some(t) if !causes.is_empty() => {
            let (static_rmse_60s_dps, extended_rmse_60s_dps, sight) = t.scores()?;
            let (inside_c, inside_blocks, outside_blocks) = inside(train);
            Some(TemperatureCheck {
                inside_c,
                inside_blocks,
                outside_blocks,
                static_rmse_60s_dps,
                extended_rmse_60s_dps,
                sight,
            })
        }
        _ => None,
    };
    let mut legs = Vec::new();
    if !causes.is_empty() {
        for split in splits.iter().filter(|s| s.source == Source::Leg) {
            let (static_rmse_60s_dps, extended_rmse_60s_dps, sight) = split.scores()?;
            let (fitted_on, fitted_blocks, scored_blocks) = split.leg.unwrap_or_default();
            legs.push(LegCheck {
                fitted_on,
                fitted_blocks,
                scored_blocks,
                static_rmse_60s_dps,
                extended_rmse_60s_dps,
                sight,
            });
        }
    }
    let check = ForwardCheck {
        split_s,
        earlier_blocks,
        later_blocks,
        causes: causes.to_vec(),
        static_rmse_60s_dps: static_rmse,
        extended_rmse_60s_dps: extended_rmse,
        sight,
        temperature,
        legs,
    };
    Ok((Some(check), splits))
}

/// The models of a training stream's splits: forward in time, and, where the static model is
/// fitted on the stream itself, across temperature ([`TemperatureCheck`]); each the static model
/// fitted without the scored part (a rate table's model as it is) and its extension by `causes`
/// (none without causes). A split the stream is too short for is left out.
pub fn splits(
    points: &Points,
    model: &GpModel,
    train: &Stream,
    cfg: &GpConfig,
    causes: &[Cause],
    rebuild: &Rebuild<'_>,
) -> anyhow::Result<Vec<Split>> {
    let mut out = Vec::new();
    if let Some(Forward {
        split_s,
        early,
        later,
        ..
    }) = forward(train)
    {
        let (static_model, static_points) = static_on(points, model, &early, cfg, rebuild)?;
        let (static_blob, extended_blob) =
            split_blobs(&static_model, &static_points, &early, causes)?;
        let t0 = train.time_s.first().copied().unwrap_or(0.0);
        let fitted: Vec<usize> = (0..train.len())
            .filter(|&i| train.time_s[i] - t0 < split_s)
            .collect();
        out.push(Split {
            source: Source::Forward,
            hours: uncertainty::streams::hours_from(&later, &fitted),
            scored: later,
            static_blob,
            extended_blob,
            leg: None,
        });
    }
    if !points.soaked {
        let ((lo, hi), inside_blocks, outside_blocks) = inside(train);
        if inside_blocks >= EARLIER_MIN_BLOCKS && outside_blocks >= LATER_MIN_BLOCKS {
            let (mut fit_on, mut scored) = (train.clone(), train.clone());
            for (i, &t) in train.temp_c.iter().enumerate() {
                if (lo..=hi).contains(&t) {
                    scored.rate_dps[i] = f64::NAN;
                } else {
                    fit_on.rate_dps[i] = f64::NAN;
                }
            }
            let p = rebuild(&fit_on)?;
            let m = GpModel::fit(p.inputs(), &p.target(), cfg)?;
            let (static_blob, extended_blob) = split_blobs(&m, &p, &fit_on, causes)?;
            out.push(Split {
                source: Source::Temperature,
                hours: uncertainty::streams::hours_from(&scored, &fit_on.referenced()),
                scored,
                static_blob,
                extended_blob,
                leg: None,
            });
        }
    }
    out.extend(leg_splits(points, model, train, cfg, causes, rebuild)?);
    Ok(out)
}

/// The leg splits of [`splits`]: the static model and its extension fitted on the samples of one
/// heating/cooling leg and scored on the other's, each way the stream holds
/// [`LEG_MIN_BLOCKS`] blocks of one leg and [`LATER_MIN_BLOCKS`] of the other. A sample
/// before the temperature first moved is on neither leg. Where the static model is a rate
/// table's, it is kept and the extension alone is fitted on the leg. None for hysteresis, whose
/// input, the leg itself, holds one value on one leg: no fit on one leg can see it.
fn leg_splits(
    points: &Points,
    model: &GpModel,
    train: &Stream,
    cfg: &GpConfig,
    causes: &[Cause],
    rebuild: &Rebuild<'_>,
) -> anyhow::Result<Vec<Split>> {
    if causes.contains(&Cause::Hysteresis) {
        return Ok(Vec::new());
    }
    let states = uncertainty::streams::leg_states(train);
    let mut out = Vec::new();
    for (name, heating) in [("heating", true), ("cooling", false)] {
        let (mut fit_on, mut scored) = (train.clone(), train.clone());
        for (i, state) in states.iter().enumerate() {
            let side = state.filter(|s| *s != 0.0).map(|s| s > 0.0);
            if side != Some(heating) {
                fit_on.rate_dps[i] = f64::NAN;
            }
            if side != Some(!heating) {
                scored.rate_dps[i] = f64::NAN;
            }
        }
        let count = |s: &Stream| blocks::half_filled(s, &s.referenced()).len();
        let (fitted_blocks, scored_blocks) = (count(&fit_on), count(&scored));
        if fitted_blocks < LEG_MIN_BLOCKS || scored_blocks < LATER_MIN_BLOCKS {
            continue;
        }
        let (static_model, static_points) = static_on(points, model, &fit_on, cfg, rebuild)?;
        let (static_blob, extended_blob) = split_blobs_on(
            &static_model,
            &static_points,
            &fit_on,
            causes,
            LEG_MIN_BLOCKS,
        )?;
        out.push(Split {
            source: Source::Leg,
            hours: uncertainty::streams::hours_from(&scored, &fit_on.referenced()),
            scored,
            static_blob,
            extended_blob,
            leg: Some((name, fitted_blocks, scored_blocks)),
        });
    }
    Ok(out)
}

/// The static model of a split fitted on `fit_on`: a rate table's as it is, else refitted on the
/// points `rebuild` makes of `fit_on`.
fn static_on(
    points: &Points,
    model: &GpModel,
    fit_on: &Stream,
    cfg: &GpConfig,
    rebuild: &Rebuild<'_>,
) -> anyhow::Result<(GpModel, Points)> {
    if points.soaked {
        return Ok((model.clone(), points.clone()));
    }
    let p = rebuild(fit_on)?;
    Ok((GpModel::fit(p.inputs(), &p.target(), cfg)?, p))
}

/// The blobs of a static model fitted on `points` and of its extension by `causes` fitted on
/// `fit_on` (none without causes).
pub(super) fn split_blobs(
    model: &GpModel,
    points: &Points,
    fit_on: &Stream,
    causes: &[Cause],
) -> anyhow::Result<(Vec<u8>, Option<Vec<u8>>)> {
    split_blobs_on(model, points, fit_on, causes, extend::MIN_BLOCKS)
}

/// [`split_blobs`] with an extension fitted on at least `min_blocks` blocks.
fn split_blobs_on(
    model: &GpModel,
    points: &Points,
    fit_on: &Stream,
    causes: &[Cause],
    min_blocks: usize,
) -> anyhow::Result<(Vec<u8>, Option<Vec<u8>>)> {
    let static_blob = export::points_blob(model, points, &Extension::default())?;
    if causes.is_empty() {
        return Ok((static_blob, None));
    }
    let ext = extend::fit_on_blocks(model, points, fit_on, causes, min_blocks)?;
    Ok((static_blob, Some(ext.blob)))
}

/// The temperatures of the temperature check (the training span less [`OUTER_SHARE`] of it at
/// each end), and the 60 s blocks inside and outside them. A sample counts by its own
/// temperature.
pub(super) fn inside(train: &Stream) -> ((f64, f64), usize, usize) {
    let temps = train.referenced().into_iter().map(|i| train.temp_c[i]);
    let (lo, hi) = temps.fold((f64::INFINITY, f64::NEG_INFINITY), |(lo, hi), t| {
        (lo.min(t), hi.max(t))
    });
    let margin = OUTER_SHARE * (hi - lo);
    let inside_c = (lo + margin, hi - margin);
    let (mut inside, mut outside) = (train.clone(), train.clone());
    for (i, &t) in train.temp_c.iter().enumerate() {
        if (inside_c.0..=inside_c.1).contains(&t) {
            outside.rate_dps[i] = f64::NAN;
        } else {
            inside.rate_dps[i] = f64::NAN;
        }
    }
    let inside_blocks = blocks::half_filled(&inside, &inside.referenced()).len();
    let outside_blocks = blocks::half_filled(&outside, &outside.referenced()).len();
    (inside_c, inside_blocks, outside_blocks)
}
