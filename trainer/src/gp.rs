//! Exact Gaussian-process regression as in the reference paper (He et al.), with the numerics of
//! Rasmussen & Williams (R&W), *Gaussian Processes for Machine Learning*, 2006.
//!
//! Model, on normalized inputs z and normalized output y = (ω − m(z)) / s_y:
//!
//! ```text
//! y = f(z) + ε,  f ~ GP(0, k),  ε ~ N(0, σ_n²),   k = ARD squared exponential (kernel.rs)
//! K = k(Z, Z) + σ_n² I = L Lᵀ,  α = K⁻¹ y
//! mean      μ(z*) = k*ᵀ α                                   (paper eq. 8, R&W eq. 2.25)
//! variance  σ²(z*) = k(z*, z*) − vᵀv,  L v = k*             (paper eq. 9, R&W eq. 2.26)
//! log ML    log p(y|θ) = −½ yᵀα − Σ log L_ii − n/2 log 2π   (paper eq. 11, R&W eq. 2.30)
//! gradient  ∂/∂θ_j = ½ tr((ααᵀ − K⁻¹) ∂K/∂θ_j)              (paper eq. 12, R&W eq. 5.9)
//! LOO       y_i − μ_{−i} = α_i / [K⁻¹]_ii,  σ²_{−i} = 1/[K⁻¹]_ii   (R&W eq. 5.12)
//! ```
//!
//! θ = (ln ℓ_1 … ln ℓ_d, ln σ_f, ln σ_n), maximized with L-BFGS (argmin, Moré–Thuente line search)
//! from several starts in parallel, the paper's (all zero) among them, at a loose tolerance; then a
//! short polish from the best at a tight one. Box bounds: the likelihood is evaluated at the clamped
//! θ, with a quadratic wall outside, so no trial step builds a non-finite K. The prior mean m is a
//! least-squares polynomial (prior.rs); it and the normalization are fixed before the
//! hyperparameters are fitted, and the closed-form LOO holds them fixed as it holds θ fixed (as R&W
//! §5.4.2 does).

use std::sync::Mutex;
use std::time::Instant;

use argmin::core::{CostFunction, Executor, Gradient, State};
use argmin::solver::linesearch::MoreThuenteLineSearch;
use argmin::solver::quasinewton::LBFGS;
use nalgebra::{Cholesky, DMatrix, DVector, Dyn};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use serde::Serialize;

use crate::kernel;
use crate::normalize::Normalizer;
use crate::prior::PolyPrior;

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
}

impl Default for Bounds {
    fn default() -> Self {
        Self {
            log_length: (1e-2f64.ln(), 1e3f64.ln()),
            log_signal: (1e-3f64.ln(), 1e3f64.ln()),
            log_noise: (1e-6f64.ln(), 1e1f64.ln()),
        }
    }
}

impl Bounds {
    fn range(&self, d: usize, j: usize) -> (f64, f64) {
        match j {
            j if j < d => self.log_length,
            j if j == d => self.log_signal,
            _ => self.log_noise,
        }
    }

    fn clamp(&self, theta: &[f64]) -> Vec<f64> {
        let d = theta.len() - 2;
        theta
            .iter()
            .enumerate()
            .map(|(j, &t)| {
                let (lo, hi) = self.range(d, j);
                t.clamp(lo, hi)
            })
            .collect()
    }
}

/// Fit settings.
#[derive(Debug, Clone, Serialize)]
pub struct GpConfig {
    /// Random starts in addition to the paper's start (all zero) and a data-informed one.
    pub random_starts: usize,
    /// Seed of the random starts.
    pub seed: u64,
    /// Total degree of the polynomial prior mean.
    pub prior_degree: u8,
    /// Hyperparameter bounds.
    pub bounds: Bounds,
    /// L-BFGS iteration cap per start.
    pub max_iters: u64,
}

impl Default for GpConfig {
    fn default() -> Self {
        Self {
            random_starts: 2,
            seed: 0,
            prior_degree: 0,
            bounds: Bounds::default(),
            max_iters: 100,
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
}

impl Hyperparameters {
    /// From θ = (ln ℓ…, ln σ_f, ln σ_n).
    pub fn from_log(theta: &[f64]) -> Self {
        let d = theta.len() - 2;
        Self {
            length_scales: theta[..d].iter().map(|t| t.exp()).collect(),
            signal_std: theta[d].exp(),
            noise_std: theta[d + 1].exp(),
        }
    }

    /// θ = (ln ℓ…, ln σ_f, ln σ_n).
    pub fn to_log(&self) -> Vec<f64> {
        let mut t: Vec<f64> = self.length_scales.iter().map(|l| l.ln()).collect();
        t.push(self.signal_std.ln());
        t.push(self.noise_std.ln());
        t
    }
}

/// Cholesky factorization with jitter escalation: none first, then 1e-10 … 1e-4 of the mean
/// diagonal, ×10 each step. Returns the factor and the jitter that was needed.
pub fn cholesky_with_jitter(k: DMatrix<f64>) -> Result<(Cholesky<f64, Dyn>, f64), GpError> {
    let mean_diag = k.diagonal().mean();
    if !mean_diag.is_finite() || mean_diag <= 0.0 || k.iter().any(|v| !v.is_finite()) {
        return Err(GpError::NotPositiveDefinite { jitter: 0.0 });
    }
    let jitters = std::iter::once(0.0).chain((0..7).map(|e| mean_diag * 10f64.powi(e - 10)));
    let mut tried = 0.0;
    for jitter in jitters {
        tried = jitter;
        let mut kj = k.clone();
        for i in 0..kj.nrows() {
            kj[(i, i)] += jitter;
        }
        if let Some(c) = Cholesky::new(kj) {
            return Ok((c, jitter));
        }
    }
    Err(GpError::NotPositiveDefinite { jitter: tried })
}

/// K⁻¹ from its Cholesky factor as L⁻ᵀ L⁻¹. L⁻¹ is formed column by column from the zero pattern
/// of the identity (n³/6 flops; nalgebra's general triangular solve would spend n³/2), the product
/// runs through the blocked matrix kernel. This is the inner loop of every likelihood gradient.
pub fn inverse_from_cholesky(chol: &Cholesky<f64, Dyn>) -> DMatrix<f64> {
    let l = chol.l_dirty();
    let n = l.nrows();
    let lcols = l.as_slice();
    let mut linv = DMatrix::<f64>::zeros(n, n);
    for (j, x) in linv.as_mut_slice().chunks_exact_mut(n).enumerate() {
        // Forward substitution L x = e_j, column-oriented so every inner loop is contiguous.
        x[j] = 1.0;
        for k in j..n {
            let col = &lcols[k * n..(k + 1) * n];
            x[k] /= col[k];
            let xk = x[k];
            for (xi, li) in x[k + 1..].iter_mut().zip(&col[k + 1..]) {
                *xi -= xk * li;
            }
        }
    }
    // `transpose() * ` goes through the blocked matrix product; `tr_mul` is 4× slower here.
    linv.transpose() * &linv
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
    /// K⁻¹ y.
    pub alpha: DVector<f64>,
    /// Diagonal jitter that the factorization needed.
    pub jitter: f64,
    /// Log marginal likelihood of the normalized data.
    pub log_marginal_likelihood: f64,
}

impl Posterior {
    /// Conditions the GP on normalized inputs `z` and outputs `y`.
    pub fn new(
        z: &DMatrix<f64>,
        y: &DVector<f64>,
        hyper: Hyperparameters,
    ) -> Result<Self, GpError> {
        let xs = kernel::scale_inputs(z, &hyper.length_scales);
        let gram = kernel::gram(&xs);
        Self::from_gram(xs, &gram, y, hyper)
    }

    /// Conditions on scaled inputs whose unit-variance Gram matrix is already known.
    fn from_gram(
        xs: DMatrix<f64>,
        gram: &DMatrix<f64>,
        y: &DVector<f64>,
        hyper: Hyperparameters,
    ) -> Result<Self, GpError> {
        let mut k = gram * hyper.signal_std.powi(2);
        for i in 0..k.nrows() {
            k[(i, i)] += hyper.noise_std.powi(2);
        }
        let (chol, jitter) = cholesky_with_jitter(k)?;
        let alpha = chol.solve(y);
        let n = y.len() as f64;
        let log_det_half: f64 = chol.l_dirty().diagonal().iter().map(|v| v.ln()).sum();
        let lml = -0.5 * y.dot(&alpha) - log_det_half - 0.5 * n * (2.0 * std::f64::consts::PI).ln();
        Ok(Self {
            hyper,
            xs,
            chol,
            alpha,
            jitter,
            log_marginal_likelihood: lml,
        })
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
    pub fn loo(&self) -> Vec<(f64, f64)> {
        let kinv = inverse_from_cholesky(&self.chol);
        self.alpha
            .iter()
            .enumerate()
            .map(|(i, a)| {
                let kii = kinv[(i, i)];
                (-a / kii, 1.0 / kii)
            })
            .collect()
    }
}

/// Log marginal likelihood and its gradient w.r.t. θ (paper eq. 11–12).
pub fn lml_and_gradient(
    z: &DMatrix<f64>,
    y: &DVector<f64>,
    theta: &[f64],
) -> Result<(f64, Vec<f64>), GpError> {
    let d = z.ncols();
    let hyper = Hyperparameters::from_log(theta);
    let xs = kernel::scale_inputs(z, &hyper.length_scales);
    let gram = kernel::gram(&xs);
    let post = Posterior::from_gram(xs, &gram, y, hyper)?;
    let sf2 = post.hyper.signal_std.powi(2);
    let sn2 = post.hyper.noise_std.powi(2);
    let kinv = inverse_from_cholesky(&post.chol);
    let n = y.len();
    let mut grad = vec![0.0; d + 2];
    // W = ααᵀ − K⁻¹; ∂K/∂ln ℓ_k = K_se ∘ (Δz_k/ℓ_k)², ∂K/∂ln σ_f = 2 K_se, ∂K/∂ln σ_n = 2 σ_n² I.
    // Both W and ∂K are symmetric: the strict lower triangle counts twice, the diagonal once.
    for j in 0..n {
        for i in j..n {
            let weight = if i == j { 0.5 } else { 1.0 };
            let w = post.alpha[i] * post.alpha[j] - kinv[(i, j)];
            let wk = weight * w * sf2 * gram[(i, j)];
            for (k, g) in grad.iter_mut().take(d).enumerate() {
                *g += wk * (post.xs[(i, k)] - post.xs[(j, k)]).powi(2);
            }
            grad[d] += 2.0 * wk;
        }
    }
    grad[d + 1] = sn2
        * (0..n)
            .map(|i| post.alpha[i].powi(2) - kinv[(i, i)])
            .sum::<f64>();
    Ok((post.log_marginal_likelihood, grad))
}

/// The L-BFGS objective: −log ML plus a quadratic penalty outside the bounds. Cost and gradient
/// come from one evaluation, cached, because argmin asks for them separately. Where the likelihood
/// is numerically rough (tiny noise, jitter switching on) a line search can stall; an evaluation
/// budget stops it, and the best point seen is kept either way.
struct Objective<'a> {
    z: &'a DMatrix<f64>,
    y: &'a DVector<f64>,
    bounds: Bounds,
    cache: Mutex<Option<Evaluated>>,
    track: &'a Mutex<Track>,
    budget: u64,
}

/// One objective evaluation: θ, cost, gradient.
type Evaluated = (Vec<f64>, f64, Vec<f64>);

/// Evaluation count and the best in-bounds point seen.
#[derive(Default)]
struct Track {
    evaluations: u64,
    best: Option<(f64, Vec<f64>)>,
}

/// Penalty weight outside the bounds, against a per-sample cost whose gradient is O(1).
const PENALTY: f64 = 10.0;

impl Objective<'_> {
    fn evaluate(&self, theta: &[f64]) -> Result<(f64, Vec<f64>), argmin::core::Error> {
        // Every call counts, cached or not: a stalled line search may ask for one point forever.
        if let Ok(mut t) = self.track.lock() {
            if t.evaluations >= self.budget {
                return Err(argmin::core::Error::msg("evaluation budget exhausted"));
            }
            t.evaluations += 1;
        }
        if let Ok(cache) = self.cache.lock()
            && let Some((t, c, g)) = cache.as_ref()
            && t.as_slice() == theta
        {
            return Ok((*c, g.clone()));
        }
        // The likelihood is evaluated at the clamped point, so K stays finite whatever step the
        // line search tries; outside the bounds a quadratic wall pulls back. Costs are per sample so
        // that gradients are O(1) whatever n is, which keeps L-BFGS's first steps sane.
        let inside = self.bounds.clamp(theta);
        let (lml, grad) = lml_and_gradient(self.z, self.y, &inside)?;
        let n = self.y.len() as f64;
        let mut cost = -lml / n;
        let mut g: Vec<f64> = grad.iter().map(|v| -v / n).collect();
        let mut outside = false;
        for (j, (&t, &c)) in theta.iter().zip(&inside).enumerate() {
            let excess = t - c;
            if excess != 0.0 {
                outside = true;
                cost += PENALTY * excess * excess;
                g[j] = 2.0 * PENALTY * excess;
            }
        }
        if let Ok(mut t) = self.track.lock()
            && !outside
            && t.best.as_ref().is_none_or(|(c, _)| cost < *c)
        {
            t.best = Some((cost, theta.to_vec()));
        }
        if let Ok(mut cache) = self.cache.lock() {
            *cache = Some((theta.to_vec(), cost, g.clone()));
        }
        Ok((cost, g))
    }
}

impl CostFunction for Objective<'_> {
    type Param = Vec<f64>;
    type Output = f64;
    fn cost(&self, p: &Vec<f64>) -> Result<f64, argmin::core::Error> {
        self.evaluate(p).map(|(c, _)| c)
    }
}

impl Gradient for Objective<'_> {
    type Param = Vec<f64>;
    type Gradient = Vec<f64>;
    fn gradient(&self, p: &Vec<f64>) -> Result<Vec<f64>, argmin::core::Error> {
        self.evaluate(p).map(|(_, g)| g)
    }
}

/// What one optimizer start did.
#[derive(Debug, Clone, Serialize)]
pub struct StartReport {
    /// Where it started (θ).
    pub start: Vec<f64>,
    /// Where it ended (θ, clamped to the bounds), if it succeeded.
    pub end: Option<Vec<f64>>,
    /// Log marginal likelihood at the end.
    pub log_marginal_likelihood: Option<f64>,
    /// L-BFGS iterations.
    pub iterations: u64,
    /// Objective calls (cost and gradient requests, cached ones included).
    pub evaluations: u64,
    /// Termination status or error.
    pub status: String,
}

/// Gradient tolerance (per-sample cost) and objective-call budget of the search from every start,
/// and of the final polish from the best one: the searches only have to find the right basin, the
/// polish converges in it. Near the optimum the likelihood is flat to rounding and line searches
/// stall, so the polish gets a small budget: its gain comes in its first iterations.
const SEARCH: (f64, u64) = (1e-3, 120);
const POLISH: (f64, u64) = (1e-5, 40);

fn optimize_from(
    z: &DMatrix<f64>,
    y: &DVector<f64>,
    start: Vec<f64>,
    cfg: &GpConfig,
    (tolerance, budget): (f64, u64),
) -> StartReport {
    let track = Mutex::new(Track::default());
    let problem = Objective {
        z,
        y,
        bounds: cfg.bounds,
        cache: Mutex::new(None),
        track: &track,
        budget,
    };
    let solver = LBFGS::new(MoreThuenteLineSearch::new(), 7)
        .with_tolerance_grad(tolerance)
        .and_then(|s| s.with_tolerance_cost(tolerance * 1e-4));
    let result = solver.and_then(|solver| {
        Executor::new(problem, solver)
            .configure(|state| state.param(start.clone()).max_iters(cfg.max_iters))
            .run()
    });
    let (iterations, status) = match &result {
        Ok(res) => (
            res.state().get_iter(),
            res.state().get_termination_status().to_string(),
        ),
        Err(e) => (0, format!("stopped: {e}")),
    };
    let (evaluations, best) = track
        .into_inner()
        .map(|t| (t.evaluations, t.best))
        .unwrap_or_default();
    // The solver's own best point may carry the out-of-bounds penalty; the tracked best never does.
    let end = best.map(|(_, t)| cfg.bounds.clamp(&t));
    let lml = end
        .as_ref()
        .and_then(|t| Posterior::new(z, y, Hyperparameters::from_log(t)).ok())
        .map(|p| p.log_marginal_likelihood);
    StartReport {
        start,
        end,
        log_marginal_likelihood: lml,
        iterations,
        evaluations,
        status,
    }
}

/// The optimizer starts: the paper's (all zero), a data-informed one (unit length scales and
/// signal, noise at 1% of the output spread), then `random_starts` drawn inside the bounds' middle.
fn starts(d: usize, cfg: &GpConfig) -> Vec<Vec<f64>> {
    let mut out = vec![vec![0.0; d + 2]];
    let mut informed = vec![0.0; d + 2];
    informed[d + 1] = 0.01f64.ln();
    out.push(informed);
    let mut rng = ChaCha8Rng::seed_from_u64(cfg.seed);
    for _ in 0..cfg.random_starts {
        let mut t: Vec<f64> = (0..d).map(|_| rng.random_range(-2.0..3.0)).collect();
        t.push(rng.random_range(-1.5..1.5));
        t.push(rng.random_range(-9.0..-2.0));
        out.push(t);
    }
    out
}

/// A fitted GP in physical units: normalization, prior mean, posterior.
#[derive(Debug, Clone)]
pub struct GpModel {
    /// Input normalization.
    pub input_norm: Normalizer,
    /// Trained range (min, max) of each raw input: beyond it the model extrapolates.
    pub input_range: Vec<(f64, f64)>,
    /// Prior mean over normalized inputs, in output units.
    pub prior: PolyPrior,
    /// Output scale s_y: the GP models (ω − m) / s_y.
    pub output_scale: f64,
    /// The conditioned GP (normalized units).
    pub posterior: Posterior,
    /// Normalized training targets.
    pub y: DVector<f64>,
    /// What each optimizer start did; the last entry is the polish from the best of them.
    pub starts: Vec<StartReport>,
    /// Wall time of the whole fit, s.
    pub fit_seconds: f64,
}

/// A prediction in output units.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Prediction {
    /// Predictive mean.
    pub mean: f64,
    /// Latent (model) variance, without observation noise.
    pub latent_var: f64,
    /// Observation-noise variance.
    pub noise_var: f64,
}

/// Normalizes the data and fits the prior mean: returns (normalizer, prior, s_y, z, y).
pub fn prepare(
    x: &DMatrix<f64>,
    target: &DVector<f64>,
    prior_degree: u8,
) -> (Normalizer, PolyPrior, f64, DMatrix<f64>, DVector<f64>) {
    let norm = Normalizer::fit(x);
    let z = norm.apply(x);
    let prior = PolyPrior::fit(&z, target, prior_degree);
    let resid = target - prior.eval_all(&z);
    let n = resid.len().max(1) as f64;
    let mean = resid.sum() / n;
    let sd = (resid.iter().map(|r| (r - mean).powi(2)).sum::<f64>() / n).sqrt();
    let scale_floor = 1e-12 * target.amax().max(1.0);
    let s = sd.max(scale_floor);
    (norm, prior, s, z, resid / s)
}

impl GpModel {
    /// Fits the GP to raw inputs `x` (rows are samples) and targets.
    pub fn fit(x: &DMatrix<f64>, target: &DVector<f64>, cfg: &GpConfig) -> Result<Self, GpError> {
        if x.nrows() < 3 {
            return Err(GpError::TooFewSamples(x.nrows()));
        }
        let t0 = Instant::now();
        let (input_norm, prior, output_scale, z, y) = prepare(x, target, cfg.prior_degree);
        let reports: Vec<StartReport> = starts(z.ncols(), cfg)
            .into_par_iter()
            .map(|s| optimize_from(&z, &y, s, cfg, SEARCH))
            .collect();
        let best_of = |reports: &[StartReport]| {
            reports
                .iter()
                .filter_map(|r| Some((r.end.clone()?, r.log_marginal_likelihood?)))
                .max_by(|a, b| a.1.total_cmp(&b.1))
        };
        let searched = best_of(&reports).ok_or_else(|| {
            GpError::OptimizerFailed(
                reports
                    .iter()
                    .map(|r| r.status.clone())
                    .collect::<Vec<_>>()
                    .join("; "),
            )
        })?;
        let mut reports = reports;
        reports.push(optimize_from(&z, &y, searched.0.clone(), cfg, POLISH));
        let best = best_of(&reports).map_or(searched.0, |b| b.0);
        let posterior = Posterior::new(&z, &y, Hyperparameters::from_log(&best))?;
        let input_range = x.column_iter().map(|c| (c.min(), c.max())).collect();
        Ok(Self {
            input_norm,
            input_range,
            prior,
            output_scale,
            posterior,
            y,
            starts: reports,
            fit_seconds: t0.elapsed().as_secs_f64(),
        })
    }

    /// Prediction at one raw sample.
    pub fn predict(&self, x: &[f64]) -> Prediction {
        let z = self.input_norm.apply_row(x);
        let (m, v) = self.posterior.predict(&z);
        let s2 = self.output_scale.powi(2);
        Prediction {
            mean: self.prior.eval(&z) + self.output_scale * m,
            latent_var: v * s2,
            noise_var: self.posterior.hyper.noise_std.powi(2) * s2,
        }
    }

    /// Closed-form LOO errors (prediction − target) in output units.
    pub fn loo_errors(&self) -> Vec<f64> {
        self.posterior
            .loo()
            .into_iter()
            .map(|(e, _)| e * self.output_scale)
            .collect()
    }

    /// Log marginal likelihood of the normalized data at the fitted hyperparameters.
    pub fn log_marginal_likelihood(&self) -> f64 {
        self.posterior.log_marginal_likelihood
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn toy(n: usize, seed: u64) -> (DMatrix<f64>, DVector<f64>) {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let x = DMatrix::from_fn(n, 2, |_, _| rng.random_range(-2.0f64..2.0));
        let y = DVector::from_fn(n, |i, _| (1.3 * x[(i, 0)]).sin() + 0.4 * x[(i, 1)].powi(2));
        (x, y)
    }

    #[test]
    fn analytic_gradient_matches_finite_differences() {
        let (z, y) = toy(25, 1);
        let y = y.map(|v| v + 0.01);
        for theta in [vec![0.0, 0.0, 0.0, 0.0], vec![-0.3, 0.7, 0.2, -2.5]] {
            let (_, g) = lml_and_gradient(&z, &y, &theta).unwrap();
            for j in 0..theta.len() {
                let h = 1e-5;
                let mut tp = theta.clone();
                tp[j] += h;
                let mut tm = theta.clone();
                tm[j] -= h;
                let fd = (lml_and_gradient(&z, &y, &tp).unwrap().0
                    - lml_and_gradient(&z, &y, &tm).unwrap().0)
                    / (2.0 * h);
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
        let p = Posterior::new(&z, &y, Hyperparameters::from_log(&[0.0, 0.0, 0.0])).unwrap();
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
        };
        let full = Posterior::new(&z, &y, hyper.clone()).unwrap();
        let loo = full.loo();
        for i in 0..z.nrows() {
            let keep: Vec<usize> = (0..z.nrows()).filter(|&j| j != i).collect();
            let zi = z.select_rows(&keep);
            let yi = y.select_rows(&keep);
            let p = Posterior::new(&zi, &yi, hyper.clone()).unwrap();
            let (m, v) = p.predict(&[z[(i, 0)], z[(i, 1)]]);
            assert!((m - y[i] - loo[i].0).abs() < 1e-9, "point {i}");
            assert!(
                (v + hyper.noise_std.powi(2) - loo[i].1).abs() < 1e-9,
                "point {i}"
            );
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
            prior_degree: 0,
            ..GpConfig::default()
        };
        let m = GpModel::fit(&x, &y, &cfg).unwrap();
        let l = &m.posterior.hyper.length_scales;
        assert!(l[1] > 20.0 * l[0], "length scales {l:?}");
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
    fn jitter_escalates_on_a_singular_matrix() {
        let k = DMatrix::from_element(3, 3, 1.0);
        let (_, jitter) = cholesky_with_jitter(k).unwrap();
        assert!(jitter > 0.0);
    }
}
