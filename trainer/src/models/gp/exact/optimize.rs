//! The hyperparameter search: L-BFGS-B from several starts, a polish from the best, and the
//! fallbacks when the likelihood is flat or the noise sits at its bound.

use std::cell::RefCell;

use nalgebra::{DMatrix, DVector};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use rayon::prelude::*;
use rcompat_lbfgsb::{Bounds as BoxBounds, OptimControl, optim_lbfgsb_with_gradient};
use serde::Serialize;

use super::config::{Bounds, GpConfig};
use super::error::GpError;
use super::hyper::Hyperparameters;
use super::likelihood::lml_and_gradient;
use super::posterior::Posterior;
use crate::models::normalize::Normalizer;
use crate::models::prior::{MeanBasis, PolyPrior, design};

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
/// computations stops: it is chasing rounding. With a tiny σ_n the log ML near an optimum is
/// rounding noise of order 1e-6 per sample between neighbouring θ, and line searches would spend
/// their last steps, and a whole polish, on it. Six computations leave room for the rejected
/// trials of a first line search.
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
#[derive(Debug, Clone, Serialize, schemars::JsonSchema)]
pub struct StartReport {
    /// Samples the run's likelihood was computed on: for a sparse GP, the start subset's for the
    /// starts ([`crate::models::gp::sparse`]) and all for the refinements on the bound.
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
/// the refinement on the bound that follows runs on a fixed budget by design ([`crate::models::gp::sparse`])
/// and keeps the best point it reaches.
#[derive(Debug, Clone, PartialEq, Serialize, schemars::JsonSchema)]
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
/// The searches stop at a projected gradient of 1e-2 per sample: loose enough that they do not
/// spend the polish's work, tight enough that the polish starts in the basin of the optimum
/// (looser, a polish can start in a lower one).
const SEARCH: Stopping = Stopping {
    tolerance: 1e-2,
    budget: 120,
    stall: true,
};

pub(super) const POLISH: Stopping = Stopping {
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
    pub(crate) fn likelihood(
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
/// past what export allows (trainer/tests/commands/cli.rs, the handled static log). Among fits the data
/// cannot tell apart, the best-conditioned one is kept. Costs one likelihood where σ_n is pinned.
pub(super) fn raise_noise(
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
/// `trainer/tests/commands/degenerate_data.rs` were reported as stopped early).
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
