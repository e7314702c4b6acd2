//! Why a GP fit failed, as a typed error.

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
    /// A fit asked for the basis the commands choose (`auto`) before it was chosen.
    #[error(
        "the prior mean's basis 'auto' is chosen on a sensor's points before a fit \
         (trainer::analysis::basis), not by the fit: give physics, constant or polyN"
    )]
    UnchosenBasis,
    /// An objective other than the likelihood (LS-SVR's LOO error) cannot be evaluated here.
    #[error("{0}")]
    Unevaluable(&'static str),
}
