//! firmware-core's C interface as a C programmer uses it: `firmware-core/ffi/include/fog_replay.c`
//! built with the host's C compiler against the `fog-ffi` static library, run on a stream. It
//! reads and writes the same records as the Cortex-M4 image ([`crate::qemu`]), so its output
//! compares bit for bit with the host replay.

use std::path::{Path, PathBuf};
use std::process::Command;

use crate::data::stream::Stream;
use crate::replay::{self, Compensated};

/// Errors of building or running the C replay.
#[derive(Debug, thiserror::Error)]
pub enum CReplayError {
    /// The static library or the C program could not be built.
    #[error("building the C replay failed: {0}")]
    Build(String),
    /// The program failed.
    #[error("the C replay failed: {0}")]
    Run(String),
    /// File exchange failed.
    #[error(transparent)]
    Io(#[from] std::io::Error),
}

/// The workspace root.
fn root() -> PathBuf {
    Path::new(env!("CARGO_MANIFEST_DIR")).join("..")
}

fn run_ok(cmd: &mut Command) -> Result<(), CReplayError> {
    let out = cmd.output()?;
    if out.status.success() {
        Ok(())
    } else {
        Err(CReplayError::Build(format!(
            "{cmd:?}: {}",
            String::from_utf8_lossy(&out.stderr)
        )))
    }
}

/// Builds `libfog_ffi.a` (cargo, release, in `target/ffi`) and the C program against it (`cc`,
/// or `$CC`); returns the program. The commands are the ones docs/firmware.md gives.
pub fn build() -> Result<PathBuf, CReplayError> {
    let root = root();
    let target = root.join("target").join("ffi");
    let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
    run_ok(
        Command::new(cargo)
            .args([
                "build",
                "-p",
                "fog-ffi",
                "--release",
                "--quiet",
                "--target-dir",
            ])
            .arg(&target)
            .current_dir(&root)
            .env_remove("RUSTFLAGS"),
    )?;
    let include = root.join("firmware-core").join("ffi").join("include");
    let exe = target.join("fog_replay");
    let cc = std::env::var_os("CC").unwrap_or_else(|| "cc".into());
    run_ok(
        Command::new(cc)
            .args(["-O2", "-Wall", "-Wextra", "-Werror", "-I"])
            .arg(&include)
            .arg(include.join("fog_replay.c"))
            .arg(target.join("release").join("libfog_ffi.a"))
            .args(["-lm", "-lpthread", "-ldl", "-o"])
            .arg(&exe),
    )?;
    Ok(exe)
}

/// Runs the C program `exe` on `blob` and every sample of `stream`.
pub fn run(exe: &Path, blob: &[u8], stream: &Stream) -> Result<Compensated, CReplayError> {
    let dir = tempfile::tempdir()?;
    let [model, samples, out] = ["model.bin", "samples.bin", "out.bin"].map(|f| dir.path().join(f));
    std::fs::write(&model, blob)?;
    std::fs::write(&samples, replay::sample_records(stream))?;
    let status = Command::new(exe)
        .arg(&model)
        .arg(&samples)
        .arg(&out)
        .output()?;
    if !status.status.success() {
        return Err(CReplayError::Run(
            String::from_utf8_lossy(&status.stderr).into_owned(),
        ));
    }
    let compensated = replay::from_result_records(&std::fs::read(&out)?, blob);
    if compensated.rate_dps.len() != stream.len() {
        return Err(CReplayError::Run(format!(
            "{} results for {} samples",
            compensated.rate_dps.len(),
            stream.len()
        )));
    }
    Ok(compensated)
}
