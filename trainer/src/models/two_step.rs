//! The traditional two-step model that the paper compares against: engineering practice.
//!
//! Step 1, per temperature plateau: a straight line `V = B_T + S_T · ω` through the plateau's rate
//! points gives that plateau's bias B_T and scale factor S_T. Step 2: B(T) and S(T) are each fitted
//! as a polynomial in temperature, separately. Compensation inverts the line:
//! `ω̂ = (V − B(T)) / S(T)`. The two fits' errors compound, and the line cannot follow the sine
//! response of an open-loop FOG; that is the paper's point.

use nalgebra::{DMatrix, DVector};
use serde::Serialize;

/// Errors of the two-step fit.
#[derive(Debug, thiserror::Error)]
pub enum TwoStepError {
    /// Fewer than two plateaus, or a plateau with a single rate.
    #[error(
        "two-step model needs ≥ 2 temperature plateaus with ≥ 2 rates each (found {plateaus} usable)"
    )]
    TooFewPlateaus {
        /// Usable plateaus found.
        plateaus: usize,
    },
}

/// A fitted two-step model.
#[derive(Debug, Clone, PartialEq, Serialize, schemars::JsonSchema)]
pub struct TwoStepModel {
    /// Temperature normalization (offset, scale) for the polynomials, °C.
    pub temp_norm: (f64, f64),
    /// Bias polynomial coefficients (ascending powers of normalized T), output units.
    pub bias_poly: Vec<f64>,
    /// Scale-factor polynomial coefficients, output units per °/s.
    pub scale_poly: Vec<f64>,
}

fn polyfit(t: &[f64], v: &[f64], degree: usize) -> Vec<f64> {
    let a = DMatrix::from_fn(t.len(), degree + 1, |i, j| t[i].powi(j as i32));
    a.svd(true, true)
        .solve(&DVector::from_column_slice(v), 1e-14)
        .map(|c| c.iter().copied().collect())
        .unwrap_or_else(|_| vec![0.0; degree + 1])
}

fn polyval(c: &[f64], t: f64) -> f64 {
    c.iter().rev().fold(0.0, |acc, &ci| acc * t + ci)
}

impl TwoStepModel {
    /// Fits the model to points (T, V, ω), step 1 per group `ids` (0-based: the temperature
    /// plateaus, or sweeps where the temperature never settles); polynomials of degree `degree`
    /// (capped at groups − 1).
    pub fn fit(
        temp: &[f64],
        volt: &[f64],
        rate: &[f64],
        ids: &[usize],
        degree: usize,
    ) -> Result<Self, TwoStepError> {
        let count = ids.iter().max().map_or(0, |m| m + 1);
        let (mut t_mean, mut bias, mut scale) = (Vec::new(), Vec::new(), Vec::new());
        for p in 0..count {
            let idx: Vec<usize> = (0..temp.len()).filter(|&i| ids[i] == p).collect();
            let n = idx.len() as f64;
            let mw = idx.iter().map(|&i| rate[i]).sum::<f64>() / n;
            let mv = idx.iter().map(|&i| volt[i]).sum::<f64>() / n;
            let sww: f64 = idx.iter().map(|&i| (rate[i] - mw).powi(2)).sum();
            if idx.len() < 2 || sww == 0.0 {
                continue;
            }
            let swv: f64 = idx.iter().map(|&i| (rate[i] - mw) * (volt[i] - mv)).sum();
            let s = swv / sww;
            t_mean.push(idx.iter().map(|&i| temp[i]).sum::<f64>() / n);
            scale.push(s);
            bias.push(mv - s * mw);
        }
        if t_mean.len() < 2 {
            return Err(TwoStepError::TooFewPlateaus {
                plateaus: t_mean.len(),
            });
        }
        let m = t_mean.len() as f64;
        let off = t_mean.iter().sum::<f64>() / m;
        let sc = (t_mean.iter().map(|t| (t - off).powi(2)).sum::<f64>() / m)
            .sqrt()
            .max(1e-9);
        let tn: Vec<f64> = t_mean.iter().map(|t| (t - off) / sc).collect();
        let degree = degree.min(t_mean.len() - 1);
        Ok(Self {
            temp_norm: (off, sc),
            bias_poly: polyfit(&tn, &bias, degree),
            scale_poly: polyfit(&tn, &scale, degree),
        })
    }

    /// Compensated rate for one sample.
    pub fn predict(&self, temp: f64, volt: f64) -> f64 {
        let t = (temp - self.temp_norm.0) / self.temp_norm.1;
        (volt - polyval(&self.bias_poly, t)) / polyval(&self.scale_poly, t)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::data::points::plateaus;

    #[test]
    fn exact_on_noise_free_polynomial_data() {
        let b = |t: f64| 0.002 + 1e-5 * t - 3e-7 * t * t;
        let s = |t: f64| 0.038 * (1.0 - 3e-4 * (t - 25.0) + 2e-6 * (t - 25.0).powi(2));
        let (mut temp, mut volt, mut rate) = (vec![], vec![], vec![]);
        for &t in &[-30.0, -10.0, 0.0, 20.0, 40.0, 60.0] {
            for &w in &[-80.0, -5.0, 1.0, 20.0, 80.0] {
                temp.push(t);
                rate.push(w);
                volt.push(b(t) + s(t) * w);
            }
        }
        let m = TwoStepModel::fit(&temp, &volt, &rate, &plateaus(&temp), 2).unwrap();
        for &t in &[-25.0, 33.0, 55.0] {
            for &w in &[-60.0, 0.0, 3.0, 70.0] {
                let e = m.predict(t, b(t) + s(t) * w) - w;
                assert!(e.abs() < 1e-9, "T {t} ω {w}: error {e}");
            }
        }
    }
}
