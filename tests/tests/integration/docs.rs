//! docs/commands.md's generated parts (every command's flags, the JSON contracts) are what the
//! code says now: `FOG_BLESS=1` rewrites them after a change.

use clap::CommandFactory;
use fog_terminal::reference;

#[test]
fn the_command_reference_is_the_code_s_own() {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../docs/commands.md");
    let page = std::fs::read_to_string(&path).unwrap();
    let mut fresh = page.clone();
    for (name, body) in [
        (
            "trainer",
            reference::commands(&trainer::cli::Cli::command()),
        ),
        (
            "firmware-sim",
            reference::commands(&firmware_sim::cli::Cli::command()),
        ),
        ("schemas", reference::schemas()),
    ] {
        fresh = reference::replace_generated(&fresh, name, &body)
            .unwrap_or_else(|| panic!("docs/commands.md has no generated part `{name}`"));
    }
    if std::env::var_os("FOG_BLESS").is_some() {
        std::fs::write(&path, &fresh).unwrap();
        return;
    }
    assert!(
        fresh == page,
        "docs/commands.md is stale: FOG_BLESS=1 cargo test -p integration-tests --test integration \
         -- docs"
    );
}
