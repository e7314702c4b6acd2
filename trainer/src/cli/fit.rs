//! `trainer fit`: its flags checked once into a plan ([`FitPlan`]: the pipeline's, in
//! [`crate::pipeline::fit`]), the logs read, the pipeline run on each unit (one channel's data is
//! a unit of one), and what it returns written and printed. Its flags are in [`args`].

use std::path::{Path, PathBuf};

use anyhow::Context;
use fog_data::channels::Channels;
use fog_data::stream::Window;
use fog_terminal::console::{Console, ConsoleFlags};
use fog_terminal::io::{ensure_not_input, write_atomically, write_json};
use fog_terminal::log::load_unit_log;
use fog_terminal::schema;

use super::inputs::ModelInput;
use crate::analysis::extend;
use crate::firmware::autopilot::SensorCubics;
use crate::pipeline::fit::{Extend, FitPlan, unit_table};
use crate::pipeline::{check_datasheet, check_one_channel};

mod args;
pub(super) mod params;

pub(super) use args::FitArgs;
use params::ParamsArgs;

use fog_terminal::log::Each;

/// `trainer fit` as asked: the pipeline's plan, and what the command reads and writes beside it.
struct FitCommand {
    plan: FitPlan,
    /// The rate tables and the column maps, excludes and unit the logs are read with.
    input: ModelInput,
    streams: Vec<PathBuf>,
    window: Option<Window>,
    params: ParamsArgs,
    out: PathBuf,
    json: Option<PathBuf>,
}

impl FitCommand {
    /// The command of `args`, or why they do not make one: every combination of flags is
    /// decided here, before anything is read.
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
        let service = service.service();
        anyhow::ensure!(
            service.full_scale.is_none_or(|f| f.is_finite() && f > 0.0),
            "--full-scale must be a positive number"
        );
        check_datasheet(&service.sheet)?;
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
        let plan = FitPlan {
            source: input.source(),
            gp: fit.gp(),
            offsets,
            pool: pool_stream,
            extend,
            budget: budget.budget(),
            service,
        };
        Ok(Self {
            plan,
            input,
            streams: stream,
            window,
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

    /// Every channel's model of each unit (a CSV or a rate table of one channel is a unit of
    /// one), checked against the firmware and written; the autopilots' parameters beside.
    fn run(self, flags: ConsoleFlags) -> anyhow::Result<()> {
        let console = Console::new(flags, self.json.as_deref());
        let first = self.streams.first().map(PathBuf::as_path);
        let mut units = self.input.unit.units(first, &console)?;
        if units.is_empty() {
            let table = self
                .input
                .points
                .as_deref()
                .context("give --points (a rate table) or --stream to fit on")?;
            units.push(Channels::single(table));
        }
        let service = &self.plan.service;
        check_one_channel(&service.sheet, service.full_scale.is_some(), &units, "fit")?;
        let params: Vec<&PathBuf> = self.params.files().collect();
        anyhow::ensure!(
            params.is_empty() || units.iter().all(|u| !u.single),
            "--px4-params and --ardupilot-params take a sensor's three axes: a unit (a flight \
             controller's log, or --channels), not one channel"
        );
        let each = Each::new(
            units.len(),
            first.unwrap_or(Path::new("")),
            self.json.as_deref(),
        )?;
        let mut inputs = self.inputs();
        inputs.extend(units.iter().map(|u| u.path.as_path()));
        for p in &params {
            ensure_not_input(p, &inputs)?;
        }
        let mut cubics = Vec::new();
        for channels in &units {
            let out = each.file(channels, &self.out);
            let json = self.json.as_deref().map(|j| each.file(channels, j));
            each.heading(channels, &console);
            let fitted = self.run_unit(channels, (&out, json.as_deref()), &console);
            cubics.extend(fitted.map_err(|e| each.naming(channels, e))?);
        }
        self.params.write(&cubics, &console)
    }

    /// Every channel of a unit's files, each fitted as one channel is, into one blob: the logs
    /// read once (their time and handling checked once for all channels).
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
                let log = load_unit_log(
                    p,
                    channels,
                    &self.input.maps.list,
                    (self.window, &self.input.exclude.list),
                    console,
                )?;
                Ok((p.as_path(), log))
            })
            .collect::<anyhow::Result<Vec<_>>>()?;
        let mut fit = self
            .plan
            .fit_unit(channels, &logs, self.params.asked(), console)?;
        write_atomically(out, &fit.blob)?;
        if let Some(path) = json {
            write_json(path, &inputs, schema::FIT, &fit.report(channels))?;
        }
        console.result(&unit_table(channels, &fit.fitted, &fit.footprint, out));
        Ok(fit.cubics.take())
    }
}

/// `trainer fit`: the static model (or a table diagnosed in time order, or a stream's extension)
/// and its blob.
pub(super) fn fit_command(args: FitArgs, flags: ConsoleFlags) -> anyhow::Result<()> {
    FitCommand::check(args)?.run(flags)
}
