//! The fitted posterior: predictive mean and variance, the closed-form leave-one-out and its
//! leave-one-group-out counterpart.

use nalgebra::{Cholesky, DMatrix, DVector, Dyn};

use super::error::GpError;
use super::hyper::Hyperparameters;
use crate::models::dense;
use crate::models::kernel;

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
    pub(super) fn from_gram(
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
    pub(super) fn projected_inverse_lower(&self) -> DMatrix<f64> {
        let mut p = dense::inverse_lower(&self.chol);
        if self.basis_factor.ncols() > 0 {
            dense::subtract_outer_lower(&mut p, &self.basis_factor);
        }
        p
    }

    /// Predictive mean and latent variance at one normalized sample (normalized units).
    pub fn predict(&self, z: &[f64]) -> (f64, f64) {
        let kstar = self.cross_covariance(z);
        let mean = kstar.dot(&self.alpha);
        let v = self
            .chol
            .l_dirty()
            .solve_lower_triangular(&kstar)
            .unwrap_or_else(|| DVector::zeros(kstar.len()));
        (
            mean,
            (self.hyper.signal_std.powi(2) - v.norm_squared()).max(0.0),
        )
    }

    /// [`Self::predict`]'s mean alone, bit for bit: without the variance's triangular solve,
    /// O(n²) a sample against the mean's O(n).
    pub fn predict_mean(&self, z: &[f64]) -> f64 {
        self.cross_covariance(z).dot(&self.alpha)
    }

    /// The prior covariance between one normalized sample and each training input.
    fn cross_covariance(&self, z: &[f64]) -> DVector<f64> {
        kernel::cross(&self.xs, z, &self.hyper.length_scales) * self.hyper.signal_std.powi(2)
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
pub(crate) fn with_terms(h: &DMatrix<f64>, terms: &DMatrix<f64>) -> (DMatrix<f64>, Vec<f64>) {
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
