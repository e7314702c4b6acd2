//! A held-out window of the calibration's own log (`replay --calibration-run`): where the
//! calibration's power-on runs in it, and how long each sample lies from the data the model was
//! fitted on.
//!
//! The calibration's data are taken to be the rest of the log's power-on beside the window: before
//! it (a window after the log's first sample keeps the samples before it as its history,
//! [`Stream::history`]) and after it (the log goes on past the window in the same power-on,
//! [`Stream::after_s`]). The model error's time terms are fitted on the hours since the data a
//! model saw, so the σ counts them from the nearer of the two: forward from the window's start,
//! back from its end. Counted from the power-on instead, a window before the data (a three-day
//! log fitted on its later half and scored on its earlier) had them smallest where it lies
//! furthest from the data fitted.

use firmware_core::FeatureState;
use firmware_core::units::SECONDS_PER_HOUR;

use crate::stream::Stream;

/// Where a replay meets the calibration's own power-on ([`FeatureState::calibration_run`]).
#[derive(Debug, Clone, Copy)]
pub(super) struct HeldOut {
    /// The sample where the calibration's power-on begins, `None` in service: the window's first
    /// where the data lie before it (a power cycle in the history ended the power-on the walk
    /// started in); where they lie after it only, the window's last power-on, the one they go on
    /// from; the first sample otherwise.
    begins: Option<usize>,
    /// The window's first time, s, where the calibration's data lie before it.
    from_s: Option<f64>,
    /// The log's first time after the window, s, where they lie after it.
    until_s: Option<f64>,
}

impl HeldOut {
    /// The calibration's power-on in `stream`, powered on again at `restarts`; none without
    /// `calibration_run` (in service every power-on is another).
    pub(super) fn new(stream: &Stream, restarts: &[bool], calibration_run: bool) -> Self {
        let from_s = match stream.history {
            0 => None,
            h => stream.time_s.get(h).copied(),
        };
        let until_s = stream.after_s;
        let begins = match (from_s, until_s) {
            (Some(_), _) => stream.history,
            (None, Some(_)) => restarts.iter().rposition(|r| *r).unwrap_or(0),
            (None, None) => 0,
        };
        Self {
            begins: calibration_run.then_some(begins),
            from_s,
            until_s,
        }
    }

    /// Whether the calibration's power-on begins at sample `i`.
    pub(super) fn begins_at(&self, i: usize) -> bool {
        self.begins == Some(i)
    }

    /// The hours from the calibration's data to sample `i` of `stream`, once the feature state
    /// has taken it (`state`): the nearer of the window's start (at most the time since power-on)
    /// and the log's first time after it. `None` outside the calibration's power-on, and for a
    /// whole log: the time terms then read the time since power-on, as in service.
    pub(super) fn hours(&self, stream: &Stream, i: usize, state: &FeatureState) -> Option<f32> {
        if !state.in_calibration_run() {
            return None;
        }
        let t = *stream.time_s.get(i)?;
        let since = self
            .from_s
            .map(|from| (t - from).max(0.0).min(state.time_on_s()));
        let until = self.until_s.map(|until| (until - t).max(0.0));
        let s = match (since, until) {
            (Some(a), Some(b)) => a.min(b),
            (a, b) => a.or(b)?,
        };
        Some((s / SECONDS_PER_HOUR) as f32)
    }
}
