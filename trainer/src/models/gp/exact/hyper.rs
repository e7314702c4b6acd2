//! The kernel's hyperparameters, as fitted and as the optimizer sees them.

use serde::Serialize;

/// Kernel hyperparameters in natural units (normalized inputs and outputs).
#[derive(Debug, Clone, PartialEq, Serialize, schemars::JsonSchema)]
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
