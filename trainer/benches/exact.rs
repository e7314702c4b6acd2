//! Exact GPs at the size of real rate tables (docs/performance.md): the fit (four starts and the
//! polish, the paper's constant mean, as `fit_timing` and the scikit-learn comparison run it), one
//! likelihood + gradient at the fitted θ, and the closed-form LOO, at n = 140, 500, 1,000 and
//! 2,000 points of the simulator's scattered table (`firmware-sim generate scattered --seed 7`),
//! the paper's protocol at 140.
//!
//! A fit at n = 2,000 takes tens of seconds: Criterion's minimum of ten samples makes this bench
//! several minutes long. `cargo bench -p trainer --bench exact -- 'n=1000'` runs one size.

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use firmware_sim::gyro::effects::Effect;
use firmware_sim::gyro::paper::{self, Point};
use firmware_sim::gyro::plant::GyroParams;
use nalgebra::{DMatrix, DVector};
use trainer::models::gp::exact::lml_and_gradient;
use trainer::models::gp::{GpConfig, GpModel, Inducing, Prepared};
use trainer::models::prior::MeanBasis;

/// The trainer's own allocator (`trainer/src/main.rs`), so that the fits timed here are the ones
/// `trainer fit` runs.
#[global_allocator]
static ALLOCATOR: mimalloc::MiMalloc = mimalloc::MiMalloc;

/// The table at size `n`, as the model's inputs (T, V) and target (rate).
fn table(n: usize) -> (DMatrix<f64>, DVector<f64>) {
    let params = GyroParams::nominal();
    let points: Vec<Point> = if n == 140 {
        paper::run(&params, Effect::None, 1, false)
    } else {
        paper::scattered(&params, Effect::None, 7, n)
    };
    let x = DMatrix::from_fn(points.len(), 2, |i, j| {
        [points[i].temp_c, points[i].voltage_v][j]
    });
    (
        x,
        DVector::from_iterator(points.len(), points.iter().map(|p| p.rate_dps)),
    )
}

fn benches(c: &mut Criterion) {
    let cfg = GpConfig {
        mean: MeanBasis::Constant,
        inducing: Inducing::Exact,
        ..GpConfig::default()
    };
    let mut group = c.benchmark_group("exact");
    group.sample_size(10);
    for n in [140, 500, 1_000, 2_000] {
        let (x, y) = table(n);
        let size = format!("n={n}");
        group.bench_function(BenchmarkId::new("fit", &size), |b| {
            b.iter(|| GpModel::fit(&x, &y, &cfg).unwrap())
        });
        let model = GpModel::fit(&x, &y, &cfg).unwrap();
        let data = Prepared::new(&x, &y, cfg.mean);
        let theta = model.posterior.hyper.to_log();
        group.bench_function(BenchmarkId::new("likelihood_and_gradient", &size), |b| {
            b.iter(|| lml_and_gradient(&data.z, &data.y, &data.h, &[], &theta).unwrap())
        });
        group.bench_function(BenchmarkId::new("closed_form_loo", &size), |b| {
            b.iter(|| model.loo_errors())
        });
    }
    group.finish();
}

criterion_group!(exact, benches);
criterion_main!(exact);
