//! firmware-core on a Cortex-M4F, run under QEMU (`mps2-an386`) by `firmware-sim qemu`.
//!
//! The host puts three files in QEMU's working directory and the image reaches them over
//! semihosting: `model.bin` (the blob), `samples.bin` (one `firmware_core::record` sample record
//! each: time, temperature, output and a power-on flag, where a gyro's firmware would boot with a
//! fresh feature state). The image decodes the model into fixed capacities, runs every sample
//! through the feature pipeline and the evaluator, and writes `out.bin` (one result record each:
//! mean, variance, status). Then it measures its own cost: SysTick ticks over
//! the first samples for an empty loop, the mean path and the mean + variance path; ticks for
//! [`EXP_CALLS`] calls of `libm::expf` (the one transcendental per centre) less their empty loop;
//! and ticks for a calibration loop of known length (`cortex_m::asm::delay(n)` executes exactly
//! `2(n + 1)` instructions: `subs` and `bne` per pass). All go to `cost.bin` as eight u32: samples,
//! empty, mean, mean + variance, expf calls, expf ticks, calibration instructions, calibration
//! ticks. Under `-icount shift=0` QEMU advances its clock by 1 ns per instruction and SysTick counts
//! the 25 MHz system clock, so one tick should be 40 instructions; the calibration loop measures it
//! rather than trusting that, and the host converts with the measured ratio.
//!
//! With the `embedded-model` feature the blob is compiled in instead (`FOG_M4_MODEL=path/model.bin`
//! at build time), which is how docs/firmware.md measures flash and RAM with a model.
//!
//! Exit code 0 on success; a failure prints its reason and exits with 1.
#![no_std]
#![no_main]

use core::hint::black_box;

use cortex_m::peripheral::{SYST, syst::SystClkSource};
use cortex_m_rt::entry;
use firmware_core::record::{self, RESULT_BYTES, SAMPLE_BYTES};
use firmware_core::{FeatureState, Model, Sample, Status, features};
use semihosting::io::{Read, Write};
use semihosting::{c, eprintln, fs, process};

/// Capacities: up to 4 inputs, 16 prior monomials and the trainer's export limit of centres.
const D: usize = 4;
const E: usize = 16 * D;
const M: usize = firmware_core::MAX_CENTRES;
const N: usize = 7 * D + 16 + 2 + M * D + M + M * (M + 1) / 2;
/// Largest blob the image reads: header, postcard lengths, and 5 bytes per number at most.
#[cfg(not(feature = "embedded-model"))]
const BLOB_MAX: usize = 64 + E + D + 5 * N;
/// Samples whose cost is measured.
const COST_SAMPLES: usize = 64;
/// `expf` calls timed.
const EXP_CALLS: usize = 256;
/// Passes of the calibration loop (2 instructions each).
const CALIBRATION_PASSES: u32 = 100_000;
/// Samples read and written per semihosting call.
const CHUNK: usize = 256;

type M4Model = Model<D, E, N>;

fn fail(what: &str) -> ! {
    eprintln!("fog-m4: {what}");
    process::exit(1)
}

fn read_full(file: &mut fs::File, buf: &mut [u8]) -> usize {
    let mut filled = 0;
    while filled < buf.len() {
        match file.read(&mut buf[filled..]) {
            Ok(0) => break,
            Ok(n) => filled += n,
            Err(_) => fail("read error"),
        }
    }
    filled
}

/// SysTick ticks elapsed while `work` runs (the counter counts down from its 24-bit reload).
fn ticks(syst: &mut SYST, work: impl FnOnce()) -> u32 {
    syst.clear_current();
    let start = SYST::get_current();
    work();
    let end = SYST::get_current();
    start.wrapping_sub(end) & 0x00FF_FFFF
}

/// Decodes the model read from `model.bin` over semihosting into `model`, through `blob`.
#[cfg(not(feature = "embedded-model"))]
fn load_model(model: &mut M4Model, blob: &mut [u8; BLOB_MAX]) {
    let mut model_file = fs::File::open(c!("model.bin")).unwrap_or_else(|_| fail("no model.bin"));
    let len = read_full(&mut model_file, blob);
    if model.decode_into(&blob[..len]).is_err() {
        fail("blob refused")
    }
}

/// Decodes the model flashed with the image, as an integrator would ship it: the blob named by
/// `FOG_M4_MODEL` at build time.
#[cfg(feature = "embedded-model")]
fn load_model(model: &mut M4Model) {
    static BLOB: &[u8] = include_bytes!(env!("FOG_M4_MODEL"));
    if model.decode_into(BLOB).is_err() {
        fail("blob refused")
    }
}

#[entry]
fn main() -> ! {
    // Static storage, decoded into in place: the stack never holds the model (cortex-m-rt hands
    // `static mut` items of the entry function over as `&'static mut`).
    static mut MODEL: M4Model = M4Model::new();
    #[cfg(not(feature = "embedded-model"))]
    static mut BLOB: [u8; BLOB_MAX] = [0; BLOB_MAX];
    let Some(peripherals) = cortex_m::Peripherals::take() else {
        fail("peripherals taken twice")
    };
    let mut syst = peripherals.SYST;
    syst.set_clock_source(SystClkSource::Core);
    syst.set_reload(0x00FF_FFFF);
    syst.enable_counter();

    #[cfg(not(feature = "embedded-model"))]
    load_model(MODEL, BLOB);
    #[cfg(feature = "embedded-model")]
    load_model(MODEL);
    let model: &M4Model = MODEL;
    let m = model.dims().m;
    let mut scratch = [0.0f32; 256];

    let mut input = fs::File::open(c!("samples.bin")).unwrap_or_else(|_| fail("no samples.bin"));
    let mut output = fs::File::create(c!("out.bin")).unwrap_or_else(|_| fail("cannot write"));
    let mut state = FeatureState::default();
    let mut inbuf = [0u8; CHUNK * SAMPLE_BYTES];
    let mut outbuf = [0u8; CHUNK * RESULT_BYTES];
    let mut first = [Sample {
        time_s: 0.0,
        temp_c: 0.0,
        output: 0.0,
    }; COST_SAMPLES];
    let mut seen = 0usize;
    loop {
        let got = read_full(&mut input, &mut inbuf) / SAMPLE_BYTES;
        if got == 0 {
            break;
        }
        let records = inbuf[..got * SAMPLE_BYTES].chunks_exact(SAMPLE_BYTES);
        let results = outbuf.chunks_exact_mut(RESULT_BYTES);
        for (i, (record, result)) in records.zip(results).enumerate() {
            let Ok(record) = record.try_into() else {
                fail("short sample record");
            };
            let (sample, power_on) = record::decode_sample(record);
            if power_on {
                state.power_on();
            }
            if let Some(slot) = first.get_mut(seen + i) {
                *slot = sample;
            }
            let (mean, var, status) = match model.compensate(&sample, &mut state, &mut scratch[..m])
            {
                Ok(p) => (p.mean, p.bias_variance, p.status),
                Err(_) => (0.0, f32::INFINITY, Status::Fault),
            };
            result.copy_from_slice(&record::encode_result(mean, var, status));
        }
        if output.write_all(&outbuf[..got * RESULT_BYTES]).is_err() {
            fail("write error");
        }
        seen += got;
    }

    // Cost of the evaluator alone: the inputs are computed beforehand.
    let k = seen.min(COST_SAMPLES);
    let d = model.dims().d;
    let mut xs = [[0.0f32; D]; COST_SAMPLES];
    for (x, s) in xs.iter_mut().zip(&first[..k]) {
        // Only the evaluator is timed: these samples' statuses were reported by the replay above.
        let _ = features::compute(model.features(), s, &mut FeatureState::default(), x);
    }
    let empty = ticks(&mut syst, || {
        for x in &xs[..k] {
            black_box(black_box(x).get(..d));
        }
    });
    let mean = ticks(&mut syst, || {
        for x in &xs[..k] {
            black_box(model.predict_mean(&black_box(x)[..d]));
        }
    });
    let full = ticks(&mut syst, || {
        for x in &xs[..k] {
            black_box(model.predict(&black_box(x)[..d], &mut scratch[..m]).ok());
        }
    });
    // Arguments as the kernel sees them: −r²/2 over the range the centres produce.
    let mut args = [0.0f32; EXP_CALLS];
    for (i, a) in args.iter_mut().enumerate() {
        *a = -0.05 * i as f32;
    }
    let exp_empty = ticks(&mut syst, || {
        for a in &args {
            black_box(black_box(*a));
        }
    });
    let exp = ticks(&mut syst, || {
        for a in &args {
            black_box(libm::expf(black_box(*a)));
        }
    });
    let calibration = ticks(&mut syst, || {
        cortex_m::asm::delay(black_box(CALIBRATION_PASSES - 1));
    });
    let mut cost = [0u8; 32];
    let words = [
        k as u32,
        empty,
        mean,
        full,
        EXP_CALLS as u32,
        exp.saturating_sub(exp_empty),
        2 * CALIBRATION_PASSES,
        calibration,
    ];
    for (i, v) in words.iter().enumerate() {
        cost[4 * i..4 * i + 4].copy_from_slice(&v.to_le_bytes());
    }
    if fs::write(c!("cost.bin"), cost).is_err() {
        fail("cannot write cost.bin");
    }
    process::exit(0)
}
