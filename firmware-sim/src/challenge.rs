//! The challenge: hidden-effect cases through the whole investigation, scored by what it names.
//!
//! Each case draws an effect and its magnitude from the documented ranges by seed
//! ([`Effect::draw`]), simulates the paper-protocol points and two streams of one gyro with it
//! (training and held-out: other noise, other rate order), writes them as CSV files and hands only
//! those files to the trainer's investigation, which never sees the plant's settings. Cases run on
//! both cores (rayon); each is deterministic by its seed.

use rayon::prelude::*;
use serde::Serialize;
use trainer::cause::Cause;
use trainer::console::ProgressBar;
use trainer::dataset::Points;
use trainer::gp::GpConfig;
use trainer::investigate;
use trainer::stream::Stream;

use crate::effects::Effect;
use crate::plant::GyroParams;
use crate::{output, paper, stream};

/// One case and what the investigation made of it.
#[derive(Debug, Clone, Serialize)]
pub struct Case {
    /// The hidden effect.
    pub hidden: Effect,
    /// Seed of the case.
    pub seed: u64,
    /// The cause named.
    pub named: Cause,
    /// Static `rmse_60s_dps` on the held-out stream.
    pub static_rmse_60s_dps: f64,
    /// Extended `rmse_60s_dps` on the held-out stream.
    pub extended_rmse_60s_dps: f64,
    /// Their ratio.
    pub gain: f64,
}

/// Runs one case: `cause` drawn by `seed` on the nominal gyro.
pub fn run_case(cause: Cause, seed: u64) -> anyhow::Result<Case> {
    let params = GyroParams::nominal();
    let hidden = Effect::draw(cause, seed);
    let dir = tempfile::tempdir()?;
    let points_path = dir.path().join("points.csv");
    let train_path = dir.path().join("train.csv");
    let valid_path = dir.path().join("valid.csv");
    let cfg = stream::StreamConfig::default();
    std::fs::write(
        &points_path,
        output::points_csv(&paper::run(&params, hidden, seed, false)),
    )?;
    std::fs::write(
        &train_path,
        output::stream_csv(&stream::run(&params, &cfg, hidden, seed + 1)),
    )?;
    std::fs::write(
        &valid_path,
        output::stream_csv(&stream::run(&params, &cfg, hidden, seed + 2)),
    )?;
    let points = Points::load(&points_path, &[], None, None)?;
    let train = Stream::load(&train_path, &[])?;
    let valid = Stream::load(&valid_path, &[])?;
    let (inv, _) = investigate::investigate(
        &points,
        &train,
        &valid,
        &GpConfig::default(),
        None,
        &ProgressBar::hidden(),
    )?;
    Ok(Case {
        hidden,
        seed,
        named: inv.cause(),
        static_rmse_60s_dps: inv.static_score.rmse_60s_dps,
        extended_rmse_60s_dps: inv.extended_score.rmse_60s_dps,
        gain: inv.gain,
    })
}

/// The challenge over `seeds` seeds per cause (seeds `first`, `first + 10`, …, so the three
/// seeds of a case never overlap another's); `bar` counts the cases.
pub fn run(seeds: u64, first: u64, bar: &ProgressBar) -> anyhow::Result<Vec<Case>> {
    let jobs: Vec<(Cause, u64)> = Cause::ALL
        .into_iter()
        .flat_map(|c| (0..seeds).map(move |k| (c, first + 10 * k)))
        .collect();
    bar.inc_length(jobs.len() as u64);
    // Each case decodes firmware models, whose heapless storage is inline (about 140 KB at the
    // host's capacities); an unoptimized build keeps several copies per frame and overflowed
    // rayon's default 2 MB worker stack.
    let pool = rayon::ThreadPoolBuilder::new()
        .stack_size(CASE_STACK_BYTES)
        .build()?;
    pool.install(|| {
        jobs.into_par_iter()
            .map(|(c, s)| {
                let case = run_case(c, s);
                bar.inc(1);
                case
            })
            .collect()
    })
}

/// Stack of each worker thread of [`run`].
const CASE_STACK_BYTES: usize = 32 << 20;

/// The confusion matrix (rows hidden, columns named, in [`Cause::ALL`] order) and the text table.
pub fn confusion(cases: &[Case]) -> ([[usize; 6]; 6], String) {
    let index = |c: Cause| Cause::ALL.iter().position(|x| *x == c).unwrap_or(0);
    let mut m = [[0usize; 6]; 6];
    for c in cases {
        m[index(c.hidden.cause())][index(c.named)] += 1;
    }
    let mut s = format!("{:<14}", "hidden \\ named");
    for c in Cause::ALL {
        s.push_str(&format!(" {:>12}", c.id()));
    }
    s.push_str(&format!(" {:>16}\n", "gain min/median"));
    for (i, row) in m.iter().enumerate() {
        s.push_str(&format!("{:<14}", Cause::ALL[i].id()));
        for n in row {
            s.push_str(&format!(" {n:>12}"));
        }
        let mut gains: Vec<f64> = cases
            .iter()
            .filter(|c| index(c.hidden.cause()) == i)
            .map(|c| c.gain)
            .collect();
        gains.sort_by(f64::total_cmp);
        if let (Some(lo), Some(mid)) = (gains.first(), gains.get(gains.len() / 2)) {
            s.push_str(&format!(" {lo:>7.2}/{mid:<7.2}"));
        }
        s.push('\n');
    }
    (m, s)
}
