//! The one rule by which causes are chosen, for the trainer's diagnosis of a residual and for the
//! bench's twin of a measured gyro alike: best subset.
//!
//! Real logs mix effects, and mixed effects can imitate a third; adding causes one at a time would
//! lock in the imitation. So for one, two, then at most [`MAX_CAUSES`] causes, every design of that
//! size is scored afresh, all its parameters chosen again, and the best is taken when it removes at
//! least [`Bars::least`] of what the design taken before it left (the residual's sum of squares, out of
//! sample); it need not contain that design's causes. The first size that finds none ends the
//! search.
//!
//! The bars depend on the evidence. The diagnosis scores a design on two out-of-sample tests and
//! takes it only where both clear the bar ([`TWO_TESTS`]): [`MIN_SCORE`] tells a first effect from
//! autocorrelated noise, and what a true first cause leaves is noise plus the next effect, hence
//! the lower bar [`MIN_NEXT_SCORE`] after it. The twin has one forward test ([`ONE_TEST`]), so a
//! further effect must clear the same bar as the first: 19% of the sum of squares, a tenth of the
//! RMS.

use itertools::Itertools;

/// Most causes named at once.
pub const MAX_CAUSES: usize = 3;
/// Smallest share of the residual's sum of squares a first cause must remove.
pub const MIN_SCORE: f64 = 0.25;
/// Smallest share of what the causes taken so far leave that a further design must remove.
pub const MIN_NEXT_SCORE: f64 = 0.1;

/// What a design must remove of what the design before it left: the first, and each further.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Bars {
    /// The share a first cause must remove.
    pub first: f64,
    /// The share a design of more causes must remove of what the one before it left.
    pub next: f64,
}

/// The bars of a design that must clear two independent out-of-sample tests (the diagnosis).
pub const TWO_TESTS: Bars = Bars {
    first: MIN_SCORE,
    next: MIN_NEXT_SCORE,
};

/// The bars of a design scored on one forward test (the twin): a tenth of the RMS each.
pub const ONE_TEST: Bars = Bars {
    first: 0.19,
    next: 0.19,
};

impl Bars {
    /// The share a design of `size` causes must remove of what the design before it left.
    pub fn least(self, size: usize) -> f64 {
        if size == 1 { self.first } else { self.next }
    }
}

/// The share of `reference` (a sum of squares) that `sse` removes: 1 − sse/reference, 0 where
/// the reference is 0.
pub fn share(sse: f64, reference: f64) -> f64 {
    if reference > 0.0 {
        1.0 - sse / reference
    } else {
        0.0
    }
}

/// Every design of `size` of `n` candidate causes (their indices, ascending), in a fixed order.
pub fn designs(n: usize, size: usize) -> impl Iterator<Item = Vec<usize>> {
    (0..n).combinations(size)
}

/// The sizes tried with `n` candidates.
pub fn sizes(n: usize) -> std::ops::RangeInclusive<usize> {
    1..=MAX_CAUSES.min(n)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_bars_and_the_designs_follow_the_rule() {
        let t = TWO_TESTS;
        assert_eq!(
            (t.least(1), t.least(2), t.least(3)),
            (MIN_SCORE, MIN_NEXT_SCORE, MIN_NEXT_SCORE)
        );
        assert_eq!(ONE_TEST.least(1), ONE_TEST.least(3));
        assert_eq!(share(3.0, 4.0), 0.25);
        assert_eq!(share(1.0, 0.0), 0.0);
        // Five causes make 25 designs of at most three.
        let n: usize = sizes(5).map(|k| designs(5, k).count()).sum();
        assert_eq!(n, 25);
        assert_eq!(
            designs(3, 2).collect::<Vec<_>>(),
            vec![vec![0, 1], vec![0, 2], vec![1, 2]]
        );
        assert_eq!(sizes(2), 1..=2);
    }
}
