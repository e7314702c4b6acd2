//! What the person at the terminal sees, shared by `trainer` and `firmware-sim`: results on
//! stdout, progress bars and details on stderr, each by the same flags.
//!
//! Scripts on a factory line read results, so a bar never goes where they look: it draws only
//! when stderr is a terminal (indicatif hides itself otherwise), and not at all under `--quiet`
//! or `--json` (a machine is reading). `--json -` puts the JSON on stdout and nothing else there.
//! Warnings go to stderr whatever the flags. Long work in the library takes a [`ProgressBar`]
//! (hidden in tests), so one bar can count the folds, steps or cases of a whole command.

use std::path::Path;
use std::time::Duration;

use clap::Args;
use indicatif::ProgressStyle;

/// The progress handle long work in the library takes (re-exported, so that callers need no
/// dependency of their own).
pub use indicatif::ProgressBar;

/// The flags every command takes.
#[derive(Args, Clone, Copy, Debug, Default)]
pub struct ConsoleFlags {
    /// No progress bars and no summary on stdout: only the files written, warnings and errors.
    #[arg(long, short, global = true, conflicts_with = "verbose")]
    pub quiet: bool,
    /// Details on stderr: every optimizer start of a fit, the commands run (cargo, QEMU).
    #[arg(long, short, global = true)]
    pub verbose: bool,
}

/// The output policy of one command.
#[derive(Clone, Debug)]
pub struct Console {
    flags: ConsoleFlags,
    /// A `--json` was given: no bars.
    json: bool,
    /// `--json -`: stdout carries the JSON alone.
    json_stdout: bool,
    /// The channel of a unit the lines are about: warnings named by it.
    channel: Option<std::sync::Arc<str>>,
    /// Results are indented under a channel's heading.
    indent: bool,
}

/// The end of both programs' `--help`: where the examples are, and what the exit status means.
pub const AFTER_HELP: &str = "Every command's --help ends with an example. Exit status: 0 on \
    success, 1 when the work failed (the message names the file, line and column where it can), \
    2 for a malformed command line.";

/// The `--json` value that means stdout.
pub const STDOUT: &str = "-";

impl Console {
    /// The policy for flags and the command's `--json`, if any.
    pub fn new(flags: ConsoleFlags, json: Option<&Path>) -> Self {
        Self {
            flags,
            json: json.is_some(),
            json_stdout: json.is_some_and(|p| p == Path::new(STDOUT)),
            channel: None,
            indent: false,
        }
    }

    /// The same policy for the lines about one channel of a unit: its heading printed now and its
    /// results indented under it (neither where the heading is empty), its warnings named by it
    /// (not where the name is empty: one channel's data).
    pub fn channel(&self, name: &str, heading: &str) -> Self {
        if !heading.is_empty() {
            self.result(heading);
        }
        Self {
            channel: (!name.is_empty()).then(|| name.into()),
            indent: !heading.is_empty(),
            ..self.clone()
        }
    }

    fn bars(&self) -> bool {
        !(self.flags.quiet || self.json)
    }

    /// A bar of `len` units (more can be added with `inc_length`), or a hidden one.
    pub fn bar(&self, len: u64) -> ProgressBar {
        if !self.bars() {
            return ProgressBar::hidden();
        }
        let bar = ProgressBar::new(len);
        if let Ok(style) =
            ProgressStyle::with_template("[{elapsed_precise}] {bar:30} {pos}/{len} {msg}")
        {
            bar.set_style(style);
        }
        bar.enable_steady_tick(Duration::from_millis(250));
        bar
    }

    /// A spinner with elapsed time, for work of unknown length.
    pub fn spinner(&self, message: &str) -> ProgressBar {
        if !self.bars() {
            return ProgressBar::hidden();
        }
        let bar = ProgressBar::new_spinner();
        if let Ok(style) = ProgressStyle::with_template("{spinner} [{elapsed_precise}] {msg}") {
            bar.set_style(style);
        }
        bar.set_message(message.to_owned());
        bar.enable_steady_tick(Duration::from_millis(120));
        bar
    }

    /// Prints a result line on stdout, unless quiet or stdout carries the JSON.
    pub fn result(&self, text: &str) {
        if self.flags.quiet || self.json_stdout {
            return;
        }
        if self.indent {
            for line in text.lines() {
                println!("  {line}");
            }
        } else {
            println!("{text}");
        }
    }

    /// Whether details are wanted.
    pub fn verbose(&self) -> bool {
        self.flags.verbose
    }

    /// Prints a detail on stderr under `--verbose`.
    pub fn detail(&self, text: &str) {
        if self.flags.verbose {
            eprintln!("{text}");
        }
    }

    /// Prints a warning on stderr, whatever the flags.
    pub fn warn(&self, text: &str) {
        match &self.channel {
            Some(name) => eprintln!("warning: {name}: {text}"),
            None => eprintln!("warning: {text}"),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bars_hide_under_quiet_and_json() {
        let loud = ConsoleFlags::default();
        let quiet = ConsoleFlags {
            quiet: true,
            ..loud
        };
        assert!(Console::new(loud, None).bars());
        assert!(!Console::new(quiet, None).bars());
        assert!(!Console::new(loud, Some(Path::new("out.json"))).bars());
        let c = Console::new(loud, Some(Path::new(STDOUT)));
        assert!(c.json_stdout && !c.bars());
        assert!(!Console::new(loud, Some(Path::new("out.json"))).json_stdout);
    }
}
