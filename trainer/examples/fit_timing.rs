//! Wall time of repeated exact GP fits on one points file, and how far it is from what this
//! machine's dense linear algebra allows: the figure compared with scikit-learn
//! (`benches/versus_sklearn.py`), so with the paper's constant mean, which is what scikit-learn's
//! `normalize_y` GP implements, and always exact (scikit-learn has no sparse GP).
//!
//! The floor is `DenseFloor`'s: the fit's likelihood count times one Cholesky + inverse timed at
//! the same n, here against the median fit.
//!
//! Usage (the mean is constant unless told: scikit-learn's):
//!
//! ```text
//! cargo run --release -p trainer --example fit_timing -- points.csv [repeats] [--json]
//!     [--map NAME=SOURCE …] [--mean constant|physics|polyN]
//! ```

use fog_data::columns::ColumnMap;
use trainer::data::points::Points;
use trainer::models::dense::DenseFloor;
use trainer::models::gp::{GpConfig, GpModel, Inducing};
use trainer::models::prior::MeanBasis;

/// The trainer's own allocator (`trainer/src/main.rs`), so that the fits timed here are the ones
/// `trainer fit` runs.
#[global_allocator]
static ALLOCATOR: mimalloc::MiMalloc = mimalloc::MiMalloc;

const USAGE: &str =
    "usage: fit_timing POINTS [REPEATS] [--json] [--map NAME=SOURCE …] [--mean BASIS]";

fn main() -> anyhow::Result<()> {
    let mut args = std::env::args().skip(1);
    let (mut json, mut maps, mut mean, mut positional) = (false, Vec::new(), None, Vec::new());
    while let Some(a) = args.next() {
        match a.as_str() {
            "--json" => json = true,
            "--map" => maps.push(args.next().unwrap_or_default().parse::<ColumnMap>()?),
            "--mean" => {
                let basis = args.next().unwrap_or_default();
                mean = Some(basis.parse::<MeanBasis>().map_err(anyhow::Error::msg)?);
            }
            _ => positional.push(a),
        }
    }
    let path = positional.first().ok_or_else(|| anyhow::anyhow!(USAGE))?;
    let repeats: usize = positional.get(1).map_or(Ok(3), |s| s.parse())?;
    let points = Points::load(std::path::Path::new(path), &maps, None, None)?;
    let (x, y) = (points.inputs(), points.target());
    let cfg = GpConfig {
        mean: mean.unwrap_or(MeanBasis::Constant),
        inducing: Inducing::Exact,
        ..GpConfig::default()
    };
    let mut fits = Vec::new();
    for _ in 0..repeats {
        fits.push(GpModel::fit(x, &y, &cfg)?);
    }
    let mut times: Vec<f64> = fits.iter().map(|m| m.fit_seconds).collect();
    times.sort_by(f64::total_cmp);
    let median = times[repeats / 2];
    let last = fits.last().expect("at least one fit");
    let n = x.nrows();
    // The floor is set against the median fit, not the last one's own time.
    let DenseFloor {
        likelihoods,
        dense_seconds: dense,
        gflops,
        floor_seconds: floor,
        ..
    } = DenseFloor::measure(n, last.starts.iter().map(|s| s.likelihoods).sum(), median);
    if json {
        println!(
            "{}",
            serde_json::json!({
                "n": n,
                "fit_seconds_median": median,
                "fit_seconds_min": times[0],
                "repeats": repeats,
                "log_marginal_likelihood": last.log_marginal_likelihood(),
                "likelihoods": likelihoods,
                "dense_seconds": dense,
                "gflops": gflops,
                "floor_seconds": floor,
            })
        );
    } else {
        println!(
            "{path}: n {n}, median fit {:.3} s (min {:.3} s) over {repeats}; log ML {:.3}; \
             {likelihoods} likelihood evaluations × {:.1} ms of dense Cholesky + inverse \
             ({gflops:.1} GFLOP/s) = floor {floor:.3} s: the fit takes {:.2}× the floor",
            median,
            times[0],
            last.log_marginal_likelihood(),
            dense * 1e3,
            median / floor
        );
        for s in &last.starts {
            let fmt = |t: &[f64]| {
                t.iter()
                    .map(|v| format!("{v:.2}"))
                    .collect::<Vec<_>>()
                    .join(" ")
            };
            println!(
                "  [{}] → [{}]  log ML {:.3}  {} likelihoods, {}",
                fmt(&s.start),
                s.end.as_deref().map_or("failed".to_owned(), fmt),
                s.log_marginal_likelihood.unwrap_or(f64::NAN),
                s.likelihoods,
                s.status
            );
        }
    }
    Ok(())
}
