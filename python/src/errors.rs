//! The library's errors as Python exceptions: one line, the command line's words (a setting
//! is named by its keyword, `spp`, where the command line names its flag, `--spp`).

use pyo3::create_exception;
use pyo3::exceptions::PyException;
use pyo3::PyErr;
use raylink::Error;

create_exception!(
    raylink,
    RaylinkError,
    PyException,
    "A render, scene, setting or image the library refused or could not finish; the message \
     is the command line's one line."
);
create_exception!(
    raylink,
    Cancelled,
    RaylinkError,
    "Work cancelled (by a progress callback) in a phase with nothing to keep."
);

/// `e` as its Python exception.
pub fn to_py(e: Error) -> PyErr {
    let message = raylink::error::one_line(&e.to_string());
    match e {
        Error::Cancelled { .. } => Cancelled::new_err(message),
        _ => RaylinkError::new_err(message),
    }
}
