use super::optimize::{POLISH, raise_noise};
use super::*;
use crate::models::dense;
use crate::models::gp::GpModel;
use crate::models::prior::{MeanBasis, design};
use nalgebra::DMatrix;
use nalgebra::DVector;
use rand::{RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

fn toy(n: usize, seed: u64) -> (DMatrix<f64>, DVector<f64>) {
    let mut rng = ChaCha8Rng::seed_from_u64(seed);
    let x = DMatrix::from_fn(n, 2, |_, _| rng.random_range(-2.0f64..2.0));
    let y = DVector::from_fn(n, |i, _| (1.3 * x[(i, 0)]).sin() + 0.4 * x[(i, 1)].powi(2));
    (x, y)
}

#[test]
fn closed_form_group_loo_equals_refitting_without_the_group() {
    let (z, y) = toy(24, 5);
    let hyper = Hyperparameters::from_log(&[0.2, -0.3, 0.1, -2.0]);
    let groups: Vec<Vec<usize>> = (0..8).map(|g| vec![3 * g, 3 * g + 1, 3 * g + 2]).collect();
    for h in bases(&z) {
        let full = Posterior::new(&z, &y, &h, hyper.clone()).unwrap();
        let kinv = dense::inverse_from_cholesky(&full.chol);
        let e = group_loo(&kinv, &h, &y, &groups).unwrap();
        for g in &groups {
            let keep: Vec<usize> = (0..24).filter(|i| !g.contains(i)).collect();
            let rows = |m: &DMatrix<f64>| m.select_rows(&keep);
            let rest = Posterior::new(
                &rows(&z),
                &DVector::from_iterator(keep.len(), keep.iter().map(|&i| y[i])),
                &rows(&h),
                hyper.clone(),
            )
            .unwrap();
            for &i in g {
                let zi: Vec<f64> = z.row(i).iter().copied().collect();
                let basis: f64 = (0..h.ncols()).map(|j| h[(i, j)] * rest.beta[j]).sum();
                let refit = rest.predict(&zi).0 + basis - y[i];
                assert!((e[i] - refit).abs() < 1e-8, "{} vs {refit}", e[i]);
            }
        }
    }
}

/// No basis, and the linear basis {1, z₀, z₁}.
fn bases(z: &DMatrix<f64>) -> [DMatrix<f64>; 2] {
    [
        DMatrix::zeros(z.nrows(), 0),
        design(z, &MeanBasis::Poly(1).exponents(2)),
    ]
}

#[test]
fn analytic_gradient_matches_finite_differences() {
    let (z, y) = toy(25, 1);
    let y = y.map(|v| v + 0.01);
    let groups: Vec<usize> = (0..25).map(|i| i % 4).collect();
    // Six inputs: the gradient's length-scale sums take two passes over each column.
    let z6 = DMatrix::from_fn(25, 6, |i, k| z[(i, k % 2)] * (1.0 + 0.3 * k as f64));
    let none = DMatrix::zeros(25, 0);
    let six = (
        &z6,
        &none,
        &groups[..],
        vec![-0.3, 0.7, 0.1, 0.4, 0.9, -0.2, 0.2, -2.5, -1.0],
    );
    for (z, h, offsets, theta) in bases(&z)
        .iter()
        .flat_map(|h| {
            [
                (&z, h, &[][..], vec![0.0, 0.0, 0.0, 0.0]),
                (&z, h, &[][..], vec![-0.3, 0.7, 0.2, -2.5]),
                (&z, h, &groups[..], vec![-0.3, 0.7, 0.2, -2.5, -1.0]),
            ]
        })
        .chain([six])
    {
        let lml = |t: &[f64]| lml_and_gradient(z, &y, h, offsets, t).unwrap();
        let (_, g) = lml(&theta);
        assert_eq!(g.len(), theta.len());
        for j in 0..theta.len() {
            let step = 1e-5;
            let mut tp = theta.clone();
            tp[j] += step;
            let mut tm = theta.clone();
            tm[j] -= step;
            let fd = (lml(&tp).0 - lml(&tm).0) / (2.0 * step);
            assert!(
                (fd - g[j]).abs() < 1e-5 * (1.0 + fd.abs()),
                "θ {theta:?} j {j}: analytic {} fd {fd}",
                g[j]
            );
        }
    }
}

#[test]
fn lml_of_two_points_by_hand() {
    // n = 2, d = 1, z = (0, 1), y = (1, −1), ℓ = σ_f = σ_n = 1:
    // K = [[2, e^{-1/2}], [e^{-1/2}, 2]], |K| = 4 − e^{-1}, yᵀK⁻¹y = 2(2 + e^{-1/2}) / |K|.
    let z = DMatrix::from_row_slice(2, 1, &[0.0, 1.0]);
    let y = DVector::from_row_slice(&[1.0, -1.0]);
    let none = DMatrix::zeros(2, 0);
    let p = Posterior::new(&z, &y, &none, Hyperparameters::from_log(&[0.0, 0.0, 0.0])).unwrap();
    let c = (-0.5f64).exp();
    let det = 4.0 - c * c;
    let quad = 2.0 * (2.0 + c) / det;
    let expected = -0.5 * quad - 0.5 * det.ln() - (2.0 * std::f64::consts::PI).ln();
    assert!((p.log_marginal_likelihood - expected).abs() < 1e-12);
    assert_eq!(p.jitter, 0.0);
}

#[test]
fn closed_form_loo_matches_brute_force_refits() {
    let (z, y) = toy(30, 2);
    let hyper = Hyperparameters {
        length_scales: vec![0.8, 1.5],
        signal_std: 1.2,
        noise_std: 0.05,
        offset_std: None,
    };
    for h in bases(&z) {
        let full = Posterior::new(&z, &y, &h, hyper.clone()).unwrap();
        let loo = full.loo();
        for i in 0..z.nrows() {
            let keep: Vec<usize> = (0..z.nrows()).filter(|&j| j != i).collect();
            let (zi, yi, hi) = (
                z.select_rows(&keep),
                y.select_rows(&keep),
                h.select_rows(&keep),
            );
            let p = Posterior::new(&zi, &yi, &hi, hyper.clone()).unwrap();
            let (m, v) = p.predict(&[z[(i, 0)], z[(i, 1)]]);
            let m = m + h.row(i).dot(&p.beta.transpose());
            assert!((m - y[i] - loo[i].0).abs() < 1e-9, "point {i}");
            // Without a basis 1/P_ii is the predictive variance; with one it adds β̂'s.
            if h.ncols() == 0 {
                let noisy = v + hyper.noise_std.powi(2);
                assert!((noisy - loo[i].1).abs() < 1e-9, "point {i}");
            } else {
                assert!(loo[i].1 >= v + hyper.noise_std.powi(2) - 1e-12, "point {i}");
            }
        }
    }
}

#[test]
fn grouped_loo_predicts_as_the_firmware_would_without_the_offsets() {
    let (z, y) = toy(30, 2);
    let groups: Vec<usize> = (0..30).map(|i| i / 6).collect();
    let hyper = Hyperparameters {
        length_scales: vec![0.8, 1.5],
        signal_std: 1.2,
        noise_std: 0.05,
        offset_std: Some(0.7),
    };
    for h in bases(&z) {
        let full = Posterior::grouped(&z, &y, &h, hyper.clone(), &groups).unwrap();
        let kinv = dense::inverse_from_cholesky(&full.chol);
        let members: Vec<Vec<usize>> = (0..5)
            .map(|g| (0..30).filter(|&i| groups[i] == g).collect())
            .collect();
        let by_group = group_loo(&kinv, &h, &y, &members).unwrap();
        let loo = full.loo();
        // Refit without the point (or its group) and predict with the kernel alone: the
        // offsets enter the training covariance, never the cross covariance.
        let refit = |keep: &[usize], i: usize| {
            let sub: Vec<usize> = keep.iter().map(|&j| groups[j]).collect();
            let p = Posterior::grouped(
                &z.select_rows(keep),
                &y.select_rows(keep),
                &h.select_rows(keep),
                hyper.clone(),
                &sub,
            )
            .unwrap();
            p.predict(&[z[(i, 0)], z[(i, 1)]]).0 + h.row(i).dot(&p.beta.transpose()) - y[i]
        };
        for i in 0..30 {
            let others: Vec<usize> = (0..30).filter(|&j| j != i).collect();
            assert!((refit(&others, i) - loo[i].0).abs() < 1e-9, "point {i}");
            let rest: Vec<usize> = (0..30).filter(|&j| groups[j] != groups[i]).collect();
            assert!((refit(&rest, i) - by_group[i]).abs() < 1e-9, "group of {i}");
        }
    }
}

#[test]
fn offsets_between_groups_are_fitted_and_leave_the_length_scale_alone() {
    // A smooth function of one input, each group of 12 samples shifted by its own offset.
    let mut rng = ChaCha8Rng::seed_from_u64(8);
    let shift: Vec<f64> = (0..8).map(|_| rng.random_range(-0.6f64..0.6)).collect();
    let x = DMatrix::from_fn(96, 1, |i, _| {
        -2.0 + 4.0 * (i % 12) as f64 / 11.0 + 0.01 * (i / 12) as f64
    });
    let groups: Vec<usize> = (0..96).map(|i| i / 12).collect();
    let y = DVector::from_fn(96, |i, _| (0.8 * x[(i, 0)]).sin() + shift[groups[i]]);
    let cfg = GpConfig::default();
    let m = GpModel::fit_grouped(&x, &y, &groups, &cfg).unwrap();
    let g = m.posterior.hyper.offset_std.unwrap() * m.output_scale;
    let spread = (shift.iter().map(|s| s * s).sum::<f64>() / 8.0).sqrt();
    assert!(
        (g / spread - 1.0).abs() < 0.5,
        "σ_g {g} against offsets' RMS {spread}"
    );
    let l = m.posterior.hyper.length_scales[0] * m.input_norm.scale[0];
    assert!(l > 0.5, "length scale {l}: the GP follows the offsets");
    assert!(m.predict(&[0.0]).noise_var > g * g * 0.99);
}

#[test]
fn gls_recovers_a_linear_trend_under_the_gp() {
    let (z, f) = toy(40, 5);
    let h = bases(&z)[1].clone();
    let beta = DVector::from_row_slice(&[0.5, -2.0, 3.0]);
    let y = &f + &h * &beta;
    let hyper = Hyperparameters {
        length_scales: vec![0.8, 1.5],
        signal_std: 1.0,
        noise_std: 0.01,
        offset_std: None,
    };
    let with = Posterior::new(&z, &y, &h, hyper.clone()).unwrap();
    let without = Posterior::new(&z, &f, &DMatrix::zeros(40, 0), hyper).unwrap();
    // The trend goes into β̂, the rest into the GP as before.
    for i in 0..40 {
        let zi = [z[(i, 0)], z[(i, 1)]];
        let a = with.predict(&zi).0 + h.row(i).dot(&with.beta.transpose());
        let b = without.predict(&zi).0 + h.row(i).dot(&beta.transpose());
        assert!((a - b).abs() < 0.05, "{i}: {a} vs {b}");
    }
}

#[test]
fn ard_sends_an_irrelevant_input_long() {
    let mut rng = ChaCha8Rng::seed_from_u64(3);
    let x = DMatrix::from_fn(60, 2, |_, _| rng.random_range(-2.0f64..2.0));
    let y = DVector::from_fn(60, |i, _| {
        (1.5 * x[(i, 0)]).sin() + 0.01 * rng.random::<f64>()
    });
    let cfg = GpConfig {
        mean: MeanBasis::Constant,
        ..GpConfig::default()
    };
    let m = GpModel::fit(&x, &y, &cfg).unwrap();
    let l = &m.posterior.hyper.length_scales;
    assert!(l[1] > 20.0 * l[0], "length scales {l:?}");
}

#[test]
fn an_extension_is_searched_from_where_the_nested_fits_starts_ended() {
    let (x, y) = toy(60, 8);
    let cfg = GpConfig::default();
    let nested = GpModel::fit(&x, &y, &cfg).unwrap();
    let ends = nested.start_ends();
    // The four starts, not the polish from the best.
    assert_eq!(ends.len(), 4);
    assert_eq!(nested.starts.len(), 5);
    let terms = DMatrix::from_fn(60, 1, |i, _| x[(i, 0)].powi(3));
    let (extended, _) = GpModel::fit_with_terms(&x, &terms, &y, &[], &cfg, &nested).unwrap();
    let started: Vec<Vec<f64>> = extended.starts[..4]
        .iter()
        .map(|r| r.start.clone())
        .collect();
    assert_eq!(started, ends);
}

#[test]
fn an_unpolished_fit_once_polished_is_the_fit() {
    let (x, y) = toy(48, 6);
    let groups: Vec<usize> = (0..48).map(|i| i / 12).collect();
    let cfg = GpConfig::default();
    let fit = GpModel::fit_grouped(&x, &y, &groups, &cfg).unwrap();
    let rough = GpModel::fit_grouped_unpolished(&x, &y, &groups, &cfg).unwrap();
    // The starts alone, ending where the fit's starts ended; the extension starts there too.
    assert!(rough.starts.iter().all(|r| !r.polish));
    assert_eq!(rough.start_ends(), fit.start_ends());
    assert_eq!(rough.starts.len() + 1, fit.starts.len());
    let polished = rough.clone().polished(&x, &y, &groups, &cfg).unwrap();
    assert_eq!(
        polished.posterior.hyper.to_log(),
        fit.posterior.hyper.to_log()
    );
    assert_eq!(polished.optimization, fit.optimization);
    assert!(polished.starts.last().is_some_and(|r| r.polish));
    assert!(polished.posterior.log_marginal_likelihood >= rough.posterior.log_marginal_likelihood);
    // A polished GP stays as it is; other data is refused.
    let again = polished.clone().polished(&x, &y, &groups, &cfg).unwrap();
    assert_eq!(again.starts.len(), polished.starts.len());
    let fewer = x.rows(0, 24).into_owned();
    let err = rough.polished(&fewer, &y.rows(0, 24).into_owned(), &groups[..24], &cfg);
    assert!(matches!(
        err,
        Err(GpError::NotItsData {
            fitted: 48,
            given: 24
        })
    ));
}

#[test]
fn fit_beats_every_start_and_predicts_the_function() {
    let (x, y) = toy(80, 4);
    let m = GpModel::fit(&x, &y, &GpConfig::default()).unwrap();
    let best = m.log_marginal_likelihood();
    for r in &m.starts {
        if let Some(l) = r.log_marginal_likelihood {
            assert!(l <= best + 1e-9);
        }
    }
    let p = m.predict(&[0.3, -0.4]);
    let truth = (1.3f64 * 0.3).sin() + 0.4 * 0.16;
    assert!((p.mean - truth).abs() < 1e-3, "{} vs {truth}", p.mean);
    assert!(p.latent_var >= 0.0);
}

/// The mean alone is the full prediction's mean, bit for bit, for an exact GP and a sparse one,
/// inside the data and beyond them.
#[test]
fn the_mean_alone_is_the_predictions_mean_bit_for_bit() {
    let (x, y) = toy(80, 4);
    let exact = GpModel::fit(&x, &y, &GpConfig::default()).unwrap();
    let sparse = GpConfig {
        inducing: Inducing::Count(12),
        ..GpConfig::default()
    };
    let sparse = GpModel::fit(&x, &y, &sparse).unwrap();
    assert!(sparse.sparse.is_some());
    for m in [&exact, &sparse] {
        for at in [[0.3, -0.4], [-0.9, 0.7], [3.0, -2.5]] {
            assert_eq!(
                m.predict_mean(&at).to_bits(),
                m.predict(&at).mean.to_bits(),
                "{at:?}"
            );
        }
    }
}

#[test]
fn inducing_parses_and_chooses_by_size() {
    assert_eq!("auto".parse(), Ok(Inducing::Auto));
    assert_eq!("exact".parse(), Ok(Inducing::Exact));
    assert_eq!("24".parse(), Ok(Inducing::Count(24)));
    assert!("1".parse::<Inducing>().is_err());
    assert!("many".parse::<Inducing>().is_err());
    assert_eq!(Inducing::Auto.count(AUTO_EXACT_MAX), None);
    assert_eq!(
        Inducing::Auto.count(AUTO_EXACT_MAX + 1),
        Some(DEFAULT_INDUCING)
    );
    assert_eq!(Inducing::Count(50).count(40), None);
    assert_eq!(Inducing::Exact.count(1_000_000), None);
}

#[test]
fn a_nan_likelihood_is_a_failed_start_never_the_best() {
    let nan = StartReport {
        samples: 10,
        start: vec![0.0; 4],
        end: Some(vec![1.0; 4]),
        log_marginal_likelihood: Some(f64::NAN),
        evaluations: 1,
        likelihoods: 1,
        status: String::new(),
        converged: false,
        polish: false,
    };
    let fine = StartReport {
        end: Some(vec![2.0; 4]),
        log_marginal_likelihood: Some(-1.0),
        ..nan.clone()
    };
    assert_eq!(best_of(&[nan, fine]).map(|b| b.0), Some(vec![2.0; 4]));
}

#[test]
fn sigma_n_is_raised_only_along_a_flat_likelihood() {
    // d = 2: θ = (ln ℓ₁, ln ℓ₂, ln σ_f, ln σ_n). Flat in ln σ_n below −5, falling above it.
    let flat = |t: &[f64]| -> Result<(f64, Vec<f64>), GpError> {
        Ok((
            -t[0] * t[0] - 10.0 * (t[3] + 5.0).max(0.0).powi(2),
            vec![0.0; 4],
        ))
    };
    let bounds = Bounds::default();
    let start = vec![0.0, 0.0, 0.0, -12.0];
    let raised = raise_noise(&flat, start.clone(), 0.0, 2, &bounds);
    assert_eq!(raised, vec![0.0, 0.0, 0.0, -5.0]);
    // Peaked at ln σ_n = −12: one step would cost 0.25 nats, so θ stays.
    let peaked = |t: &[f64]| -> Result<(f64, Vec<f64>), GpError> {
        Ok((-(t[3] + 12.0).powi(2), vec![0.0; 4]))
    };
    assert_eq!(raise_noise(&peaked, start.clone(), 0.0, 2, &bounds), start);
    // An unevaluable step ends the raise where it is.
    let failing = failing_below(1.0);
    assert_eq!(
        raise_noise(&failing, start.clone(), -1.0, 2, &bounds),
        start
    );
}

/// A likelihood that cannot be evaluated below σ_n = `floor` (normalized).
fn failing_below(floor: f64) -> impl Fn(&[f64]) -> Result<(f64, Vec<f64>), GpError> + Sync {
    move |t: &[f64]| match t.last() {
        Some(&ln_noise) if ln_noise >= floor.ln() => Ok((-1.0, vec![0.0; t.len()])),
        _ => Err(GpError::NotPositiveDefinite { jitter: 1.0 }),
    }
}

#[test]
fn every_start_failing_falls_back_with_raised_noise() {
    let cfg = GpConfig::default();
    let likelihood = failing_below(5.0);
    let found = search(&likelihood, (10, 2), false, &cfg).unwrap();
    assert!(found.reports.iter().all(|r| r.end.is_none()));
    let Optimization::Fallback { noise_std, .. } = found.optimization else {
        panic!("{:?}", found.optimization);
    };
    assert!((noise_std - 10.0).abs() < 1e-9, "{noise_std}");
    assert_eq!(&found.theta[..3], &[0.0, 0.0, 0.0]);
    // Beyond the bound the fallback gives up, with every start's status.
    let never = failing_below(100.0);
    let e = search(&never, (10, 2), false, &cfg).err().unwrap();
    assert!(matches!(e, GpError::OptimizerFailed(_)), "{e}");
    assert_eq!(e.to_string().matches("stopped:").count(), 4, "{e}");
}

#[test]
fn a_search_that_converges_nowhere_says_so_and_keeps_its_best() {
    let (x, y) = toy(40, 3);
    let capped = GpConfig {
        max_iters: 1,
        ..GpConfig::default()
    };
    let m = GpModel::fit(&x, &y, &capped).unwrap();
    assert!(m.starts.iter().all(|r| !r.converged));
    let Optimization::StoppedEarly {
        log_marginal_likelihood,
    } = m.optimization
    else {
        panic!("{:?}", m.optimization);
    };
    assert!((log_marginal_likelihood - m.log_marginal_likelihood()).abs() < 1e-9);
    assert!(
        m.warnings()[0].contains("converged from no start"),
        "{:?}",
        m.warnings()
    );
    let free = GpModel::fit(&x, &y, &GpConfig::default()).unwrap();
    assert_eq!(free.optimization, Optimization::Converged);
    assert!(free.warnings().is_empty(), "{:?}", free.warnings());
    assert!(free.log_marginal_likelihood() > log_marginal_likelihood);
}

/// A likelihood rough at rounding level near its maximum, as an ill-conditioned K makes it: a
/// smooth bowl plus wiggles of 1e-7 per sample, and a gradient whose wiggles never let the
/// polish's tolerance be met. The polish stops on the stall, well inside its budget, and keeps
/// the best point; a run on the bowl alone converges without stalling.
#[test]
fn a_run_stops_when_its_gains_sink_below_rounding_and_keeps_its_best() {
    let n = 1000.0;
    let rough = |t: &[f64]| -> Result<(f64, Vec<f64>), GpError> {
        let wiggle: f64 = t.iter().map(|v| (v * 1e6).sin()).sum();
        let lml = -n * (t.iter().map(|v| (v - 0.5).powi(2)).sum::<f64>() + 1e-7 * wiggle);
        let grad = t
            .iter()
            .map(|v| -n * (2.0 * (v - 0.5) + 1e-3 * (v * 1e6).cos()))
            .collect();
        Ok((lml, grad))
    };
    let ranges = GpConfig::default().bounds.ranges(2, 4);
    let start = vec![0.4, 0.45, 0.3, 0.6];
    let run = optimize_from(&rough, 1000, start.clone(), &ranges, 100, POLISH);
    assert!(run.status.contains("stalled"), "{}", run.status);
    assert!(run.evaluations < POLISH.budget, "{}", run.evaluations);
    let end = run.end.unwrap();
    assert!(end.iter().all(|v| (v - 0.5).abs() < 1e-2), "{end:?}");
    assert_eq!(run.log_marginal_likelihood, Some(rough(&end).unwrap().0));

    let smooth = |t: &[f64]| -> Result<(f64, Vec<f64>), GpError> {
        let lml = -n * t.iter().map(|v| (v - 0.5).powi(2)).sum::<f64>();
        Ok((lml, t.iter().map(|v| -2.0 * n * (v - 0.5)).collect()))
    };
    let run = optimize_from(&smooth, 1000, start, &ranges, 100, POLISH);
    assert!(run.converged, "{}", run.status);
}

#[test]
fn jitter_escalates_on_a_singular_matrix() {
    let k = DMatrix::from_element(3, 3, 1.0);
    let (_, jitter) = cholesky_with_jitter(k).unwrap();
    assert!(jitter > 0.0);
}

#[test]
fn a_non_finite_covariance_is_refused_before_any_jitter() {
    for bad in [f64::NAN, f64::INFINITY] {
        let mut k = DMatrix::identity(4, 4) * 2.0;
        k[(3, 1)] = bad;
        assert!(matches!(
            cholesky_with_jitter(k),
            Err(GpError::NotPositiveDefinite { jitter: 0.0 })
        ));
    }
}
