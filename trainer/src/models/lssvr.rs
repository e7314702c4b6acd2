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
//! The search is L-BFGS-B on ln of that error over (ln ℓ, ln γ), with its analytic gradient
//! (`loo_gradient`): one Cholesky factorization, its inverse and one symmetric matrix product
//! per step, about 2n³ flops. Each of its four starts first takes the best γ for its length scales
//! from K's eigendecomposition (`Spectrum`): with H = (K + I/γ)⁻¹ = U diag(1/(λ + 1/γ)) Uᵀ and
//! s = 1ᵀH1,
//!
//! ```text
//! b = 1ᵀHy / s,   α = H(y − b1),   [C⁻¹]_ii = H_ii − (H1)_i² / s   (i ≥ 1, the Schur complement)
//! ```
//!
//! all in O(n²) from Uᵀ1, Uᵀy and U∘U, so a whole grid of γ over its range costs two matrix
//! products: the descent starts in the right valley of γ, which is far from convex, and needs far
//! fewer eigendecompositions than a search over ln ℓ that profiles γ out at every point.

use nalgebra::{DMatrix, DVector};
use rayon::prelude::*;
use serde::Serialize;

use crate::models::gp::exact::{Stopping, optimize_from};
use crate::models::gp::{Bounds, GpError, Prepared};
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
    /// The basis the commands choose (`auto`) was asked for before it was chosen.
    #[error("{}", GpError::UnchosenBasis)]
    Unchosen,
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

/// The LS-SVR system at one K and ridge 1/γ, through a Cholesky factor of K + I/γ.
///
/// With H = (K + I/γ)⁻¹ and s = 1ᵀH1, the system's inverse C⁻¹ has P = H − H11ᵀH/s as its
/// lower-right block (the Schur complement of the border), so b = 1ᵀHy/s, α = Py, and the
/// closed-form LOO error of row i is −α_i/P_ii.
struct System {
    p: DMatrix<f64>,
    alpha: DVector<f64>,
    bias: f64,
}

impl System {
    /// `None` where K + I/γ is not positive definite.
    fn new(gram: &DMatrix<f64>, y: &DVector<f64>, ridge: f64) -> Option<Self> {
        let n = y.len();
        let mut a = gram.clone();
        for i in 0..n {
            a[(i, i)] += ridge;
        }
        let chol = dense::cholesky(a)?;
        // H1 and Hy through the factor, not the explicit inverse: at γ near 1e12 the inverse's
        // rounding moved one Oct FOG fold's predictions by thousands of °/h.
        let h1 = chol.solve(&DVector::from_element(n, 1.0));
        let hy = chol.solve(y);
        let mut p = dense::inverse_from_cholesky(&chol);
        let s = h1.sum();
        let bias = hy.sum() / s;
        let alpha = &hy - &h1 * bias;
        p.ger(-1.0 / s, &h1, &h1, 1.0);
        Some(Self { p, alpha, bias })
    }
}

/// Solves the LS-SVR system at θ = (ln ℓ…, ln γ), with its closed-form LOO errors.
pub fn solve(z: &DMatrix<f64>, y: &DVector<f64>, theta: &[f64]) -> Result<Solved, LssvrError> {
    let d = z.ncols();
    let length_scales: Vec<f64> = theta[..d].iter().map(|t| t.exp()).collect();
    let gamma = theta[d].exp();
    let xs = kernel::scale_inputs(z, &length_scales);
    let System { p, alpha, bias } = System::new(&kernel::gram(&xs), y, 1.0 / gamma)
        .filter(|s| s.alpha.iter().all(|v| v.is_finite()))
        .ok_or_else(|| LssvrError::Singular(theta.to_vec()))?;
    let loo = alpha
        .iter()
        .zip(p.diagonal().iter())
        .map(|(a, pii)| -a / pii)
        .collect();
    Ok(Solved {
        length_scales,
        gamma,
        xs,
        alpha,
        bias,
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
/// How the search over (ln ℓ, ln γ) stops: its cost is ln of the LOO error, so the
/// projected-gradient tolerance is relative. Not looser: a LOO error can vary by a few percent
/// over the whole range of ℓ, and a looser tolerance stops every start where it began.
const TUNING: Stopping = Stopping {
    tolerance: 1e-3,
    budget: 60,
    stall: true,
};
/// L-BFGS-B iterations per start, a cap the budget reaches first.
const TUNING_ITERATIONS: u32 = 100;

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

/// The mean squared closed-form LOO error at θ = (ln ℓ…, ln γ) and its gradient w.r.t. θ, from
/// one Cholesky factorization of K + I/γ, or `None` where it is not positive definite.
///
/// With P, α of [`System`] and r_i = α_i/P_ii, a change dK moves dα = −P dK α and dP_ii = −(P dK P)_ii, so
///
/// ```text
/// d mean(r²) = (2/n) Σ_jl dK_jl (M_jl − v_j α_l),   M = P diag(r²/P_ii) P,   v = P (r/P_ii)
/// ```
///
/// one symmetric matrix product, then O(n²) per length scale (dK = K ∘ (x_j − x_l)²/ℓ²) and O(n) for γ
/// (dK = −I/γ per unit of ln γ).
fn loo_gradient(z: &DMatrix<f64>, y: &DVector<f64>, theta: &[f64]) -> Option<(f64, Vec<f64>)> {
    let (n, d) = z.shape();
    let length_scales: Vec<f64> = theta[..d].iter().map(|t| t.exp()).collect();
    let ridge = (-theta[d]).exp();
    let xs = kernel::scale_inputs(z, &length_scales);
    let gram = kernel::gram(&xs);
    let System { mut p, alpha, .. } = System::new(&gram, y, ridge)?;
    let pd = p.diagonal();
    let r = alpha.component_div(&pd);
    let press = r.norm_squared() / n as f64;
    let v = &p * r.component_div(&pd);
    // M = G Gᵀ with G = P diag(|r|/√P_ii); both sums below are symmetric in (j, l) and vanish on
    // the diagonal for ℓ, so the lower triangle carries them.
    for (mut col, (ri, pi)) in p.column_iter_mut().zip(r.iter().zip(pd.iter())) {
        col *= ri.abs() / pi.sqrt();
    }
    let m = dense::outer_lower(&p);
    let scale = 2.0 / n as f64;
    let mut grad: Vec<f64> = (0..d)
        .map(|k| {
            let mut sum = 0.0;
            for l in 0..n {
                let (xl, vl, al) = (xs[(l, k)], v[l], alpha[l]);
                for j in (l + 1)..n {
                    let dx = xs[(j, k)] - xl;
                    let cross = 0.5 * (v[j] * al + vl * alpha[j]);
                    sum += gram[(j, l)] * dx * dx * (m[(j, l)] - cross);
                }
            }
            2.0 * scale * sum
        })
        .collect();
    grad.push(-scale * ridge * (0..n).map(|j| m[(j, j)] - v[j] * alpha[j]).sum::<f64>());
    (press.is_finite() && press > 0.0 && grad.iter().all(|g| g.is_finite()))
        .then_some((press, grad))
}

/// The tuning problem: the data whose closed-form LOO error the hyperparameters minimize.
#[derive(Clone, Copy)]
struct Tuning<'a> {
    z: &'a DMatrix<f64>,
    y: &'a DVector<f64>,
}

impl Tuning<'_> {
    /// L-BFGS-B over (ln ℓ, ln γ) from length scales `start` and the best γ there, within the GP's
    /// range of length scales: the best θ and its cost (ln of the mean squared LOO error).
    ///
    /// The range (ℓ ≥ 0.1, normalized) matters: below it a rate table's setpoints become separate
    /// clusters, and a kernel that narrow in the output snaps each row to its setpoint's value,
    /// which leave-one-out cannot see: such a fold's LOO error is near zero while its left-out
    /// sweep scores far worse than the others.
    fn descend(&self, start: &[f64]) -> Option<(Vec<f64>, f64)> {
        let objective = |t: &[f64]| self.objective(t);
        let (log_gamma, _) = self.best(start)?;
        let ranges: Vec<(f64, f64)> =
            std::iter::repeat_n(Bounds::default().log_length, start.len())
                .chain([LOG_GAMMA])
                .collect();
        let report = optimize_from(
            &objective,
            1,
            start.iter().copied().chain([log_gamma]).collect(),
            &ranges,
            u64::from(TUNING_ITERATIONS),
            TUNING,
        );
        Some((report.end?, -report.log_marginal_likelihood?))
    }

    /// The search's objective as the GP optimizer takes it, a value to maximize and its gradient:
    /// −ln of the mean squared LOO error at θ = (ln ℓ…, ln γ).
    fn objective(&self, theta: &[f64]) -> Result<(f64, Vec<f64>), GpError> {
        let (press, grad) = loo_gradient(self.z, self.y, theta)
            .ok_or(GpError::Unevaluable("K + I/γ is not positive definite"))?;
        Ok((-press.ln(), grad.iter().map(|g| -g / press).collect()))
    }

    /// The best ln γ at these length scales, and its LOO error: a whole grid through one
    /// eigendecomposition.
    fn best(&self, log_lengths: &[f64]) -> Option<(f64, f64)> {
        let ls: Vec<f64> = log_lengths.iter().map(|t| t.exp()).collect();
        Spectrum::new(self.z, self.y, &ls)?.best_gamma()
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
#[derive(Debug, Clone, Serialize, schemars::JsonSchema)]
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
        crate::models::gp::chosen(basis).map_err(|_| LssvrError::Unchosen)?;
        let Prepared {
            norm: input_norm,
            prior,
            scale: output_scale,
            z,
            y,
            ..
        } = Prepared::new(x, target, basis);
        let d = z.ncols();
        let tuning = Tuning { z: &z, y: &y };
        let best = [0.0, 1.0, -1.0, 2.0]
            .into_par_iter()
            .filter_map(|l| tuning.descend(&vec![l; d]))
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
        // γ = 20 and γ ≈ 5e11, where K + I/γ is nearly singular and an explicit inverse's
        // rounding would show in α.
        for log_gamma in [3.0, 27.0] {
            let s = solve(&z, &y, &[0.2, -0.1, log_gamma]).unwrap();
            assert!(s.alpha.sum().abs() < 1e-9, "Σα = {}", s.alpha.sum());
            let k = kernel::gram(&s.xs);
            let lhs = &k * &s.alpha + &s.alpha / s.gamma + DVector::from_element(25, s.bias);
            let off = (lhs - &y).amax();
            assert!(off < 1e-9, "ln γ {log_gamma}: residual {off:e}");
        }
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

    #[test]
    fn the_gradient_is_the_loo_errors_slope() {
        let (z, y) = toy();
        let theta = [0.2, -0.1, 3.0];
        let press = |t: &[f64]| {
            let loo = solve(&z, &y, t).unwrap().loo;
            loo.iter().map(|e| e * e).sum::<f64>() / loo.len() as f64
        };
        let (at, grad) = loo_gradient(&z, &y, &theta).unwrap();
        assert!(
            (at - press(&theta)).abs() < 1e-10 * at,
            "{at} vs {}",
            press(&theta)
        );
        for k in 0..theta.len() {
            let h = 1e-5;
            let moved = |sign: f64| {
                let mut t = theta;
                t[k] += sign * h;
                press(&t)
            };
            let numeric = (moved(1.0) - moved(-1.0)) / (2.0 * h);
            assert!(
                (grad[k] - numeric).abs() < 1e-6 * (1.0 + numeric.abs()),
                "θ_{k}: {} vs {numeric}",
                grad[k]
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
