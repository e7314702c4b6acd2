//! The trainer's models as scikit-learn estimators: `fit(X, y)`, then `predict(X)`, with what
//! was learned as attributes ending in `_`. Each call is the trainer's own ([`GpModel::fit`],
//! [`LssvrModel::fit`], [`PolyModel::fit`]); this module only moves arrays across.

use nalgebra::{DMatrix, DVector};
use numpy::{AllowTypeChange, IntoPyArray, PyArray1, PyArrayLike1, PyArrayLike2};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use trainer::models::gp::{GpConfig, GpModel, Inducing};
use trainer::models::lssvr::LssvrModel;
use trainer::models::poly::PolyModel;
use trainer::models::prior::MeanBasis;

use crate::error::{FogError, NotFitted};

/// `X` as the trainer's design matrix (rows are samples) and `y` as its target, of one length.
fn design(
    x: &PyArrayLike2<'_, f64, AllowTypeChange>,
    y: Option<&PyArrayLike1<'_, f64, AllowTypeChange>>,
) -> PyResult<(DMatrix<f64>, Option<DVector<f64>>)> {
    let x = x.as_array();
    let (n, d) = x.dim();
    if n == 0 || d == 0 {
        return Err(PyValueError::new_err(format!(
            "X is {n} × {d}: it needs at least one sample and one input"
        )));
    }
    let m = DMatrix::from_fn(n, d, |i, j| x[[i, j]]);
    let y = match y {
        None => None,
        Some(y) => {
            let y = y.as_array();
            if y.len() != n {
                return Err(PyValueError::new_err(format!(
                    "X has {n} samples and y {}: they must be of one length",
                    y.len()
                )));
            }
            Some(DVector::from_iterator(n, y.iter().copied()))
        }
    };
    if m.iter().chain(y.iter().flatten()).any(|v| !v.is_finite()) {
        return Err(PyValueError::new_err(
            "X or y holds a value that is not finite (NaN or ±inf): leave such samples out",
        ));
    }
    Ok((m, y))
}

/// The rows of `x`, each a sample.
fn rows(x: &DMatrix<f64>) -> Vec<Vec<f64>> {
    x.row_iter().map(|r| r.iter().copied().collect()).collect()
}

/// The paper's Gaussian process: an ARD squared-exponential kernel plus white noise over
/// standardized inputs, a prior mean of `mean`, its hyperparameters by L-BFGS-B from the paper's
/// start, a data-informed one and `random_starts` seeded random ones.
#[pyclass(module = "fog._fog")]
pub struct GaussianProcess {
    cfg: GpConfig,
    fitted: Option<GpModel>,
}

/// The fitted model, or `NotFittedError`.
fn fitted<T>(model: &Option<T>) -> PyResult<&T> {
    model
        .as_ref()
        .ok_or_else(|| NotFitted::new_err("call fit(X, y) first"))
}

impl GaussianProcess {
    fn model(&self) -> PyResult<&GpModel> {
        fitted(&self.fitted)
    }
}

/// The prior mean's basis a model of this module is fitted with: one of its own, as a fit takes
/// it (`auto`, chosen on a sensor's temperature bands, is `fog.calibrate`'s, on the sensor's points).
fn basis(mean: &str) -> PyResult<MeanBasis> {
    match mean.parse() {
        Ok(MeanBasis::Auto) | Err(_) => Err(PyValueError::new_err(format!(
            "mean '{mean}': expected constant, physics or polyN with N in 0..=5 (auto, the basis \
             chosen on a sensor's temperature bands, is fog.calibrate's)"
        ))),
        Ok(basis) => Ok(basis),
    }
}

#[pymethods]
impl GaussianProcess {
    #[new]
    #[pyo3(signature = (mean = "physics", random_starts = 2, seed = 0, inducing = "auto", max_iters = 100))]
    fn new(
        mean: &str,
        random_starts: usize,
        seed: u64,
        inducing: &str,
        max_iters: u64,
    ) -> PyResult<Self> {
        let mean = basis(mean)?;
        let inducing: Inducing = inducing
            .parse()
            .map_err(|e: String| PyValueError::new_err(format!("inducing {e}")))?;
        Ok(Self {
            cfg: GpConfig {
                random_starts,
                seed,
                mean,
                inducing,
                max_iters,
                ..GpConfig::default()
            },
            fitted: None,
        })
    }

    /// Fits the GP to `X` (samples × inputs) and `y`; returns itself. The work runs without the
    /// GIL.
    fn fit<'py>(
        mut slf: PyRefMut<'py, Self>,
        py: Python<'py>,
        x: PyArrayLike2<'py, f64, AllowTypeChange>,
        y: PyArrayLike1<'py, f64, AllowTypeChange>,
    ) -> PyResult<PyRefMut<'py, Self>> {
        let (x, y) = design(&x, Some(&y))?;
        let y = y.unwrap_or_default();
        let cfg = slf.cfg.clone();
        let model = py
            .detach(|| GpModel::fit(&x, &y, &cfg))
            .map_err(|e| FogError::new_err(e.to_string()))?;
        slf.fitted = Some(model);
        Ok(slf)
    }

    /// The predictive mean at each row of `X`; with `return_std`, also the standard deviation of
    /// a new observation there (the latent variance plus the noise, as scikit-learn's with a
    /// `WhiteKernel`).
    #[pyo3(signature = (x, return_std = false))]
    fn predict<'py>(
        &self,
        py: Python<'py>,
        x: PyArrayLike2<'py, f64, AllowTypeChange>,
        return_std: bool,
    ) -> PyResult<Py<PyAny>> {
        let model = self.model()?;
        let (x, _) = design(&x, None)?;
        let d = model.input_norm.offset.len();
        if x.ncols() != d {
            return Err(PyValueError::new_err(format!(
                "X has {} inputs; the GP was fitted on {d}",
                x.ncols()
            )));
        }
        if !return_std {
            // The mean alone: the variance would cost O(n²) a row for nothing.
            let mean: Vec<f64> =
                py.detach(|| rows(&x).iter().map(|r| model.predict_mean(r)).collect());
            return Ok(mean.into_pyarray(py).into_any().unbind());
        }
        let (mean, std): (Vec<f64>, Vec<f64>) = py.detach(|| {
            rows(&x)
                .iter()
                .map(|r| {
                    let p = model.predict(r);
                    (p.mean, (p.latent_var + p.noise_var).sqrt())
                })
                .unzip()
        });
        let mean = mean.into_pyarray(py).into_any().unbind();
        let std = std.into_pyarray(py).into_any().unbind();
        Ok((mean, std).into_pyobject(py)?.into_any().unbind())
    }

    /// The leave-one-out errors of the training samples (prediction − target), in closed form
    /// with the hyperparameters held (Rasmussen and Williams, eq. 5.12), as `trainer loo` takes
    /// them.
    fn loo_errors<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let model = self.model()?;
        Ok(py.detach(|| model.loo_errors()).into_pyarray(py))
    }

    /// The log marginal likelihood of the fitted hyperparameters (on the standardized data).
    #[getter]
    fn log_marginal_likelihood_(&self) -> PyResult<f64> {
        Ok(self.model()?.log_marginal_likelihood())
    }

    /// One length scale per input, in the input's own unit.
    #[getter]
    fn length_scales_(&self) -> PyResult<Vec<f64>> {
        let m = self.model()?;
        Ok(m.posterior
            .hyper
            .length_scales
            .iter()
            .zip(&m.input_norm.scale)
            .map(|(l, s)| l * s)
            .collect())
    }

    /// The signal standard deviation σ_f, in the target's unit.
    #[getter]
    fn signal_std_(&self) -> PyResult<f64> {
        let m = self.model()?;
        Ok(m.posterior.hyper.signal_std * m.output_scale)
    }

    /// The noise standard deviation σ_n, in the target's unit.
    #[getter]
    fn noise_std_(&self) -> PyResult<f64> {
        let m = self.model()?;
        Ok(m.posterior.hyper.noise_std * m.output_scale)
    }

    /// Whether the fit is sparse (inducing points) and how many it has; `None` for an exact GP.
    #[getter]
    fn inducing_points_(&self) -> PyResult<Option<usize>> {
        Ok(self.model()?.sparse.as_ref().map(|s| s.inducing))
    }

    /// What the fit warns of (a hyperparameter on its bound, a poorly conditioned kernel).
    #[getter]
    fn warnings_(&self) -> PyResult<Vec<String>> {
        Ok(self.model()?.warnings())
    }

    /// The wall time of the fit, s.
    #[getter]
    fn fit_seconds_(&self) -> PyResult<f64> {
        Ok(self.model()?.fit_seconds)
    }

    fn __repr__(&self) -> String {
        format!(
            "GaussianProcess(mean='{}', random_starts={}, seed={}, inducing='{}', max_iters={})",
            self.cfg.mean,
            self.cfg.random_starts,
            self.cfg.seed,
            self.cfg.inducing,
            self.cfg.max_iters
        )
    }
}

/// The least-squares support-vector regression the paper compares: the same kernel, its length
/// scales and regularization by the closed-form leave-one-out error.
#[pyclass(module = "fog._fog", name = "LSSVR")]
pub struct Lssvr {
    mean: MeanBasis,
    fitted: Option<LssvrModel>,
}

#[pymethods]
impl Lssvr {
    #[new]
    #[pyo3(signature = (mean = "physics"))]
    fn new(mean: &str) -> PyResult<Self> {
        Ok(Self {
            mean: basis(mean)?,
            fitted: None,
        })
    }

    /// Fits to `X` (samples × inputs) and `y`; returns itself.
    fn fit<'py>(
        mut slf: PyRefMut<'py, Self>,
        py: Python<'py>,
        x: PyArrayLike2<'py, f64, AllowTypeChange>,
        y: PyArrayLike1<'py, f64, AllowTypeChange>,
    ) -> PyResult<PyRefMut<'py, Self>> {
        let (x, y) = design(&x, Some(&y))?;
        let y = y.unwrap_or_default();
        let basis = slf.mean;
        let model = py
            .detach(|| LssvrModel::fit(&x, &y, basis))
            .map_err(|e| FogError::new_err(e.to_string()))?;
        slf.fitted = Some(model);
        Ok(slf)
    }

    /// The prediction at each row of `X`.
    fn predict<'py>(
        &self,
        py: Python<'py>,
        x: PyArrayLike2<'py, f64, AllowTypeChange>,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let model = fitted(&self.fitted)?;
        let (x, _) = design(&x, None)?;
        Ok(rows(&x)
            .iter()
            .map(|r| model.predict(r))
            .collect::<Vec<_>>()
            .into_pyarray(py))
    }

    /// The closed-form leave-one-out errors of the training samples.
    fn loo_errors<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let model = fitted(&self.fitted)?;
        Ok(model.loo_errors().into_pyarray(py))
    }

    /// The regularization γ.
    #[getter]
    fn gamma_(&self) -> PyResult<f64> {
        Ok(fitted(&self.fitted)?.hyper().gamma)
    }
}

/// The paper's polynomial: Chebyshev terms of degree 9 in the gyro output times 3 in temperature,
/// by least squares. `X`'s columns are the temperature (°C) and the gyro output.
#[pyclass(module = "fog._fog")]
pub struct Polynomial {
    fitted: Option<PolyModel>,
}

/// `X`'s two columns, temperature and output.
fn temperature_and_output(
    x: &PyArrayLike2<'_, f64, AllowTypeChange>,
) -> PyResult<(Vec<f64>, Vec<f64>)> {
    let x = x.as_array();
    if x.ncols() != 2 {
        return Err(PyValueError::new_err(format!(
            "X has {} columns: the polynomial takes two, temperature (°C) and the gyro output",
            x.ncols()
        )));
    }
    Ok((x.column(0).to_vec(), x.column(1).to_vec()))
}

#[pymethods]
impl Polynomial {
    #[new]
    fn new() -> Self {
        Self { fitted: None }
    }

    /// Fits to `X` (temperature, output) and the reference rate `y`; returns itself.
    fn fit<'py>(
        mut slf: PyRefMut<'py, Self>,
        x: PyArrayLike2<'py, f64, AllowTypeChange>,
        y: PyArrayLike1<'py, f64, AllowTypeChange>,
    ) -> PyResult<PyRefMut<'py, Self>> {
        let (t, v) = temperature_and_output(&x)?;
        let y = y.as_array().to_vec();
        if y.len() != t.len() {
            return Err(PyValueError::new_err(format!(
                "X has {} samples and y {}: they must be of one length",
                t.len(),
                y.len()
            )));
        }
        let model = PolyModel::fit(&t, &v, &y).map_err(|e| FogError::new_err(e.to_string()))?;
        slf.fitted = Some(model);
        Ok(slf)
    }

    /// The rate at each row of `X` (temperature, output).
    fn predict<'py>(
        &self,
        py: Python<'py>,
        x: PyArrayLike2<'py, f64, AllowTypeChange>,
    ) -> PyResult<Bound<'py, PyArray1<f64>>> {
        let model = fitted(&self.fitted)?;
        let (t, v) = temperature_and_output(&x)?;
        Ok(t.iter()
            .zip(&v)
            .map(|(&t, &v)| model.predict(t, v))
            .collect::<Vec<_>>()
            .into_pyarray(py))
    }
}
