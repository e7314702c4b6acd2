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

mod config;
mod error;
mod hyper;
mod likelihood;
mod optimize;
mod posterior;

pub use config::{AUTO_EXACT_MAX, Bounds, DEFAULT_INDUCING, GpConfig, Inducing};
pub use error::GpError;
pub use hyper::Hyperparameters;
pub use likelihood::lml_and_gradient;
pub(crate) use optimize::{
    Likelihood, Searched, Stopping, best_of, explore, optimize_from, polish, search, search_from,
    starts, walk_noise,
};
pub use optimize::{Optimization, Prepared, StartReport};
pub(crate) use posterior::with_terms;
pub use posterior::{Posterior, cholesky_with_jitter, group_loo};

#[cfg(test)]
mod tests;
