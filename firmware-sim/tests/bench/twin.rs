//! Identification (issue 23): a twin recovers the simulator's own parameters from data it
//! generated, and an effect the twin lacks is named and closes the gap on held-out data.

use firmware_sim::gyro::effects::Effect;
use firmware_sim::gyro::paper;
use firmware_sim::gyro::plant::GyroParams;
use firmware_sim::gyro::stream as gyro_stream;
use firmware_sim::twin::{self, Measured, Record, SourceKind};
use fog_data::cause::Cause;

fn points(p: &GyroParams, seed: u64) -> Measured {
    Measured {
        kind: SourceKind::Points,
        records: paper::run(p, Effect::None, seed, false)
            .iter()
            .map(|pt| Record {
                time_s: None,
                temp_c: pt.temp_c,
                output: pt.voltage_v,
                rate_dps: pt.rate_dps,
            })
            .collect(),
        setpoint_c: None,
    }
}

fn stream(p: &GyroParams, effect: Effect, seed: u64) -> Measured {
    Measured {
        kind: SourceKind::Stream,
        records: gyro_stream::run(p, &gyro_stream::StreamConfig::default(), effect, seed)
            .iter()
            .map(|r| Record {
                time_s: Some(r.time_s),
                temp_c: r.temp_c,
                output: r.voltage_v,
                rate_dps: r.rate_dps,
            })
            .collect(),
        setpoint_c: None,
    }
}

/// The identified parameters against the unit's own, each within five standard errors of the
/// fit. The standard errors come from the points' residual scatter as if independent; the bias
/// instability correlates neighbouring points, and over eight noise seeds per unit the estimates
/// spread up to 1.7× the standard error, so five of them hold about three true sigmas.
#[test]
fn identification_recovers_the_simulators_own_parameters_for_random_units() {
    for unit in 1..=5u64 {
        let truth = GyroParams::random_unit(unit);
        let id = twin::identify(Some(&points(&truth, unit)), None, None, |_| {}).unwrap();
        let value = |name: &str| {
            let p = id.parameters.iter().find(|p| p.name == name).unwrap();
            assert!(
                p.determined,
                "unit {unit}: {name} not determined: {}",
                p.why
            );
            (p.value, p.std_error.unwrap())
        };
        let b = truth.bias_poly_dph;
        for (name, t) in [
            ("scale_factor_v_per_dps", truth.scale_factor_v_per_dps),
            ("sf_tc_per_c", truth.sf_tc_per_c),
            ("sf_tc2_per_c2", truth.sf_tc2_per_c2),
            ("sagnac_k_s", truth.sagnac_k_s),
            ("sf_asymmetry", truth.sf_asymmetry),
            ("output_offset_v", truth.output_offset_v),
            ("bias_poly_dph[0]", b[0]),
            ("bias_poly_dph[1]", b[1]),
            ("bias_poly_dph[2]", b[2]),
            ("bias_poly_dph[3]", b[3]),
        ] {
            let (v, se) = value(name);
            assert!(
                (v - t).abs() <= 5.0 * se,
                "unit {unit}: {name} {v:.6e} ± {se:.2e}, truth {t:.6e} ({:.1} σ)",
                (v - t) / se
            );
        }
        // A table of soaked points says nothing of the noise or of transients: nominal, and why.
        let arw = id
            .parameters
            .iter()
            .find(|p| p.name == "arw_dpsqrth")
            .unwrap();
        assert!(!arw.determined && arw.why.contains("static log"));
        assert_eq!(id.causes, vec![Cause::None]);
    }
}

/// The "measured" data carry an effect the static twin lacks: a coil lagging the sensor by 10
/// min, or a bias of 17.5 (°/h)/(°C/min) of the coil's temperature rate. Identification fits the
/// map on the rate table, names the effect on the stream's first two thirds, and its fitted
/// strength closes most of the gap on the last third, which it never saw.
#[test]
fn an_effect_the_twin_lacks_is_named_and_closes_the_gap_on_held_out_data() {
    let truth = GyroParams::nominal();
    for (effect, cause) in [
        (Effect::SensorLag { tau_min: 10.0 }, Cause::SensorLag),
        (
            Effect::ThermalRate {
                k_dph_per_c_per_min: 17.5,
            },
            Cause::ThermalRate,
        ),
    ] {
        let id = twin::identify(
            Some(&points(&truth, 1)),
            Some(&stream(&truth, effect, 2)),
            None,
            |_| {},
        )
        .unwrap();
        eprintln!(
            "{}: held out {:.2} → {:.2} °/h, causes {:?}, effects {:?}",
            cause.id(),
            id.fidelity_before_dph,
            id.fidelity_after_dph,
            id.causes,
            id.unit.effects
        );
        assert_eq!(id.causes[0], cause, "{:?}", id.candidates);
        assert!(id.fidelity_after_dph < 0.5 * id.fidelity_before_dph);
        // The strength found is the one hidden, within 10%.
        let found = id.unit.effects.iter().find(|e| e.cause() == cause).unwrap();
        assert!(
            (found.strength() / effect.strength() - 1.0).abs() < 0.1,
            "{found:?}"
        );
    }
}
