//! The Cortex-M4F build under QEMU against the host replay, over a full simulated stream (issue 4).
//! Needs `qemu-system-arm` and the `thumbv7em-none-eabihf` target (`.ci/run` installs both).

use firmware_sim::{c_replay, qemu};
use fog_data::replay;

use crate::{at, one, sim, trainer};

/// The command-line path of an extension (static fit, `diagnose`, `fit --features`) and its blob on
/// the Cortex-M4F over a full simulated stream: a stateful input and a refitted GP run there as
/// they do on the host, bit for bit, at a cost QEMU measures.
#[test]
fn an_extended_model_from_the_command_line_runs_bit_for_bit_on_the_m4() {
    let dir = tempfile::tempdir().unwrap();
    let p = |name| at(dir.path(), name);
    let effect = ["--effect", "hysteresis", "--strength", "20"];
    sim(&[
        &["generate", "paper", "--seed", "5", "--out", &p("p.csv")][..],
        &effect,
    ]
    .concat())
    .unwrap();
    sim(&[
        &["generate", "stream", "--seed", "6", "--out", &p("s.csv")][..],
        &effect,
    ]
    .concat())
    .unwrap();
    trainer(&["fit", "--points", &p("p.csv"), "--out", &p("static.bin")]).unwrap();
    trainer(&[
        "diagnose",
        "--model",
        &p("static.bin"),
        "--stream",
        &p("s.csv"),
        "--json",
        &p("d.json"),
    ])
    .unwrap();
    assert_eq!(one(p("d.json"))["diagnosis"]["cause"], "hysteresis");
    trainer(&[
        "fit",
        "--points",
        &p("p.csv"),
        "--stream",
        &p("s.csv"),
        "--features",
        "thermal-state",
        // The scale term, in proportion to the output², then runs on the M4 too.
        "--scale-repeatability",
        "500",
        "--out",
        &p("ext.bin"),
        "--json",
        &p("ext.json"),
    ])
    .unwrap();
    let summary = one(p("ext.json"));
    let rmse = &summary["extension"]["train_rmse_60s_dps"];
    assert!(
        rmse[1].as_f64().unwrap() < rmse[0].as_f64().unwrap() / 3.0,
        "{rmse}"
    );
    assert!(
        summary["extension"]["point_offsets"]
            .as_array()
            .unwrap()
            .len()
            >= 8
    );

    let blob = std::fs::read(p("ext.bin")).unwrap();
    let firmware = fog_data::replay::decode(&blob).unwrap();
    assert!(firmware.error_model().scale_var > 0.0);
    assert!(
        firmware
            .features()
            .iter()
            .any(|f| matches!(f, firmware_core::Feature::ThermalState { .. }))
    );
    let data = fog_data::stream::Stream::load(std::path::Path::new(&p("s.csv")), &[]).unwrap();
    assert!(data.len() > 25_000, "a full stream: {} samples", data.len());
    let host = replay::replay(&firmware, &data);
    let image = qemu::build_image(&firmware_sim::source_tree::locate(None).unwrap()).unwrap();
    let m4 = qemu::run(&image, &blob, &[&data]).unwrap();
    let agreement = qemu::compare(&host, &m4.compensated[0]);
    assert_eq!(agreement.identical, data.len(), "{agreement:?}");
    assert!(agreement.statuses_equal);
    // The cost figures are measured, not invented: the calibration loop confirms QEMU's clock,
    // and the mean path of the 140-point model lies between its arithmetic minimum (one expf and
    // 3·d multiply-adds per centre) and twice that. Instruction counts under -icount are exact,
    // so this is not a timing test.
    assert!(
        (m4.cost.instructions_per_tick - 40.0).abs() < 0.5,
        "{:?}",
        m4.cost
    );
    let dims = firmware.dims();
    assert_eq!(dims.m, 140, "{dims:?}");
    let minimum = dims.m as f64 * m4.cost.minimum_per_centre(dims.d);
    assert!(m4.cost.exp_instructions > 20.0, "{:?}", m4.cost);
    assert!(
        m4.cost.mean_instructions > minimum && m4.cost.mean_instructions < 2.0 * minimum,
        "{:?} against a minimum of {minimum}",
        m4.cost
    );
    assert!(
        m4.cost.full_instructions > m4.cost.mean_instructions,
        "{:?}",
        m4.cost
    );
    // The C program too: its thermal state goes through the stream's power cycles as the host's.
    let c = c_replay::run(&c_replay::build().unwrap(), &blob, &[&data]).unwrap();
    let agreement = qemu::compare(&host, &c[0]);
    assert_eq!(agreement.identical, data.len(), "C: {agreement:?}");
    assert!(agreement.statuses_equal);
}
