//! The forward check of an extension inside the training stream, on its splits
//! ([`super::split`]): what each check found ([`ForwardCheck`], its [`TemperatureCheck`] and
//! [`LegCheck`]s) and the rule each votes by ([`vote`]).

use fog_data::cause::Cause;
use serde::Serialize;

use crate::analysis::diagnose;
use crate::analysis::uncertainty::ResidualSource;

use super::split::{Fitted, Forward, Sight, Split, forward, inside, splits};

/// Do no harm: the extension of the named causes fitted on the earlier part of the training
/// stream (the static model too, where it was fitted on the stream), both scored on the later
/// part. The causes are those the whole training stream names: running the whole diagnosis again
/// on the earlier part was measured and is too conservative (docs/diagnosis.md).
#[derive(Debug, Clone, Serialize, schemars::JsonSchema)]
pub struct ForwardCheck {
    /// Where the stream was cut, s from its first sample.
    pub split_s: f64,
    /// 60 s blocks before the cut.
    pub earlier_blocks: usize,
    /// 60 s blocks after it.
    pub later_blocks: usize,
    /// The causes fitted on the earlier part (named on the whole training stream, or asked for).
    pub causes: Vec<Cause>,
    /// Static `rmse_60s_dps` on the later part.
    pub static_rmse_60s_dps: f64,
    /// Extended `rmse_60s_dps` on the later part (the static one where nothing was named).
    pub extended_rmse_60s_dps: f64,
    /// What the later part could see of the extension ([`Sight`]).
    pub sight: Sight,
    /// The static model's residual over the whole training stream, its 60 s means about their
    /// mean (RMS): what the harm a test that cannot see the extension measures is weighed against
    /// where the part it scores is quieter ([`vote`]), as the diagnosis weighs a first cause.
    pub residual_60s_dps: f64,
    /// The same test across temperature, where the static model is fitted on the stream itself
    /// (absent with a rate table, or where either side is too short).
    pub temperature: Option<TemperatureCheck>,
    /// The same test across the heating/cooling legs, each way the stream holds enough of both.
    pub legs: Vec<LegCheck>,
}

impl ForwardCheck {
    /// Whether the extension passes: better than the static model on the later part and outside
    /// the temperatures it was fitted on, each where that test could see it; no harm where it
    /// could not ([`vote`]). The diagnosis' interleaved test,
    /// which named the causes, always sees them.
    pub fn extension_helps(&self) -> bool {
        !self.causes.is_empty()
            && vote(
                self.static_rmse_60s_dps,
                self.extended_rmse_60s_dps,
                &self.sight,
                self.residual_60s_dps,
            )
            && self
                .temperature
                .as_ref()
                .is_none_or(|t| t.extension_helps(self.residual_60s_dps))
            && self.legs_pass()
    }

    /// Whether the leg checks pass: none could be made, or the extension wins on at least one
    /// leg it was not fitted on ([`LegCheck`]).
    pub fn legs_pass(&self) -> bool {
        self.legs.is_empty()
            || self
                .legs
                .iter()
                .any(|l| l.extension_helps(self.residual_60s_dps))
    }
}

/// Do no harm on the other heating/cooling leg: a firmware calibrated on a stream meets the leg
/// it holds less of (a cool-down after a warm-up), and a cause named on one leg can be the other
/// leg's difference in disguise (a warm-up that coincides with a log's first cooling). Both
/// models are fitted on the samples of one leg, as the firmware tracks it
/// (`firmware_core::FeatureState::leg`), and scored on the other's, the whole stream replayed,
/// each way the stream holds enough of both. The extension must win on at least one: a leg
/// scored before the one fitted asks a transient fitted late to say what it was early, which a
/// real warm-up fails as often as a false one (on the simulated cool-downs, every seed), but a
/// cause that loses on both legs explains neither (the MEMS log's acc.z, whose warm-up, named
/// on the training stream, is 1.5× worse than static held out).
#[derive(Debug, Clone, Serialize, schemars::JsonSchema)]
pub struct LegCheck {
    /// The leg fitted on, `heating` or `cooling`; the other is scored.
    pub fitted_on: &'static str,
    /// 60 s blocks fitted on.
    pub fitted_blocks: usize,
    /// 60 s blocks of the other leg, scored.
    pub scored_blocks: usize,
    /// Static `rmse_60s_dps` on the other leg.
    pub static_rmse_60s_dps: f64,
    /// Extended `rmse_60s_dps` on the other leg.
    pub extended_rmse_60s_dps: f64,
    /// What the other leg could see of the extension ([`Sight`]).
    pub sight: Sight,
}

impl LegCheck {
    /// Whether the extension passes on the other leg ([`vote`]; `residual`:
    /// [`ForwardCheck::residual_60s_dps`]).
    pub fn extension_helps(&self, residual: f64) -> bool {
        vote(
            self.static_rmse_60s_dps,
            self.extended_rmse_60s_dps,
            &self.sight,
            residual,
        )
    }
}

/// One test's vote on an extension: where it sees the extension, a gain; where it cannot, no
/// harm in what it can measure ([`Sight`]): the mean square it adds there must not raise the
/// larger of the scored part's own error and the training stream's `residual` (its 60 s means'
/// RMS about their mean) by more than [`diagnose::HARM`] ([`diagnose::raises`]). It abstains,
/// and the decision rests on the tests that could see (the diagnosis' interleaved test always
/// does). Weighed against the scored part's own error alone, a part at the noise of a 60 s mean
/// refused warm-ups of 30–48 °/h for tails a few tenths of °/h off there (docs/diagnosis.md).
pub fn vote(static_rmse: f64, extended_rmse: f64, sight: &Sight, residual: f64) -> bool {
    if sight.sees {
        extended_rmse < static_rmse
    } else {
        let [s, e] = sight.centred_rmse_60s_dps;
        !diagnose::raises(e * e - s * s, s * s, residual * residual)
    }
}

/// Do no harm beyond the trained temperatures: where the static curve is fitted on the stream
/// together with the extension, the extension also refits that curve, and a firmware meets
/// temperatures its training did not reach. Both models are fitted on the samples inside the
/// training span less a tenth of it at each end and scored on the samples outside (the whole
/// stream replayed, so stateful inputs keep their history). A state can win the forward test in
/// time and still fail beyond the trained temperatures, where a held-out part often lies
/// (docs/real-data.md, the MEMS thermal cycle's x axis).
#[derive(Debug, Clone, Serialize, schemars::JsonSchema)]
pub struct TemperatureCheck {
    /// The temperatures fitted on, °C.
    pub inside_c: (f64, f64),
    /// 60 s blocks inside.
    pub inside_blocks: usize,
    /// 60 s blocks outside, scored.
    pub outside_blocks: usize,
    /// Static `rmse_60s_dps` outside.
    pub static_rmse_60s_dps: f64,
    /// Extended `rmse_60s_dps` outside.
    pub extended_rmse_60s_dps: f64,
    /// What the samples outside could see of the extension ([`Sight`]).
    pub sight: Sight,
}

impl TemperatureCheck {
    /// Whether the extension passes outside ([`vote`]; `residual`:
    /// [`ForwardCheck::residual_60s_dps`]).
    pub fn extension_helps(&self, residual: f64) -> bool {
        vote(
            self.static_rmse_60s_dps,
            self.extended_rmse_60s_dps,
            &self.sight,
            residual,
        )
    }
}

/// The forward check of [`super::choose`] (`None` where the stream is too short for one), and the splits
/// it fitted; `residual_60s_dps` is [`ForwardCheck::residual_60s_dps`]. Blocks are counted as the
/// diagnosis counts them (samples with a reference).
pub(super) fn forward_check(
    fitted: Fitted<'_>,
    causes: &[Cause],
    residual_60s_dps: f64,
) -> anyhow::Result<(Option<ForwardCheck>, Vec<Split>)> {
    let splits = splits(fitted, causes)?;
    let train = fitted.train;
    let Some(Forward {
        split_s,
        earlier_blocks,
        later_blocks,
        ..
    }) = forward(train)
    else {
        return Ok((None, splits));
    };
    let scored = |source| splits.iter().find(|s| s.source == source);
    let Some(f) = scored(ResidualSource::Forward) else {
        return Ok((None, splits));
    };
    let (static_rmse, extended_rmse, sight) = f.scores()?;
    let temperature = match scored(ResidualSource::Temperature) {
        Some(t) if !causes.is_empty() => {
            let (static_rmse_60s_dps, extended_rmse_60s_dps, sight) = t.scores()?;
            let (inside_c, inside_blocks, outside_blocks) = inside(train);
            Some(TemperatureCheck {
                inside_c,
                inside_blocks,
                outside_blocks,
                static_rmse_60s_dps,
                extended_rmse_60s_dps,
                sight,
            })
        }
        _ => None,
    };
    let mut legs = Vec::new();
    if !causes.is_empty() {
        for split in splits.iter().filter(|s| s.source == ResidualSource::Leg) {
            let (static_rmse_60s_dps, extended_rmse_60s_dps, sight) = split.scores()?;
            let (fitted_on, fitted_blocks, scored_blocks) = split.leg.unwrap_or_default();
            legs.push(LegCheck {
                fitted_on,
                fitted_blocks,
                scored_blocks,
                static_rmse_60s_dps,
                extended_rmse_60s_dps,
                sight,
            });
        }
    }
    let check = ForwardCheck {
        split_s,
        earlier_blocks,
        later_blocks,
        causes: causes.to_vec(),
        static_rmse_60s_dps: static_rmse,
        extended_rmse_60s_dps: extended_rmse,
        sight,
        residual_60s_dps,
        temperature,
        legs,
    };
    Ok((Some(check), splits))
}
