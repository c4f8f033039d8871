//! Training statistics that merge ([`linpose::partial::Partial`]) as the tasks of a distributed
//! fit (`linpose.dask`): [`partial_plan`] says how the training set is cut, [`partial_read_shard`]
//! reads one shard's images from disk into partial statistics, [`partial_merge`] adds two, and
//! [`partial_finish`] fits the model. Partial statistics travel as the bytes of their file
//! (`linpose train --shard I/N --partial FILE` writes the same), so any engine can move them.
//!
//! The training set is given as image paths (each read where the task runs, so every worker must
//! see them) with their poses; the first image gives the image size, which the planner returns
//! and the shard tasks take, so an image of another size is an error naming its file.

use crate::model::{space, Model};
use crate::py_err;
use linpose::image_io::{ColorMode, ImageSpec};
use linpose::partial::Partial;
use linpose::{Manifest, Method, Settings};
use numpy::{PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyBytes;
use std::path::Path;

/// The pose parameters as `(name, period)` pairs.
type Params = Vec<(String, Option<f64>)>;

/// The method, settings and manifest of a fit on the images `paths` (read as they are written:
/// absolute, or relative to the working folder) at `poses`.
fn fit_of(
    method: &str,
    settings: Vec<(String, String)>,
    paths: Vec<String>,
    poses: PyReadonlyArray2<'_, f64>,
    params: Params,
) -> PyResult<(&'static Method, Settings, Manifest)> {
    let (method, settings, _) = crate::model::method_of(method, settings)?;
    let space = space(params)?;
    let (n, k) = (poses.shape()[0], poses.shape()[1]);
    if n != paths.len() || k != space.len() {
        return Err(PyValueError::new_err(format!(
            "poses have shape ({n}, {k}); {} images of {} pose parameters need ({}, {})",
            paths.len(),
            space.len(),
            paths.len(),
            space.len()
        )));
    }
    let poses: Vec<f64> = poses.as_array().iter().copied().collect();
    let manifest = Manifest::new("", space, paths, poses).map_err(py_err)?;
    Ok((method, settings, manifest))
}

/// How the fit of `method` with `settings` on the images `paths` at `poses` is cut into shards:
/// `(split, units, width, height, stats_bytes)`: `"images"` or `"pixels"`, how many images or
/// pixels the shards share, the size of the first image (which every other must have), and the
/// bytes of a partial's sums (X^T X, or the Gram matrix; a shard of pixels also holds its pixels,
/// 4 N bytes each).
#[pyfunction]
#[pyo3(signature = (method, settings, paths, poses, params))]
pub(crate) fn partial_plan(
    py: Python<'_>,
    method: &str,
    settings: Vec<(String, String)>,
    paths: Vec<String>,
    poses: PyReadonlyArray2<'_, f64>,
    params: Params,
) -> PyResult<(&'static str, usize, u32, u32, usize)> {
    let (method, settings, manifest) = fit_of(method, settings, paths, poses, params)?;
    py.detach(|| {
        let partial = Partial::for_images(method, &settings, &manifest, ColorMode::Gray)?;
        let (w, h) = partial.image_size();
        Ok((partial.split().unit(), partial.units(), w, h, partial.bytes()))
    })
    .map_err(py_err)
}

/// Reads shard `index` (0-based) of `count` of the fit's training images (`width` x `height`,
/// as [`partial_plan`] found them) from disk: its partial statistics, as a file's bytes. The
/// fit is `(method, settings)`, the data `(paths, poses, params)`, the size `(width, height)`
/// and the shard `(index, count)`.
#[pyfunction]
pub(crate) fn partial_read_shard<'py>(
    py: Python<'py>,
    fit: (String, Vec<(String, String)>),
    data: (Vec<String>, PyReadonlyArray2<'_, f64>, Params),
    size: (u32, u32),
    shard: (usize, usize),
) -> PyResult<Bound<'py, PyBytes>> {
    let ((method, settings), (paths, poses, params), (width, height), (index, count)) = (fit, data, size, shard);
    let method = method.as_str();
    let (method, settings, manifest) = fit_of(method, settings, paths, poses, params)?;
    let spec = ImageSpec { width, height, color: ColorMode::Gray };
    let partial = py
        .detach(|| {
            let source = format!("shard {}/{count}", index + 1);
            let mut partial = Partial::new(method, &settings, &manifest, spec)?.with_source(source);
            partial.read_shard(&manifest, ColorMode::Gray, index, count, &|_| {})?;
            Ok(partial)
        })
        .map_err(py_err)?;
    to_py_bytes(py, &partial)
}

/// The statistics' file bytes written straight into a Python `bytes` (no copy beside them).
fn to_py_bytes<'py>(py: Python<'py>, partial: &Partial) -> PyResult<Bound<'py, PyBytes>> {
    let len = py.detach(|| partial.file_len());
    PyBytes::new_with(py, len, |buf| partial.write_into(buf).map_err(py_err))
}

/// Partial statistics from a file's bytes; `name` names them in errors.
fn parse(data: &[u8], name: &str) -> linpose::Result<Partial> {
    Partial::from_bytes(Path::new(name), data)
}

/// The sum of two partial statistics (of other images or pixels of one fit), as a file's bytes;
/// `a_name` and `b_name` name them in errors (e.g. the shards each holds).
#[pyfunction]
#[pyo3(signature = (a, b, a_name="partial statistics a", b_name="partial statistics b"))]
pub(crate) fn partial_merge<'py>(py: Python<'py>, a: &[u8], b: &[u8], a_name: &str, b_name: &str) -> PyResult<Bound<'py, PyBytes>> {
    // b's statistics are added and dropped before the sum is written: two sets of statistics
    // in memory at most, beside the inputs.
    let sum = py
        .detach(|| {
            let mut sum = parse(a, a_name)?;
            sum.merge(parse(b, b_name)?)?;
            Ok(sum)
        })
        .map_err(py_err)?;
    to_py_bytes(py, &sum)
}

/// The model fitted from partial statistics that cover the whole training set.
#[pyfunction]
#[pyo3(signature = (data, name="partial statistics"))]
pub(crate) fn partial_finish(py: Python<'_>, data: &[u8], name: &str) -> PyResult<Model> {
    let inner = py.detach(|| parse(data, name)?.finish()).map_err(py_err)?;
    Ok(Model::new(inner))
}

/// What partial statistics hold, in one line.
#[pyfunction]
pub(crate) fn partial_describe(py: Python<'_>, data: &[u8]) -> PyResult<String> {
    py.detach(|| parse(data, "partial statistics").map(|p| p.describe())).map_err(py_err)
}
