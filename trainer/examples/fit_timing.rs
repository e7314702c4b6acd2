//! Median wall time of repeated GP fits on one points file (the figure compared with scikit-learn,
//! so with the paper's constant mean, which is what scikit-learn's `normalize_y` GP implements).
//!
//! Usage: cargo run --release -p trainer --example fit_timing -- points.csv [repeats]

use trainer::data::points::Points;
use trainer::models::gp::{GpConfig, GpModel};
use trainer::models::prior::MeanBasis;

fn main() -> anyhow::Result<()> {
    let mut args = std::env::args().skip(1);
    let path = args
        .next()
        .ok_or_else(|| anyhow::anyhow!("usage: fit_timing POINTS [REPEATS]"))?;
    let repeats: usize = args.next().map_or(Ok(11), |s| s.parse())?;
    let points = Points::load(std::path::Path::new(&path), &[], None, None)?;
    let (x, y) = (points.inputs(), points.target());
    let cfg = GpConfig {
        mean: MeanBasis::Constant,
        ..GpConfig::default()
    };
    let mut times = Vec::new();
    let mut lml = 0.0;
    for _ in 0..repeats {
        let m = GpModel::fit(x, &y, &cfg)?;
        times.push(m.fit_seconds);
        lml = m.log_marginal_likelihood();
    }
    times.sort_by(f64::total_cmp);
    println!(
        "{path}: median fit {:.1} ms, min {:.1} ms over {repeats} fits; log ML {lml:.3}",
        times[repeats / 2] * 1e3,
        times[0] * 1e3
    );
    Ok(())
}
