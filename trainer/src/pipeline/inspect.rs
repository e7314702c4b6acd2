//! `inspect`: what a blob holds and what it costs the firmware, a unit's blob channel by channel.

use firmware_core::blob::{HEADER_LEN, unit::MAGIC};

use crate::firmware::export::{self, ExportError, Footprint};
use crate::firmware::unit::{self, UnitFootprint};

/// What a blob holds and costs.
#[derive(Debug, Clone)]
pub enum Inspection {
    /// A unit's blob: its footprint, and each channel's output unit in channel order.
    Unit(UnitFootprint, Vec<&'static str>),
    /// One model's blob.
    Model(Footprint),
}

/// Decodes `bytes` as the firmware would (refusing what it would refuse) and measures it.
pub fn inspect(bytes: &[u8]) -> Result<Inspection, ExportError> {
    if bytes.get(..4) == Some(&MAGIC[..]) {
        let footprint = unit::unit_footprint(bytes)?;
        let decoded = fog_data::replay::decode_unit(bytes).map_err(ExportError::Blob)?;
        let units = decoded
            .channels()
            .iter()
            .map(|c| c.quantity().unit())
            .collect();
        return Ok(Inspection::Unit(footprint, units));
    }
    let footprint = export::footprint(bytes)?;
    fog_data::replay::decode(bytes).map_err(ExportError::Blob)?;
    Ok(Inspection::Model(footprint))
}

impl Inspection {
    /// What `trainer inspect` prints of the blob `name`.
    pub fn text(&self, name: &str) -> String {
        match self {
            Self::Unit(f, units) => unit_text(name, f, units),
            Self::Model(f) => format!(
                "{name}: m = {} centres, d = {} inputs, p = {} prior monomials\n\
                 blob: {} bytes ({HEADER_LEN}-byte header + postcard payload)\n\
                 flat f32 array: 7d + p + 2 + m·d + m + m(m+1)/2 = {} numbers\n\
                 static memory of Model<{}, {}, {}>: 4·{} + p·d + d + 24 = {} bytes (32-bit target)\n\
                 variance scratch: 4·m = {} bytes",
                f.m,
                f.d,
                f.p,
                f.blob_bytes,
                f.floats,
                f.d,
                f.p * f.d,
                f.floats,
                f.floats,
                f.model_bytes,
                f.scratch_bytes
            ),
        }
    }
}

/// A unit blob's lines: the unit, a row per channel, the firmware's sizes.
fn unit_text(name: &str, f: &UnitFootprint, units: &[&str]) -> String {
    let mut text = format!(
        "{name}: a unit of {} channels for sensor '{}', trained {:.1} … {:.1} °C\n\
         blob: {} bytes (22-byte header + postcard payload)\n\
         channel           centres  inputs  monomials  numbers  unit\n",
        f.channels.len(),
        f.sensor_id,
        f.temperature_c[0],
        f.temperature_c[1],
        f.blob_bytes
    );
    for ((channel, c), unit) in f.channels.iter().zip(units) {
        text.push_str(&format!(
            "{channel:<17} {:>7}  {:>6}  {:>9}  {:>7}  ({unit})\n",
            c.m, c.d, c.p, c.floats
        ));
    }
    text.push_str(&format!(
        "on the firmware: StaticUnit<C ≥ {}, D ≥ {}, E ≥ {}, N ≥ {}> takes {} bytes of RAM \
         (32-bit target), the variance scratch {} bytes, about {:.0} instructions per sample \
         on the Cortex-M4F (every channel's mean and variance)",
        f.channels.len(),
        f.channels.iter().map(|(_, c)| c.d).max().unwrap_or(0),
        f.channels.iter().map(|(_, c)| c.p * c.d).max().unwrap_or(0),
        f.numbers,
        f.unit_bytes,
        f.scratch_bytes,
        f.instructions
    ));
    text
}
