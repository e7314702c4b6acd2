//! The accuracy–cost curve of the sparse GP (docs/performance.md): the static model fitted on
//! a rate table pooled with every sample of long streams, sparse at several numbers of inducing
//! points and exact on random subsets of the same data, each scored by replaying a held-out
//! stream through its firmware blob. Writes the blobs, so that `firmware-sim qemu` can count their
//! M4 instructions, and prints one table row per model.
//!
//! Usage:
//!
//! ```text
//! cargo run --release -p trainer --example sparse_curve -- OUT_DIR POINTS HELD_OUT STREAM...
//! ```

use std::path::{Path, PathBuf};
use std::time::Instant;

use anyhow::Context;
use fog_data::replay;
use fog_data::stream::Stream;
use nalgebra::DMatrix;
use rand::SeedableRng;
use rand_chacha::ChaCha8Rng;
use trainer::data::points::Points;
use trainer::firmware::export::{self, Extension};
use trainer::models::gp::{GpConfig, GpModel, Inducing};

/// The trainer's own allocator (`trainer/src/main.rs`), so that the fits timed here are the ones
/// `trainer fit` runs.
#[global_allocator]
static ALLOCATOR: mimalloc::MiMalloc = mimalloc::MiMalloc;

/// Inducing points tried.
const INDUCING: [usize; 7] = [8, 12, 16, 20, 24, 32, 64];
/// Subset sizes of the exact GP: up to 2,000, past a comfortable fit (minutes), the size the
/// issue benchmarks.
const SUBSETS: [usize; 4] = [250, 500, 1000, 2000];

fn main() -> anyhow::Result<()> {
    let args: Vec<PathBuf> = std::env::args().skip(1).map(PathBuf::from).collect();
    let [out, points, held_out, streams @ ..] = args.as_slice() else {
        anyhow::bail!("usage: sparse_curve OUT_DIR POINTS HELD_OUT STREAM...");
    };
    anyhow::ensure!(!streams.is_empty(), "give at least one training stream");
    std::fs::create_dir_all(out)?;
    let mut pool = Points::load(points, &[], None, None)?;
    for path in streams {
        let s = Stream::load(path, &[])?;
        pool = pool.pooled(Points::from_stream_samples(path, &s, None)?)?;
    }
    let valid = Stream::load(held_out, &[])?;
    let (x, y) = (pool.inputs(), pool.target());
    println!(
        "{} training samples ({} points + {} streams), held out: {}",
        pool.len(),
        Points::load(points, &[], None, None)?.len(),
        streams.len(),
        held_out.display()
    );
    println!(
        "| model | centres | fit (s) | held-out rmse_60s (°/s) | blob (B) | floats + scratch (B) |"
    );
    println!("|---|---|---|---|---|---|");
    for m in INDUCING {
        let cfg = GpConfig {
            inducing: Inducing::Count(m),
            ..GpConfig::default()
        };
        row(out, &format!("sparse-m{m}"), &pool, x, &y, &cfg, &valid)?;
    }
    let mut rng = ChaCha8Rng::seed_from_u64(0);
    for n in SUBSETS {
        let mut idx = rand::seq::index::sample(&mut rng, pool.len(), n).into_vec();
        idx.sort_unstable();
        let sub = pool.select(&idx);
        let cfg = GpConfig {
            inducing: Inducing::Exact,
            ..GpConfig::default()
        };
        row(
            out,
            &format!("exact-n{n}"),
            &sub,
            sub.inputs(),
            &sub.target(),
            &cfg,
            &valid,
        )?;
    }
    Ok(())
}

/// Fits, exports, replays and prints one row.
fn row(
    out: &Path,
    name: &str,
    points: &Points,
    x: &DMatrix<f64>,
    y: &nalgebra::DVector<f64>,
    cfg: &GpConfig,
    valid: &Stream,
) -> anyhow::Result<()> {
    let t0 = Instant::now();
    let model = GpModel::fit(x, y, cfg).with_context(|| format!("fitting {name}"))?;
    let seconds = t0.elapsed().as_secs_f64();
    // Models beyond the firmware's 256 centres are replayed on the host (f64), the rest through
    // their blob (f32), as the gyro would run them.
    let (centres, blob_bytes, ram, comp) =
        match export::points_blob(&model, points, &Extension::default()) {
            Ok(blob) => {
                std::fs::write(out.join(format!("{name}.bin")), &blob)?;
                let fw = fog_data::replay::decode(&blob)?;
                let dims = fw.dims();
                let ram = 4 * (dims.floats() + dims.m);
                (
                    dims.m,
                    blob.len().to_string(),
                    ram.to_string(),
                    replay::replay(&fw, valid),
                )
            }
            Err(_) => {
                let mut comp = replay::Compensated::default();
                for i in 0..valid.len() {
                    let p = model.predict(&[valid.temp_c[i], valid.voltage_v[i]]);
                    comp.rate_dps.push(p.mean as f32);
                    comp.bias_var.push(p.latent_var as f32);
                    comp.noise_var.push(p.noise_var as f32);
                    comp.status.push(firmware_core::Status::Valid);
                }
                let na = "— (host)".to_string();
                (model.posterior.xs.nrows(), na.clone(), na, comp)
            }
        };
    let score = replay::score(valid, &comp);
    println!(
        "| {name} | {centres} | {seconds:.1} | {:.3e} | {blob_bytes} | {ram} |",
        score.rmse_60s_dps
    );
    Ok(())
}
