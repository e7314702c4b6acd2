//! Output files are written atomically: a temporary file beside the target, then a rename, so an
//! interrupted run never leaves a half-written model or report. Commands also refuse to write over
//! one of their own inputs.

use std::io::Write;
use std::path::{Path, PathBuf};

use serde::Serialize;

use crate::schema::{Schema, Stamped};

/// Errors while writing outputs.
#[derive(Debug, thiserror::Error)]
pub enum OutputError {
    /// The file could not be created, written or renamed into place.
    #[error("writing {path}")]
    Io {
        /// The target file.
        path: PathBuf,
        /// The underlying error.
        source: std::io::Error,
    },
    /// The output would replace an input of the same command.
    #[error("refusing to write {path}: it is also an input of this command")]
    WouldOverwriteInput {
        /// The target file.
        path: PathBuf,
    },
}

/// Writes `contents` to `path` through a temporary file in the same directory. The temporary is
/// created like any new file (permissions from the umask, not the private mode of a temp-file
/// crate), so the result looks like a file written directly.
pub fn write_atomically(path: &Path, contents: &[u8]) -> Result<(), OutputError> {
    let err = |source| OutputError::Io {
        path: path.to_owned(),
        source,
    };
    let dir = match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d,
        _ => Path::new("."),
    };
    let name = path
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    let tmp = dir.join(format!(".{name}.{}.tmp", std::process::id()));
    let written = std::fs::OpenOptions::new()
        .write(true)
        .create_new(true)
        .open(&tmp)
        .and_then(|mut f| f.write_all(contents).and_then(|()| f.sync_all()))
        .and_then(|()| std::fs::rename(&tmp, path));
    if written.is_err() {
        let _ = std::fs::remove_file(&tmp);
    }
    written.map_err(err)
}

/// Writes `value` (a struct or map) as pretty JSON to `path` (atomically), or to stdout when
/// `path` is `-`, with `schema` as its first field; refuses to write over one of `inputs`.
pub fn write_json(
    path: &Path,
    inputs: &[&Path],
    schema: Schema,
    value: &impl Serialize,
) -> Result<(), OutputError> {
    write_text(
        path,
        inputs,
        &Stamped {
            schema,
            body: value,
        },
    )
}

/// Pretty JSON of `value` to `path` or stdout.
fn write_text(path: &Path, inputs: &[&Path], value: &impl Serialize) -> Result<(), OutputError> {
    let text = serde_json::to_string_pretty(value).map_err(|e| OutputError::Io {
        path: path.to_owned(),
        source: e.into(),
    })?;
    if path == Path::new(crate::console::STDOUT) {
        println!("{text}");
        return Ok(());
    }
    ensure_not_input(path, inputs)?;
    write_atomically(path, text.as_bytes())
}

/// Fails if `output` names the same file as any of `inputs`.
pub fn ensure_not_input(output: &Path, inputs: &[&Path]) -> Result<(), OutputError> {
    let canon = |p: &Path| std::fs::canonicalize(p).ok();
    let out = canon(output);
    if out.is_some() && inputs.iter().any(|i| canon(i) == out) {
        return Err(OutputError::WouldOverwriteInput {
            path: output.to_owned(),
        });
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn json_names_its_schema_first() {
        #[derive(Serialize, schemars::JsonSchema)]
        struct Fit {
            rmse: f64,
        }
        let dir = tempfile::tempdir().unwrap();
        let (one, list) = (dir.path().join("one.json"), dir.path().join("list.json"));
        write_json(&one, &[], crate::schema::FIT, &Fit { rmse: 1.5 }).unwrap();
        let text = std::fs::read_to_string(&one).unwrap();
        let v: serde_json::Value = serde_json::from_str(&text).unwrap();
        assert_eq!(v["schema"]["name"], "trainer.fit");
        assert_eq!(v["schema"]["version"], 3);
        assert_eq!(v["rmse"], 1.5);
        assert!(text.find("schema") < text.find("rmse"), "{text}");
        let files = crate::schema::PerFile { files: &[1, 2] };
        write_json(&list, &[], crate::schema::SUMMARIZE, &files).unwrap();
        let v: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&list).unwrap()).unwrap();
        assert_eq!(v["schema"]["name"], "trainer.summarize");
        assert_eq!(v["files"], serde_json::json!([1, 2]));
        assert!(
            write_json(&dir.path().join("x.json"), &[], crate::schema::FIT, &[1, 2]).is_err(),
            "a list has no fields to follow the schema: a body of its own holds it (PerFile)"
        );
    }

    #[test]
    fn writes_and_refuses_to_overwrite_an_input() {
        let dir = tempfile::tempdir().unwrap();
        let p = dir.path().join("a.csv");
        write_atomically(&p, b"x").unwrap();
        assert_eq!(std::fs::read(&p).unwrap(), b"x");
        assert!(ensure_not_input(&p, &[&p]).is_err());
        assert!(ensure_not_input(&dir.path().join("b"), &[&p]).is_ok());
        assert_eq!(
            std::fs::read_dir(dir.path()).unwrap().count(),
            1,
            "no temporary left"
        );
    }
}
