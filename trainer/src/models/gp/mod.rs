//! The Gaussian-process model in physical units, exact ([`exact`], the reference paper's) or
//! sparse ([`sparse`], for long streams): input normalization, the prior mean with its
//! coefficients, the posterior, and how the hyperparameters were found. [`GpModel::fit`] chooses
//! between the two by size ([`Inducing`]); both feed the same prediction and export code.

use std::time::Instant;

use exact::{
    Likelihood, Searched, best_of, explore, group_loo, polish, search, search_from, with_terms,
};
use nalgebra::{DMatrix, DVector};
use sparse::SparseFit;

use crate::models::dense::inverse_from_cholesky;
use crate::models::normalize::{Normalizer, trained_range};
use crate::models::prior::{DropReason, MeanBasis, PolyPrior};

pub mod exact;
pub mod sparse;

pub use exact::{
    AUTO_EXACT_MAX, Bounds, DEFAULT_INDUCING, GpConfig, GpError, Hyperparameters, Inducing,
    Optimization, Posterior, Prepared, StartReport,
};

/// A fitted GP in physical units: normalization, prior mean, posterior.
#[derive(Debug, Clone)]
pub struct GpModel {
    /// Input normalization.
    pub input_norm: Normalizer,
    /// Trained range of each raw input, where its data are ([`trained_range`]): beyond it the
    /// model extrapolates.
    pub input_range: Vec<(f64, f64)>,
    /// Basis of the prior mean.
    pub basis: MeanBasis,
    /// Prior mean over normalized inputs, in output units, with the GLS coefficients.
    pub prior: PolyPrior,
    /// Output scale s_y: the GP models (ω − m) / s_y.
    pub output_scale: f64,
    /// The conditioned GP (normalized units).
    pub posterior: Posterior,
    /// Normalized training targets.
    pub y: DVector<f64>,
    /// The sparse approximation, when the GP is one (the posterior's centres are then its
    /// inducing points).
    pub sparse: Option<SparseFit>,
    /// What each optimizer run did: the starts, then the polish from the best of them (none after
    /// a fallback), then for a sparse GP the refinements on the bound. Empty for a refit.
    pub starts: Vec<StartReport>,
    /// How the hyperparameter search ended (a refit on new targets keeps its model's).
    pub optimization: Optimization,
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

/// Refuses [`MeanBasis::Auto`], which a command chooses before it fits
/// ([`crate::analysis::basis`]): a fit never guesses it.
pub(crate) fn chosen(basis: MeanBasis) -> Result<(), GpError> {
    if basis == MeanBasis::Auto {
        Err(GpError::UnchosenBasis)
    } else {
        Ok(())
    }
}

impl GpModel {
    /// Fits the GP to raw inputs `x` (rows are samples) and targets.
    pub fn fit(x: &DMatrix<f64>, target: &DVector<f64>, cfg: &GpConfig) -> Result<Self, GpError> {
        Self::fit_grouped(x, target, &[], cfg)
    }

    /// Fits the GP with an offset per group: `offsets` gives each sample's group index (empty:
    /// no offsets). The offsets are independent N(0, σ_g²) draws, a covariance term σ_g² where
    /// two samples share a group, σ_g fitted with the other hyperparameters; so runs, sweeps or
    /// power-ons that sit apart by a constant are not followed with the temperature length scale.
    /// Predictions leave them out (a new run's offset is unknown) and count σ_g² as observation
    /// noise ([`Hyperparameters::observation_var`]). Offsets need an exact GP.
    pub fn fit_grouped(
        x: &DMatrix<f64>,
        target: &DVector<f64>,
        offsets: &[usize],
        cfg: &GpConfig,
    ) -> Result<Self, GpError> {
        let n = x.nrows();
        let t0 = Instant::now();
        let Some(m) = cfg.inducing.count(n).filter(|_| n >= 3) else {
            let data = Self::exact_data(x, target, offsets, cfg)?;
            return Self::exact(x, cfg.mean, data, t0, |likelihood, shape| {
                search(likelihood, shape, !offsets.is_empty(), cfg)
            });
        };
        if !offsets.is_empty() {
            return Err(GpError::ExactOnly(n));
        }
        chosen(cfg.mean)?;
        let data = Prepared::grouped(x, target, cfg.mean, offsets);
        let s = sparse::fit(&data, m, cfg)?;
        Ok(Self::assemble(
            x,
            cfg.mean,
            data,
            s.posterior,
            Some(s.fit),
            (s.reports, s.optimization),
            t0,
        ))
    }

    /// `x`, `target` and `offsets` prepared for an exact GP, or why they cannot have one: fewer
    /// than 3 samples, or more than `cfg` fits exactly.
    fn exact_data(
        x: &DMatrix<f64>,
        target: &DVector<f64>,
        offsets: &[usize],
        cfg: &GpConfig,
    ) -> Result<Prepared, GpError> {
        chosen(cfg.mean)?;
        let n = x.nrows();
        if n < 3 {
            return Err(GpError::TooFewSamples(n));
        }
        if cfg.inducing.count(n).is_some() {
            return Err(GpError::ExactOnly(n));
        }
        Ok(Prepared::grouped(x, target, cfg.mean, offsets))
    }

    /// The exact GP on `data` (prepared from `x`) at the θ that `find` reaches with its
    /// likelihood, for data of shape (n, d).
    fn exact(
        x: &DMatrix<f64>,
        basis: MeanBasis,
        data: Prepared,
        t0: Instant,
        find: impl FnOnce(Likelihood<'_>, (usize, usize)) -> Result<Searched, GpError>,
    ) -> Result<Self, GpError> {
        let (n, d) = x.shape();
        let found = find(&|t: &[f64]| data.likelihood(&data.h, t), (n, d))?;
        let posterior = data.condition(Hyperparameters::from_log_of(&found.theta, d))?;
        Ok(Self::assemble(
            x,
            basis,
            data,
            posterior,
            None,
            (found.reports, found.optimization),
            t0,
        ))
    }

    /// Where the starts of its hyperparameter search ended (θ), the polish from the best left out.
    fn start_ends(&self) -> Vec<Vec<f64>> {
        self.starts
            .iter()
            .filter(|r| !r.polish)
            .filter_map(|r| r.end.clone())
            .collect()
    }

    /// [`Self::fit_grouped`] without the polish: the exact GP at the best end of its starts'
    /// searches, each stopped at the searches' loose tolerance. That is the basin the data chose,
    /// which is what a diagnosis needs from its static model: candidates are scored at these
    /// hyperparameters, and an extension's search starts where the starts ended. Only a static
    /// model that ships needs converging; [`Self::polished`] then gives exactly what
    /// `fit_grouped` returns, and a diagnosis whose every fold ships its extension never pays for
    /// the static model's polish.
    pub fn fit_grouped_unpolished(
        x: &DMatrix<f64>,
        target: &DVector<f64>,
        offsets: &[usize],
        cfg: &GpConfig,
    ) -> Result<Self, GpError> {
        let t0 = Instant::now();
        let data = Self::exact_data(x, target, offsets, cfg)?;
        let starts = exact::starts(x.ncols(), !offsets.is_empty(), cfg);
        Self::exact(x, cfg.mean, data, t0, |likelihood, shape| {
            explore(likelihood, shape, starts, cfg)
        })
    }

    /// A GP from [`Self::fit_grouped_unpolished`] polished: what [`Self::fit_grouped`] returns
    /// for the same data. `x`, `target`, `offsets` and `cfg` must be those it was fitted with. A
    /// GP already polished, or fitted by the fallback, is returned as it is.
    pub fn polished(
        self,
        x: &DMatrix<f64>,
        target: &DVector<f64>,
        offsets: &[usize],
        cfg: &GpConfig,
    ) -> Result<Self, GpError> {
        let n = x.nrows();
        if n != self.y.len() {
            return Err(GpError::NotItsData {
                fitted: self.y.len(),
                given: n,
            });
        }
        let done = self.starts.iter().any(|r| r.polish)
            || matches!(self.optimization, Optimization::Fallback { .. });
        let Some((theta, _)) = best_of(&self.starts).filter(|_| !done) else {
            return Ok(self);
        };
        let explored = Searched {
            theta,
            reports: self.starts,
            optimization: self.optimization,
        };
        let data = Prepared::grouped(x, target, cfg.mean, offsets);
        let mut model = Self::exact(x, cfg.mean, data, Instant::now(), |likelihood, shape| {
            Ok(polish(likelihood, shape, explored, cfg))
        })?;
        model.fit_seconds += self.fit_seconds;
        Ok(model)
    }

    /// Fits the GP with extra prior-mean columns `terms` (n × q, raw units) beside its basis:
    /// their coefficients γ are marginalized with the basis (generalized least squares) and the
    /// hyperparameters maximize the joint restricted likelihood, so the GP does not spend its
    /// length scales on what the terms explain. Returns the GP conditioned on target − terms·γ
    /// at those hyperparameters (the same model: with γ̂ held, the basis' GLS coefficients are
    /// the joint ones, Frisch–Waugh–Lovell) and γ, output units per term unit. `offsets` as in
    /// [`Self::fit_grouped`]. Exact GPs only.
    ///
    /// `nested` is the GP already fitted to the same data without the terms (a model nested in
    /// this one, as the static model is in a diagnosis): the search starts where its starts ended.
    /// Each of those is a local optimum the data chose, from the same spread of starts, and the
    /// terms move the optimum from there, so these searches are short. All the ends rather than
    /// the best alone: from one, a fold can stay in the static model's basin. Where `nested` has
    /// no end (a fallback fit), the fixed starts.
    pub fn fit_with_terms(
        x: &DMatrix<f64>,
        terms: &DMatrix<f64>,
        target: &DVector<f64>,
        offsets: &[usize],
        cfg: &GpConfig,
        nested: &GpModel,
    ) -> Result<(Self, Vec<f64>), GpError> {
        let (n, d) = x.shape();
        let t0 = Instant::now();
        let data = Self::exact_data(x, target, offsets, cfg)?;
        let (h, rms) = with_terms(&data.h, terms);
        let likelihood = |t: &[f64]| data.likelihood(&h, t);
        let ends = nested.start_ends();
        let found = if ends.is_empty() {
            search(&likelihood, (n, d), !offsets.is_empty(), cfg)?
        } else {
            search_from(&likelihood, (n, d), ends, cfg)?
        };
        let hyper = Hyperparameters::from_log_of(&found.theta, d);
        let joint = Posterior::grouped(&data.z, &data.y, &h, hyper.clone(), offsets)?;
        let p = data.h.ncols();
        let gamma: Vec<f64> = rms
            .iter()
            .enumerate()
            .map(|(j, r)| data.scale * joint.beta[p + j] / r)
            .collect();
        let rest = target - terms * DVector::from_column_slice(&gamma);
        let prior = PolyPrior::fit(&data.z, &rest, cfg.mean);
        let y = (&rest - prior.eval_all(&data.z)) / data.scale;
        let data = Prepared { prior, y, ..data };
        let posterior = data.condition(hyper)?;
        let model = Self::assemble(
            x,
            cfg.mean,
            data,
            posterior,
            None,
            (found.reports, found.optimization),
            t0,
        );
        Ok((model, gamma))
    }

    /// Closed-form leave-one-group-out errors (prediction − target, output units) of this exact
    /// GP on its training data `x`, `target`, with extra prior-mean columns `terms` (n × q, may be
    /// empty) marginalized beside the basis, hyperparameters held ([`group_loo`]).
    pub fn group_loo_with(
        &self,
        x: &DMatrix<f64>,
        target: &DVector<f64>,
        terms: &DMatrix<f64>,
        groups: &[Vec<usize>],
    ) -> Result<Vec<f64>, GpError> {
        let kinv = inverse_from_cholesky(&self.posterior.chol);
        self.group_loo_given(&kinv, x, target, terms, groups)
    }

    /// [`Self::group_loo_with`] with K⁻¹ computed once by the caller (many term sets, one GP).
    pub fn group_loo_given(
        &self,
        kinv: &DMatrix<f64>,
        x: &DMatrix<f64>,
        target: &DVector<f64>,
        terms: &DMatrix<f64>,
        groups: &[Vec<usize>],
    ) -> Result<Vec<f64>, GpError> {
        let data = Prepared::new(x, target, self.basis);
        let (h, _) = with_terms(&data.h, terms);
        let e = group_loo(kinv, &h, &data.y, groups)?;
        Ok(e.into_iter().map(|v| v * data.scale).collect())
    }

    /// K⁻¹ of this GP's training covariance (normalized units).
    pub fn covariance_inverse(&self) -> DMatrix<f64> {
        inverse_from_cholesky(&self.posterior.chol)
    }

    /// The GP with this model's hyperparameters and mean basis conditioned on other targets at
    /// the same inputs `x`: no optimization (an extension corrects the points' targets and keeps
    /// the kernel the marginal likelihood chose).
    pub fn refit_targets(&self, x: &DMatrix<f64>, target: &DVector<f64>) -> Result<Self, GpError> {
        let t0 = Instant::now();
        let data = Prepared::grouped(x, target, self.basis, &self.posterior.offsets);
        let hyper = self.posterior.hyper.clone();
        let (posterior, sparse) = match &self.sparse {
            Some(s) => {
                let (posterior, fit) = s.recondition(&data, hyper)?;
                (posterior, Some(fit))
            }
            None => (data.condition(hyper)?, None),
        };
        Ok(Self::assemble(
            x,
            self.basis,
            data,
            posterior,
            sparse,
            (Vec::new(), self.optimization.clone()),
            t0,
        ))
    }

    pub(crate) fn assemble(
        x: &DMatrix<f64>,
        basis: MeanBasis,
        data: Prepared,
        posterior: Posterior,
        sparse: Option<SparseFit>,
        (starts, optimization): (Vec<StartReport>, Optimization),
        t0: Instant,
    ) -> Self {
        let input_range = x
            .column_iter()
            .map(|c| trained_range(c.iter().copied()))
            .collect();
        // The mean in output units: c₀ + s_y β̂.
        let mut prior = data.prior;
        for (c, b) in prior.coefficients.iter_mut().zip(&posterior.beta) {
            *c += data.scale * b;
        }
        Self {
            input_norm: data.norm,
            input_range,
            basis,
            prior,
            output_scale: data.scale,
            posterior,
            y: data.y,
            sparse,
            starts,
            optimization,
            fit_seconds: t0.elapsed().as_secs_f64(),
        }
    }

    /// Prediction at one raw sample.
    pub fn predict(&self, x: &[f64]) -> Prediction {
        let z = self.input_norm.apply_row(x);
        let (m, v) = self.posterior.predict(&z);
        let s2 = self.output_scale.powi(2);
        Prediction {
            mean: self.output_mean(&z, m),
            latent_var: v * s2,
            noise_var: self.posterior.hyper.observation_var() * s2,
        }
    }

    /// [`Self::predict`]'s mean alone, bit for bit, for the callers that read no variance: the
    /// variance costs O(n²) a sample, the mean O(n).
    pub fn predict_mean(&self, x: &[f64]) -> f64 {
        let z = self.input_norm.apply_row(x);
        self.output_mean(&z, self.posterior.predict_mean(&z))
    }

    /// The mean in output units at the normalized sample `z`, from the posterior's part `m`.
    fn output_mean(&self, z: &[f64], m: f64) -> f64 {
        self.prior.eval(z) + self.output_scale * m
    }

    /// Closed-form LOO errors (prediction − target) in output units: of the exact GP, or of the
    /// sparse GP's Gaussian model (covariance Q + σ²I, see [`sparse`]).
    pub fn loo_errors(&self) -> Vec<f64> {
        let loo = match &self.sparse {
            Some(s) => s.loo.clone(),
            None => self.posterior.loo().into_iter().map(|(e, _)| e).collect(),
        };
        loo.into_iter().map(|e| e * self.output_scale).collect()
    }

    /// Leave-one-group-out of every training sample, closed form with the hyperparameters held,
    /// as (prediction − target, predictive variance with noise) in output units: the exact GP's
    /// own ([`Posterior::group_loo_predictive`]); a sparse GP's point LOO errors, with its
    /// variance at the sample (`x`, the training inputs), which has no group form.
    pub fn group_loo_predictive(
        &self,
        x: &DMatrix<f64>,
        groups: &[Vec<usize>],
    ) -> Result<Vec<(f64, f64)>, GpError> {
        let s2 = self.output_scale.powi(2);
        match &self.sparse {
            None => Ok(self
                .posterior
                .group_loo_predictive(groups)?
                .into_iter()
                .map(|(e, v)| (e * self.output_scale, v * s2))
                .collect()),
            Some(s) => Ok(s
                .loo
                .iter()
                .zip(x.row_iter())
                .map(|(e, row)| {
                    let row: Vec<f64> = row.iter().copied().collect();
                    let p = self.predict(&row);
                    (e * self.output_scale, p.latent_var + p.noise_var)
                })
                .collect()),
        }
    }

    /// What the user should be told about this fit, one sentence each: an optimizer that did
    /// not converge or fell back, prior monomials left out, a sparse fit explaining signal as
    /// noise. Empty for a clean fit.
    pub fn warnings(&self) -> Vec<String> {
        let mut out = Vec::new();
        match &self.optimization {
            Optimization::Converged => {}
            Optimization::StoppedEarly {
                log_marginal_likelihood,
            } => out.push(format!(
                "the hyperparameter search converged from no start (each stopped on the iteration \
                 cap, the evaluation budget or a failed line search; statuses under -v and in the \
                 JSON's starts): the best point reached is used, log ML {log_marginal_likelihood:.3}; \
                 more iterations (--max-iters) or starts (--restarts) may find a better one"
            )),
            Optimization::Fallback {
                noise_std,
                statuses,
            } => out.push(format!(
                "the likelihood could not be evaluated from any optimizer start ({}): fell back to \
                 unit length scales and signal with σ_n {noise_std:e} (normalized), a model close \
                 to its prior mean",
                statuses.join("; ")
            )),
        }
        for reason in [DropReason::Dependent, DropReason::TooFewSamples] {
            let names: Vec<&str> = self
                .prior
                .dropped
                .iter()
                .filter(|d| d.reason == reason)
                .map(|d| d.monomial.as_str())
                .collect();
            if !names.is_empty() {
                out.push(format!(
                    "prior mean ({}): left out {} ({reason})",
                    self.basis,
                    names.join(", ")
                ));
            }
        }
        if let Some(s) = &self.sparse {
            let noise = self.posterior.hyper.noise_std;
            if s.noise_inflated(noise) {
                out.push(format!(
                    "the sparse bound explains part of the signal as noise (σ_n {:.3e} → {noise:.3e} \
                     normalized, against the start subset's exact GP): the inducing points are too \
                     few for the structure in these data; try more (--inducing)",
                    s.start_noise_std
                ));
            }
        }
        out
    }

    /// Log marginal likelihood of the normalized data at the fitted hyperparameters.
    pub fn log_marginal_likelihood(&self) -> f64 {
        self.posterior.log_marginal_likelihood
    }
}
