//! A strong parametric baseline for the GP: one least-squares polynomial in output and temperature,
//! ω = Σ c_ij P_i(v) P_j(t), degree 9 in the output and 3 in temperature with all cross terms.
//!
//! Why this one: a calibration engineer with a rate-table log would fit exactly this (the UWRT
//! authors' own surface is of this family, and the dataset note measured this degree pair as its
//! best), and an open-loop FOG's sine response is smooth enough for a ninth-degree polynomial to
//! follow over its range. Inputs are scaled to [−1, 1] over the training data and expanded in
//! Chebyshev polynomials, so the degree-9 design stays well conditioned without changing the
//! model (the same polynomial space as monomials).

use nalgebra::{DMatrix, DVector};
use serde::Serialize;

/// Degree in the gyro output.
pub const OUTPUT_DEGREE: usize = 9;
/// Degree in temperature.
pub const TEMPERATURE_DEGREE: usize = 3;

/// Errors of the polynomial fit.
#[derive(Debug, thiserror::Error)]
pub enum PolyError {
    /// Fewer points than coefficients.
    #[error("a polynomial with {coefficients} coefficients needs more than {points} points")]
    TooFewPoints {
        /// Coefficients.
        coefficients: usize,
        /// Points given.
        points: usize,
    },
}

/// A fitted polynomial surface.
#[derive(Debug, Clone, PartialEq, Serialize, schemars::JsonSchema)]
pub struct PolyModel {
    /// (offset, half-span) mapping the output onto [−1, 1].
    pub output_norm: (f64, f64),
    /// (offset, half-span) mapping temperature onto [−1, 1].
    pub temp_norm: (f64, f64),
    /// Coefficient of P_i(v) P_j(t) at index i·(TEMPERATURE_DEGREE + 1) + j, °/s.
    pub coefficients: Vec<f64>,
}

fn norm(x: &[f64]) -> (f64, f64) {
    let lo = x.iter().copied().fold(f64::INFINITY, f64::min);
    let hi = x.iter().copied().fold(f64::NEG_INFINITY, f64::max);
    let half = 0.5 * (hi - lo);
    (0.5 * (hi + lo), if half > 0.0 { half } else { 1.0 })
}

/// Chebyshev polynomials T_0 … T_n at x.
fn chebyshev(x: f64, n: usize) -> impl Iterator<Item = f64> {
    let (mut a, mut b) = (1.0, x);
    (0..=n).map(move |_| {
        let out = a;
        (a, b) = (b, 2.0 * x * b - a);
        out
    })
}

impl PolyModel {
    fn row(&self, temp_c: f64, output: f64) -> Vec<f64> {
        let v = (output - self.output_norm.0) / self.output_norm.1;
        let t = (temp_c - self.temp_norm.0) / self.temp_norm.1;
        let tt: Vec<f64> = chebyshev(t, TEMPERATURE_DEGREE).collect();
        chebyshev(v, OUTPUT_DEGREE)
            .flat_map(|pv| tt.iter().map(move |pt| pv * pt))
            .collect()
    }

    /// Least squares on points (T, output, ω).
    pub fn fit(temp: &[f64], output: &[f64], rate: &[f64]) -> Result<Self, PolyError> {
        let k = (OUTPUT_DEGREE + 1) * (TEMPERATURE_DEGREE + 1);
        if temp.len() <= k {
            return Err(PolyError::TooFewPoints {
                coefficients: k,
                points: temp.len(),
            });
        }
        let mut model = Self {
            output_norm: norm(output),
            temp_norm: norm(temp),
            coefficients: vec![0.0; k],
        };
        let rows: Vec<Vec<f64>> = temp
            .iter()
            .zip(output)
            .map(|(t, v)| model.row(*t, *v))
            .collect();
        let a = DMatrix::from_fn(rows.len(), k, |i, j| rows[i][j]);
        model.coefficients = a
            .svd(true, true)
            .solve(&DVector::from_column_slice(rate), 1e-12)
            .map(|c| c.iter().copied().collect())
            .unwrap_or_else(|_| vec![0.0; k]);
        Ok(model)
    }

    /// Compensated rate at (T, output), °/s.
    pub fn predict(&self, temp_c: f64, output: f64) -> f64 {
        self.row(temp_c, output)
            .iter()
            .zip(&self.coefficients)
            .map(|(a, c)| a * c)
            .sum()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn chebyshev_follows_the_recurrence() {
        let c: Vec<f64> = chebyshev(0.5, 3).collect();
        assert_eq!(c, vec![1.0, 0.5, -0.5, -1.0]);
    }

    #[test]
    fn a_sine_response_with_a_temperature_scale_factor_is_recovered() {
        let mut t = Vec::new();
        let mut v = Vec::new();
        let mut w = Vec::new();
        for i in 0..12 {
            for j in -20..=20 {
                let temp = 40.0 + i as f64;
                let rate = 7.5 * j as f64;
                t.push(temp);
                w.push(rate);
                v.push((rate / 200.0).sin() * (1.0 - 4e-4 * (temp - 40.0)));
            }
        }
        let m = PolyModel::fit(&t, &v, &w).unwrap();
        let worst = (0..t.len())
            .map(|i| (m.predict(t[i], v[i]) - w[i]).abs())
            .fold(0.0, f64::max);
        assert!(worst < 1e-3, "{worst}");
        assert!(PolyModel::fit(&t[..40], &v[..40], &w[..40]).is_err());
    }
}
