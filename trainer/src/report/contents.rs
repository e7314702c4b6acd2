//! What a report holds: its data, the held-out replays, and the figures it promises.

use fog_data::replay::Compensated;
use fog_data::stream::Stream;
use serde::Serialize;

use crate::analysis::investigate::Investigation;
use crate::analysis::reproduce::Reproduction;
use crate::data::points::Points;
use crate::data::summary::Summary;
use fog_data::allan::Analysis as Allan;

/// The figure files, in page order: (file name, caption).
pub const FIGURES: [(&str, &str); 9] = [
    (
        "rate_table.svg",
        "Rate table: output over temperature and rate (paper Fig. 1)",
    ),
    (
        "output_vs_temperature.svg",
        "Output against temperature per rate, first-order fits (paper Fig. 2)",
    ),
    (
        "qq.svg",
        "Q-Q plot of leave-one-out residuals (paper Fig. 4)",
    ),
    (
        "loo_error.svg",
        "Leave-one-out error over (T, rate), GPR and LS-SVR (paper Fig. 5–6)",
    ),
    (
        "bias_vs_temperature.svg",
        "The log's bias against temperature, heating and cooling apart",
    ),
    (
        "replay.svg",
        "Held-out stream replayed through the firmware: static and extended models",
    ),
    (
        "diagnosis.svg",
        "Diagnosis: the static model's residual against its cause and against temperature",
    ),
    (
        "reliability.svg",
        "Reliability of the σ: the fraction of errors within the interval it claims, at every level",
    ),
    (
        "allan.svg",
        "Allan deviation of the held-out stream's error: raw, static and extended (lines: the slopes the noise terms are read from)",
    ),
];

/// What a report is made from: the data a user brings decides what it can show.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, schemars::JsonSchema)]
#[serde(rename_all = "kebab-case")]
pub enum ReportKind {
    /// A rate table alone (the paper's protocol).
    Table,
    /// A rate table and one stream: its first two thirds train the extension, the last third is
    /// held out.
    TableAndStream,
    /// One log alone (a static log with its scale factor, or a ramp log): its first two thirds
    /// fit the model, the last third is held out.
    Log,
    /// A rate table, a training stream and a held-out stream.
    Full,
}

/// The held-out stream and what it shows.
pub struct HeldOut {
    /// How it was held out, in words.
    pub split: String,
    /// The investigation: diagnosis on the training stream, both models scored here.
    pub investigation: Investigation,
    /// The held-out stream.
    pub valid: Stream,
    /// Static and extended replays of it.
    pub replays: [Compensated; 2],
    /// The static model's 60 s residual, with the named cause's regressor and block temperature.
    pub residual: Vec<f64>,
    /// Regressor of the named cause (empty for `none`).
    pub regressor: Vec<f64>,
    /// Block-mean temperature, °C.
    pub block_temp_c: Vec<f64>,
    /// Allan analyses of the held-out stream's error: raw (output over the scale factor),
    /// static, extended.
    pub allan: [Allan; 3],
}

/// Everything the page shows.
pub struct Report {
    /// Where the data came from.
    pub source: String,
    /// What the data are.
    pub kind: ReportKind,
    /// Each file as the loader saw it: the page's first section.
    pub summaries: Vec<Summary>,
    /// The points the static model is fitted on (a rate table, or a log's 60 s means).
    pub points: Points,
    /// LOO evaluations and the Fig. 2 check (a rate table only).
    pub reproduction: Option<Reproduction>,
    /// The held-out stream (not for a rate table alone).
    pub held_out: Option<HeldOut>,
    /// A static log's bias against temperature: 60 s means of temperature and of output / K −
    /// reference, °/h.
    pub bias: Option<(Vec<f64>, Vec<f64>)>,
    /// What these data could show, and what they could not.
    pub could: Vec<String>,
    /// What they could not.
    pub could_not: Vec<String>,
}

/// The figures behind a report's page, as data (`report.json` beside `report.html`): what was
/// loaded, the paper's reproduction, the held-out investigation and what the data could and
/// could not show. The streams and replays the figures are drawn from are left out.
#[derive(Debug, Serialize, schemars::JsonSchema)]
pub struct Figures<'a> {
    /// Where the data came from.
    pub source: &'a str,
    /// What the data are.
    pub kind: ReportKind,
    /// Each file as the loader saw it.
    pub summaries: &'a [Summary],
    /// LOO evaluations and the Fig. 2 check (a rate table only).
    pub reproduction: Option<&'a Reproduction>,
    /// The held-out part: how it was held out, and the investigation on it.
    pub held_out: Option<HeldOutFigures<'a>>,
    /// What these data could show.
    pub could: &'a [String],
    /// What they could not.
    pub could_not: &'a [String],
}

/// The held-out part of a report, as data.
#[derive(Debug, Serialize, schemars::JsonSchema)]
pub struct HeldOutFigures<'a> {
    /// How it was held out, in words.
    pub split: &'a str,
    /// The diagnosis on the training part, both models scored on the held-out part.
    pub investigation: &'a Investigation,
}

impl HeldOut {
    /// Its figures, as data.
    pub fn figures(&self) -> HeldOutFigures<'_> {
        HeldOutFigures {
            split: &self.split,
            investigation: &self.investigation,
        }
    }
}

impl Report {
    /// The figures behind the page, as data.
    pub fn figures(&self) -> Figures<'_> {
        Figures {
            source: &self.source,
            kind: self.kind,
            summaries: &self.summaries,
            reproduction: self.reproduction.as_ref(),
            held_out: self.held_out.as_ref().map(HeldOut::figures),
            could: &self.could,
            could_not: &self.could_not,
        }
    }
}
