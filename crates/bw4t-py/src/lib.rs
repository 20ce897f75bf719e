//! `bw4t._native`: the Rust half of the Python package. Environments (`EnvSpec`, `Env`,
//! `VecEnv`) write into NumPy arrays the caller allocated and step
//! without holding the interpreter; the command line runs as `bw4t` from the wheel.
//!
//! The Python half (`python/bw4t`) wraps these in PettingZoo, Gymnasium and vector
//! environments and an in-process match; everything here is deliberately plain.

mod arrays;
mod env;
mod spec;
mod vector;

use std::ffi::OsString;
use std::sync::{Mutex, MutexGuard, TryLockError};

use pyo3::exceptions::PyRuntimeError;
use pyo3::prelude::*;

/// `what`'s lock, or an error when another thread is using it: waiting could deadlock (the
/// waiter holds the interpreter, which the call in progress needs back to return).
fn locked<'a, T>(mutex: &'a Mutex<T>, what: &str) -> PyResult<MutexGuard<'a, T>> {
    match mutex.try_lock() {
        Ok(guard) => Ok(guard),
        Err(TryLockError::Poisoned(_)) => Err(PyRuntimeError::new_err(format!(
            "this {what} stopped in the middle of a call (an internal error, reported then); make a new one"
        ))),
        Err(TryLockError::WouldBlock) => {
            Err(PyRuntimeError::new_err(format!("this {what} is in use by another thread")))
        }
    }
}

/// Runs the `bw4t` command line with `argv` (the first is the program's name) and
/// returns its exit status. `self_command` is how to start it again as a child process.
#[pyfunction]
fn cli_main(py: Python<'_>, argv: Vec<String>, self_command: Vec<String>) -> u8 {
    let argv: Vec<OsString> = argv.into_iter().map(OsString::from).collect();
    let again: Vec<OsString> = self_command.into_iter().map(OsString::from).collect();
    py.detach(move || bw4t_cli::main(argv, Some(again)))
}

/// The names of the maps shipped with bw4t.
#[pyfunction]
fn shipped_maps() -> Vec<&'static str> {
    bw4t_cli::shipped_maps().collect()
}

/// The names of the built-in teammates' strategies (`coop` first).
#[pyfunction]
fn strategies() -> Vec<&'static str> {
    bw4t_agents::Strategy::ALL.iter().map(|s| s.name()).collect()
}

/// The module.
#[pymodule]
fn _native(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add_function(wrap_pyfunction!(cli_main, m)?)?;
    m.add_function(wrap_pyfunction!(shipped_maps, m)?)?;
    m.add_function(wrap_pyfunction!(strategies, m)?)?;
    m.add_class::<spec::EnvSpec>()?;
    m.add_class::<env::Env>()?;
    m.add_class::<vector::VecEnv>()?;
    m.add("VERSION", env!("CARGO_PKG_VERSION"))?;
    Ok(())
}
