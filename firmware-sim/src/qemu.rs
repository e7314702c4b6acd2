//! Runs firmware-core's Cortex-M4F build (the `m4/` image) under `qemu-system-arm` on a stream, and
//! reads back what it computed and what it cost.
//!
//! The image and the host exchange files over semihosting in a temporary directory (the image's
//! module doc has the formats). Each run is two QEMU runs of the image. The first replays every
//! sample as fast as QEMU goes. The second replays only the first [`COST_SAMPLES`], over which the
//! image measures its cost, under `-icount shift=0`: its virtual clock then advances 1 ns per
//! executed instruction, and the image counts SysTick ticks of the 25 MHz system clock, so one
//! tick should be 40 instructions. The image also times a loop of known instruction count, and the
//! ticks are converted with that measured ratio. Counting every instruction halves QEMU's speed
//! (a 28,622-sample stream on a 140-centre model: 63 s counted, 34 s not), and only the cost needs
//! it; the second run's results must equal the first's, sample for sample.

use std::path::{Path, PathBuf};
use std::process::Command;
use std::time::Duration;

use serde::Serialize;

use fog_data::replay::{self, Compensated};
use fog_data::stream::Stream;

/// QEMU is stopped after this long.
pub const TIMEOUT: Duration = Duration::from_secs(900);

/// qemu-system-arm's arguments before the image: the MPS2-AN386 board (Cortex-M4F), no display,
/// semihosting for the file exchange; the cost run adds [`COUNTED`]. Then `-kernel` and the
/// image.
pub const QEMU_ARGS: [&str; 11] = [
    "-machine",
    "mps2-an386",
    "-cpu",
    "cortex-m4",
    "-nographic",
    "-monitor",
    "none",
    "-serial",
    "none",
    "-semihosting-config",
    "enable=on,target=native",
];

/// One instruction per virtual nanosecond, which makes the cost run's instruction counts exact.
pub const COUNTED: [&str; 2] = ["-icount", "shift=0"];

/// The samples the image measures its cost over (its own `COST_SAMPLES`): the first of the
/// stream, all the cost run is given.
pub const COST_SAMPLES: usize = 64;

/// Errors of a QEMU run.
#[derive(Debug, thiserror::Error)]
pub enum QemuError {
    /// `qemu-system-arm` could not be started.
    #[error(
        "cannot run qemu-system-arm ({0}); install it (Debian: apt-get install qemu-system-arm)"
    )]
    NotInstalled(std::io::Error),
    /// The image could not be built.
    #[error("building the Cortex-M4 image failed: {0}")]
    Build(String),
    /// The image exited with an error.
    #[error("the Cortex-M4 image failed: {0}")]
    Image(String),
    /// QEMU ran longer than [`TIMEOUT`].
    #[error("QEMU did not finish within {0:?}")]
    Timeout(Duration),
    /// No source tree to build the image from.
    #[error(transparent)]
    Source(#[from] crate::source_tree::NotFound),
    /// File exchange failed.
    #[error("{0}")]
    Io(#[from] std::io::Error),
}

/// The image's cost measurement, converted to instructions: of the evaluator alone, and of the
/// whole call per sample, every channel of the blob (one for a model blob).
#[derive(Debug, Clone, Copy, Serialize, schemars::JsonSchema)]
pub struct M4Cost {
    /// Samples timed per path.
    pub samples: u32,
    /// Instructions per prediction of the evaluator alone, every channel's mean at inputs
    /// computed beforehand (loop overhead removed).
    pub mean_instructions: f64,
    /// The same, means and variances.
    pub full_instructions: f64,
    /// Instructions per sample of the whole call: the features the channels share, then every
    /// channel's mean (`compensate_mean`).
    pub sample_mean_instructions: f64,
    /// The same with every channel's variances (`compensate`): what a sample costs the firmware.
    pub sample_full_instructions: f64,
    /// Instructions per `libm::expf` call (the transcendental of each centre).
    pub exp_instructions: f64,
    /// Instructions per SysTick tick, measured on the calibration loop.
    pub instructions_per_tick: f64,
}

impl M4Cost {
    /// The arithmetic minimum of the mean path per centre: one `expf` and 3·d multiply-adds.
    pub fn minimum_per_centre(&self, d: usize) -> f64 {
        self.exp_instructions + 3.0 * d as f64
    }
}

/// What the image computed.
#[derive(Debug, Clone)]
pub struct QemuRun {
    /// Per-sample output of each channel, as the host replay's.
    pub compensated: Vec<Compensated>,
    /// Cost per sample.
    pub cost: M4Cost,
}

/// Directory of the image's crate in the source tree `root` ([`crate::source_tree`]).
pub fn image_crate(root: &Path) -> PathBuf {
    root.join("firmware-sim").join("m4")
}

/// Builds the image (cargo, release, its own target directory); cheap when it is up to date.
pub fn build_image(root: &Path) -> Result<PathBuf, QemuError> {
    let cargo = std::env::var_os("CARGO").unwrap_or_else(|| "cargo".into());
    let out = Command::new(cargo)
        .args(["build", "--release", "--quiet"])
        .current_dir(image_crate(root))
        .env_remove("RUSTFLAGS")
        .env_remove("CARGO_TARGET_DIR")
        .output()?;
    if !out.status.success() {
        return Err(QemuError::Build(
            String::from_utf8_lossy(&out.stderr).into_owned(),
        ));
    }
    Ok(image_crate(root).join("target/thumbv7em-none-eabihf/release/fog-m4"))
}

/// Runs `image` on `blob` (a unit or model blob) and every sample of `streams`: one per channel,
/// in the blob's channel order, sharing their time ([`replay::replay_unit`]). Two runs (module
/// doc): every sample, then the first [`COST_SAMPLES`] counted for the cost.
pub fn run(image: &Path, blob: &[u8], streams: &[&Stream]) -> Result<QemuRun, QemuError> {
    let records = replay::unit_sample_records(streams);
    let samples = streams.first().map_or(0, |s| s.len());
    let compensated = session(image, blob, &records, false)?.0;
    if let Some(c) = compensated.iter().find(|c| c.rate_dps.len() != samples) {
        return Err(QemuError::Image(format!(
            "{} results for {samples} samples",
            c.rate_dps.len()
        )));
    }
    let record_bytes = records.len() / samples.max(1);
    let first = &records[..record_bytes * samples.min(COST_SAMPLES)];
    let (counted, cost) = session(image, blob, first, true)?;
    let agree = counted.iter().zip(&compensated).all(|(c, all)| {
        let n = c.rate_dps.len();
        let bits = |v: &[f32]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
        n == samples.min(COST_SAMPLES)
            && bits(&c.rate_dps) == bits(&all.rate_dps[..n])
            && bits(&c.bias_var) == bits(&all.bias_var[..n])
            && bits(&c.noise_var) == bits(&all.noise_var[..n])
            && c.status[..] == all.status[..n]
    });
    if !agree {
        return Err(QemuError::Image(
            "the counted run's results differ from the first run's on the same samples".into(),
        ));
    }
    Ok(QemuRun { compensated, cost })
}

/// One QEMU run of `image` on `blob` and the sample `records`, counting instructions when
/// `counted`: what it computed, and its cost measurement.
fn session(
    image: &Path,
    blob: &[u8],
    records: &[u8],
    counted: bool,
) -> Result<(Vec<Compensated>, M4Cost), QemuError> {
    let dir = tempfile::tempdir()?;
    std::fs::write(dir.path().join("model.bin"), blob)?;
    std::fs::write(dir.path().join("samples.bin"), records)?;
    let clock: &[&str] = if counted { &COUNTED } else { &[] };
    let mut child = Command::new("qemu-system-arm")
        .args(QEMU_ARGS)
        .args(clock)
        .arg("-kernel")
        .arg(image)
        .current_dir(dir.path())
        .stdout(std::process::Stdio::piped())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .map_err(QemuError::NotInstalled)?;
    let start = std::time::Instant::now();
    let status = loop {
        if let Some(status) = child.try_wait()? {
            break status;
        }
        if start.elapsed() > TIMEOUT {
            child.kill()?;
            return Err(QemuError::Timeout(TIMEOUT));
        }
        std::thread::sleep(Duration::from_millis(20));
    };
    let out = child.wait_with_output()?;
    if !status.success() {
        return Err(QemuError::Image(format!(
            "{status}: {}{}",
            String::from_utf8_lossy(&out.stdout),
            String::from_utf8_lossy(&out.stderr)
        )));
    }
    let bytes = std::fs::read(dir.path().join("out.bin"))?;
    let compensated = replay::from_unit_result_records(&bytes, blob);
    let cost = std::fs::read(dir.path().join("cost.bin"))?;
    if cost.len() != 44 {
        return Err(QemuError::Image(format!(
            "cost.bin has {} bytes",
            cost.len()
        )));
    }
    let word = |i: usize| {
        f64::from(u32::from_le_bytes([
            cost[4 * i],
            cost[4 * i + 1],
            cost[4 * i + 2],
            cost[4 * i + 3],
        ]))
    };
    let samples = word(0).max(1.0);
    let instructions_per_tick = word(6) / word(7).max(1.0);
    let per = |ticks: f64, empty: f64| (ticks - empty) * instructions_per_tick / samples;
    Ok((
        compensated,
        M4Cost {
            samples: word(0) as u32,
            mean_instructions: per(word(2), word(1)),
            full_instructions: per(word(3), word(1)),
            sample_mean_instructions: per(word(9), word(8)),
            sample_full_instructions: per(word(10), word(8)),
            exp_instructions: word(5) * instructions_per_tick / word(4).max(1.0),
            instructions_per_tick,
        },
    ))
}

/// How the M4 run and the host replay compare.
#[derive(Debug, Clone, Copy, Serialize, schemars::JsonSchema)]
pub struct M4Agreement {
    /// Largest |M4 mean − host mean|, °/s.
    pub max_abs_mean_diff: f64,
    /// Samples whose mean and bias variance are bit-identical.
    pub identical: usize,
    /// Every status equal.
    pub statuses_equal: bool,
}

impl M4Agreement {
    /// The agreement of several channels' replays together: the largest difference, the
    /// bit-identical samples of them all, and whether every status is equal.
    pub fn all(each: &[M4Agreement]) -> M4Agreement {
        M4Agreement {
            max_abs_mean_diff: each.iter().map(|a| a.max_abs_mean_diff).fold(0.0, f64::max),
            identical: each.iter().map(|a| a.identical).sum(),
            statuses_equal: each.iter().all(|a| a.statuses_equal),
        }
    }
}

/// Compares two replays of the same stream.
pub fn compare(host: &Compensated, m4: &Compensated) -> M4Agreement {
    let pairs = || host.rate_dps.iter().zip(&m4.rate_dps);
    M4Agreement {
        max_abs_mean_diff: pairs()
            .map(|(a, b)| (f64::from(*a) - f64::from(*b)).abs())
            .fold(0.0, f64::max),
        identical: pairs()
            .zip(host.bias_var.iter().zip(&m4.bias_var))
            .filter(|((a, b), (sa, sb))| a.to_bits() == b.to_bits() && sa.to_bits() == sb.to_bits())
            .count(),
        statuses_equal: host.status == m4.status,
    }
}
