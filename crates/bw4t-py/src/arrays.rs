//! Caller-allocated NumPy arrays as Rust slices: C-contiguous, of the expected size, or a
//! `ValueError` that names the argument.

use numpy::{Element, PyReadonlyArrayDyn, PyReadwriteArrayDyn, PyUntypedArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;

fn check(name: &str, contiguous: bool, len: Option<usize>, want: usize, shape: &str) -> PyResult<()> {
    if !contiguous {
        return Err(PyValueError::new_err(format!(
            "{name} must be a C-contiguous array (np.ascontiguousarray)"
        )));
    }
    match len {
        Some(n) if n == want => Ok(()),
        Some(n) => {
            Err(PyValueError::new_err(format!("{name} holds {n} values; it must hold {want} ({shape})")))
        }
        None => Err(PyValueError::new_err(format!("{name} is not contiguous or is misaligned"))),
    }
}

/// `array` as a mutable slice of `want` values (`shape` says how they are laid out).
pub(crate) fn writable<'a, T: Element>(
    array: &'a mut PyReadwriteArrayDyn<'_, T>,
    name: &str,
    want: usize,
    shape: &str,
) -> PyResult<&'a mut [T]> {
    let contiguous = array.is_c_contiguous();
    let len = array.as_slice_mut().ok().map(|s| s.len());
    check(name, contiguous, len, want, shape)?;
    array.as_slice_mut().map_err(|e| PyValueError::new_err(format!("{name}: {e}")))
}

/// `array` as a slice of `want` values.
pub(crate) fn readable<'a, T: Element>(
    array: &'a PyReadonlyArrayDyn<'_, T>,
    name: &str,
    want: usize,
    shape: &str,
) -> PyResult<&'a [T]> {
    let contiguous = array.is_c_contiguous();
    let len = array.as_slice().ok().map(|s| s.len());
    check(name, contiguous, len, want, shape)?;
    array.as_slice().map_err(|e| PyValueError::new_err(format!("{name}: {e}")))
}
