//! The `trainer` command line: flags are parsed into checked settings, then dispatched to the
//! library. `main.rs` only calls [`run`]; tests call it too, with arguments of their own.

use clap::{Parser, Subcommand};
use fog_terminal::console::{AFTER_HELP, Console, ConsoleFlags};

mod analyse;
mod challenge;
mod contracts;
mod demo;
mod fit;
mod gyro;
mod inputs;
mod inspect;
mod look;
mod report;
mod sensors;

pub use contracts::contracts;

/// The library's progress, drawn by the console's bar.
impl crate::progress::Progress for fog_terminal::console::ProgressBar {
    fn expect(&self, steps: u64) {
        self.inc_length(steps);
    }

    fn advance(&self, steps: u64) {
        self.inc(steps);
    }

    fn stage(&self, what: &str) {
        self.set_message(what.to_owned());
    }
}

/// The pipelines' messages, on the console: results on stdout, warnings and details on stderr,
/// work as a bar (counted) or a spinner (of unknown length) that clears when it ends.
impl crate::progress::Messages for fog_terminal::console::Console {
    fn result(&self, text: &str) {
        Console::result(self, text);
    }

    fn warn(&self, text: &str) {
        Console::warn(self, text);
    }

    fn verbose(&self) -> bool {
        Console::verbose(self)
    }

    fn detail(&self, text: &str) {
        Console::detail(self, text);
    }

    fn busy(&self, what: &str) -> Box<dyn crate::progress::Progress + '_> {
        Box::new(Shown(self.spinner(what)))
    }

    fn counted(&self) -> Box<dyn crate::progress::Progress + '_> {
        Box::new(Shown(self.bar(0)))
    }

    fn channel(&self, name: &str, heading: &str) -> Box<dyn crate::progress::Messages + '_> {
        Box::new(Console::channel(self, name, heading))
    }
}

/// A console bar or spinner that clears itself when the work it shows ends (is dropped).
struct Shown(fog_terminal::console::ProgressBar);

impl crate::progress::Progress for Shown {
    fn expect(&self, steps: u64) {
        self.0.expect(steps);
    }

    fn advance(&self, steps: u64) {
        self.0.advance(steps);
    }

    fn stage(&self, what: &str) {
        self.0.stage(what);
    }
}

impl Drop for Shown {
    fn drop(&mut self) {
        self.0.finish_and_clear();
    }
}

/// Host trainer for FOG temperature-drift compensation (Gaussian-process regression).
#[derive(Parser)]
#[command(version, about, after_help = AFTER_HELP)]
pub struct Cli {
    #[command(subcommand)]
    /// The subcommand.
    command: Command,
    #[command(flatten)]
    console: ConsoleFlags,
}

#[derive(Subcommand)]
enum Command {
    /// The main job, end to end, on a simulated gyro with a hidden thermal-rate drift: its rate
    /// table and two ramp streams, the static fit and blob, the diagnosis, the extended model and
    /// its gain on the held-out stream, the replay of the extended blob, the paper's tables and
    /// the report (OUT/report/report.html). Prints each step as the command that does it alone.
    ///
    /// Example: trainer demo --out run
    Demo(demo::DemoArgs),
    /// Fit the GP map ω = f(T, V) to rate-table points (or to a stream's 60 s block means) and
    /// export the firmware blob; with --features, extend it by the inputs named (or by what the
    /// diagnosis names: auto), fitted on the stream.
    ///
    /// Example: trainer fit --points points.csv --out model.bin --json fit.json
    ///
    /// Example: trainer fit --points points.csv --stream ramp.csv --features auto --out ext.bin
    ///
    /// Example (a turntable run, rows in time order, 21 s each): trainer fit --points run.csv
    /// --map time_s=segment*21 --features auto --out model.bin
    ///
    /// Example (a static log, gyro output in °/s): trainer fit --stream imu.tsv --map
    /// time_s=timestamp*1e-6 --map temp_c=imu.temperature --map voltage_v=imu.gyro.x*57.29577951
    /// --map rate_dps=0 --scale-factor 1 --out bias.bin
    Fit(fit::FitArgs),
    /// Replay a stream through a model, and name the physical cause of what it gets wrong
    /// (docs/design.md §5 cause ids), with the evidence and the runner-up.
    ///
    /// Example: trainer diagnose --model model.bin --stream s.csv --json d.json
    Diagnose(analyse::DiagnoseArgs),
    /// Static fit → replay on the held-out stream → diagnosis → extended fit on the points and the
    /// training stream → replay on the held-out stream → gain.
    ///
    /// Example: trainer investigate --points p.csv --stream a.csv --valid-stream b.csv --json
    /// i.json
    ///
    /// Example (one static log, forward in time): trainer investigate --stream imu.tsv
    /// --hold-out-from 2400 --scale-factor 1 --map …
    Investigate(analyse::InvestigateArgs),
    /// Size and static memory of a blob on the firmware, every channel's, with the formula.
    ///
    /// Example: trainer inspect model.bin
    Inspect(inspect::InspectArgs),
    /// Allan deviation of a log (IEEE Std 952): the raw output divided by a scale factor, or the
    /// output compensated by a model, less the reference rate; the noise terms read from it
    /// (angle random walk, bias instability, rate random walk) and its figure. A static log in
    /// rad/s, for example:
    ///
    /// Example: trainer allan --stream imu.tsv --map
    /// time_s=timestamp*1e-6 --map temp_c=imu.temperature --map voltage_v=imu.gyro.x*57.29577951
    /// --map rate_dps=0 --scale-factor 1 --json allan.json --plot allan.svg
    Allan(gyro::AllanArgs),
    /// A look at a data file before anything is fitted: rows, the columns mapped, temperature and
    /// rate ranges, plateaus, sampling and gaps, rows left out and why, the scale factor the data
    /// show, and whether the earth rate seems to be in the reference. A wrong --map or unit shows
    /// here.
    ///
    /// Example: trainer summarize --points run.csv --map temp_c=temp_C --map
    /// voltage_v=gyro_raw_counts --map rate_dps=rig_rate_deg_s
    Summarize(look::SummarizeArgs),
    /// Leave-one-out and leave-one-temperature-out evaluation of one method.
    ///
    /// Example: trainer loo --points points.csv --method gpr --json loo.json
    Loo(analyse::LooArgs),
    /// One self-contained HTML report (inline SVG) and its figures as SVG files: the rate table,
    /// the paper's Fig. 2, 4 and 5–6, the held-out replay (static and extended, ±2σ) and the
    /// diagnosis, with the LOO, leave-one-temperature-out and gain tables. Without data, on a
    /// simulated gyro with a hidden thermal-rate drift (the main job's data, written to
    /// OUT/data).
    ///
    /// Example: trainer report --points points.csv --stream train.csv --valid-stream valid.csv
    /// --out report
    Report(report::ReportArgs),
    /// Our figures beside the reference paper's: LOO, leave-one-temperature-out, Fig. 2, Q-Q.
    ///
    /// Example: trainer reproduce --points points.csv
    Reproduce(analyse::ReproduceArgs),
    /// Hidden-effect cases through the investigation (static fit → diagnosis → extension → gain):
    /// the confusion matrix of hidden vs named cause and the gain per case.
    ///
    /// Example: trainer challenge --seeds 10 --json challenge.json
    Challenge(challenge::ChallengeArgs),
}

/// Runs one parsed command line.
pub fn run(cli: Cli) -> anyhow::Result<()> {
    let flags = cli.console;
    match cli.command {
        Command::Demo(args) => demo::run(args, flags, run),
        Command::Fit(args) => fit::fit_command(args, flags),
        Command::Diagnose(args) => analyse::diagnose_command(args, flags),
        Command::Investigate(args) => analyse::investigate_command(args, flags),
        Command::Inspect(args) => inspect::inspect_command(args, flags),
        Command::Loo(args) => analyse::loo_command(args, flags),
        Command::Allan(args) => gyro::allan_command(args, flags),
        Command::Summarize(args) => look::summarize_command(args, flags),
        Command::Report(args) => report::report_command(args, flags),
        Command::Reproduce(args) => analyse::reproduce_command(args, flags),
        Command::Challenge(args) => challenge::challenge_command(args, flags),
    }
}
