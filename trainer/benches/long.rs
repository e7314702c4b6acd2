//! The performance picture of long streams (issue 7): the sparse GP's bound and fit against n and
//! m, an exact likelihood evaluation at n = 2,000 (the unit of an exact fit's cost), and
//! firmware-core's prediction on the host at m = 16…256. Full fits at n = 10⁵ take seconds each;
//! their times come from `/usr/bin/time` on the CLI (docs/performance.md), not from here.

use criterion::{BenchmarkId, Criterion, criterion_group, criterion_main};
use nalgebra::{DMatrix, DVector};
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;
use trainer::data::points::POINT_FEATURES;
use trainer::firmware::export;
use trainer::models::gp::exact::lml_and_gradient;
use trainer::models::gp::sparse;
use trainer::models::gp::{GpConfig, GpModel, Inducing, Prepared};

/// The trainer's own allocator (`trainer/src/main.rs`), so that the fits timed here are the ones
/// `trainer fit` runs.
#[global_allocator]
static ALLOCATOR: mimalloc::MiMalloc = mimalloc::MiMalloc;

/// n samples of a 2-D function with structure at a length scale of about 0.3 (normalized), so
/// that every inducing point up to 128 is used.
fn data(n: usize, seed: u64) -> (DMatrix<f64>, DVector<f64>) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let x = DMatrix::from_fn(n, 2, |_, _| rng.random_range(-2.0f64..2.0));
    let y = DVector::from_fn(n, |i, _| {
        (3.0 * x[(i, 0)]).sin() * (2.0 * x[(i, 1)]).cos() + 0.05 * rng.random_range(-1.0..1.0)
    });
    (x, y)
}

fn sparse_fits(c: &mut Criterion) {
    let mut group = c.benchmark_group("sparse");
    group.sample_size(10);
    for n in [10_000, 100_000] {
        let (x, y) = data(n, 1);
        let prepared = Prepared::new(&x, &y, GpConfig::default().mean);
        for m in [32, 64, 128] {
            let xs = trainer::models::kernel::scale_inputs(&prepared.z, &[0.3, 0.3]);
            let u = prepared.z.select_rows(&sparse::select(&xs, &xs, m));
            let theta = [0.3f64.ln(), 0.3f64.ln(), 0.0, 0.05f64.ln()];
            group.bench_with_input(
                BenchmarkId::new(format!("bound_and_gradient_n{n}"), m),
                &m,
                |b, _| {
                    b.iter(|| {
                        sparse::bound_and_gradient(&prepared.z, &prepared.y, &u, &theta).unwrap()
                    })
                },
            );
            if n == 10_000 {
                let cfg = GpConfig {
                    inducing: Inducing::Count(m),
                    ..GpConfig::default()
                };
                group.bench_with_input(BenchmarkId::new("fit_n10000", m), &m, |b, _| {
                    b.iter(|| GpModel::fit(&x, &y, &cfg).unwrap())
                });
            }
        }
    }
    group.finish();
}

fn exact_2000(c: &mut Criterion) {
    let (x, y) = data(2000, 2);
    let prepared = Prepared::new(&x, &y, GpConfig::default().mean);
    let theta = [0.3f64.ln(), 0.3f64.ln(), 0.0, 0.05f64.ln()];
    let mut group = c.benchmark_group("exact");
    group.sample_size(10);
    group.bench_function("lml_and_gradient_n2000", |b| {
        b.iter(|| lml_and_gradient(&prepared.z, &prepared.y, &prepared.h, &[], &theta).unwrap())
    });
    group.finish();
}

fn firmware_prediction(c: &mut Criterion) {
    let mut group = c.benchmark_group("firmware_predict");
    for m in [16, 32, 64, 128, 256] {
        let (x, y) = data(m, 3);
        let cfg = GpConfig {
            inducing: Inducing::Exact,
            ..GpConfig::default()
        };
        let model = GpModel::fit(&x, &y, &cfg).unwrap();
        let fw =
            fog_data::replay::decode(&export::to_blob(&model, &POINT_FEATURES).unwrap()).unwrap();
        let mut scratch = vec![0.0f32; m];
        let input = [0.3f32, -0.4];
        group.bench_with_input(BenchmarkId::new("mean", m), &m, |b, _| {
            b.iter(|| fw.predict_mean(std::hint::black_box(&input)))
        });
        group.bench_with_input(BenchmarkId::new("mean_and_variance", m), &m, |b, _| {
            b.iter(|| {
                fw.predict(std::hint::black_box(&input), &mut scratch)
                    .unwrap()
            })
        });
    }
    group.finish();
}

criterion_group!(benches, firmware_prediction, sparse_fits, exact_2000);
criterion_main!(benches);
