//! firmware-core's C interface as a C programmer uses it: `firmware-core/ffi/include/fog_replay.c`
//! built against the `fog-ffi` static library, with the host's C compiler ([`build`]) or with
//! `arm-none-eabi-gcc` and newlib for the Cortex-M4F, run under QEMU ([`build_m4`], [`run_m4`]).
//! It reads and writes the same records as the Rust Cortex-M4 image ([`crate::qemu`]), so its
//! output compares bit for bit with the host replay.

use std::path::{Path, PathBuf};
use std::process::Command;

use fog_data::replay::{self, Compensated};
use fog_data::stream::Stream;

/// Errors of building or running the C replay.
#[derive(Debug, thiserror::Error)]
pub enum CReplayError {
    /// The static library or the C program could not be built.
    #[error("building the C replay failed: {0}")]
    Build(String),
    /// The program failed.
    #[error("the C replay failed: {0}")]
    Run(String),
    /// No source tree to build from.
    #[error(transparent)]
    Source(#[from] crate::source_tree::NotFound),
    /// File exchange failed.
    #[error(transparent)]
    Io(#[from] std::io::Error),
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

/// Builds `libfog_ffi.a` (cargo, release, in `target/ffi`) for the host or `triple`; returns the
/// workspace root and that target directory.
fn build_library(triple: Option<&str>) -> Result<(PathBuf, PathBuf), CReplayError> {
    let root = crate::source_tree::locate(None)?;
    let target = root.join("target").join("ffi");
    let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
    let mut cmd = Command::new(cargo);
    cmd.args([
        "build",
        "-p",
        "fog-ffi",
        "--release",
        "--quiet",
        "--target-dir",
    ])
    .arg(&target)
    .current_dir(&root)
    .env_remove("RUSTFLAGS");
    if let Some(triple) = triple {
        cmd.args(["--target", triple]);
    }
    run_ok(&mut cmd)?;
    Ok((root, target))
}

/// A C program of the interface's: the replay example (`include/fog_replay.c`) or the self-test
/// of its promises (`tests/c/fog_selftest.c`), with the C flags it is built with.
#[derive(Debug, Clone, Copy)]
pub struct Program {
    /// Its source, from `firmware-core/ffi`.
    pub source: &'static str,
    /// The executable's name.
    pub name: &'static str,
    /// Extra C flags (e.g. `-fno-short-enums`).
    pub flags: &'static [&'static str],
}

/// The replay example of docs/firmware.md.
pub const REPLAY: Program = Program {
    source: "include/fog_replay.c",
    name: "fog_replay",
    flags: &[],
};

/// Builds `libfog_ffi.a` (cargo, release, in `target/ffi`) and the C program against it (`cc`,
/// or `$CC`); returns the program. The commands are the ones docs/firmware.md gives.
pub fn build() -> Result<PathBuf, CReplayError> {
    build_program(REPLAY)
}

/// [`build`] for any [`Program`].
pub fn build_program(program: Program) -> Result<PathBuf, CReplayError> {
    let (root, target) = build_library(None)?;
    let ffi = root.join("firmware-core").join("ffi");
    let exe = target.join(program.name);
    let cc = std::env::var_os("CC").unwrap_or_else(|| "cc".into());
    run_ok(
        Command::new(cc)
            .args(["-O2", "-Wall", "-Wextra", "-Werror"])
            .args(program.flags)
            .arg("-I")
            .arg(ffi.join("include"))
            .arg(ffi.join(program.source))
            .arg(target.join("release").join("libfog_ffi.a"))
            .args(["-lm", "-lpthread", "-ldl", "-o"])
            .arg(&exe),
    )?;
    Ok(exe)
}

/// Builds `libfog_ffi.a` for `thumbv7em-none-eabihf` and links the C program with
/// `arm-none-eabi-gcc`, newlib's semihosting start-up (rdimon) and `firmware-core/ffi/m4`'s
/// vector table and linker script; returns the ELF image for QEMU's mps2-an386.
pub fn build_m4() -> Result<PathBuf, CReplayError> {
    build_program_m4(REPLAY)
}

/// [`build_m4`] for any [`Program`].
pub fn build_program_m4(program: Program) -> Result<PathBuf, CReplayError> {
    let (root, target) = build_library(Some("thumbv7em-none-eabihf"))?;
    let ffi = root.join("firmware-core").join("ffi");
    let elf = target.join(format!("{}.elf", program.name));
    let crt0 = Command::new("arm-none-eabi-gcc")
        .args(M4_FLAGS)
        .arg("-print-file-name=rdimon-crt0.o")
        .output()
        .map_err(|e| CReplayError::Build(format!("arm-none-eabi-gcc: {e}")))?;
    let crt0 = String::from_utf8_lossy(&crt0.stdout).trim().to_owned();
    run_ok(
        Command::new("arm-none-eabi-gcc")
            .args(["-O2", "-Wall", "-Wextra", "-Werror"])
            .args(M4_FLAGS)
            .args(program.flags)
            .args([
                "--specs=rdimon.specs",
                "-nostartfiles",
                "-Wl,--gc-sections",
                "-T",
            ])
            .arg(ffi.join("m4").join("link.ld"))
            .arg("-I")
            .arg(ffi.join("include"))
            .arg(ffi.join("m4").join("startup.c"))
            .arg(ffi.join(program.source))
            .arg(crt0)
            .arg(
                target
                    .join("thumbv7em-none-eabihf")
                    .join("release")
                    .join("libfog_ffi.a"),
            )
            .args(["-lm", "-o"])
            .arg(&elf),
    )?;
    Ok(elf)
}

/// The Cortex-M4F with its FPU, hard-float ABI (as `thumbv7em-none-eabihf`).
const M4_FLAGS: [&str; 4] = [
    "-mcpu=cortex-m4",
    "-mthumb",
    "-mfloat-abi=hard",
    "-mfpu=fpv4-sp-d16",
];

/// Runs the C program `exe` (built by [`build`]) on `blob` (a unit or model blob) and every
/// sample of `streams` (one per channel, in the blob's channel order): one replay per channel.
pub fn run(exe: &Path, blob: &[u8], streams: &[&Stream]) -> Result<Vec<Compensated>, CReplayError> {
    let (compensated, _) = exchange(blob, streams, |[model, samples, out]| {
        Command::new(exe).arg(model).arg(samples).arg(out).output()
    })?;
    Ok(compensated)
}

/// The Cortex-M4F replay's results and the deepest stack it used.
#[derive(Debug, Clone)]
pub struct M4Run {
    /// One replay per channel.
    pub compensated: Vec<Compensated>,
    /// Bytes of stack the whole program used at most (newlib's start-up and stdio included), as
    /// its start-up file measures it (`firmware-core/ffi/m4/startup.c`).
    pub stack_bytes: u32,
}

/// Runs the Cortex-M4F image `elf` (built by [`build_m4`]) under QEMU on `blob` and every sample
/// of `streams`; its command line and files go over semihosting.
pub fn run_m4(elf: &Path, blob: &[u8], streams: &[&Stream]) -> Result<M4Run, CReplayError> {
    let (compensated, stderr) = exchange(blob, streams, |[model, samples, out]| {
        let config = format!(
            "enable=on,target=native,arg=fog_replay,arg={},arg={},arg={}",
            model.display(),
            samples.display(),
            out.display()
        );
        Command::new("qemu-system-arm")
            .args(&crate::qemu::QEMU_ARGS[..9])
            .args(["-semihosting-config", &config, "-kernel"])
            .arg(elf)
            .output()
    })?;
    let stack_bytes = stderr
        .lines()
        .find_map(|l| {
            l.strip_prefix("stack: ")?
                .strip_suffix(" bytes")?
                .parse()
                .ok()
        })
        .ok_or_else(|| CReplayError::Run(format!("no stack figure in: {stderr}")))?;
    Ok(M4Run {
        compensated,
        stack_bytes,
    })
}

/// Runs a program built by [`build_program`] (host) or [`build_program_m4`] (`m4`: under QEMU)
/// with `args`; returns what it wrote on stdout, or why it failed.
pub fn run_program(exe: &Path, m4: bool, args: &[&str]) -> Result<String, CReplayError> {
    let out = if m4 {
        let mut config = String::from("enable=on,target=native,arg=program");
        for a in args {
            config.push_str(",arg=");
            config.push_str(a);
        }
        Command::new("qemu-system-arm")
            .args(&crate::qemu::QEMU_ARGS[..9])
            .args(["-semihosting-config", &config, "-kernel"])
            .arg(exe)
            .output()?
    } else {
        Command::new(exe).args(args).output()?
    };
    let stdout = String::from_utf8_lossy(&out.stdout).into_owned();
    if out.status.success() {
        Ok(stdout)
    } else {
        Err(CReplayError::Run(format!(
            "{stdout}{}",
            String::from_utf8_lossy(&out.stderr)
        )))
    }
}

/// Writes the blob and the sample records, runs `program` on (model, samples, out) and reads the
/// results back, with what the program wrote on stderr.
fn exchange(
    blob: &[u8],
    streams: &[&Stream],
    program: impl FnOnce([&Path; 3]) -> std::io::Result<std::process::Output>,
) -> Result<(Vec<Compensated>, String), CReplayError> {
    let dir = tempfile::tempdir()?;
    let [model, samples, out] = ["model.bin", "samples.bin", "out.bin"].map(|f| dir.path().join(f));
    std::fs::write(&model, blob)?;
    std::fs::write(&samples, replay::unit_sample_records(streams))?;
    let status = program([&model, &samples, &out])?;
    if !status.status.success() {
        return Err(CReplayError::Run(format!(
            "{}{}",
            String::from_utf8_lossy(&status.stdout),
            String::from_utf8_lossy(&status.stderr)
        )));
    }
    let compensated = replay::from_unit_result_records(&std::fs::read(&out)?, blob);
    let n = streams.first().map_or(0, |s| s.len());
    if let Some(c) = compensated.iter().find(|c| c.rate_dps.len() != n) {
        return Err(CReplayError::Run(format!(
            "{} results for {n} samples",
            c.rate_dps.len()
        )));
    }
    Ok((
        compensated,
        String::from_utf8_lossy(&status.stderr).into_owned(),
    ))
}
