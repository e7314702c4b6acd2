//! Allan deviation, the field's first look at a gyro's noise (IEEE Std 952-1997, Annex C): the
//! overlapping estimator over cluster times τ = m·τ₀, its confidence interval, and the noise terms
//! read from the curve's slopes.
//!
//! With θ the integrated rate (angle) at the samples, the overlapping Allan variance at τ = m·τ₀ is
//!
//! ```text
//! σ²(τ) = Σ_k (θ_{k+2m} − 2θ_{k+m} + θ_k)² / (2 τ² (N − 2m)),   k = 0 … N − 2m − 1
//! ```
//!
//! and the log-log curve shows each noise by its slope: −½ for angle random walk (white rate
//! noise, read as the line's value at τ = 1 s), 0 at the bias instability's flat bottom (the
//! minimum divided by 0.664, the flicker-noise constant), +½ for rate random walk (the line's
//! value at τ = 3 s). A term whose slope the curve never shows is `None`: a log too short for rate
//! random walk, or one whose minimum is its last point. The confidence interval is the standard
//! approximation for `N/m` clusters, σ·(1 ± 1/√(2(N/m − 1))) (IEEE 952, C.2).
//!
//! The simulator's bias instability is a first-order Gauss–Markov process (firmware-sim's plant);
//! [`gauss_markov_avar`] is its closed-form Allan variance, which identification inverts to turn a
//! measured minimum into the process's standard deviation.

use serde::Serialize;

use crate::stream::{GAP_FACTOR, typical_step};
use firmware_core::Quantity;
use firmware_core::units::SECONDS_PER_HOUR;

/// Flicker (bias-instability) noise: σ(τ) on its flat bottom is 0.664·B.
pub const FLICKER_FLOOR: f64 = 0.664;
/// Cluster sizes per decade of τ.
const PER_DECADE: f64 = 10.0;
/// Fewest clusters a point is computed from: fewer give an interval wider than the value.
const MIN_CLUSTERS: usize = 3;
/// Fewest clusters (relative to the longest τ's) at a bias-instability bottom: about 20 clusters
/// there, an interval of ±16%.
const MIN_BOTTOM_CLUSTERS: usize = 7;

/// An Allan deviation curve.
#[derive(Debug, Clone, PartialEq, Serialize, schemars::JsonSchema)]
pub struct Curve {
    /// Cluster times, s.
    pub tau_s: Vec<f64>,
    /// Allan deviation, in the rate's units (°/s).
    pub adev: Vec<f64>,
    /// Lower end of the confidence interval (one sigma).
    pub adev_lo: Vec<f64>,
    /// Upper end.
    pub adev_hi: Vec<f64>,
}

/// The noise terms read from a curve, each in the units of IEEE 952 and `None` where the curve does
/// not show its slope.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, schemars::JsonSchema)]
pub struct Terms {
    /// Angle random walk N, °/√h: the slope −½ line at τ = 1 s.
    pub arw_deg_per_sqrt_h: Option<f64>,
    /// Bias instability B, °/h: the minimum / 0.664.
    pub bias_instability_deg_per_h: Option<f64>,
    /// Where the minimum is, s.
    pub bias_instability_tau_s: Option<f64>,
    /// Rate random walk K, (°/h)/√h: the slope +½ line at τ = 3 s.
    pub rrw_deg_per_h_per_sqrt_h: Option<f64>,
}

/// Overlapping Allan deviation of `rate` (°/s) sampled every `tau0_s`, at about ten cluster times
/// per decade from τ₀ up to the longest with three clusters.
pub fn overlapping(rate: &[f64], tau0_s: f64) -> Curve {
    overlapping_runs(&[rate], tau0_s)
}

/// [`overlapping`] over several evenly sampled runs of one log (the stretches between its gaps
/// and the windows left out of it): each run contributes the clusters it holds whole, and the sums
/// are pooled, so a left-out minute costs the clusters across it, not the log.
pub fn overlapping_runs(runs: &[&[f64]], tau0_s: f64) -> Curve {
    // θ_k of each run: the angle after k samples.
    let thetas: Vec<Vec<f64>> = runs
        .iter()
        .map(|rate| {
            let mut theta = Vec::with_capacity(rate.len() + 1);
            theta.push(0.0);
            let mut acc = 0.0;
            for r in *rate {
                acc += r * tau0_s;
                theta.push(acc);
            }
            theta
        })
        .collect();
    let n: usize = runs.iter().map(|r| r.len()).sum();
    let longest = runs.iter().map(|r| r.len()).max().unwrap_or(0);
    let mut curve = Curve {
        tau_s: Vec::new(),
        adev: Vec::new(),
        adev_lo: Vec::new(),
        adev_hi: Vec::new(),
    };
    let mut last = 0;
    for k in 0.. {
        let m = 10f64.powf(f64::from(k) / PER_DECADE).round() as usize;
        if m == last {
            continue;
        }
        last = m;
        if n < MIN_CLUSTERS * m || 2 * m > longest {
            break;
        }
        let (mut terms, mut sum) = (0usize, 0.0);
        for theta in thetas.iter().filter(|t| t.len() > 2 * m) {
            let k = theta.len() - 2 * m;
            terms += k;
            sum += (0..k)
                .map(|i| {
                    let d = theta[i + 2 * m] - 2.0 * theta[i + m] + theta[i];
                    d * d
                })
                .sum::<f64>();
        }
        let tau = m as f64 * tau0_s;
        let adev = (sum / (2.0 * tau * tau * terms as f64)).sqrt();
        let clusters = n as f64 / m as f64;
        let rel = 1.0 / (2.0 * (clusters - 1.0)).sqrt();
        curve.tau_s.push(tau);
        curve.adev.push(adev);
        curve.adev_lo.push(adev * (1.0 - rel).max(0.0));
        curve.adev_hi.push(adev * (1.0 + rel));
    }
    curve
}

/// Local log-log slope between points `i` and `i + 1`.
fn slope(c: &Curve, i: usize) -> f64 {
    (c.adev[i + 1] / c.adev[i]).ln() / (c.tau_s[i + 1] / c.tau_s[i]).ln()
}

/// Reads the noise terms from `curve` (module doc).
pub fn terms(curve: &Curve) -> Terms {
    let n = curve.adev.len();
    let none = Terms {
        arw_deg_per_sqrt_h: None,
        bias_instability_deg_per_h: None,
        bias_instability_tau_s: None,
        rrw_deg_per_h_per_sqrt_h: None,
    };
    if n < 3 {
        return none;
    }
    // The bottom: the first point after which the curve stops falling (slope above −0.1), among
    // the points of at least MIN_BOTTOM_CLUSTERS clusters, where noise cannot fake a turn. A
    // Gauss–Markov bias falls again at τ ≫ T, so the global minimum can be the last point; the
    // bias instability is the first bottom. The longest τ has at least MIN_CLUSTERS clusters, so
    // these have at least MIN_CLUSTERS × MIN_BOTTOM_CLUSTERS.
    // A curve that never fell first (a residual dominated by a drift or by steps from the first
    // τ) has no white-noise floor to bottom out from: no bias instability is read from it.
    let bottom = (0..n - 1)
        .take_while(|&i| curve.tau_s[i] <= curve.tau_s[n - 1] / MIN_BOTTOM_CLUSTERS as f64)
        .find(|&i| slope(curve, i) > -0.1)
        .filter(|&i| i >= 2 && slope(curve, 0) < -0.25);
    let min_at = bottom.unwrap_or(n - 1);
    // A line of slope s through the points whose local slope is near s (±0.2), fitted in logs:
    // its value at τ = `at`.
    let line = |s: f64, range: std::ops::Range<usize>, at: f64| -> Option<f64> {
        let logs: Vec<f64> = range
            .filter(|&i| i + 1 < n && (slope(curve, i) - s).abs() <= 0.2)
            .map(|i| curve.adev[i].ln() - s * curve.tau_s[i].ln())
            .collect();
        (!logs.is_empty())
            .then(|| (logs.iter().sum::<f64>() / logs.len() as f64 + s * at.ln()).exp())
    };
    // ARW: σ(1 s) on the −½ line of the curve's leading fall (white noise shows at the shortest
    // τ, or nowhere); °/√s × 60 = °/√h.
    let fall = (0..n - 1).take_while(|&i| slope(curve, i) < -0.25).count();
    let arw = line(-0.5, 0..fall.min(min_at.max(1)), 1.0).map(|s| s * 60.0);
    let turned = bottom.is_some();
    let bi = turned.then(|| curve.adev[min_at] / FLICKER_FLOOR * SECONDS_PER_HOUR);
    // RRW: σ(3 s) on the +½ line after the minimum; °/s/√s × 3600 × 60 = (°/h)/√h.
    let rrw = line(0.5, min_at..n, 3.0).map(|s| s * SECONDS_PER_HOUR * 60.0);
    Terms {
        arw_deg_per_sqrt_h: arw,
        bias_instability_deg_per_h: bi,
        bias_instability_tau_s: turned.then(|| curve.tau_s[min_at]),
        rrw_deg_per_h_per_sqrt_h: rrw,
    }
}

/// The stretches of `time_s` without a gap (a step over three times the typical one) or a
/// non-finite value of `rate` (a window left out): the Allan deviation needs evenly spaced
/// samples. Returns the ranges and the typical step, s.
pub fn runs(time_s: &[f64], rate: &[f64]) -> (Vec<std::ops::Range<usize>>, f64) {
    let step = typical_step(time_s);
    let mut out = Vec::new();
    let mut start = 0;
    for i in 0..=time_s.len() {
        let breaks = i == time_s.len()
            || !rate.get(i).is_some_and(|r| r.is_finite())
            || (i > start && time_s[i] - time_s[i - 1] > GAP_FACTOR * step);
        if breaks {
            if i > start {
                out.push(start..i);
            }
            start = if i < time_s.len() && rate[i].is_finite() {
                i
            } else {
                i + 1
            };
        }
    }
    (out, step)
}

/// An Allan analysis of a log: the curve, its terms, and what it was computed over.
#[derive(Debug, Clone, PartialEq, Serialize, schemars::JsonSchema)]
pub struct Analysis {
    /// What the rate is (e.g. "output/K − reference").
    pub of: String,
    /// Samples used: every stretch without a gap or a window left out.
    pub samples: usize,
    /// Those stretches.
    pub runs: usize,
    /// Sample interval, s.
    pub tau0_s: f64,
    /// Cluster times, s.
    pub tau_s: Vec<f64>,
    /// Allan deviation, °/s.
    pub adev_dps: Vec<f64>,
    /// One-sigma interval, low end.
    pub adev_lo_dps: Vec<f64>,
    /// High end.
    pub adev_hi_dps: Vec<f64>,
    /// The noise terms.
    #[serde(flatten)]
    pub terms: Terms,
}

/// Too few samples without a gap for an Allan deviation.
#[derive(Debug, Clone, Copy, PartialEq, Eq, thiserror::Error)]
#[error("{samples} samples without a gap: too few for an Allan deviation")]
pub struct TooFew {
    /// The samples the stretches hold.
    pub samples: usize,
}

impl Analysis {
    /// The Allan analysis of `rate_dps` sampled at `time_s`, over its stretches without a gap or
    /// a non-finite value (a window left out: [`overlapping_runs`]).
    pub fn of(what: &str, time_s: &[f64], rate_dps: &[f64]) -> Self {
        let (runs, step) = runs(time_s, rate_dps);
        let parts: Vec<&[f64]> = runs.iter().map(|r| &rate_dps[r.clone()]).collect();
        let curve = overlapping_runs(&parts, step);
        let terms = terms(&curve);
        Self {
            of: what.to_owned(),
            samples: parts.iter().map(|p| p.len()).sum(),
            runs: parts.len(),
            tau0_s: step,
            tau_s: curve.tau_s,
            adev_dps: curve.adev,
            adev_lo_dps: curve.adev_lo,
            adev_hi_dps: curve.adev_hi,
            terms,
        }
    }

    /// The Allan analysis of `rate_dps` less `reference_dps` where the log has a reference (any
    /// finite value): the samples without one (handled windows, windows left out) are gaps, not
    /// fed in raw, and `what` says " − reference".
    pub fn less_reference(
        what: &str,
        time_s: &[f64],
        rate_dps: &[f64],
        reference_dps: &[f64],
    ) -> Self {
        if !reference_dps.iter().any(|r| r.is_finite()) {
            return Self::of(what, time_s, rate_dps);
        }
        let rate: Vec<f64> = rate_dps
            .iter()
            .zip(reference_dps)
            .map(|(w, r)| w - r)
            .collect();
        Self::of(&format!("{what} − reference"), time_s, &rate)
    }

    /// Whether the curve has the few cluster times an Allan deviation needs (three), or why not.
    pub fn enough(&self) -> Result<(), TooFew> {
        if self.tau_s.len() >= 3 {
            Ok(())
        } else {
            Err(TooFew {
                samples: self.samples,
            })
        }
    }

    /// The curve, for a figure.
    pub fn curve(&self) -> Curve {
        Curve {
            tau_s: self.tau_s.clone(),
            adev: self.adev_dps.clone(),
            adev_lo: self.adev_lo_dps.clone(),
            adev_hi: self.adev_hi_dps.clone(),
        }
    }

    /// The terms as a line of text, each with its units, or why it is missing.
    pub fn text(&self) -> String {
        self.text_in(Quantity::AngularRate)
    }

    /// [`Self::text`] for a channel measuring `quantity`: an accelerometer's velocity random walk
    /// in (m/s)/√h, its bias instability in mg and its random walk in mg/√h.
    pub fn text_in(&self, quantity: Quantity) -> String {
        let or = |v: Option<f64>, f: &dyn Fn(f64) -> String, why: &str| v.map_or(why.to_owned(), f);
        // The terms are stated as a gyro's (°/h from °/s): back to the rate's unit, then to the
        // quantity's bias unit.
        let k = quantity.bias_per_unit() / SECONDS_PER_HOUR;
        let u = quantity.bias_unit();
        let (walk, walk_unit) = quantity.random_walk();
        let (drift, drift_unit) = match quantity {
            Quantity::AngularRate => ("rate random walk", format!("({u})/√h")),
            Quantity::SpecificForce => ("acceleration random walk", format!("{u}/√h")),
        };
        format!(
            "Allan deviation of {} over {} samples{} (τ₀ {:.3} s): {walk} {}; bias instability \
             {}; {drift} {}",
            self.of,
            self.samples,
            if self.runs > 1 {
                format!(" in {} stretches", self.runs)
            } else {
                String::new()
            },
            self.tau0_s,
            or(
                self.terms.arw_deg_per_sqrt_h,
                &|n| format!("{n:.4} {walk_unit}"),
                "not shown (no slope −½)"
            ),
            match (
                self.terms.bias_instability_deg_per_h,
                self.terms.bias_instability_tau_s
            ) {
                (Some(b), Some(t)) => format!("{:.4} {u} (bottom at τ {t:.0} s)", b * k),
                _ => "not shown (the curve does not bottom out: log too short)".to_owned(),
            },
            or(
                self.terms.rrw_deg_per_h_per_sqrt_h,
                &|r| format!("{:.4} {drift_unit}", r * k),
                "not shown (no slope +½: log too short)"
            ),
        )
    }
}

/// Angle random walk of quantization alone, °/√h, for a rate (°/s) quantized in `step`
/// ([`crate::stats::quantization_step`]) and sampled
/// every `tau0_s`: white noise of step/√12 per sample.
pub fn quantization_arw(step: f64, tau0_s: f64) -> f64 {
    step / 12f64.sqrt() * tau0_s.sqrt() * 60.0
}

/// Closed-form Allan variance at `tau_s` of a first-order Gauss–Markov rate with standard deviation
/// `sigma` and correlation time `corr_s`: (σ²T²/τ²)(2τ/T − 3 + 4e^{−τ/T} − e^{−2τ/T}). Rate
/// random walk 2σ²τ/(3T) for τ ≪ T, white noise 2σ²T/τ for τ ≫ T.
pub fn gauss_markov_avar(sigma: f64, corr_s: f64, tau_s: f64) -> f64 {
    let x = tau_s / corr_s;
    if x < 1e-3 {
        // The bracket cancels to (2/3)x³ − (1/2)x⁴ …; the closed form loses every digit here.
        return sigma * sigma * (2.0 / 3.0 * x - 0.5 * x * x);
    }
    sigma * sigma / (x * x) * (2.0 * x - 3.0 + 4.0 * (-x).exp() - (-2.0 * x).exp())
}

/// Closed-form Allan variance of white rate noise of angle random walk `arw` (°/√s): N²/τ.
pub fn white_avar(arw_deg_per_sqrt_s: f64, tau_s: f64) -> f64 {
    arw_deg_per_sqrt_s * arw_deg_per_sqrt_s / tau_s
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::stats::quantization_step;
    use rand::SeedableRng;
    use rand_chacha::ChaCha8Rng;
    use rand_distr::{Distribution, StandardNormal};

    #[test]
    fn a_curve_of_too_few_cluster_times_is_refused_with_its_samples() {
        let few = Analysis::of("rate", &[0.0, 1.0, 2.0], &[0.1, 0.2, 0.3]);
        assert_eq!(
            few.enough().unwrap_err().to_string(),
            "3 samples without a gap: too few for an Allan deviation"
        );
        let t: Vec<f64> = (0..100).map(f64::from).collect();
        assert!(Analysis::of("rate", &t, &vec![0.5; 100]).enough().is_ok());
    }

    /// White noise of ARW N °/√h at 1 Hz plus a Gauss–Markov bias of σ °/h and correlation time T.
    fn simulate(n: usize, arw_dpsqrth: f64, gm_dph: f64, corr_s: f64, seed: u64) -> Vec<f64> {
        let mut rng = ChaCha8Rng::seed_from_u64(seed);
        let white = arw_dpsqrth / 60.0;
        let phi = (-1.0 / corr_s).exp();
        let gm_sigma = gm_dph / SECONDS_PER_HOUR;
        let z: f64 = StandardNormal.sample(&mut rng);
        let mut gm = gm_sigma * z;
        (0..n)
            .map(|_| {
                let w: f64 = StandardNormal.sample(&mut rng);
                let g: f64 = StandardNormal.sample(&mut rng);
                gm = phi * gm + gm_sigma * (1.0 - phi * phi).sqrt() * g;
                white * w + gm
            })
            .collect()
    }

    #[test]
    fn white_noise_gives_its_arw_and_slope_minus_half() {
        // 0.1 °/√h, the nominal unit's, over 20,000 s.
        let rate = simulate(20_000, 0.1, 0.0, 300.0, 1);
        let c = overlapping(&rate, 1.0);
        let t = terms(&c);
        let arw = t.arw_deg_per_sqrt_h.expect("white noise shows slope −½");
        eprintln!("white noise: ARW {arw:.4} °/√h (simulated 0.1)");
        assert!((arw / 0.1 - 1.0).abs() < 0.1, "ARW {arw} °/√h");
        assert!((slope(&c, 0) + 0.5).abs() < 0.05);
        // The interval holds the value and narrows with τ's cluster count.
        assert!(c.adev_lo[0] < c.adev[0] && c.adev[0] < c.adev_hi[0]);
        assert!(c.adev_hi[0] / c.adev[0] < c.adev_hi[10] / c.adev[10]);
    }

    #[test]
    fn gauss_markov_bias_gives_the_bias_instability_of_its_closed_form_curve() {
        // The nominal unit: ARW 0.1 °/√h, bias instability σ 1 °/h with T = 300 s, 200,000 s.
        let (arw, gm, corr) = (0.1, 1.0, 300.0);
        let rate = simulate(200_000, arw, gm, corr, 2);
        let c = overlapping(&rate, 1.0);
        let t = terms(&c);
        // The known value: the minimum of the closed-form curve over τ, / 0.664.
        // The known value: the closed-form curve's first bottom, / 0.664.
        let model = |tau: f64| {
            (white_avar(arw / 60.0, tau) + gauss_markov_avar(gm / SECONDS_PER_HOUR, corr, tau))
                .sqrt()
        };
        let grid: Vec<f64> = (0..4000)
            .map(|i| 10f64.powf(f64::from(i) / 1000.0))
            .collect();
        let first = grid
            .windows(2)
            .find(|w| model(w[1]) >= model(w[0]))
            .map_or(f64::NAN, |w| model(w[0]));
        let known = first / FLICKER_FLOOR * SECONDS_PER_HOUR;
        let bi = t.bias_instability_deg_per_h.expect("a minimum");
        eprintln!(
            "Gauss–Markov: B {bi:.4} °/h (closed form {known:.4}), ARW {:?}",
            t.arw_deg_per_sqrt_h
        );
        assert!(
            (bi / known - 1.0).abs() < 0.1,
            "B {bi} °/h, closed form {known}"
        );
        let a = t.arw_deg_per_sqrt_h.expect("ARW");
        assert!((a / arw - 1.0).abs() < 0.1, "ARW {a}");
        // The estimated curve follows the closed form within its interval at every τ up to 10⁴ s.
        for i in 0..c.tau_s.len() {
            let tau = c.tau_s[i];
            if tau > 1e4 {
                break;
            }
            let rel = c.adev_hi[i] / c.adev[i] - 1.0;
            assert!(
                (c.adev[i] / model(tau) - 1.0).abs() < 3.0 * rel + 0.02,
                "τ {tau}: {} vs {}",
                c.adev[i],
                model(tau)
            );
        }
    }

    #[test]
    fn a_quantized_log_is_told_from_an_averaged_one() {
        let rate = simulate(5_000, 0.1, 0.0, 300.0, 5);
        assert_eq!(quantization_step(&rate), None);
        let lsb = 0.01;
        let steps: Vec<f64> = rate.iter().map(|r| (r / lsb).round() * lsb + 0.5).collect();
        let q = quantization_step(&steps).expect("quantized");
        assert!((q - lsb).abs() < 1e-9, "{q}");
        // 0.01 °/s steps at 1 Hz: 0.173 °/√h of ARW from the quantizer alone.
        assert!((quantization_arw(q, 1.0) - 0.1732).abs() < 1e-3);
    }

    #[test]
    fn windows_left_out_cost_only_the_clusters_across_them() {
        // White noise with two handled minutes of huge scatter, left out (NaN): the ARW is the
        // white noise's, as for the whole quiet log.
        let mut rate = simulate(20_000, 0.1, 0.0, 300.0, 4);
        let time: Vec<f64> = (0..rate.len()).map(|i| i as f64).collect();
        let whole = Analysis::of("quiet", &time, &rate);
        for i in (5_000..5_060).chain(12_000..12_060) {
            rate[i] = f64::NAN;
        }
        let cut = Analysis::of("cut", &time, &rate);
        assert_eq!((cut.runs, cut.samples), (3, 20_000 - 120));
        let (a, b) = (
            whole.terms.arw_deg_per_sqrt_h.unwrap(),
            cut.terms.arw_deg_per_sqrt_h.unwrap(),
        );
        assert!((a / b - 1.0).abs() < 0.02, "{a} {b}");
        // Only the longest τ, whose clusters no stretch holds whole, are lost.
        assert!(
            cut.tau_s.len() + 4 >= whole.tau_s.len(),
            "{} {}",
            cut.tau_s.len(),
            whole.tau_s.len()
        );
    }

    #[test]
    fn a_short_log_shows_no_rate_random_walk_and_the_closed_form_has_its_limits() {
        let rate = simulate(2_000, 0.1, 0.0, 300.0, 3);
        let t = terms(&overlapping(&rate, 1.0));
        assert!(t.rrw_deg_per_h_per_sqrt_h.is_none());
        // Gauss–Markov: RRW-like for τ ≪ T, white-like for τ ≫ T.
        let (s, tc) = (1.0, 300.0);
        assert!(
            (gauss_markov_avar(s, tc, 0.01) / (2.0 * s * s * 0.01 / (3.0 * tc)) - 1.0).abs() < 1e-3
        );
        assert!((gauss_markov_avar(s, tc, 1e6) / (2.0 * s * s * tc / 1e6) - 1.0).abs() < 1e-3);
    }
}
