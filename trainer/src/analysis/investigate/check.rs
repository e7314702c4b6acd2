//! The forward check of an extension inside the training stream: fitted on the earlier part,
//! scored on the later part (and, where the static curve was fitted on the stream, beyond the
//! temperatures it was fitted on), with the blobs of each part.

use fog_data::blocks;
use fog_data::cause::Cause;
use fog_data::stream::Stream;

use crate::analysis::extend;
use crate::analysis::uncertainty::{self, Source};
use crate::data::points::Points;
use crate::firmware::export::{self, Extension};
use crate::models::gp::{GpConfig, GpModel};

use super::{
    EARLIER_MIN_BLOCKS, Forward, ForwardCheck, LATER_MIN_BLOCKS, LEG_MIN_BLOCKS, LegCheck,
    OUTER_SHARE, Rebuild, Split, TemperatureCheck, forward,
};

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
            hours: uncertainty::hours_from(&later, &fitted),
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
                hours: uncertainty::hours_from(&scored, &fit_on.referenced()),
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
    let states = uncertainty::leg_states(train);
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
            hours: uncertainty::hours_from(&scored, &fit_on.referenced()),
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
