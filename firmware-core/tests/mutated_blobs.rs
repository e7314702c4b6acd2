//! Blob robustness on stable, in CI: a real blob mutated every way a flash, a file transfer or a
//! hand edit can damage it. Every case is refused with a typed error or decodes to a model whose
//! every prediction is finite (`support/exercise.rs`). The longer run is the fuzz target in
//! `firmware-core/fuzz` (docs/reliability.md).

// Test code: the firmware's no-panic lints guard data paths; here a failed check is the point.
#![allow(
    clippy::indexing_slicing,
    clippy::expect_used,
    clippy::panic,
    clippy::unwrap_used
)]

#[path = "support/exercise.rs"]
mod exercise;

use std::collections::BTreeMap;

use exercise::{Roomy, exercise, reseal};
use firmware_core::blob::{HEADER_LEN, Limits};
use firmware_core::model::Conditions;
use firmware_core::{ErrorModel, Evaluation, Prepared};
use rand::{Rng, RngExt, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// The sparse model of docs/firmware.md's integration example (24 centres, 2 inputs).
const BLOB: &[u8] = include_bytes!("../doc/gyro.bin");
/// Mutated blobs per run.
const CASES: usize = 500_000;

/// Bits of f32 that stress the evaluator: not numbers, overflow, underflow, sign, zero.
const NASTY: [f32; 10] = [
    f32::NAN,
    f32::INFINITY,
    f32::NEG_INFINITY,
    f32::MAX,
    -f32::MAX,
    f32::MIN_POSITIVE,
    1e-45,
    -1.0,
    0.0,
    1e30,
];

/// One mutation of `good`, named for the tally.
fn mutate(good: &[u8], rng: &mut impl Rng) -> (&'static str, Vec<u8>) {
    let mut b = good.to_vec();
    // Where each f32 lives: the flat array's 395, then, after the rule beyond the range (one
    // byte), the error model's and the limits', which end the blob.
    let tail = ErrorModel::NUMBERS + Limits::NUMBERS;
    let floats_at = good.len() - 4 * tail - 1 - 4 * 395;
    let float_at = |i: usize| {
        if i < 395 {
            floats_at + 4 * i
        } else {
            good.len() - 4 * (tail + 395 - i)
        }
    };
    let kind = match rng.random_range(0..8) {
        0 => flip_bits(&mut b, rng),
        1 => {
            b.truncate(rng.random_range(0..good.len()));
            "truncation"
        }
        2 => {
            let extra = rng.random_range(1..64);
            b.extend((0..extra).map(|_| rng.random::<u8>()));
            if rng.random() {
                reseal(&mut b);
            }
            "extension"
        }
        3 => {
            let lie: u32 = if rng.random() {
                rng.random()
            } else {
                (good.len() - HEADER_LEN) as u32 ^ (1 << rng.random_range(0..32))
            };
            b[14..18].copy_from_slice(&lie.to_le_bytes());
            "lying length"
        }
        4 => {
            let field = rng.random_range(6..10);
            b[field] = rng.random();
            "header dimensions"
        }
        5 => scramble_payload(&mut b, 18, rng),
        6 => {
            for _ in 0..rng.random_range(1..=3) {
                let at = float_at(rng.random_range(0..395 + tail));
                let v = NASTY[rng.random_range(0..NASTY.len())];
                b[at..at + 4].copy_from_slice(&v.to_le_bytes());
            }
            reseal(&mut b);
            "NaN/Inf/extreme floats, CRC fixed"
        }
        _ => {
            // Finite but wild numbers everywhere a float lives: scales, weights, the factor, the
            // error model and the limits.
            for i in 0..395 + tail {
                if rng.random_bool(0.1) {
                    let v = f32::from_bits(rng.random::<u32>() & 0x7F7F_FFFF)
                        * if rng.random() { 1.0 } else { -1.0 };
                    let at = float_at(i);
                    b[at..at + 4].copy_from_slice(&v.to_le_bytes());
                }
            }
            reseal(&mut b);
            "wild finite floats, CRC fixed"
        }
    };
    (kind, b)
}

/// One to eight random bits flipped anywhere, the CRC left as it was.
fn flip_bits(b: &mut [u8], rng: &mut impl Rng) -> &'static str {
    for _ in 0..rng.random_range(1..=8) {
        let i = rng.random_range(0..b.len());
        b[i] ^= 1 << rng.random_range(0..8);
    }
    "bit flips"
}

/// One to four random bytes of the payload (from byte `from`) replaced, the CRC fixed: what
/// only the decoder's own checks can catch.
fn scramble_payload(b: &mut [u8], from: usize, rng: &mut impl Rng) -> &'static str {
    for _ in 0..rng.random_range(1..=4) {
        let i = rng.random_range(from..b.len());
        b[i] = rng.random();
    }
    reseal(b);
    "payload bytes, CRC fixed"
}

#[test]
fn mutated_blobs_are_refused_or_predict_finite_numbers() {
    let good = Roomy::decode(BLOB).expect("the example blob decodes");
    assert_eq!(good.dims().floats(), 395);
    exercise(&good);
    let mut rng = ChaCha8Rng::seed_from_u64(9);
    let mut tally: BTreeMap<(&str, String), usize> = BTreeMap::new();
    let mut predictions = 0;
    // The mutations are drawn in order, a chunk at a time, and each chunk is checked on two
    // threads: the same cases as one after the other, on both cores.
    for start in (0..CASES).step_by(CHUNK) {
        let chunk: Vec<_> = (start..CASES.min(start + CHUNK))
            .map(|_| mutate(BLOB, &mut rng))
            .collect();
        let (a, b) = chunk.split_at(chunk.len() / 2);
        let checked = std::thread::scope(|s| {
            let other = s.spawn(|| check_cases(a));
            [
                check_cases(b),
                other.join().expect("the other half's checks"),
            ]
        });
        for (counts, n) in checked {
            predictions += n;
            for (key, count) in counts {
                *tally.entry(key).or_default() += count;
            }
        }
    }
    eprintln!("{CASES} mutated blobs, {predictions} predictions checked");
    check_tally(
        &tally,
        CASES,
        &[
            "CrcMismatch",
            "Truncated",
            "TrailingBytes",
            "Malformed",
            "NonFinite",
        ],
    );
}

/// Mutated blobs drawn at a time ([`mutated_blobs_are_refused_or_predict_finite_numbers`]).
const CHUNK: usize = 10_000;

/// Tally of outcomes by mutation, and predictions checked.
type Checked = (BTreeMap<(&'static str, String), usize>, usize);

/// Decodes each mutated blob, checks what it predicts where it decodes, and tallies the
/// outcomes.
fn check_cases(cases: &[(&'static str, Vec<u8>)]) -> Checked {
    let (mut tally, mut predictions) = (BTreeMap::new(), 0);
    // One storage decoded into again and again, as the firmware's `static`: a refused blob
    // leaves it holding no model, whatever it held before.
    let mut storage = Roomy::new();
    for (kind, blob) in cases {
        storage.decode_into(BLOB).expect("the example blob decodes");
        let decoded = storage.decode_into(blob);
        // The check an update runs before writing agrees with the decode, error for error.
        assert_eq!(Roomy::check(blob).map(|_| ()), decoded.clone(), "{kind}");
        if decoded.is_err() {
            assert_eq!(storage.dims().m, 0, "{kind}");
            assert_eq!(
                storage.predict_mean(&[25.0, 0.4]).status,
                firmware_core::Status::Fault
            );
        }
        let outcome = match Roomy::decode(blob) {
            Ok(model) => {
                predictions += exercise(&model);
                "decoded".to_owned()
            }
            Err(e) => error_name(&e),
        };
        *tally.entry((*kind, outcome)).or_default() += 1;
    }
    (tally, predictions)
}

/// The error's name alone (`CrcMismatch`, not its fields), to tally outcomes by.
fn error_name(e: &impl std::fmt::Debug) -> String {
    format!("{e:?}")
        .split(['(', ' '])
        .next()
        .unwrap_or("")
        .to_owned()
}

/// Prints the outcomes of `cases` mutations by kind and checks they reached the evaluator (more
/// than one in twenty decoded, not only refused by the integrity checks) and produced each of
/// `errors`.
fn check_tally(tally: &BTreeMap<(&str, String), usize>, cases: usize, errors: &[&str]) {
    for ((kind, outcome), n) in tally {
        eprintln!("{kind:<36} {outcome:<24} {n:>7}");
    }
    let decoded: usize = tally
        .iter()
        .filter(|((_, o), _)| o == "decoded")
        .map(|(_, n)| n)
        .sum();
    assert!(decoded > cases / 20, "only {decoded} decoded");
    for error in errors {
        assert!(
            tally.keys().any(|(_, o)| o == error),
            "no mutation produced {error}"
        );
    }
}

/// The MEMS IMU's six-channel unit blob (docs/firmware.md, "A whole unit in one blob").
const UNIT: &[u8] = include_bytes!("../doc/imu.bin");
/// Mutated unit blobs per run: each is 15 times the model blob's size.
const UNIT_CASES: usize = 20_000;

/// Unit storage roomy enough that a mutated blob is refused for what it holds, not its size.
type RoomyUnit = firmware_core::StaticUnit<8, 8, 1320, 16_384>;

/// One mutation of a unit blob: the kinds of [`mutate`] that do not depend on a model's layout.
fn mutate_unit(good: &[u8], rng: &mut impl Rng) -> (&'static str, Vec<u8>) {
    let mut b = good.to_vec();
    let kind = match rng.random_range(0..6) {
        0 => flip_bits(&mut b, rng),
        1 => {
            b.truncate(rng.random_range(0..good.len()));
            reseal(&mut b);
            "truncation, resealed"
        }
        2 => {
            b[rng.random_range(6..10)] = rng.random();
            reseal(&mut b);
            "header sizes, resealed"
        }
        3 => scramble_payload(&mut b, 22, rng),
        4 => {
            // A float of some channel's model, somewhere in the second half of the payload.
            let i = rng.random_range(b.len() / 2..b.len() - 4);
            let v = NASTY[rng.random_range(0..NASTY.len())];
            b[i..i + 4].copy_from_slice(&v.to_le_bytes());
            reseal(&mut b);
            "NaN/Inf/extreme floats, CRC fixed"
        }
        _ => {
            let extra = rng.random_range(1..64);
            b.extend((0..extra).map(|_| rng.random::<u8>()));
            reseal(&mut b);
            "extension, resealed"
        }
    };
    (kind, b)
}

/// Every channel of a decoded unit, along a short sample stream of probe values: finite means,
/// finite non-negative variances. Returns the predictions checked.
fn exercise_unit(unit: &RoomyUnit) -> usize {
    let c = unit.channels().len();
    let mut scratch = vec![0.0f32; unit.scratch_len()];
    let mut out = vec![
        firmware_core::Prediction {
            mean: 0.0,
            bias_variance: 0.0,
            noise_variance: 0.0,
            status: firmware_core::Status::Fault,
        };
        c
    ];
    let (mut state, mut twin) = Default::default();
    // Each channel's samples side by side, as a host replays them (`Unit::evaluate`).
    let none = Prepared::inputs(&[], Conditions::at_hours(0.0));
    let (mut one, mut prepared) = (vec![none; c], vec![Vec::new(); c]);
    let mut expected = vec![Vec::new(); c];
    for (k, &t) in NASTY.iter().chain(&[-10.0, 20.0, 40.0]).enumerate() {
        let outputs: Vec<f32> = (0..c).map(|j| NASTY[(k + j) % NASTY.len()]).collect();
        let sample = firmware_core::UnitSample {
            time_s: k as f64 * 1.5,
            temp_c: t,
            outputs: &outputs,
        };
        unit.compensate(&sample, &mut state, &mut scratch, &mut out)
            .expect("buffers sized to the unit");
        unit.prepare(&sample, &mut twin, &mut one)
            .expect("buffers sized to the unit");
        for (j, p) in out.iter().enumerate() {
            assert!(p.mean.is_finite(), "{p:?} at {t}");
            assert!(p.variance().is_finite() && p.variance() >= 0.0, "{p:?}");
            prepared[j].push(one[j]);
            expected[j].push(*p);
        }
    }
    let mut lanes = vec![0.0f32; unit.evaluate_scratch_len()];
    for (j, (prepared, expected)) in prepared.iter().zip(&expected).enumerate() {
        let mut evaluations = vec![Evaluation::NONE; prepared.len()];
        unit.evaluate(j, prepared, &mut lanes, &mut evaluations)
            .expect("a channel of the unit")
            .expect("the scratch is sized for it");
        for (e, p) in evaluations.iter().zip(expected) {
            assert_eq!(
                e.prediction.mean.to_bits(),
                p.mean.to_bits(),
                "{e:?} vs {p:?}"
            );
            assert_eq!(
                e.prediction.bias_variance.to_bits(),
                p.bias_variance.to_bits(),
                "{e:?} vs {p:?}"
            );
            assert_eq!(
                e.prediction.noise_variance.to_bits(),
                p.noise_variance.to_bits(),
                "{e:?} vs {p:?}"
            );
            assert_eq!(e.prediction.status, p.status, "{e:?} vs {p:?}");
        }
    }
    (NASTY.len() + 3) * c
}

#[test]
fn mutated_unit_blobs_are_refused_or_predict_finite_numbers_on_every_channel() {
    let mut storage = Box::new(RoomyUnit::new());
    storage.decode_into(UNIT).expect("the unit blob decodes");
    assert_eq!(storage.channels().len(), 6);
    exercise_unit(&storage);
    let mut rng = ChaCha8Rng::seed_from_u64(10);
    let mut tally: BTreeMap<(&str, String), usize> = BTreeMap::new();
    let mut predictions = 0;
    for _ in 0..UNIT_CASES {
        let (kind, blob) = mutate_unit(UNIT, &mut rng);
        storage.decode_into(UNIT).expect("the unit blob decodes");
        let decoded = storage.decode_into(&blob);
        assert_eq!(RoomyUnit::check(&blob).map(|_| ()), decoded, "{kind}");
        let outcome = match decoded {
            Ok(()) => {
                predictions += exercise_unit(&storage);
                "decoded".to_owned()
            }
            Err(e) => {
                assert!(
                    storage.channels().is_empty(),
                    "{kind}: a refused blob left channels"
                );
                error_name(&e)
            }
        };
        *tally.entry((kind, outcome)).or_default() += 1;
    }
    eprintln!("{UNIT_CASES} mutated unit blobs, {predictions} predictions checked");
    check_tally(
        &tally,
        UNIT_CASES,
        &[
            "CrcMismatch",
            "Malformed",
            "InconsistentDimensions",
            "NonFinite",
        ],
    );
}
