//! The exceptions: [`HamiltonianError`] (a `ValueError` with the position of the offending
//! token) and [`IntegrationError`] (a `RuntimeError` carrying the partial solution), and the
//! conversions from the crates' error types.

use pyo3::create_exception;
use pyo3::exceptions::{PyRuntimeError, PyValueError};
use pyo3::prelude::*;
use pyo3::types::PyList;

use dth::runtime::RuntimeError;

create_exception!(
    dth,
    HamiltonianError,
    PyValueError,
    "A Hamiltonian text that does not compile, or a bad parameter.\n\n\
     Attributes: `line` and `column` (1-based) of the first offending token (None for an error \
     without a position, such as an unknown parameter), `errors`: every independent error as \
     (message, line, column), and `source`: the text."
);

create_exception!(
    dth,
    IntegrationError,
    PyRuntimeError,
    "An integration that stopped before its end (a step that did not converge, a breakdown, \
     an interrupted run) raised with `raise_on_failure=True`.\n\n\
     Attributes: `solution`, the partial `Solution` up to the last accepted step, and \
     `kind`, the failure's name."
);

/// One error's message and its 1-based (line, column), when it has a position.
type Located = (String, Option<(usize, usize)>);

/// 1-based (line, column) of byte `offset` in `text` (columns count characters).
fn line_column(text: &str, offset: usize) -> (usize, usize) {
    dth_examples::scene::line_col(text, offset.min(text.len()))
}

/// `e` as the exception a Python user catches: a [`HamiltonianError`] with its positions for an
/// expression that does not compile or a bad parameter; anything else (a JIT or evaluation
/// failure) a `RuntimeError`.
pub fn hamiltonian_error(py: Python<'_>, source: &str, e: &RuntimeError) -> PyErr {
    let (message, positions): (String, Vec<Located>) = match e {
        RuntimeError::Expression(errors) => (
            format!(
                "the Hamiltonian does not compile:\n{}",
                dth_examples::derive::render_errors(source, errors)
            ),
            errors
                .0
                .iter()
                .map(|e| (e.to_string(), Some(line_column(source, e.span.start))))
                .collect(),
        ),
        RuntimeError::UnknownParameter { .. } | RuntimeError::NonFiniteParameter { .. } => {
            (e.to_string(), vec![(e.to_string(), None)])
        }
        other => return PyRuntimeError::new_err(other.to_string()),
    };
    let err = HamiltonianError::new_err(message);
    if let Err(failed) = annotate(py, &err, source, &positions) {
        return failed;
    }
    err
}

/// Sets `line`, `column`, `errors` and `source` on the exception value.
fn annotate(py: Python<'_>, err: &PyErr, source: &str, positions: &[Located]) -> PyResult<()> {
    let value = err.value(py);
    let first = positions.first().and_then(|(_, at)| *at);
    value.setattr("line", first.map(|(l, _)| l))?;
    value.setattr("column", first.map(|(_, c)| c))?;
    let list = PyList::empty(py);
    for (message, at) in positions {
        list.append((message, at.map(|(l, _)| l), at.map(|(_, c)| c)))?;
    }
    value.setattr("errors", list)?;
    value.setattr("source", source)?;
    Ok(())
}

/// A DTH option refused by `dth` (a non-positive `dtau`, an order that does not exist) as the
/// `ValueError` naming the argument.
pub fn option_error(e: &dth::Error) -> PyErr {
    PyValueError::new_err(e.to_string())
}
