//! Where the bench finds the project's source tree, for the commands that build from it (the
//! Cortex-M4 image, the C interface's library and programs): a binary may have been installed or
//! moved since it was built, so the folder it was built in is the last guess, not the only one.

use std::path::{Path, PathBuf};

/// The variable that names the source tree, as `--source` does.
pub const VARIABLE: &str = "FOG_SOURCE_DIR";

/// What marks a folder as the project's source tree.
const MARKERS: [&str; 2] = ["firmware-sim/m4/Cargo.toml", "firmware-core/ffi/Cargo.toml"];

/// No source tree where one was looked for.
#[derive(Debug, thiserror::Error)]
#[error(
    "the project's source tree (a folder holding {}) is needed to build the Cortex-M4 image and \
     the C library, and none was found; looked in: {}. Give it with --source DIR or {VARIABLE}=DIR, \
     or run from inside a checkout",
    MARKERS.join(" and "),
    .looked.iter().map(|(p, why)| format!("{} ({why})", p.display())).collect::<Vec<_>>().join(", ")
)]
pub struct NotFound {
    /// Each folder tried, with how it was chosen.
    pub looked: Vec<(PathBuf, &'static str)>,
}

/// The source tree: `given` (a `--source` flag) if any, else [`VARIABLE`], else the current
/// folder or the nearest of its parents that holds one, else the folder this binary was built
/// from. A folder named explicitly is the only one tried.
pub fn locate(given: Option<&Path>) -> Result<PathBuf, NotFound> {
    let holds = |p: &Path| MARKERS.iter().all(|m| p.join(m).is_file());
    let named = given
        .map(|p| (p.to_owned(), "--source"))
        .or_else(|| std::env::var_os(VARIABLE).map(|v| (PathBuf::from(v), VARIABLE)));
    if let Some((p, why)) = named {
        return if holds(&p) {
            Ok(p)
        } else {
            Err(NotFound {
                looked: vec![(p, why)],
            })
        };
    }
    let mut looked = Vec::new();
    if let Ok(cwd) = std::env::current_dir() {
        if let Some(p) = cwd.ancestors().find(|p| holds(p)) {
            return Ok(p.to_owned());
        }
        looked.push((cwd, "the current folder and its parents"));
    }
    let built = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
    if holds(&built) {
        return Ok(built);
    }
    looked.push((built, "where this binary was built"));
    Err(NotFound { looked })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_named_folder_is_the_only_one_tried_and_the_error_says_what_was_looked_for() {
        let dir = tempfile::tempdir().unwrap();
        let err = locate(Some(dir.path())).unwrap_err();
        assert_eq!(err.looked.len(), 1);
        let text = err.to_string();
        assert!(text.contains(&dir.path().display().to_string()), "{text}");
        assert!(text.contains("--source"), "{text}");
        let here = Path::new(env!("CARGO_MANIFEST_DIR")).join("..");
        assert!(locate(Some(&here)).is_ok());
    }
}
