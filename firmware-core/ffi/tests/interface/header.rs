//! The committed header is what cbindgen makes of the crate now: CI fails when it is stale.

use std::path::Path;

#[test]
fn header_is_current() {
    let dir = Path::new(env!("CARGO_MANIFEST_DIR"));
    let mut generated = Vec::new();
    cbindgen::generate(dir)
        .expect("cbindgen reads the crate")
        .write(&mut generated);
    let path = dir.join("include/fog.h");
    if std::env::var_os("FOG_BLESS").is_some() {
        std::fs::write(&path, &generated).expect("header written");
    }
    let committed = std::fs::read(&path).unwrap_or_default();
    assert!(
        committed == generated,
        "include/fog.h is stale: FOG_BLESS=1 cargo test -p fog-ffi --test header"
    );
}
