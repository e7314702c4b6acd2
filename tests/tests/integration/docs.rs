//! docs/commands.md's and docs/json.md's generated parts (every command's flags, the JSON
//! contracts and their fields) are what the code says now: `FOG_BLESS=1` rewrites them after a
//! change.

use clap::CommandFactory;
use fog_terminal::reference;

#[test]
fn the_command_reference_is_the_code_s_own() {
    let mut contracts = trainer::cli::contracts();
    contracts.extend(firmware_sim::cli::contracts());
    let order = |c: &fog_terminal::schema::Contract| {
        fog_terminal::schema::ALL
            .iter()
            .position(|s| *s == c.schema)
            .unwrap_or_else(|| panic!("{} is not in schema::ALL", c.schema.name))
    };
    contracts.sort_by_key(order);
    let written: Vec<_> = contracts.iter().map(|c| c.schema).collect();
    assert_eq!(
        written,
        fog_terminal::schema::ALL,
        "every contract has the type it is written from, once"
    );
    let pages: [(&str, Vec<(&str, String)>); 2] = [
        (
            "commands.md",
            vec![
                (
                    "trainer",
                    reference::commands(&trainer::cli::Cli::command()),
                ),
                (
                    "firmware-sim",
                    reference::commands(&firmware_sim::cli::Cli::command()),
                ),
                ("schemas", reference::schemas()),
            ],
        ),
        (
            "json.md",
            vec![("json", reference::json_fields(&contracts))],
        ),
    ];
    python_records(&contracts);
    for (page_name, parts) in pages {
        let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR"))
            .join("../docs")
            .join(page_name);
        let page = std::fs::read_to_string(&path).unwrap();
        let mut fresh = page.clone();
        for (name, body) in parts {
            fresh = reference::replace_generated(&fresh, name, &body)
                .unwrap_or_else(|| panic!("docs/{page_name} has no generated part `{name}`"));
        }
        if std::env::var_os("FOG_BLESS").is_some() {
            std::fs::write(&path, &fresh).unwrap();
            continue;
        }
        assert!(
            fresh == page,
            "docs/{page_name} is stale: FOG_BLESS=1 cargo test -p integration-tests --test \
             integration -- docs"
        );
    }
}

/// python/fog/records.py is generated whole from the trainer's contracts (the ones the Python
/// package returns).
fn python_records(contracts: &[fog_terminal::schema::Contract]) {
    let path = std::path::Path::new(env!("CARGO_MANIFEST_DIR")).join("../python/fog/records.py");
    let trainer: Vec<_> = contracts
        .iter()
        .filter(|c| c.schema.name.starts_with("trainer."))
        .collect();
    let fresh = reference::python_records(&trainer);
    if std::env::var_os("FOG_BLESS").is_some() {
        std::fs::write(&path, &fresh).unwrap();
        return;
    }
    let page = std::fs::read_to_string(&path).unwrap_or_default();
    assert!(
        fresh == page,
        "python/fog/records.py is stale: FOG_BLESS=1 cargo test -p integration-tests --test \
         integration -- docs"
    );
}
