//! Scenes from Python: views put into scenes in memory ([`scene`]), and what a rendered or
//! restaged view's scene is ([`Info`]: the object's mask, the pixels occluders cover, and each
//! view's record) as numpy arrays and plain tuples.

use crate::py_err;
use linpose::image_io::{ColorMode, ImageSpec};
use linpose::render::background::BackgroundSpec;
use linpose::render::scene::{SceneRecord, SceneSpec};
use linpose::scene::restage_view;
use numpy::{PyArray1, PyArrayDyn, PyArrayMethods, PyReadonlyArrayDyn, PyUntypedArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use rayon::prelude::*;
use std::path::Path;

/// An occluder as `(shape, cx, cy, hx, hy)`: "rect" or "ellipse", centre and half-sizes in pixels.
type OccluderTuple = (String, f64, f64, f64, f64);

/// A record as `(image, background, seed, occlude, hidden, object_pixels, occluders)`.
pub(crate) type RecordTuple = (String, String, u64, f64, f64, usize, Vec<OccluderTuple>);

/// What views' scenes are: `(mask (n, h, w) bool, occluded (n, h, w) bool, records)`.
pub(crate) type Info<'py> = (Bound<'py, PyArrayDyn<bool>>, Bound<'py, PyArrayDyn<bool>>, Vec<RecordTuple>);

/// The scene `(background, occlude, seed)` as the package passes it, for views of `width` x
/// `height`.
pub(crate) fn scene_spec(background: &str, occlude: f64, seed: u64) -> PyResult<SceneSpec> {
    Ok(SceneSpec { background: BackgroundSpec::parse(background).map_err(py_err)?, occlude, seed, canvas: None })
}

/// The arrays and tuples of views' scenes: `masks` (n x h x w), the occluders of `records` (one
/// per view, or none when the scene had none).
pub(crate) fn info<'py>(py: Python<'py>, dims: [usize; 3], masks: Vec<bool>, records: &[SceneRecord]) -> PyResult<Info<'py>> {
    let [n, h, w] = dims;
    let mut occluded = vec![false; n * h * w];
    for (i, r) in records.iter().enumerate() {
        for o in &r.occluders {
            let [x0, y0, x1, y1] = o.bounds(w, h);
            for y in y0..y1 {
                for x in x0..x1 {
                    occluded[(i * h + y) * w + x] |= o.covers(x, y);
                }
            }
        }
    }
    let mask = PyArray1::from_vec(py, masks).reshape(vec![n, h, w])?;
    let occluded = PyArray1::from_vec(py, occluded).reshape(vec![n, h, w])?;
    let tuples = records
        .iter()
        .map(|r| {
            let occluders = r.occluders.iter().map(|o| (o.shape.name().to_string(), o.centre[0], o.centre[1], o.half[0], o.half[1])).collect();
            (r.image.clone(), r.background.to_string(), r.seed, r.occlude, r.hidden, r.object_pixels, occluders)
        })
        .collect();
    Ok((mask, occluded, tuples))
}

/// Puts studio views into scenes in memory, as `linpose scene` does to a data set's: `images`
/// uint8 (n, h, w) gray or (n, h, w, 3) RGB; `(background, occlude, seed)` as the package's
/// `linpose.scene` takes them (the background as a string). Returns `(images, info)`, the images
/// in the input's shape; view i draws the scene's view i. A view without an object to find is a
/// ValueError naming its index.
#[pyfunction]
pub(crate) fn scene<'py>(py: Python<'py>, images: PyReadonlyArrayDyn<'py, u8>, scene: (String, f64, u64)) -> PyResult<(Bound<'py, PyArrayDyn<u8>>, Info<'py>)> {
    let (background, occlude, seed) = scene;
    let shape = images.shape().to_vec();
    let (n, h, w, color) = match shape[..] {
        [n, h, w] => (n, h, w, ColorMode::Gray),
        [n, h, w, 3] => (n, h, w, ColorMode::Rgb),
        _ => return Err(PyValueError::new_err(format!("images of shape {shape:?}: expected (n, h, w) gray or (n, h, w, 3) RGB uint8"))),
    };
    if n == 0 || h == 0 || w == 0 {
        return Err(PyValueError::new_err(format!("images of shape {shape:?}: no pixels")));
    }
    let spec = ImageSpec { width: w as u32, height: h as u32, color };
    let mut pixels: Vec<u8> = images.as_array().iter().copied().collect();
    let scene = scene_spec(&background, occlude, seed)?.open(spec.width, spec.height).map_err(py_err)?;
    let per = spec.features();
    let results: Vec<linpose::Result<(Vec<bool>, SceneRecord)>> = py.detach(|| {
        pixels
            .par_chunks_mut(per)
            .enumerate()
            .map(|(i, view)| {
                let name = format!("image {i}");
                let r = restage_view(&scene, i, &name, Path::new(&name), spec, view)?;
                Ok((r.object.mask, r.record))
            })
            .collect()
    });
    let mut masks = Vec::with_capacity(n * h * w);
    let mut records = Vec::with_capacity(n);
    for r in results {
        let (mask, record) = r.map_err(py_err)?;
        masks.extend(mask);
        records.push(record);
    }
    let out = PyArray1::from_vec(py, pixels).reshape(shape)?;
    Ok((out, info(py, [n, h, w], masks, &records)?))
}
