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
use fog_data::channels::Channel;
use serde::Serialize;

use crate::analysis::uncertainty::MAX_PPM;

/// Checks a datasheet's run-to-run figures as `fit`, `loo` and `investigate` take them: the
/// bias's repeatability (`--repeatability`) a σ, the scale factor's (`--scale-repeatability`) a
/// σ in ppm up to 100 %.
pub fn check_repeatability(bias: Option<f64>, scale_ppm: Option<f64>) -> anyhow::Result<()> {
    anyhow::ensure!(
        bias.is_none_or(|r| r.is_finite() && r >= 0.0),
        "--repeatability must be a σ: a number not below 0"
    );
    anyhow::ensure!(
        scale_ppm.is_none_or(|r| (0.0..=MAX_PPM).contains(&r)),
        "--scale-repeatability must be a σ in ppm: a number from 0 to 1e6 (100 %)"
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
