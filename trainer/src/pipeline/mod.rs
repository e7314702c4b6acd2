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
