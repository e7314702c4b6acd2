//! The package's exceptions: `fog.FogError` for what the trainer or the firmware refuses (the
//! message is the command line's), `fog.NotFittedError` for a model asked before `fit`.

use pyo3::create_exception;
use pyo3::exceptions::PyValueError;

create_exception!(
    _fog,
    FogError,
    PyValueError,
    "What the trainer or the firmware refuses: bad data, a blob that does not decode, a fit that \
     cannot be made. The message is the one the command line prints."
);
create_exception!(
    _fog,
    NotFitted,
    PyValueError,
    "A model asked for a prediction before it was fitted."
);

/// `e` as the command line prints it: the error and its causes, joined by ": ".
pub fn fog_error(e: impl Into<anyhow::Error>) -> pyo3::PyErr {
    FogError::new_err(format!("{:#}", e.into()))
}
