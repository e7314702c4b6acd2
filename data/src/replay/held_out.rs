//! A held-out window of the calibration's own log (`replay --calibration-run`): where the
//! calibration's power-on runs in it, and how long each sample lies from the data the model was
//! fitted on.
//!
//! The calibration's data are taken to be the rest of the log beside the window, in the power-ons
//! the window shares with it: before it (a window after the log's first sample keeps the samples
//! before it as its history, [`Stream::history`]) and after it (the log's references resume past
//! the window in the power-on of the window's last sample, [`Stream::after_s`]). The model error's
//! time terms are fitted on the hours since the data a model saw, so the σ counts them from the
//! data of the sample's power-on: forward from the window's start in its first power-on, back from
//! where the data resume after it in its last, from the nearer of the two where that is one
//! power-on. A power-on between is another, as in service. A window's first power-on counts as
//! the calibration's even where a power cycle in its history, or at its first sample, parted it
//! from the data before: the window was asked for as the held-out part of the calibration's own
//! log. Counted from the power-on instead, a window before the data (a three-day log fitted on
//! its later half and scored on its earlier) had them smallest where it lies furthest from the
//! data fitted.

use firmware_core::FeatureState;
use firmware_core::units::SECONDS_PER_HOUR;

use crate::stream::Stream;

/// Where a replay meets the calibration's own power-on ([`FeatureState::calibration_run`]).
#[derive(Debug, Clone)]
pub(super) struct HeldOut {
    /// The samples where a power-on of the calibration's begins; none in service. A whole log's
    /// first; a window's first where the data lie before it, and its last power-on's first where
    /// they lie after it.
    begins: Vec<usize>,
    /// Where the data lie before the window: its first time, s, and the window's first power
    /// cycle (the samples before it count forward from that time).
    from: Option<(f64, usize)>,
    /// Where they lie after it: the log's first time with a reference after the window, s, and the
    /// first sample of the window's last power-on (the samples from it count back from that
    /// time).
    until: Option<(f64, usize)>,
}

impl HeldOut {
    /// The calibration's power-ons in `stream`, powered on again at `restarts`; none without
    /// `calibration_run` (in service every power-on is another).
    pub(super) fn new(stream: &Stream, restarts: &[bool], calibration_run: bool) -> Self {
        let start = stream.history.min(restarts.len());
        let cycles: Vec<usize> = (start + 1..restarts.len())
            .filter(|&i| restarts[i])
            .collect();
        let first_cycle = cycles.first().copied().unwrap_or(restarts.len());
        let last_on = cycles.last().copied().unwrap_or(start);
        let from = match start {
            0 => None,
            _ => stream.time_s.get(start).map(|&t| (t, first_cycle)),
        };
        let until = stream.after_s.map(|t| (t, last_on));
        let begins = match (calibration_run, from, until) {
            (false, ..) => Vec::new(),
            (true, None, None) => vec![0],
            (true, from, until) => from
                .map(|_| start)
                .into_iter()
                .chain(until.map(|_| last_on))
                .collect(),
        };
        Self {
            begins,
            from,
            until,
        }
    }

    /// Whether a power-on of the calibration's begins at sample `i`.
    pub(super) fn begins_at(&self, i: usize) -> bool {
        self.begins.contains(&i)
    }

    /// The hours from the calibration's data to sample `i` of `stream`, once the feature state
    /// has taken it (`state`): forward from the window's start in its first power-on (at most the
    /// time since power-on), back from the log's first referenced time after it in its last, the
    /// nearer where both. `None` outside the calibration's power-ons, and for a whole log: the time
    /// terms then read the time since power-on, as in service.
    pub(super) fn hours(&self, stream: &Stream, i: usize, state: &FeatureState) -> Option<f32> {
        if !state.in_calibration_run() {
            return None;
        }
        let t = *stream.time_s.get(i)?;
        let since = self
            .from
            .filter(|(_, cycle)| i < *cycle)
            .map(|(from, _)| (t - from).max(0.0).min(state.time_on_s()));
        let until = self
            .until
            .filter(|(_, on)| i >= *on)
            .map(|(until, _)| (until - t).max(0.0));
        let s = match (since, until) {
            (Some(a), Some(b)) => a.min(b),
            (a, b) => a.or(b)?,
        };
        Some((s / SECONDS_PER_HOUR) as f32)
    }
}
