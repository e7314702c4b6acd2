//! The trainer's looks at data from Python: the Allan deviation of a rate (`trainer allan`) and a
//! log's summary (`trainer summarize`). Each result is the command's JSON, handed to Python as a
//! dict (the `fog` package gives it attributes).

use std::path::PathBuf;

use fog_data::allan::Analysis;
use fog_data::autopilot::Format;
use fog_data::columns::ColumnMap;
use numpy::{AllowTypeChange, PyArrayLike1};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use serde::Serialize;

use crate::error::{FogError, fog_error};

/// `value` as Python objects, through its JSON (the same fields as the command's `--json`).
fn to_python<'py>(py: Python<'py>, value: &impl Serialize) -> PyResult<Bound<'py, PyAny>> {
    let text = serde_json::to_string(value).map_err(fog_error)?;
    py.import("json")?.call_method1("loads", (text,))
}

/// `{"temp_c": "T"}` as the trainer's column maps (`--map temp_c=T`).
fn maps(map: Option<Vec<(String, String)>>) -> PyResult<Vec<ColumnMap>> {
    map.unwrap_or_default()
        .into_iter()
        .map(|(name, source)| {
            format!("{name}={source}")
                .parse()
                .map_err(|e| PyValueError::new_err(format!("map {name}={source}: {e}")))
        })
        .collect()
}

/// The overlapping Allan deviation of `rate_dps` sampled at `time_s`, less `reference_dps`
/// where given (NaN where unknown), over its stretches without a gap, with its noise terms: the
/// analysis `trainer allan` makes (its `--json`).
#[pyfunction]
#[pyo3(signature = (time_s, rate_dps, reference_dps = None, what = "rate"))]
pub fn allan<'py>(
    py: Python<'py>,
    time_s: PyArrayLike1<'py, f64, AllowTypeChange>,
    rate_dps: PyArrayLike1<'py, f64, AllowTypeChange>,
    reference_dps: Option<PyArrayLike1<'py, f64, AllowTypeChange>>,
    what: &str,
) -> PyResult<Bound<'py, PyAny>> {
    let time = time_s.as_array().to_vec();
    let rate = rate_dps.as_array().to_vec();
    let reference =
        reference_dps.map_or_else(|| vec![f64::NAN; rate.len()], |r| r.as_array().to_vec());
    if rate.len() != time.len() || reference.len() != time.len() {
        return Err(PyValueError::new_err(format!(
            "time_s holds {} samples, rate_dps {} and reference_dps {}: they must be of one length",
            time.len(),
            rate.len(),
            reference.len()
        )));
    }
    let analysis = py.detach(|| Analysis::less_reference(what, &time, &rate, &reference));
    analysis
        .enough()
        .map_err(|e| FogError::new_err(e.to_string()))?;
    to_python(py, &analysis)
}

/// What kind of log `path` is, told by its first bytes as every command tells it: `"csv"`,
/// `"ulog"` (PX4) or `"dataflash"` (ArduPilot). A binary file of neither kind is refused, with
/// what it begins with.
#[pyfunction]
pub fn log_format(py: Python<'_>, path: PathBuf) -> PyResult<&'static str> {
    let format = py
        .detach(|| fog_data::autopilot::sniff(&path))
        .map_err(fog_error)?;
    Ok(match format {
        Format::Csv => "csv",
        Format::ULog => "ulog",
        Format::DataFlash => "dataflash",
    })
}

/// A data file as the loader sees it, before anything is fitted (`trainer summarize`): a stream
/// (`points=False`) or a points table, its columns named or mapped by `map`
/// (`{"temp_c": "T", "time_s": "timestamp*1e-6"}`, as `--map`).
#[pyfunction]
#[pyo3(signature = (path, map = None, points = false, scale_factor = None))]
pub fn summarize(
    py: Python<'_>,
    path: PathBuf,
    map: Option<Vec<(String, String)>>,
    points: bool,
    scale_factor: Option<f64>,
) -> PyResult<Bound<'_, PyAny>> {
    let maps = maps(map)?;
    let summary = py
        .detach(|| {
            if points {
                trainer::data::summary::of_points_file(&path, &maps, scale_factor)
                    .map_err(anyhow::Error::new)
            } else {
                trainer::data::summary::of_stream_file(&path, &maps).map_err(anyhow::Error::new)
            }
        })
        .map_err(fog_error)?;
    to_python(py, &summary)
}
