//! The fit's settings: the hyperparameters' bounds, the starts and iterations of the search,
//! and the model size (exact or sparse) a user asks for.

use std::fmt;
use std::str::FromStr;

use serde::Serialize;

use crate::models::prior::MeanBasis;

/// Box bounds on the log-hyperparameters (normalized units).
#[derive(Debug, Clone, Copy, Serialize, schemars::JsonSchema)]
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
    pub(super) fn range(&self, d: usize, j: usize) -> (f64, f64) {
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
#[derive(Debug, Clone, Serialize, schemars::JsonSchema)]
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
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize, schemars::JsonSchema)]
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

/// The largest data set `Inducing::Auto` fits exactly where no command resolved the size first
/// (`analysis::capacity::resolve` does for what is exported): beyond it an exact fit's O(n³)
/// likelihood evaluations dominate every command.
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
