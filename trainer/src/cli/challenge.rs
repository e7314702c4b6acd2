//! `trainer challenge`: hidden-effect cases on the simulator, each investigated as a user's log
//! would be, how often the diagnosis names the cause it hid, and how well the shipped σ covers
//! the held-out stream (the service cases hide nothing and are judged on that σ alone).

use std::path::PathBuf;

use clap::Args;
use fog_data::cause::Cause;
use fog_terminal::console::{Console, ConsoleFlags};
use fog_terminal::io::write_json;
use fog_terminal::schema;
use serde::Serialize;

use crate::analysis::challenge;

/// The arguments of `trainer challenge`.
#[derive(Args)]
pub(super) struct ChallengeArgs {
    /// single: every cause alone and none; pairs: every two distinct causes together, each
    /// also investigated by an oracle told the true causes; weak: every cause alone, 0.3–1× the
    /// lower end of its documented strength; lab: the shapes of log labs record, each from one
    /// power-on (power-on, short, warm-up, cool-down), with a warm-up of τ 10–40 min or none;
    /// unit: a unit of three gyro axes, each its own gyro and hidden cause, calibrated through a
    /// channels file; service: a random unit with a turn-on repeatability, calibrated on one log
    /// alone and held out on another power-on of another shape (colder, the other leg, another
    /// power-on, a log with power cycles), its σ scored. Every case scores the shipped model's σ
    /// on the held-out stream.
    #[arg(long, value_enum, default_value_t = challenge::CaseSet::Single)]
    kind: challenge::CaseSet,
    /// Seeds per cause (per pair).
    #[arg(long, default_value_t = 10)]
    seeds: u64,
    /// First seed.
    #[arg(long, default_value_t = 1000)]
    first_seed: u64,
    /// Write every case and the matrix as JSON here.
    #[arg(long)]
    json: Option<PathBuf>,
}

/// `trainer challenge`: hidden-effect cases on the simulator through the investigation.
pub(super) fn challenge_command(args: ChallengeArgs, flags: ConsoleFlags) -> anyhow::Result<()> {
    let ChallengeArgs {
        kind,
        seeds,
        first_seed,
        json,
    } = args;
    let console = Console::new(flags, json.as_deref());
    let bar = console.bar(0);
    bar.set_message("challenge cases");
    let cases = challenge::run(kind, seeds, first_seed, &bar)?;
    bar.finish_and_clear();
    let each = match kind {
        challenge::CaseSet::Lab => "points + two logs of one shape",
        challenge::CaseSet::Service => "one log to calibrate on alone + another power-on held out",
        _ => "points + two 8.75 h chamber streams",
    };
    console.detail(&format!(
        "{} cases ({kind:?}, {seeds} seeds each), each: {each} → investigate",
        cases.len()
    ));
    for c in &cases {
        let ids = |v: &[Cause]| {
            if v.is_empty() {
                "none".to_owned()
            } else {
                v.iter().map(|c| c.id()).collect::<Vec<_>>().join("+")
            }
        };
        let strengths: Vec<String> = c
            .hidden
            .0
            .iter()
            .map(|e| format!("{:.2}", e.strength()))
            .collect();
        let sigma = format!(
            "; ±2σ covers {:.1} % of the 60 s means (sharpness {:.2}){}",
            100.0 * c.sigma_60s.within_2sigma,
            c.sigma_60s.sharpness,
            if c.faults > 0 {
                format!(", {} samples called a fault", c.faults)
            } else {
                String::new()
            }
        );
        let scores = format!(
            "static {:.3e} shipped {:.3e} °/s gain {:.2}×",
            c.static_rmse_60s_dps, c.extended_rmse_60s_dps, c.gain
        );
        if let (Some(condition), Some(held_out)) = (c.condition, c.held_out) {
            console.result(&format!(
                "{:<38} seed {:>5} → named {:<12} {scores}{sigma}",
                format!("{condition}: {} → {held_out}", c.design),
                c.seed,
                ids(&c.named),
            ));
            continue;
        }
        console.result(&format!(
            "{:<10} {:<24} strength {:<12} seed {:>5} → {:<24} {scores}{}{sigma}",
            c.axis.as_deref().unwrap_or(c.design),
            ids(&c.hidden.causes()),
            strengths.join("+"),
            c.seed,
            ids(&c.named),
            c.oracle_gain
                .map_or(String::new(), |o| format!(" (oracle {o:.2}×)")),
        ));
    }
    let summary = challenge::summary(&cases);
    if matches!(kind, challenge::CaseSet::Single | challenge::CaseSet::Unit) {
        console.result(challenge::confusion(&cases).1.trim_end());
    }
    console.result(&summary.text());
    if let Some(path) = json {
        write_json(
            &path,
            &[],
            schema::CHALLENGE,
            &ChallengeReport {
                kind,
                confusion: challenge::confusion(&cases).0,
                order: Cause::ALL,
                accuracy: summary.first_named_right as f64 / cases.len().max(1) as f64,
                false_alarms_none: summary.false_alarms_none,
                cases: &cases,
                summary: &summary,
            },
        )?;
    }
    Ok(())
}

/// What `trainer challenge --json` writes.
#[derive(Serialize, schemars::JsonSchema)]
pub(super) struct ChallengeReport<'a> {
    kind: challenge::CaseSet,
    /// Hidden (rows) against first named (columns), in `order`.
    confusion: [[usize; 6]; 6],
    order: [Cause; 6],
    /// Fraction of cases whose first named cause is the hidden one.
    accuracy: f64,
    false_alarms_none: usize,
    cases: &'a [challenge::Case],
    summary: &'a challenge::ChallengeSummary,
}

/// The challenge's kinds as `--kind` values, by the names their JSON carries (the library's type
/// knows no command line).
impl clap::ValueEnum for challenge::CaseSet {
    fn value_variants<'a>() -> &'a [Self] {
        &challenge::CaseSet::ALL
    }

    fn to_possible_value(&self) -> Option<clap::builder::PossibleValue> {
        Some(clap::builder::PossibleValue::new(self.name()))
    }
}
