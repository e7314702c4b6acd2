//! `inspect`: what a blob holds and what it costs the firmware, channel by channel (a model blob
//! of one channel is a unit of one).

use firmware_core::blob::{HEADER_LEN, unit::MAGIC};

use crate::firmware::export::ExportError;
use crate::firmware::unit::{self, UnitFootprint};

/// What a blob holds and costs: a unit's footprint (a model blob's, as a unit of one channel),
/// and each channel's output unit in channel order.
#[derive(Debug, Clone)]
pub struct Inspection {
    /// Its footprint.
    pub footprint: UnitFootprint,
    /// Each channel's output unit.
    pub units: Vec<&'static str>,
    /// A model blob of one channel (as `fit` wrote them before unit blobs): read as a unit of one.
    pub model_blob: bool,
}

/// Decodes `bytes` as the firmware would (refusing what it would refuse) and measures it.
pub fn inspect(bytes: &[u8]) -> Result<Inspection, ExportError> {
    let decoded = fog_data::replay::decode_unit(bytes).map_err(ExportError::Blob)?;
    let footprint = unit::unit_footprint(bytes)?;
    let units = decoded
        .channels()
        .iter()
        .map(|c| c.quantity().unit())
        .collect();
    Ok(Inspection {
        footprint,
        units,
        model_blob: bytes.get(..4) != Some(&MAGIC[..]),
    })
}

impl Inspection {
    /// What `trainer inspect` prints of the blob `name`.
    pub fn text(&self, name: &str) -> String {
        let header = if self.model_blob {
            format!(
                "a model blob: {HEADER_LEN}-byte header + postcard payload, read as a unit of one"
            )
        } else {
            "22-byte header + postcard payload".to_owned()
        };
        unit_text(name, &self.footprint, &self.units, &header)
    }
}

/// A unit blob's lines: the unit, a row per channel, the firmware's sizes.
fn unit_text(name: &str, f: &UnitFootprint, units: &[&str], header: &str) -> String {
    let mut text = format!(
        "{name}: a unit of {}{}, trained {:.1} … {:.1} °C\n\
         blob: {} bytes ({header})\n\
         channel           centres  inputs  monomials  numbers  unit\n",
        match f.channels.len() {
            1 => "one channel".to_owned(),
            n => format!("{n} channels"),
        },
        if f.sensor_id.is_empty() {
            String::new()
        } else {
            format!(" for sensor '{}'", f.sensor_id)
        },
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
