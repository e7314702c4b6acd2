//! Sparse GP for long streams: Titsias' variational free energy (VFE; M. Titsias, "Variational
//! learning of inducing variables in sparse Gaussian processes", AISTATS 2009).
//!
//! Why VFE rather than FITC: VFE maximizes a lower bound on the exact marginal likelihood, so more
//! inducing points can only tighten it and the hyperparameters approach the exact GP's as m grows.
//! FITC's per-sample noise correction lets it explain data by moving inducing variance instead,
//! which underestimates σ_n and overfits (Bauer, van der Wilk & Rasmussen, NeurIPS 2016). On 1 Hz
//! stream samples σ_n is the gyro's angle random walk, and the firmware's ±2σ band rests on it.
//!
//! ```text
//! F = log N(y | 0, Q + σ²I) − tr(K_nn − Q) / (2σ²),   Q = K_nm K_mm⁻¹ K_mn
//! S = K_mn K_nm,  b = K_mn y,  A = K_mm + σ⁻² S,  K_mm = L Lᵀ,  B = I + σ⁻² L⁻¹ S L⁻ᵀ = L_B L_Bᵀ
//! log|Q + σ²I| = log|B| + n log σ²,     yᵀ(Q + σ²I)⁻¹y = σ⁻² yᵀy − σ⁻⁴ bᵀA⁻¹b
//! mean  μ(z*) = k*ᵀ w,  w = σ⁻² A⁻¹ b;   latent variance  k** − k*ᵀ (K_mm⁻¹ − A⁻¹) k*
//! ```
//!
//! The firmware evaluates the variance as k** − ‖v‖² with L_Q v = k* (docs/design.md §4): the
//! factor is the Cholesky factor of (K_mm⁻¹ − A⁻¹)⁻¹ = L (I + C⁻¹) Lᵀ, C = σ⁻² L⁻¹ S L⁻ᵀ, built
//! from C's
//! eigenvalues (those below 1e-6, directions no sample informs, are raised to it: the variance
//! there is the prior's to within 1e-6). One evaluator serves exact and sparse models.
//!
//! Gradient, with α = (Q + σ²I)⁻¹ y, u = K_mm⁻¹ K_mn α and D = K_mm⁻¹ − A⁻¹ (derived from
//! dQ = ∂K_nm P + Pᵀ ∂K_mn − Pᵀ ∂K_mm P, P = K_mm⁻¹ K_mn, and P (Q + σ²I)⁻¹ = σ⁻² A⁻¹ K_mn, which
//! keeps every n×n matrix out):
//!
//! ```text
//! ∂F = Σ G∘∂K_mn − ½ Σ H∘∂K_mm + ½ (tr W + (nσ_f² − tr Q) / σ⁴) ∂σ² − n ∂σ_f² / (2σ²)
//! G = u αᵀ + σ⁻² D K_mn,   H = u uᵀ − D + σ⁻² K_mm⁻¹ S K_mm⁻¹,   tr W = αᵀα − σ⁻² (n − m + tr A⁻¹K_mm)
//! ```
//!
//! Each evaluation is O(n m²), over chunks of samples in parallel; memory O(n m).
//!
//! The fit: hyperparameters of an exact GP on a subset of the samples, half spread over the inputs
//! and half random (`start_subset`; all the optimizer starts of the exact GP, cheap at that size);
//! inducing points chosen greedily in that kernel's metric ([`select`]); then L-BFGS-B on the bound
//! from there. The prior mean stays the ordinary least-squares
//! fit of the basis (the exact GP re-estimates it by GLS): with n ≫ m samples the two differ little,
//! and marginalizing it through the bound would add a p×p term to every gradient for no measured gain.

use std::ops::Range;

use nalgebra::{Cholesky, DMatrix, DVector, Dyn, SymmetricEigen};
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use serde::Serialize;

use super::exact::{
    self, GpConfig, GpError, Hyperparameters, Optimization, Posterior, Prepared, StartReport,
    cholesky_with_jitter, lml_and_gradient,
};
use crate::models::kernel;

/// Samples whose kernel rows are computed together (one parallel task).
const CHUNK: usize = 4096;
/// Diagonal added to K_mm relative to σ_f²: inducing points close in the kernel's metric make it
/// near-singular. Part of the model (prediction uses the same K_mm).
const JITTER: f64 = 1e-6;
/// Greedy selection stops when the best remaining sample is this well explained (residual
/// variance relative to σ_f², ten times the jitter): a closer inducing point adds nothing but
/// ill-conditioning of K_mm.
const MIN_RESIDUAL: f64 = 10.0 * JITTER;
/// The smallest eigenvalue of C kept in the variance factor (module doc).
const MIN_EIGENVALUE: f64 = 1e-6;
/// Selection–refinement rounds of a sparse fit.
const ROUNDS: usize = 2;
/// Residual variance (relative to σ_f², in the model's own metric) below which [`select`] passes
/// a sample over: it bounds how close to dependent K_mm's columns get, and with it the size of
/// the mean weights against the f32 rounding of the kernel values.
const MIN_GUARD_RESIDUAL: f64 = 1e-4;
/// Longest length scale (normalized units) of the metric inducing points are selected in.
const SELECTION_MAX_LENGTH: f64 = 1.0;
/// Samples of the exact GP that gives the starting hyperparameters.
pub const SUBSET: usize = 300;
/// Ratio of fitted to starting σ_n above which a sparse fit is flagged ([`SparseFit::noise_inflated`]).
pub const NOISE_INFLATION: f64 = 3.0;
/// How the refinement on the bound stops (from a start that is already near the optimum): on
/// its tolerance or budget, not on a stall, so it keeps the fixed budget this module is built on.
const REFINE: exact::Stopping = exact::Stopping {
    tolerance: 1e-5,
    budget: 60,
    stall: false,
};

/// What a sparse fit was.
#[derive(Debug, Clone, Serialize, schemars::JsonSchema)]
pub struct SparseFit {
    /// The approximation: `vfe`.
    pub method: &'static str,
    /// Inducing points (the blob's centres).
    pub inducing: usize,
    /// Training samples.
    pub n_train: usize,
    /// Samples of the exact GP that gave the starting hyperparameters.
    pub subset: usize,
    /// The variational bound at the fitted hyperparameters (normalized data).
    pub bound: f64,
    /// σ_n of the exact GP on the start subset (normalized).
    pub start_noise_std: f64,
    /// Inducing points in normalized input coordinates (m × d).
    #[serde(skip)]
    pub u: DMatrix<f64>,
    /// Closed-form LOO errors of the Gaussian model N(0, Q + σ²I), normalized units.
    #[serde(skip)]
    pub loo: Vec<f64>,
}

impl SparseFit {
    /// Whether the bound explains signal as noise: VFE's trace term, tr(K_nn − Q)/(2σ²), grows
    /// with n, and when m is too small for the structure the data hold the bound escapes it by
    /// raising σ_n instead (a known trait of VFE; Bauer et al. 2016). Flagged when the fitted σ_n is
    /// more than [`NOISE_INFLATION`] times the start subset's exact GP's.
    pub fn noise_inflated(&self, noise_std: f64) -> bool {
        noise_std > NOISE_INFLATION * self.start_noise_std
    }

    /// The same inducing points conditioned on other data at `hyper` (no optimization).
    pub fn recondition(
        &self,
        data: &Prepared,
        hyper: Hyperparameters,
    ) -> Result<(Posterior, SparseFit), GpError> {
        let (posterior, loo) = condition(&data.z, &data.y, &self.u, hyper)?;
        let fit = Self {
            bound: posterior.log_marginal_likelihood,
            n_train: data.y.len(),
            u: self.u.clone(),
            loo,
            ..*self
        };
        Ok((posterior, fit))
    }
}

/// A sparse GP fitted to prepared data: the posterior on the inducing points, the approximation,
/// and what each optimizer run did (the starts on the subset, then the refinements on the bound).
pub(crate) struct SparseOutcome {
    /// The conditioned GP, centred on the inducing points.
    pub posterior: Posterior,
    /// The approximation.
    pub fit: SparseFit,
    /// Every optimizer run.
    pub reports: Vec<StartReport>,
    /// How the search on the start subset ended.
    pub optimization: Optimization,
}

/// Fits a sparse GP with `m` inducing points to prepared data (module doc).
pub(crate) fn fit(data: &Prepared, m: usize, cfg: &GpConfig) -> Result<SparseOutcome, GpError> {
    let n = data.y.len();
    let subset = start_subset(&data.z, cfg.seed);
    let (zs, ys) = (data.z.select_rows(&subset), data.y.select_rows(&subset));
    let none = DMatrix::zeros(subset.len(), 0);
    let exact = |t: &[f64]| lml_and_gradient(&zs, &ys, &none, &[], t);
    let mut found = exact::search(&exact, zs.shape(), false, cfg)?;
    let start = found.theta.clone();
    let start_noise_std = Hyperparameters::from_log(&start).noise_std;
    // Inducing points are selected in the kernel's metric at the current hyperparameters, and the
    // bound refined on them; a second round reselects at the refined ones (the subset's are noisy)
    // and is kept when it raises the bound. They are selected, not optimized: moving them with the
    // hyperparameters by L-BFGS raised the bound but worsened the held-out error
    // (docs/performance.md). An input the subset found irrelevant (ℓ at its bound) may only be too
    // noisy to show its structure in a few hundred samples: the selection metric caps ℓ at one
    // normalized
    // unit, which still spreads inducing points along it, so the bound can find that structure.
    let d = data.z.ncols();
    let mut best: Option<(DMatrix<f64>, Vec<f64>, f64)> = None;
    let mut theta = start;
    for _ in 0..ROUNDS {
        let ls = Hyperparameters::from_log(&theta).length_scales;
        let capped: Vec<f64> = ls.iter().map(|l| l.min(SELECTION_MAX_LENGTH)).collect();
        let u = data.z.select_rows(&select(
            &kernel::scale_inputs(&data.z, &capped),
            &kernel::scale_inputs(&data.z, &ls),
            m,
        ));
        let bound = |t: &[f64]| bound_and_gradient(&data.z, &data.y, &u, t);
        let start = climb_noise(&bound, theta.clone(), cfg.bounds.log_noise.1);
        let ranges = cfg.bounds.ranges(d, start.len());
        let refined = exact::optimize_from(&bound, n, start, &ranges, cfg.max_iters, REFINE);
        let end = match (&refined.end, refined.log_marginal_likelihood) {
            (Some(end), Some(f)) => Some((end.clone(), f)),
            _ => None,
        };
        found.reports.push(refined);
        match end {
            Some((t, f)) if best.as_ref().is_none_or(|b| f > b.2) => {
                theta = t.clone();
                best = Some((u, t, f));
            }
            _ => break,
        }
    }
    let (u, best, _) = best.ok_or_else(|| {
        GpError::OptimizerFailed(
            "the sparse bound could not be evaluated from the subset's optimum".into(),
        )
    })?;
    let (posterior, loo) = condition(&data.z, &data.y, &u, Hyperparameters::from_log(&best))?;
    let fit = SparseFit {
        method: "vfe",
        inducing: u.nrows(),
        n_train: n,
        subset: subset.len(),
        bound: posterior.log_marginal_likelihood,
        start_noise_std,
        u,
        loo,
    };
    Ok(SparseOutcome {
        posterior,
        fit,
        reports: found.reports,
        optimization: found.optimization,
    })
}

/// θ with σ_n doubled while that raises the bound (up to `max_log_noise`). The bound's trace term,
/// tr(K_nn − Q)/(2σ²), grows with n: when the inducing points are too few for the structure, the
/// start subset's σ_n sits orders of magnitude down a slope only σ_n can climb, with a gradient so
/// steep that L-BFGS's first line search can stall there and report convergence without moving.
/// Where the start's σ_n is right this costs one evaluation.
fn climb_noise(bound: exact::Likelihood<'_>, theta: Vec<f64>, max_log_noise: f64) -> Vec<f64> {
    let last = theta.len() - 1;
    let Ok((mut best, _)) = bound(&theta) else {
        return theta;
    };
    let step = (std::f64::consts::LN_2, max_log_noise);
    exact::walk_noise(bound, theta, last, step, |f| {
        let higher = f > best;
        if higher {
            best = f;
        }
        higher
    })
}

/// The samples of the exact GP that starts the hyperparameters: half spread over the inputs
/// (greedy selection at unit length scales), half at random. A purely random subset of a pooled
/// run is nearly all stream samples, which crowd around a few rates and temperatures: it saw
/// almost none of the rate table, found temperature irrelevant (ℓ_T in the hundreds), and the bound
/// stayed in that optimum, recovering the temperature structure only through nearly dependent
/// inducing points. Spread over the inputs, the start keeps it: on the integration test's 28,761
/// samples the bound rose by about 1,700, and on the 114,624 of docs/performance.md the held-out
/// error at m = 24 is 5.2e-4 °/s where the random start gave 8.7e-4 (docs/performance.md).
fn start_subset(z: &DMatrix<f64>, seed: u64) -> Vec<usize> {
    let n = z.nrows();
    let size = SUBSET.min(n);
    let unit = kernel::scale_inputs(z, &vec![1.0; z.ncols()]);
    let mut subset = select(&unit, &unit, size / 2);
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    for i in rand::seq::index::sample(&mut rng, n, size) {
        if subset.len() == size {
            break;
        }
        if !subset.contains(&i) {
            subset.push(i);
        }
    }
    subset.sort_unstable();
    subset
}

/// Greedy inducing-point selection: a pivoted Cholesky factorization of the unit-variance kernel
/// on the scaled inputs `rank`, each step taking the sample the chosen ones explain worst (largest
/// diagonal of K − Q). That diagonal is the bound's trace term, so each pick lowers what the bound
/// pays for the approximation. Written here because it works in the kernel's own metric. Stops
/// early when every sample is explained (fewer distinct inputs than `m`).
///
/// `guard` holds the same samples scaled by the model's own length scales, which may be longer
/// than the ranking metric's: a sample the chosen ones explain to within `MIN_GUARD_RESIDUAL`
/// in that metric is passed over. Such a point adds a nearly dependent column to K_mm, and the
/// mean weights turn into large alternating pairs whose cancellation the f32 firmware cannot
/// follow (docs/performance.md).
pub fn select(rank: &DMatrix<f64>, guard: &DMatrix<f64>, m: usize) -> Vec<usize> {
    let n = rank.nrows();
    let mut ranked = Pivoted::new(n);
    let mut guarded = Pivoted::new(n);
    let mut chosen = Vec::with_capacity(m);
    while chosen.len() < m {
        let Some((p, r)) = ranked
            .residual
            .iter()
            .zip(&guarded.residual)
            .enumerate()
            .filter(|(_, (_, g))| **g >= MIN_GUARD_RESIDUAL)
            .map(|(i, (r, _))| (i, *r))
            .max_by(|a, b| a.1.total_cmp(&b.1).then(b.0.cmp(&a.0)))
        else {
            break;
        };
        if r < MIN_RESIDUAL {
            break;
        }
        ranked.take(rank, p);
        guarded.take(guard, p);
        chosen.push(p);
    }
    chosen
}

/// A pivoted Cholesky factorization of a unit-variance kernel, one pivot at a time.
struct Pivoted {
    /// Diagonal of K − Q for every sample.
    residual: Vec<f64>,
    columns: Vec<DVector<f64>>,
}

impl Pivoted {
    fn new(n: usize) -> Self {
        Self {
            residual: vec![1.0; n],
            columns: Vec::new(),
        }
    }

    /// Adds sample `p` of the scaled inputs `xs` as a pivot.
    fn take(&mut self, xs: &DMatrix<f64>, p: usize) {
        let row: Vec<f64> = xs.row(p).iter().copied().collect();
        let mut col = kernel::cross(xs, &row, &vec![1.0; xs.ncols()]);
        for c in &self.columns {
            col.axpy(-c[p], c, 1.0);
        }
        col /= self.residual[p].sqrt();
        for (res, c) in self.residual.iter_mut().zip(col.iter()) {
            *res -= c * c;
        }
        self.residual[p] = 0.0;
        self.columns.push(col);
    }
}

/// One chunk of samples: its rows, their scaled inputs, K_mn's columns and Φ = L⁻¹ K_mn's.
struct Chunk {
    rows: Range<usize>,
    xs: DMatrix<f64>,
    k: DMatrix<f64>,
    phi: DMatrix<f64>,
}

/// Everything of size m at one θ, and the chunks. Every product goes through Φ = L⁻¹K_mn
/// (triangular solves, backward stable) rather than K_mm⁻¹ or S = K_mn K_nm: with inducing
/// points close in the kernel's metric, K_mm⁻¹ S K_mm⁻¹ loses the bound to rounding at n = 10⁵.
struct Terms {
    hyper: Hyperparameters,
    us: DMatrix<f64>,
    chunks: Vec<Chunk>,
    /// K_mm with its jitter, and its Cholesky factor L.
    kmm: DMatrix<f64>,
    l: DMatrix<f64>,
    /// The jitter K_mm needed beyond [`JITTER`].
    jitter: f64,
    /// C = σ⁻² ΦΦᵀ.
    c: DMatrix<f64>,
    /// B = I + C = L_B L_Bᵀ.
    lb: Cholesky<f64, Dyn>,
    /// Φ y.
    phi_y: DVector<f64>,
    /// The bound F.
    bound: f64,
}

fn terms(
    z: &DMatrix<f64>,
    y: &DVector<f64>,
    u: &DMatrix<f64>,
    hyper: Hyperparameters,
) -> Result<Terms, GpError> {
    let (n, d) = z.shape();
    let m = u.nrows();
    let sf2 = hyper.signal_std.powi(2);
    let sn2 = hyper.noise_std.powi(2);
    let ls = &hyper.length_scales;
    let us = kernel::scale_inputs(u, ls);
    let mut kmm = kernel::gram(&us) * sf2;
    for i in 0..m {
        kmm[(i, i)] += JITTER * sf2;
    }
    let (chol, jitter) = cholesky_with_jitter(kmm.clone())?;
    for i in 0..m {
        kmm[(i, i)] += jitter;
    }
    let l = chol.l();
    let not_pd = || GpError::NotPositiveDefinite { jitter };
    let ranges: Vec<Range<usize>> = (0..n)
        .step_by(CHUNK)
        .map(|a| a..(a + CHUNK).min(n))
        .collect();
    let chunks: Vec<Chunk> = ranges
        .into_par_iter()
        .map(|rows| {
            let xs = DMatrix::from_fn(rows.len(), d, |i, j| z[(rows.start + i, j)] / ls[j]);
            let k = kernel::cross_matrix(&us, &xs) * sf2;
            let phi = l.solve_lower_triangular(&k).ok_or_else(not_pd)?;
            Ok(Chunk { rows, xs, k, phi })
        })
        .collect::<Result<_, GpError>>()?;
    let (pp, phi_y, yy) = chunks
        .par_iter()
        .map(|c| {
            let yc = y.rows(c.rows.start, c.rows.len());
            (&c.phi * c.phi.transpose(), &c.phi * yc, yc.norm_squared())
        })
        .reduce(
            || (DMatrix::zeros(m, m), DVector::zeros(m), 0.0),
            |a, b| (a.0 + b.0, a.1 + b.1, a.2 + b.2),
        );
    let c = (&pp + pp.transpose()) * (0.5 / sn2);
    let lb = Cholesky::new(DMatrix::identity(m, m) + &c).ok_or_else(not_pd)?;
    let v = lb
        .l_dirty()
        .solve_lower_triangular(&phi_y)
        .ok_or_else(not_pd)?;
    let quad = yy / sn2 - v.norm_squared() / (sn2 * sn2);
    let log_det_b: f64 = 2.0 * lb.l_dirty().diagonal().iter().map(|v| v.ln()).sum::<f64>();
    let tr_q = sn2 * c.trace();
    let nf = n as f64;
    let bound = -0.5 * quad
        - 0.5 * log_det_b
        - 0.5 * nf * (sn2.ln() + (2.0 * std::f64::consts::PI).ln())
        - (nf * sf2 - tr_q) / (2.0 * sn2);
    if !bound.is_finite() {
        return Err(not_pd());
    }
    Ok(Terms {
        hyper,
        us,
        chunks,
        kmm,
        l,
        jitter,
        c,
        lb,
        phi_y,
        bound,
    })
}

impl Terms {
    /// α = (Q + σ²I)⁻¹ y = σ⁻² (y − σ⁻² Φᵀ B⁻¹ Φ y) for each chunk.
    fn alphas(&self, y: &DVector<f64>) -> Vec<DVector<f64>> {
        let sn2 = self.hyper.noise_std.powi(2);
        let w = self.lb.solve(&self.phi_y);
        self.chunks
            .par_iter()
            .map(|c| {
                let yc = y.rows(c.rows.start, c.rows.len());
                (yc - c.phi.tr_mul(&w) / sn2) / sn2
            })
            .collect()
    }

    /// L⁻ᵀ X.
    fn left_solve(&self, x: &DMatrix<f64>) -> Result<DMatrix<f64>, GpError> {
        self.l
            .tr_solve_lower_triangular(x)
            .ok_or(GpError::NotPositiveDefinite {
                jitter: self.jitter,
            })
    }
}

/// The bound F and its gradient w.r.t. θ = (ln ℓ…, ln σ_f, ln σ_n), for normalized inputs `z`,
/// targets `y` and inducing points `u` (normalized coordinates, held fixed).
pub fn bound_and_gradient(
    z: &DMatrix<f64>,
    y: &DVector<f64>,
    u: &DMatrix<f64>,
    theta: &[f64],
) -> Result<(f64, Vec<f64>), GpError> {
    let t = terms(z, y, u, Hyperparameters::from_log(theta))?;
    let (n, d) = z.shape();
    let m = u.nrows();
    let sf2 = t.hyper.signal_std.powi(2);
    let sn2 = t.hyper.noise_std.powi(2);
    let alphas = t.alphas(y);
    let (phi_alpha, alpha2) = t
        .chunks
        .par_iter()
        .zip(&alphas)
        .map(|(c, a)| (&c.phi * a, a.norm_squared()))
        .reduce(|| (DVector::zeros(m), 0.0), |a, b| (a.0 + b.0, a.1 + b.1));
    let uvec = t.left_solve(&DMatrix::from_column_slice(m, 1, phi_alpha.as_slice()))?;
    let uvec = uvec.column(0).into_owned();
    let eye = DMatrix::<f64>::identity(m, m);
    let b_inv = t.lb.inverse();
    let not_b = &eye - &b_inv;
    // Σ G∘∂K_mn with G = u αᵀ + σ⁻² L⁻ᵀ (I − B⁻¹) Φ: with R = G∘K_mn, ∂K_mn/∂ln ℓ_k =
    // K_mn∘(u_k − x_k)² (scaled coordinates) expands into row sums, R·X and column sums, so no
    // m×n temporary outlives its chunk.
    let (rows, rx, cols) = t
        .chunks
        .par_iter()
        .zip(&alphas)
        .map(|(c, a)| {
            let mut g = t.left_solve(&(&not_b * &c.phi))? / sn2;
            for (j, mut col) in g.column_iter_mut().enumerate() {
                col.axpy(a[j], &uvec, 1.0);
            }
            let rmat = g.component_mul(&c.k);
            let rows: DVector<f64> = rmat.column_sum();
            let rx = &rmat * &c.xs;
            let colsum = rmat.row_sum();
            let cols = DVector::from_fn(d, |k, _| {
                colsum
                    .iter()
                    .zip(c.xs.column(k).iter())
                    .map(|(s, x)| s * x * x)
                    .sum::<f64>()
            });
            Ok((rows, rx, cols))
        })
        .try_reduce(
            || (DVector::zeros(m), DMatrix::zeros(m, d), DVector::zeros(d)),
            |a, b| Ok((a.0 + b.0, a.1 + b.1, a.2 + b.2)),
        )?;
    // H = u uᵀ + L⁻ᵀ X L⁻¹ with X = C − (I − B⁻¹).
    let x = &t.c - &not_b;
    let lx = t.left_solve(&x)?;
    let h = &uvec * uvec.transpose() + t.left_solve(&lx.transpose())?.transpose();
    let mut grad = vec![0.0; d + 2];
    for (k, g) in grad.iter_mut().take(d).enumerate() {
        let mn: f64 = (0..m)
            .map(|i| {
                let ui = t.us[(i, k)];
                ui * ui * rows[i] - 2.0 * ui * rx[(i, k)]
            })
            .sum::<f64>()
            + cols[k];
        let mut mm = 0.0;
        for j in 0..m {
            for i in 0..m {
                mm += h[(i, j)] * t.kmm[(i, j)] * (t.us[(i, k)] - t.us[(j, k)]).powi(2);
            }
        }
        *g = mn - 0.5 * mm;
    }
    let nf = n as f64;
    // Σ H∘K_mm = uᵀK_mm u + tr X.
    let h_kmm = uvec.dot(&(&t.kmm * &uvec)) + x.trace();
    grad[d] = 2.0 * rows.sum() - h_kmm - nf * sf2 / sn2;
    let tr_q = sn2 * t.c.trace();
    let tr_w = alpha2 - (nf - m as f64 + b_inv.trace()) / sn2;
    grad[d + 1] = sn2 * tr_w + (nf * sf2 - tr_q) / sn2;
    Ok((t.bound, grad))
}

/// The sparse GP conditioned at `hyper`: a [`Posterior`] over the inducing points (module doc)
/// and the closed-form LOO errors of N(0, Q + σ²I), e_a = −α_a / [(Q + σ²I)⁻¹]_aa with
/// [(Q + σ²I)⁻¹]_aa = σ⁻² − σ⁻⁴ ‖L_B⁻¹ φ_a‖².
pub fn condition(
    z: &DMatrix<f64>,
    y: &DVector<f64>,
    u: &DMatrix<f64>,
    hyper: Hyperparameters,
) -> Result<(Posterior, Vec<f64>), GpError> {
    let t = terms(z, y, u, hyper)?;
    let m = u.nrows();
    let sn2 = t.hyper.noise_std.powi(2);
    let not_pd = || GpError::NotPositiveDefinite { jitter: t.jitter };
    // w = σ⁻² A⁻¹ b = σ⁻² L⁻ᵀ B⁻¹ Φ y.
    let bphi = t.lb.solve(&t.phi_y);
    let weights = t
        .left_solve(&DMatrix::from_column_slice(m, 1, bphi.as_slice()))?
        .column(0)
        / sn2;
    let eig = SymmetricEigen::new(t.c.clone());
    let mut v = eig.eigenvectors.clone();
    for (mut col, l) in v.column_iter_mut().zip(eig.eigenvalues.iter()) {
        col *= (1.0 + 1.0 / l.max(MIN_EIGENVALUE)).sqrt();
    }
    let half = &t.l * v;
    let (factor, _): (Cholesky<f64, Dyn>, f64) = cholesky_with_jitter(&half * half.transpose())?;
    let alphas = t.alphas(y);
    let lb = t.lb.l_dirty();
    let loo: Vec<f64> = t
        .chunks
        .par_iter()
        .zip(&alphas)
        .map(|(c, a)| {
            let v = lb.solve_lower_triangular(&c.phi).ok_or_else(not_pd)?;
            Ok((0..c.rows.len())
                .map(|j| -a[j] / (1.0 / sn2 - v.column(j).norm_squared() / (sn2 * sn2)))
                .collect::<Vec<f64>>())
        })
        .collect::<Result<Vec<_>, GpError>>()?
        .into_iter()
        .flatten()
        .collect();
    let posterior = Posterior::from_parts(
        t.hyper.clone(),
        t.us.clone(),
        factor,
        weights.into_owned(),
        t.jitter,
        t.bound,
    );
    Ok((posterior, loo))
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::models::gp::{self, GpModel};
    use rand::RngExt;

    fn toy(n: usize, seed: u64) -> (DMatrix<f64>, DVector<f64>) {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let z = DMatrix::from_fn(n, 2, |_, _| rng.random_range(-2.0f64..2.0));
        let y = DVector::from_fn(n, |i, _| {
            (1.3 * z[(i, 0)]).sin() + 0.4 * z[(i, 1)].powi(2) + 0.05 * rng.random_range(-1.0..1.0)
        });
        (z, y)
    }

    #[test]
    fn analytic_gradient_matches_finite_differences() {
        let (z, y) = toy(150, 1);
        let u = z.select_rows(&[3, 17, 40, 41, 77, 90, 123]);
        for theta in [vec![0.0, 0.0, 0.0, -2.0], vec![-0.3, 0.7, 0.2, -3.5]] {
            let (_, g) = bound_and_gradient(&z, &y, &u, &theta).unwrap();
            for j in 0..theta.len() {
                let step = 1e-5;
                let at = |s: f64| {
                    let mut t = theta.clone();
                    t[j] += s;
                    bound_and_gradient(&z, &y, &u, &t).unwrap().0
                };
                let fd = (at(step) - at(-step)) / (2.0 * step);
                assert!(
                    (fd - g[j]).abs() < 1e-5 * (1.0 + fd.abs()),
                    "θ {theta:?} j {j}: analytic {} fd {fd}",
                    g[j]
                );
            }
        }
    }

    #[test]
    fn with_every_sample_inducing_the_bound_is_the_exact_likelihood() {
        let (z, y) = toy(40, 2);
        let theta = [0.1, 0.4, 0.0, -2.0];
        let (bound, _) = bound_and_gradient(&z, &y, &z, &theta).unwrap();
        let (exact, _) = lml_and_gradient(&z, &y, &DMatrix::zeros(40, 0), &[], &theta).unwrap();
        // Equal up to the jitter on K_mm (1e-6 of σ_f²).
        assert!(
            (bound - exact).abs() < 1e-3 * exact.abs(),
            "{bound} vs {exact}"
        );
        let u = z.select_rows(&[0, 5, 10]);
        let (fewer, _) = bound_and_gradient(&z, &y, &u, &theta).unwrap();
        assert!(fewer < exact, "a bound: {fewer} < {exact}");
    }

    #[test]
    fn prediction_is_the_dtc_posterior_and_loo_matches_refits() {
        let (z, y) = toy(60, 3);
        let u = z.select_rows(&[1, 9, 22, 35, 48]);
        let hyper = Hyperparameters::from_log(&[0.2, 0.5, 0.1, -2.5]);
        let (post, loo) = condition(&z, &y, &u, hyper.clone()).unwrap();
        let sf2 = hyper.signal_std.powi(2);
        let sn2 = hyper.noise_std.powi(2);
        // Reference: the Gaussian model N(0, Q + σ²I) written out densely.
        let us = kernel::scale_inputs(&u, &hyper.length_scales);
        let xs = kernel::scale_inputs(&z, &hyper.length_scales);
        let mut kmm = kernel::gram(&us) * sf2;
        for i in 0..5 {
            kmm[(i, i)] += JITTER * sf2;
        }
        let kmn = kernel::cross_matrix(&us, &xs) * sf2;
        let kmm_inv = kmm.clone().try_inverse().unwrap();
        let q = kmn.transpose() * &kmm_inv * &kmn;
        let cov = &q + DMatrix::identity(60, 60) * sn2;
        let cov_inv = cov.clone().try_inverse().unwrap();
        let alpha = &cov_inv * &y;
        for i in 0..60 {
            let zi = [z[(i, 0)], z[(i, 1)]];
            // Mean at a training input: Q (Q + σ²I)⁻¹ y = y − σ² α.
            let (mean, var) = post.predict(&zi);
            assert!((mean - (y[i] - sn2 * alpha[i])).abs() < 1e-7, "mean {i}");
            // Variance: k** − k*ᵀ (K_mm⁻¹ − A⁻¹) k*.
            let a = &kmm + &kmn * kmn.transpose() / sn2;
            let k = kmn.column(i);
            let expected = sf2 - (k.transpose() * (&kmm_inv - a.try_inverse().unwrap()) * k)[0];
            assert!(
                (var - expected).abs() < 1e-6,
                "var {i}: {var} vs {expected}"
            );
            // LOO of the Gaussian model by conditioning on the other samples.
            let keep: Vec<usize> = (0..60).filter(|&j| j != i).collect();
            let c = cov.select_rows(&keep).select_columns(&keep);
            let ci = cov.select_rows(&keep).column(i).into_owned();
            let pred = ci.dot(&(c.try_inverse().unwrap() * y.select_rows(&keep)));
            assert!((pred - y[i] - loo[i]).abs() < 1e-7, "loo {i}");
        }
    }

    #[test]
    fn greedy_selection_spreads_over_the_inputs_and_stops_at_duplicates() {
        let x = DMatrix::from_row_slice(6, 1, &[0.0, 0.0, 0.0, 5.0, 5.0, 10.0]);
        let chosen = select(&x, &x, 6);
        assert_eq!(chosen.len(), 3, "three distinct inputs: {chosen:?}");
        let mut at: Vec<f64> = chosen.iter().map(|&i| x[(i, 0)]).collect();
        at.sort_by(f64::total_cmp);
        assert_eq!(at, vec![0.0, 5.0, 10.0]);
    }

    #[test]
    fn selection_passes_over_samples_nearly_dependent_in_the_models_metric() {
        // Three samples along an input the model finds irrelevant (ℓ = 1000): one apart in the
        // ranking metric, 1e-3 apart in the model's, where each explains the next to 1 − e^(−1e-6).
        let rank = DMatrix::from_row_slice(3, 1, &[0.0, 1.0, 2.0]);
        let guard = &rank / 1000.0;
        assert_eq!(select(&rank, &rank, 3).len(), 3);
        assert_eq!(select(&rank, &guard, 3).len(), 1);
        // Far enough apart in both metrics, all are kept.
        let wide = DMatrix::from_row_slice(3, 1, &[0.0, 10.0, 20.0]);
        assert_eq!(select(&wide, &(&wide / 5.0), 3).len(), 3);
    }

    #[test]
    fn a_sparse_fit_predicts_the_function_like_the_exact_one() {
        let (x, y) = toy(1500, 4);
        let cfg = GpConfig {
            inducing: gp::Inducing::Count(32),
            ..GpConfig::default()
        };
        let sparse = GpModel::fit(&x, &y, &cfg).unwrap();
        let fit = sparse.sparse.as_ref().unwrap();
        // Selection stops once every sample is explained to 1e-5 of σ_f².
        assert!(
            (16..=32).contains(&fit.inducing),
            "{} inducing",
            fit.inducing
        );
        assert_eq!(fit.n_train, 1500);
        assert_eq!(sparse.posterior.xs.nrows(), fit.inducing);
        let mut worst: f64 = 0.0;
        for (a, b) in [(0.3, -0.4), (-1.5, 1.2), (1.0, 0.0)] {
            let truth = (1.3f64 * a).sin() + 0.4 * b * b;
            worst = worst.max((sparse.predict(&[a, b]).mean - truth).abs());
        }
        assert!(worst < 0.02, "worst error {worst}");
        let noise = sparse.posterior.hyper.noise_std * sparse.output_scale;
        // The noise is uniform on ±0.05: σ = 0.029.
        assert!((noise - 0.0289).abs() < 0.004, "σ_n {noise}");
        let loo = sparse.loo_errors();
        let rmse = fog_data::stats::rms(&loo);
        assert!(rmse < 0.035, "LOO rmse {rmse}");
        assert!(!fit.noise_inflated(sparse.posterior.hyper.noise_std));
    }

    #[test]
    fn too_few_inducing_points_for_fine_structure_are_flagged() {
        // Several periods along each input, nearly noiseless: four inducing points cannot carry
        // it, and the bound raises σ_n to escape its trace term.
        let mut rng = ChaCha8Rng::seed_from_u64(6);
        let x = DMatrix::from_fn(4000, 2, |_, _| rng.random_range(-2.0f64..2.0));
        let y = DVector::from_fn(4000, |i, _| {
            (4.0 * x[(i, 0)]).sin() * (3.0 * x[(i, 1)]).cos() + 0.01 * rng.random_range(-1.0..1.0)
        });
        let fit_with = |m| {
            let cfg = GpConfig {
                inducing: gp::Inducing::Count(m),
                ..GpConfig::default()
            };
            let model = GpModel::fit(&x, &y, &cfg).unwrap();
            let noise = model.posterior.hyper.noise_std;
            model.sparse.unwrap().noise_inflated(noise)
        };
        assert!(fit_with(4));
        assert!(!fit_with(128));
    }
}
