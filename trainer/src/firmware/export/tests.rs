use super::*;
use crate::models::gp::GpConfig;

/// Points of a gyro with a temperature-dependent bias and scale factor.
fn points(scale_factor: Option<f64>) -> Points {
    let (mut temp_c, mut voltage_v, mut rate_dps) = (Vec::new(), Vec::new(), Vec::new());
    for t in [-20.0, 0.0, 20.0, 40.0, 60.0] {
        for (k, w) in [-40.0, -10.0, 0.0, 10.0, 40.0].into_iter().enumerate() {
            // The sensor's scatter on a soak, independent of the rate.
            temp_c.push(t + 0.01 * [0.3, -0.7, 0.1, 0.9, -0.4][k]);
            voltage_v.push(0.05 * w * (1.0 + 1e-4 * t) + 0.002 * t + 0.3);
            rate_dps.push(w);
        }
    }
    let group = temp_c.iter().map(|t: &f64| format!("{t:.0}")).collect();
    Points::new(temp_c, voltage_v, rate_dps, group, scale_factor, true, None)
}

fn fitted(p: &Points) -> (GpModel, Vec<u8>) {
    let m = GpModel::fit(p.inputs(), &p.target(), &GpConfig::default()).unwrap();
    let blob = points_blob(&m, p, &Extension::default()).unwrap();
    (m, blob)
}

#[test]
fn a_blob_that_follows_its_model_passes_one_that_does_not_is_refused() {
    let p = points(None);
    let (mut m, blob) = fitted(&p);
    let (_, report) = verify(&m, &blob, &p, &Extension::default()).unwrap();
    assert!(report.training.max_abs_mean_diff < 3e-5, "{report:?}");
    // The host model moved by 1e-3 °/s after export: the blob no longer follows it.
    m.prior.coefficients[0] += 1e-3;
    let e = verify(&m, &blob, &p, &Extension::default()).unwrap_err();
    assert!(
        matches!(
            e,
            ExportError::Disagrees {
                mismatch: Mismatch::Exceeds { .. },
                ..
            }
        ),
        "{e}"
    );
    assert!(e.to_string().contains("the training points"), "{e}");
}

#[test]
fn the_firmware_variance_with_an_error_model_follows_the_host() {
    let p = points(None);
    let (m, blob) = fitted(&p);
    let error = ErrorModel {
        sample_noise_var: 1e-6,
        sample_interval_s: 1.0,
        floor_var: 2e-6,
        extrapolation_var: 5e-3,
        walk_var_per_h: 0.0,
        trend_var_per_h2: 0.0,
        ..ErrorModel::noise_only(0.0)
    };
    let blob = with_error_model(&blob, &error).unwrap();
    let fw = replay::decode(&blob).unwrap();
    assert_eq!(fw.error_model(), error);
    let report = agreement_report(&m, &fw, p.inputs(), &Extension::default());
    // Beyond the range the extrapolation term dominates the bias variance; the f32 sum
    // follows the f64 one there to well inside 1e-3.
    let a = report.grid_beyond;
    assert!(a.n_var > 100 && a.n_extrapolating > 0, "{a:?}");
    assert!(a.max_rel_var_diff < 1e-3, "{a:?}");
}

#[test]
fn a_bias_model_is_compared_on_its_gp_part() {
    // The firmware's extra input (the output, through 1/K) is set to zero, so it evaluates
    // the bias the host models; before, the missing input made every comparison a fault.
    let p = points(Some(0.05));
    let (m, blob) = fitted(&p);
    let (_, report) = verify(&m, &blob, &p, &Extension::default()).unwrap();
    assert_eq!(report.training.n, 25);
    assert_eq!(report.training.n_fault, 0);
    assert!(report.training.max_abs_host_mean > 0.0);
    assert!(report.training.max_abs_mean_diff < 1e-5, "{report:?}");
    assert_eq!(p.inputs().ncols(), 1);
}
