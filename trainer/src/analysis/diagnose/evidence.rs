//! The out-of-sample evidence: interleaved and forward-in-time splits of the blocks, the score of
//! a design on them, and whether a test can see a candidate at all.

use super::regression::{Candidates, Constant, ols, predict};
use fog_data::stats::spread;

/// Blocks per chunk of the cross-validation (10 minutes of 60 s blocks).
pub(super) const CHUNK_BLOCKS: usize = 10;
/// Folds of the cross-validation.
pub(super) const FOLDS: usize = 5;
/// Origins of the forward test, as fractions of the blocks (module doc).
pub(super) const FORWARD_ORIGINS: [f64; 4] = [0.5, 0.625, 0.75, 0.875];
/// Share of a regressor's spread over the whole stream that it must show in the blocks a test
/// scores for the test to see it (module doc: below, the test abstains).
pub const VISIBLE: f64 = 0.2;
/// Worsening of an RMS error, as a fraction, counted as harm: by a test that cannot see a cause
/// ([`raises`]; module doc), in the diagnosis and the extension's checks in
/// [`crate::analysis::investigate`] alike, and by the challenge on the held-out stream.
pub const HARM: f64 = 0.02;
/// Fewest training blocks a split needs to be scored.
pub(super) const MIN_TRAIN_BLOCKS: usize = 5;

/// A training/test split of the blocks.
pub(super) type Split = (Vec<usize>, Vec<usize>);

/// The interleaved splits: 10-minute chunks, chunk k in fold k mod 5 (module doc).
pub(super) fn interleaved_splits(n: usize) -> Vec<Split> {
    let folds: Vec<usize> = (0..n).map(|b| (b / CHUNK_BLOCKS) % FOLDS).collect();
    (0..FOLDS)
        .map(|f| {
            (
                (0..n).filter(|&i| folds[i] != f).collect(),
                (0..n).filter(|&i| folds[i] == f).collect(),
            )
        })
        .collect()
}

/// The forward splits (rolling origin): the blocks before each origin in [`FORWARD_ORIGINS`]
/// train, the blocks up to the next origin (or the end) test.
pub(super) fn forward_splits(n: usize) -> Vec<Split> {
    let cut = |f: f64| ((f * n as f64).round() as usize).min(n);
    FORWARD_ORIGINS
        .iter()
        .enumerate()
        .map(|(k, &o)| {
            let end = FORWARD_ORIGINS.get(k + 1).map_or(n, |&e| cut(e));
            ((0..cut(o)).collect(), (cut(o)..end).collect())
        })
        .collect()
}

/// Whether a split is scored: enough training blocks, and some to test.
fn scorable((train, test): &Split) -> bool {
    train.len() >= MIN_TRAIN_BLOCKS && !test.is_empty()
}

/// Test-set SSE of a design (the causes' candidate regressors, in order) and of the intercept
/// alone, summed over `splits`. On each split's training blocks alone, each cause's parameter is
/// chosen by grid in turn, given those chosen before it, and the coefficients by least squares.
/// `centred` takes each model's mean test residual out per split: what a test that cannot see a
/// design judges harm on (module doc).
pub(super) fn split_sse(
    y: &[f64],
    constant: Constant<'_>,
    design: &[&Candidates],
    splits: &[Split],
    centred: bool,
) -> (f64, f64) {
    let sum_sq = |r: &[f64]| {
        let m = if centred {
            r.iter().sum::<f64>() / r.len().max(1) as f64
        } else {
            0.0
        };
        r.iter().map(|v| (v - m).powi(2)).sum::<f64>()
    };
    let mut sse = 0.0;
    let mut sse_none = 0.0;
    for (train, test) in splits.iter().filter(|s| scorable(s)) {
        let xs = choose(y, constant, design, train);
        let (beta, _) = ols(constant, &xs, y, train);
        let (mean, _) = ols(Constant::Intercept, &[], y, train);
        let r: Vec<f64> = test
            .iter()
            .map(|&i| y[i] - predict(constant, &beta, &xs, i))
            .collect();
        let r0: Vec<f64> = test.iter().map(|&i| y[i] - mean[0]).collect();
        sse += sum_sq(&r);
        sse_none += sum_sq(&r0);
    }
    (sse, sse_none)
}

/// Each cause's regressor at the parameter that best fits `idx`, chosen in design order, each
/// given those before it; a cause without a regressor (`none`) adds nothing.
pub(super) fn choose<'c>(
    y: &[f64],
    constant: Constant<'_>,
    design: &[&'c Candidates],
    idx: &[usize],
) -> Vec<&'c [f64]> {
    let mut xs: Vec<&[f64]> = Vec::new();
    for candidates in design {
        let best = candidates
            .iter()
            .filter_map(|(_, x)| x.as_deref())
            .map(|x| {
                let mut with = xs.clone();
                with.push(x);
                (x, ols(constant, &with, y, idx).1)
            })
            .min_by(|a, b| a.1.total_cmp(&b.1));
        if let Some((x, _)) = best {
            xs.push(x);
        }
    }
    xs
}

/// The parameter of the last cause of `design` chosen on every block, given the others.
pub(super) fn chosen_parameter(y: &[f64], constant: Constant<'_>, design: &[&Candidates]) -> f32 {
    let all: Vec<usize> = (0..y.len()).collect();
    let xs = choose(y, constant, design, &all);
    let (Some(last), Some(x)) = (design.last(), xs.last()) else {
        return 0.0;
    };
    last.iter()
        .find(|(_, c)| c.as_deref().is_some_and(|c| std::ptr::eq(c, *x)))
        .map_or(0.0, |(p, _)| *p)
}

/// Whether `values` moves in `scored` (indices) by at least [`VISIBLE`] of its spread over all
/// of them: whether a test scoring `scored` can see what `values` carries.
pub fn sees(values: &[f64], scored: &[usize]) -> bool {
    let all = spread(values);
    let part = spread(
        &scored
            .iter()
            .filter_map(|&i| values.get(i).copied())
            .collect::<Vec<_>>(),
    );
    all > 0.0 && part >= VISIBLE * all
}

/// What blind harm ([`blind_harm`]) is weighed against: the design taken before (the intercept
/// alone before the first cause), its centred error on the forward test's later blocks and what
/// it leaves of the whole stream.
pub(super) struct Before {
    /// Its forward test-set SSE, each split's mean taken out ([`split_sse`], centred).
    sse: f64,
    /// The spread (RMS about the mean) of what it leaves of `y`, fitted on every block.
    left: f64,
    /// Blocks the forward test scores: what `sse`, and a design's beside it, is per block.
    tested: f64,
}

impl Before {
    /// The design `design` over `constant`, taken before the designs it will judge.
    pub(super) fn new(y: &[f64], constant: Constant<'_>, design: &[&Candidates]) -> Self {
        let all: Vec<usize> = (0..y.len()).collect();
        let xs = choose(y, constant, design, &all);
        let (beta, _) = ols(constant, &xs, y, &all);
        let left: Vec<f64> = all
            .iter()
            .map(|&i| y[i] - predict(constant, &beta, &xs, i))
            .collect();
        let splits = forward_splits(y.len());
        Self {
            sse: split_sse(y, constant, design, &splits, true).0,
            left: spread(&left),
            tested: splits
                .iter()
                .filter(|s| scorable(s))
                .map(|(_, test)| test.len())
                .sum::<usize>() as f64,
        }
    }
}

/// Whether a design the forward test cannot see still harms there: fitted on the earlier blocks,
/// it leaves the later ones more error than `before`, the design taken before it, each with its
/// mean over them taken out (the design's intercept, fitted beside a transient on the earlier
/// blocks alone, is not the one fitted on the whole stream), by enough to count as harm
/// ([`raises`]: weighed against what `before` leaves of the whole stream where the later blocks
/// are quieter; module doc). A design of further causes is judged against the design taken, as
/// the interleaved test judges it: weighed against the static residual, a wrong second cause
/// could hide behind the first cause's size.
pub(super) fn blind_harm(
    y: &[f64],
    constant: Constant<'_>,
    design: &[&Candidates],
    before: &Before,
) -> bool {
    let (sse, _) = split_sse(y, constant, design, &forward_splits(y.len()), true);
    raises(
        (sse - before.sse) / before.tested,
        before.sse / before.tested,
        before.left.powi(2),
    )
}

/// Whether `extra`, a mean square a design adds per block to the part a test scores, is harm:
/// whether it raises the larger of that part's own error (mean square `own`) and the training
/// stream's residual about its mean (`stream`, per 60 s block: the static model's, or in the
/// diagnosis what the design taken before leaves) by more than [`HARM`] in RMS
/// (module doc). Never stricter than the part's own error, and a quiet part is not held to the
/// noise of a 60 s mean. Harm where the figures are not numbers, or added to no error at all.
pub fn raises(extra: f64, own: f64, stream: f64) -> bool {
    if extra.is_nan() {
        return true;
    }
    if extra <= 0.0 {
        return false;
    }
    let reference = own.max(stream);
    reference.is_nan() || reference <= 0.0 || (1.0 + extra / reference).sqrt() - 1.0 > HARM
}

/// Whether the forward test sees `design`: some cause's regressor, at its parameter chosen on all
/// blocks, moves in the blocks the test predicts (module doc).
pub(super) fn forward_sees(y: &[f64], constant: Constant<'_>, design: &[&Candidates]) -> bool {
    let n = y.len();
    let all: Vec<usize> = (0..n).collect();
    let tested: Vec<usize> = forward_splits(n)
        .into_iter()
        .flat_map(|(_, test)| test)
        .collect();
    choose(y, constant, design, &all)
        .iter()
        .any(|x| sees(x, &tested))
}
