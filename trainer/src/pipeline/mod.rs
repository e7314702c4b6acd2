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
use fog_data::channels::{Channel, Channels};
use serde::Serialize;

use crate::analysis::uncertainty::Datasheet;

/// Checks a datasheet's figures as `fit`, `loo` and `investigate` take them
/// ([`Datasheet::invalid`]), naming the flag.
pub fn check_datasheet(sheet: &Datasheet) -> anyhow::Result<()> {
    match sheet.invalid() {
        Some((field, why)) => anyhow::bail!("--{} {why}", field.replace('_', "-")),
        None => Ok(()),
    }
}

/// Checks that figures in one channel's units (`full_scale`, and those of `sheet`:
/// [`Datasheet::in_one_channels_units`]) go to channels that all read in that unit: every channel
/// of `units`, as read, of one quantity and one output unit (a 3-axis gyro, a flight controller's
/// gyro sensor), not an IMU's gyros and accelerometers at once (`verb`: the command).
pub fn check_one_channel(
    sheet: &Datasheet,
    full_scale: bool,
    units: &[Channels],
    verb: &str,
) -> anyhow::Result<()> {
    let channels: Vec<(Quantity, String)> = units
        .iter()
        .flat_map(|u| &u.list)
        .map(|ch| (ch.quantity, ch.unit.to_string()))
        .collect();
    let mut read_in: Vec<&str> = Vec::new();
    for (_, unit) in &channels {
        if !read_in.contains(&unit.as_str()) {
            read_in.push(unit);
        }
    }
    anyhow::ensure!(
        !(full_scale || sheet.in_one_channels_units()) || channels.windows(2).all(|w| w[0] == w[1]),
        "--full-scale, --repeatability, --tempco and --hysteresis are one channel's, in its \
         units, and these channels read in {}: state each channel's in its [[channel]] of a \
         channels file, or {verb} one kind at a time (one sensor: --sensor); 0 means the same in \
         every unit",
        read_in.join(", ")
    );
    Ok(())
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
