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
//! all in O(n²) from Uᵀ1, Uᵀy and U∘U: no refit, no factorization per γ, and a whole grid of γ in
//! two matrix products. The best γ for ℓ comes from a grid over the range and finer grids around
//! its best point; Nelder–Mead (argmin) searches ln ℓ over that profile (its logarithm, so the
//! tolerance is relative) from several starts. At the Aug FOG run's 695 points one joint evaluation
//! was an (n+1)² inverse; the profile spends one eigendecomposition per ℓ and tens of O(n²) γ
//! steps (docs/performance.md).

use argmin::core::{CostFunction, Executor, State};
use argmin::solver::neldermead::NelderMead;
use nalgebra::{DMatrix, DVector};
use rayon::prelude::*;
use serde::Serialize;

use crate::models::gp::{Bounds, Prepared};
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

/// Range of ln γ searched (γ in 1e-3…1e12).
const LOG_GAMMA: (f64, f64) = (-6.9, 27.6);
/// Points of the first grid over ln γ, and of each finer grid between the best point's neighbours.
const GAMMA_GRID: usize = 24;
const GAMMA_FINE: usize = 12;
/// Finer grids after the first: each narrows the step 5.5-fold, so four leave it below 2e-3 in
/// ln γ, where the LOO error is flat to far below any digit reported.
const GAMMA_ROUNDS: usize = 4;
/// Nelder–Mead stops when the simplex's ln LOO errors spread less than this: relative, so the
/// same on a residual of 1e-3 as of 1 (normalized units). An absolute 1e-6 asked six digits of
/// the Aug FOG run's nearly flat LOO error (589 s against 61 s); 1e-3 stopped its folds early
/// enough to move the left-out-sweep error by 11% (docs/performance.md).
const LENGTH_TOLERANCE: f64 = 3e-4;

/// K's eigendecomposition at one set of length scales, with the data rotated into it: the
/// closed-form LOO at any γ from it in O(n²) (module doc).
struct Spectrum {
    values: DVector<f64>,
    /// U: H1 and Hy for a batch of γ in one product.
    vectors: DMatrix<f64>,
    /// U∘U: diag(H) for a batch of γ in one product (diag(H) = (U∘U) d).
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

    /// Mean squared closed-form LOO error at each ln γ of a batch, `None` where K + I/γ is not
    /// positive definite (an eigenvalue of K below −1/γ: numerically, at very large γ). The batch
    /// is two matrix products, U and U∘U times the spectral weights of every γ: a γ step costs a
    /// matrix–vector product's flops at a matrix product's speed.
    fn press(&self, log_gammas: &[f64]) -> Vec<Option<f64>> {
        let n = self.values.len();
        let g = log_gammas.len();
        // Columns [0, g): d∘Uᵀ1, [g, 2g): d∘Uᵀy; `spectral`: d, for every γ.
        let mut weights = DMatrix::zeros(n, 2 * g);
        let mut spectral = DMatrix::zeros(n, g);
        let mut valid = vec![true; g];
        for (c, &lg) in log_gammas.iter().enumerate() {
            let ridge = (-lg).exp();
            for k in 0..n {
                let d = 1.0 / (self.values[k] + ridge);
                valid[c] &= d.is_finite() && d > 0.0;
                weights[(k, c)] = d * self.rotated[(k, 0)];
                weights[(k, g + c)] = d * self.rotated[(k, 1)];
                spectral[(k, c)] = d;
            }
        }
        // [H1 | Hy] and diag H for every γ.
        let h = &self.vectors * &weights;
        let diag = &self.squares * &spectral;
        (0..g)
            .map(|c| {
                if !valid[c] {
                    return None;
                }
                let r1 = self.rotated.column(0);
                let s = r1.dot(&weights.column(c));
                let b = r1.dot(&weights.column(g + c)) / s;
                let sum: f64 = (0..n)
                    .map(|i| {
                        let (h1, hy) = (h[(i, c)], h[(i, g + c)]);
                        let r = (hy - b * h1) / (diag[(i, c)] - h1 * h1 / s);
                        r * r
                    })
                    .sum();
                let press = sum / n as f64;
                press.is_finite().then_some(press)
            })
            .collect()
    }

    /// The ln γ with the least LOO error in the range, and that error: the best point of a grid,
    /// then of finer grids between its neighbours.
    fn best_gamma(&self) -> Option<(f64, f64)> {
        let (mut lo, mut hi) = LOG_GAMMA;
        let mut best: Option<(f64, f64)> = None;
        for round in 0..=GAMMA_ROUNDS {
            let points = if round == 0 { GAMMA_GRID } else { GAMMA_FINE };
            let step = (hi - lo) / (points - 1) as f64;
            let grid: Vec<f64> = (0..points).map(|k| lo + step * k as f64).collect();
            let (at, press) = grid
                .iter()
                .zip(self.press(&grid))
                .filter_map(|(&g, p)| p.map(|p| (g, p)))
                .min_by(|a, b| a.1.total_cmp(&b.1))?;
            if best.is_none_or(|(_, p)| press < p) {
                best = Some((at, press));
            }
            (lo, hi) = ((at - step).max(LOG_GAMMA.0), (at + step).min(LOG_GAMMA.1));
        }
        best
    }
}

/// The tuning cost of length scales: the least LOO error over γ.
#[derive(Clone, Copy)]
struct Profile<'a> {
    z: &'a DMatrix<f64>,
    y: &'a DVector<f64>,
}

impl Profile<'_> {
    /// Nelder–Mead over ln ℓ from `start`, its first simplex one unit wide along each axis, until
    /// the simplex's costs spread less than [`LENGTH_TOLERANCE`]: the best point and its cost.
    fn descend(&self, start: &[f64]) -> Option<(Vec<f64>, f64)> {
        let simplex: Vec<Vec<f64>> = std::iter::once(start.to_vec())
            .chain((0..start.len()).map(|j| {
                let mut v = start.to_vec();
                v[j] += 1.0;
                v
            }))
            .collect();
        let solver = NelderMead::new(simplex)
            .with_sd_tolerance(LENGTH_TOLERANCE)
            .ok()?;
        let res = Executor::new(*self, solver)
            .configure(|s| s.max_iters(200))
            .run()
            .ok()?;
        let st = res.state();
        Some((st.get_best_param()?.clone(), st.get_best_cost()))
    }

    fn best(&self, log_lengths: &[f64]) -> Option<(f64, f64)> {
        let ls: Vec<f64> = log_lengths.iter().map(|t| t.exp()).collect();
        Spectrum::new(self.z, self.y, &ls)?.best_gamma()
    }
}

impl CostFunction for Profile<'_> {
    type Param = Vec<f64>;
    type Output = f64;
    fn cost(&self, log_lengths: &Vec<f64>) -> Result<f64, argmin::core::Error> {
        // The GP's range of length scales (ℓ ≥ 0.1, normalized). Below it a rate table's setpoints
        // become separate clusters, and a kernel that narrow in the output snaps each row to its
        // setpoint's value, which leave-one-out cannot see: on the Aug FOG run one fold's search
        // went there (ℓ = 0.02, LOO error 3e-6 of the residual's spread) and scored 2.8 °/h on its
        // left-out sweep against 140–250 for every other fold. Outside the range the cost is a
        // wall, not an error, so the simplex simply turns back.
        let (lo, hi) = Bounds::default().log_length;
        if !log_lengths.iter().all(|t| (lo..hi).contains(t)) {
            return Ok(1e300);
        }
        Ok(self
            .best(log_lengths)
            .map_or(1e300, |(_, press)| press.ln()))
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
            .filter_map(|l| profile.descend(&vec![l; d]))
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
        // One batch: each γ's column is its own.
        let log_gammas = [-2.0, 3.0, 9.0];
        for (log_gamma, through) in log_gammas.into_iter().zip(spectrum.press(&log_gammas)) {
            let direct = solve(&z, &y, &[0.2, -0.1, log_gamma]).unwrap();
            let press = direct.loo.iter().map(|e| e * e).sum::<f64>() / direct.loo.len() as f64;
            let through = through.unwrap();
            assert!(
                (through - press).abs() < 1e-8 * press,
                "{through} vs {press}"
            );
        }
    }

    /// A rate table's target takes a few setpoint values; its output clusters around each, here
    /// with a scatter no smooth map explains. Only a kernel narrower than the clusters' spacing
    /// snaps every row to its setpoint, so the tuning presses on the GP's bound on ℓ (it ends at
    /// 0.1000002): it must stop there.
    #[test]
    fn length_scales_keep_to_the_gps_bound_on_setpoint_clusters() {
        let n = 60;
        let rate = |i: usize| [-80.0, -20.0, 0.0, 20.0, 80.0][i % 5];
        let temp = |i: usize| -30.0 + 90.0 * ((i * 37) % n) as f64 / n as f64;
        let x = DMatrix::from_fn(n, 2, |i, j| {
            let t = temp(i);
            let wobble = 0.2 * (((i * 7919) % 101) as f64 / 101.0 - 0.5);
            if j == 0 {
                t
            } else {
                rate(i) * (1.0 + 4e-4 * t) / 26.0 + wobble
            }
        });
        let y = DVector::from_fn(n, |i, _| rate(i));
        let m = LssvrModel::fit(&x, &y, MeanBasis::Constant).unwrap();
        let (lo, _) = Bounds::default().log_length;
        for l in &m.solved.length_scales {
            assert!(l.ln() >= lo - 1e-9, "ℓ = {l} below the GP's {}", lo.exp());
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
