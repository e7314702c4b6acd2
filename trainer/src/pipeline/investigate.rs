//! `trainer investigate` as a library pipeline: on a log's training part, the static model, its
//! diagnosis and the extension it calls for; both models scored forward in time on the held-out
//! part; the one that ships, and its σ: every channel of a unit ([`InvestigatePlan::unit`]; one
//! channel is a unit of one). Reading the logs and splitting off the held-out part, and writing
//! what comes back, are the caller's.

use std::path::Path;

use fog_data::cause::Cause;
use fog_data::channels::{Channels, Datasheet};
use fog_data::sigma;
use fog_data::stream::Stream;
use serde::Serialize;

use crate::analysis::diagnose::causes_text;
use crate::analysis::investigate::{self, Blobs, Investigation};
use crate::firmware::export::ExportError;
use crate::firmware::unit;
use crate::models::gp::GpConfig;
use crate::pipeline::ChannelEntry;
use crate::pipeline::source::PointFiles;
use crate::pipeline::text::render_diagnosis;
use crate::progress::Messages;
use firmware_core::blob::unit::ChannelBlob;

/// `trainer investigate`'s settings, checked once by whoever built them.
#[derive(Clone, Debug)]
pub struct InvestigatePlan {
    /// Where the static model's points come from.
    pub source: PointFiles,
    /// The GP's settings.
    pub gp: GpConfig,
    /// The causes to extend by; `None`: those the diagnosis names.
    pub asked: Option<Vec<Cause>>,
    /// The held-out part is the training log's later part: the calibration's own power-on, its
    /// σ scored without another power-on's bias and scale up to its first power cycle. Else it
    /// is a log of its own, another power-on, scored as in service.
    pub calibration_run: bool,
    /// A datasheet's figures, the command's (each channel's own in its `[[channel]]` before
    /// them); each `None`: measured, assumed or left out, as `fit` does.
    pub sheet: Datasheet,
}

/// A unit investigated: each channel's investigation and blobs, in the unit's order.
pub struct UnitInvestigated {
    /// Each channel's investigation and its two blobs.
    pub each: Vec<(Investigation, Blobs)>,
}

/// What `investigate --json` writes for a unit: each channel's investigation, its figures in
/// `units` (the `_dps` fields too).
#[derive(Serialize, schemars::JsonSchema)]
pub struct UnitInvestigation<'a> {
    /// The sensor's ID.
    pub sensor_id: &'a str,
    /// Each channel's investigation.
    pub channels: Vec<ChannelEntry<'a, Investigation>>,
}

impl InvestigatePlan {
    /// One channel's investigation, said as it goes: the static fit, diagnosis and extension on
    /// `train` (read from `train_path`), both models scored on `valid`.
    fn channel(
        &self,
        (train_path, train, valid): (&Path, Stream, Stream),
        messages: &dyn Messages,
    ) -> anyhow::Result<(Investigation, Blobs)> {
        let source = &self.source;
        let train = [(train_path, train)];
        let points = source.static_points(&train, false, messages)?;
        let [(_, train)] = train;
        let rebuild =
            |part: &Stream| source.static_points(&[(train_path, part.clone())], false, messages);
        let progress = messages.counted();
        let (inv, blobs) = investigate::investigate(
            &points,
            &train,
            (&valid, self.calibration_run),
            &self.gp,
            investigate::Told {
                asked: self.asked.as_deref(),
                sheet: self.sheet,
            },
            &rebuild,
            &*progress,
        )?;
        drop(progress);
        for w in &inv.warnings {
            messages.warn(w);
        }
        let (k, u, unit) = (
            points.quantity.bias_per_unit(),
            points.quantity.bias_unit(),
            points.quantity.unit(),
        );
        if let Some(c) = &inv.basis_choice {
            messages.result(&format!("prior mean: {}", c.verdict));
        }
        if let Some(c) = &inv.centres_choice {
            messages.result(&c.verdict);
        }
        messages.result(render_diagnosis(&inv.diagnosis).trim_end());
        messages.result(&format!("shipped {:?}: {}", inv.shipped, inv.verdict));
        messages.result(&format!(
            "static rmse_60s {:.3e} {unit} ({:.2} {u}) | causes {} | added {} | shipped \
             rmse_60s {:.3e} {unit} ({:.2} {u}) | gain {:.2}× {}",
            inv.static_score.rmse_60s_dps,
            inv.static_score.rmse_60s_dps * k,
            causes_text(&inv.diagnosis.causes),
            if inv.added_inputs.is_empty() {
                "nothing".to_owned()
            } else {
                inv.added_inputs.join(", ")
            },
            inv.extended_score.rmse_60s_dps,
            inv.extended_score.rmse_60s_dps * k,
            inv.gain,
            inv.extended_score.counted()
        ));
        messages.result(&format!("beyond the trained range: {}", inv.beyond.verdict));
        messages.result(&format!(
            "shipped model's {}",
            inv.calibration.describe(unit)
        ));
        let stated = self.sheet.scale_repeatability.is_some();
        for line in inv.calibration.skipped_lines(stated) {
            messages.result(&line);
        }
        let scored_as = if self.calibration_run {
            "scored as the calibration's own power-on"
        } else {
            "scored as another power-on"
        };
        messages.result(&format!(
            "on the held-out stream ({scored_as}), the shipped model's σ: {}",
            sigma::describe(
                &inv.extended_score.sigma_samples,
                &inv.extended_score.sigma_60s
            )
        ));
        Ok((inv, blobs))
    }

    /// Every channel of `channels` investigated as one channel is, on its training and held-out
    /// parts (`train`, `valid`: one stream per channel, read from `train_path`); their held-out
    /// figures said in one table at the end.
    pub fn unit(
        &self,
        channels: &Channels,
        (train_path, train, valid): (&Path, &[Stream], &[Stream]),
        messages: &dyn Messages,
    ) -> anyhow::Result<UnitInvestigated> {
        let mut each = Vec::new();
        for (k, ch) in channels.list.iter().enumerate() {
            let heading = channels.heading(k, ch.quantity.unit());
            let said = messages.channel(channels.label(k), &heading);
            let plan = Self {
                source: self.source.for_channel(channels, k)?,
                sheet: ch.datasheet.or(self.sheet),
                ..self.clone()
            };
            let one = channels.in_channel(
                k,
                plan.channel((train_path, train[k].clone(), valid[k].clone()), &*said),
            )?;
            each.push(one);
        }
        let investigated = UnitInvestigated { each };
        messages.result(&investigated.gains(channels));
        Ok(investigated)
    }
}

impl UnitInvestigated {
    /// The unit's blob of each channel's extended (`Blobs::extended_blob`) or static model.
    pub fn blob(
        &self,
        channels: &Channels,
        pick: fn(&Blobs) -> &Vec<u8>,
    ) -> Result<Vec<u8>, ExportError> {
        let parts: Vec<ChannelBlob<'_>> = channels
            .list
            .iter()
            .zip(&self.each)
            .map(|(ch, (_, b))| ChannelBlob {
                name: &ch.name,
                quantity: ch.quantity,
                model: pick(b),
            })
            .collect();
        unit::unit_blob(&channels.sensor_id, &parts)
    }

    /// What `investigate --json` writes of it, for `channels`.
    pub fn report<'a>(&'a self, channels: &'a Channels) -> UnitInvestigation<'a> {
        UnitInvestigation {
            sensor_id: &channels.sensor_id,
            channels: channels
                .list
                .iter()
                .zip(&self.each)
                .map(|(ch, (inv, _))| ChannelEntry::new(ch, inv))
                .collect(),
        }
    }

    /// The unit's investigation in one table: each channel's held-out figures, static and
    /// shipped, in its bias unit, with its causes and gain.
    fn gains(&self, channels: &Channels) -> String {
        let mut s = String::from(
            "held out, rmse_60s:  static          shipped         gain   causes named (shipped)\n",
        );
        let mut counted = String::new();
        for (ch, (inv, _)) in channels.list.iter().zip(&self.each) {
            let (k, u) = (ch.quantity.bias_per_unit(), ch.quantity.bias_unit());
            s.push_str(&format!(
                "  {:<16} {:>9.3} {u:<4}  {:>9.3} {u:<4}  {:>5.2}×  {} ({})\n",
                ch.name,
                inv.static_score.rmse_60s_dps * k,
                inv.extended_score.rmse_60s_dps * k,
                inv.gain,
                causes_text(&inv.diagnosis.causes),
                match inv.shipped {
                    investigate::Shipped::Extended => "extended",
                    investigate::Shipped::Static => "static",
                }
            ));
            counted.push_str(&format!(
                "  {:<16} {}\n",
                ch.name,
                inv.extended_score.counted()
            ));
        }
        s + &counted
    }
}
