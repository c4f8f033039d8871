//! The Rust core of the `linpose` Python package: the library's models, renderer, data set
//! reader and error measure over numpy arrays, and the tasks of a distributed fit (partial
//! training statistics as bytes: `linpose.dask`). The Python layer (`python/linpose`) wraps it in
//! scikit-learn estimators; this module keeps to arrays, bytes and plain values.
//!
//! Every call that fits, estimates, renders or reads releases the interpreter lock
//! ([`Python::detach`]), so Python threads run beside it. Inputs that are C-contiguous `uint8` or
//! `float32` arrays are read where they lie; other dtypes and layouts are converted once. Errors
//! are Python exceptions carrying the library's message: `ValueError` for bad values,
//! `OSError` for files, `TypeError` for inputs of the wrong kind.

#![warn(unreachable_pub)]

mod arrays;
mod data;
mod model;
mod objects;
mod partial;
mod scenes;

use pyo3::prelude::*;

/// The library's error as the Python exception a caller expects.
pub(crate) fn py_err(e: linpose::Error) -> PyErr {
    match e {
        linpose::Error::Io { .. } => pyo3::exceptions::PyOSError::new_err(e.to_string()),
        e => pyo3::exceptions::PyValueError::new_err(e.to_string()),
    }
}

/// linpose's Rust core (see the `linpose` package for the documented interface).
#[pymodule]
fn _linpose(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("__version__", env!("CARGO_PKG_VERSION"))?;
    m.add("FORMAT_VERSION", linpose::model_file::FORMAT_VERSION)?;
    m.add_class::<model::Model>()?;
    m.add_class::<model::Serve>()?;
    m.add_function(wrap_pyfunction!(model::fit, m)?)?;
    m.add_function(wrap_pyfunction!(model::load, m)?)?;
    m.add_function(wrap_pyfunction!(model::methods, m)?)?;
    m.add_function(wrap_pyfunction!(model::merging_methods, m)?)?;
    m.add_function(wrap_pyfunction!(objects::recognizers, m)?)?;
    m.add_class::<objects::Objects>()?;
    m.add_function(wrap_pyfunction!(objects::fit_objects, m)?)?;
    m.add_function(wrap_pyfunction!(objects::load_objects, m)?)?;
    m.add_function(wrap_pyfunction!(objects::holds_objects, m)?)?;
    m.add_function(wrap_pyfunction!(objects::bytes_hold_objects, m)?)?;
    m.add_function(wrap_pyfunction!(data::synth, m)?)?;
    m.add_function(wrap_pyfunction!(scenes::scene, m)?)?;
    m.add_function(wrap_pyfunction!(data::read_dataset, m)?)?;
    m.add_function(wrap_pyfunction!(data::pose_error, m)?)?;
    m.add_function(wrap_pyfunction!(data::train_mask, m)?)?;
    m.add_function(wrap_pyfunction!(partial::partial_plan, m)?)?;
    m.add_function(wrap_pyfunction!(partial::partial_read_shard, m)?)?;
    m.add_function(wrap_pyfunction!(partial::partial_merge, m)?)?;
    m.add_function(wrap_pyfunction!(partial::partial_finish, m)?)?;
    m.add_function(wrap_pyfunction!(partial::partial_describe, m)?)?;
    Ok(())
}
