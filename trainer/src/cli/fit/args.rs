//! `trainer fit`'s flags, as clap reads them: what to fit on and how, the target's budget, and
//! what the blob states for service (rated range, full scale, repeatability, the rule beyond the
//! trained range). `FitCommand::check` turns them into the pipeline's plan.

use std::path::PathBuf;

use clap::Args;
use firmware_core::blob::Beyond;
use fog_data::channels::Datasheet;
use fog_data::stream::Window;

use crate::analysis::budget::{Budget, Bytes};
use crate::cli::inputs::{FitOptions, ModelInput, Runs};
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
    /// The bias's run-to-run repeatability, 1σ in the channel's units (°/s, m/s²), as a datasheet
    /// gives it: every power-on in service is another than the calibration's, whose own bias was
    /// a draw too, so twice its variance is added to every sample's σ (default: where several
    /// power-ons do not measure it, the difference of two power-ons assumed as large as the
    /// model error's floor, said in the σ line). For channels that read in one unit (else each
    /// channel's `repeatability` in the channels file), but 0 (a bias that repeats exactly),
    /// which every channel takes.
    #[arg(long, value_name = "SIGMA")]
    pub(super) repeatability: Option<f64>,
    /// The scale factor's run-to-run repeatability, 1σ in ppm, as a datasheet gives it: every
    /// power-on in service is another than the calibration's, so twice its variance, in
    /// proportion to the output², is added to every sample's σ; on a unit, the same figure to
    /// each channel's (a channel's `scale_repeatability` in the channels file states its own;
    /// default: not assumed, said in one line).
    #[arg(long, value_name = "PPM")]
    pub(super) scale_repeatability: Option<f64>,
    /// The bias's temperature coefficient, in the channel's units per °C (°/s/°C, m/s²/°C), as
    /// a datasheet gives it (its zero-rate output, or offset, change over temperature): beyond
    /// the trained range the σ grows by that much per °C, in place of the growth assumed from the
    /// model's own slope inside the range where the mean is held there (under `--beyond` tangent
    /// or follow, added to what that rule assumes; a larger one the residuals fitted stands; the
    /// scale factor's part stays). For channels that read in one unit (else each channel's `tempco` in
    /// the channels file).
    #[arg(long, value_name = "PER_C")]
    pub(super) tempco: Option<f64>,
    /// The gap between the heating and the cooling leg at one temperature, in the channel's
    /// units, as a datasheet gives it (its thermal hysteresis): on a leg the training did not
    /// hold, the σ carries it (default: assumed as large as the training data's own
    /// out-of-sample error, said in the σ line; no term where the training held both legs, or
    /// where its states are not known: a rate table's soaks, logs pooled). For channels that read
    /// in one unit (else each channel's `hysteresis` in the channels file).
    #[arg(long, value_name = "BAND")]
    pub(super) hysteresis: Option<f64>,
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
            sheet: Datasheet {
                repeatability: self.repeatability,
                scale_repeatability: self.scale_repeatability,
                tempco: self.tempco,
                hysteresis: self.hysteresis,
            },
            beyond: match self.beyond {
                BeyondArg::Auto => None,
                BeyondArg::Tangent => Some(Beyond::Tangent),
                BeyondArg::Hold => Some(Beyond::Hold),
                BeyondArg::Follow => Some(Beyond::Follow),
            },
        }
    }
}
