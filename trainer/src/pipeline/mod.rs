//! What the commands do, as a library: each takes a plan (its settings, checked once by whoever
//! built it) and the data already read, and returns a typed result; it says its choices as it
//! makes them through [`crate::progress::Messages`]. The command line builds the plans from its
//! flags and prints or writes the results; the Python package and the tests call the same code.

pub mod allan;
pub mod diagnose;
pub mod fit;
pub mod inspect;
pub mod investigate;
pub mod loo;
pub mod report;
pub mod source;
pub mod summarize;
pub mod text;

use firmware_core::Quantity;
use fog_data::channels::{Channel, Channels, Datasheet};
use serde::Serialize;

/// Checks a datasheet's figures as `fit`, `loo` and `investigate` take them
/// ([`Datasheet::check`]), naming the flag.
pub fn check_datasheet(sheet: &Datasheet) -> anyhow::Result<()> {
    sheet
        .check()
        .map_err(|e| anyhow::anyhow!("{} {}", e.flag(), e.why))
}

/// Checks that figures in one channel's units go to channels that share them (`verb`: the
/// command): those of `sheet` ([`Datasheet::in_one_channels_units`]), in the quantity's unit
/// (°/s, m/s²), to channels of one quantity (a 3-axis gyro, a flight controller's gyro sensor),
/// not an IMU's gyros and accelerometers at once; a `full_scale`, in the unit the output is read
/// in (the quantity's where it is physical, else its raw unit), to channels read in one.
pub fn check_one_channel(
    sheet: &Datasheet,
    full_scale: bool,
    units: &[Channels],
    verb: &str,
) -> anyhow::Result<()> {
    let read_in = |ch: &Channel| match ch.unit.factor() {
        Some(_) => ch.quantity.unit().to_string(),
        None => ch.unit.to_string(),
    };
    let kinds = |of: &dyn Fn(&Channel) -> String| {
        let mut seen: Vec<String> = Vec::new();
        for ch in units.iter().flat_map(|u| &u.list) {
            let kind = of(ch);
            if !seen.contains(&kind) {
                seen.push(kind);
            }
        }
        seen
    };
    let quantities = kinds(&|ch| ch.quantity.unit().to_string());
    let outputs = kinds(&read_in);
    let (flags, differ) = if sheet.in_one_channels_units() && quantities.len() > 1 {
        ("--repeatability, --tempco and --hysteresis are", quantities)
    } else if full_scale && outputs.len() > 1 {
        ("--full-scale is", outputs)
    } else {
        return Ok(());
    };
    anyhow::bail!(
        "{flags} one channel's, in its units, and these channels' are {}: state each channel's \
         in its [[channel]] of a channels file, or {verb} one kind at a time (one sensor: \
         --sensor); 0 means the same in every unit",
        differ.join(", ")
    )
}

/// One channel in a unit's JSON: its name, what it measures and its output's unit, then its
/// fields, its figures in that unit (the `_dps` fields too).
#[derive(Serialize, schemars::JsonSchema)]
pub struct ChannelEntry<'a, T> {
    /// The channel's name.
    pub name: &'a str,
    /// What its output measures.
    pub quantity: Quantity,
    /// Its output's unit.
    pub units: &'static str,
    /// Its fields, as one channel's.
    #[serde(flatten)]
    pub fields: &'a T,
}

impl<'a, T> ChannelEntry<'a, T> {
    /// The entry of `channel`, with its `fields`.
    pub fn new(channel: &'a Channel, fields: &'a T) -> Self {
        Self {
            name: &channel.name,
            quantity: channel.quantity,
            units: channel.quantity.unit(),
            fields,
        }
    }
}
