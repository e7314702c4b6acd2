//! Input and output normalization: models work on z-scored inputs so that length scales and
//! polynomial coefficients are O(1) whatever the units (°C, V, counts). And the trained range of
//! an input: where its data are.

use nalgebra::DMatrix;
use serde::Serialize;

/// Per-column affine map `z = (x − offset) / scale`.
#[derive(Debug, Clone, PartialEq, Serialize, schemars::JsonSchema)]
pub struct Normalizer {
    /// Column means.
    pub offset: Vec<f64>,
    /// Column standard deviations (population).
    pub scale: Vec<f64>,
}

impl Normalizer {
    /// Fits the map to the columns of `x` (rows are samples). A constant column keeps scale 1, so
    /// the map stays invertible; loaders refuse constant inputs before this is reached.
    pub fn fit(x: &DMatrix<f64>) -> Self {
        let n = x.nrows().max(1) as f64;
        let (offset, scale) = x
            .column_iter()
            .map(|c| {
                let mean = c.sum() / n;
                let var = c.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / n;
                let sd = var.sqrt();
                (mean, if sd > 0.0 { sd } else { 1.0 })
            })
            .unzip();
        Self { offset, scale }
    }

    /// Normalizes every row of `x`.
    pub fn apply(&self, x: &DMatrix<f64>) -> DMatrix<f64> {
        DMatrix::from_fn(x.nrows(), x.ncols(), |i, j| {
            (x[(i, j)] - self.offset[j]) / self.scale[j]
        })
    }

    /// Normalizes one sample.
    pub fn apply_row(&self, x: &[f64]) -> Vec<f64> {
        x.iter()
            .zip(self.offset.iter().zip(&self.scale))
            .map(|(v, (o, s))| (v - o) / s)
            .collect()
    }
}

/// Share of the values left out at each end of a trained range ([`trained_range`]).
pub const RANGE_TAIL: f64 = 0.005;

/// The trained range of an input: where its data are, not where its extremes are. The values
/// beyond the 0.5% and 99.5% quantiles (nearest rank) are left out, so a handful of blocks at the
/// edge of a long log (two stray minutes of a 74-hour log) do not make a band count as trained
/// that the model has barely seen; with fewer than 200 values it is the minimum and maximum. The
/// firmware flags a reading outside it `Extrapolating`, and its variance grows there
/// (docs/design.md §4). (NaN, NaN) for no values.
pub fn trained_range(values: impl Iterator<Item = f64>) -> (f64, f64) {
    Sorted::new(values).range_without(&[])
}

/// A column's finite values in ascending order, with their rows: the trained range of the rows
/// left in when some are left out ([`Self::range_without`]), without sorting again for each, as
/// leaving every point of a pooled table out in turn needs.
pub struct Sorted {
    values: Vec<(f64, usize)>,
    present: Vec<bool>,
}

impl Sorted {
    /// The column `values` (row i is the i-th value), sorted.
    pub fn new(values: impl Iterator<Item = f64>) -> Self {
        let mut present = Vec::new();
        let mut sorted = Vec::new();
        for (i, x) in values.enumerate() {
            present.push(x.is_finite());
            if x.is_finite() {
                sorted.push((x, i));
            }
        }
        sorted.sort_by(|a, b| a.0.total_cmp(&b.0));
        Self {
            values: sorted,
            present,
        }
    }

    /// [`trained_range`] of the rows not in `left_out`: the k-th kept value from each end of the
    /// sorted column, k from the count kept.
    pub fn range_without(&self, left_out: &[usize]) -> (f64, f64) {
        // A large group is looked up in a set, a small one (a point) in place.
        let set: Option<std::collections::HashSet<usize>> =
            (left_out.len() > 16).then(|| left_out.iter().copied().collect());
        let out = |i: usize| match &set {
            Some(s) => s.contains(&i),
            None => left_out.contains(&i),
        };
        let gone = left_out
            .iter()
            .filter(|&&i| self.present.get(i).copied().unwrap_or(false))
            .count();
        let m = self.values.len().saturating_sub(gone);
        if m == 0 {
            return (f64::NAN, f64::NAN);
        }
        let cut = (RANGE_TAIL * m as f64).floor() as usize;
        let mut kept = self.values.iter().filter(|(_, i)| !out(*i)).map(|v| v.0);
        let lo = kept.nth(cut).unwrap_or(f64::NAN);
        let hi = self
            .values
            .iter()
            .rev()
            .filter(|(_, i)| !out(*i))
            .map(|v| v.0)
            .nth(cut)
            .unwrap_or(f64::NAN);
        (lo, hi)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn columns_get_zero_mean_unit_variance() {
        let x = DMatrix::from_row_slice(4, 2, &[1.0, 10.0, 2.0, 10.0, 3.0, 10.0, 4.0, 10.0]);
        let n = Normalizer::fit(&x);
        let z = n.apply(&x);
        assert!(z.column(0).sum().abs() < 1e-12);
        assert!((z.column(0).norm_squared() / 4.0 - 1.0).abs() < 1e-12);
        assert_eq!(n.scale[1], 1.0);
        assert_eq!(n.apply_row(&[2.5, 10.0]), vec![0.0, 0.0]);
    }

    #[test]
    fn a_handful_of_values_at_the_edge_do_not_stretch_the_trained_range() {
        // 1,000 values at 30…40 and 3 stray ones at 20: not trained there.
        let mut v: Vec<f64> = (0..1000).map(|i| 30.0 + 0.01 * f64::from(i)).collect();
        v.extend([20.0, 20.5, 21.0]);
        let (lo, hi) = trained_range(v.iter().copied());
        assert!(lo > 30.0 && lo < 30.1, "{lo}");
        assert!(hi > 39.9, "{hi}");
        // A short table keeps its extremes.
        assert_eq!(trained_range([3.0, 1.0, 2.0].into_iter()), (1.0, 3.0));
    }

    #[test]
    fn a_range_without_some_rows_is_the_range_of_the_rows_left_in() {
        // 450 values in a scrambled order (every 7th missing), left out singly and in groups.
        let v: Vec<f64> = (0..450)
            .map(|i| {
                if i % 7 == 3 {
                    f64::NAN
                } else {
                    f64::from((i * 37) % 450)
                }
            })
            .collect();
        let sorted = Sorted::new(v.iter().copied());
        let groups: Vec<Vec<usize>> = vec![
            vec![],
            vec![0],
            vec![3],
            (0..40).map(|k| k * 11).collect(),
            (0..449).collect(),
        ];
        for g in groups {
            let kept = (0..v.len()).filter(|i| !g.contains(i)).map(|i| v[i]);
            let (a, b) = (sorted.range_without(&g), trained_range(kept));
            assert!(
                (a.0 == b.0 || a.0.is_nan() && b.0.is_nan())
                    && (a.1 == b.1 || a.1.is_nan() && b.1.is_nan()),
                "{g:?}: {a:?} vs {b:?}"
            );
        }
    }
}
