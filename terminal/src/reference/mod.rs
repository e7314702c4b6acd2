//! The parts of docs/commands.md and docs/json.md that are the code's own words, rendered from it
//! so they cannot drift: every command's flags from its clap definition (the help a user sees),
//! the JSON contracts from [`crate::schema`], and each contract's fields from the JSON Schema of
//! the type it is written from ([`schema::Contract`]). A test in the integration suite compares
//! them with the pages (and rewrites them under `FOG_BLESS=1`).

use clap::Command;

use crate::schema;

mod json;
mod python;
mod text;

pub use json::json_fields;
pub use python::python_records;
use text::{cell, one_line};

/// A markdown section per command of `program` (subcommands of subcommands too): a table of its
/// arguments, each with its value, default and help, in the order `--help` gives them. The flags
/// every command takes (`--quiet`, `--verbose`, `--help`) are left to the page's text.
pub fn commands(program: &Command) -> String {
    let mut out = String::new();
    for sub in program.get_subcommands() {
        section(&mut out, program.get_name(), sub);
    }
    out
}

fn section(out: &mut String, parent: &str, cmd: &Command) {
    let name = format!("{parent} {}", cmd.get_name());
    if cmd.has_subcommands() {
        for sub in cmd.get_subcommands() {
            section(out, &name, sub);
        }
        return;
    }
    out.push_str(&format!("#### `{name}`\n\n"));
    if let Some(about) = cmd.get_about() {
        out.push_str(&format!("{}\n\n", one_line(&about.to_string())));
    }
    out.push_str("| argument | value | default | what |\n|---|---|---|---|\n");
    for arg in cmd.get_arguments() {
        if arg.is_hide_set() || arg.is_global_set() || matches!(arg.get_id().as_str(), "help") {
            continue;
        }
        let flag = match (arg.get_long(), arg.get_short()) {
            (Some(l), Some(s)) => format!("`--{l}`, `-{s}`"),
            (Some(l), None) => format!("`--{l}`"),
            (None, Some(s)) => format!("`-{s}`"),
            (None, None) => format!("`{}` (positional)", arg.get_id().as_str().to_uppercase()),
        };
        let possible: Vec<String> = arg
            .get_possible_values()
            .iter()
            .filter(|v| !v.is_hide_set())
            .map(|v| v.get_name().to_owned())
            .collect();
        let value = if !arg.get_action().takes_values() {
            String::new()
        } else if !possible.is_empty() {
            possible.join(" \\| ")
        } else {
            arg.get_value_names()
                .map(|v| v.iter().map(|s| s.as_str()).collect::<Vec<_>>().join(" "))
                .unwrap_or_else(|| arg.get_id().as_str().to_uppercase())
        };
        let repeat = matches!(arg.get_action(), clap::ArgAction::Append);
        let value = match (value.is_empty(), repeat) {
            (true, _) => String::new(),
            (false, true) => format!("{value} …"),
            (false, false) => value,
        };
        let default: Vec<String> = arg
            .get_default_values()
            .iter()
            .map(|v| v.to_string_lossy().into_owned())
            .collect();
        let required = if arg.is_required_set() {
            "required. "
        } else {
            ""
        };
        let help = arg.get_long_help().or(arg.get_help());
        out.push_str(&format!(
            "| {flag} | {} | {} | {required}{} |\n",
            cell(&value),
            cell(&default.join(", ")),
            cell(&help.map(|h| h.to_string()).unwrap_or_default())
        ));
    }
    out.push('\n');
}

/// The contracts of [`schema::ALL`] as a markdown table.
pub fn schemas() -> String {
    let mut out = String::from("| schema | version | written by |\n|---|---|---|\n");
    for s in schema::ALL {
        out.push_str(&format!(
            "| `{}` | {} | `{}` |\n",
            s.name, s.version, s.written_by
        ));
    }
    out
}

/// `page` with the text between `<!-- generated: NAME -->` and `<!-- end generated: NAME -->`
/// replaced by `body`; `None` where the page has no such markers.
pub fn replace_generated(page: &str, name: &str, body: &str) -> Option<String> {
    let open = format!("<!-- generated: {name} -->\n");
    let close = format!("<!-- end generated: {name} -->");
    let start = page.find(&open)? + open.len();
    let end = start + page[start..].find(&close)?;
    Some(format!("{}{body}{}", &page[..start], &page[end..]))
}

#[cfg(test)]
mod tests {
    use super::*;
    use clap::{Arg, ArgAction};

    #[test]
    fn a_command_renders_as_a_table_of_its_flags() {
        let program = Command::new("p").subcommand(
            Command::new("fit")
                .about("Fit it.")
                .arg(
                    Arg::new("out")
                        .long("out")
                        .required(true)
                        .help("Blob | to write"),
                )
                .arg(
                    Arg::new("run")
                        .long("run")
                        .value_name("CSV")
                        .action(ArgAction::Append),
                )
                .arg(Arg::new("q").long("quiet").action(ArgAction::SetTrue))
                .arg(Arg::new("n").long("n").default_value("10")),
        );
        let text = commands(&program);
        assert!(text.starts_with("#### `p fit`\n\nFit it.\n"), "{text}");
        assert!(
            text.contains("| `--out` | OUT |  | required. Blob \\| to write |"),
            "{text}"
        );
        assert!(text.contains("| `--run` | CSV … |  |  |"), "{text}");
        assert!(text.contains("| `--quiet` |  |  |  |"), "{text}");
        assert!(text.contains("| `--n` | N | 10 |  |"), "{text}");
    }

    #[test]
    fn only_the_marked_part_of_a_page_is_replaced() {
        let page = "a\n<!-- generated: x -->\nold\n<!-- end generated: x -->\nb";
        assert_eq!(
            replace_generated(page, "x", "new\n").unwrap(),
            "a\n<!-- generated: x -->\nnew\n<!-- end generated: x -->\nb"
        );
        assert!(replace_generated(page, "y", "").is_none());
    }
}
