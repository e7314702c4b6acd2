//! A training stream cut for the checks and the σ: forward in time ([`forward`]), across
//! temperature, by heating/cooling leg and by power-on ([`splits`]), with the static model and
//! the extension fitted on one part and scored on the other ([`Split`]), and what a part could
//! see of the extension ([`Sight`]).

use fog_data::cause::Cause;
use fog_data::replay;
use fog_data::stats::rms;
use fog_data::stream::{Stream, TimeIssue, Window};
use serde::Serialize;

use crate::analysis::diagnose;
use crate::analysis::extend;
use crate::analysis::uncertainty::{self, ResidualSource};
use crate::data::points::Points;
use crate::firmware::export::{self, Extension};
use crate::models::gp::{GpConfig, GpModel};

/// Makes the static points from part of a training stream as from all of it (a table's: as is).
pub type Rebuild<'a> = dyn Fn(&Stream) -> anyhow::Result<Points> + 'a;

/// A training stream's static model and what it was fitted on, as every split refits it
/// without the part it scores ([`splits`], [`power_on_splits`]).
#[derive(Clone, Copy)]
pub struct Fitted<'a> {
    /// The static model's points.
    pub points: &'a Points,
    /// The static model.
    pub model: &'a GpModel,
    /// The training stream.
    pub train: &'a Stream,
    /// The GP's settings.
    pub cfg: &'a GpConfig,
    /// The static points of part of the stream, as `points` were made from all of it.
    pub rebuild: &'a Rebuild<'a>,
}

/// Fewest 60 s blocks the earlier part of a forward check holds (an extension needs 30).
pub(super) const EARLIER_MIN_BLOCKS: usize = 30;

/// Fewest 60 s blocks the later part of a forward check holds.
pub(super) const LATER_MIN_BLOCKS: usize = 8;

/// Share of the training stream's blocks the earlier part holds, when it is long enough.
const EARLIER_SHARE: f64 = 2.0 / 3.0;

/// Fewest 60 s blocks a stream cut forward in time holds: [`forward`] cuts every stream this
/// long (its later part then holds at least [`LATER_MIN_BLOCKS`]) and no shorter one.
pub(crate) const FORWARD_MIN_BLOCKS: usize = EARLIER_MIN_BLOCKS + LATER_MIN_BLOCKS;

/// Share of the training stream's temperature span left out at each end by the temperature check
/// ([`super::TemperatureCheck`]): a fifth of the span in all, as a wider cut leaves a 40-minute log fewer
/// than the 30 blocks an extension needs inside.
const OUTER_SHARE: f64 = 0.1;

/// Fewest 60 s blocks of one heating/cooling leg a leg check fits on ([`super::LegCheck`]): a quarter
/// hour of the leg.
const LEG_MIN_BLOCKS: usize = 15;

/// A model fitted on part of the training stream and the rest it is scored on.
pub struct Split {
    /// The test: forward in time, across temperature, across legs, or a power-on left out.
    pub source: ResidualSource,
    /// The training stream with its reference only where scored (replayed whole, so the stateful
    /// inputs keep their history).
    pub scored: Stream,
    /// Hours from each sample to the data fitted (NaN where fitted); for a power-on left out,
    /// hours since its power-on, as for a run the model never saw.
    pub hours: Vec<f64>,
    /// The static model fitted without the scored part (a rate table's, where there is one).
    pub static_blob: Vec<u8>,
    /// The extension of the named causes fitted without it, where causes were named.
    pub extended_blob: Option<Vec<u8>>,
    /// For a leg split ([`ResidualSource::Leg`]): the leg fitted on, and the 60 s blocks fitted
    /// on and scored.
    pub leg: Option<(&'static str, usize, usize)>,
}

impl Split {
    /// `rmse_60s_dps` of the static model and of the extension (the static one's where none),
    /// and whether the scored part exercised the extension: its contribution (extended − static,
    /// 60 s means over the whole stream) moves in the scored blocks ([`diagnose::sees`]).
    pub(super) fn scores(&self) -> anyhow::Result<(f64, f64, Sight)> {
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
        // The window's samples: the history before it is no part of any test.
        let all: Vec<usize> = self.scored.inside().collect();
        let blocks = self.scored.half_filled_blocks(&all);
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
    let blocks = stream.half_filled_blocks(&stream.referenced());
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

/// What a test could see of an extension.
#[derive(Debug, Clone, Copy, Serialize, schemars::JsonSchema)]
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

/// The models of a training stream's splits: forward in time; where the static model is fitted
/// on the stream itself, across temperature ([`super::TemperatureCheck`]); and across
/// heating/cooling legs. Each is the static model fitted without the scored part (a rate
/// table's model as it is) and its extension by `causes` (none without causes). A split the
/// stream is too short for is left out. The σ's own, each power-on left out, are
/// [`power_on_splits`]: no check reads them, and each design checked would refit them.
pub fn splits(fitted: Fitted<'_>, causes: &[Cause]) -> anyhow::Result<Vec<Split>> {
    let Fitted {
        points,
        model,
        train,
        cfg,
        rebuild,
    } = fitted;
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
            source: ResidualSource::Forward,
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
                source: ResidualSource::Temperature,
                hours: uncertainty::streams::hours_from(&scored, &fit_on.referenced()),
                scored,
                static_blob,
                extended_blob,
                leg: None,
            });
        }
    }
    out.extend(leg_splits(fitted, causes)?);
    Ok(out)
}

/// The power-on splits of a training stream, for the σ of the design shipped (`causes`, as
/// [`splits`] takes them): where it holds at least [`uncertainty::MIN_POWER_ONS`] power-ons (a
/// jump back in time or a gap of 5 minutes starts one) with 8 blocks each, each power-on left
/// out in turn, the static model and the extension fitted on the others (at least 30 blocks)
/// and scored on it, in hours since its power-on, as a run the model never saw. Its residuals carry its own turn-on bias and
/// scale, so the σ measures another power-on's where the stream holds several, as `loo --run`
/// does a table's runs, rather than assume it. None for a stream of one power-on.
pub fn power_on_splits(fitted: Fitted<'_>, causes: &[Cause]) -> anyhow::Result<Vec<Split>> {
    let Fitted {
        points,
        model,
        train,
        cfg,
        rebuild,
    } = fitted;
    let of = power_on_of_each(train);
    let count = |s: &Stream| s.half_filled_blocks(&s.referenced()).len();
    let parts: Vec<(Stream, Stream)> = (0..=of.last().copied().unwrap_or(0))
        .map(|p| {
            let (mut fit_on, mut scored) = (train.clone(), train.clone());
            for (i, &q) in of.iter().enumerate() {
                if q == p {
                    fit_on.rate_dps[i] = f64::NAN;
                } else {
                    scored.rate_dps[i] = f64::NAN;
                }
            }
            (fit_on, scored)
        })
        .filter(|(fit_on, scored)| {
            count(fit_on) >= EARLIER_MIN_BLOCKS && count(scored) >= LATER_MIN_BLOCKS
        })
        .collect();
    if parts.len() < uncertainty::MIN_POWER_ONS {
        return Ok(Vec::new());
    }
    parts
        .into_iter()
        .map(|(fit_on, scored)| {
            let (static_model, static_points) = static_on(points, model, &fit_on, cfg, rebuild)?;
            let (static_blob, extended_blob) =
                split_blobs(&static_model, &static_points, &fit_on, causes)?;
            Ok(Split {
                source: ResidualSource::PowerOn,
                hours: uncertainty::streams::hours_on(&scored),
                scored,
                static_blob,
                extended_blob,
                leg: None,
            })
        })
        .collect()
}

/// The leg splits of [`splits`]: the static model and its extension fitted on the samples of one
/// heating/cooling leg and scored on the other's, each way the stream holds
/// [`LEG_MIN_BLOCKS`] blocks of one leg and [`LATER_MIN_BLOCKS`] of the other. A sample
/// before the temperature first moved is on neither leg. Where the static model is a rate
/// table's, it is kept and the extension alone is fitted on the leg. None for hysteresis, whose
/// input, the leg itself, holds one value on one leg: no fit on one leg can see it.
fn leg_splits(fitted: Fitted<'_>, causes: &[Cause]) -> anyhow::Result<Vec<Split>> {
    let Fitted {
        points,
        model,
        train,
        cfg,
        rebuild,
    } = fitted;
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
        let count = |s: &Stream| s.half_filled_blocks(&s.referenced()).len();
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
            source: ResidualSource::Leg,
            hours: uncertainty::streams::hours_from(&scored, &fit_on.referenced()),
            scored,
            static_blob,
            extended_blob,
            leg: Some((name, fitted_blocks, scored_blocks)),
        });
    }
    Ok(out)
}

impl Split {
    /// Its scored part of `train` less the power-ons none of whose samples its models were
    /// fitted on: where power-ons are left out in turn ([`power_on_splits`]), their bias is
    /// measured there, and this split's residuals in such a power-on would count it again in
    /// the floor.
    pub fn within_power_ons_seen(&self, train: &Stream) -> Stream {
        let of = power_on_of_each(train);
        let seen: std::collections::HashSet<usize> = (0..train.len())
            .filter(|&i| self.hours[i].is_nan() && train.rate_dps[i].is_finite())
            .map(|i| of[i])
            .collect();
        let mut scored = self.scored.clone();
        for (rate, p) in scored.rate_dps.iter_mut().zip(&of) {
            if !seen.contains(p) {
                *rate = f64::NAN;
            }
        }
        scored
    }
}

/// Shortest break in a log's time the power-on splits take for a power-off: a jump back (the
/// clock restarted) is one whatever its size. A shorter gap may be a logger's pause, and a pause
/// taken for a power-on would measure a turn-on bias of next to nothing; the firmware's stateful
/// inputs restart at any gap, as a power cycle's would ([`replay::restarts`]).
const MIN_OFF_S: f64 = 300.0;

/// The power-on each sample of `train` belongs to, counted from 0 at its start: a new one after
/// each jump back in time, and each gap of at least [`MIN_OFF_S`].
fn power_on_of_each(train: &Stream) -> Vec<usize> {
    let starts: std::collections::HashSet<u64> = train
        .time_issues
        .iter()
        .filter(|issue| match issue {
            TimeIssue::Backwards { .. } => true,
            TimeIssue::Gap { step_s, .. } => *step_s >= MIN_OFF_S,
            TimeIssue::Duplicate { .. } => false,
        })
        .map(TimeIssue::line)
        .collect();
    let mut power_on = 0;
    train
        .lines
        .iter()
        .enumerate()
        .map(|(i, line)| {
            power_on += usize::from(i > 0 && starts.contains(line));
            power_on
        })
        .collect()
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
    let (lo, hi) = fog_data::stats::extent(train.referenced().into_iter().map(|i| train.temp_c[i]));
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
    let inside_blocks = inside.half_filled_blocks(&inside.referenced()).len();
    let outside_blocks = outside.half_filled_blocks(&outside.referenced()).len();
    (inside_c, inside_blocks, outside_blocks)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 1 Hz stream of `n` samples whose time steps by `step` s at each of the `jumps`
    /// (sample, step), as the loader reports it.
    fn stream(n: usize, jumps: &[(usize, f64)]) -> Stream {
        let (mut time_s, mut time_issues, mut t) = (Vec::new(), Vec::new(), 0.0);
        for i in 0..n {
            let line = i as u64 + 2;
            match jumps.iter().find(|(at, _)| *at == i) {
                Some(&(_, step_s)) => {
                    t += step_s;
                    time_issues.push(if step_s < 0.0 {
                        TimeIssue::Backwards { line, step_s }
                    } else if step_s == 0.0 {
                        TimeIssue::Duplicate { line }
                    } else {
                        TimeIssue::Gap { line, step_s }
                    });
                }
                None if i > 0 => t += 1.0,
                None => {}
            }
            time_s.push(t);
        }
        Stream {
            time_s,
            temp_c: vec![20.0; n],
            voltage_v: vec![0.0; n],
            rate_dps: vec![0.0; n],
            lines: (2..n as u64 + 2).collect(),
            step_s: 1.0,
            time_issues,
            handled: vec![],
            history: 0,
            after_s: None,
        }
    }

    #[test]
    fn a_power_on_starts_at_a_jump_back_or_a_long_gap_but_not_at_a_pause() {
        let s = stream(10, &[(2, 299.0), (4, MIN_OFF_S), (6, -50.0), (8, 0.0)]);
        assert_eq!(power_on_of_each(&s), [0, 0, 0, 0, 1, 1, 2, 2, 2, 2]);
    }

    #[test]
    fn a_split_keeps_to_the_power_ons_its_models_were_fitted_on() {
        let s = stream(9, &[(3, 600.0), (6, 600.0)]);
        // Fitted on samples 0, 1 and 7, and on 3, which has no reference: the second power-on
        // (3–5) was not fitted on.
        let mut train = s.clone();
        train.rate_dps[3] = f64::NAN;
        let mut hours = vec![0.1; 9];
        for i in [0, 1, 3, 7] {
            hours[i] = f64::NAN;
        }
        let split = Split {
            source: ResidualSource::Forward,
            scored: s,
            hours,
            static_blob: Vec::new(),
            extended_blob: None,
            leg: None,
        };
        let kept = split.within_power_ons_seen(&train);
        let scored: Vec<bool> = kept.rate_dps.iter().map(|r| r.is_finite()).collect();
        assert_eq!(
            scored,
            [true, true, true, false, false, false, true, true, true]
        );
    }
}
