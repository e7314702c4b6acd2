//! `trainer inspect`: what a blob holds and what it costs the firmware.

use std::path::PathBuf;

use anyhow::Context;
use clap::Args;
use fog_terminal::console::{Console, ConsoleFlags};
use fog_terminal::io::write_json;
use fog_terminal::schema;

use crate::firmware::export;
use crate::firmware::unit;

/// The arguments of `trainer inspect`.
#[derive(Args)]
pub(super) struct InspectArgs {
    /// The model blob.
    model: PathBuf,
    /// Write the figures as JSON here (`-`: stdout, alone).
    #[arg(long)]
    json: Option<PathBuf>,
}

/// `trainer inspect`: a blob's size and static memory on the firmware (every channel's, for a
/// unit's blob).
pub(super) fn inspect_command(args: InspectArgs, flags: ConsoleFlags) -> anyhow::Result<()> {
    let InspectArgs { model, json } = args;
    let console = Console::new(flags, json.as_deref());
    let bytes = std::fs::read(&model).with_context(|| format!("reading {}", model.display()))?;
    if bytes.get(..4) == Some(&firmware_core::blob::unit::MAGIC[..]) {
        let f = unit::unit_footprint(&bytes)
            .with_context(|| format!("decoding {}", model.display()))?;
        let mut text = format!(
            "{}: a unit of {} channels for sensor '{}', trained {:.1} … {:.1} °C\n\
             blob: {} bytes (22-byte header + postcard payload)\n\
             channel           centres  inputs  monomials  numbers  unit\n",
            model.display(),
            f.channels.len(),
            f.sensor_id,
            f.temperature_c[0],
            f.temperature_c[1],
            f.blob_bytes
        );
        let unit = fog_data::replay::decode_unit(&bytes)?;
        for ((name, c), ch) in f.channels.iter().zip(unit.channels()) {
            text.push_str(&format!(
                "{name:<17} {:>7}  {:>6}  {:>9}  {:>7}  ({})\n",
                c.m,
                c.d,
                c.p,
                c.floats,
                ch.quantity().unit()
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
        console.result(&text);
        if let Some(path) = json {
            write_json(&path, &[model.as_path()], schema::INSPECT_UNIT, &f)?;
        }
        return Ok(());
    }
    let f = export::footprint(&bytes)?;
    fog_data::replay::decode(&bytes)?;
    console.result(&format!(
        "{}: m = {} centres, d = {} inputs, p = {} prior monomials\n\
         blob: {} bytes ({}-byte header + postcard payload)\n\
         flat f32 array: 7d + p + 2 + m·d + m + m(m+1)/2 = {} numbers\n\
         static memory of Model<{}, {}, {}>: 4·{} + p·d + d + 24 = {} bytes (32-bit target)\n\
         variance scratch: 4·m = {} bytes",
        model.display(),
        f.m,
        f.d,
        f.p,
        f.blob_bytes,
        firmware_core::blob::HEADER_LEN,
        f.floats,
        f.d,
        f.p * f.d,
        f.floats,
        f.floats,
        f.model_bytes,
        f.scratch_bytes
    ));
    if let Some(path) = json {
        write_json(&path, &[model.as_path()], schema::INSPECT, &f)?;
    }
    Ok(())
}
