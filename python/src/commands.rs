//! The trainer's commands run in this process, as `trainer` runs them: the arguments parsed by
//! its own command line ([`trainer::cli::Cli`]) and the work done by [`trainer::cli::run`], so a
//! calibration from Python is the command's, its files and its messages included. The `fog`
//! package builds the arguments from keywords and reads the files back (`fog.calibrate`,
//! `fog.investigate`).

use ::trainer::cli::{Cli, run};
use clap::Parser;
use pyo3::prelude::*;

use crate::error::{FogError, fog_error};

/// Runs `trainer ARGS…` without the GIL; raises `FogError` with the command's own message
/// (a flag it does not take, a log it cannot read, a fit it refuses).
#[pyfunction]
pub fn trainer(py: Python<'_>, args: Vec<String>) -> PyResult<()> {
    let cli = Cli::try_parse_from(std::iter::once("trainer".to_owned()).chain(args))
        .map_err(|e| FogError::new_err(e.render().to_string().trim_end().to_owned()))?;
    py.detach(|| run(cli)).map_err(fog_error)
}
