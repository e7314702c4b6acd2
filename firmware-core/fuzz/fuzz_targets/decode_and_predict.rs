//! Any bytes as a blob: refused with a typed error, or decoded to a model whose every prediction
//! is finite (`tests/support/exercise.rs`, shared with the stable mutated-blob test). The first
//! byte's low bit reseals the length and CRC, so that mutations reach the decoder behind the
//! integrity check as often as they test it.
#![no_main]

#[path = "../../tests/support/exercise.rs"]
mod exercise;

use libfuzzer_sys::fuzz_target;

fuzz_target!(|data: &[u8]| {
    let Some((&mode, bytes)) = data.split_first() else {
        return;
    };
    let mut blob = bytes.to_vec();
    if mode & 1 == 1 {
        exercise::reseal(&mut blob);
    }
    if let Ok(model) = exercise::Roomy::decode(&blob) {
        exercise::exercise(&model);
    }
});
