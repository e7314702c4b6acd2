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
    let floats_at = good.len() - 4 * 395;
    let kind = match rng.random_range(0..8) {
        0 => {
            for _ in 0..rng.random_range(1..=8) {
                let i = rng.random_range(0..b.len());
                b[i] ^= 1 << rng.random_range(0..8);
            }
            "bit flips"
        }
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
                (good.len() - 18) as u32 ^ (1 << rng.random_range(0..32))
            };
            b[10..14].copy_from_slice(&lie.to_le_bytes());
            "lying length"
        }
        4 => {
            let field = rng.random_range(6..10);
            b[field] = rng.random();
            "header dimensions"
        }
        5 => {
            for _ in 0..rng.random_range(1..=4) {
                let i = rng.random_range(18..b.len());
                b[i] = rng.random();
            }
            reseal(&mut b);
            "payload bytes, CRC fixed"
        }
        6 => {
            for _ in 0..rng.random_range(1..=3) {
                let i = rng.random_range(0..395);
                let v = NASTY[rng.random_range(0..NASTY.len())];
                b[floats_at + 4 * i..floats_at + 4 * i + 4].copy_from_slice(&v.to_le_bytes());
            }
            reseal(&mut b);
            "NaN/Inf/extreme floats, CRC fixed"
        }
        _ => {
            // Finite but wild numbers everywhere a float lives: scales, weights, the factor.
            for i in 0..395 {
                if rng.random_bool(0.1) {
                    let v = f32::from_bits(rng.random::<u32>() & 0x7F7F_FFFF)
                        * if rng.random() { 1.0 } else { -1.0 };
                    b[floats_at + 4 * i..floats_at + 4 * i + 4].copy_from_slice(&v.to_le_bytes());
                }
            }
            reseal(&mut b);
            "wild finite floats, CRC fixed"
        }
    };
    (kind, b)
}

#[test]
fn mutated_blobs_are_refused_or_predict_finite_numbers() {
    let good = Roomy::decode(BLOB).expect("the example blob decodes");
    assert_eq!(good.dims().floats(), 395);
    exercise(&good);
    let mut rng = ChaCha8Rng::seed_from_u64(9);
    let mut tally: BTreeMap<(&str, String), usize> = BTreeMap::new();
    let mut predictions = 0;
    // One storage decoded into again and again, as the firmware's `static`: a refused blob
    // leaves it holding no model, whatever it held before.
    let mut storage = Roomy::new();
    for _ in 0..CASES {
        let (kind, blob) = mutate(BLOB, &mut rng);
        storage.decode_into(BLOB).expect("the example blob decodes");
        let decoded = storage.decode_into(&blob);
        // The check an update runs before writing agrees with the decode, error for error.
        assert_eq!(Roomy::check(&blob).map(|_| ()), decoded.clone(), "{kind}");
        if decoded.is_err() {
            assert_eq!(storage.dims().m, 0, "{kind}");
            assert_eq!(
                storage.predict_mean(&[25.0, 0.4]).status,
                firmware_core::Status::Fault
            );
        }
        let outcome = match Roomy::decode(&blob) {
            Ok(model) => {
                predictions += exercise(&model);
                "decoded".to_owned()
            }
            Err(e) => format!("{e:?}")
                .split(['(', ' '])
                .next()
                .unwrap_or("")
                .to_owned(),
        };
        *tally.entry((kind, outcome)).or_default() += 1;
    }
    for ((kind, outcome), n) in &tally {
        eprintln!("{kind:<36} {outcome:<24} {n:>7}");
    }
    eprintln!("{CASES} mutated blobs, {predictions} predictions checked");
    let decoded: usize = tally
        .iter()
        .filter(|((_, o), _)| o == "decoded")
        .map(|(_, n)| n)
        .sum();
    // The mutations must reach the evaluator, not only the integrity checks.
    assert!(decoded > CASES / 20, "only {decoded} decoded");
    for error in [
        "CrcMismatch",
        "Truncated",
        "TrailingBytes",
        "Malformed",
        "NonFinite",
    ] {
        assert!(
            tally.keys().any(|(_, o)| o == error),
            "no mutation produced {error}"
        );
    }
}
