//! The firmware blob from Python: read, written and evaluated by firmware-core's f32 evaluator,
//! one call for a whole stream as `firmware-sim replay` makes it ([`replay::replay_unit`]), so
//! its outputs are bit for bit the firmware's.

use std::path::PathBuf;

use fog_data::replay::{self, Compensated as Replayed, HostUnit};
use fog_data::stream::Stream;
use numpy::{AllowTypeChange, IntoPyArray, PyArray1, PyArrayLike1};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyDict;

use crate::error::fog_error;

/// A firmware blob: one model, or a unit of several channels (every blob reads as a unit; a
/// single-channel blob is a unit of one).
#[pyclass(module = "fog._fog", frozen)]
pub struct Model {
    blob: Vec<u8>,
    unit: Box<HostUnit>,
}

/// The firmware's outputs for every sample of one channel.
#[pyclass(module = "fog._fog", frozen, get_all)]
pub struct Compensated {
    /// Compensated rate (or acceleration), f32, in the channel's unit (°/s, m/s²).
    mean: Py<PyArray1<f32>>,
    /// Bias variance: the model's latent variance plus its model error, f32.
    bias_variance: Py<PyArray1<f32>>,
    /// Noise variance of the sample, f32.
    noise_variance: Py<PyArray1<f32>>,
    /// Status codes, as the C interface's `FogStatus`: 0 valid, 1 extrapolating, 2 degraded,
    /// 3 fault.
    status: Py<PyArray1<u8>>,
}

impl Compensated {
    fn new(py: Python<'_>, c: Replayed) -> Self {
        let status: Vec<u8> = c.status.iter().map(|&s| s as u8).collect();
        Self {
            mean: c.rate_dps.into_pyarray(py).unbind(),
            bias_variance: c.bias_var.into_pyarray(py).unbind(),
            noise_variance: c.noise_var.into_pyarray(py).unbind(),
            status: status.into_pyarray(py).unbind(),
        }
    }
}

#[pymethods]
impl Compensated {
    /// The four arrays as a pandas DataFrame, one row per sample (pandas must be installed).
    fn to_frame<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let columns = PyDict::new(py);
        columns.set_item("mean", &self.mean)?;
        columns.set_item("bias_variance", &self.bias_variance)?;
        columns.set_item("noise_variance", &self.noise_variance)?;
        columns.set_item("status", &self.status)?;
        py.import("pandas")?.call_method1("DataFrame", (columns,))
    }

    fn __repr__(&self, py: Python<'_>) -> PyResult<String> {
        Ok(format!(
            "Compensated({} samples)",
            self.mean.bind(py).len()?
        ))
    }
}

impl Model {
    fn decode(blob: Vec<u8>, what: &str) -> PyResult<Self> {
        let unit = replay::decode_unit(&blob)
            .map_err(|e| fog_error(anyhow::Error::new(e).context(format!("decoding {what}"))))?;
        Ok(Self { blob, unit })
    }
}

/// Reads a firmware blob (`trainer fit --out`).
#[pyfunction]
pub fn load_model(path: PathBuf) -> PyResult<Model> {
    let blob = std::fs::read(&path).map_err(|e| {
        fog_error(anyhow::Error::new(e).context(format!("reading {}", path.display())))
    })?;
    Model::decode(blob, &path.display().to_string())
}

#[pymethods]
impl Model {
    /// A blob from its bytes.
    #[staticmethod]
    fn from_bytes(blob: Vec<u8>) -> PyResult<Self> {
        Self::decode(blob, "the bytes")
    }

    /// The blob's bytes, as the firmware reads them.
    fn to_bytes(&self) -> &[u8] {
        &self.blob
    }

    /// Writes the blob, byte for byte as read.
    fn save(&self, path: PathBuf) -> PyResult<()> {
        std::fs::write(&path, &self.blob).map_err(|e| {
            fog_error(anyhow::Error::new(e).context(format!("writing {}", path.display())))
        })
    }

    /// The sensor's ID, as written by `fit`.
    #[getter]
    fn sensor_id(&self) -> &str {
        self.unit.sensor_id()
    }

    /// The channels' names, in the blob's order.
    #[getter]
    fn channels(&self) -> Vec<String> {
        self.unit
            .channels()
            .iter()
            .map(|c| c.name().to_owned())
            .collect()
    }

    /// Every sample through the firmware's f32 evaluator, in time order, its feature state kept
    /// through the stream (and reset at a power cycle: a time gap or a clock running backwards),
    /// as `firmware-sim replay` runs it. `output` is one array for a blob of one channel, or one
    /// per channel (a list in the blob's channel order, or a dict by name) for a unit. With
    /// `calibration_run`, the stream up to its first power cycle is the power-on the model was
    /// calibrated on (`--calibration-run`). Returns `Compensated` for one channel, a dict of
    /// them by channel name for a unit.
    #[pyo3(signature = (time_s, temp_c, output, calibration_run = false))]
    fn compensate<'py>(
        &self,
        py: Python<'py>,
        time_s: PyArrayLike1<'py, f64, AllowTypeChange>,
        temp_c: PyArrayLike1<'py, f64, AllowTypeChange>,
        output: Bound<'py, PyAny>,
        calibration_run: bool,
    ) -> PyResult<Py<PyAny>> {
        let names = self.channels();
        let outputs = outputs(&names, &output)?;
        let time = time_s.as_array().to_vec();
        let temp = temp_c.as_array().to_vec();
        let streams = outputs
            .into_iter()
            .map(|o| {
                let n = o.len();
                Stream::from_columns(time.clone(), temp.clone(), o, vec![f64::NAN; n])
                    .map_err(fog_error)
            })
            .collect::<PyResult<Vec<_>>>()?;
        let unit = &self.unit;
        let comps = py.detach(|| {
            let refs: Vec<&Stream> = streams.iter().collect();
            replay::replay_unit(unit, &refs, calibration_run)
        });
        let single = names.len() == 1 && !output.is_instance_of::<PyDict>() && !is_list(&output);
        if single {
            let c = comps.into_iter().next().unwrap_or_default();
            return Ok(Py::new(py, Compensated::new(py, c))?.into_any());
        }
        let d = PyDict::new(py);
        for (name, c) in names.iter().zip(comps) {
            d.set_item(name, Py::new(py, Compensated::new(py, c))?)?;
        }
        Ok(d.into_any().unbind())
    }

    fn __repr__(&self) -> String {
        format!(
            "Model(sensor_id='{}', channels={:?}, {} bytes)",
            self.unit.sensor_id(),
            self.channels(),
            self.blob.len()
        )
    }
}

/// Whether `o` is a list or a tuple of arrays (one per channel) rather than one array (a list of
/// numbers).
fn is_list(o: &Bound<'_, PyAny>) -> bool {
    let seq =
        o.is_instance_of::<pyo3::types::PyList>() || o.is_instance_of::<pyo3::types::PyTuple>();
    seq && o
        .get_item(0)
        .is_ok_and(|first| first.extract::<f64>().is_err())
}

/// The channels' outputs in the blob's order: one array for a blob of one channel, a list (in
/// order) or a dict (by name) for a unit.
fn outputs(names: &[String], output: &Bound<'_, PyAny>) -> PyResult<Vec<Vec<f64>>> {
    let array = |o: &Bound<'_, PyAny>| -> PyResult<Vec<f64>> {
        Ok(o.extract::<PyArrayLike1<'_, f64, AllowTypeChange>>()?
            .as_array()
            .to_vec())
    };
    if let Ok(d) = output.cast::<PyDict>() {
        let given: Vec<String> = d.keys().extract()?;
        if let Some(extra) = given.iter().find(|k| !names.contains(k)) {
            return Err(PyValueError::new_err(format!(
                "output '{extra}': the blob has no such channel (it has {})",
                names.join(", ")
            )));
        }
        return names
            .iter()
            .map(|n| match d.get_item(n)? {
                Some(o) => array(&o),
                None => Err(PyValueError::new_err(format!(
                    "no output for channel '{n}' (the blob's channels: {})",
                    names.join(", ")
                ))),
            })
            .collect();
    }
    if is_list(output) {
        let list: Vec<Bound<'_, PyAny>> = output.extract()?;
        if list.len() != names.len() {
            return Err(PyValueError::new_err(format!(
                "{} outputs for a blob of {} channels ({})",
                list.len(),
                names.len(),
                names.join(", ")
            )));
        }
        return list.iter().map(array).collect();
    }
    if names.len() != 1 {
        return Err(PyValueError::new_err(format!(
            "the blob holds a unit of {} channels ({}): give one output per channel, a list in \
             that order or a dict by name",
            names.len(),
            names.join(", ")
        )));
    }
    Ok(vec![array(output)?])
}
