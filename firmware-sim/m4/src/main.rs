//! firmware-core on a Cortex-M4F, run under QEMU (`mps2-an386`) by `firmware-sim qemu`.
//!
//! The host puts two files in QEMU's working directory and the image reaches them over
//! semihosting: `model.bin` (a unit blob, or a model blob as a unit of one channel) and
//! `samples.bin` (one `firmware_core::record` unit sample record each: time, temperature, every
//! channel's output and a power-on flag, where a gyro's firmware would boot with its feature
//! state kept). The image decodes the blob into fixed capacities (up to 6 channels), runs every
//! sample through the unit (the shared features once, then every channel's mean and variance),
//! and writes `out.bin` (one result record per channel per sample: mean, variance, status). Then
//! it measures its own cost over the first samples: SysTick ticks of the evaluator alone (every
//! channel's mean, then mean + variance, at inputs computed beforehand) against an empty loop;
//! ticks of the whole per-sample call (`compensate_mean`, `compensate`: the features the channels
//! share and every channel) against its own empty loop; ticks for [`EXP_CALLS`] calls of
//! `libm::expf` (the one transcendental per centre) less their empty loop; and ticks for a
//! calibration loop of known length (`cortex_m::asm::delay(n)` executes exactly `2(n + 1)`
//! instructions: `subs` and `bne` per pass). All go to `cost.bin` as eleven u32: samples, empty,
//! mean, mean + variance, expf calls, expf ticks, calibration instructions, calibration ticks,
//! per-sample empty, per-sample mean, per-sample mean + variance. Under `-icount shift=0` (the
//! host's cost run, on the first samples only) QEMU advances its clock by 1 ns per instruction
//! and SysTick counts the 25 MHz system clock, so one tick should be 40 instructions; the
//! calibration loop measures it rather than trusting that, and the host converts with the
//! measured ratio.
//!
//! With the `embedded-model` feature the blob is compiled in instead (`FOG_M4_MODEL=path/model.bin`
//! at build time, and `FOG_M4_NUMBERS` the numbers it needs, `trainer inspect` says how many),
//! which is how docs/firmware.md measures flash and RAM with a model or a unit.
//!
//! Exit code 0 on success; a failure prints its reason and exits with 1.
#![no_std]
#![no_main]

use core::hint::black_box;

use cortex_m::peripheral::{SYST, syst::SystClkSource};
use cortex_m_rt::entry;
use firmware_core::record::{self, RESULT_BYTES};
use firmware_core::{FeatureState, Prediction, Sample, StaticUnit, Status, UnitSample, features};
use semihosting::io::{Read, Write};
use semihosting::{c, eprintln, fs, process};

/// Capacities: up to 6 channels of up to 4 inputs, 16 prior monomials and the trainer's export
/// limit of centres each; `N` numbers of them all together (build.rs: six of the largest models,
/// or `FOG_M4_NUMBERS`).
const C: usize = 6;
const D: usize = 4;
const E: usize = 16 * D;
const M: usize = firmware_core::MAX_CENTRES;
include!(concat!(env!("OUT_DIR"), "/capacity.rs"));
/// Largest blob the image reads: headers, names and postcard lengths, and 5 bytes per number at
/// most.
#[cfg(not(feature = "embedded-model"))]
const BLOB_MAX: usize = 128 + C * (64 + E + D) + 5 * N;
/// Samples whose cost is measured.
const COST_SAMPLES: usize = 64;
/// `expf` calls timed.
const EXP_CALLS: usize = 256;
/// Passes of the calibration loop (2 instructions each).
const CALIBRATION_PASSES: u32 = 100_000;
/// Samples read and written per semihosting call.
const CHUNK: usize = 128;
/// Bytes of the largest sample record.
const SAMPLE_MAX: usize = record::unit_sample_bytes(C);

type M4Unit = StaticUnit<C, D, E, N>;

/// A sample kept for the cost measurement: time, temperature, outputs.
#[derive(Clone, Copy)]
struct Kept {
    time_s: f64,
    temp_c: f32,
    outputs: [f32; C],
}

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

/// Decodes the blob read from `model.bin` over semihosting into `unit`, through `blob`.
#[cfg(not(feature = "embedded-model"))]
fn load_model(unit: &mut M4Unit, blob: &mut [u8; BLOB_MAX]) {
    let mut model_file = fs::File::open(c!("model.bin")).unwrap_or_else(|_| fail("no model.bin"));
    let len = read_full(&mut model_file, blob);
    if unit.decode_into(&blob[..len]).is_err() {
        fail("blob refused")
    }
}

/// Decodes the blob flashed with the image, as an integrator would ship it: the one named by
/// `FOG_M4_MODEL` at build time.
#[cfg(feature = "embedded-model")]
fn load_model(unit: &mut M4Unit) {
    static BLOB: &[u8] = include_bytes!(env!("FOG_M4_MODEL"));
    if unit.decode_into(BLOB).is_err() {
        fail("blob refused")
    }
}

#[entry]
fn main() -> ! {
    // Static storage, decoded into in place: the stack never holds the unit (cortex-m-rt hands
    // `static mut` items of the entry function over as `&'static mut`).
    static mut UNIT: M4Unit = M4Unit::new();
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
    load_model(UNIT, BLOB);
    #[cfg(feature = "embedded-model")]
    load_model(UNIT);
    let unit: &M4Unit = UNIT;
    let c = unit.channels().len();
    let sample_bytes = record::unit_sample_bytes(c);
    let mut scratch = [0.0f32; M];
    let Some(scratch) = scratch.get_mut(..unit.scratch_len()) else {
        fail("a channel has more centres than the image's scratch")
    };

    let mut input = fs::File::open(c!("samples.bin")).unwrap_or_else(|_| fail("no samples.bin"));
    let mut output = fs::File::create(c!("out.bin")).unwrap_or_else(|_| fail("cannot write"));
    let mut state = FeatureState::default();
    let mut inbuf = [0u8; CHUNK * SAMPLE_MAX];
    let mut outbuf = [0u8; CHUNK * C * RESULT_BYTES];
    let none = Prediction {
        mean: 0.0,
        bias_variance: f32::INFINITY,
        noise_variance: 0.0,
        status: Status::Fault,
    };
    let mut predictions = [none; C];
    let mut first = [Kept {
        time_s: 0.0,
        temp_c: 0.0,
        outputs: [0.0; C],
    }; COST_SAMPLES];
    let mut seen = 0usize;
    loop {
        let got = read_full(&mut input, &mut inbuf[..CHUNK * sample_bytes]) / sample_bytes;
        if got == 0 {
            break;
        }
        let records = inbuf[..got * sample_bytes].chunks_exact(sample_bytes);
        let results = outbuf.chunks_exact_mut(c * RESULT_BYTES);
        for (i, (rec, result)) in records.zip(results).enumerate() {
            let mut outputs = [0.0f32; C];
            let Some((time_s, temp_c, power_on)) =
                record::decode_unit_sample(rec, &mut outputs[..c])
            else {
                fail("short sample record");
            };
            if power_on {
                state.power_on();
            }
            if let Some(slot) = first.get_mut(seen + i) {
                *slot = Kept {
                    time_s,
                    temp_c,
                    outputs,
                };
            }
            let sample = UnitSample {
                time_s,
                temp_c,
                outputs: &outputs[..c],
            };
            if unit
                .compensate(&sample, &mut state, scratch, &mut predictions)
                .is_err()
            {
                predictions = [none; C];
            }
            for (p, r) in predictions
                .iter()
                .zip(result.chunks_exact_mut(RESULT_BYTES))
            {
                r.copy_from_slice(&record::encode_result(p.mean, p.bias_variance, p.status));
            }
        }
        if output.write_all(&outbuf[..got * c * RESULT_BYTES]).is_err() {
            fail("write error");
        }
        seen += got;
    }

    // Cost of the evaluator alone, every channel's: its inputs computed beforehand, each
    // channel's own features through a fresh state of its own.
    let k = seen.min(COST_SAMPLES);
    let samples = &first[..k];
    let mut xs = [[[0.0f32; D]; C]; COST_SAMPLES];
    for (x, s) in xs.iter_mut().zip(samples) {
        for (j, ch) in unit.channels().iter().enumerate() {
            let own = Sample {
                time_s: s.time_s,
                temp_c: s.temp_c,
                output: s.outputs[j],
            };
            // Only the evaluator is timed: these samples' statuses were reported by the replay.
            let _ = features::compute(ch.features(), &own, &mut FeatureState::default(), &mut x[j]);
        }
    }
    let dims: [usize; C] =
        core::array::from_fn(|j| unit.channels().get(j).map_or(0, |c| c.dims().d));
    let empty = ticks(&mut syst, || {
        for x in &xs[..k] {
            for (j, d) in dims.iter().enumerate().take(c) {
                black_box(black_box(x)[j].get(..*d));
            }
        }
    });
    let mean = ticks(&mut syst, || {
        for x in &xs[..k] {
            for (j, d) in dims.iter().enumerate().take(c) {
                black_box(unit.predict_mean(j, &black_box(x)[j][..*d]));
            }
        }
    });
    let full = ticks(&mut syst, || {
        for x in &xs[..k] {
            for (j, d) in dims.iter().enumerate().take(c) {
                black_box(unit.predict_at(j, &black_box(x)[j][..*d], 0.0, scratch));
            }
        }
    });
    // Cost per sample, every channel and the features they share: the first samples again, through
    // a fresh state.
    let sample_empty = ticks(&mut syst, || {
        for s in samples {
            black_box(black_box(s).outputs.get(..c));
        }
    });
    let mut means = [(
        firmware_core::Mean {
            mean: 0.0,
            status: Status::Fault,
        },
        0.0f32,
    ); C];
    let mut cost_state = FeatureState::default();
    let sample_mean = ticks(&mut syst, || {
        for s in samples {
            let s = black_box(s);
            let sample = UnitSample {
                time_s: s.time_s,
                temp_c: s.temp_c,
                outputs: &s.outputs[..c],
            };
            black_box(
                unit.compensate_mean(&sample, &mut cost_state, &mut means)
                    .ok(),
            );
        }
    });
    let mut cost_state = FeatureState::default();
    let sample_full = ticks(&mut syst, || {
        for s in samples {
            let s = black_box(s);
            let sample = UnitSample {
                time_s: s.time_s,
                temp_c: s.temp_c,
                outputs: &s.outputs[..c],
            };
            black_box(
                unit.compensate(&sample, &mut cost_state, scratch, &mut predictions)
                    .ok(),
            );
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
    let mut cost = [0u8; 44];
    let words = [
        k as u32,
        empty,
        mean,
        full,
        EXP_CALLS as u32,
        exp.saturating_sub(exp_empty),
        2 * CALIBRATION_PASSES,
        calibration,
        sample_empty,
        sample_mean,
        sample_full,
    ];
    for (i, v) in words.iter().enumerate() {
        cost[4 * i..4 * i + 4].copy_from_slice(&v.to_le_bytes());
    }
    if fs::write(c!("cost.bin"), cost).is_err() {
        fail("cannot write cost.bin");
    }
    process::exit(0)
}
