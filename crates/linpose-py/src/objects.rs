//! Many objects from arrays: [`Objects`] holds a recogniser (and, fitted with poses, each
//! object's pose model) and answers which object each image shows, "none of these", and the
//! pose; [`fit_objects`] fits one from images, object indices and, optionally, poses. A model's
//! bytes are its model file's bytes, the file `linpose train` writes for a data set of many
//! objects.

use crate::arrays::{pixels, Pixels};
use crate::model::{array2, check_rows, method_of, space, stage};
use crate::py_err;
use linpose::image_io::{ColorMode, ImageSpec};
use linpose::recognize::{Labels, ObjectModel, Recognition, Recognizer, RecognizerParams, Unknown};
use linpose::{model_file, Dataset, ObjectSet, Param, PoseSpace};
use numpy::{PyArray1, PyReadonlyArray1, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyBytes;
use std::path::{Path, PathBuf};

/// A fitted many-object model: a recogniser and, fitted with poses, each object's pose model.
#[pyclass(frozen, module = "linpose._linpose")]
pub struct Objects {
    inner: ObjectModel,
}

impl Objects {
    /// Checks that `x` holds whole images of the model's size; returns their number.
    fn check(&self, x: &Pixels<'_>) -> PyResult<usize> {
        check_rows(x, self.inner.spec())
    }
}

/// Recognitions as arrays: `(object (n,) int64, -1 for none of the known objects; nearest (n,)
/// int64; distance (n,); confidence (n,))`.
#[allow(clippy::type_complexity)]
fn recognition_arrays<'a, 'py>(
    py: Python<'py>,
    rec: impl Iterator<Item = &'a Recognition> + Clone,
) -> (Bound<'py, PyArray1<i64>>, Bound<'py, PyArray1<i64>>, Bound<'py, PyArray1<f64>>, Bound<'py, PyArray1<f64>>) {
    let object = rec.clone().map(|r| r.object.map_or(-1, |k| k as i64)).collect();
    let nearest = rec.clone().map(|r| r.nearest as i64).collect();
    let distance = rec.clone().map(|r| r.distance).collect();
    let confidence = rec.map(|r| r.confidence).collect();
    (PyArray1::from_vec(py, object), PyArray1::from_vec(py, nearest), PyArray1::from_vec(py, distance), PyArray1::from_vec(py, confidence))
}

#[pymethods]
impl Objects {
    /// Each image's object and pose: `(object (n,) int64, -1 for none of the known objects;
    /// nearest (n,) int64, the nearest object even when unknown; distance (n,), to it;
    /// confidence (n,), 1 - (distance / second distance)^2; pose (n, K) degrees, NaN for an
    /// unknown object, or None for a model fitted without poses)`. An image the normalisation
    /// stage cannot normalise is a ValueError naming its place.
    #[allow(clippy::type_complexity)]
    fn estimate<'py>(
        &self,
        py: Python<'py>,
        x: &Bound<'py, PyAny>,
    ) -> PyResult<(
        Bound<'py, PyArray1<i64>>,
        Bound<'py, PyArray1<i64>>,
        Bound<'py, PyArray1<f64>>,
        Bound<'py, PyArray1<f64>>,
        Option<Bound<'py, numpy::PyArray2<f64>>>,
    )> {
        let x = pixels(x, "X")?;
        let n = self.check(&x)?;
        let f = x.features("X")?;
        let model = &self.inner;
        let est = py.detach(|| model.estimate(&f, 1)).map_err(py_err)?;
        let (object, nearest, distance, confidence) = recognition_arrays(py, est.iter().map(|e| &e.recognition));
        let pose = match model.space() {
            None => None,
            Some(s) => {
                let k = s.len();
                let v: Vec<f64> = est.iter().flat_map(|e| e.pose.as_ref().map_or_else(|| vec![f64::NAN; k], |p| p.pose.clone())).collect();
                Some(array2(py, v, n, k)?)
            }
        };
        Ok((object, nearest, distance, confidence, pose))
    }

    /// Each image's object alone, without the pose (the pose models are not run):
    /// `(object, nearest, distance, confidence)` as [`Objects::estimate`] gives them.
    #[allow(clippy::type_complexity)]
    fn recognize<'py>(
        &self,
        py: Python<'py>,
        x: &Bound<'py, PyAny>,
    ) -> PyResult<(Bound<'py, PyArray1<i64>>, Bound<'py, PyArray1<i64>>, Bound<'py, PyArray1<f64>>, Bound<'py, PyArray1<f64>>)> {
        let x = pixels(x, "X")?;
        self.check(&x)?;
        let f = x.features("X")?;
        let model = &self.inner;
        let rec = py.detach(|| model.recognize(&f)).map_err(py_err)?;
        Ok(recognition_arrays(py, rec.iter()))
    }

    /// Each image's distance to each object (n, objects), the recogniser's measure (smaller:
    /// more like that object).
    fn distances<'py>(&self, py: Python<'py>, x: &Bound<'py, PyAny>) -> PyResult<Bound<'py, numpy::PyArray2<f64>>> {
        let x = pixels(x, "X")?;
        let n = self.check(&x)?;
        let f = x.features("X")?;
        let model = &self.inner;
        let d = py.detach(|| model.distances(&f)).map_err(py_err)?;
        array2(py, d, n, model.names().len())
    }

    /// The model file's bytes.
    fn to_bytes<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyBytes>> {
        let model = &self.inner;
        let bytes = py.detach(|| model.to_bytes()).map_err(py_err)?;
        Ok(PyBytes::new(py, &bytes))
    }

    /// The model of a many-object model file's bytes.
    #[staticmethod]
    fn from_bytes(py: Python<'_>, data: &[u8]) -> PyResult<Objects> {
        let inner = py.detach(|| ObjectModel::from_bytes(Path::new("<bytes>"), data)).map_err(py_err)?;
        Ok(Objects { inner })
    }

    /// Writes the model file (atomically); returns its size in bytes.
    fn save(&self, py: Python<'_>, path: PathBuf) -> PyResult<u64> {
        let model = &self.inner;
        py.detach(|| model.save(&path)).map_err(py_err)
    }

    /// The objects' names, in the order of their indices.
    #[getter]
    fn names(&self) -> Vec<String> {
        self.inner.names().to_vec()
    }

    /// The caller's labels for the objects as JSON (`values`, `unknown`, `kind`), or None: the
    /// names are the labels.
    #[getter]
    fn labels_json(&self) -> Option<String> {
        self.inner.labels().map(|l| serde_json::to_string(l).expect("the labels serialise"))
    }

    /// The recogniser's name (one of `recognizers()`).
    #[getter]
    fn recognizer(&self) -> &'static str {
        self.inner.kind().name
    }

    /// The pose method's name, `None` for a model fitted without poses.
    #[getter]
    fn method(&self) -> Option<&str> {
        self.inner.method_name()
    }

    /// (height, width) of the images the model takes.
    #[getter]
    fn image_shape(&self) -> (u32, u32) {
        (self.inner.spec().height, self.inner.spec().width)
    }

    /// Features per image.
    #[getter]
    fn n_features(&self) -> usize {
        self.inner.spec().features()
    }

    /// The pose parameters, `(name, period)` pairs (period `None`: linear); `None` for a model
    /// fitted without poses.
    #[getter]
    fn params(&self) -> Option<Vec<(String, Option<f64>)>> {
        self.inner.space().map(|s| s.params().iter().map(|p| (p.name.clone(), p.period)).collect())
    }

    /// The recogniser's settings and calibration, as JSON.
    #[getter]
    fn settings_json(&self) -> String {
        serde_json::to_string(self.inner.settings()).expect("the settings serialise")
    }

    /// Object `k`'s pose model's settings (as given and as chosen) as JSON, `None` without poses.
    fn pose_settings_json(&self, k: usize) -> PyResult<Option<String>> {
        if k >= self.inner.names().len() {
            return Err(PyValueError::new_err(format!("object {k}: the model knows {} objects", self.inner.names().len())));
        }
        Ok(self.inner.pose_model(k).map(|m| linpose::PoseModel::meta(m).settings.to_string()))
    }

    /// How the normalisation was decided (JSON), or None for a model fitted without a rule.
    #[getter]
    fn stage_choice_json(&self) -> Option<String> {
        self.inner.settings().stage_choice.as_ref().map(|c| serde_json::to_string(c).expect("the choice serialises"))
    }

    /// The normalisation stage as JSON, or `None` when images are used as they are.
    #[getter]
    fn normalize_json(&self) -> Option<String> {
        self.inner.stage().map(|n| serde_json::to_string(n).expect("the stage serialises"))
    }

    /// Bytes of the numbers the model stores to serve queries: the recogniser's and every pose
    /// model's.
    #[getter]
    fn model_bytes(&self) -> usize {
        self.inner.model_bytes()
    }

    fn __repr__(&self) -> String {
        let s = self.inner.spec();
        format!(
            "<linpose objects: {} recogniser, {} pose models, {} objects of {}x{}>",
            self.inner.kind().name,
            self.inner.method_name().unwrap_or("no"),
            self.inner.names().len(),
            s.width,
            s.height
        )
    }
}

/// The recognisers: `(name, summary)`, the default first.
#[pyfunction]
pub(crate) fn recognizers() -> Vec<(&'static str, &'static str)> {
    linpose::recognize::RECOGNIZERS.iter().map(|r| (r.name, r.summary)).collect()
}

/// Fits a many-object model on the images `x` (rows of `height` x `width` pixels) of the objects
/// `labels` (one index per image, 0 to `names.len()` - 1) named `names`: the recogniser
/// `recognizer` with `components`, `manifold_step` and the unknown-object rule `unknown`
/// (`calibrated`, `off`, or a distance), and with the poses `y` ((n, K) degrees) of the
/// parameters `params`, each object's pose model by `method` with `settings`; without `y`, the
/// recogniser alone on the views as points (`ObjectModel::fit_views`). `normalize`: `None`,
/// `all`, `geometry` or `brightness`. `caller_labels`: the caller's labels for the objects
/// (`linpose::recognize::Labels` as JSON), kept with the model and in its file.
///
/// The arguments come grouped from the package's `ObjectRecognizer.fit`: `recognizer` =
/// `(recognizer, components, manifold_step, unknown)`, `images` = `(x, height, width)`, `labels`
/// = `(labels, names, caller_labels)`, `poses` = `(y, params, method, settings)` or None.
/// The poses of [`fit_objects`]: `(y, params, method, settings)`.
type Poses<'py> = (PyReadonlyArray2<'py, f64>, Vec<(String, Option<f64>)>, String, Vec<(String, String)>);

#[pyfunction]
#[pyo3(signature = (recognizer, images, labels, poses=None, normalize=None))]
pub(crate) fn fit_objects(
    py: Python<'_>,
    recognizer: (String, usize, f64, Bound<'_, PyAny>),
    images: (Bound<'_, PyAny>, u32, u32),
    labels: (PyReadonlyArray1<'_, i64>, Vec<String>, Option<String>),
    poses: Option<Poses<'_>>,
    normalize: Option<&str>,
) -> PyResult<Objects> {
    let (recognizer, components, manifold_step, unknown) = recognizer;
    let (recognizer, unknown) = (recognizer.as_str(), &unknown);
    let (x, height, width) = images;
    let x = &x;
    let (labels, names, caller_labels) = labels;
    let caller_labels = caller_labels.as_deref();
    let (y, params, method, settings) = match poses {
        Some((y, params, method, settings)) => (Some(y), Some(params), Some(method), settings),
        None => (None, None, None, Vec::new()),
    };
    let method = method.as_deref();
    let caller_labels: Option<Labels> =
        caller_labels.map(|j| serde_json::from_str(j).map_err(|e| PyValueError::new_err(format!("caller_labels: not the labels' JSON ({e})")))).transpose()?;
    let unknown = if let Ok(s) = unknown.extract::<String>() {
        match s.as_str() {
            "calibrated" => Unknown::Calibrated,
            "off" => Unknown::Off,
            _ => return Err(PyValueError::new_err(format!("unknown={s:?}: expected 'calibrated', None (off) or a positive distance"))),
        }
    } else {
        Unknown::Threshold(unknown.extract::<f64>().map_err(|_| PyValueError::new_err("unknown: expected 'calibrated', None (off) or a positive distance"))?)
    };
    let rp = RecognizerParams::new(Recognizer::from_name(recognizer).map_err(py_err)?).components(components).manifold_step(manifold_step).unknown(unknown);
    let normalize = stage(normalize)?;
    let x = pixels(x, "X")?;
    let (n, m) = x.shape();
    let image = ImageSpec { width, height, color: ColorMode::Gray };
    if m != image.features() {
        return Err(PyValueError::new_err(format!("X has {m} values per image, but images of {width}x{height} have {}", image.features())));
    }
    let labels = labels.as_slice().map_err(|e| PyValueError::new_err(format!("labels: {e}")))?.to_vec();
    if labels.len() != n {
        return Err(PyValueError::new_err(format!("{} labels for {n} images", labels.len())));
    }
    let k = names.len();
    if let Some(&bad) = labels.iter().find(|&&l| l < 0 || l as usize >= k) {
        return Err(PyValueError::new_err(format!("label {bad}: the objects are numbered 0 to {}", k as i64 - 1)));
    }
    // Each object's rows, in the order given.
    let rows: Vec<Vec<usize>> = (0..k).map(|c| (0..n).filter(|&i| labels[i] == c as i64).collect()).collect();
    let posed = match (y, params, method) {
        (Some(y), Some(params), Some(method)) => {
            let space = space(params)?;
            let (ny, kp) = (y.shape()[0], y.shape()[1]);
            if ny != n || kp != space.len() {
                return Err(PyValueError::new_err(format!(
                    "y has shape ({ny}, {kp}); {n} images of {} pose parameters need ({n}, {})",
                    space.len(),
                    space.len()
                )));
            }
            let (_, _, spec) = method_of(method, settings)?;
            Some((space, y.as_array().iter().copied().collect::<Vec<f64>>(), spec))
        }
        (None, _, _) => None,
        _ => return Err(PyValueError::new_err("poses need their parameters and a pose method")),
    };
    // Without poses the data sets carry each view's place, which nothing reads.
    let place = PoseSpace::new(vec![Param::linear("view")]).map_err(py_err)?;
    let u8s = x.u8_slice();
    let features = if u8s.is_none() { Some(x.features("X")?) } else { None };
    let model = py
        .detach(|| {
            let sets = rows
                .iter()
                .map(|r| {
                    let (sp, poses) = match &posed {
                        Some((space, y, _)) => (space.clone(), r.iter().flat_map(|&i| y[i * space.len()..(i + 1) * space.len()].iter().copied()).collect()),
                        None => (place.clone(), (0..r.len()).map(|i| i as f64).collect()),
                    };
                    match (u8s, &features) {
                        (Some(p), _) => Dataset::from_u8(image, &r.iter().flat_map(|&i| p[i * m..(i + 1) * m].iter().copied()).collect::<Vec<u8>>(), sp, poses),
                        (None, Some(f)) => Dataset::new(image, r.iter().flat_map(|&i| f[i * m..(i + 1) * m].iter().copied()).collect(), sp, poses),
                        (None, None) => unreachable!("features are made when the images are not 8-bit"),
                    }
                })
                .collect::<linpose::Result<Vec<Dataset>>>()?;
            let objects = ObjectSet::new(names, sets)?;
            match &posed {
                Some((_, _, spec)) => ObjectModel::fit_staged(&objects, &rp, spec, normalize, &|_| {}),
                None => ObjectModel::fit_views_staged(&objects, &rp, normalize),
            }
        })
        .map_err(py_err)?;
    let model = match caller_labels {
        Some(l) => model.with_labels(l).map_err(py_err)?,
        None => model,
    };
    Ok(Objects { inner: model })
}

/// Reads a many-object model file.
#[pyfunction]
pub(crate) fn load_objects(py: Python<'_>, path: PathBuf) -> PyResult<Objects> {
    let inner = py.detach(|| ObjectModel::load(&path)).map_err(py_err)?;
    Ok(Objects { inner })
}

/// Whether the model file at `path` holds many objects (read it with `load_objects`).
#[pyfunction]
pub(crate) fn holds_objects(py: Python<'_>, path: PathBuf) -> PyResult<bool> {
    py.detach(|| model_file::holds_objects(&path)).map_err(py_err)
}

/// Whether model file bytes hold many objects (read them with `Objects.from_bytes`).
#[pyfunction]
pub(crate) fn bytes_hold_objects(data: &[u8]) -> bool {
    model_file::bytes_hold_objects(data)
}
