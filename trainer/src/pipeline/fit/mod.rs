//! `trainer fit` as a library pipeline: a [`FitPlan`] (checked once by whoever built it, the
//! command line from its flags) run on the data already read: a unit's channels into one blob
//! ([`FitPlan::fit_unit`]; one channel's data is a unit of one). It returns the blobs and what
//! `fit --json` reports of them, and says its choices as it makes them ([`Messages`]); writing
//! the files is the caller's.
//!
//! A channel's fit: the static model on its points (its size chosen on the data where the
//! firmware cannot hold an exact GP, [`capacity`]); where a stream is pooled beside a rate table,
//! the check that decides which ships; the extension its diagnosis calls for, where it wins its
//! forward check; the σ of what ships, measured on the training data alone; then the service
//! settings ([`Service`]) written in, and the blob checked against the f32 firmware.

use std::path::Path;

use firmware_core::MAX_CENTRES;
use firmware_core::blob::Beyond;
use fog_data::autopilot::Mounting;
use fog_data::cause::Cause;
use fog_data::channels::{Channels, Datasheet};
use fog_data::replay::HostModel;
use fog_data::stream::Stream;

use crate::analysis::basis::{self, BasisChoice};
use crate::analysis::beyond::BeyondChoice;
use crate::analysis::budget::{self, Budget};
use crate::analysis::capacity;
use crate::analysis::diagnose::causes_text;
use crate::analysis::investigate::{self, Forward};
use crate::analysis::pool::{self, PoolCheck, Pooling};
use crate::analysis::table::{self, TableModel, Transients};
use crate::analysis::uncertainty::tables::StreamPoints;
use crate::analysis::uncertainty::{self, Calibration};
use crate::data::points::{self, Points};
use crate::firmware::autopilot::{AxisCubic, Cubic, SensorCubics};
use crate::firmware::export::{self, Extension};
use crate::firmware::unit;
use crate::models::gp::{AUTO_EXACT_MAX, GpConfig, GpModel, Inducing};
use crate::pipeline::ChannelEntry;
use crate::pipeline::source::PointFiles;
use crate::progress::Messages;
use firmware_core::blob::unit::ChannelBlob;

pub mod report;
mod service;
mod within_budget;

pub use report::{
    ChannelFit, ExtensionReport, FitReport, Inputs, StreamChoice, UnitFitReport, quantity_words,
    say_fit, unit_table,
};

/// A channel to size: its name, its plan and its loaded streams.
type Named<'a> = (&'a str, &'a FitPlan, &'a [(&'a Path, Stream)]);

/// What the static model is extended by, as `trainer fit` was asked.
#[derive(Clone, Debug)]
pub enum Extend {
    /// Nothing: the static model ships.
    Nothing,
    /// The transients of a rate table recorded in time order (`--features auto`, no stream).
    TableTransients,
    /// Inputs fitted on the one stream: those its diagnosis calls for (`None`: `auto`), or those
    /// of the causes named.
    Stream(Option<Vec<Cause>>),
}

/// `trainer fit`'s settings, checked once by whoever built them (the command line from its
/// flags): the pipeline only follows the plan.
#[derive(Clone)]
pub struct FitPlan {
    /// Where the static model's points come from.
    pub source: PointFiles,
    /// The GP's settings, as asked (its size resolved per channel).
    pub gp: GpConfig,
    /// Each group of the rate table its own offset (`--offsets`).
    pub offsets: bool,
    /// Every sample of the streams pooled with the points (`--pool-stream`).
    pub pool: bool,
    /// What the static model is extended by.
    pub extend: Extend,
    /// The target's budget (unset: the default sizes).
    pub budget: Budget,
    /// What the blob states for service.
    pub service: Service,
}

/// What the blob states for service: the sensor's rated range and full scale, a datasheet's
/// figures (the bias and scale of another power-on, the growth beyond the trained range, the
/// leg not trained), and the rule beyond the trained range.
#[derive(Clone, Debug, Default)]
pub struct Service {
    /// The rated temperature range, °C (default: the blob's, [`firmware_core::blob::Limits::DEFAULT`]).
    pub rated_temp: Option<(f32, f32)>,
    /// The output's full scale, in its units (default: none stated).
    pub full_scale: Option<f32>,
    /// What a datasheet states of the bias and scale of another power-on, the growth beyond the
    /// trained range and the leg not trained.
    pub sheet: Datasheet,
    /// The mean's rule beyond the trained range; `None`: chosen on the data.
    pub beyond: Option<Beyond>,
}

/// A unit fitted: each channel's fit, the unit's blob and what it costs, and the autopilots'
/// cubics where asked.
pub struct UnitFit {
    /// Each channel's model, in the unit's order.
    pub fitted: Vec<ChannelFit>,
    /// The unit's blob.
    pub blob: Vec<u8>,
    /// What the blob costs the firmware.
    pub footprint: unit::UnitFootprint,
    /// How the budget was met, where one was given.
    pub budget: Option<budget::Report>,
    /// The cubic per channel, for the autopilots' parameters (where asked).
    pub cubics: Option<SensorCubics>,
}

impl UnitFit {
    /// What `fit --json` writes of it, for `channels`.
    pub fn report<'a>(&'a self, channels: &'a Channels) -> UnitFitReport<'a> {
        UnitFitReport {
            sensor_id: &channels.sensor_id,
            temperature_c: self.footprint.temperature_c,
            channels: channels
                .list
                .iter()
                .zip(&self.fitted)
                .map(|(ch, f)| ChannelEntry::new(ch, &f.summary))
                .collect(),
            blob_bytes: self.blob.len(),
            footprint: &self.footprint,
            budget: self.budget.clone(),
            autopilot: self.cubics.as_ref(),
        }
    }
}

impl FitPlan {
    /// Every channel of a unit, each fitted as one channel is, into one blob. `logs` holds each
    /// log read (its path, then one stream per channel of `channels`); with `cubics`, the
    /// autopilots' cubic per channel is fitted on the same samples.
    pub fn fit_unit(
        &self,
        channels: &Channels,
        logs: &[(&Path, Vec<Stream>)],
        cubics: bool,
        messages: &dyn Messages,
    ) -> anyhow::Result<UnitFit> {
        let per_channel: Vec<(FitPlan, Vec<(&Path, Stream)>)> = (0..channels.len())
            .map(|k| {
                let plan = Self {
                    source: self.source.for_channel(channels, k)?,
                    service: self.service.for_channel(&channels.list[k]),
                    ..self.clone()
                };
                let streams: Vec<(&Path, Stream)> =
                    logs.iter().map(|(p, log)| (*p, log[k].clone())).collect();
                Ok((plan, streams))
            })
            .collect::<anyhow::Result<_>>()?;
        let named: Vec<Named<'_>> = channels
            .list
            .iter()
            .zip(&per_channel)
            .map(|(ch, (plan, s))| (ch.name.as_str(), plan, s.as_slice()))
            .collect();
        let (plans, budgeted) = self.within_budget(&named, messages)?;
        let mut fitted = Vec::new();
        for (k, ch) in channels.list.iter().enumerate() {
            let heading = channels.heading(
                k,
                &format!("{} in {}", quantity_words(ch.quantity), ch.quantity.unit()),
            );
            let said = messages.channel(channels.label(k), &heading);
            let (plan, chosen) = &plans[k];
            let one = channels.in_channel(k, plan.fit(&per_channel[k].1, chosen, &*said))?;
            say_fit(&*said, &one, (None, one.blob.len()), ch.quantity);
            fitted.push(one);
        }
        let parts: Vec<ChannelBlob<'_>> = channels
            .list
            .iter()
            .zip(&fitted)
            .map(|(ch, f)| ChannelBlob {
                name: &ch.name,
                quantity: ch.quantity,
                model: &f.blob,
            })
            .collect();
        let blob = unit::unit_blob(&channels.sensor_id, &parts)?;
        let footprint = unit::unit_footprint(&blob)?;
        self.check_fitted(&footprint)?;
        let cubics = cubics
            .then(|| {
                let streams = per_channel.iter().map(|c| c.1.iter().map(|s| &s.1));
                unit_cubics(channels, streams)
            })
            .transpose()?;
        Ok(UnitFit {
            fitted,
            blob,
            footprint,
            budget: budgeted,
            cubics,
        })
    }

    /// The static model on the loaded `streams` (with `--points`, the table), its extension and
    /// its σ: the blob, checked against the firmware, and what `fit` reports of it.
    /// `chosen`: the prior mean's basis as chosen before (to size the model within a budget),
    /// `self.gp` then holding it; `None`: chosen here where `self.gp` asks.
    fn fit(
        &self,
        streams: &[(&Path, Stream)],
        chosen: &Option<BasisChoice>,
        messages: &dyn Messages,
    ) -> anyhow::Result<ChannelFit> {
        // A pooled fit beside a table is checked on the streams cut forward in time: cut first,
        // so that a stream too short to check is refused before anything is fitted.
        let cuts = if self.pool && self.source.points.is_some() {
            Some(pool::forward_cuts(streams)?)
        } else {
            None
        };
        let points = self.source.static_points(streams, self.pool, messages)?;
        let spinner = messages.busy("choosing the prior mean's basis on temperature bands");
        let (gp, now) = basis::resolve(&points, &self.gp);
        drop(spinner);
        if let Some(c) = &now {
            messages.result(&format!("prior mean: {}", c.verdict));
        }
        let plan = Self { gp, ..self.clone() };
        let basis_choice = now.or_else(|| chosen.clone());
        plan.fit_points(streams, (points, cuts), basis_choice, messages)
    }

    /// [`Self::fit`] on the static `points` (and the streams' forward `cuts`, for a pooled fit
    /// beside a table), with the basis chosen (`basis_choice`, for the report).
    fn fit_points(
        &self,
        streams: &[(&Path, Stream)],
        (points, cuts): (Points, Option<Vec<Forward>>),
        basis_choice: Option<BasisChoice>,
        messages: &dyn Messages,
    ) -> anyhow::Result<ChannelFit> {
        let (gp, centres_choice) = self.size(&points, messages)?;
        let (points, model, table, pool_check) =
            self.static_model(points, &gp, (streams, cuts), messages)?;
        log_starts(messages, &model);
        // Before the f32 check: a warning may explain why it refuses the blob.
        for w in model.warnings() {
            messages.warn(&w);
        }
        let extension = table
            .as_ref()
            .map(TableModel::extension)
            .unwrap_or_default();
        let static_blob = export::points_blob(&model, &points, &extension)?;
        let (firmware, agreement) = export::verify(&model, &static_blob, &points, &extension)?;
        let mut summary = FitReport::new(&model, &points, agreement, static_blob.len());
        // Whether the shipped points hold the streams' samples beside a table's rows.
        let pooled = pool_check
            .as_ref()
            .is_some_and(|c| matches!(c.shipped, Pooling::Pooled));
        summary.pool_check = pool_check;
        summary.centres_choice = centres_choice;
        summary.basis_choice = basis_choice;
        if let Some(t) = &table {
            messages.result(&format!(
                "diagnosis of the table (time order): {}",
                t.diagnosis.verdict
            ));
            summary.table_diagnosis = Some(t.diagnosis.clone());
            summary.extension = Some(ExtensionReport::Table(extension.clone()));
            summary.features = Inputs::Firmware(firmware.features().to_vec());
        }
        // Chosen first: the σ assumed beyond the range is what the rule misses there.
        let beyond = self.service.beyond(&points, &gp);
        let shipped = match streams {
            [(path, data)] => self.on_stream(
                (path, data),
                (&points, &model, &firmware, &gp),
                &static_blob,
                &beyond,
                &mut summary,
                messages,
            )?,
            _ => None,
        };
        let (mut blob, mut calibration, exported_from) = match shipped {
            Some(s) => s,
            None => {
                let mut calibration = uncertainty::tables::pooled_calibration(
                    &points,
                    &model,
                    &gp,
                    Some(&beyond),
                    self.stream_points(streams, (&points, &firmware, pooled), messages)?
                        .as_ref(),
                )?;
                // The logs the shipped points hold: all of them without a table, or pooled with
                // one and shipped so; a table shipped alone beside them holds none.
                let fitted: Vec<&Stream> = if self.source.points.is_none() || pooled {
                    streams.iter().map(|(_, s)| s).collect()
                } else {
                    Vec::new()
                };
                uncertainty::tables::state_fitted_conditions(
                    &mut calibration,
                    (&points, &model, &firmware),
                    &fitted,
                );
                (static_blob.clone(), calibration, None)
            }
        };
        messages.result(&format!("beyond the trained range: {}", beyond.verdict));
        blob = self.service.apply(&blob, &mut calibration, beyond.rule)?;
        summary.beyond = Some(beyond);
        // The agreement of the blob as written: its error model and its rule beyond the range.
        let (checked_model, checked_extension) = exported_from
            .as_ref()
            .map_or((&model, &extension), |(m, e)| (m, e));
        let agreement = export::verify(checked_model, &blob, &points, checked_extension)?.1;
        messages.result(&format!(
            "the blob's {}",
            calibration.describe(points.quantity.unit())
        ));
        if streams.is_empty() {
            messages.result(
                "skipped: one sample's noise (a rate table's points are means over an interval \
                 the file does not give: the blob states their noise, undivided over a mean, and \
                 a single sample's σ is too narrow; a log of the sensor measures it: --stream, \
                 beside a table with --features or --pool-stream)",
            );
        }
        let stated = self.service.sheet.scale_repeatability.is_some();
        for line in calibration.skipped_lines(stated) {
            messages.result(&line);
        }
        summary.calibration = Some(calibration);
        summary.handled = streams
            .iter()
            .flat_map(|(_, s)| s.handled.iter().cloned())
            .collect();
        summary.firmware_agreement = agreement;
        summary.blob_bytes = blob.len();
        Ok(ChannelFit {
            n: points.len(),
            blob,
            summary,
            model,
        })
    }

    /// The GP's settings with its size resolved for `points` ([`capacity::resolve`]: the exact GP
    /// where the firmware holds it or a size was asked for, else the size chosen on the data),
    /// refused before any fit when the firmware could not hold the result.
    fn size(
        &self,
        points: &Points,
        messages: &dyn Messages,
    ) -> anyhow::Result<(GpConfig, Option<capacity::Choice>)> {
        let asked = self.gp.clone();
        let n = points.len();
        let exact_only = matches!(self.extend, Extend::TableTransients) || self.offsets;
        anyhow::ensure!(
            !(exact_only && capacity::needed(asked.inducing, n)),
            "{n} points are more than the {MAX_CENTRES} centres a firmware model holds, and {} \
             needs an exact GP: fit without it (the default then chooses a sparse GP) or on at \
             most {MAX_CENTRES} points (checked before fitting)",
            if self.offsets {
                "--offsets"
            } else {
                "a time-ordered table's transient terms (--features auto)"
            },
        );
        let spinner = capacity::needed(asked.inducing, n)
            .then(|| messages.busy("choosing the firmware model's size"));
        let (gp, choice) = capacity::resolve(points, &asked, |step| {
            if let Some(s) = &spinner {
                s.stage(&format!("choosing the firmware model's size: {step}"));
            }
        })?;
        drop(spinner);
        if let Some(c) = &choice {
            messages.result(&c.verdict);
        }
        let centres = gp.inducing.count(n).unwrap_or(n);
        anyhow::ensure!(
            centres <= MAX_CENTRES,
            "model too large to export: {} gives {centres} centres, and a firmware model holds at \
             most {MAX_CENTRES} centres; ask for a sparse GP (--inducing {MAX_CENTRES}) or fit on \
             fewer points (checked before fitting)",
            match gp.inducing {
                Inducing::Auto =>
                    format!("an exact GP on {n} points (the default up to {AUTO_EXACT_MAX})"),
                asked => format!("--inducing {asked} on {n} points"),
            },
        );
        Ok((gp, choice))
    }

    /// The static model on `points` (with a time-ordered table's transient terms where asked),
    /// and, for a pooled fit beside a rate table (`cuts`: its streams cut forward in time), the
    /// check that decides which of the two ships: the points and model that ship, the table's
    /// fit, and the check.
    #[allow(clippy::type_complexity)]
    fn static_model(
        &self,
        points: Points,
        gp: &GpConfig,
        (streams, cuts): (&[(&Path, Stream)], Option<Vec<Forward>>),
        messages: &dyn Messages,
    ) -> anyhow::Result<(Points, GpModel, Option<TableModel>, Option<PoolCheck>)> {
        let spinner = messages.busy(&match gp.inducing.count(points.len()) {
            Some(m) => format!(
                "fitting a sparse GP ({m} inducing points) on {} samples",
                points.len()
            ),
            None => format!("fitting an exact GP on {} points", points.len()),
        });
        let offsets = self.offsets;
        let table = match self.extend {
            Extend::TableTransients => {
                let transients = Transients::compute(&points)?;
                let all: Vec<usize> = (0..points.len()).collect();
                Some(table::fit(&points, &transients, &all, (gp, offsets))?)
            }
            _ => None,
        };
        let model = match &table {
            Some(t) => t.gp.clone(),
            None => GpModel::fit_grouped(
                points.inputs(),
                &points.target(),
                &points.offset_groups(offsets),
                gp,
            )?,
        };
        drop(spinner);
        let Some(cuts) = cuts else {
            return Ok((points, model, table, None));
        };
        let spinner =
            messages.busy("checking the pooled model against the table's alone, forward in time");
        let table_points = self.source.static_points(&[], false, messages)?;
        // The size chosen for the pooled points is theirs; a table the firmware holds whole keeps
        // its exact GP.
        let table_gp = self.gp.clone();
        let fit_static = |p: &Points| {
            let cfg = if p.len() <= MAX_CENTRES {
                &table_gp
            } else {
                gp
            };
            GpModel::fit_grouped(p.inputs(), &p.target(), &p.offset_groups(offsets), cfg)
        };
        let table_model = fit_static(&table_points)?;
        let check = pool::check(&table_points, &table_model, (streams, &cuts), &fit_static)?;
        drop(spinner);
        Ok(match check.shipped {
            Pooling::Pooled => {
                messages.result(&check.verdict);
                (points, model, table, Some(check))
            }
            Pooling::TableOnly => {
                messages.warn(&check.verdict);
                (table_points, table_model, table, Some(check))
            }
        })
    }

    /// With one stream: the extension it calls for (or was asked for) where it wins its forward
    /// check, and the σ of what ships, calibrated on the stream's own splits. The blob, its
    /// agreement and its calibration (its σ beyond the range for the rule `beyond`); `None` where
    /// the stream gives no splits to calibrate on (a pooled fit not extended), so the table's
    /// calibration stands.
    #[allow(clippy::type_complexity)]
    fn on_stream(
        &self,
        (path, data): (&Path, &Stream),
        (points, model, firmware, gp): (&Points, &GpModel, &HostModel, &GpConfig),
        static_blob: &[u8],
        beyond: &BeyondChoice,
        summary: &mut FitReport,
        messages: &dyn Messages,
    ) -> anyhow::Result<Option<(Vec<u8>, Calibration, Option<(GpModel, Extension)>)>> {
        let rebuild = |part: &Stream| {
            self.source
                .static_points(&[(path, part.clone())], self.pool, messages)
        };
        let choice = match &self.extend {
            Extend::Stream(asked) => {
                let choice = investigate::choose(
                    points,
                    model,
                    firmware,
                    data,
                    gp,
                    asked.as_deref(),
                    &rebuild,
                )?;
                if asked.is_none() {
                    messages.result(&format!(
                        "diagnosis of {}: {} — {}",
                        path.display(),
                        causes_text(&choice.diagnosis.causes),
                        choice.diagnosis.explanation
                    ));
                }
                Some(choice)
            }
            _ => None,
        };
        let (kind, splits) = match &choice {
            Some(c) => (c.shipped, None),
            None if !self.pool => {
                let on = investigate::Fitted {
                    points,
                    model,
                    train: data,
                    cfg: gp,
                    rebuild: &rebuild,
                };
                let mut splits = investigate::splits(on, &[])?;
                splits.extend(investigate::power_on_splits(on, &[])?);
                (investigate::Shipped::Static, Some(splits))
            }
            None => (investigate::Shipped::Static, None),
        };
        let mut blob = static_blob.to_vec();
        let mut exported_from = None;
        if let Some(choice) = &choice {
            summary.stream_choice = Some(StreamChoice {
                diagnosis: choice.diagnosis.clone(),
                causes: choice.causes.clone(),
                forward_check: choice.check.clone(),
                shipped: choice.shipped,
                verdict: choice.verdict.clone(),
            });
            if let (Some(extended), investigate::Shipped::Extended) =
                (&choice.extended, choice.shipped)
            {
                let fitted = extended.fitted.clone();
                blob = extended.blob.clone();
                summary.firmware_agreement = extended.agreement;
                exported_from = Some((extended.model.clone(), fitted.extension.clone()));
                let ext = fog_data::replay::decode(&blob)?;
                messages.result(&format!(
                    "extended by {:?} on {}: training residual rmse_60s {:.3e} → {:.3e} {}",
                    ext.features(),
                    path.display(),
                    fitted.train_rmse_60s_dps[0],
                    fitted.train_rmse_60s_dps[1],
                    points.quantity.unit()
                ));
                summary.features = Inputs::Firmware(ext.features().to_vec());
                summary.extension = Some(ExtensionReport::Stream(fitted));
            }
            if choice.check.as_ref().is_some_and(|c| !c.extension_helps()) {
                messages.warn(&choice.verdict);
            } else {
                messages.result(&choice.verdict);
            }
        }
        let Some(splits) = choice.as_ref().map(|c| &c.splits).or(splits.as_ref()) else {
            return Ok(None);
        };
        let calibration = investigate::calibrate(
            (points, model, static_blob),
            &blob,
            kind,
            data,
            splits,
            beyond,
        )?;
        Ok(Some((blob, calibration, exported_from)))
    }

    /// One sample's white noise, measured on the static model's errors over every stream, and
    /// each point's where the points are the streams' own (no rate table, or one pooled with
    /// their samples and shipped so): over the samples it averages (a 60 s block's, or one with
    /// `--pool-stream`). A table's rows, and a table shipped alone, keep the GP's level at their
    /// points. `None` without streams, or where they are too short to show it (said).
    fn stream_points(
        &self,
        streams: &[(&Path, Stream)],
        (points, firmware, pooled): (&Points, &HostModel, bool),
        messages: &dyn Messages,
    ) -> anyhow::Result<Option<StreamPoints>> {
        if streams.is_empty() {
            return Ok(None);
        }
        let logs: Vec<&Stream> = streams.iter().map(|(_, s)| s).collect();
        let Some(noise) = uncertainty::streams::sample_noise(firmware, &logs) else {
            messages.warn(
                "skipped: one sample's noise (the streams hold too few consecutive samples to \
                 measure it): the GP's noise level on the points stands in, undivided over a mean",
            );
            return Ok(None);
        };
        let mut point_var = vec![None; points.len()];
        if self.source.points.is_none() || pooled {
            // Noise density over the samples a point averages, at each stream's own interval.
            let density = noise.var * noise.interval_s;
            let mut stream_vars = Vec::new();
            for (_, s) in streams {
                let of = |n: usize| Some(density / (n as f64 * s.step_s));
                if self.pool {
                    stream_vars.extend(std::iter::repeat_n(of(1), points::scored(s).len()));
                } else {
                    stream_vars.extend(points::stream_blocks(s).iter().map(|b| of(b.len())));
                }
            }
            // The streams' points are the last runs ([`PointFiles::static_points`]), after a
            // rate table's rows.
            let first = points.runs() - streams.len();
            let rows = points.run.iter().filter(|&&r| r < first).count();
            anyhow::ensure!(
                rows + stream_vars.len() == points.len(),
                "{} points, {rows} of a table and {} from the streams: they do not add up",
                points.len(),
                stream_vars.len()
            );
            point_var[rows..].copy_from_slice(&stream_vars);
        }
        Ok(Some(StreamPoints { noise, point_var }))
    }
}

/// Under --verbose: every optimizer start of a fit, where it began and ended.
fn log_starts(messages: &dyn Messages, model: &GpModel) {
    if !messages.verbose() {
        return;
    }
    messages.detail("optimizer starts (θ = ln ℓ…, ln σ_f, ln σ_n[, ln σ_g]; normalized):");
    for (i, s) in model.starts.iter().enumerate() {
        let fmt = |t: &[f64]| {
            t.iter()
                .map(|v| format!("{v:.3}"))
                .collect::<Vec<_>>()
                .join(", ")
        };
        messages.detail(&format!(
            "  {i:>2}: [{}] → [{}]  log ML {}  {} likelihoods, {} evaluations: {}",
            fmt(&s.start),
            s.end.as_deref().map_or("failed".to_owned(), fmt),
            s.log_marginal_likelihood
                .map_or("—".to_owned(), |l| format!("{l:.3}")),
            s.likelihoods,
            s.evaluations,
            s.status
        ));
    }
}

/// The autopilots' cubic of each channel of `channels` whose output has a physical unit, fitted on
/// the same training samples as its model (`streams`: each channel's), as PX4 and ArduPilot take it.
pub fn unit_cubics<'s, S: IntoIterator<Item = &'s Stream>>(
    channels: &Channels,
    streams: impl IntoIterator<Item = S>,
) -> anyhow::Result<SensorCubics> {
    let mut axes = Vec::new();
    for (ch, streams) in channels.list.iter().zip(streams) {
        if ch.unit.factor().is_none() {
            continue;
        }
        let (mut temp, mut offset) = (Vec::new(), Vec::new());
        for s in streams {
            for i in s.referenced() {
                temp.push(s.temp_c[i]);
                offset.push(s.voltage_v[i] - s.rate_dps[i]);
            }
        }
        let cubic = Cubic::fit(&temp, &offset)
            .map_err(|e| anyhow::anyhow!("{} channel {}: {e}", channels.sensor_id, ch.name))?;
        axes.push(AxisCubic {
            name: ch.name.clone(),
            quantity: ch.quantity,
            cubic,
        });
    }
    let sensor = channels.recorded.as_deref();
    Ok(SensorCubics {
        name: channels
            .unit_name()
            .map_or_else(|| channels.sensor_id.clone(), str::to_owned),
        instance: sensor.map_or(0, |s| s.instance),
        device_id: sensor.and_then(|s| s.device_id),
        axes,
        vehicle_axes: sensor.is_some_and(|s| matches!(s.mounting, Some(Mounting::Unknown(_)))),
    })
}
