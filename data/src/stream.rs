//! Time-series streams (docs/design.md §3 `stream`): `time_s,temp_c,voltage_v,rate_dps`, the
//! reference rate empty where unknown.
//!
//! Time is checked, not trusted: a step that goes backwards or repeats a timestamp, and a gap
//! longer than [`GAP_FACTOR`] times the typical step, are collected as [`TimeIssue`]s so that every
//! command that uses the stream can report them (and stateful features can restart there) instead
//! of silently differentiating across them.

use std::fmt;
use std::path::Path;

use crate::blocks;
use crate::columns::{self, ColumnMap, DataError};

/// A step longer than this many typical steps is a gap.
pub const GAP_FACTOR: f64 = 3.0;

/// What is wrong with the time between two rows.
#[derive(Debug, Clone, Copy, PartialEq, serde::Serialize, schemars::JsonSchema)]
#[serde(rename_all = "snake_case", tag = "kind")]
pub enum TimeIssue {
    /// Time went backwards at this line.
    Backwards {
        /// 1-based line in the file.
        line: u64,
        /// The step, s (negative).
        step_s: f64,
    },
    /// The timestamp repeats the previous one.
    Duplicate {
        /// 1-based line in the file.
        line: u64,
    },
    /// A step much longer than the typical one.
    Gap {
        /// 1-based line in the file.
        line: u64,
        /// The step, s.
        step_s: f64,
    },
}

impl TimeIssue {
    /// The 1-based file line of the row where the issue shows.
    pub fn line(&self) -> u64 {
        match *self {
            Self::Backwards { line, .. } | Self::Duplicate { line } | Self::Gap { line, .. } => {
                line
            }
        }
    }

    /// Whether the gyro was powered on again where it shows: time jumps back or leaves a gap (a
    /// power cycle, or a reset the firmware would make); a repeated time stamp is neither.
    pub fn is_restart(&self) -> bool {
        !matches!(self, Self::Duplicate { .. })
    }
}

impl fmt::Display for TimeIssue {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match *self {
            Self::Backwards { line, step_s } => {
                write!(f, "line {line}: time goes back {:.1} s", -step_s)
            }
            Self::Duplicate { line } => write!(f, "line {line}: the timestamp repeats"),
            Self::Gap { line, step_s } => write!(
                f,
                "line {line}: time jumps {step_s:.1} s (a power cycle or a logger pause)"
            ),
        }
    }
}

/// A loaded stream.
#[derive(Debug, Clone)]
pub struct Stream {
    /// Time, s.
    pub time_s: Vec<f64>,
    /// Temperature-sensor reading, °C.
    pub temp_c: Vec<f64>,
    /// Gyro output.
    pub voltage_v: Vec<f64>,
    /// Reference rate, °/s; NaN where unknown.
    pub rate_dps: Vec<f64>,
    /// 1-based line of each row.
    pub lines: Vec<u64>,
    /// Typical (median) time step, s.
    pub step_s: f64,
    /// Time problems found, in file order.
    pub time_issues: Vec<TimeIssue>,
    /// Windows of a static log where the unit was handled ([`Handled`]): their references are
    /// removed, so no fit or score uses them.
    pub handled: Vec<Handled>,
    /// Samples at the start that are the log's history before a window ([`Stream::window`]):
    /// the firmware's feature state runs through them from the power-on, as it did on the gyro,
    /// but their references are removed and no replay writes them.
    pub history: usize,
    /// Time of the log's first sample with a reference after a window ([`Stream::window`]), s,
    /// where the log goes on past it in the same power-on: a model fitted on the rest of the log
    /// saw data there too. `None` for a whole log, a window to its end, one a power cycle ends
    /// before another reference, and one no reference follows.
    pub after_s: Option<f64>,
}

/// How many times the log's typical scatter a block's output scatter must exceed to count as
/// handled. A MEMS start-up transient reaches 7× (the MIT log's first minute); moving or tapping
/// the unit, tens of °/s against noise of hundredths, goes far beyond.
pub const HANDLED_SCATTER: f64 = 10.0;
/// Fewest blocks a log needs before any is judged against the others.
const HANDLED_MIN_BLOCKS: usize = 5;

/// A 60 s window of a static log whose output scatters far beyond the log's own noise: someone
/// handled the unit there (moved, tapped, re-cabled it), and what it shows is not the gyro at rest.
#[derive(Debug, Clone, PartialEq, serde::Serialize, schemars::JsonSchema)]
pub struct Handled {
    /// First line of the window.
    pub line: u64,
    /// Start and end, s from the first sample.
    pub span_s: [f64; 2],
    /// Samples in it.
    pub n: usize,
    /// Its output's standard deviation over the log's median one (0 for a window the user
    /// named).
    pub scatter_ratio: f64,
    /// Left out because the user named it (`--exclude`), not by the screening.
    pub asked: bool,
}

impl Handled {
    /// The part of this window among the rows `keep` of a stream (`time_s`, `lines`), its span
    /// counted from `new_t0` (the first kept sample); `None` where no row of it is kept.
    fn within(&self, time_s: &[f64], lines: &[u64], keep: &[usize], new_t0: f64) -> Option<Self> {
        let t0 = time_s.first().copied().unwrap_or(0.0);
        let (start, end) = (t0 + self.span_s[0], t0 + self.span_s[1]);
        let rows: Vec<usize> = keep
            .iter()
            .copied()
            .filter(|&i| time_s[i] >= start && time_s[i] <= end)
            .collect();
        let (&first, &last) = (rows.first()?, rows.last()?);
        Some(Self {
            line: lines[first],
            span_s: [time_s[first] - new_t0, time_s[last] - new_t0],
            n: rows.len(),
            scatter_ratio: self.scatter_ratio,
            asked: self.asked,
        })
    }
}

impl fmt::Display for Handled {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        if self.asked {
            return write!(
                f,
                "line {}: {:.0}–{:.0} s, left out as --exclude asked (every fit and score)",
                self.line, self.span_s[0], self.span_s[1]
            );
        }
        write!(
            f,
            "line {}: {:.0}–{:.0} s, output scatter {:.0}× the log's own: handled, left out of \
             every fit and score",
            self.line, self.span_s[0], self.span_s[1], self.scatter_ratio
        )
    }
}

/// The windows of a log left out of every fit and score, in one line: how many the screening
/// found handled (with the range of their scatter) and how many `--exclude` named, the samples
/// they hold and where; `None` where there are none. Each window is in the JSON and under
/// `--verbose`.
pub fn left_out_summary(handled: &[Handled]) -> Option<String> {
    if handled.is_empty() {
        return None;
    }
    let screened: Vec<&Handled> = handled.iter().filter(|h| !h.asked).collect();
    let asked = handled.len() - screened.len();
    let samples: usize = handled.iter().map(|h| h.n).sum();
    let mut parts = Vec::new();
    if !screened.is_empty() {
        let (lo, hi) = screened
            .iter()
            .fold((f64::INFINITY, 0.0f64), |(lo, hi), h| {
                (lo.min(h.scatter_ratio), hi.max(h.scatter_ratio))
            });
        let scatter = if hi / lo < 1.05 {
            format!("{hi:.0}×")
        } else {
            format!("{lo:.0}–{hi:.0}×")
        };
        parts.push(format!(
            "{} minute{} where the unit was handled (output scatter {scatter} the log's own)",
            screened.len(),
            if screened.len() == 1 { "" } else { "s" }
        ));
    }
    if asked > 0 {
        parts.push(format!(
            "{asked} window{} named by --exclude",
            if asked == 1 { "" } else { "s" }
        ));
    }
    let first = &handled[0];
    let last = &handled[handled.len() - 1];
    Some(format!(
        "{}: {samples} samples between {:.0} and {:.0} s (line {} on), left out of every fit, score \
         and Allan deviation (each in the JSON and with -v)",
        parts.join(" and "),
        first.span_s[0],
        last.span_s[1],
        first.line
    ))
}

/// The 60 s blocks of a static log (every reference the same: the unit at rest) whose output
/// scatters beyond [`HANDLED_SCATTER`] times the log's typical scatter, with that ratio; none for
/// other streams.
fn scattered_blocks(time_s: &[f64], output: &[f64], rate_dps: &[f64]) -> Vec<(Vec<usize>, f64)> {
    let refs: Vec<f64> = rate_dps.iter().copied().filter(|r| r.is_finite()).collect();
    if refs.is_empty() || refs.iter().any(|r| *r != refs[0]) {
        return Vec::new();
    }
    let scored: Vec<usize> = (0..time_s.len())
        .filter(|&i| rate_dps[i].is_finite())
        .collect();
    let scatter = |b: &[usize]| {
        let m = b.iter().map(|&i| output[i]).sum::<f64>() / b.len() as f64;
        (b.iter().map(|&i| (output[i] - m).powi(2)).sum::<f64>() / b.len() as f64).sqrt()
    };
    let spread: Vec<(Vec<usize>, f64)> = blocks::group(time_s, &scored)
        .into_iter()
        .filter(|b| b.len() >= 2)
        .map(|b| {
            let s = scatter(&b);
            (b, s)
        })
        .collect();
    if spread.len() < HANDLED_MIN_BLOCKS {
        return Vec::new();
    }
    let mut sorted: Vec<f64> = spread.iter().map(|(_, s)| *s).collect();
    sorted.sort_by(f64::total_cmp);
    let typical = sorted[sorted.len() / 2];
    if typical <= 0.0 {
        return Vec::new();
    }
    spread
        .into_iter()
        .filter(|(_, s)| *s > HANDLED_SCATTER * typical)
        .map(|(b, s)| (b, s / typical))
        .collect()
}

/// The handled windows of `blocks` (rows and scatter ratio), in time order, with their references
/// removed from every one of `rates` (a unit's channels are handled together).
fn mark_handled(
    blocks: Vec<(Vec<usize>, f64)>,
    time_s: &[f64],
    lines: &[u64],
    rates: &mut [&mut Vec<f64>],
) -> Vec<Handled> {
    let t0 = time_s.first().copied().unwrap_or(0.0);
    let mut out: Vec<Handled> = blocks
        .into_iter()
        .map(|(b, ratio)| {
            for rate in rates.iter_mut() {
                for &i in &b {
                    rate[i] = f64::NAN;
                }
            }
            Handled {
                line: lines[b[0]],
                span_s: [time_s[b[0]] - t0, time_s[b[b.len() - 1]] - t0],
                n: b.len(),
                scatter_ratio: ratio,
                asked: false,
            }
        })
        .collect();
    out.sort_by(|a, b| a.span_s[0].total_cmp(&b.span_s[0]));
    out
}

/// The handled windows of a static log (every reference the same: the unit at rest), and
/// their references removed; other streams are left alone.
fn screen_handling(
    time_s: &[f64],
    output: &[f64],
    rate_dps: &mut Vec<f64>,
    lines: &[u64],
) -> Vec<Handled> {
    let blocks = scattered_blocks(time_s, output, rate_dps);
    mark_handled(blocks, time_s, lines, &mut [rate_dps])
}

/// The handled windows of a unit's log, screened on every channel (a minute where any channel
/// scatters is one where the unit was handled, with the largest ratio of them), removed from every
/// channel's references.
pub(crate) fn screen_unit_handling(
    time_s: &[f64],
    channels: &mut [(Vec<f64>, Vec<f64>)],
    lines: &[u64],
) -> Vec<Handled> {
    let mut blocks: Vec<(Vec<usize>, f64)> = Vec::new();
    for (output, rate) in channels.iter() {
        for (b, ratio) in scattered_blocks(time_s, output, rate) {
            match blocks.iter_mut().find(|(seen, _)| seen[0] == b[0]) {
                Some((seen, r)) => {
                    if b.len() > seen.len() {
                        *seen = b;
                    }
                    *r = r.max(ratio);
                }
                None => blocks.push((b, ratio)),
            }
        }
    }
    let mut rates: Vec<&mut Vec<f64>> = channels.iter_mut().map(|(_, r)| r).collect();
    mark_handled(blocks, time_s, lines, &mut rates)
}

/// The typical step of `time_s` and its problems (steps back, repeated stamps, gaps), one per row
/// where they show.
pub(crate) fn time_checks(time_s: &[f64], lines: &[u64]) -> (f64, Vec<TimeIssue>) {
    let typical = typical_step(time_s);
    let issues = time_s
        .windows(2)
        .zip(&lines[1..])
        .filter_map(|(w, &line)| {
            let step_s = w[1] - w[0];
            if step_s < 0.0 {
                Some(TimeIssue::Backwards { line, step_s })
            } else if step_s == 0.0 {
                Some(TimeIssue::Duplicate { line })
            } else if step_s > GAP_FACTOR * typical {
                Some(TimeIssue::Gap { line, step_s })
            } else {
                None
            }
        })
        .collect();
    (typical, issues)
}

/// The typical (median) forward step of `time_s`, s; 1 s where it has none.
pub fn typical_step(time_s: &[f64]) -> f64 {
    let mut steps: Vec<f64> = time_s
        .windows(2)
        .map(|w| w[1] - w[0])
        .filter(|d| *d > 0.0)
        .collect();
    steps.sort_by(f64::total_cmp);
    steps.get(steps.len() / 2).copied().unwrap_or(1.0)
}

impl Stream {
    /// Loads a stream CSV (any delimiter and column names, through `maps`).
    pub fn load(path: &Path, maps: &[ColumnMap]) -> Result<Self, DataError> {
        let c = columns::read_columns(
            path,
            &["time_s", "temp_c", "voltage_v", "rate_dps"],
            &["rate_dps"],
            &[],
            maps,
        )?;
        Ok(Self::checked(
            c.get("time_s").to_vec(),
            c.get("temp_c").to_vec(),
            c.get("voltage_v").to_vec(),
            c.get("rate_dps").to_vec(),
            c.lines,
        ))
    }

    /// A stream of columns held in memory (a notebook's arrays), checked as a loaded one is: its
    /// time problems found and its handled minutes screened. Row `i` is numbered as line `i + 2`
    /// of a CSV with a header. `rate_dps` is NaN where the reference is unknown; the columns are
    /// of one length.
    pub fn from_columns(
        time_s: Vec<f64>,
        temp_c: Vec<f64>,
        voltage_v: Vec<f64>,
        rate_dps: Vec<f64>,
    ) -> Result<Self, DataError> {
        let n = time_s.len();
        for (name, len) in [
            ("temp_c", temp_c.len()),
            ("voltage_v", voltage_v.len()),
            ("rate_dps", rate_dps.len()),
        ] {
            if len != n {
                return Err(DataError::ColumnLength {
                    column: name,
                    len,
                    expected: n,
                });
            }
        }
        let lines = (2..n as u64 + 2).collect();
        Ok(Self::checked(time_s, temp_c, voltage_v, rate_dps, lines))
    }

    /// The stream of these columns, its time checked and its handled minutes screened.
    fn checked(
        time_s: Vec<f64>,
        temp_c: Vec<f64>,
        voltage_v: Vec<f64>,
        mut rate_dps: Vec<f64>,
        lines: Vec<u64>,
    ) -> Self {
        let (typical, time_issues) = time_checks(&time_s, &lines);
        let handled = screen_handling(&time_s, &voltage_v, &mut rate_dps, &lines);
        Self {
            time_s,
            temp_c,
            voltage_v,
            rate_dps,
            lines,
            step_s: typical,
            time_issues,
            handled,
            history: 0,
            after_s: None,
        }
    }

    /// The samples inside `window` (seconds from the first sample), with the time problems among
    /// them, and those before it kept as its history ([`Stream::history`]): a window is a part of
    /// the log's power-on, not a power-on of its own. A gyro's firmware ran from the power-on
    /// through the samples before it, so its time since power-on, temperature rate, coil
    /// estimate and heating/cooling state there are those the whole log gives; a window whose
    /// first sample started them afresh had a model fitted on the later half of a three-day log
    /// learn a heating/cooling state it never has in service (156 °/h held out, against the
    /// static model's 7.9, on the simulated room log, docs/uncertainty.md). The samples after it
    /// are left out. Times stay counted from the log's first sample.
    pub fn window(&self, window: Window) -> Self {
        let t0 = self.time_s.first().copied().unwrap_or(0.0);
        // From the first sample inside to the last (a clock that jumps back at a power cycle, or
        // one stray time stamp, can put samples outside between them: their references go).
        let inside = |i: &usize| window.contains(self.time_s[*i] - t0);
        let first = (0..self.len()).find(inside).unwrap_or(self.len());
        let kept = (0..self.len()).rev().find(inside).map_or(first, |i| i + 1);
        let history = first.max(self.history).min(kept);
        let mut rate_dps = self.rate_dps[..kept].to_vec();
        for (i, r) in rate_dps.iter_mut().enumerate() {
            if i < history || !inside(&i) {
                *r = f64::NAN;
            }
        }
        let lines = self.lines[..kept].to_vec();
        let rows: Vec<usize> = (history..kept).filter(inside).collect();
        // The first sample after it with a reference, in the same power-on: a minute left out
        // or handled there held nothing to fit.
        let restarts = self.restart_lines();
        let mut after_s = self.after_s;
        for i in kept..self.len() {
            if restarts.contains(&self.lines[i]) {
                after_s = None;
                break;
            }
            if self.rate_dps[i].is_finite() {
                after_s = Some(self.time_s[i]);
                break;
            }
        }
        Self {
            time_s: self.time_s[..kept].to_vec(),
            temp_c: self.temp_c[..kept].to_vec(),
            voltage_v: self.voltage_v[..kept].to_vec(),
            rate_dps,
            step_s: self.step_s,
            time_issues: self
                .time_issues
                .iter()
                .filter(|i| lines.contains(&i.line()) && Some(i.line()) != lines.first().copied())
                .cloned()
                .collect(),
            handled: self
                .handled
                .iter()
                .filter_map(|h| h.within(&self.time_s, &self.lines, &rows, t0))
                .collect(),
            lines,
            history,
            after_s,
        }
    }

    /// The file lines where the gyro was powered on again ([`TimeIssue::is_restart`]).
    pub fn restart_lines(&self) -> std::collections::HashSet<u64> {
        self.time_issues
            .iter()
            .filter(|i| i.is_restart())
            .map(TimeIssue::line)
            .collect()
    }

    /// The samples of the window a command was given: those after the log's history before it
    /// ([`Stream::history`]).
    pub fn inside(&self) -> std::ops::Range<usize> {
        self.history.min(self.len())..self.len()
    }

    /// Leaves the samples inside `windows` (s from the first sample) out of every fit and score:
    /// their references are removed, and each window is recorded with the handled ones. A window
    /// that holds no sample is reported as such.
    pub fn exclude(&mut self, windows: &[Window]) -> Result<(), DataError> {
        let t0 = self.time_s.first().copied().unwrap_or(0.0);
        for w in windows {
            let rows: Vec<usize> = (0..self.len())
                .filter(|&i| w.contains(self.time_s[i] - t0))
                .collect();
            let (Some(&first), Some(&last)) = (rows.first(), rows.last()) else {
                return Err(DataError::EmptyWindow(w.to_string()));
            };
            for &i in &rows {
                self.rate_dps[i] = f64::NAN;
            }
            self.handled.push(Handled {
                line: self.lines[first],
                span_s: [self.time_s[first] - t0, self.time_s[last] - t0],
                n: rows.len(),
                scatter_ratio: 0.0,
                asked: true,
            });
        }
        self.handled
            .sort_by(|a, b| a.span_s[0].total_cmp(&b.span_s[0]));
        Ok(())
    }

    /// Whether each sample lies in a handled window ([`Stream::handled`]): from the window's
    /// first line on, as far as its span reaches along the clock.
    pub fn handled_rows(&self) -> Vec<bool> {
        let mut rows = vec![false; self.len()];
        for h in &self.handled {
            let Some(first) = self.lines.iter().position(|&l| l == h.line) else {
                continue;
            };
            let (start, span) = (self.time_s[first], h.span_s[1] - h.span_s[0]);
            // The window's rows: as long as the clock runs on from its first, within its span.
            let within = self.time_s[first..]
                .windows(2)
                .take_while(|w| w[1] >= w[0] && w[1] - start <= span)
                .count();
            for row in &mut rows[first..=first + within] {
                *row = true;
            }
        }
        rows
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.time_s.len()
    }

    /// Indices of the samples with a reference rate: what fits and scores use.
    pub fn referenced(&self) -> Vec<usize> {
        (0..self.len())
            .filter(|&i| self.rate_dps[i].is_finite())
            .collect()
    }

    /// The samples `scored` grouped into [`blocks::BLOCK_S`] blocks, those at least half filled:
    /// what every 60 s score counts.
    pub fn half_filled_blocks(&self, scored: &[usize]) -> Vec<Vec<usize>> {
        let need = (0.5 * blocks::BLOCK_S / self.step_s).ceil().max(1.0) as usize;
        blocks::group(&self.time_s, scored)
            .into_iter()
            .filter(|b| b.len() >= need)
            .collect()
    }

    /// True when empty (never, once loaded).
    pub fn is_empty(&self) -> bool {
        self.time_s.is_empty()
    }
}

/// A span of a stream, `START:END` in seconds from its first sample; either end may be left open
/// (`:2400`, `2400:`). The start is inside, the end outside.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
pub struct Window {
    /// Start, s (open: from the first sample).
    pub start_s: Option<f64>,
    /// End, s (open: to the last sample).
    pub end_s: Option<f64>,
}

impl Window {
    /// Whether `t` (s from the first sample) lies inside.
    pub fn contains(&self, t: f64) -> bool {
        self.start_s.is_none_or(|s| t >= s) && self.end_s.is_none_or(|e| t < e)
    }
}

/// A window that does not parse.
#[derive(Debug, thiserror::Error)]
#[error("window '{0}': expected START:END in seconds from the first sample, e.g. 0:2400 or 2400:")]
pub struct BadWindow(String);

impl fmt::Display for Window {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let end = |v: Option<f64>| v.map_or(String::new(), |v| v.to_string());
        write!(f, "{}:{}", end(self.start_s), end(self.end_s))
    }
}

impl std::str::FromStr for Window {
    type Err = BadWindow;

    fn from_str(text: &str) -> Result<Self, Self::Err> {
        let bad = || BadWindow(text.to_owned());
        let (a, b) = text.split_once(':').ok_or_else(bad)?;
        let end = |v: &str| -> Result<Option<f64>, BadWindow> {
            let v = v.trim();
            if v.is_empty() {
                return Ok(None);
            }
            let x: f64 = v.parse().map_err(|_| bad())?;
            if x.is_finite() {
                Ok(Some(x))
            } else {
                Err(bad())
            }
        };
        let w = Self {
            start_s: end(a)?,
            end_s: end(b)?,
        };
        match (w.start_s, w.end_s) {
            (Some(s), Some(e)) if e <= s => Err(bad()),
            _ => Ok(w),
        }
    }
}

#[cfg(test)]
mod tests;
