//! States from Python: a 1-D numpy array of float64 is read in place, anything else that
//! numpy accepts as a 1-D sequence of numbers (a list, a tuple, an int array) is converted,
//! and a wrong shape is a `ValueError` naming the argument, the shape found and the one
//! expected.

use numpy::{PyReadonlyArray1, PyUntypedArrayMethods};
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;

/// The coordinates' names for a state of dimension `dim` (`q1..qn, p1..pn`), shortened for a
/// large `dim`.
pub fn layout(dim: usize) -> String {
    let n = dim / 2;
    match n {
        0 => "no coordinates".to_string(),
        1 => "q1, p1".to_string(),
        2 => "q1, q2, p1, p2".to_string(),
        _ => format!("q1..q{n}, p1..p{n}"),
    }
}

/// A shape as Python prints it: `(4,)`, `(2, 4)`.
fn shape(dims: &[usize]) -> String {
    match dims {
        [n] => format!("({n},)"),
        _ => {
            let parts: Vec<String> = dims.iter().map(usize::to_string).collect();
            format!("({})", parts.join(", "))
        }
    }
}

/// `obj` as a state of length `dim`, for the argument `name`.
pub fn read(obj: &Bound<'_, PyAny>, name: &str, dim: usize) -> PyResult<Vec<f64>> {
    let values = values(obj, name, dim)?;
    if values.len() != dim {
        return Err(PyValueError::new_err(format!(
            "{name} has length {}, expected {dim} ({})",
            values.len(),
            layout(dim)
        )));
    }
    Ok(values)
}

/// `obj` as a 1-D vector of any length (`dim` only for the messages).
pub fn values(obj: &Bound<'_, PyAny>, name: &str, dim: usize) -> PyResult<Vec<f64>> {
    Ok(
        if let Ok(array) = obj.extract::<PyReadonlyArray1<'_, f64>>() {
            match array.as_slice() {
                Ok(slice) => slice.to_vec(),
                Err(_) => array.as_array().to_vec(),
            }
        } else if let Ok(array) = obj.cast::<numpy::PyUntypedArray>() {
            if array.ndim() != 1 {
                return Err(PyValueError::new_err(format!(
                    "{name} has shape {}, expected ({dim},): one state ({})",
                    shape(array.shape()),
                    layout(dim)
                )));
            }
            // An integer or float32 array: read as float64.
            let converted = obj.call_method1("astype", ("float64",)).map_err(|_| {
                PyTypeError::new_err(format!(
                    "{name} has dtype {}, which is not a number type",
                    array.dtype()
                ))
            })?;
            return values(&converted, name, dim);
        } else {
            obj.extract::<Vec<f64>>().map_err(|_| {
                PyTypeError::new_err(format!(
                    "{name} must be a 1-D sequence of {dim} floats ({}), not {}",
                    layout(dim),
                    obj.get_type()
                        .name()
                        .map_or_else(|_| "this type".to_string(), |n| n.to_string())
                ))
            })?
        },
    )
}
