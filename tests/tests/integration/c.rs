//! Firmware in C (issue 22): `firmware-core/ffi/include/fog_replay.c`, built against the `fog-ffi`
//! static library with the host C compiler and with `arm-none-eabi-gcc` for the Cortex-M4F (run
//! under QEMU), replays a whole simulated stream bit for bit as the host replay does, through the
//! same blob. Needs `cc`, `arm-none-eabi-gcc` with newlib and `qemu-system-arm` (`.ci/run`
//! installs them).

use firmware_sim::{c_replay, qemu};
use fog_data::replay;
use fog_data::stream::Stream;

use crate::{at, sim};

#[test]
fn a_c_program_replays_a_stream_bit_for_bit_like_the_host_on_the_host_and_the_m4() {
    let dir = tempfile::tempdir().unwrap();
    sim(&[
        "generate",
        "stream",
        "--seed",
        "5",
        "--out",
        &at(dir.path(), "s.csv"),
    ])
    .unwrap();
    let stream = Stream::load(&dir.path().join("s.csv"), &[]).unwrap();
    // The firmware-integration example's model (24 centres), and the stream's power cycles.
    let blob = include_bytes!("../../../firmware-core/doc/gyro.bin");
    let host = replay::replay(&replay::decode(blob).unwrap(), &stream);
    let exe = c_replay::build().unwrap();
    let c = c_replay::run(&exe, blob, &[&stream]).unwrap();
    let agreement = qemu::compare(&host, &c[0]);
    assert_eq!(agreement.identical, stream.len(), "{agreement:?}");
    assert!(agreement.statuses_equal);
    assert!(replay::restarts(&stream).iter().filter(|&&r| r).count() >= 3);

    // The same C source on the Cortex-M4F, under QEMU.
    let elf = c_replay::build_m4().unwrap();
    let m4 = c_replay::run_m4(&elf, blob, &[&stream]).unwrap();
    let agreement = qemu::compare(&host, &m4.compensated[0]);
    assert_eq!(agreement.identical, stream.len(), "M4: {agreement:?}");
    assert!(agreement.statuses_equal);
    eprintln!("C replay on the M4: {} bytes of stack", m4.stack_bytes);
    // Decoding works in the caller's static storage: the stack holds no copy of the model
    // (137 KB at these capacities), only the frames of the library, newlib's stdio and main.
    assert!(m4.stack_bytes < 8192, "{} bytes of stack", m4.stack_bytes);

    // A corrupted blob is refused by the C program with the code of the Rust error.
    let mut bad = blob.to_vec();
    bad[200] ^= 4;
    let err = c_replay::run(&exe, &bad, &[&stream])
        .unwrap_err()
        .to_string();
    assert!(err.contains("model refused (FogResult 6)"), "{err}");
}

/// Issue 46: the interface's promises checked from C (`firmware-core/ffi/tests/c/fog_selftest.c`)
/// on the host and on the Cortex-M4F under QEMU, built with short enums and without: the ABI
/// check, no stale model after a failed decode, wrong slot layouts refused before anything is
/// touched, a flash driver that fails any operation once and then loses power (at every byte on
/// the host, every 7th on the M4) always booting the old model or the new one, and a clock that
/// went back flagged.
#[test]
fn the_c_interface_keeps_its_promises_when_the_flash_driver_and_the_caller_misbehave() {
    let blob = concat!(env!("CARGO_MANIFEST_DIR"), "/../firmware-core/doc/gyro.bin");
    for flags in [&["-fshort-enums"][..], &["-fno-short-enums"]] {
        let program = c_replay::Program {
            source: "tests/c/fog_selftest.c",
            name: if flags[0] == "-fshort-enums" {
                "fog_selftest_short"
            } else {
                "fog_selftest"
            },
            flags,
        };
        let exe = c_replay::build_program(program).unwrap();
        let out = c_replay::run_program(&exe, false, &[blob, "1"]).unwrap();
        assert!(out.contains(", 0 failed"), "{flags:?}: {out}");
        let checks: u64 = out
            .split_whitespace()
            .nth(1)
            .and_then(|n| n.parse().ok())
            .unwrap_or(0);
        assert!(checks > 100_000, "{out}");
        let elf = c_replay::build_program_m4(program).unwrap();
        let out = c_replay::run_program(&elf, true, &[blob, "7"]).unwrap();
        assert!(out.contains(", 0 failed"), "M4 {flags:?}: {out}");
    }
}
