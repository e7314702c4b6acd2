//! `trainer fit`'s flags, as clap reads them: what to fit on and how, the target's budget, and
//! what the blob states for service (rated range, full scale, repeatability, the rule beyond the
//! trained range). `FitCommand::check` turns them into the pipeline's plan.

use std::path::PathBuf;

use clap::Args;
use firmware_core::blob::Beyond;
use fog_data::stream::Window;

use crate::analysis::budget::{Budget, Bytes};
use crate::cli::inputs::{DatasheetArgs, FitOptions, ModelInput, Runs};
use crate::pipeline::fit::Service;

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
    /// The samples before it are its history: the firmware's state runs through them from the
    /// power-on, as it did on the gyro, but nothing is fitted or scored on them.
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
    /// The blob to write: a unit blob, every channel's model (one entry for one channel's data);
    /// one per sensor beside this name where a flight controller's log holds several.
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
    /// ± it is a fault (default: none, any finite output is a reading). For channels that read
    /// in one unit (else each channel's `full_scale` in the channels file).
    #[arg(long, value_name = "OUTPUT")]
    pub(super) full_scale: Option<f32>,
    #[command(flatten)]
    pub(super) datasheet: DatasheetArgs,
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
    /// The settings the blob states for service, as the pipeline takes them.
    pub(super) fn service(&self) -> Service {
        Service {
            rated_temp: self.rated_temp,
            full_scale: self.full_scale,
            sheet: self.datasheet.sheet(),
            beyond: match self.beyond {
                BeyondArg::Auto => None,
                BeyondArg::Tangent => Some(Beyond::Tangent),
                BeyondArg::Hold => Some(Beyond::Hold),
                BeyondArg::Follow => Some(Beyond::Follow),
            },
        }
    }
}
