//! Speed of the paper-sized problem: GP fit with restarts, closed-form LOO, one likelihood
//! evaluation, and the LS-SVR tuning, on 140 paper-protocol-like points (10 temperatures × 14
//! rates, sine response, temperature-dependent scale factor, 2-min-mean noise).

use criterion::{Criterion, criterion_group, criterion_main};
use nalgebra::{DMatrix, DVector};
use rand::SeedableRng;
use rand_distr::{Distribution, Normal};
use trainer::models::gp::exact::lml_and_gradient;
use trainer::models::gp::{GpConfig, GpModel, Prepared};
use trainer::models::lssvr::LssvrModel;

/// The trainer's own allocator (`trainer/src/main.rs`), so that the fits timed here are the ones
/// `trainer fit` runs.
#[global_allocator]
static ALLOCATOR: mimalloc::MiMalloc = mimalloc::MiMalloc;

fn paper_like() -> (DMatrix<f64>, DVector<f64>) {
    let temps = [-30.0, -20.0, -10.0, -5.0, 0.0, 5.0, 10.0, 20.0, 40.0, 60.0];
    let rates = [
        -80.0, -40.0, -20.0, -10.0, -5.0, -2.0, -1.0, 1.0, 2.0, 5.0, 10.0, 20.0, 40.0, 80.0,
    ];
    let mut rng = rand_chacha::ChaCha8Rng::seed_from_u64(1);
    let noise = Normal::new(0.0, 4e-4).unwrap();
    let k = 0.12f64.to_radians();
    let (mut x, mut y) = (Vec::new(), Vec::new());
    for &t in &temps {
        for &w in &rates {
            let dt: f64 = t - 25.0;
            let s = 0.038 * (1.0 - 3e-4 * dt + 1.5e-6 * dt * dt);
            let omega: f64 = w + noise.sample(&mut rng);
            x.extend([t + 4.0, 0.002 + s * (k * omega).sin() / k]);
            y.push(w);
        }
    }
    (
        DMatrix::from_row_slice(y.len(), 2, &x),
        DVector::from_vec(y),
    )
}

fn benches(c: &mut Criterion) {
    let (x, y) = paper_like();
    let cfg = GpConfig::default();
    c.bench_function("gp_fit_140_points_4_starts", |b| {
        b.iter(|| GpModel::fit(&x, &y, &cfg).unwrap())
    });
    let model = GpModel::fit(&x, &y, &cfg).unwrap();
    c.bench_function("gp_closed_form_loo_140", |b| b.iter(|| model.loo_errors()));
    let data = Prepared::new(&x, &y, cfg.mean);
    let theta = model.posterior.hyper.to_log();
    c.bench_function("gp_lml_and_gradient_140", |b| {
        b.iter(|| lml_and_gradient(&data.z, &data.y, &data.h, &[], &theta).unwrap())
    });
    c.bench_function("lssvr_tuned_fit_140", |b| {
        b.iter(|| LssvrModel::fit(&x, &y, cfg.mean).unwrap())
    });
}

criterion_group! {
    name = paper_size;
    config = Criterion::default().sample_size(20);
    targets = benches
}
criterion_main!(paper_size);
