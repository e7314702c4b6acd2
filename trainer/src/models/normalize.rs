//! Input and output normalization: models work on z-scored inputs so that length scales and
//! polynomial coefficients are O(1) whatever the units (°C, V, counts). And the trained range of
//! an input: where its data are.

use nalgebra::DMatrix;
use serde::Serialize;

/// Per-column affine map `z = (x − offset) / scale`.
#[derive(Debug, Clone, PartialEq, Serialize)]
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
    let mut v: Vec<f64> = values.filter(|x| x.is_finite()).collect();
    if v.is_empty() {
        return (f64::NAN, f64::NAN);
    }
    v.sort_by(f64::total_cmp);
    let cut = (RANGE_TAIL * v.len() as f64).floor() as usize;
    (v[cut], v[v.len() - 1 - cut])
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
}
