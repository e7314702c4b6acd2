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
//! overshooting into it (as a line search against a penalty wall does). The bounds
//! keep ℓ ≥ 0.1 and σ_f ≤ 10 (normalized units): below 0.1 each rate
//! level becomes its own independent GP, and above 10 the GP and the basis trade off along a ridge
//! with huge cancelling weights (f32 study). The closed-form LOO holds θ fixed (as R&W §5.4.2
//! does).

use nalgebra::{Cholesky, DMatrix, Dyn};
use serde::Serialize;

use crate::models::dense;

mod config;
mod likelihood;
mod optimize;
mod posterior;

pub use config::{AUTO_EXACT_MAX, Bounds, DEFAULT_INDUCING, GpConfig, Inducing};
pub use likelihood::lml_and_gradient;
pub(crate) use optimize::{
    Likelihood, Searched, Stopping, best_of, explore, optimize_from, polish, search, search_from,
    starts, walk_noise,
};
pub use optimize::{Optimization, Prepared, StartReport};
pub(crate) use posterior::with_terms;
pub use posterior::{Posterior, group_loo};

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
pub(super) fn cholesky_built(
    build: impl Fn() -> DMatrix<f64>,
) -> Result<(Cholesky<f64, Dyn>, f64), GpError> {
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

#[cfg(test)]
mod tests;
