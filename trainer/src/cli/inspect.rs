//! `trainer inspect`: what a blob holds and what it costs the firmware.

use std::path::PathBuf;

use anyhow::Context;
use clap::Args;
use fog_terminal::console::{Console, ConsoleFlags};
use fog_terminal::io::write_json;
use fog_terminal::schema;

use crate::pipeline::inspect;

/// The arguments of `trainer inspect`.
#[derive(Args)]
pub(super) struct InspectArgs {
    /// The blob: a unit's, or a model blob of one channel.
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
    let inspection =
        inspect::inspect(&bytes).with_context(|| format!("decoding {}", model.display()))?;
    console.result(&inspection.text(&model.display().to_string()));
    if let Some(path) = json {
        let inputs = [model.as_path()];
        write_json(&path, &inputs, schema::INSPECT, &inspection.footprint)?;
    }
    Ok(())
}
