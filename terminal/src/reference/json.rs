//! docs/json.md's generated part: each contract's fields, then every type they are made of, from
//! the JSON Schema of the types the files are written from ([`Contract`]).

use std::collections::BTreeMap;

use serde_json::Value;

use super::text::{cell, one_line};
use crate::schema::{Contract, Schema};

/// The contracts' JSON Schemas, every type they are made of named once: a generic type is named
/// without its parameters, so where an earlier contract gave a name to a different type, this
/// one is named for its contract (or takes the name an earlier contract gave the same type).
pub(super) struct Collected {
    /// Each contract with its schema, its references renamed.
    pub(super) roots: Vec<(Schema, Option<String>, Value)>,
    /// Every type, by its name.
    pub(super) types: BTreeMap<String, Value>,
}

/// [`Collected`] of `contracts`.
pub(super) fn collect<'a>(contracts: impl IntoIterator<Item = &'a Contract>) -> Collected {
    let mut types: BTreeMap<String, Value> = BTreeMap::new();
    let mut roots = Vec::new();
    for c in contracts {
        let s = c.schema;
        let mut root = c.fields.as_value().clone();
        let defs = root.get("$defs").and_then(Value::as_object).cloned();
        let renamed: BTreeMap<String, String> = defs
            .iter()
            .flatten()
            .filter(|(name, def)| types.get(*name).is_some_and(|d| d != *def))
            .map(|(name, def)| {
                let earlier = types
                    .iter()
                    .find(|(other, d)| *d == def && other.starts_with(&format!("{name} (")));
                let new = match earlier {
                    Some((other, _)) => other.clone(),
                    None => format!("{name} ({})", s.name),
                };
                (name.clone(), new)
            })
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
        roots.push((s, c.about.clone(), root));
    }
    Collected { roots, types }
}

/// The name a `$ref` points at.
pub(super) fn ref_name(v: &Value) -> Option<&str> {
    let r = v.get("$ref")?.as_str()?;
    Some(r.rsplit('/').next().unwrap_or(r))
}

/// Each contract's fields as a markdown table, then every type they are made of, each once.
pub fn json_fields(contracts: &[Contract]) -> String {
    let Collected { roots, types } = collect(contracts);
    let mut out = String::new();
    for (s, about, root) in &roots {
        out.push_str(&format!("### `{}`\n\n", s.name));
        out.push_str(&format!(
            "Version {}, written by `{}`.{}\n\n",
            s.version,
            s.written_by,
            about
                .as_deref()
                .map_or(String::new(), |a| format!(" {}", one_line(a)))
        ));
        out.push_str(&fields_table(root));
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
    if let Some(name) = ref_name(v) {
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
