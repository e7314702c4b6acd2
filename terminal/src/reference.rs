//! The parts of docs/commands.md and docs/json.md that are the code's own words, rendered from it
//! so they cannot drift: every command's flags from its clap definition (the help a user sees),
//! the JSON contracts from [`crate::schema`], and each contract's fields from the JSON Schema of
//! the type it is written from ([`schema::Contract`]). A test in the integration suite compares
//! them with the pages (and rewrites them under `FOG_BLESS=1`).

use std::collections::BTreeMap;

use clap::Command;
use serde_json::Value;

use crate::schema::{self, Contract};

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

/// Each contract's fields as a markdown table, then every type they are made of, each once (by
/// name; a name two different types share is told apart by the contract it first appears in).
pub fn json_fields(contracts: &[Contract]) -> String {
    let mut types: BTreeMap<String, Value> = BTreeMap::new();
    let mut out = String::new();
    for c in contracts {
        let s = c.schema;
        out.push_str(&format!("### `{}`\n\n", s.name));
        out.push_str(&format!(
            "Version {}, written by `{}`.{}\n\n",
            s.version,
            s.written_by,
            c.about
                .as_deref()
                .map_or(String::new(), |a| format!(" {}", one_line(a)))
        ));
        let mut root = c.fields.as_value().clone();
        // A generic type is named without its parameters: where another contract already gave
        // the name to a different type, this one is named for its contract.
        let defs = root.get("$defs").and_then(Value::as_object).cloned();
        let renamed: BTreeMap<String, String> = defs
            .iter()
            .flatten()
            .filter(|(name, def)| types.get(*name).is_some_and(|d| d != *def))
            .map(|(name, _)| (name.clone(), format!("{name} ({})", s.name)))
            .collect();
        rename_refs(&mut root, &renamed);
        for (name, def) in root
            .get("$defs")
            .and_then(Value::as_object)
            .into_iter()
            .flatten()
        {
            let name = renamed.get(name).unwrap_or(name);
            types.entry(name.clone()).or_insert_with(|| def.clone());
        }
        out.push_str(&fields_table(&root));
        out.push('\n');
    }
    out.push_str("### Types\n\n");
    for (name, def) in &types {
        out.push_str(&format!("#### {name}\n\n"));
        if let Some(d) = def.get("description").and_then(Value::as_str) {
            out.push_str(&format!("{}\n\n", cell(d)));
        }
        if def.get("properties").is_some() {
            out.push_str(&fields_table(def));
        } else {
            out.push_str(&format!("{}\n", variants(def)));
        }
        out.push('\n');
    }
    out
}

/// `value` with every `$ref` to a type of `renamed` pointing at its new name.
fn rename_refs(value: &mut Value, renamed: &BTreeMap<String, String>) {
    match value {
        Value::Object(map) => {
            for (key, v) in map.iter_mut() {
                match (key.as_str(), &*v) {
                    ("$ref", Value::String(r)) => {
                        let name = r.rsplit('/').next().unwrap_or(r);
                        if let Some(new) = renamed.get(name) {
                            *v = Value::String(format!("#/$defs/{new}"));
                        }
                    }
                    _ => rename_refs(v, renamed),
                }
            }
        }
        Value::Array(list) => list.iter_mut().for_each(|v| rename_refs(v, renamed)),
        _ => {}
    }
}

/// An object schema's properties as a table: field, type, what it holds.
fn fields_table(object: &Value) -> String {
    let mut out = String::from("| field | type | what |\n|---|---|---|\n");
    if let Some(props) = object.get("properties").and_then(Value::as_object) {
        for (name, p) in props {
            let what = p.get("description").and_then(Value::as_str).unwrap_or("");
            out.push_str(&format!(
                "| `{name}` | {} | {} |\n",
                cell(&ty(p)),
                cell(what)
            ));
        }
    }
    out
}

/// A schema that is not an object (an enum, a value of one of several shapes), in words.
fn variants(def: &Value) -> String {
    let alternatives = def
        .get("oneOf")
        .or_else(|| def.get("anyOf"))
        .and_then(Value::as_array);
    match alternatives {
        Some(list) => list
            .iter()
            .map(|v| {
                let what = v.get("description").and_then(Value::as_str);
                let shape = match v.get("properties") {
                    Some(_) if v.get("const").is_none() => ty_object(v),
                    _ => ty(v),
                };
                match what {
                    Some(w) => format!("- {shape}: {}", cell(w)),
                    None => format!("- {shape}"),
                }
            })
            .collect::<Vec<_>>()
            .join("\n"),
        None => format!("One of: {}.", ty(def)),
    }
}

/// An object's fields, inline: `{a: T, b: U}`.
fn ty_object(v: &Value) -> String {
    let props = v.get("properties").and_then(Value::as_object);
    let fields: Vec<String> = props
        .into_iter()
        .flatten()
        .map(|(k, p)| format!("`{k}`: {}", ty(p)))
        .collect();
    format!("{{{}}}", fields.join(", "))
}

/// A schema's type as a reader needs it: a link to a named type, a list, one of several values.
fn ty(v: &Value) -> String {
    if let Some(r) = v.get("$ref").and_then(Value::as_str) {
        let name = r.rsplit('/').next().unwrap_or(r);
        return format!("[{name}](#{})", anchor(name));
    }
    if let Some(c) = v.get("const") {
        return format!("`{c}`");
    }
    if let Some(e) = v.get("enum").and_then(Value::as_array) {
        return e
            .iter()
            .map(|x| format!("`{x}`"))
            .collect::<Vec<_>>()
            .join(" or ");
    }
    for key in ["oneOf", "anyOf"] {
        if let Some(list) = v.get(key).and_then(Value::as_array) {
            return list.iter().map(ty).collect::<Vec<_>>().join(" or ");
        }
    }
    if let Some([one]) = v.get("allOf").and_then(Value::as_array).map(Vec::as_slice) {
        return ty(one);
    }
    let kinds: Vec<&str> = match v.get("type") {
        Some(Value::String(t)) => vec![t.as_str()],
        Some(Value::Array(ts)) => ts.iter().filter_map(Value::as_str).collect(),
        _ => return "any".to_owned(),
    };
    let nullable = kinds.contains(&"null");
    let shapes: Vec<String> = kinds
        .iter()
        .filter(|k| **k != "null")
        .map(|k| match *k {
            "array" => match (v.get("prefixItems"), v.get("items")) {
                (Some(Value::Array(items)), _) => {
                    format!("[{}]", items.iter().map(ty).collect::<Vec<_>>().join(", "))
                }
                (_, Some(items)) => format!("[{}]", ty(items)),
                _ => "[any]".to_owned(),
            },
            "object" => match v.get("additionalProperties") {
                Some(p) if p.is_object() => format!("{{string: {}}}", ty(p)),
                _ if v.get("properties").is_some() => ty_object(v),
                _ => "object".to_owned(),
            },
            other => other.to_owned(),
        })
        .collect();
    match (shapes.is_empty(), nullable) {
        (true, _) => "null".to_owned(),
        (false, true) => format!("{} or null", shapes.join(" or ")),
        (false, false) => shapes.join(" or "),
    }
}

/// The anchor markdown gives a heading `name`.
fn anchor(name: &str) -> String {
    name.chars()
        .filter_map(|c| match c {
            c if c.is_alphanumeric() => Some(c.to_ascii_lowercase()),
            '-' | '_' => Some(c),
            ' ' => Some('-'),
            _ => None,
        })
        .collect()
}

/// `text` on one line.
fn one_line(text: &str) -> String {
    text.split_whitespace().collect::<Vec<_>>().join(" ")
}

/// `text` fit for a table cell: one line, its pipes escaped, a rustdoc link to an item kept as
/// the item's name.
fn cell(text: &str) -> String {
    one_line(text)
        .replace("[`", "`")
        .replace("`]", "`")
        .replace('|', "\\|")
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
