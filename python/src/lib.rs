//! The `fog` Python package's native module, `fog._fog`: the trainer's models, firmware-core's
//! evaluator and the trainer's looks at data, with numpy arrays in and out. It only translates;
//! every figure is computed by the crates the command line runs.

mod analysis;
mod commands;
mod error;
mod firmware;
mod models;

use pyo3::prelude::*;

/// The trainer's own allocator (`trainer/src/main.rs`), so that a fit from Python runs as
/// `trainer fit` does.
#[global_allocator]
static ALLOCATOR: mimalloc::MiMalloc = mimalloc::MiMalloc;

/// The native half of the `fog` package.
#[pymodule]
fn _fog(m: &Bound<'_, PyModule>) -> PyResult<()> {
    let py = m.py();
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add("FogError", py.get_type::<error::FogError>())?;
    m.add("NotFittedError", py.get_type::<error::NotFitted>())?;
    m.add_class::<models::GaussianProcess>()?;
    m.add_class::<models::Lssvr>()?;
    m.add_class::<models::Polynomial>()?;
    m.add_class::<firmware::Model>()?;
    m.add_class::<firmware::Compensated>()?;
    m.add_function(wrap_pyfunction!(firmware::load_model, m)?)?;
    m.add_function(wrap_pyfunction!(analysis::allan, m)?)?;
    m.add_function(wrap_pyfunction!(analysis::summarize, m)?)?;
    m.add_function(wrap_pyfunction!(analysis::log_format, m)?)?;
    m.add_function(wrap_pyfunction!(commands::trainer, m)?)?;
    Ok(())
}
