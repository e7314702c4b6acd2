//! Exact Gaussian-process regression as in the reference paper (He et al.), with the numerics of
//! Rasmussen & Williams (R&W), *Gaussian Processes for Machine Learning*, 2006.
//!
//! Model, on normalized inputs z and output y = (ω − H c₀) / s_y (c₀: ordinary least squares of
//! the prior-mean basis H, [`crate::models::prior`]; s_y: the spread of its residual):
//!
//! ```text
//! y = Hβ + f(z) + ε,  f ~ GP(0, k),  ε ~ N(0, σ_n²),  β with a vague prior (R&W §2.7)
//! K = k(Z, Z) + σ_n² I = L Lᵀ,   L⁻¹H = QR,   P = K⁻¹ − K⁻¹H (HᵀK⁻¹H)⁻¹ HᵀK⁻¹
//! β̂ = R⁻¹ Qᵀ L⁻¹ y  (generalized least squares),   α = P y = K⁻¹ (y − Hβ̂)
//! mean      μ(z*) = h*ᵀβ̂ + k*ᵀ α                          (paper eq. 8 with the basis, R&W eq. 2.41)
//! variance  σ²(z*) = k(z*, z*) − vᵀv,  L v = k*            (paper eq. 9, R&W eq. 2.26)
//! log ML    −½ yᵀα − Σ log L_ii − Σ log |R_ii| − (n−p)/2 log 2π   (restricted, R&W eq. 2.45)
//! gradient  ∂/∂θ_j = ½ tr((ααᵀ − P) ∂K/∂θ_j)              (paper eq. 12 with K⁻¹ → P)
//! LOO       y_i − μ_{−i} = α_i / P_ii,  σ²_{−i} = 1/P_ii    (R&W eq. 5.12, β̂ re-estimated per fold)
//! ```
//!
//! Without a basis (p = 0) P = K⁻¹ and these are the paper's equations. The variance leaves out
//! the uncertainty of β̂ (R&W eq. 2.42's extra term): it is what the firmware evaluates, and inside
//! the trained range it is small next to the GP's.
//!
//! With per-group offsets (runs, sweeps, power-ons; [`super::GpModel::fit_grouped`]) K gains σ_g²
//! B, B_ij = 1 where samples i and j share a group, and θ gains ln σ_g. Cross covariances k* never
//! carry it: a prediction is for a run whose offset is unknown, as on the firmware.
//!
//! θ = (ln ℓ_1 … ln ℓ_d, ln σ_f, ln σ_n), maximized with L-BFGS-B (`rcompat-lbfgsb`, the
//! box-constrained quasi-Newton method scikit-learn's GP also uses) from several starts in
//! parallel, the paper's (all zero) among them, at a loose tolerance; then a short polish from the
//! best at a tight one. A run also stops once its gains sink below the likelihood's rounding, which
//! ill-conditioned K (tiny σ_n) makes coarse. The bounds are the method's own: no trial step leaves
//! them, so none builds a non-finite K, and a line search that meets one stops there instead of
//! overshooting into it (with L-BFGS and a penalty wall it did, docs/performance.md). The bounds
//! keep ℓ ≥ 0.1 and σ_f ≤ 10 (normalized units): below 0.1 each rate
//! level becomes its own independent GP, and above 10 the GP and the basis trade off along a ridge
//! with huge cancelling weights (f32 study). The closed-form LOO holds θ fixed (as R&W §5.4.2
//! does).

use std::cell::RefCell;
use std::fmt;
use std::str::FromStr;

use nalgebra::{Cholesky, DMatrix, DVector, Dyn};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use rcompat_lbfgsb::{Bounds as BoxBounds, OptimControl, optim_lbfgsb_with_gradient};
use serde::Serialize;

use crate::models::dense;
use crate::models::kernel;
use crate::models::normalize::Normalizer;
use crate::models::prior::{MeanBasis, PolyPrior, design};

/// Errors of GP fitting.
#[derive(Debug, thiserror::Error)]
pub enum GpError {
    /// The covariance matrix stayed indefinite even with the largest jitter tried.
    #[error("covariance matrix not positive definite even with jitter {jitter:e}")]
    NotPositiveDefinite {
        /// Largest diagonal jitter tried.
        jitter: f64,
    },
    /// Every optimizer start failed.
    #[error("hyperparameter optimization failed from every start: {0}")]
    OptimizerFailed(String),
    /// Too few samples to fit.
    #[error("{0} training samples; at least 3 are needed")]
    TooFewSamples(usize),
    /// A GP was to be polished on other data than it was fitted on.
    #[error("a GP fitted on {fitted} samples cannot be polished on {given}")]
    NotItsData {
        /// Samples it was fitted on.
        fitted: usize,
        /// Samples given.
        given: usize,
    },
    /// The prior-mean basis is rank-deficient on the training inputs.
    #[error(
        "the prior-mean basis is degenerate on these inputs (collinear monomials): \
         choose a smaller one with --mean"
    )]
    DegenerateBasis,
    /// Extra prior-mean columns or per-group offsets asked of a sparse GP.
    #[error(
        "{0} samples take a sparse GP, which carries no extra prior-mean terms or group offsets: \
         fit on fewer samples (--inducing exact)"
    )]
    ExactOnly(usize),
    /// An objective other than the likelihood (LS-SVR's LOO error) cannot be evaluated here.
    #[error("{0}")]
    Unevaluable(&'static str),
}

/// Box bounds on the log-hyperparameters (normalized units).
#[derive(Debug, Clone, Copy, Serialize)]
pub struct Bounds {
    /// ln ℓ range.
    pub log_length: (f64, f64),
    /// ln σ_f range.
    pub log_signal: (f64, f64),
    /// ln σ_n range.
    pub log_noise: (f64, f64),
    /// ln σ_g range (per-group offsets).
    pub log_offset: (f64, f64),
}

impl Default for Bounds {
    fn default() -> Self {
        Self {
            log_length: (0.1f64.ln(), 1e3f64.ln()),
            log_signal: (1e-3f64.ln(), 10f64.ln()),
            log_noise: (1e-6f64.ln(), 1e1f64.ln()),
            log_offset: (1e-4f64.ln(), 1e1f64.ln()),
        }
    }
}

impl Bounds {
    /// Range of θ's entry `j` for a model of `d` inputs.
    fn range(&self, d: usize, j: usize) -> (f64, f64) {
        match j {
            j if j < d => self.log_length,
            j if j == d => self.log_signal,
            j if j == d + 1 => self.log_noise,
            _ => self.log_offset,
        }
    }

    /// The ranges of a θ of `params` entries for a model of `d` inputs.
    pub(crate) fn ranges(&self, d: usize, params: usize) -> Vec<(f64, f64)> {
        (0..params).map(|j| self.range(d, j)).collect()
    }
}

/// Fit settings.
#[derive(Debug, Clone, Serialize)]
pub struct GpConfig {
    /// Random starts in addition to the paper's start (all zero) and a data-informed one.
    pub random_starts: usize,
    /// Seed of the random starts.
    pub seed: u64,
    /// Basis of the prior mean.
    pub mean: MeanBasis,
    /// Hyperparameter bounds.
    pub bounds: Bounds,
    /// L-BFGS-B iteration cap per start.
    pub max_iters: u64,
    /// Exact GP or sparse (inducing points), by size unless told.
    pub inducing: Inducing,
}

/// Exact or sparse GP. `Auto` fits an exact GP up to [`AUTO_EXACT_MAX`] samples and a sparse one
/// with [`DEFAULT_INDUCING`] inducing points above.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize)]
#[serde(into = "String")]
pub enum Inducing {
    /// By size.
    #[default]
    Auto,
    /// Always exact.
    Exact,
    /// Sparse with this many inducing points.
    Count(usize),
}

/// The largest data set `Inducing::Auto` fits exactly: beyond it an exact fit's O(n³) likelihood
/// evaluations take seconds each (docs/performance.md).
pub const AUTO_EXACT_MAX: usize = 1000;

/// Inducing points of an automatic sparse fit: chosen from the accuracy–cost curve
/// (docs/performance.md).
pub const DEFAULT_INDUCING: usize = 24;

impl Inducing {
    /// The number of inducing points for `n` samples, or `None` for an exact GP. A sparse GP with
    /// as many inducing points as samples is the exact GP at higher cost: it is fitted exactly.
    pub fn count(self, n: usize) -> Option<usize> {
        match self {
            Self::Exact => None,
            Self::Auto if n <= AUTO_EXACT_MAX => None,
            Self::Auto => Some(DEFAULT_INDUCING),
            Self::Count(m) if m >= n => None,
            Self::Count(m) => Some(m),
        }
    }
}

impl fmt::Display for Inducing {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Auto => write!(f, "auto"),
            Self::Exact => write!(f, "exact"),
            Self::Count(m) => write!(f, "{m}"),
        }
    }
}

impl From<Inducing> for String {
    fn from(i: Inducing) -> Self {
        i.to_string()
    }
}

impl FromStr for Inducing {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "auto" => Ok(Self::Auto),
            "exact" => Ok(Self::Exact),
            _ => match s.parse::<usize>() {
                Ok(m) if m >= 2 => Ok(Self::Count(m)),
                _ => Err(format!(
                    "'{s}': expected auto, exact or a number of inducing points (at least 2)"
                )),
            },
        }
    }
}

impl Default for GpConfig {
    fn default() -> Self {
        Self {
            random_starts: 2,
            seed: 0,
            mean: MeanBasis::default(),
            bounds: Bounds::default(),
            max_iters: 100,
            inducing: Inducing::default(),
        }
    }
}

/// Kernel hyperparameters in natural units (normalized inputs and outputs).
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Hyperparameters {
    /// One length scale per input.
    pub length_scales: Vec<f64>,
    /// Signal standard deviation σ_f.
    pub signal_std: f64,
    /// Noise standard deviation σ_n.
    pub noise_std: f64,
    /// Standard deviation σ_g of the per-group offsets, when the model has them.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub offset_std: Option<f64>,
}

impl Hyperparameters {
    /// From θ = (ln ℓ…, ln σ_f, ln σ_n).
    pub fn from_log(theta: &[f64]) -> Self {
        let d = theta.len() - 2;
        Self {
            length_scales: theta[..d].iter().map(|t| t.exp()).collect(),
            signal_std: theta[d].exp(),
            noise_std: theta[d + 1].exp(),
            offset_std: None,
        }
    }

    /// From θ of a model of `d` inputs: (ln ℓ…, ln σ_f, ln σ_n), then ln σ_g if θ has it.
    pub fn from_log_of(theta: &[f64], d: usize) -> Self {
        Self {
            offset_std: theta.get(d + 2).map(|t| t.exp()),
            ..Self::from_log(&theta[..d + 2])
        }
    }

    /// θ = (ln ℓ…, ln σ_f, ln σ_n[, ln σ_g]).
    pub fn to_log(&self) -> Vec<f64> {
        let mut t: Vec<f64> = self.length_scales.iter().map(|l| l.ln()).collect();
        t.push(self.signal_std.ln());
        t.push(self.noise_std.ln());
        t.extend(self.offset_std.map(f64::ln));
        t
    }

    /// Variance of an observation around the latent function for the firmware, which does not
    /// know the offset of the run it runs in: σ_n² + σ_g² (normalized units).
    pub fn observation_var(&self) -> f64 {
        self.noise_std.powi(2) + self.offset_std.map_or(0.0, |g| g * g)
    }
}

/// Cholesky factorization with jitter escalation: none first, then 1e-10 … 1e-4 of the mean
/// diagonal, ×10 each step. Returns the factor and the jitter that was needed.
pub fn cholesky_with_jitter(k: DMatrix<f64>) -> Result<(Cholesky<f64, Dyn>, f64), GpError> {
    cholesky_built(|| k.clone())
}

/// [`cholesky_with_jitter`] of the matrix `build` makes, made again for every retry: a caller
/// that can rebuild K from what it keeps anyway saves the copy that each attempt overwrites.
/// Only the lower triangle is read. The first attempt skips the scan for non-finite entries: a
/// non-finite entry leaves a non-finite factor or none, and the scan then runs before any retry.
fn cholesky_built(build: impl Fn() -> DMatrix<f64>) -> Result<(Cholesky<f64, Dyn>, f64), GpError> {
    let k = build();
    let mean_diag = k.diagonal().mean();
    if !mean_diag.is_finite() || mean_diag <= 0.0 {
        return Err(GpError::NotPositiveDefinite { jitter: 0.0 });
    }
    if let Some(c) = dense::cholesky(k) {
        return Ok((c, 0.0));
    }
    let k = build();
    if !dense::lower_finite(&k) {
        return Err(GpError::NotPositiveDefinite { jitter: 0.0 });
    }
    let mut scanned = Some(k);
    let mut tried = 0.0;
    for jitter in (0..7).map(|e| mean_diag * 10f64.powi(e - 10)) {
        tried = jitter;
        let mut kj = scanned.take().unwrap_or_else(&build);
        for i in 0..kj.nrows() {
            kj[(i, i)] += jitter;
        }
        if let Some(c) = dense::cholesky(kj) {
            return Ok((c, jitter));
        }
    }
    Err(GpError::NotPositiveDefinite { jitter: tried })
}

/// The GP conditioned on data at fixed hyperparameters: everything prediction needs.
#[derive(Debug, Clone)]
pub struct Posterior {
    /// Hyperparameters.
    pub hyper: Hyperparameters,
    /// Training inputs divided by the length scales.
    pub xs: DMatrix<f64>,
    /// Cholesky factor of K (with jitter).
    pub chol: Cholesky<f64, Dyn>,
    /// P y = K⁻¹ (y − Hβ̂).
    pub alpha: DVector<f64>,
    /// Generalized-least-squares basis coefficients (normalized output units; empty without a
    /// basis).
    pub beta: DVector<f64>,
    /// M = L⁻ᵀQ, so that P = K⁻¹ − M Mᵀ (n × p).
    basis_factor: DMatrix<f64>,
    /// Diagonal jitter that the factorization needed.
    pub jitter: f64,
    /// Log marginal likelihood of the normalized data.
    pub log_marginal_likelihood: f64,
    /// Group of each training sample when the model has per-group offsets (empty without).
    pub offsets: Vec<usize>,
}

/// The training covariance σ_f² k + σ_n² I, plus σ_g² where two samples share a group of `groups`
/// (per-group offsets drawn independently, N(0, σ_g²) each; empty: none), in the lower triangle:
/// from the unit-variance Gram matrix's lower triangle, its strict upper one only scaled.
fn covariance_lower(
    gram: &DMatrix<f64>,
    hyper: &Hyperparameters,
    groups: &[usize],
) -> DMatrix<f64> {
    let mut k = gram * hyper.signal_std.powi(2);
    let sn2 = hyper.noise_std.powi(2);
    for i in 0..k.nrows() {
        k[(i, i)] += sn2;
    }
    if let Some(g) = hyper.offset_std.filter(|_| !groups.is_empty()) {
        let g2 = g * g;
        for (j, gj) in groups.iter().enumerate() {
            for (i, gi) in groups.iter().enumerate().skip(j) {
                if gi == gj {
                    k[(i, j)] += g2;
                }
            }
        }
    }
    k
}

impl Posterior {
    /// Conditions the GP on normalized inputs `z`, outputs `y` and the prior-mean basis `h`
    /// evaluated at `z` (n × p; p = 0 for a zero mean).
    pub fn new(
        z: &DMatrix<f64>,
        y: &DVector<f64>,
        h: &DMatrix<f64>,
        hyper: Hyperparameters,
    ) -> Result<Self, GpError> {
        Self::grouped(z, y, h, hyper, &[])
    }

    /// [`Self::new`] with an offset per group of `offsets` (each sample's group index) in the
    /// training covariance when `hyper` has σ_g. Predictions leave the offsets out: a new run's
    /// is unknown.
    pub fn grouped(
        z: &DMatrix<f64>,
        y: &DVector<f64>,
        h: &DMatrix<f64>,
        hyper: Hyperparameters,
        offsets: &[usize],
    ) -> Result<Self, GpError> {
        let xs = kernel::scale_inputs(z, &hyper.length_scales);
        let gram = kernel::gram_lower(&xs);
        Self::from_gram(xs, &gram, y, h, hyper, offsets)
    }

    /// Conditions on scaled inputs whose unit-variance Gram matrix is already known (its lower
    /// triangle is read).
    fn from_gram(
        xs: DMatrix<f64>,
        gram: &DMatrix<f64>,
        y: &DVector<f64>,
        h: &DMatrix<f64>,
        hyper: Hyperparameters,
        offsets: &[usize],
    ) -> Result<Self, GpError> {
        let n = y.len();
        let offsets = match hyper.offset_std {
            Some(_) if offsets.len() == n => offsets.to_vec(),
            _ => Vec::new(),
        };
        let (chol, jitter) = cholesky_built(|| covariance_lower(gram, &hyper, &offsets))?;
        let p = h.ncols();
        let column = |m: DMatrix<f64>| m.column(0).into_owned();
        let ys = column(dense::solve_lower(
            &chol,
            DMatrix::from_column_slice(n, 1, y.as_slice()),
        ));
        let (resid, beta, basis_factor, log_det_r) = if p == 0 {
            (ys, DVector::zeros(0), DMatrix::zeros(n, 0), 0.0)
        } else {
            let qr = dense::solve_lower(&chol, h.clone()).qr();
            let (q, r) = (qr.q(), qr.r());
            let qty = q.tr_mul(&ys);
            let beta = r
                .solve_upper_triangular(&qty)
                .filter(|b| b.iter().all(|v| v.is_finite()))
                .ok_or(GpError::DegenerateBasis)?;
            let log_det_r: f64 = r.diagonal().iter().map(|v| v.abs().ln()).sum();
            if !log_det_r.is_finite() {
                return Err(GpError::DegenerateBasis);
            }
            let resid = &ys - &q * qty;
            (
                resid,
                beta,
                dense::solve_lower_transpose(&chol, q),
                log_det_r,
            )
        };
        let alpha = column(dense::solve_lower_transpose(
            &chol,
            DMatrix::from_column_slice(n, 1, resid.as_slice()),
        ));
        let log_det_half: f64 = chol.l_dirty().diagonal().iter().map(|v| v.ln()).sum();
        let lml = -0.5 * resid.norm_squared()
            - log_det_half
            - log_det_r
            - 0.5 * (n - p) as f64 * (2.0 * std::f64::consts::PI).ln();
        Ok(Self {
            hyper,
            xs,
            chol,
            alpha,
            beta,
            basis_factor,
            jitter,
            log_marginal_likelihood: lml,
            offsets,
        })
    }

    /// A posterior without a basis from its parts: centres divided by the length scales, the
    /// factor whose inverse gives the latent variance, and the weights (how the sparse GP enters
    /// the same prediction and export code, [`super::sparse`]).
    pub(crate) fn from_parts(
        hyper: Hyperparameters,
        xs: DMatrix<f64>,
        chol: Cholesky<f64, Dyn>,
        alpha: DVector<f64>,
        jitter: f64,
        log_marginal_likelihood: f64,
    ) -> Self {
        let m = xs.nrows();
        Self {
            hyper,
            xs,
            chol,
            alpha,
            beta: DVector::zeros(0),
            basis_factor: DMatrix::zeros(m, 0),
            jitter,
            log_marginal_likelihood,
            offsets: Vec::new(),
        }
    }

    /// P = K⁻¹ − M Mᵀ.
    fn projected_inverse(&self) -> DMatrix<f64> {
        let mut p = self.projected_inverse_lower();
        p.fill_upper_triangle_with_lower_triangle();
        p
    }

    /// The lower triangle of P = K⁻¹ − M Mᵀ (the strict upper triangle is not P's).
    fn projected_inverse_lower(&self) -> DMatrix<f64> {
        let mut p = dense::inverse_lower(&self.chol);
        if self.basis_factor.ncols() > 0 {
            dense::subtract_outer_lower(&mut p, &self.basis_factor);
        }
        p
    }

    /// Predictive mean and latent variance at one normalized sample (normalized units).
    pub fn predict(&self, z: &[f64]) -> (f64, f64) {
        let sf2 = self.hyper.signal_std.powi(2);
        let kstar = kernel::cross(&self.xs, z, &self.hyper.length_scales) * sf2;
        let mean = kstar.dot(&self.alpha);
        let v = self
            .chol
            .l_dirty()
            .solve_lower_triangular(&kstar)
            .unwrap_or_else(|| DVector::zeros(kstar.len()));
        (mean, (sf2 - v.norm_squared()).max(0.0))
    }

    /// Closed-form leave-one-out (R&W eq. 5.12): for each sample, (prediction − target, predictive
    /// variance including noise), normalized units.
    ///
    /// With per-group offsets, the prediction is the one a firmware makes, which does not know
    /// the offset its group has: the model's LOO prediction less the offset part of its cross
    /// covariance, σ_g² Σ_{j in i's group, j ≠ i} (P₋ᵢ y₋ᵢ)_j, where P₋ᵢ y₋ᵢ = α₋ᵢ − P₋ᵢ,ᵢ αᵢ / Pᵢᵢ
    /// (the fold's weights from the full ones, Dubrule 1983).
    pub fn loo(&self) -> Vec<(f64, f64)> {
        let kinv = self.projected_inverse();
        let g2 = self.hyper.offset_std.map_or(0.0, |g| g * g);
        self.alpha
            .iter()
            .enumerate()
            .map(|(i, a)| {
                let kii = kinv[(i, i)];
                let known: f64 = self
                    .offsets
                    .iter()
                    .enumerate()
                    .filter(|&(j, g)| j != i && *g == self.offsets[i])
                    .map(|(j, _)| self.alpha[j] - kinv[(j, i)] * a / kii)
                    .sum();
                (-a / kii - g2 * known, 1.0 / kii)
            })
            .collect()
    }
}

impl Posterior {
    /// Closed-form leave-one-group-out with the basis re-estimated in every fold, hyperparameters
    /// held ([`group_loo`]'s errors), with each left-out sample's predictive variance, noise
    /// included: the group's predictive covariance is (P_GG)⁻¹. (prediction − target, variance)
    /// per sample, normalized units. Samples in no group are left at (NaN, NaN).
    pub fn group_loo_predictive(&self, groups: &[Vec<usize>]) -> Result<Vec<(f64, f64)>, GpError> {
        let p = self.projected_inverse();
        let mut out = vec![(f64::NAN, f64::NAN); self.alpha.len()];
        for g in groups {
            let block = DMatrix::from_fn(g.len(), g.len(), |a, b| p[(g[a], g[b])]);
            let inv = block
                .try_inverse()
                .ok_or(GpError::NotPositiveDefinite { jitter: 0.0 })?;
            let alpha = DVector::from_iterator(g.len(), g.iter().map(|&i| self.alpha[i]));
            let e = -(&inv * alpha);
            for (k, &i) in g.iter().enumerate() {
                out[i] = (e[k], inv[(k, k)]);
            }
        }
        Ok(out)
    }
}

/// The basis `h` with `terms` appended, each column divided by its RMS (returned, 1 for an
/// all-zero column) so that GLS sees columns of the basis' order.
pub(super) fn with_terms(h: &DMatrix<f64>, terms: &DMatrix<f64>) -> (DMatrix<f64>, Vec<f64>) {
    let (n, p) = h.shape();
    let q = terms.ncols();
    let rms: Vec<f64> = terms
        .column_iter()
        .map(|c| {
            let r = (c.norm_squared() / n.max(1) as f64).sqrt();
            if r > 0.0 { r } else { 1.0 }
        })
        .collect();
    let out = DMatrix::from_fn(n, p + q, |i, j| {
        if j < p {
            h[(i, j)]
        } else {
            terms[(i, j - p)] / rms[j - p]
        }
    });
    (out, rms)
}

/// Closed-form leave-one-group-out with the basis re-estimated in every fold, hyperparameters
/// held: with P = K⁻¹ − K⁻¹H (HᵀK⁻¹H)⁻¹ HᵀK⁻¹ and α = P y, the errors of group G left out are
/// −(P_GG)⁻¹ α_G (R&W eq. 5.12 by blocks; Dubrule 1983 for the universal-kriging form). Returns
/// prediction − target for every sample, normalized units. Only P's diagonal blocks are formed:
/// a diagnosis scores dozens of term sets on one K⁻¹, and P itself would cost n² each.
pub fn group_loo(
    kinv: &DMatrix<f64>,
    h: &DMatrix<f64>,
    y: &DVector<f64>,
    groups: &[Vec<usize>],
) -> Result<Vec<f64>, GpError> {
    let mut alpha = kinv * y;
    let basis = if h.ncols() > 0 {
        let kh = kinv * h;
        let a = (h.transpose() * &kh)
            .cholesky()
            .ok_or(GpError::DegenerateBasis)?;
        alpha -= &kh * a.solve(&kh.tr_mul(y));
        Some((kh, a))
    } else {
        None
    };
    let mut e = vec![0.0; y.len()];
    for g in groups {
        let mut block = DMatrix::from_fn(g.len(), g.len(), |a, b| kinv[(g[a], g[b])]);
        if let Some((kh, a)) = &basis {
            let rows = DMatrix::from_fn(g.len(), kh.ncols(), |r, j| kh[(g[r], j)]);
            block -= &rows * a.solve(&rows.transpose());
        }
        let rhs = DVector::from_iterator(g.len(), g.iter().map(|&i| alpha[i]));
        let sol = block
            .lu()
            .solve(&rhs)
            .ok_or(GpError::NotPositiveDefinite { jitter: 0.0 })?;
        for (k, &i) in g.iter().enumerate() {
            e[i] = -sol[k];
        }
    }
    Ok(e)
}

/// Columns of the gradient's double sum given to one parallel task.
const GRADIENT_CHUNK: usize = 64;

/// (Restricted) log marginal likelihood and its gradient w.r.t. θ (paper eq. 11–12). θ has
/// ln σ_g last when `offsets` (each sample's group index) is not empty.
pub fn lml_and_gradient(
    z: &DMatrix<f64>,
    y: &DVector<f64>,
    h: &DMatrix<f64>,
    offsets: &[usize],
    theta: &[f64],
) -> Result<(f64, Vec<f64>), GpError> {
    let d = z.ncols();
    let hyper = Hyperparameters::from_log_of(theta, d);
    let xs = kernel::scale_inputs(z, &hyper.length_scales);
    let gram = kernel::gram_lower(&xs);
    let post = Posterior::from_gram(xs, &gram, y, h, hyper, offsets)?;
    let sf2 = post.hyper.signal_std.powi(2);
    let sn2 = post.hyper.noise_std.powi(2);
    let kinv = post.projected_inverse_lower();
    let n = y.len();
    let grouped = !post.offsets.is_empty();
    // W = ααᵀ − P; ∂K/∂ln ℓ_k = K_se ∘ (Δz_k/ℓ_k)², ∂K/∂ln σ_f = 2 K_se, ∂K/∂ln σ_n = 2 σ_n² I,
    // ∂K/∂ln σ_g = 2 σ_g² B (B_ij = 1 where i and j share a group).
    // Both W and ∂K are symmetric: the strict lower triangle counts twice, the diagonal once.
    // Column by column over contiguous slices, the columns spread over the cores: [ℓ…, σ_f, B].
    let columns = GradientColumns {
        n,
        kinv: kinv.as_slice(),
        gram: gram.as_slice(),
        alpha: post.alpha.as_slice(),
        xs: post.xs.as_slice(),
        offsets: &post.offsets,
        sf2,
    };
    // Fixed chunks summed in order: the same θ gives the same bits, however the work was shared.
    let partial: Vec<Vec<f64>> = (0..n.div_ceil(GRADIENT_CHUNK))
        .into_par_iter()
        .map(|c| {
            let (mut acc, mut column) = (vec![0.0; d + 2], vec![0.0; d + 2]);
            for j in c * GRADIENT_CHUNK..((c + 1) * GRADIENT_CHUNK).min(n) {
                columns.sums(j, &mut column);
                acc.iter_mut().zip(&column).for_each(|(a, v)| *a += v);
            }
            acc
        })
        .collect();
    let mut sums = vec![0.0; d + 2];
    for p in &partial {
        sums.iter_mut().zip(p).for_each(|(a, v)| *a += v);
    }
    let mut grad = vec![0.0; d + 2 + usize::from(grouped)];
    grad[..=d].copy_from_slice(&sums[..=d]);
    grad[d + 1] = sn2
        * (0..n)
            .map(|i| post.alpha[i].powi(2) - kinv[(i, i)])
            .sum::<f64>();
    if let Some(g) = post.hyper.offset_std.filter(|_| grouped) {
        grad[d + 2] = 2.0 * g * g * sums[d + 1];
    }
    Ok((post.log_marginal_likelihood, grad))
}

/// What one column of the likelihood gradient's double sum reads (all column-major, n rows).
struct GradientColumns<'a> {
    n: usize,
    /// Lower triangle of P.
    kinv: &'a [f64],
    /// Lower triangle of the unit-variance Gram matrix.
    gram: &'a [f64],
    alpha: &'a [f64],
    /// Scaled inputs.
    xs: &'a [f64],
    /// Each sample's group (empty without offsets).
    offsets: &'a [usize],
    sf2: f64,
}

/// Inputs whose length-scale sums one pass over a column carries ([`GradientColumns::sums`]).
const PASS_INPUTS: usize = 4;

impl GradientColumns<'_> {
    /// Column j's sums over i ≥ j (the diagonal halved) into `out`: [ℓ…, σ_f, B].
    fn sums(&self, j: usize, out: &mut [f64]) {
        let d = out.len() - 2;
        out.fill(0.0);
        for k0 in (0..d.max(1)).step_by(PASS_INPUTS) {
            let first = k0 == 0;
            match (d - k0).min(PASS_INPUTS) {
                0 => self.pass::<0>(j, k0, first, out),
                1 => self.pass::<1>(j, k0, first, out),
                2 => self.pass::<2>(j, k0, first, out),
                3 => self.pass::<3>(j, k0, first, out),
                _ => self.pass::<PASS_INPUTS>(j, k0, first, out),
            }
        }
    }

    /// One pass over column j for the length scales of inputs k0..k0 + D, and with `first` the
    /// σ_f and group sums. D is a constant so that the sums stay in registers (with a count
    /// known only at run time they went through memory at every step: a tenth of a likelihood
    /// at n = 730). Each sum still runs over i in order: the same bits however inputs are split.
    fn pass<const D: usize>(&self, j: usize, k0: usize, first: bool, out: &mut [f64]) {
        let n = self.n;
        let (kc, gc) = (
            &self.kinv[j * n..(j + 1) * n],
            &self.gram[j * n..(j + 1) * n],
        );
        let x: [&[f64]; D] = std::array::from_fn(|k| &self.xs[(k0 + k) * n..(k0 + k + 1) * n]);
        let xj: [f64; D] = std::array::from_fn(|k| x[k][j]);
        let alpha_j = self.alpha[j];
        let group_j = self.offsets.get(j);
        let (mut lengths, mut signal, mut group) = ([0.0; D], 0.0, 0.0);
        for i in j..n {
            let weight = if i == j { 0.5 } else { 1.0 };
            let w = self.alpha[i] * alpha_j - kc[i];
            let wk = weight * w * self.sf2 * gc[i];
            for k in 0..D {
                let dz = x[k][i] - xj[k];
                lengths[k] += wk * dz * dz;
            }
            if first {
                signal += 2.0 * wk;
                if group_j.is_some_and(|g| self.offsets[i] == *g) {
                    group += weight * w;
                }
            }
        }
        out[k0..k0 + D].copy_from_slice(&lengths);
        if first {
            let d = out.len() - 2;
            out[d] = signal;
            out[d + 1] = group;
        }
    }
}

/// The L-BFGS-B objective: −log ML per sample. Cost and gradient come from one evaluation,
/// cached, because the solver asks for them separately. Where the likelihood is numerically rough
/// (tiny noise, jitter switching on) a line search can stall; an evaluation budget stops it, and
/// the best point seen is kept either way.
struct Objective<'a> {
    likelihood: Likelihood<'a>,
    n: f64,
    ranges: &'a [(f64, f64)],
    cache: RefCell<Option<Evaluated>>,
    track: RefCell<Track>,
    stopping: Stopping,
}

/// A log marginal likelihood (or a bound on it) and its gradient w.r.t. θ.
pub(crate) type Likelihood<'a> = &'a (dyn Fn(&[f64]) -> Result<(f64, Vec<f64>), GpError> + Sync);

/// One objective evaluation: θ, cost, gradient.
type Evaluated = (Vec<f64>, f64, Vec<f64>);

/// Evaluation count and the best point seen: its cost, θ and log marginal likelihood (kept so the
/// run's end needs no factorization of its own).
#[derive(Default)]
struct Track {
    evaluations: u64,
    computed: u64,
    best: Option<(f64, Vec<f64>, f64)>,
    /// The cost at the last gain larger than [`STALL`]'s, and the computations since.
    anchor: Option<f64>,
    stalled: u32,
    /// Why the objective stopped answering (budget, stall, a failed likelihood), if it did.
    stop: Option<String>,
}

/// A run whose best cost has not fallen by more than this (per sample) in this many likelihood
/// computations stops: it is chasing rounding. With σ_n near 4e-5 (normalized) at n = 1,000–2,000
/// the log ML at one optimum varies by 2e-6 per sample between points 1e-4 apart in θ, and the
/// line searches' last 20–30 computations and the whole polish were spent on that (measured with
/// `fit_timing` on the scattered tables, docs/performance.md). Six computations leave room for
/// the rejected trials of a first line search (up to four in a row there).
const STALL: (u32, f64) = (6, 1e-6);

impl Objective<'_> {
    /// Cost and gradient at θ, or `None` once the run is to stop (the reason is in the track).
    fn evaluate(&self, theta: &[f64]) -> Option<(f64, Vec<f64>)> {
        let mut track = self.track.borrow_mut();
        // Every call counts, cached or not: a stalled line search may ask for one point forever.
        if track.stop.is_none() {
            if track.evaluations >= self.stopping.budget {
                track.stop = Some("evaluation budget exhausted".to_owned());
            } else if self.stopping.stall && track.stalled >= STALL.0 {
                track.stop = Some("stalled: no gain above the likelihood's rounding".to_owned());
            }
        }
        if track.stop.is_some() {
            return None;
        }
        track.evaluations += 1;
        if let Some((t, c, g)) = self.cache.borrow().as_ref()
            && t.as_slice() == theta
        {
            return Some((*c, g.clone()));
        }
        // L-BFGS-B keeps θ inside the bounds; the clamp only absorbs a rounding step across one.
        // Costs are per sample so that gradients are O(1) whatever n is.
        let inside = clamp(theta, self.ranges);
        track.computed += 1;
        let (lml, grad) = match (self.likelihood)(&inside) {
            Ok(v) => v,
            Err(e) => {
                track.stop = Some(format!("stopped: {e}"));
                return None;
            }
        };
        let n = self.n;
        let cost = -lml / n;
        let g: Vec<f64> = grad.iter().map(|v| -v / n).collect();
        if cost.is_finite() && track.best.as_ref().is_none_or(|(c, _, _)| cost < *c) {
            track.best = Some((cost, inside, lml));
        }
        if track.anchor.is_none_or(|a| cost < a - STALL.1) {
            track.anchor = Some(cost);
            track.stalled = 0;
        } else {
            track.stalled += 1;
        }
        *self.cache.borrow_mut() = Some((theta.to_vec(), cost, g.clone()));
        Some((cost, g))
    }
}

/// What one optimizer start did.
#[derive(Debug, Clone, Serialize)]
pub struct StartReport {
    /// Samples the run's likelihood was computed on: for a sparse GP, the start subset's for the
    /// starts ([`super::sparse`]) and all for the refinements on the bound.
    pub samples: usize,
    /// Where it started (θ).
    pub start: Vec<f64>,
    /// Where it ended (θ, clamped to the bounds), if it succeeded.
    pub end: Option<Vec<f64>>,
    /// Log marginal likelihood at the end.
    pub log_marginal_likelihood: Option<f64>,
    /// Objective calls (cost and gradient requests, cached ones included).
    pub evaluations: u64,
    /// Likelihood computations among them (each a factorization, an inverse and a gradient).
    pub likelihoods: u64,
    /// Termination status or error.
    pub status: String,
    /// It stopped at the tolerance (not on the iteration cap, the evaluation budget or an error).
    pub converged: bool,
    /// It is the polish from the best start's end, not a start.
    pub polish: bool,
}

/// How the hyperparameter search ended. For a sparse GP, the search on the start subset's exact GP:
/// the refinement on the bound that follows runs on a fixed budget by design ([`super::sparse`])
/// and keeps the best point it reaches.
#[derive(Debug, Clone, PartialEq, Serialize)]
#[serde(tag = "outcome", rename_all = "kebab-case")]
pub enum Optimization {
    /// At least one run converged: the best point of all runs is used.
    Converged,
    /// No run converged (iteration cap, evaluation budget or a failed line search) and the best
    /// point any of them reached is not stationary within the bounds: it is used all the same.
    StoppedEarly {
        /// Log marginal likelihood at that point (of the start subset, for a sparse GP).
        log_marginal_likelihood: f64,
    },
    /// The likelihood could not be evaluated anywhere the runs went: the fit uses the
    /// data-informed start's length scales and signal with σ_n raised tenfold at a time until the
    /// likelihood evaluates (at the bound, 10 output scales, the model is its prior mean).
    Fallback {
        /// The σ_n used (normalized).
        noise_std: f64,
        /// How each start ended.
        statuses: Vec<String>,
    },
}

/// How one L-BFGS-B run stops.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Stopping {
    /// Projected-gradient tolerance (largest component, per-sample cost): L-BFGS-B's pgtol.
    pub tolerance: f64,
    /// Objective-call budget.
    pub budget: u64,
    /// Whether it also stops when its best stops rising above rounding ([`STALL`]).
    pub stall: bool,
}

/// The search from every start, and the final polish from the best one: the searches only have to
/// find the right basin, the polish converges in it. Near the optimum the likelihood is flat to
/// rounding and line searches stall, so both stop when their gains sink below it ([`STALL`]).
/// The searches stop at a projected gradient of 1e-2 per sample: on 41 fits (140–2,000 points,
/// both FOG runs, constant and physics means) that kept every optimum (within 0.013 nats) with 13%
/// fewer likelihoods than 1e-3; at 3e-2 the Aug FOG run's polish started in the wrong basin, 2
/// nats lower (docs/performance.md).
const SEARCH: Stopping = Stopping {
    tolerance: 1e-2,
    budget: 120,
    stall: true,
};

const POLISH: Stopping = Stopping {
    tolerance: 1e-5,
    budget: 40,
    stall: true,
};

/// L-BFGS-B's memory (correction pairs kept).
const MEMORY: usize = 7;

/// L-BFGS-B's relative-reduction test, in machine epsilons (scipy's and scikit-learn's default).
/// Runs near the optimum end on [`STALL`] first; this ends the ones whose steps shrink smoothly.
const FACTR: f64 = 1e7;

/// θ moved into its box.
fn clamp(theta: &[f64], ranges: &[(f64, f64)]) -> Vec<f64> {
    theta
        .iter()
        .zip(ranges)
        .map(|(&t, &(lo, hi))| t.clamp(lo, hi))
        .collect()
}

/// One L-BFGS-B run of `likelihood` (of `n` samples) from `start`, within `ranges` (one per entry
/// of θ) and at most `max_iters` iterations.
pub(crate) fn optimize_from(
    likelihood: Likelihood<'_>,
    n: usize,
    start: Vec<f64>,
    ranges: &[(f64, f64)],
    max_iters: u64,
    stopping: Stopping,
) -> StartReport {
    let problem = Objective {
        likelihood,
        n: n as f64,
        ranges,
        cache: RefCell::new(None),
        track: RefCell::new(Track::default()),
        stopping,
    };
    let (lower, upper): (Vec<f64>, Vec<f64>) = ranges.iter().copied().unzip();
    let control = OptimControl {
        maxit: usize::try_from(max_iters).unwrap_or(usize::MAX),
        factr: FACTR,
        pgtol: stopping.tolerance,
        lmm: MEMORY,
        ..OptimControl::default_for_dimension(start.len())
    };
    // The objective answers NaN once it has stopped (its reason is in the track), which ends the
    // solver's run with an error; the best point seen is kept either way.
    let result = BoxBounds::new(lower, upper).and_then(|bounds| {
        optim_lbfgsb_with_gradient(
            clamp(&start, ranges),
            bounds,
            |t: &[f64]| problem.evaluate(t).map_or(f64::NAN, |(c, _)| c),
            |t: &[f64]| {
                problem
                    .evaluate(t)
                    .map_or_else(|| vec![f64::NAN; t.len()], |(_, g)| g)
            },
            control,
        )
    });
    let track = problem.track.into_inner();
    let (status, converged) = match (result, track.stop) {
        (_, Some(reason)) => (reason, false),
        (Ok(r), None) => (r.message.to_lowercase(), r.convergence == 0),
        (Err(e), None) => (format!("stopped: {e}"), false),
    };
    let (end, lml) = track
        .best
        .map_or((None, None), |(_, t, l)| (Some(t), Some(l)));
    StartReport {
        samples: n,
        start,
        end,
        log_marginal_likelihood: lml,
        evaluations: track.evaluations,
        likelihoods: track.computed,
        status,
        converged,
        polish: false,
    }
}

/// The data-informed start: unit length scales and signal, noise at 1% of the output spread.
/// With per-group offsets (`grouped`), σ_g starts at 0.1.
fn informed(d: usize, grouped: bool) -> Vec<f64> {
    let mut t = vec![0.0; d + 2];
    t[d + 1] = 0.01f64.ln();
    if grouped {
        t.push(0.1f64.ln());
    }
    t
}

/// The optimizer starts: the paper's (all zero), the data-informed one ([`informed`]), then
/// `random_starts` drawn inside the bounds' middle.
pub(crate) fn starts(d: usize, grouped: bool, cfg: &GpConfig) -> Vec<Vec<f64>> {
    let params = d + 2 + usize::from(grouped);
    let mut out = vec![vec![0.0; params], informed(d, grouped)];
    let mut rng = ChaCha8Rng::seed_from_u64(cfg.seed);
    for _ in 0..cfg.random_starts {
        let mut t: Vec<f64> = (0..d).map(|_| rng.random_range(-2.0..3.0)).collect();
        t.push(rng.random_range(-1.5..1.5));
        t.push(rng.random_range(-9.0..-2.0));
        if grouped {
            t.push(rng.random_range(-5.0..0.5));
        }
        out.push(t);
    }
    out
}

/// Training data in the model's normalized coordinates.
#[derive(Debug, Clone)]
pub struct Prepared {
    /// Input normalization.
    pub norm: Normalizer,
    /// Ordinary-least-squares prior mean c₀ (output units).
    pub prior: PolyPrior,
    /// Output scale s_y: the spread of the residual from `prior`.
    pub scale: f64,
    /// Normalized inputs.
    pub z: DMatrix<f64>,
    /// Normalized outputs (target − prior) / s_y.
    pub y: DVector<f64>,
    /// The basis at `z` (n × p).
    pub h: DMatrix<f64>,
    /// Group of each sample when the model has per-group offsets (empty without).
    pub offsets: Vec<usize>,
}

impl Prepared {
    /// Normalizes the data and fits the basis by ordinary least squares.
    pub fn new(x: &DMatrix<f64>, target: &DVector<f64>, basis: MeanBasis) -> Self {
        let norm = Normalizer::fit(x);
        let z = norm.apply(x);
        let prior = PolyPrior::fit(&z, target, basis);
        let resid = target - prior.eval_all(&z);
        let n = resid.len().max(1) as f64;
        let mean = resid.sum() / n;
        let sd = (resid.iter().map(|r| (r - mean).powi(2)).sum::<f64>() / n).sqrt();
        let scale_floor = 1e-12 * target.amax().max(1.0);
        let scale = sd.max(scale_floor);
        // The paper's constant mean is the data's mean, fixed (scikit-learn's `normalize_y`), so
        // that model stays exactly the paper's; richer bases are marginalized.
        let h = if basis == MeanBasis::Constant {
            DMatrix::zeros(z.nrows(), 0)
        } else {
            design(&z, &prior.exponents)
        };
        Self {
            norm,
            prior,
            scale,
            z,
            y: resid / scale,
            h,
            offsets: Vec::new(),
        }
    }

    /// [`Self::new`] with each sample's group for per-group offsets (empty: none).
    pub fn grouped(
        x: &DMatrix<f64>,
        target: &DVector<f64>,
        basis: MeanBasis,
        offsets: &[usize],
    ) -> Self {
        Self {
            offsets: offsets.to_vec(),
            ..Self::new(x, target, basis)
        }
    }

    /// The GP conditioned on this data at `hyper`.
    pub fn condition(&self, hyper: Hyperparameters) -> Result<Posterior, GpError> {
        Posterior::grouped(&self.z, &self.y, &self.h, hyper, &self.offsets)
    }

    /// Its (restricted) log marginal likelihood and gradient at θ, with extra basis columns `h`.
    pub(super) fn likelihood(
        &self,
        h: &DMatrix<f64>,
        theta: &[f64],
    ) -> Result<(f64, Vec<f64>), GpError> {
        lml_and_gradient(&self.z, &self.y, h, &self.offsets, theta)
    }
}

/// What [`search`] found: the θ to use, what each run did, and how it ended.
pub(crate) struct Searched {
    pub theta: Vec<f64>,
    pub reports: Vec<StartReport>,
    pub optimization: Optimization,
}

/// Maximizes `likelihood` over θ for data of shape (n, d): every start of [`starts`] searched in
/// parallel, then a polish from the best. When no run reached a point where the likelihood
/// evaluates, falls back ([`Optimization::Fallback`]); fails only when the fallback cannot
/// evaluate it either.
pub(crate) fn search(
    likelihood: Likelihood<'_>,
    (n, d): (usize, usize),
    grouped: bool,
    cfg: &GpConfig,
) -> Result<Searched, GpError> {
    search_from(likelihood, (n, d), starts(d, grouped, cfg), cfg)
}

/// [`search`] from the given starts.
pub(crate) fn search_from(
    likelihood: Likelihood<'_>,
    (n, d): (usize, usize),
    starts: Vec<Vec<f64>>,
    cfg: &GpConfig,
) -> Result<Searched, GpError> {
    let explored = explore(likelihood, (n, d), starts, cfg)?;
    Ok(polish(likelihood, (n, d), explored, cfg))
}

/// The first half of [`search_from`]: every start searched in parallel to the searches'
/// tolerance, θ the best end (the basin, not yet its optimum), or the fallback. The outcome is
/// `Converged` where a run converged, `StoppedEarly` otherwise; [`polish`] settles it.
pub(crate) fn explore(
    likelihood: Likelihood<'_>,
    (n, d): (usize, usize),
    starts: Vec<Vec<f64>>,
    cfg: &GpConfig,
) -> Result<Searched, GpError> {
    let grouped = starts.first().is_some_and(|s| s.len() > d + 2);
    let reports: Vec<StartReport> = starts
        .into_par_iter()
        .map(|s| {
            let ranges = cfg.bounds.ranges(d, s.len());
            optimize_from(likelihood, n, s, &ranges, cfg.max_iters, SEARCH)
        })
        .collect();
    let Some((theta, lml)) = best_of(&reports) else {
        let statuses: Vec<String> = reports.iter().map(|r| r.status.clone()).collect();
        let Some((theta, noise_std)) = fallback(likelihood, d, grouped, cfg) else {
            return Err(GpError::OptimizerFailed(statuses.join("; ")));
        };
        return Ok(Searched {
            theta,
            reports,
            optimization: Optimization::Fallback {
                noise_std,
                statuses,
            },
        });
    };
    let optimization = if reports.iter().any(|r| r.converged) {
        Optimization::Converged
    } else {
        Optimization::StoppedEarly {
            log_marginal_likelihood: lml,
        }
    };
    Ok(Searched {
        theta,
        reports,
        optimization,
    })
}

/// The second half of [`search_from`]: the polish from an [`explore`]d search's best end, σ_n
/// raised where the likelihood is flat in it ([`raise_noise`]), and how the search ended. A
/// fallback is returned as it is.
pub(crate) fn polish(
    likelihood: Likelihood<'_>,
    (n, d): (usize, usize),
    explored: Searched,
    cfg: &GpConfig,
) -> Searched {
    if matches!(explored.optimization, Optimization::Fallback { .. }) {
        return explored;
    }
    let Searched {
        theta: searched,
        mut reports,
        ..
    } = explored;
    reports.push(StartReport {
        polish: true,
        ..optimize_from(
            likelihood,
            n,
            searched.clone(),
            &cfg.bounds.ranges(d, searched.len()),
            cfg.max_iters,
            POLISH,
        )
    });
    let theta = match best_of(&reports) {
        Some((best, lml)) => raise_noise(likelihood, best, lml, d, &cfg.bounds),
        None => searched,
    };
    let optimization = if reports.iter().any(|r| r.converged)
        || stationary(likelihood, &theta, &cfg.bounds, (n, d))
    {
        Optimization::Converged
    } else {
        Optimization::StoppedEarly {
            log_marginal_likelihood: likelihood(&theta).map_or(f64::NAN, |(l, _)| l),
        }
    };
    Searched {
        theta,
        reports,
        optimization,
    }
}

/// Nats of log marginal likelihood that raising σ_n may cost in all ([`raise_noise`]): a
/// likelihood ratio of 1.001, far below anything the data can tell apart.
const FLAT: f64 = 1e-3;

/// Step of ln σ_n in [`raise_noise`].
const NOISE_STEP: f64 = 0.5;

/// `theta` (log marginal likelihood `lml`) with σ_n raised in steps of [`NOISE_STEP`] as long as
/// the likelihood stays within [`FLAT`] of `lml`. On nearly noise-free data the likelihood is flat
/// in σ_n below the data's own misfit, so where a search stops along that direction is arbitrary,
/// and the smallest σ_n conditions K worst: the f32 firmware followed one such fit by 17 ulps,
/// past what export allows (trainer/tests/cli.rs, the handled static log). Among fits the data
/// cannot tell apart, the best-conditioned one is kept. Costs one likelihood where σ_n is pinned.
fn raise_noise(
    likelihood: Likelihood<'_>,
    theta: Vec<f64>,
    lml: f64,
    d: usize,
    bounds: &Bounds,
) -> Vec<f64> {
    let top = bounds.range(d, d + 1).1;
    walk_noise(likelihood, theta, d + 1, (NOISE_STEP, top), |l| {
        l >= lml - FLAT
    })
}

/// θ with ln σ_n (entry `j`) raised in steps of `step` up to `top` as long as `accept` takes the
/// likelihood at the next step; a step refused or not evaluable ends the walk. The search's end
/// ([`raise_noise`]) and the sparse bound's start (`sparse::climb_noise`) walk this way.
pub(crate) fn walk_noise(
    likelihood: Likelihood<'_>,
    mut theta: Vec<f64>,
    j: usize,
    (step, top): (f64, f64),
    mut accept: impl FnMut(f64) -> bool,
) -> Vec<f64> {
    while theta[j] < top {
        let mut next = theta.clone();
        next[j] = (next[j] + step).min(top);
        match likelihood(&next) {
            Ok((l, _)) if accept(l) => theta = next,
            _ => break,
        }
    }
    theta
}

/// Largest per-sample gradient component (in ln units) at which a point that no run declared
/// converged still counts as the optimum: to first order a step of 0.1 (10% in a hyperparameter)
/// along it gains at most 0.005 nats per sample. Nearly noise-free data (σ_n at its bound) leave
/// every run stalled short of the tolerance on a likelihood this peaked: 0.009 on the unit test's
/// toy function, more on duplicated rate tables (at 0.02, 5 of the 24 in
/// `tests/degenerate_data.rs` were reported as stopped early).
const STATIONARY: f64 = 0.05;

/// Within this (ln units) of a bound, a gradient pushing outward is the bound holding, not a
/// search that stopped short.
const AT_BOUND: f64 = 0.01;

/// Whether θ is a maximum of `likelihood` (of `n` samples) within the bounds: every gradient
/// component is below [`STATIONARY`] per sample, except those pushing against a bound θ is at.
/// Noise-free data put σ_f or σ_n at a bound, where a run can stall on the likelihood's rounding
/// short of its tolerance, though the point it stalls at is the constrained optimum.
fn stationary(
    likelihood: Likelihood<'_>,
    theta: &[f64],
    bounds: &Bounds,
    (n, d): (usize, usize),
) -> bool {
    likelihood(theta).is_ok_and(|(_, grad)| {
        grad.iter().enumerate().all(|(j, &g)| {
            let (lo, hi) = bounds.range(d, j);
            let held =
                (theta[j] >= hi - AT_BOUND && g > 0.0) || (theta[j] <= lo + AT_BOUND && g < 0.0);
            held || (g / n as f64).abs() <= STATIONARY
        })
    })
}

/// The fallback θ: the data-informed start with σ_n at 0.1, 1 and 10 (normalized, within the
/// bounds) in turn, the first where the likelihood evaluates to a finite number; with that σ_n.
fn fallback(
    likelihood: Likelihood<'_>,
    d: usize,
    grouped: bool,
    cfg: &GpConfig,
) -> Option<(Vec<f64>, f64)> {
    let (lo, hi) = cfg.bounds.log_noise;
    [0.1f64, 1.0, 10.0].into_iter().find_map(|noise| {
        let mut theta = informed(d, grouped);
        theta[d + 1] = noise.ln().clamp(lo, hi);
        let fine = likelihood(&theta).is_ok_and(|(l, _)| l.is_finite());
        fine.then(|| {
            let noise_std = theta[d + 1].exp();
            (theta, noise_std)
        })
    })
}

/// The end point of the run with the highest likelihood.
pub(crate) fn best_of(reports: &[StartReport]) -> Option<(Vec<f64>, f64)> {
    // A NaN likelihood is a failed start, not the best (total_cmp orders NaN above everything).
    reports
        .iter()
        .filter_map(|r| Some((r.end.clone()?, r.log_marginal_likelihood?)))
        .filter(|(_, l)| l.is_finite())
        .max_by(|a, b| a.1.total_cmp(&b.1))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::models::gp::GpModel;

    fn toy(n: usize, seed: u64) -> (DMatrix<f64>, DVector<f64>) {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let x = DMatrix::from_fn(n, 2, |_, _| rng.random_range(-2.0f64..2.0));
        let y = DVector::from_fn(n, |i, _| (1.3 * x[(i, 0)]).sin() + 0.4 * x[(i, 1)].powi(2));
        (x, y)
    }

    #[test]
    fn closed_form_group_loo_equals_refitting_without_the_group() {
        let (z, y) = toy(24, 5);
        let hyper = Hyperparameters::from_log(&[0.2, -0.3, 0.1, -2.0]);
        let groups: Vec<Vec<usize>> = (0..8).map(|g| vec![3 * g, 3 * g + 1, 3 * g + 2]).collect();
        for h in bases(&z) {
            let full = Posterior::new(&z, &y, &h, hyper.clone()).unwrap();
            let kinv = dense::inverse_from_cholesky(&full.chol);
            let e = group_loo(&kinv, &h, &y, &groups).unwrap();
            for g in &groups {
                let keep: Vec<usize> = (0..24).filter(|i| !g.contains(i)).collect();
                let rows = |m: &DMatrix<f64>| m.select_rows(&keep);
                let rest = Posterior::new(
                    &rows(&z),
                    &DVector::from_iterator(keep.len(), keep.iter().map(|&i| y[i])),
                    &rows(&h),
                    hyper.clone(),
                )
                .unwrap();
                for &i in g {
                    let zi: Vec<f64> = z.row(i).iter().copied().collect();
                    let basis: f64 = (0..h.ncols()).map(|j| h[(i, j)] * rest.beta[j]).sum();
                    let refit = rest.predict(&zi).0 + basis - y[i];
                    assert!((e[i] - refit).abs() < 1e-8, "{} vs {refit}", e[i]);
                }
            }
        }
    }

    /// No basis, and the linear basis {1, z₀, z₁}.
    fn bases(z: &DMatrix<f64>) -> [DMatrix<f64>; 2] {
        [
            DMatrix::zeros(z.nrows(), 0),
            design(z, &MeanBasis::Poly(1).exponents(2)),
        ]
    }

    #[test]
    fn analytic_gradient_matches_finite_differences() {
        let (z, y) = toy(25, 1);
        let y = y.map(|v| v + 0.01);
        let groups: Vec<usize> = (0..25).map(|i| i % 4).collect();
        // Six inputs: the gradient's length-scale sums take two passes over each column.
        let z6 = DMatrix::from_fn(25, 6, |i, k| z[(i, k % 2)] * (1.0 + 0.3 * k as f64));
        let none = DMatrix::zeros(25, 0);
        let six = (
            &z6,
            &none,
            &groups[..],
            vec![-0.3, 0.7, 0.1, 0.4, 0.9, -0.2, 0.2, -2.5, -1.0],
        );
        for (z, h, offsets, theta) in bases(&z)
            .iter()
            .flat_map(|h| {
                [
                    (&z, h, &[][..], vec![0.0, 0.0, 0.0, 0.0]),
                    (&z, h, &[][..], vec![-0.3, 0.7, 0.2, -2.5]),
                    (&z, h, &groups[..], vec![-0.3, 0.7, 0.2, -2.5, -1.0]),
                ]
            })
            .chain([six])
        {
            let lml = |t: &[f64]| lml_and_gradient(z, &y, h, offsets, t).unwrap();
            let (_, g) = lml(&theta);
            assert_eq!(g.len(), theta.len());
            for j in 0..theta.len() {
                let step = 1e-5;
                let mut tp = theta.clone();
                tp[j] += step;
                let mut tm = theta.clone();
                tm[j] -= step;
                let fd = (lml(&tp).0 - lml(&tm).0) / (2.0 * step);
                assert!(
                    (fd - g[j]).abs() < 1e-5 * (1.0 + fd.abs()),
                    "θ {theta:?} j {j}: analytic {} fd {fd}",
                    g[j]
                );
            }
        }
    }

    #[test]
    fn lml_of_two_points_by_hand() {
        // n = 2, d = 1, z = (0, 1), y = (1, −1), ℓ = σ_f = σ_n = 1:
        // K = [[2, e^{-1/2}], [e^{-1/2}, 2]], |K| = 4 − e^{-1}, yᵀK⁻¹y = 2(2 + e^{-1/2}) / |K|.
        let z = DMatrix::from_row_slice(2, 1, &[0.0, 1.0]);
        let y = DVector::from_row_slice(&[1.0, -1.0]);
        let none = DMatrix::zeros(2, 0);
        let p = Posterior::new(&z, &y, &none, Hyperparameters::from_log(&[0.0, 0.0, 0.0])).unwrap();
        let c = (-0.5f64).exp();
        let det = 4.0 - c * c;
        let quad = 2.0 * (2.0 + c) / det;
        let expected = -0.5 * quad - 0.5 * det.ln() - (2.0 * std::f64::consts::PI).ln();
        assert!((p.log_marginal_likelihood - expected).abs() < 1e-12);
        assert_eq!(p.jitter, 0.0);
    }

    #[test]
    fn closed_form_loo_matches_brute_force_refits() {
        let (z, y) = toy(30, 2);
        let hyper = Hyperparameters {
            length_scales: vec![0.8, 1.5],
            signal_std: 1.2,
            noise_std: 0.05,
            offset_std: None,
        };
        for h in bases(&z) {
            let full = Posterior::new(&z, &y, &h, hyper.clone()).unwrap();
            let loo = full.loo();
            for i in 0..z.nrows() {
                let keep: Vec<usize> = (0..z.nrows()).filter(|&j| j != i).collect();
                let (zi, yi, hi) = (
                    z.select_rows(&keep),
                    y.select_rows(&keep),
                    h.select_rows(&keep),
                );
                let p = Posterior::new(&zi, &yi, &hi, hyper.clone()).unwrap();
                let (m, v) = p.predict(&[z[(i, 0)], z[(i, 1)]]);
                let m = m + h.row(i).dot(&p.beta.transpose());
                assert!((m - y[i] - loo[i].0).abs() < 1e-9, "point {i}");
                // Without a basis 1/P_ii is the predictive variance; with one it adds β̂'s.
                if h.ncols() == 0 {
                    let noisy = v + hyper.noise_std.powi(2);
                    assert!((noisy - loo[i].1).abs() < 1e-9, "point {i}");
                } else {
                    assert!(loo[i].1 >= v + hyper.noise_std.powi(2) - 1e-12, "point {i}");
                }
            }
        }
    }

    #[test]
    fn grouped_loo_predicts_as_the_firmware_would_without_the_offsets() {
        let (z, y) = toy(30, 2);
        let groups: Vec<usize> = (0..30).map(|i| i / 6).collect();
        let hyper = Hyperparameters {
            length_scales: vec![0.8, 1.5],
            signal_std: 1.2,
            noise_std: 0.05,
            offset_std: Some(0.7),
        };
        for h in bases(&z) {
            let full = Posterior::grouped(&z, &y, &h, hyper.clone(), &groups).unwrap();
            let kinv = dense::inverse_from_cholesky(&full.chol);
            let members: Vec<Vec<usize>> = (0..5)
                .map(|g| (0..30).filter(|&i| groups[i] == g).collect())
                .collect();
            let by_group = group_loo(&kinv, &h, &y, &members).unwrap();
            let loo = full.loo();
            // Refit without the point (or its group) and predict with the kernel alone: the
            // offsets enter the training covariance, never the cross covariance.
            let refit = |keep: &[usize], i: usize| {
                let sub: Vec<usize> = keep.iter().map(|&j| groups[j]).collect();
                let p = Posterior::grouped(
                    &z.select_rows(keep),
                    &y.select_rows(keep),
                    &h.select_rows(keep),
                    hyper.clone(),
                    &sub,
                )
                .unwrap();
                p.predict(&[z[(i, 0)], z[(i, 1)]]).0 + h.row(i).dot(&p.beta.transpose()) - y[i]
            };
            for i in 0..30 {
                let others: Vec<usize> = (0..30).filter(|&j| j != i).collect();
                assert!((refit(&others, i) - loo[i].0).abs() < 1e-9, "point {i}");
                let rest: Vec<usize> = (0..30).filter(|&j| groups[j] != groups[i]).collect();
                assert!((refit(&rest, i) - by_group[i]).abs() < 1e-9, "group of {i}");
            }
        }
    }

    #[test]
    fn offsets_between_groups_are_fitted_and_leave_the_length_scale_alone() {
        // A smooth function of one input, each group of 12 samples shifted by its own offset.
        let mut rng = ChaCha8Rng::seed_from_u64(8);
        let shift: Vec<f64> = (0..8).map(|_| rng.random_range(-0.6f64..0.6)).collect();
        let x = DMatrix::from_fn(96, 1, |i, _| {
            -2.0 + 4.0 * (i % 12) as f64 / 11.0 + 0.01 * (i / 12) as f64
        });
        let groups: Vec<usize> = (0..96).map(|i| i / 12).collect();
        let y = DVector::from_fn(96, |i, _| (0.8 * x[(i, 0)]).sin() + shift[groups[i]]);
        let cfg = GpConfig::default();
        let m = GpModel::fit_grouped(&x, &y, &groups, &cfg).unwrap();
        let g = m.posterior.hyper.offset_std.unwrap() * m.output_scale;
        let spread = (shift.iter().map(|s| s * s).sum::<f64>() / 8.0).sqrt();
        assert!(
            (g / spread - 1.0).abs() < 0.5,
            "σ_g {g} against offsets' RMS {spread}"
        );
        let l = m.posterior.hyper.length_scales[0] * m.input_norm.scale[0];
        assert!(l > 0.5, "length scale {l}: the GP follows the offsets");
        assert!(m.predict(&[0.0]).noise_var > g * g * 0.99);
    }

    #[test]
    fn gls_recovers_a_linear_trend_under_the_gp() {
        let (z, f) = toy(40, 5);
        let h = bases(&z)[1].clone();
        let beta = DVector::from_row_slice(&[0.5, -2.0, 3.0]);
        let y = &f + &h * &beta;
        let hyper = Hyperparameters {
            length_scales: vec![0.8, 1.5],
            signal_std: 1.0,
            noise_std: 0.01,
            offset_std: None,
        };
        let with = Posterior::new(&z, &y, &h, hyper.clone()).unwrap();
        let without = Posterior::new(&z, &f, &DMatrix::zeros(40, 0), hyper).unwrap();
        // The trend goes into β̂, the rest into the GP as before.
        for i in 0..40 {
            let zi = [z[(i, 0)], z[(i, 1)]];
            let a = with.predict(&zi).0 + h.row(i).dot(&with.beta.transpose());
            let b = without.predict(&zi).0 + h.row(i).dot(&beta.transpose());
            assert!((a - b).abs() < 0.05, "{i}: {a} vs {b}");
        }
    }

    #[test]
    fn ard_sends_an_irrelevant_input_long() {
        let mut rng = ChaCha8Rng::seed_from_u64(3);
        let x = DMatrix::from_fn(60, 2, |_, _| rng.random_range(-2.0f64..2.0));
        let y = DVector::from_fn(60, |i, _| {
            (1.5 * x[(i, 0)]).sin() + 0.01 * rng.random::<f64>()
        });
        let cfg = GpConfig {
            mean: MeanBasis::Constant,
            ..GpConfig::default()
        };
        let m = GpModel::fit(&x, &y, &cfg).unwrap();
        let l = &m.posterior.hyper.length_scales;
        assert!(l[1] > 20.0 * l[0], "length scales {l:?}");
    }

    #[test]
    fn an_extension_is_searched_from_where_the_nested_fits_starts_ended() {
        let (x, y) = toy(60, 8);
        let cfg = GpConfig::default();
        let nested = GpModel::fit(&x, &y, &cfg).unwrap();
        let ends = nested.start_ends();
        // The four starts, not the polish from the best.
        assert_eq!(ends.len(), 4);
        assert_eq!(nested.starts.len(), 5);
        let terms = DMatrix::from_fn(60, 1, |i, _| x[(i, 0)].powi(3));
        let (extended, _) = GpModel::fit_with_terms(&x, &terms, &y, &[], &cfg, &nested).unwrap();
        let started: Vec<Vec<f64>> = extended.starts[..4]
            .iter()
            .map(|r| r.start.clone())
            .collect();
        assert_eq!(started, ends);
    }

    #[test]
    fn an_unpolished_fit_once_polished_is_the_fit() {
        let (x, y) = toy(48, 6);
        let groups: Vec<usize> = (0..48).map(|i| i / 12).collect();
        let cfg = GpConfig::default();
        let fit = GpModel::fit_grouped(&x, &y, &groups, &cfg).unwrap();
        let rough = GpModel::fit_grouped_unpolished(&x, &y, &groups, &cfg).unwrap();
        // The starts alone, ending where the fit's starts ended; the extension starts there too.
        assert!(rough.starts.iter().all(|r| !r.polish));
        assert_eq!(rough.start_ends(), fit.start_ends());
        assert_eq!(rough.starts.len() + 1, fit.starts.len());
        let polished = rough.clone().polished(&x, &y, &groups, &cfg).unwrap();
        assert_eq!(
            polished.posterior.hyper.to_log(),
            fit.posterior.hyper.to_log()
        );
        assert_eq!(polished.optimization, fit.optimization);
        assert!(polished.starts.last().is_some_and(|r| r.polish));
        assert!(
            polished.posterior.log_marginal_likelihood >= rough.posterior.log_marginal_likelihood
        );
        // A polished GP stays as it is; other data is refused.
        let again = polished.clone().polished(&x, &y, &groups, &cfg).unwrap();
        assert_eq!(again.starts.len(), polished.starts.len());
        let fewer = x.rows(0, 24).into_owned();
        let err = rough.polished(&fewer, &y.rows(0, 24).into_owned(), &groups[..24], &cfg);
        assert!(matches!(
            err,
            Err(GpError::NotItsData {
                fitted: 48,
                given: 24
            })
        ));
    }

    #[test]
    fn fit_beats_every_start_and_predicts_the_function() {
        let (x, y) = toy(80, 4);
        let m = GpModel::fit(&x, &y, &GpConfig::default()).unwrap();
        let best = m.log_marginal_likelihood();
        for r in &m.starts {
            if let Some(l) = r.log_marginal_likelihood {
                assert!(l <= best + 1e-9);
            }
        }
        let p = m.predict(&[0.3, -0.4]);
        let truth = (1.3f64 * 0.3).sin() + 0.4 * 0.16;
        assert!((p.mean - truth).abs() < 1e-3, "{} vs {truth}", p.mean);
        assert!(p.latent_var >= 0.0);
    }

    #[test]
    fn inducing_parses_and_chooses_by_size() {
        assert_eq!("auto".parse(), Ok(Inducing::Auto));
        assert_eq!("exact".parse(), Ok(Inducing::Exact));
        assert_eq!("24".parse(), Ok(Inducing::Count(24)));
        assert!("1".parse::<Inducing>().is_err());
        assert!("many".parse::<Inducing>().is_err());
        assert_eq!(Inducing::Auto.count(AUTO_EXACT_MAX), None);
        assert_eq!(
            Inducing::Auto.count(AUTO_EXACT_MAX + 1),
            Some(DEFAULT_INDUCING)
        );
        assert_eq!(Inducing::Count(50).count(40), None);
        assert_eq!(Inducing::Exact.count(1_000_000), None);
    }

    #[test]
    fn a_nan_likelihood_is_a_failed_start_never_the_best() {
        let nan = StartReport {
            samples: 10,
            start: vec![0.0; 4],
            end: Some(vec![1.0; 4]),
            log_marginal_likelihood: Some(f64::NAN),
            evaluations: 1,
            likelihoods: 1,
            status: String::new(),
            converged: false,
            polish: false,
        };
        let fine = StartReport {
            end: Some(vec![2.0; 4]),
            log_marginal_likelihood: Some(-1.0),
            ..nan.clone()
        };
        assert_eq!(best_of(&[nan, fine]).map(|b| b.0), Some(vec![2.0; 4]));
    }

    #[test]
    fn sigma_n_is_raised_only_along_a_flat_likelihood() {
        // d = 2: θ = (ln ℓ₁, ln ℓ₂, ln σ_f, ln σ_n). Flat in ln σ_n below −5, falling above it.
        let flat = |t: &[f64]| -> Result<(f64, Vec<f64>), GpError> {
            Ok((
                -t[0] * t[0] - 10.0 * (t[3] + 5.0).max(0.0).powi(2),
                vec![0.0; 4],
            ))
        };
        let bounds = Bounds::default();
        let start = vec![0.0, 0.0, 0.0, -12.0];
        let raised = raise_noise(&flat, start.clone(), 0.0, 2, &bounds);
        assert_eq!(raised, vec![0.0, 0.0, 0.0, -5.0]);
        // Peaked at ln σ_n = −12: one step would cost 0.25 nats, so θ stays.
        let peaked = |t: &[f64]| -> Result<(f64, Vec<f64>), GpError> {
            Ok((-(t[3] + 12.0).powi(2), vec![0.0; 4]))
        };
        assert_eq!(raise_noise(&peaked, start.clone(), 0.0, 2, &bounds), start);
        // An unevaluable step ends the raise where it is.
        let failing = failing_below(1.0);
        assert_eq!(
            raise_noise(&failing, start.clone(), -1.0, 2, &bounds),
            start
        );
    }

    /// A likelihood that cannot be evaluated below σ_n = `floor` (normalized).
    fn failing_below(floor: f64) -> impl Fn(&[f64]) -> Result<(f64, Vec<f64>), GpError> + Sync {
        move |t: &[f64]| match t.last() {
            Some(&ln_noise) if ln_noise >= floor.ln() => Ok((-1.0, vec![0.0; t.len()])),
            _ => Err(GpError::NotPositiveDefinite { jitter: 1.0 }),
        }
    }

    #[test]
    fn every_start_failing_falls_back_with_raised_noise() {
        let cfg = GpConfig::default();
        let likelihood = failing_below(5.0);
        let found = search(&likelihood, (10, 2), false, &cfg).unwrap();
        assert!(found.reports.iter().all(|r| r.end.is_none()));
        let Optimization::Fallback { noise_std, .. } = found.optimization else {
            panic!("{:?}", found.optimization);
        };
        assert!((noise_std - 10.0).abs() < 1e-9, "{noise_std}");
        assert_eq!(&found.theta[..3], &[0.0, 0.0, 0.0]);
        // Beyond the bound the fallback gives up, with every start's status.
        let never = failing_below(100.0);
        let e = search(&never, (10, 2), false, &cfg).err().unwrap();
        assert!(matches!(e, GpError::OptimizerFailed(_)), "{e}");
        assert_eq!(e.to_string().matches("stopped:").count(), 4, "{e}");
    }

    #[test]
    fn a_search_that_converges_nowhere_says_so_and_keeps_its_best() {
        let (x, y) = toy(40, 3);
        let capped = GpConfig {
            max_iters: 1,
            ..GpConfig::default()
        };
        let m = GpModel::fit(&x, &y, &capped).unwrap();
        assert!(m.starts.iter().all(|r| !r.converged));
        let Optimization::StoppedEarly {
            log_marginal_likelihood,
        } = m.optimization
        else {
            panic!("{:?}", m.optimization);
        };
        assert!((log_marginal_likelihood - m.log_marginal_likelihood()).abs() < 1e-9);
        assert!(
            m.warnings()[0].contains("converged from no start"),
            "{:?}",
            m.warnings()
        );
        let free = GpModel::fit(&x, &y, &GpConfig::default()).unwrap();
        assert_eq!(free.optimization, Optimization::Converged);
        assert!(free.warnings().is_empty(), "{:?}", free.warnings());
        assert!(free.log_marginal_likelihood() > log_marginal_likelihood);
    }

    /// A likelihood rough at rounding level near its maximum, as an ill-conditioned K makes it: a
    /// smooth bowl plus wiggles of 1e-7 per sample, and a gradient whose wiggles never let the
    /// polish's tolerance be met. The polish stops on the stall, well inside its budget, and keeps
    /// the best point; a run on the bowl alone converges without stalling.
    #[test]
    fn a_run_stops_when_its_gains_sink_below_rounding_and_keeps_its_best() {
        let n = 1000.0;
        let rough = |t: &[f64]| -> Result<(f64, Vec<f64>), GpError> {
            let wiggle: f64 = t.iter().map(|v| (v * 1e6).sin()).sum();
            let lml = -n * (t.iter().map(|v| (v - 0.5).powi(2)).sum::<f64>() + 1e-7 * wiggle);
            let grad = t
                .iter()
                .map(|v| -n * (2.0 * (v - 0.5) + 1e-3 * (v * 1e6).cos()))
                .collect();
            Ok((lml, grad))
        };
        let ranges = GpConfig::default().bounds.ranges(2, 4);
        let start = vec![0.4, 0.45, 0.3, 0.6];
        let run = optimize_from(&rough, 1000, start.clone(), &ranges, 100, POLISH);
        assert!(run.status.contains("stalled"), "{}", run.status);
        assert!(run.evaluations < POLISH.budget, "{}", run.evaluations);
        let end = run.end.unwrap();
        assert!(end.iter().all(|v| (v - 0.5).abs() < 1e-2), "{end:?}");
        assert_eq!(run.log_marginal_likelihood, Some(rough(&end).unwrap().0));

        let smooth = |t: &[f64]| -> Result<(f64, Vec<f64>), GpError> {
            let lml = -n * t.iter().map(|v| (v - 0.5).powi(2)).sum::<f64>();
            Ok((lml, t.iter().map(|v| -2.0 * n * (v - 0.5)).collect()))
        };
        let run = optimize_from(&smooth, 1000, start, &ranges, 100, POLISH);
        assert!(run.converged, "{}", run.status);
    }

    #[test]
    fn jitter_escalates_on_a_singular_matrix() {
        let k = DMatrix::from_element(3, 3, 1.0);
        let (_, jitter) = cholesky_with_jitter(k).unwrap();
        assert!(jitter > 0.0);
    }

    #[test]
    fn a_non_finite_covariance_is_refused_before_any_jitter() {
        for bad in [f64::NAN, f64::INFINITY] {
            let mut k = DMatrix::identity(4, 4) * 2.0;
            k[(3, 1)] = bad;
            assert!(matches!(
                cholesky_with_jitter(k),
                Err(GpError::NotPositiveDefinite { jitter: 0.0 })
            ));
        }
    }
}
