//! `trainer fit`'s flags, as clap reads them: what to fit on and how, the target's budget, and
//! what the blob states for service (rated range, full scale, repeatability, the rule beyond the
//! trained range). [`super::FitPlan::check`] turns them into a plan.

use std::path::PathBuf;

use clap::Args;
use fog_data::replay;
use fog_data::stream::Window;

use crate::analysis::beyond::{self, BeyondChoice};
use crate::analysis::budget::{Budget, Bytes};
use crate::analysis::uncertainty::Calibration;
use crate::cli::inputs::{FitOptions, ModelInput, Runs};
use crate::data::points::Points;
use crate::firmware::export;
use crate::models::gp::GpConfig;
use firmware_core::blob::{Beyond, Limits};

/// The arguments of `trainer fit`.
#[derive(Args)]
pub(in crate::cli) struct FitArgs {
    #[command(flatten)]
    pub(super) input: ModelInput,
    #[command(flatten)]
    pub(super) runs: Runs,
    #[command(flatten)]
    pub(super) fit: FitOptions,
    /// Give each group of --group its own offset in the GP (runs, sweeps or power-ons that sit
    /// apart by a constant): fitted as a variance, left out of the firmware's predictions.
    #[arg(long, requires = "group")]
    pub(super) offsets: bool,
    /// Stream: time_s,temp_c,voltage_v,rate_dps (repeatable: runs are pooled). The static model
    /// is fitted on it when there are no --points; --features are fitted on it (one stream; it
    /// must excite them: ramps, power-ons).
    #[arg(long)]
    pub(super) stream: Vec<PathBuf>,
    /// Use only this part of each stream: START:END, s from its first sample.
    #[arg(long, requires = "stream")]
    pub(super) window: Option<Window>,
    /// Fit the static model on every sample of --stream (1 Hz, not 60 s means), pooled with
    /// --points when given: a long stream's static model (sparse GP by size). With --points the
    /// pooled model ships only if it beats the table's alone on the streams' last third, fitted
    /// on the rest (the comparison on stderr and in --json's pool_check).
    #[arg(long, requires = "stream")]
    pub(super) pool_stream: bool,
    /// Inputs to add, fitted on --stream: auto (diagnose the stream and add what the cause
    /// calls for) or a list of temperature-rate, coil-temperature, power-on-decay,
    /// thermal-state, time-on. Without --stream, auto diagnoses --points recorded in time
    /// order (--map time_s=…) for transients on the bias and the scale factor.
    #[arg(long)]
    pub(super) features: Option<String>,
    #[command(flatten)]
    pub(super) budget: BudgetArgs,
    #[command(flatten)]
    pub(super) service: ServiceArgs,
    #[command(flatten)]
    pub(super) params: super::params::ParamsArgs,
    /// Model blob to write (firmware-core format; a unit blob with --channels or a flight
    /// controller's log, one per sensor beside this name where the log holds several).
    #[arg(long)]
    pub(super) out: PathBuf,
    /// Write the fit summary as JSON here (`-`: stdout, alone).
    #[arg(long)]
    pub(super) json: Option<PathBuf>,
}

/// The target's budget, where the models must fit (`analysis::budget`).
#[derive(Args, Clone, Default)]
pub(super) struct BudgetArgs {
    /// RAM the models may take on the target (their numbers, bookkeeping and variance scratch):
    /// bytes, or with K/KiB, KB, M/MiB, MB. The channels' sizes are chosen within it, or the fit is
    /// refused before it starts, with the figures.
    #[arg(long, value_name = "BYTES")]
    pub(super) budget_ram: Option<Bytes>,
    /// Flash the blob may take (one calibration slot; keep two).
    #[arg(long, value_name = "BYTES")]
    pub(super) budget_flash: Option<Bytes>,
    /// Instructions per sample on the Cortex-M4F, every channel's mean and variance (an estimate
    /// from the sizes, as `trainer inspect` gives it; `firmware-sim qemu` measures it).
    #[arg(long, value_name = "N")]
    pub(super) budget_instructions: Option<f64>,
}

impl BudgetArgs {
    pub(super) fn budget(&self) -> Budget {
        Budget {
            ram_bytes: self.budget_ram.map(|b| b.0),
            flash_bytes: self.budget_flash.map(|b| b.0),
            instructions: self.budget_instructions,
        }
    }
}

/// What service meets that the calibration data may not show: what a reading that cannot be true
/// is, and the bias of another power-on (docs/uncertainty.md).
#[derive(Args, Clone, Default)]
pub(super) struct ServiceArgs {
    /// The temperature sensor's rated range, °C (LO:HI; default −55:125): a reading beyond it is a
    /// fault. Any reading inside it is compensated, beyond the trained range too (held at its
    /// edge, σ grown with the distance).
    #[arg(long, value_name = "LO:HI", value_parser = parse_rated, allow_hyphen_values = true)]
    pub(super) rated_temp: Option<(f32, f32)>,
    /// The output's full scale, in the output's own units (volts, counts, °/s): an output beyond
    /// ± it is a fault (default: none, any finite output is a reading). One channel only.
    #[arg(long, value_name = "OUTPUT")]
    pub(super) full_scale: Option<f32>,
    /// The bias's run-to-run repeatability, 1σ in the channel's units (°/s, m/s²), as a datasheet
    /// gives it: every power-on in service is another than the calibration's, so its variance is
    /// added to every sample's σ (default: not assumed, said in one line).
    #[arg(long, value_name = "SIGMA")]
    pub(super) repeatability: Option<f64>,
    /// What the mean does beyond the trained range: hold (held at the edge, as PX4's and
    /// ArduPilot's clip; its linear terms in the output still follow it), tangent (the prior mean
    /// continued along its tangent at the edge), follow (the GP's own prediction), or auto (the
    /// rule that predicts the training points beyond their inner part best, hold where too few
    /// tell: docs/uncertainty.md). The σ grows with the distance under each.
    #[arg(long, value_enum, default_value_t = BeyondArg::Auto)]
    pub(super) beyond: BeyondArg,
}

/// `--beyond`: firmware-core's `Beyond`, or chosen on the training points.
#[derive(Clone, Copy, Default, PartialEq, Eq, clap::ValueEnum)]
pub(super) enum BeyondArg {
    /// Chosen on the training points (`analysis::beyond`).
    #[default]
    Auto,
    /// The prior mean continued along its tangent at the edge.
    Tangent,
    /// The prior mean held at the edge.
    Hold,
    /// The GP's own prediction.
    Follow,
}

/// `LO:HI` in °C, LO below HI.
pub(super) fn parse_rated(text: &str) -> Result<(f32, f32), String> {
    let (lo, hi) = text
        .split_once(':')
        .ok_or_else(|| format!("'{text}': expected LO:HI in °C"))?;
    let num = |v: &str| {
        v.trim()
            .parse::<f32>()
            .ok()
            .filter(|v| v.is_finite())
            .ok_or_else(|| format!("'{v}' is not a temperature in °C"))
    };
    let (lo, hi) = (num(lo)?, num(hi)?);
    if lo >= hi {
        return Err(format!("'{text}': LO must be below HI"));
    }
    // The feature pipeline refuses a reading beyond these whatever a blob says.
    if lo < -100.0 || hi > 200.0 {
        return Err(format!(
            "'{text}': a rated range lies within −100…200 °C, beyond which no temperature \
             sensor's reading is taken as one"
        ));
    }
    Ok((lo, hi))
}

impl ServiceArgs {
    /// The blob's limits.
    pub(super) fn limits(&self) -> Limits {
        let (temp_min_c, temp_max_c) = self
            .rated_temp
            .unwrap_or((Limits::DEFAULT.temp_min_c, Limits::DEFAULT.temp_max_c));
        Limits {
            temp_min_c,
            temp_max_c,
            full_scale: self.full_scale.unwrap_or(0.0),
        }
    }

    /// The rule beyond the trained range: as asked, or chosen on `points` (fitted as `gp`).
    pub(super) fn beyond(&self, points: &Points, gp: &GpConfig) -> BeyondChoice {
        let asked = |rule, name| BeyondChoice {
            rule,
            inside_c: None,
            scored: 0,
            rmse: None,
            verdict: format!("{name} as asked (--beyond)"),
        };
        match self.beyond {
            BeyondArg::Auto => beyond::choose(points, gp),
            BeyondArg::Tangent => asked(Beyond::Tangent, "along the tangent"),
            BeyondArg::Hold => asked(Beyond::Hold, "held at the edge"),
            BeyondArg::Follow => asked(Beyond::Follow, "the GP's own prediction"),
        }
    }

    /// `blob` (its σ `calibration`) with the limits, the repeatability and the rule beyond the
    /// trained range written in.
    pub(super) fn apply(
        &self,
        blob: &[u8],
        calibration: &mut Calibration,
        beyond: Beyond,
    ) -> anyhow::Result<Vec<u8>> {
        if let Some(sigma) = self.repeatability {
            calibration.set_turn_on(sigma);
        }
        let blob = calibration.apply(blob)?;
        let limits = self.limits();
        let blob = export::with_limits(&blob, &limits)?;
        let fw = replay::decode(&blob).map_err(|_| {
            anyhow::anyhow!(
                "the training data hold readings beyond the sensor's limits (rated {}…{} °C{}): \
                 a reading that was recorded is possible; widen --rated-temp or --full-scale",
                limits.temp_min_c,
                limits.temp_max_c,
                if limits.full_scale > 0.0 {
                    format!(", full scale ±{}", limits.full_scale)
                } else {
                    String::new()
                }
            )
        })?;
        debug_assert_eq!(fw.limits(), limits);
        Ok(export::with_beyond(&blob, beyond)?)
    }
}
