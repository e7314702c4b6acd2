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
//! matrix above. They are never left at defaults.
//!
//! The search is nested, because γ is cheap once ℓ is fixed. For length scales ℓ, K = U Λ Uᵀ once
//! (`Spectrum`); then for any γ, with H = (K + I/γ)⁻¹ = U diag(1/(λ + 1/γ)) Uᵀ and s = 1ᵀH1,
//!
//! ```text
//! b = 1ᵀHy / s,   α = H(y − b1),   [C⁻¹]_ii = H_ii − (H1)_i² / s   (i ≥ 1, the Schur complement)
//! ```
//!
//! all in O(n²) from Uᵀ1, Uᵀy and U∘U: no refit, no factorization per γ. The best γ for ℓ comes
//! from a grid over the range and a golden-section refinement; Nelder–Mead (argmin) searches ℓ
//! over that profile from several starts. At the Aug FOG run's 695 points one joint evaluation
//! was an (n+1)² inverse; the profile spends one eigendecomposition per ℓ and tens of O(n²) γ
//! steps (docs/performance.md).

use argmin::core::{CostFunction, Executor, State};
use argmin::solver::neldermead::NelderMead;
use nalgebra::{DMatrix, DVector};
use rayon::prelude::*;
use serde::Serialize;

use crate::models::gp::Prepared;
use crate::models::normalize::Normalizer;
use crate::models::prior::{MeanBasis, PolyPrior};
use crate::models::{dense, kernel};

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

/// Range of ln ℓ and ln γ searched (ℓ in 1e-2…1e3, γ in 1e-3…1e12, normalized units).
const LOG_LENGTH: (f64, f64) = (-4.6, 6.9);
const LOG_GAMMA: (f64, f64) = (-6.9, 27.6);
/// Grid over ln γ before the golden-section refinement.
const GAMMA_GRID: usize = 24;
/// Golden-section steps around the grid's best point.
const GAMMA_REFINE: usize = 20;

/// K's eigendecomposition at one set of length scales, with the data rotated into it: the
/// closed-form LOO at any γ from it in O(n²) (module doc).
struct Spectrum {
    values: DVector<f64>,
    vectors: DMatrix<f64>,
    /// U∘U: diag(H) = (U∘U) d.
    squares: DMatrix<f64>,
    /// [Uᵀ1, Uᵀy].
    rotated: DMatrix<f64>,
}

impl Spectrum {
    fn new(z: &DMatrix<f64>, y: &DVector<f64>, length_scales: &[f64]) -> Option<Self> {
        let k = kernel::gram(&kernel::scale_inputs(z, length_scales));
        let (values, vectors) = dense::symmetric_eigen(&k)?;
        let n = y.len();
        let mut ones_y = DMatrix::from_element(n, 2, 1.0);
        ones_y.set_column(1, y);
        let rotated = vectors.tr_mul(&ones_y);
        let squares = vectors.component_mul(&vectors);
        Some(Self {
            values,
            vectors,
            squares,
            rotated,
        })
    }

    /// Mean squared closed-form LOO error at ln γ, or `None` where K + I/γ is not positive
    /// definite (an eigenvalue of K below −1/γ: numerically, at very large γ).
    fn press(&self, log_gamma: f64) -> Option<f64> {
        let ridge = (-log_gamma).exp();
        let d: Vec<f64> = self.values.iter().map(|l| 1.0 / (l + ridge)).collect();
        if d.iter().any(|v| !v.is_finite() || *v <= 0.0) {
            return None;
        }
        let d = DVector::from_vec(d);
        let mut scaled = self.rotated.clone();
        for mut c in scaled.column_iter_mut() {
            c.component_mul_assign(&d);
        }
        // [H1, Hy] and s = 1ᵀH1, 1ᵀHy.
        let h = &self.vectors * &scaled;
        let s = self.rotated.column(0).dot(&scaled.column(0));
        let b = self.rotated.column(0).dot(&scaled.column(1)) / s;
        let diag = &self.squares * &d;
        let n = diag.len();
        let sum: f64 = (0..n)
            .map(|i| {
                let (h1, hy) = (h[(i, 0)], h[(i, 1)]);
                let r = (hy - b * h1) / (diag[i] - h1 * h1 / s);
                r * r
            })
            .sum();
        let press = sum / n as f64;
        press.is_finite().then_some(press)
    }

    /// The ln γ with the least LOO error in the range, and that error: the best point of a grid,
    /// refined by golden section between its neighbours.
    fn best_gamma(&self) -> Option<(f64, f64)> {
        let (lo, hi) = LOG_GAMMA;
        let step = (hi - lo) / (GAMMA_GRID - 1) as f64;
        let cost = |g: f64| self.press(g).unwrap_or(f64::INFINITY);
        let (k, _) = (0..GAMMA_GRID)
            .map(|k| (k, cost(lo + step * k as f64)))
            .min_by(|a, b| a.1.total_cmp(&b.1))?;
        let (mut a, mut b) = (
            (lo + step * k as f64 - step).max(lo),
            (lo + step * k as f64 + step).min(hi),
        );
        let ratio = (5f64.sqrt() - 1.0) / 2.0;
        let (mut c, mut d) = (b - ratio * (b - a), a + ratio * (b - a));
        let (mut fc, mut fd) = (cost(c), cost(d));
        for _ in 0..GAMMA_REFINE {
            if fc < fd {
                (b, d, fd) = (d, c, fc);
                c = b - ratio * (b - a);
                fc = cost(c);
            } else {
                (a, c, fc) = (c, d, fd);
                d = a + ratio * (b - a);
                fd = cost(d);
            }
        }
        let grid_best = lo + step * k as f64;
        [(c, fc), (d, fd), (grid_best, cost(grid_best))]
            .into_iter()
            .filter(|p| p.1.is_finite())
            .min_by(|a, b| a.1.total_cmp(&b.1))
    }
}

/// The tuning cost of length scales: the least LOO error over γ.
struct Profile<'a> {
    z: &'a DMatrix<f64>,
    y: &'a DVector<f64>,
}

impl Profile<'_> {
    fn best(&self, log_lengths: &[f64]) -> Option<(f64, f64)> {
        let ls: Vec<f64> = log_lengths.iter().map(|t| t.exp()).collect();
        Spectrum::new(self.z, self.y, &ls)?.best_gamma()
    }
}

impl CostFunction for Profile<'_> {
    type Param = Vec<f64>;
    type Output = f64;
    fn cost(&self, log_lengths: &Vec<f64>) -> Result<f64, argmin::core::Error> {
        // Outside the range the cost is a wall, not an error, so the simplex simply turns back.
        let (lo, hi) = LOG_LENGTH;
        if !log_lengths.iter().all(|t| (lo..hi).contains(t)) {
            return Ok(1e300);
        }
        Ok(self.best(log_lengths).map_or(1e300, |(_, press)| press))
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
        let profile = Profile { z: &z, y: &y };
        let best = [0.0, 1.0, -1.0, 2.0]
            .into_par_iter()
            .filter_map(|l| {
                let start = vec![l; d];
                let simplex: Vec<Vec<f64>> = std::iter::once(start.clone())
                    .chain((0..d).map(|j| {
                        let mut v = start.clone();
                        v[j] += 1.0;
                        v
                    }))
                    .collect();
                let solver = NelderMead::new(simplex).with_sd_tolerance(1e-6).ok()?;
                let res = Executor::new(Profile { z: &z, y: &y }, solver)
                    .configure(|s| s.max_iters(200))
                    .run()
                    .ok()?;
                let st = res.state();
                Some((st.get_best_param()?.clone(), st.get_best_cost()))
            })
            .min_by(|a, b| a.1.total_cmp(&b.1))
            .ok_or(LssvrError::TuningFailed)?;
        let (log_gamma, _) = profile.best(&best.0).ok_or(LssvrError::TuningFailed)?;
        let theta: Vec<f64> = best.0.iter().copied().chain([log_gamma]).collect();
        let solved = solve(&z, &y, &theta)?;
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
    fn the_loo_error_through_the_eigenvalues_is_the_direct_one() {
        let (z, y) = toy();
        let spectrum = Spectrum::new(&z, &y, &[0.2f64.exp(), (-0.1f64).exp()]).unwrap();
        for log_gamma in [-2.0, 3.0, 9.0] {
            let direct = solve(&z, &y, &[0.2, -0.1, log_gamma]).unwrap();
            let press = direct.loo.iter().map(|e| e * e).sum::<f64>() / direct.loo.len() as f64;
            let through = spectrum.press(log_gamma).unwrap();
            assert!(
                (through - press).abs() < 1e-8 * press,
                "{through} vs {press}"
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
