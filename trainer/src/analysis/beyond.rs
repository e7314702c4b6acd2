//! Which rule a blob's mean follows beyond its trained range (firmware-core's `Beyond`), chosen
//! on the training points alone.
//!
//! Beyond the range the model is held at the edge (`Hold`, PX4's and ArduPilot's clip of the
//! temperature), held with its prior mean continued along its tangent (`Tangent`), or the GP's
//! own prediction, its prior mean followed whole (`Follow`). Which is right depends on the gyro
//! and on the calibration: a prior mean fitted across a wide table follows a bias curve a few
//! degrees past its ends, one fitted on a narrow warm-up can point anywhere (on the MEMS log
//! trained on −17…−8 °C, the tangent missed gyro x by 12,200 °/h where holding missed by 1,470).
//! So the rule is tested as service meets it: the model is fitted on the inner part of the
//! training temperatures and each rule predicts the points beyond it. Another rule than `Hold`
//! ships only where it is the better there; wherever the points are too few to tell, the rule that
//! cannot run away does.

use firmware_core::blob::Beyond;
use firmware_core::{Feature, FeatureState, Sample};
use fog_data::replay;
use fog_data::stats::rms;
use serde::Serialize;

use crate::data::points::Points;
use crate::firmware::export::{self, Extension};
use crate::models::gp::{GpConfig, GpModel, Inducing};

/// Share of the training temperatures' span left out at each end to test the rules on.
const OUTER_SHARE: f64 = 0.2;
/// Fewest points inside to fit on, and outside to score.
const MIN_INSIDE: usize = 10;
const MIN_OUTSIDE: usize = 4;
/// Most points the test fits an exact GP on.
pub const MAX_POINTS: usize = firmware_core::MAX_CENTRES;

/// The rule chosen and the evidence (`beyond` in `fit --json`).
#[derive(Debug, Clone, Serialize, schemars::JsonSchema)]
pub struct BeyondChoice {
    /// The rule shipped.
    #[serde(serialize_with = "rule_name")]
    pub rule: Beyond,
    /// The temperatures fitted on for the test, °C.
    pub inside_c: Option<(f64, f64)>,
    /// Points beyond them, scored.
    pub scored: usize,
    /// RMS error of each rule there, output units (hold, tangent, follow).
    pub rmse: Option<[f64; 3]>,
    /// Why, in one line.
    pub verdict: String,
}

fn rule_name<S: serde::Serializer>(rule: &Beyond, s: S) -> Result<S::Ok, S::Error> {
    s.serialize_str(name(*rule))
}

/// A rule's name, as `--beyond` takes it.
pub fn name(rule: Beyond) -> &'static str {
    match rule {
        Beyond::Hold => "hold",
        Beyond::Tangent => "tangent",
        Beyond::Follow => "follow",
    }
}

impl BeyondChoice {
    /// The share of holding's miss the rule chosen missed on the points beyond the inner fit:
    /// `None` where the rule was not tested (asked for, or too few or too many points) or the
    /// test gave no positive, finite ratio.
    pub fn share(&self) -> Option<f64> {
        let rmse = self.rmse?;
        let k = RULES.iter().position(|r| *r == self.rule)?;
        let share = rmse[k] / rmse[0];
        (share.is_finite() && share > 0.0).then(|| share.min(1.0))
    }

    fn hold(verdict: String) -> Self {
        Self {
            rule: Beyond::Hold,
            inside_c: None,
            scored: 0,
            rmse: None,
            verdict,
        }
    }
}

/// Chooses the rule on `points` (module doc), fitting with `cfg`'s settings.
pub fn choose(points: &Points, cfg: &GpConfig) -> BeyondChoice {
    if !points
        .features()
        .iter()
        .any(|f| matches!(f, Feature::Temperature))
    {
        return BeyondChoice::hold("held at the edge: the model has no temperature input".into());
    }
    let (lo, hi) = fog_data::stats::extent(points.temp_c.iter().copied());
    let margin = OUTER_SHARE * (hi - lo);
    let inside_c = (lo + margin, hi - margin);
    let (inside, outside): (Vec<usize>, Vec<usize>) =
        (0..points.len()).partition(|&i| (inside_c.0..=inside_c.1).contains(&points.temp_c[i]));
    if inside.len() < MIN_INSIDE || outside.len() < MIN_OUTSIDE || points.len() > MAX_POINTS {
        return BeyondChoice::hold(format!(
            "held at the edge: {} points inside {:.1}…{:.1} °C and {} beyond are {} to test the \
             tangent on",
            inside.len(),
            inside_c.0,
            inside_c.1,
            outside.len(),
            if points.len() > MAX_POINTS {
                "too many"
            } else {
                "too few"
            }
        ));
    }
    match score(points, &inside, &outside, cfg) {
        Ok(rmse) => {
            // The first of the rules, in order of safety, that no other beats.
            let best = (0..RULES.len()).fold(0, |b, k| if rmse[k] < rmse[b] { k } else { b });
            let rule = RULES[best];
            let unit = points.quantity.unit();
            let verdict = format!(
                "fitted inside {:.1}…{:.1} °C, the {} points beyond miss by {:.3e} {unit} held at \
                 the edge, {:.3e} along the tangent, {:.3e} as the GP follows: {} ships",
                inside_c.0,
                inside_c.1,
                outside.len(),
                rmse[0],
                rmse[1],
                rmse[2],
                name(rule)
            );
            BeyondChoice {
                rule,
                inside_c: Some(inside_c),
                scored: outside.len(),
                rmse: Some(rmse),
                verdict,
            }
        }
        Err(e) => BeyondChoice::hold(format!(
            "held at the edge: the test could not be fitted ({e:#})"
        )),
    }
}

/// The rules, in order of safety: a rule later in it ships only where it beats those before.
const RULES: [Beyond; 3] = [Beyond::Hold, Beyond::Tangent, Beyond::Follow];

/// The RMS errors of the rules (hold, tangent, follow) on the `outside` points, the model
/// fitted on `inside` with `cfg`'s settings (an exact GP), as the firmware predicts them.
pub fn score(
    points: &Points,
    inside: &[usize],
    outside: &[usize],
    cfg: &GpConfig,
) -> anyhow::Result<[f64; 3]> {
    let fit_on = points.select(inside);
    let cfg = GpConfig {
        inducing: Inducing::Exact,
        ..cfg.clone()
    };
    let model = GpModel::fit(fit_on.inputs(), &fit_on.target(), &cfg)?;
    let blob = export::points_blob(&model, &fit_on, &Extension::default())?;
    let error = |rule: Beyond| -> anyhow::Result<f64> {
        let fw = replay::decode(&export::with_beyond(&blob, rule)?)?;
        let mut scratch = vec![0.0f32; fw.dims().m];
        let errors = outside
            .iter()
            .map(|&i| {
                let sample = Sample {
                    time_s: 0.0,
                    temp_c: points.temp_c[i] as f32,
                    output: points.voltage_v[i] as f32,
                };
                let p = fw.compensate(&sample, &mut FeatureState::default(), &mut scratch)?;
                Ok(f64::from(p.mean) - points.rate_dps[i])
            })
            .collect::<anyhow::Result<Vec<f64>>>()?;
        Ok(rms(&errors))
    };
    Ok([error(RULES[0])?, error(RULES[1])?, error(RULES[2])?])
}
