//! Data for the models: the renderer ([`synth`]), the data set reader ([`read_dataset`]), the
//! paper's training selection ([`train_mask`]) and the error measure ([`pose_error`]), all as
//! numpy arrays.

use crate::model::{array2, space};
use crate::py_err;
use linpose::dataset::{first_gray8, load_gray8_into};
use linpose::image_io::ColorMode;
use linpose::render::synth::{render_scenes, render_u8, PoseGrid};
use linpose::render::{objects, Camera, Grid, Jitter, Light, Mesh, RenderParams};
use linpose::{Dataset, Manifest, TrainSelection};
use numpy::{PyArray1, PyArray3, PyArrayMethods, PyReadonlyArray2, PyUntypedArray, PyUntypedArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use std::path::{Path, PathBuf};

/// The pose parameters of a rendered data set, as `(name, period)` pairs.
type Params = Vec<(String, Option<f64>)>;

/// Renders a turntable data set in memory, as `linpose synth` writes it: `(images (n, h, w)
/// uint8, poses (n, K) degrees, params)`, poses elevation-major over `elevation`, `azimuth` and,
/// when given, `roll` and `light` (`START:STOP:STEP` degrees). The arguments come grouped from
/// the package's `linpose.synth` (which documents them): `source` = `(object, random, mesh)`,
/// `poses` = `(azimuth, elevation, roll, light)`, `look` = `(size, perspective, specular)`,
/// `jitter` = `(shift, scale, exposure)` or None, and its seed, `scene` = `(background, occlude,
/// seed, info)` (the background as `linpose synth --background` takes it). With `info` the
/// views' scenes come fourth ([`crate::scenes::Info`]), else None.
#[pyfunction]
#[allow(clippy::type_complexity)]
pub(crate) fn synth<'py>(
    py: Python<'py>,
    source: (Option<String>, Option<u64>, Option<PathBuf>),
    poses: (String, String, Option<String>, Option<String>),
    look: ((u32, u32), bool, f64),
    jitter: (Option<(f64, f64, f64)>, u64),
    scene: (String, f64, u64, bool),
) -> PyResult<(Bound<'py, PyArray3<u8>>, Bound<'py, numpy::PyArray2<f64>>, Params, Option<crate::scenes::Info<'py>>)> {
    let ((object, random, mesh), (azimuth, elevation, roll, light), (size, perspective, specular), (jitter, jitter_seed)) = (source, poses, look, jitter);
    let (background, occlude, scene_seed, want_info) = scene;
    let (object, azimuth, elevation) = (object.as_deref(), azimuth.as_str(), elevation.as_str());
    let mesh: Mesh = match (object, random, &mesh) {
        (Some(name), None, None) => objects::builtin(name).map_err(py_err)?,
        (None, Some(seed), None) => objects::random(seed).map_err(py_err)?,
        (None, None, Some(path)) => Mesh::from_obj(path).map_err(py_err)?,
        _ => return Err(PyValueError::new_err("give one of object (a built-in name), random (a seed) or mesh (an OBJ file)")),
    };
    let mut grid = PoseGrid::new(Grid::parse("elevation", elevation).map_err(py_err)?, Grid::parse("azimuth", azimuth).map_err(py_err)?).map_err(py_err)?;
    if let Some(spec) = &roll {
        grid = grid.with_roll(Grid::parse("roll", spec).map_err(py_err)?).map_err(py_err)?;
    }
    if let Some(spec) = &light {
        grid = grid.with_light(Grid::parse("light", spec).map_err(py_err)?).map_err(py_err)?;
    }
    if let Some((shift, scale, exposure)) = jitter {
        let j = Jitter::parse(&format!("{shift},{scale},{exposure}"), jitter_seed).map_err(py_err)?;
        grid = grid.with_jitter(j).map_err(py_err)?;
    }
    let (w, h) = size;
    if w == 0 || h == 0 {
        return Err(PyValueError::new_err(format!("size=({w}, {h}): width and height must be positive")));
    }
    let camera = if perspective { Camera::perspective() } else { Camera::default() };
    let params = RenderParams::default().width(w).height(h).camera(camera).light(Light::default().specular(specular));
    params.validate().map_err(py_err)?;
    let grid = grid.with_scene(crate::scenes::scene_spec(&background, occlude, scene_seed)?.open(w, h).map_err(py_err)?);
    let manifest = grid.manifest(Path::new("")).map_err(py_err)?;
    let n = grid.len();
    // The masks only when asked for: they take as much memory as the images.
    let (pixels, info) = match want_info {
        true => {
            let views = py.detach(|| render_scenes(&mesh, &grid, &params, &|_| {})).map_err(py_err)?;
            (views.pixels, Some(crate::scenes::info(py, [n, h as usize, w as usize], views.masks, &views.records)?))
        }
        false => (py.detach(|| render_u8(&mesh, &grid, &params, &|_| {})).map_err(py_err)?, None),
    };
    let images = PyArray1::from_vec(py, pixels).reshape([n, h as usize, w as usize])?;
    let poses = array2(py, manifest.poses().to_vec(), n, manifest.space().len())?;
    Ok((images, poses, manifest.space().params().iter().map(|p| (p.name.clone(), p.period)).collect(), info))
}

/// Reads a data set folder (`poses.csv` beside its images, or a COIL folder with `object`):
/// `(images (n, h, w), poses (n, K) degrees, params, names)`. The images are `uint8` when every
/// one is 8-bit gray (or colour turned gray), else `float32` features in [0, 1].
#[pyfunction]
#[allow(clippy::type_complexity)]
#[pyo3(signature = (path, object=None))]
pub(crate) fn read_dataset<'py>(
    py: Python<'py>,
    path: PathBuf,
    object: Option<u32>,
) -> PyResult<(Bound<'py, PyUntypedArray>, Bound<'py, numpy::PyArray2<f64>>, Params, Vec<String>)> {
    let manifest = Manifest::open(&path, object).map_err(py_err)?;
    let n = manifest.len();
    // 8-bit images as they are, read into an array numpy allocates (so it is numpy's in every
    // way, huge pages for a large one included: a large batch is then predicted 4-7% faster
    // than from 4 kB pages, BENCHMARKS.md "From Python"); otherwise the features the library's
    // loader reads.
    let first = py.detach(|| first_gray8(&manifest)).map_err(py_err)?;
    let gray8 = match first {
        Some((spec, row0)) => {
            let dims = (n, spec.height as usize, spec.width as usize);
            // numpy.empty: a size that cannot be allocated is numpy's MemoryError.
            let array = py.import("numpy")?.getattr("empty")?.call1((dims, "uint8"))?.cast_into::<PyArray3<u8>>()?;
            let read = {
                let mut rw = array.readwrite();
                let out = rw.as_slice_mut().map_err(|e| PyValueError::new_err(format!("{e}")))?;
                py.detach(|| load_gray8_into(&manifest, spec, &row0, out, &|_| {})).map_err(py_err)?
            };
            read.then(|| array.into_any())
        }
        None => None,
    };
    let array = match gray8 {
        Some(a) => a,
        None => {
            let data = py.detach(|| Dataset::load(manifest.clone(), ColorMode::Gray, &|_| {})).map_err(py_err)?;
            let spec = data.spec();
            PyArray1::from_slice(py, data.features()).reshape([n, spec.height as usize, spec.width as usize])?.into_any()
        }
    }
    .cast_into::<PyUntypedArray>()?;
    let k = manifest.space().len();
    let poses = array2(py, manifest.poses().to_vec(), n, k)?;
    let params = manifest.space().params().iter().map(|p| (p.name.clone(), p.period)).collect();
    Ok((array, poses, params, manifest.images().to_vec()))
}

/// Which rows of `poses` the paper's protocol trains on: every parameter a multiple of `step`
/// degrees from its smallest value (as `linpose train --train-step`).
#[pyfunction]
pub(crate) fn train_mask<'py>(py: Python<'py>, poses: PyReadonlyArray2<'py, f64>, params: Params, step: f64) -> PyResult<Bound<'py, PyArray1<bool>>> {
    let space = space(params)?;
    let (n, k) = (poses.shape()[0], poses.shape()[1]);
    if k != space.len() {
        return Err(PyValueError::new_err(format!("poses have {k} columns for {} pose parameters", space.len())));
    }
    let names = (0..n).map(|i| format!("sample {i}")).collect();
    let manifest = Manifest::new("", space, names, poses.as_array().iter().copied().collect()).map_err(py_err)?;
    let mask = manifest.training_mask(&TrainSelection::Step(step)).map_err(py_err)?;
    Ok(PyArray1::from_vec(py, mask))
}

/// The pose error of each row (degrees): the angle on the viewing sphere between the true and
/// the estimated pose (the measure `linpose eval` reports).
#[pyfunction]
pub(crate) fn pose_error<'py>(
    py: Python<'py>,
    y_true: PyReadonlyArray2<'py, f64>,
    y_pred: PyReadonlyArray2<'py, f64>,
    params: Params,
) -> PyResult<Bound<'py, PyArray1<f64>>> {
    let space = space(params)?;
    let (a, b) = (y_true.as_array(), y_pred.as_array());
    if a.shape() != b.shape() || a.shape()[1] != space.len() {
        return Err(PyValueError::new_err(format!(
            "y_true has shape {:?} and y_pred {:?}; both need one column per pose parameter ({})",
            a.shape(),
            b.shape(),
            space.len()
        )));
    }
    let errors = a.outer_iter().zip(b.outer_iter()).map(|(t, e)| space.error_deg(&t.to_vec(), &e.to_vec())).collect();
    Ok(PyArray1::from_vec(py, errors))
}
