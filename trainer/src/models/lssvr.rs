//! Least-squares support-vector regression (Suykens), the paper's rival, with the same ARD
//! squared-exponential kernel, normalization and prior mean as the GP.
//!
//! ```text
//! [ 0   1ᵀ       ] [b]   [0]
//! [ 1   K + I/γ  ] [α] = [y],      f(z) = Σ α_i k(z, z_i) + b
//! ```
//!
//! Hyperparameters (ln ℓ per input, ln γ) are tuned honestly: by minimizing the exact closed-form
//! leave-one-out error of Cawley & Talbot (2004), `r_i = α_i / [C⁻¹]_ii` with C the full system
//! matrix above, with Nelder–Mead (argmin) from several starts. They are never left at defaults.

use argmin::core::{CostFunction, Executor, State};
use argmin::solver::neldermead::NelderMead;
use nalgebra::{DMatrix, DVector};
use rayon::prelude::*;
use serde::Serialize;

use crate::models::gp::Prepared;
use crate::models::kernel;
use crate::models::normalize::Normalizer;
use crate::models::prior::{MeanBasis, PolyPrior};

/// Errors of LS-SVR fitting.
#[derive(Debug, thiserror::Error)]
pub enum LssvrError {
    /// The system matrix is singular at these hyperparameters.
    #[error("LS-SVR system singular at ln θ = {0:?}")]
    Singular(Vec<f64>),
    /// Tuning failed from every start.
    #[error("LS-SVR tuning failed from every start")]
    TuningFailed,
}

/// The LS-SVR solved at fixed hyperparameters (normalized units).
#[derive(Debug, Clone)]
pub struct Solved {
    /// Length scales, one per input.
    pub length_scales: Vec<f64>,
    /// Regularization γ.
    pub gamma: f64,
    /// Scaled training inputs.
    pub xs: DMatrix<f64>,
    /// Dual weights.
    pub alpha: DVector<f64>,
    /// Bias term.
    pub bias: f64,
    /// Closed-form LOO errors (prediction − target).
    pub loo: Vec<f64>,
}

/// Solves the LS-SVR system at θ = (ln ℓ…, ln γ), with its closed-form LOO errors.
pub fn solve(z: &DMatrix<f64>, y: &DVector<f64>, theta: &[f64]) -> Result<Solved, LssvrError> {
    let d = z.ncols();
    let n = z.nrows();
    let length_scales: Vec<f64> = theta[..d].iter().map(|t| t.exp()).collect();
    let gamma = theta[d].exp();
    let xs = kernel::scale_inputs(z, &length_scales);
    let k = kernel::gram(&xs);
    let mut c = DMatrix::zeros(n + 1, n + 1);
    for i in 0..n {
        c[(0, i + 1)] = 1.0;
        c[(i + 1, 0)] = 1.0;
        for j in 0..n {
            c[(i + 1, j + 1)] = k[(i, j)];
        }
        c[(i + 1, i + 1)] += 1.0 / gamma;
    }
    let cinv = c
        .try_inverse()
        .filter(|m| m.iter().all(|v| v.is_finite()))
        .ok_or_else(|| LssvrError::Singular(theta.to_vec()))?;
    let mut rhs = DVector::zeros(n + 1);
    rhs.rows_mut(1, n).copy_from(y);
    let sol = &cinv * rhs;
    let alpha = sol.rows(1, n).into_owned();
    let loo = (0..n).map(|i| -alpha[i] / cinv[(i + 1, i + 1)]).collect();
    Ok(Solved {
        length_scales,
        gamma,
        xs,
        alpha,
        bias: sol[0],
        loo,
    })
}

impl Solved {
    /// Prediction at one normalized sample.
    pub fn predict(&self, z: &[f64]) -> f64 {
        kernel::cross(&self.xs, z, &self.length_scales).dot(&self.alpha) + self.bias
    }
}

struct Press<'a> {
    z: &'a DMatrix<f64>,
    y: &'a DVector<f64>,
}

impl CostFunction for Press<'_> {
    type Param = Vec<f64>;
    type Output = f64;
    fn cost(&self, theta: &Vec<f64>) -> Result<f64, argmin::core::Error> {
        // Outside sane bounds (ℓ in 1e-2…1e3, γ in 1e-3…1e12) the cost is a wall, not an error,
        // so the simplex simply turns back.
        let d = self.z.ncols();
        let inside =
            theta[..d].iter().all(|t| (-4.6..6.9).contains(t)) && (-6.9..27.6).contains(&theta[d]);
        if !inside {
            return Ok(1e300);
        }
        Ok(solve(self.z, self.y, theta).map_or(1e300, |s| {
            s.loo.iter().map(|e| e * e).sum::<f64>() / s.loo.len() as f64
        }))
    }
}

/// A tuned LS-SVR in physical units.
#[derive(Debug, Clone)]
pub struct LssvrModel {
    /// Input normalization.
    pub input_norm: Normalizer,
    /// Prior mean (output units).
    pub prior: PolyPrior,
    /// Output scale.
    pub output_scale: f64,
    /// The solved system.
    pub solved: Solved,
}

/// The tuned hyperparameters, for reports.
#[derive(Debug, Clone, Serialize)]
pub struct LssvrHyper {
    /// Length scales (normalized inputs).
    pub length_scales: Vec<f64>,
    /// Regularization γ.
    pub gamma: f64,
}

impl LssvrModel {
    /// Fits and tunes the LS-SVR on raw inputs.
    pub fn fit(
        x: &DMatrix<f64>,
        target: &DVector<f64>,
        basis: MeanBasis,
    ) -> Result<Self, LssvrError> {
        let Prepared {
            norm: input_norm,
            prior,
            scale: output_scale,
            z,
            y,
            ..
        } = Prepared::new(x, target, basis);
        let d = z.ncols();
        let starts: Vec<Vec<f64>> = [(0.0, 2.0), (1.0, 6.0), (-1.0, 10.0), (2.0, 14.0)]
            .iter()
            .map(|&(l, g)| {
                let mut t = vec![l; d];
                t.push(g);
                t
            })
            .collect();
        let best = starts
            .into_par_iter()
            .filter_map(|start| {
                let simplex: Vec<Vec<f64>> = std::iter::once(start.clone())
                    .chain((0..=d).map(|j| {
                        let mut v = start.clone();
                        v[j] += 1.0;
                        v
                    }))
                    .collect();
                let solver = NelderMead::new(simplex).with_sd_tolerance(1e-6).ok()?;
                let res = Executor::new(Press { z: &z, y: &y }, solver)
                    .configure(|s| s.max_iters(400))
                    .run()
                    .ok()?;
                let st = res.state();
                Some((st.get_best_param()?.clone(), st.get_best_cost()))
            })
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .ok_or(LssvrError::TuningFailed)?;
        let solved = solve(&z, &y, &best.0)?;
        Ok(Self {
            input_norm,
            prior,
            output_scale,
            solved,
        })
    }

    /// Prediction at one raw sample.
    pub fn predict(&self, x: &[f64]) -> f64 {
        let z = self.input_norm.apply_row(x);
        self.prior.eval(&z) + self.output_scale * self.solved.predict(&z)
    }

    /// Closed-form LOO errors (prediction − target), output units.
    pub fn loo_errors(&self) -> Vec<f64> {
        self.solved
            .loo
            .iter()
            .map(|e| e * self.output_scale)
            .collect()
    }

    /// The tuned hyperparameters.
    pub fn hyper(&self) -> LssvrHyper {
        LssvrHyper {
            length_scales: self.solved.length_scales.clone(),
            gamma: self.solved.gamma,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn toy() -> (DMatrix<f64>, DVector<f64>) {
        let z = DMatrix::from_fn(25, 2, |i, j| ((i * 7 + j * 5) % 13) as f64 / 6.0 - 1.0);
        let y = DVector::from_fn(25, |i, _| (2.0 * z[(i, 0)]).sin() + z[(i, 1)]);
        (z, y)
    }

    #[test]
    fn solution_satisfies_its_linear_system() {
        let (z, y) = toy();
        let s = solve(&z, &y, &[0.2, -0.1, 3.0]).unwrap();
        assert!(s.alpha.sum().abs() < 1e-9, "Σα = {}", s.alpha.sum());
        let k = kernel::gram(&s.xs);
        let lhs = &k * &s.alpha + &s.alpha / s.gamma + DVector::from_element(25, s.bias);
        assert!((lhs - &y).amax() < 1e-9);
    }

    #[test]
    fn closed_form_loo_matches_refits() {
        let (z, y) = toy();
        let theta = [0.2, -0.1, 3.0];
        let s = solve(&z, &y, &theta).unwrap();
        for i in 0..z.nrows() {
            let keep: Vec<usize> = (0..z.nrows()).filter(|&j| j != i).collect();
            let si = solve(&z.select_rows(&keep), &y.select_rows(&keep), &theta).unwrap();
            let e = si.predict(&[z[(i, 0)], z[(i, 1)]]) - y[i];
            assert!(
                (e - s.loo[i]).abs() < 1e-8,
                "point {i}: {e} vs {}",
                s.loo[i]
            );
        }
    }

    #[test]
    fn tuning_beats_the_untuned_start() {
        let (z, y) = toy();
        let m = LssvrModel::fit(&z, &y, MeanBasis::Constant).unwrap();
        let tuned: f64 = m.solved.loo.iter().map(|e| e * e).sum();
        let data = Prepared::new(&z, &y, MeanBasis::Constant);
        let start: f64 = solve(&data.z, &data.y, &[0.0, 0.0, 2.0])
            .unwrap()
            .loo
            .iter()
            .map(|e| e * e)
            .sum();
        assert!(tuned < start, "{tuned} vs {start}");
    }
}
