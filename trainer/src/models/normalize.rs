//! Input and output normalization: models work on z-scored inputs so that length scales and
//! polynomial coefficients are O(1) whatever the units (°C, V, counts).

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
}
