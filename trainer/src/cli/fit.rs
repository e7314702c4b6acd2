//! `trainer fit`: a model and its blob, as a checked plan ([`FitPlan`]) run channel by channel;
//! its flags are in [`args`], what it writes and prints in [`report`].

use std::path::{Path, PathBuf};

use anyhow::Context;
use firmware_core::MAX_CENTRES;
use fog_data::cause::Cause;
use fog_data::replay::HostModel;
use fog_data::stream::{Stream, Window};
use fog_terminal::console::{Console, ConsoleFlags};
use fog_terminal::io::{ensure_not_input, write_atomically, write_json};
use fog_terminal::schema;

use super::inputs::{FitOptions, ModelInput, load_stream};
use super::text::{causes_text, log_starts};
use crate::analysis::budget::{self, Budget};
use crate::analysis::capacity;
use crate::analysis::extend;
use crate::analysis::investigate;
use crate::analysis::pool::{self, PoolCheck, Pooling};
use crate::analysis::table::{self, TableModel, Transients};
use crate::analysis::uncertainty::{self, Calibration};
use crate::data::points::Points;
use crate::firmware::autopilot::SensorCubics;
use crate::firmware::export::{self, Extension};
use crate::firmware::unit::{self, ChannelBlob};
use crate::models::gp::{AUTO_EXACT_MAX, GpConfig, GpModel, Inducing};
use firmware_core::blob::Dims;
use fog_data::channels::Channels;
use fog_terminal::log::load_unit_log;

mod args;
pub(super) mod params;
mod report;

pub(super) use args::FitArgs;
use args::ServiceArgs;
use params::{ParamsArgs, beside};
use report::{
    ChannelFit, ChannelReport, ExtensionReport, FitReport, Inputs, StreamChoice, UnitFitReport,
    print_fit, quantity_words, unit_table,
};

/// A channel to size: its name, its plan and its loaded streams.
type Named<'a> = (&'a str, &'a FitPlan, &'a [(&'a Path, Stream)]);

/// What the static model is extended by, as `trainer fit` was asked.
#[derive(Clone)]
enum Extend {
    /// Nothing: the static model ships.
    Nothing,
    /// The transients of a rate table recorded in time order (`--features auto`, no stream).
    TableTransients,
    /// Inputs fitted on the one stream: those its diagnosis calls for (`None`: `auto`), or those
    /// of the causes named.
    Stream(Option<Vec<Cause>>),
}

/// `trainer fit`'s arguments checked once: which combinations make sense is decided here, and
/// the pipeline ([`FitPlan::run`]) only follows the plan.
#[derive(Clone)]
struct FitPlan {
    input: ModelInput,
    fit: FitOptions,
    /// Each group of `--group` its own offset.
    offsets: bool,
    streams: Vec<PathBuf>,
    window: Option<Window>,
    pool: bool,
    extend: Extend,
    budget: Budget,
    service: ServiceArgs,
    params: ParamsArgs,
    out: PathBuf,
    json: Option<PathBuf>,
}

impl FitPlan {
    /// The plan of `args`, or why they do not make one.
    fn check(args: FitArgs) -> anyhow::Result<Self> {
        let FitArgs {
            input,
            runs,
            fit,
            offsets,
            stream,
            window,
            pool_stream,
            features,
            budget,
            service,
            params,
            out,
            json,
        } = args;
        let input = input.with_runs(runs);
        anyhow::ensure!(
            service.full_scale.is_none_or(|f| f.is_finite() && f > 0.0),
            "--full-scale must be a positive number"
        );
        anyhow::ensure!(
            service
                .repeatability
                .is_none_or(|r| r.is_finite() && r >= 0.0),
            "--repeatability must be a σ: a number not below 0"
        );
        anyhow::ensure!(
            (service.full_scale.is_none() && service.repeatability.is_none())
                || input.unit.channels.is_none(),
            "--full-scale and --repeatability are one channel's, in its units: a unit's channels \
             each have their own (fit them one at a time to state them)"
        );
        anyhow::ensure!(
            input.runs.is_empty() || features.is_none() || !stream.is_empty(),
            "--features auto on a rate table diagnoses one recorded in time order; tables of \
             several power-ons pooled (--run) are not one"
        );
        let extend = match (features.as_deref(), stream.len(), &input.points) {
            (None, _, _) => Extend::Nothing,
            (Some("auto"), 0, Some(_)) => Extend::TableTransients,
            (Some(_), 0, Some(_)) => anyhow::bail!(
                "on a rate table the inputs are chosen by its diagnosis: --features auto"
            ),
            (Some("auto"), 1, _) => Extend::Stream(None),
            (Some(list), 1, _) => Extend::Stream(Some(extend::parse_features(list)?)),
            (Some(_), n, _) => anyhow::bail!(
                "--features are fitted on one stream, or (auto) on a rate table recorded in time \
                 order; {n} streams given"
            ),
        };
        anyhow::ensure!(
            input.points.is_none()
                || stream.is_empty()
                || !matches!(extend, Extend::Nothing)
                || pool_stream,
            "--stream would not be used: with --points the static model is fitted on the rate \
             table; add --pool-stream to fit on the stream's samples too, or --features to \
             extend the model by inputs fitted on the stream"
        );
        Ok(Self {
            input,
            fit,
            offsets,
            streams: stream,
            window,
            pool: pool_stream,
            extend,
            budget: budget.budget(),
            service,
            params,
            out,
            json,
        })
    }

    /// The files read.
    fn inputs(&self) -> Vec<&Path> {
        self.input
            .points
            .iter()
            .chain(&self.input.runs)
            .chain(&self.streams)
            .map(PathBuf::as_path)
            .collect()
    }

    /// The model (or, with `--channels` or a flight controller's log, every channel's of each
    /// unit), checked against the firmware and written; the autopilots' parameters beside.
    fn run(self, flags: ConsoleFlags) -> anyhow::Result<()> {
        let console = Console::new(flags, self.json.as_deref());
        let first = self.streams.first().map(PathBuf::as_path);
        let units = self.input.unit.units(first, &console)?;
        let params: Vec<&PathBuf> = self.params.files().collect();
        anyhow::ensure!(
            params.is_empty() || !units.is_empty(),
            "--px4-params and --ardupilot-params take a sensor's three axes: a unit (a flight \
             controller's log, or --channels), not one channel"
        );
        if units.is_empty() {
            return self.run_single(&console);
        }
        let several = units.len() > 1;
        anyhow::ensure!(
            !several || self.json.as_deref() != Some(Path::new("-")),
            "--json - writes one JSON and {} holds {} sensors: name a file (one per sensor is \
             written beside it), or choose one with --sensor",
            first.map_or(String::new(), |p| p.display().to_string()),
            units.len()
        );
        let mut inputs = self.inputs();
        inputs.extend(units.iter().map(|u| u.path.as_path()));
        for p in &params {
            ensure_not_input(p, &inputs)?;
        }
        let mut cubics = Vec::new();
        for channels in &units {
            let name = channels.unit_name();
            let each = |path: &Path| match name.filter(|_| several) {
                Some(n) => beside(path, n),
                None => path.to_owned(),
            };
            let (out, json) = (each(&self.out), self.json.as_deref().map(each));
            if several {
                console.result(&format!(
                    "{} ({}):",
                    name.unwrap_or_default(),
                    channels.sensor_id
                ));
            }
            cubics.extend(self.run_unit(channels, (&out, json.as_deref()), &console)?);
        }
        self.params.write(&cubics, &console)
    }

    /// One channel: the static model, its extension and its σ, its blob and report.
    fn run_single(self, console: &Console) -> anyhow::Result<()> {
        ensure_not_input(&self.out, &self.inputs())?;
        let streams = self
            .streams
            .iter()
            .map(|p| {
                let s = load_stream(
                    p,
                    &self.input.maps.list,
                    (self.window, &self.input.exclude.list),
                    console,
                )?;
                Ok((p.as_path(), s))
            })
            .collect::<anyhow::Result<Vec<_>>>()?;
        let (plans, budgeted) = self.within_budget(&[("the model", &self, &streams)], console)?;
        let [plan] = plans
            .try_into()
            .map_err(|_| anyhow::anyhow!("one plan per channel"))?;
        let mut fitted = plan.fit(&streams, console)?;
        fitted.summary.budget = budgeted;
        if self.budget.is_set() {
            let f = unit::unit_footprint(&fitted.blob)?;
            self.check_fitted(&f)?;
        }
        write_atomically(&self.out, &fitted.blob)?;
        if let Some(path) = &self.json {
            write_json(path, &self.inputs(), schema::FIT, &fitted.summary)?;
        }
        print_fit(
            console,
            &fitted,
            (Some(&self.out), fitted.blob.len()),
            self.input.quantity,
        );
        Ok(())
    }

    /// Every channel of a unit's files, each fitted as one channel is, into one blob: the logs read
    /// once (their time and handling checked once for all channels).
    fn run_unit(
        &self,
        channels: &Channels,
        (out, json): (&Path, Option<&Path>),
        console: &Console,
    ) -> anyhow::Result<Option<SensorCubics>> {
        let mut inputs = self.inputs();
        inputs.push(&channels.path);
        ensure_not_input(out, &inputs)?;
        let logs = self
            .streams
            .iter()
            .map(|p| {
                load_unit_log(
                    p,
                    channels,
                    &self.input.maps.list,
                    (self.window, &self.input.exclude.list),
                    console,
                )
            })
            .collect::<anyhow::Result<Vec<_>>>()?;
        let per_channel: Vec<(FitPlan, Vec<(&Path, Stream)>)> = (0..channels.len())
            .map(|k| {
                let plan = Self {
                    input: self.input.for_channel(channels, k)?,
                    ..self.clone()
                };
                let streams: Vec<(&Path, Stream)> = self
                    .streams
                    .iter()
                    .zip(&logs)
                    .map(|(p, log)| (p.as_path(), log[k].clone()))
                    .collect();
                Ok((plan, streams))
            })
            .collect::<anyhow::Result<_>>()?;
        let named: Vec<Named<'_>> = channels
            .list
            .iter()
            .zip(&per_channel)
            .map(|(ch, (plan, s))| (ch.name.as_str(), plan, s.as_slice()))
            .collect();
        let (plans, budgeted) = self.within_budget(&named, console)?;
        let mut fitted = Vec::new();
        for (k, ch) in channels.list.iter().enumerate() {
            let heading = format!(
                "{} ({} in {}, [{}/{}]):",
                ch.name,
                quantity_words(ch.quantity),
                ch.quantity.unit(),
                k + 1,
                channels.len()
            );
            let console = console.channel(&ch.name, &heading);
            let one = plans[k]
                .fit(&per_channel[k].1, &console)
                .with_context(|| format!("channel {}", ch.name))?;
            print_fit(&console, &one, (None, one.blob.len()), ch.quantity);
            fitted.push(one);
        }
        let parts: Vec<ChannelBlob<'_>> = channels
            .list
            .iter()
            .zip(&fitted)
            .map(|(ch, f)| ChannelBlob {
                name: &ch.name,
                quantity: ch.quantity,
                blob: &f.blob,
            })
            .collect();
        let blob = unit::unit_blob(&channels.sensor_id, &parts)?;
        let footprint = unit::unit_footprint(&blob)?;
        self.check_fitted(&footprint)?;
        let streams = per_channel.iter().map(|c| c.1.iter().map(|s| &s.1));
        let cubics = self.params.cubics(channels, streams)?;
        write_atomically(out, &blob)?;
        let report = UnitFitReport {
            sensor_id: &channels.sensor_id,
            temperature_c: footprint.temperature_c,
            channels: channels
                .list
                .iter()
                .zip(&fitted)
                .map(|(ch, f)| ChannelReport {
                    name: &ch.name,
                    quantity: ch.quantity,
                    units: ch.quantity.unit(),
                    fit: &f.summary,
                })
                .collect(),
            blob_bytes: blob.len(),
            footprint: &footprint,
            budget: budgeted,
            autopilot: cubics.as_ref(),
        };
        if let Some(path) = json {
            write_json(path, &inputs, schema::FIT_UNIT, &report)?;
        }
        console.result(&unit_table(channels, &fitted, &footprint, out));
        Ok(cubics)
    }

    /// The plans of the channels `named` (each with its loaded streams), their models' sizes chosen
    /// within the budget where one is given (`analysis::budget`): this plan for each, with the
    /// size chosen for its channel.
    fn within_budget(
        &self,
        named: &[Named<'_>],
        console: &Console,
    ) -> anyhow::Result<(Vec<FitPlan>, Option<budget::Report>)> {
        let plans: Vec<FitPlan> = named.iter().map(|(_, p, _)| (*p).clone()).collect();
        if !self.budget.is_set() {
            return Ok((plans, None));
        }
        anyhow::ensure!(
            self.fit.inducing == Inducing::Auto,
            "--budget-* chooses the models' sizes: leave --inducing out"
        );
        let points = named
            .iter()
            .map(|(_, plan, streams)| plan.input.static_points(streams, plan.pool))
            .collect::<anyhow::Result<Vec<_>>>()?;
        let basis = self.fit.gp().mean;
        let dims = |p: &Points, m: usize| budget::static_dims(p, basis, m);
        let smallest: Vec<(&str, Dims)> = named
            .iter()
            .zip(&points)
            .map(|((name, _, _), p)| (*name, dims(p, p.len())))
            .collect();
        budget::check_smallest(&self.budget, &smallest)?;
        let default: Vec<Dims> = points
            .iter()
            .map(|p| dims(p, p.len().min(MAX_CENTRES)))
            .collect();
        let most_m = default.iter().map(|d| d.m).max().unwrap_or(0);
        let default_cost = default.iter().fold(budget::Cost::unit(most_m), |acc, d| {
            acc + budget::Cost::model(*d)
        });
        if self.budget.holds(&default_cost) {
            console.result(&format!(
                "the budget ({}) holds the models the default fit ships ({default_cost}): no size \
                 is chosen",
                self.budget
            ));
            let report = budget::Report {
                budget: self.budget,
                default_cost,
                channels: named
                    .iter()
                    .map(|(name, _, _)| budget::ChannelSizes {
                        name: (*name).to_owned(),
                        sizes: Vec::new(),
                        chosen: None,
                    })
                    .collect(),
                chosen_cost: default_cost,
            };
            return Ok((plans, Some(report)));
        }
        let spinner = console.spinner("sizing the channels' models within the budget");
        let sizes = named
            .iter()
            .zip(&points)
            .map(|((name, _, _), p)| {
                budget::sizes(p, &self.fit.gp(), |step| {
                    spinner.set_message(format!("sizing {name}: {step}"));
                })
            })
            .collect::<Result<Vec<_>, _>>()?;
        spinner.finish_and_clear();
        let (chosen, cost) = budget::choose(&sizes, &self.budget).ok_or_else(|| {
            anyhow::anyhow!(
                "no combination of the channels' sizes fits the budget ({}): the smallest \
                 exceed it once the unit's scratch is added",
                self.budget
            )
        })?;
        let mut lines = format!(
            "the budget ({}) does not hold the default models ({default_cost}); chosen within \
             it, on each channel's points with every fifth held out ({cost}):",
            self.budget
        );
        let mut out = Vec::new();
        for (((name, _, _), s), (&i, mut plan)) in
            named.iter().zip(&sizes).zip(chosen.iter().zip(plans))
        {
            let pick = &s[i];
            let best = s
                .iter()
                .map(|x| x.held_out_rmse)
                .fold(f64::INFINITY, f64::min);
            lines.push_str(&format!(
                "\n  {name}: {} GP of {} {} ({:+.1}% held-out error against its best size), \
                 {} bytes of RAM",
                pick.kind,
                pick.asked,
                if pick.kind == "exact" {
                    "points"
                } else {
                    "inducing points"
                },
                100.0 * (pick.held_out_rmse / best - 1.0),
                pick.cost.ram_bytes
            ));
            plan.fit.inducing = pick.inducing();
            out.push(plan);
        }
        console.result(&lines);
        let report = budget::Report {
            budget: self.budget,
            default_cost,
            channels: named
                .iter()
                .zip(sizes)
                .zip(&chosen)
                .map(|(((name, _, _), sizes), &i)| budget::ChannelSizes {
                    name: (*name).to_owned(),
                    sizes,
                    chosen: Some(i),
                })
                .collect(),
            chosen_cost: cost,
        };
        Ok((out, Some(report)))
    }

    /// The budget checked on the blob as fitted (an extension may have made it larger than its
    /// static model): refused with the figures where it does not fit.
    fn check_fitted(&self, f: &unit::UnitFootprint) -> anyhow::Result<()> {
        let cost = budget::Cost {
            ram_bytes: f.unit_bytes + f.scratch_bytes,
            flash_bytes: f.blob_bytes,
            instructions: f.instructions,
        };
        anyhow::ensure!(
            self.budget.holds(&cost),
            "the fitted blob needs {cost}, beyond the budget ({}): the extensions the diagnosis \
             added made it larger than its static models; fit without --features, or raise the \
             budget (nothing written)",
            self.budget
        );
        Ok(())
    }

    /// The static model on the loaded `streams` (with `--points`, the table), its extension and
    /// its σ: the blob, checked against the firmware, and what `fit` reports of it.
    fn fit(&self, streams: &[(&Path, Stream)], console: &Console) -> anyhow::Result<ChannelFit> {
        let points = self.input.static_points(streams, self.pool)?;
        let (gp, centres_choice) = self.size(&points, console)?;
        let (points, model, table, pool_check) =
            self.static_model(points, &gp, streams, console)?;
        log_starts(console, &model);
        // Before the f32 check: a warning may explain why it refuses the blob.
        for w in model.warnings() {
            console.warn(&w);
        }
        let extension = table
            .as_ref()
            .map(TableModel::extension)
            .unwrap_or_default();
        let static_blob = export::points_blob(&model, &points, &extension)?;
        let (firmware, agreement) = export::verify(&model, &static_blob, &points, &extension)?;
        let mut summary = FitReport::new(&model, &points, agreement, static_blob.len());
        summary.pool_check = pool_check;
        summary.centres_choice = centres_choice;
        if let Some(t) = &table {
            console.result(&format!(
                "diagnosis of the table (time order): {}",
                t.diagnosis.verdict
            ));
            summary.table_diagnosis = Some(t.diagnosis.clone());
            summary.extension = Some(ExtensionReport::Table(extension.clone()));
            summary.features = Inputs::Firmware(firmware.features().to_vec());
        }
        let shipped = match streams {
            [(path, data)] => self.on_stream(
                (path, data),
                (&points, &model, &firmware, &gp),
                &static_blob,
                &mut summary,
                console,
            )?,
            _ => None,
        };
        let (mut blob, mut calibration, exported_from) = match shipped {
            Some(s) => s,
            None => (
                static_blob.clone(),
                uncertainty::tables::pooled_calibration(&points, &model, &gp)?,
                None,
            ),
        };
        let beyond = self.service.beyond(&points, &gp);
        console.result(&format!("beyond the trained range: {}", beyond.verdict));
        blob = self.service.apply(&blob, &mut calibration, beyond.rule)?;
        summary.beyond = Some(beyond);
        // The agreement of the blob as written: its error model and its rule beyond the range.
        let (checked_model, checked_extension) = exported_from
            .as_ref()
            .map_or((&model, &extension), |(m, e)| (m, e));
        let agreement = export::verify(checked_model, &blob, &points, checked_extension)?.1;
        console.result(&format!(
            "the blob's {}",
            calibration.describe(points.quantity.unit())
        ));
        if self.service.repeatability.is_none() && !calibration.runs_measured() {
            console.result(
                "skipped: the bias of another power-on (one power-on's data cannot show it; \
                 --repeatability states a datasheet's run-to-run σ, several --stream logs of \
                 one sensor measure it)",
            );
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
        console: &Console,
    ) -> anyhow::Result<(GpConfig, Option<capacity::Choice>)> {
        let asked = self.fit.gp();
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
            .then(|| console.spinner("choosing the firmware model's size"));
        let (gp, choice) = capacity::resolve(points, &asked, |step| {
            if let Some(s) = &spinner {
                s.set_message(format!("choosing the firmware model's size: {step}"));
            }
        })?;
        if let Some(s) = spinner {
            s.finish_and_clear();
        }
        if let Some(c) = &choice {
            console.result(&c.verdict);
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
    /// and, for a pooled fit beside a rate table, the check that decides which of the two ships:
    /// the points and model that ship, the table's fit, and the check.
    #[allow(clippy::type_complexity)]
    fn static_model(
        &self,
        points: Points,
        gp: &GpConfig,
        streams: &[(&Path, Stream)],
        console: &Console,
    ) -> anyhow::Result<(Points, GpModel, Option<TableModel>, Option<PoolCheck>)> {
        let spinner = console.spinner(&match gp.inducing.count(points.len()) {
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
        spinner.finish_and_clear();
        if !(self.pool && self.input.points.is_some()) {
            return Ok((points, model, table, None));
        }
        let spinner =
            console.spinner("checking the pooled model against the table's alone, forward in time");
        let table_points = self.input.static_points(&[], false)?;
        // The size chosen for the pooled points is theirs; a table the firmware holds whole keeps
        // its exact GP.
        let table_gp = self.fit.gp();
        let fit_static = |p: &Points| {
            let cfg = if p.len() <= MAX_CENTRES {
                &table_gp
            } else {
                gp
            };
            GpModel::fit_grouped(p.inputs(), &p.target(), &p.offset_groups(offsets), cfg)
        };
        let table_model = fit_static(&table_points)?;
        let check = pool::check(&table_points, &table_model, streams, &fit_static)?;
        spinner.finish_and_clear();
        Ok(match check.shipped {
            Pooling::Pooled => {
                console.result(&check.verdict);
                (points, model, table, Some(check))
            }
            Pooling::TableOnly => {
                console.warn(&check.verdict);
                (table_points, table_model, table, Some(check))
            }
        })
    }

    /// With one stream: the extension it calls for (or was asked for) where it wins its forward
    /// check, and the σ of what ships, calibrated on the stream's own splits. The blob, its
    /// agreement and its calibration; `None` where the stream gives no splits to calibrate on (a
    /// pooled fit not extended), so the table's calibration stands.
    #[allow(clippy::type_complexity)]
    fn on_stream(
        &self,
        (path, data): (&Path, &Stream),
        (points, model, firmware, gp): (&Points, &GpModel, &HostModel, &GpConfig),
        static_blob: &[u8],
        summary: &mut FitReport,
        console: &Console,
    ) -> anyhow::Result<Option<(Vec<u8>, Calibration, Option<(GpModel, Extension)>)>> {
        let rebuild = |part: &Stream| self.input.static_points(&[(path, part.clone())], self.pool);
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
                    console.result(&format!(
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
            None if !self.pool => (
                investigate::Shipped::Static,
                Some(investigate::splits(points, model, data, gp, &[], &rebuild)?),
            ),
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
                console.result(&format!(
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
                console.warn(&choice.verdict);
            } else {
                console.result(&choice.verdict);
            }
        }
        let Some(splits) = choice.as_ref().map(|c| &c.splits).or(splits.as_ref()) else {
            return Ok(None);
        };
        let calibration =
            investigate::calibrate(points, model, static_blob, &blob, kind, data, splits)?;
        Ok(Some((blob, calibration, exported_from)))
    }
}

/// `trainer fit`: the static model (or a table diagnosed in time order, or a stream's extension)
/// and its blob.
pub(super) fn fit_command(args: FitArgs, flags: ConsoleFlags) -> anyhow::Result<()> {
    FitPlan::check(args)?.run(flags)
}
