//! The residuals of a rate table, or of points made from logs (their 60 s means or samples): its
//! runs, groups or points left out, closed form where the GP is exact and fitted again where it is
//! sparse, and the σ a blob states at a table's point.

use firmware_core::model::Conditions;

use fog_data::replay::HostModel;
use fog_data::stream::Stream;

use super::heating::{self, Changes};
use super::terms::calibrate;
use super::{Calibration, Prior, Residual, ResidualSource, SampleNoise, Series};
use crate::analysis::beyond::BeyondChoice;
use crate::data::points::Points;
use crate::firmware::export;
use crate::models::gp::{GpConfig, GpError, GpModel};
use crate::models::normalize::Sorted;

/// The σ of a model fitted on a rate table alone: its groups (or points) left out
/// ([`table_series`]), and the points' own noise as a point's (where some are streams', theirs:
/// [`StreamPoints`]); what they cannot show, the model's [`Prior`], for the rule its blob ships
/// beyond the range where `beyond` gives it ([`Prior::for_rule`]; `None`, for `loo`, which ships
/// no blob: holding's miss, unscaled).
pub fn table_calibration(
    points: &Points,
    model: &GpModel,
    beyond: Option<&BeyondChoice>,
    streams: Option<&StreamPoints>,
) -> Result<Calibration, GpError> {
    let (source, groups, mut loo) = left_out(model, points)?;
    let gp_noise = table_noise(points, model);
    if let Some(s) = streams {
        for (i, (_, var)) in loo.iter_mut().enumerate() {
            *var = (*var - gp_noise.var).max(0.0) + s.white(i, gp_noise.var);
        }
    }
    Ok(calibrate(
        &[series_of(points, source, &groups, &loo)],
        streams.map_or(gp_noise, |s| s.noise),
        prior(model, points, beyond),
    ))
}

/// The white noise of points that are streams' (their 60 s block means, or their samples pooled
/// with `--pool-stream`): one sample's, measured on the streams
/// ([`SampleNoise::from_streams`]), and each point's over the samples it averages. A GP fitted on
/// such points takes as its noise whatever it cannot follow at a point (several power-ons'
/// offsets; rates that change within a block), and that is no sample's white noise: at one
/// sample of a 5 Hz log it was a sixteenth of it (the simulated board's warm-ups pooled: 9–11 %
/// of another warm-up's samples within ±2σ), and over a 60 s mean it was not divided. The σ
/// takes the samples' own noise instead, and what the GP called noise beyond it is model error,
/// which the terms fitted on the residuals take up.
#[derive(Debug, Clone, PartialEq)]
pub struct StreamPoints {
    /// One sample's white noise: what the blob states.
    pub noise: SampleNoise,
    /// Each point's white-noise variance where it is a stream's (its samples' noise over their
    /// number), `None` for a rate table's row, whose noise is the GP's level: one per point.
    pub point_var: Vec<Option<f64>>,
}

impl StreamPoints {
    /// Point `i`'s white-noise variance (`gp_var`, the GP's level, for a table's row).
    fn white(&self, i: usize, gp_var: f64) -> f64 {
        self.point_var[i].unwrap_or(gp_var)
    }
}

/// The [`Prior`] of `model` fitted on `points`, for `beyond`'s rule where it is given.
fn prior(model: &GpModel, points: &Points, beyond: Option<&BeyondChoice>) -> Prior {
    let prior = Prior::of(model, points);
    beyond.map_or(prior, |b| prior.for_rule(b))
}

/// The σ of a model fitted with `cfg` on `points` of several power-ons pooled: as
/// [`table_calibration`], but where the GP is sparse (no closed form leaves a run out) each run is
/// left out by fitting again on the others, so that the model error holds another power-on's
/// bias ([`ResidualSource::Runs`]). One run, or an exact GP: [`table_calibration`].
pub fn pooled_calibration(
    points: &Points,
    model: &GpModel,
    cfg: &GpConfig,
    beyond: Option<&BeyondChoice>,
    streams: Option<&StreamPoints>,
) -> Result<Calibration, GpError> {
    let runs = points.run_members();
    if runs.len() < 2 || model.sparse.is_none() {
        return table_calibration(points, model, beyond, streams);
    }
    let target = points.target();
    let mut loo = vec![(0.0, 0.0); points.len()];
    for run in &runs {
        let rest: Vec<usize> = (0..points.len())
            .filter(|i| points.run[*i] != points.run[run[0]])
            .collect();
        let part = points.select(&rest);
        let refit = GpModel::fit(part.inputs(), &part.target(), cfg)?;
        for &i in run {
            let row: Vec<f64> = points.inputs().row(i).iter().copied().collect();
            let p = refit.predict(&row);
            let white = streams.map_or(p.noise_var, |s| s.white(i, p.noise_var));
            loo[i] = (p.mean - target[i], p.latent_var + white);
        }
    }
    Ok(calibrate(
        &[series_of(points, ResidualSource::Runs, &runs, &loo)],
        streams.map_or_else(|| table_noise(points, model), |s| s.noise),
        prior(model, points, beyond),
    ))
}

/// A table point's noise: the GP's noise level on the points it was fitted on.
pub fn table_noise(points: &Points, model: &GpModel) -> SampleNoise {
    SampleNoise {
        var: model.predict(&vec![0.0; points.inputs().ncols()]).noise_var,
        interval_s: 0.0,
    }
}

/// How a rate table is left out for its residuals: each run (power-on) in turn where the points
/// hold two or more, so that the σ carries the bias of another power-on; else each group in turn
/// where there are two or more; each point otherwise. Groups and runs need the exact GP.
pub fn table_groups(model: &GpModel, points: &Points) -> (ResidualSource, Vec<Vec<usize>>) {
    let runs = points.run_members();
    let groups: Vec<Vec<usize>> = points.groups().into_iter().map(|(_, g)| g).collect();
    if runs.len() >= 2 && model.sparse.is_none() {
        (ResidualSource::Runs, runs)
    } else if groups.len() >= 2 && model.sparse.is_none() {
        (ResidualSource::Groups, groups)
    } else {
        (
            ResidualSource::Points,
            (0..points.len()).map(|i| vec![i]).collect(),
        )
    }
}

/// The residuals of a rate table ([`table_groups`]), closed form with `model`'s hyperparameters
/// held; e(x) against the trained range of the rows left in.
pub fn table_series(model: &GpModel, points: &Points) -> Result<Series, GpError> {
    let (source, groups, loo) = left_out(model, points)?;
    Ok(series_of(points, source, &groups, &loo))
}

/// How the table is left out ([`table_groups`]) and each point's left-out prediction (error,
/// predictive variance with noise), closed form.
type LeftOut = (ResidualSource, Vec<Vec<usize>>, Vec<(f64, f64)>);

fn left_out(model: &GpModel, points: &Points) -> Result<LeftOut, GpError> {
    let (source, groups) = table_groups(model, points);
    let loo = model.group_loo_predictive(points.inputs(), &groups)?;
    Ok((source, groups, loo))
}

/// A table's residuals from its left-out predictions `loo` (error, predictive variance with
/// noise, per point), e(x) against the trained range of the rows left in for each group.
pub fn series_of(
    points: &Points,
    source: ResidualSource,
    groups: &[Vec<usize>],
    loo: &[(f64, f64)],
) -> Series {
    let x = points.inputs();
    let columns: Vec<Sorted> = x
        .column_iter()
        .map(|c| Sorted::new(c.iter().copied()))
        .collect();
    let mut residuals = vec![None; points.len()];
    for g in groups {
        let range: Vec<(f64, f64)> = columns.iter().map(|c| c.range_without(g)).collect();
        for &i in g {
            let (error, base_var) = loo[i];
            let row: Vec<f64> = x.row(i).iter().copied().collect();
            residuals[i] = Some(Residual {
                error,
                base_var,
                excess2: export::excess2(&row, &range),
                output2: points.rate_dps[i].powi(2),
                output: points.rate_dps[i],
                hours: 0.0,
            });
        }
    }
    Series {
        source,
        residuals: residuals.into_iter().flatten().collect(),
    }
}

/// The σ a blob with `calibration` states for a rate-table point `x` of `model` (f64; the
/// firmware computes the same in f32): latent, noise and model error at power-on, another than
/// calibration's.
pub fn point_sigma(model: &GpModel, calibration: &Calibration, x: &[f64]) -> f64 {
    let p = model.predict(x);
    let e2 = export::excess2(x, &model.input_range);
    let error = f64::from(calibration.error_model.model_error(
        e2 as f32,
        p.mean as f32,
        Conditions::at_hours(0.0),
    ));
    (p.latent_var + f64::from(calibration.error_model.sample_noise_var) + error).sqrt()
}

/// States in `calibration` the heating rates and heating/cooling states a pooled fit's `model`
/// was fitted at, so that its blob's σ grows at a heating rate and on a leg unlike them, as one
/// log's does: a rate table's rows ([`super::heating::table_rates`]: soaks, unless their times
/// say otherwise) and the `logs` whose samples `points` hold after them (each log's own rates
/// and states, read from its own power-on: [`super::heating::rates`],
/// [`super::streams::legs`]), the band the widest of each one's
/// ([`super::heating::HeatingBand::of_parts`]), with `model`'s change per °C over them all
/// (`firmware`: its blob). The legs are stated only where no table's rows are among the points:
/// a soak's state is not known. Points that are a stream's with none of their logs given state
/// none. `loo`, which ships no blob and states no lag, leaves it out.
pub fn state_fitted_conditions(
    calibration: &mut Calibration,
    (points, model, firmware): (&Points, &GpModel, &HostModel),
    logs: &[&Stream],
) {
    let first = points.runs().saturating_sub(logs.len());
    let rows: Vec<usize> = (0..points.len())
        .filter(|&i| points.run[i] < first)
        .collect();
    let table =
        (!rows.is_empty() && (!logs.is_empty() || points.soaked)).then(|| points.select(&rows));
    let mut parts = Vec::new();
    let mut changes = Changes::default();
    if let Some(t) = &table {
        parts.push(heating::table_rates(t));
        changes = Changes::of_points(model, t);
    }
    let mut states = Vec::new();
    for log in logs {
        parts.push(heating::rates(log));
        changes.extend(Changes::of_stream(firmware, log));
        states.extend(super::streams::legs(log));
    }
    if table.is_none() {
        calibration.set_legs(&states);
    }
    if parts.iter().all(Vec::is_empty) {
        return;
    }
    // Without logs, told apart at a table point's noise; with them, all at one sample's.
    let noise_std = if logs.is_empty() {
        table_noise(points, model).var.sqrt()
    } else {
        calibration.sample_noise_std
    };
    let parts: Vec<&[(f64, f64)]> = parts.iter().map(Vec::as_slice).collect();
    let soaks = table.as_ref().is_some_and(|t| t.time_s.is_none());
    calibration.set_fitted_heating(&parts, changes.split(noise_std), soaks);
}
