//! Puts memory.x where the linker finds it, and writes the image's numbers capacity: the numbers
//! of every channel's model together that its unit storage holds, `FOG_M4_NUMBERS` where given
//! (to size the storage to one blob and measure its RAM, docs/firmware.md), else six models of
//! 256 centres, 4 inputs and 16 monomials each.
use std::path::PathBuf;

/// Six of the largest models the image holds: 7d + p + 2 + m·d + m + m(m + 1)/2 numbers each.
const DEFAULT_NUMBERS: usize = 6 * (7 * 4 + 16 + 2 + 256 * 4 + 256 + 256 * 257 / 2);

fn main() {
    let out = PathBuf::from(std::env::var_os("OUT_DIR").expect("cargo sets OUT_DIR"));
    std::fs::copy("memory.x", out.join("memory.x")).expect("memory.x is readable");
    println!("cargo:rustc-link-search={}", out.display());
    println!("cargo:rerun-if-changed=memory.x");
    let numbers = match std::env::var("FOG_M4_NUMBERS") {
        Ok(v) => v
            .trim()
            .parse::<usize>()
            .expect("FOG_M4_NUMBERS is a whole number"),
        Err(_) => DEFAULT_NUMBERS,
    };
    std::fs::write(
        out.join("capacity.rs"),
        format!("/// Numbers the unit storage holds (build.rs).\nconst N: usize = {numbers};\n"),
    )
    .expect("OUT_DIR is writable");
    println!("cargo:rerun-if-env-changed=FOG_M4_NUMBERS");
}
