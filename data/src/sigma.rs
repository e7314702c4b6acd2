//! Scores of a σ against the errors it claims to describe. Every σ the project shows is scored
//! this way (docs/design.md §6): a navigation filter takes the firmware's variance as the
//! uncertainty of the rate, so a σ that is too small is a filter that trusts a wrong rate, and one
//! that is too wide throws away what the model knows.
//!
//! - **Coverage**: the fraction of errors within 1, 2 and 3 σ. For errors that are Gaussian with
//!   the stated σ: 68.3 %, 95.4 % and 99.7 %.
//! - **Sharpness**: the median σ over the RMS error. About 1 for a σ that is right and no wider; a
//!   σ can cover everything by being huge, and this says so.

use serde::Serialize;

use crate::stats::{median, rms};

/// How a set of σ describes the errors they go with.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, schemars::JsonSchema)]
pub struct Coverage {
    /// Errors scored.
    pub n: usize,
    /// Fraction with |error| ≤ σ.
    pub within_1sigma: f64,
    /// Fraction with |error| ≤ 2σ.
    pub within_2sigma: f64,
    /// Fraction with |error| ≤ 3σ.
    pub within_3sigma: f64,
    /// Median σ, output units.
    pub median_sigma: f64,
    /// RMS error, output units.
    pub rmse: f64,
    /// Median σ over the RMS error.
    pub sharpness: f64,
}

impl Coverage {
    /// The scores of `sigmas` for `errors` (pairs in order; NaN figures when there are none).
    pub fn of(errors: &[f64], sigmas: &[f64]) -> Self {
        let n = errors.len().min(sigmas.len());
        let within = |k: f64| Self::within(errors, sigmas, k);
        let median_sigma = median(&sigmas[..n]);
        let rmse = rms(&errors[..n]);
        Self {
            n,
            within_1sigma: within(1.0),
            within_2sigma: within(2.0),
            within_3sigma: within(3.0),
            median_sigma,
            rmse,
            sharpness: median_sigma / rmse,
        }
    }

    /// The fraction of errors within `k` σ.
    pub fn within(errors: &[f64], sigmas: &[f64], k: f64) -> f64 {
        let n = errors.len().min(sigmas.len());
        if n == 0 {
            return f64::NAN;
        }
        let hits = errors
            .iter()
            .zip(sigmas)
            .filter(|(e, s)| e.abs() <= k * **s)
            .count();
        hits as f64 / n as f64
    }
}

/// One line for a person: coverage at 1, 2 and 3 σ and sharpness, of samples and of 60 s means.
pub fn describe(samples: &Coverage, means: &Coverage) -> String {
    let part = |c: &Coverage| {
        format!(
            "{:.0}/{:.0}/{:.0}% within 1/2/3σ, median σ {:.2}× the RMS error",
            100.0 * c.within_1sigma,
            100.0 * c.within_2sigma,
            100.0 * c.within_3sigma,
            c.sharpness
        )
    };
    format!(
        "samples {}; 60 s means {} (a Gaussian: 68/95/99.7%, about 1×)",
        part(samples),
        part(means)
    )
}

/// One line for a person: the coverage at 2 σ and the sharpness of the 60 s means inside the
/// trained range and beyond it, apart (`None`: no 60 s mean there).
pub fn describe_by_range(inside: Option<&Coverage>, beyond: Option<&Coverage>) -> String {
    let part = |c: Option<&Coverage>| match c {
        None => "none".to_string(),
        Some(c) => format!(
            "{} at {:.0}% within 2σ, median σ {:.2}× the RMS error",
            c.n,
            100.0 * c.within_2sigma,
            c.sharpness
        ),
    };
    format!(
        "60 s means inside the trained range {}; beyond it {}",
        part(inside),
        part(beyond)
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn coverage_and_sharpness_follow_their_definitions() {
        let errors = [0.5, -1.5, 2.5, -3.5];
        let c = Coverage::of(&errors, &[1.0; 4]);
        assert_eq!(c.n, 4);
        assert_eq!(
            (c.within_1sigma, c.within_2sigma, c.within_3sigma),
            (0.25, 0.5, 0.75)
        );
        assert_eq!(c.median_sigma, 1.0);
        let rmse = ((0.25 + 2.25 + 6.25 + 12.25) / 4.0f64).sqrt();
        assert!((c.rmse - rmse).abs() < 1e-12);
        assert!((c.sharpness - 1.0 / rmse).abs() < 1e-12);
        assert!(Coverage::of(&[], &[]).within_2sigma.is_nan());
    }
}
