//! Fitted models: [`Model`] holds any method's model (or one behind a normalisation stage) and
//! estimates poses from arrays; [`fit`] fits one from arrays, [`load`] reads a model file. A
//! model's bytes are its model file's bytes, so a model fitted here and one fitted by the
//! command line on the same data are the same file.

use crate::arrays::{pixels, Pixels};
use crate::py_err;
use linpose::image_io::{ColorMode, ImageSpec};
use linpose::normalize::{NormalizeParams, StageRule};
use linpose::{AnyModel, Dataset, Method, MethodSpec, Param, PoseModel, PoseSpace, Settings};
use numpy::{IntoPyArray, PyArray1, PyArray2, PyArray3, PyArrayMethods, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::exceptions::PyValueError;
use pyo3::prelude::*;
use pyo3::types::PyBytes;
use std::path::{Path, PathBuf};

/// A fitted pose model of any method.
#[pyclass(frozen, module = "linpose._linpose")]
pub struct Model {
    inner: AnyModel,
}

/// The pose space of `(name, period)` pairs (`None`: linear).
pub(crate) fn space(params: Vec<(String, Option<f64>)>) -> PyResult<PoseSpace> {
    PoseSpace::new(params.into_iter().map(|(n, p)| Param { name: n, period: p }).collect()).map_err(py_err)
}

/// `rows` x `cols` values as a 2-D array: one numpy array over the vector's own buffer (no copy,
/// no 1-D array reshaped: one Python object fewer per call).
pub(crate) fn array2<'py, T: numpy::Element>(py: Python<'py>, v: Vec<T>, rows: usize, cols: usize) -> PyResult<Bound<'py, PyArray2<T>>> {
    let a = numpy::ndarray::Array2::from_shape_vec((rows, cols), v).map_err(|e| PyValueError::new_err(format!("an array of {rows} x {cols}: {e}")))?;
    Ok(a.into_pyarray(py))
}

impl Model {
    /// Wraps a model of the library.
    pub(crate) fn new(inner: AnyModel) -> Model {
        Model { inner }
    }

    fn meta(&self) -> &linpose::ModelMeta {
        self.inner.meta()
    }

    /// Checks that `x` holds whole images of the model's size.
    fn check(&self, x: &Pixels<'_>) -> PyResult<usize> {
        check_rows(x, self.meta().spec)
    }

    /// The poses (degrees, row-major n x K) of the `n` images of `x`, with the interpreter's lock
    /// released: 8-bit images as they are, others as features.
    fn poses(&self, py: Python<'_>, x: &Pixels<'_>, n: usize) -> PyResult<Vec<f64>> {
        let k = self.meta().space.len();
        let model = &self.inner;
        match x.u8_slice() {
            Some(v) => py.detach(|| {
                let mut out = vec![0.0; n * k];
                model.predict_u8_into(v, &mut out).map(|_| out)
            }),
            None => {
                let f = x.features("X")?;
                py.detach(|| {
                    let mut out = vec![0.0; n * k];
                    model.predict_into(&f, &mut out).map(|_| out)
                })
            }
        }
        .map_err(py_err)
    }
}

/// A fitted estimator's `predict` on the arrays the core reads as they are, with the
/// estimator's own checks and output shape, in one call: those checks in Python cost a single
/// rendered image's predict 4 us more (BENCHMARKS.md "From Python"). Anything else (another
/// dtype, a list, no rows) gives `None`, and the estimator validates it as scikit-learn does.
#[pyclass(frozen, module = "linpose._linpose")]
pub struct Serve {
    model: Py<Model>,
    n_features: usize,
    y_1d: bool,
    name: String,
}

#[pymethods]
impl Serve {
    /// Serves `model` for an estimator named `name` fitted on images of `n_features` values,
    /// giving (n,) poses when `y_1d`, else (n, K).
    #[new]
    fn new(model: Py<Model>, n_features: usize, y_1d: bool, name: String) -> Self {
        Serve { model, n_features, y_1d, name }
    }

    /// The poses of the images `x`, or `None` when `x` is not an array the core reads as it is.
    fn __call__<'py>(&self, py: Python<'py>, x: &Bound<'py, PyAny>) -> PyResult<Option<Bound<'py, PyAny>>> {
        let x = match pixels(x, "X") {
            Ok(x) => x,
            Err(e) if e.is_instance_of::<pyo3::exceptions::PyTypeError>(py) => return Ok(None),
            Err(e) => return Err(e),
        };
        let (n, m) = x.shape();
        if n == 0 {
            return Ok(None);
        }
        if m != self.n_features {
            return Err(PyValueError::new_err(format!("X has {m} features, but {} is expecting {} features as input.", self.name, self.n_features)));
        }
        let model = self.model.get();
        let k = model.meta().space.len();
        let poses = model.poses(py, &x, n)?;
        Ok(Some(if self.y_1d && k == 1 { PyArray1::from_vec(py, poses).into_any() } else { array2(py, poses, n, k)?.into_any() }))
    }
}

/// Checks that `x` holds at least one whole image of `spec`'s size; returns their number.
pub(crate) fn check_rows(x: &Pixels<'_>, spec: ImageSpec) -> PyResult<usize> {
    let (n, m) = x.shape();
    let want = spec.features();
    if m != want {
        return Err(PyValueError::new_err(format!(
            "X has {m} features per image, but the model was trained on {}x{} images ({want} features)",
            spec.width, spec.height
        )));
    }
    if n == 0 {
        return Err(PyValueError::new_err("X holds no images (0 rows); at least one is needed"));
    }
    Ok(n)
}

/// The method named `method` and its `settings` (name, value), checked: an unknown method is a
/// `ValueError` listing the methods, a setting the method cannot read one with its message.
pub(crate) fn method_of(method: &str, settings: Vec<(String, String)>) -> PyResult<(&'static Method, Settings, MethodSpec)> {
    let method = linpose::Method::from_name(method).ok().ok_or_else(|| {
        let names: Vec<&str> = linpose::METHODS.iter().map(|m| m.name).collect();
        PyValueError::new_err(format!("unknown method {method:?} (methods: {})", names.join(", ")))
    })?;
    let settings = settings.into_iter().fold(Settings::new(), |s, (n, v)| s.set(n, v));
    let spec = method.spec(&settings).map_err(py_err)?;
    Ok((method, settings, spec))
}

/// What `normalize` asks of the normalisation stage: `"auto"` (chosen on held-out training
/// views), `None` or `"off"` (none), `"all"`, `"geometry"` or `"brightness"`.
pub(crate) fn stage(normalize: Option<&str>) -> PyResult<StageRule> {
    match normalize {
        None => Ok(StageRule::Fixed(NormalizeParams::OFF)),
        Some(v) => StageRule::from_name(v)
            .map_err(|_| PyValueError::new_err(format!("normalize={v:?}: expected 'auto', None, 'off', 'all', 'geometry' or 'brightness'"))),
    }
}

#[pymethods]
impl Model {
    /// Estimates the pose (degrees) of each row of `x` (each image of an (n, h, w) array): an
    /// (n, K) array.
    fn predict<'py>(&self, py: Python<'py>, x: &Bound<'py, PyAny>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let x = pixels(x, "X")?;
        let n = self.check(&x)?;
        let k = self.meta().space.len();
        array2(py, self.poses(py, &x, n)?, n, k)
    }

    /// The estimates of each row of `x` with up to `top` ranked hypotheses and a confidence:
    /// `(pose (n, K), confidence (n,), hypotheses (n, top, K), scores (n, top))`, hypotheses
    /// best first and padded with NaN where fewer were found.
    #[allow(clippy::type_complexity)]
    fn estimate<'py>(
        &self,
        py: Python<'py>,
        x: &Bound<'py, PyAny>,
        top: usize,
    ) -> PyResult<(Bound<'py, PyArray2<f64>>, Bound<'py, PyArray1<f64>>, Bound<'py, PyArray3<f64>>, Bound<'py, PyArray2<f64>>)> {
        if top == 0 {
            return Err(PyValueError::new_err("top must be at least 1"));
        }
        let x = pixels(x, "X")?;
        let n = self.check(&x)?;
        let k = self.meta().space.len();
        let f = x.features("X")?;
        let model = &self.inner;
        let est = py.detach(|| model.estimate(&f, top)).map_err(py_err)?;
        let mut pose = Vec::with_capacity(n * k);
        let mut conf = Vec::with_capacity(n);
        let mut hyp = vec![f64::NAN; n * top * k];
        let mut score = vec![f64::NAN; n * top];
        for (i, e) in est.iter().enumerate() {
            pose.extend_from_slice(&e.pose);
            conf.push(e.confidence);
            for (j, h) in e.hypotheses.iter().take(top).enumerate() {
                hyp[(i * top + j) * k..(i * top + j + 1) * k].copy_from_slice(&h.pose);
                score[i * top + j] = h.score;
            }
        }
        Ok((array2(py, pose, n, k)?, PyArray1::from_vec(py, conf), PyArray1::from_vec(py, hyp).reshape([n, top, k])?, array2(py, score, n, top)?))
    }

    /// The model file's bytes.
    fn to_bytes<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyBytes>> {
        let model = &self.inner;
        let bytes = py.detach(|| model.to_bytes()).map_err(py_err)?;
        Ok(PyBytes::new(py, &bytes))
    }

    /// The model of a model file's bytes.
    #[staticmethod]
    fn from_bytes(py: Python<'_>, data: &[u8]) -> PyResult<Model> {
        let inner = py.detach(|| AnyModel::from_bytes(Path::new("<bytes>"), data)).map_err(py_err)?;
        Ok(Model { inner })
    }

    /// Writes the model file (atomically); returns its size in bytes.
    fn save(&self, py: Python<'_>, path: PathBuf) -> PyResult<u64> {
        let model = &self.inner;
        py.detach(|| model.save(&path)).map_err(py_err)
    }

    /// The method's name.
    #[getter]
    fn method(&self) -> &str {
        &self.meta().method
    }

    /// (height, width) of the images the model takes.
    #[getter]
    fn image_shape(&self) -> (u32, u32) {
        (self.meta().spec.height, self.meta().spec.width)
    }

    /// Features per image.
    #[getter]
    fn n_features(&self) -> usize {
        self.meta().spec.features()
    }

    /// The pose parameters: `(name, period)` pairs, period `None` for a linear parameter.
    #[getter]
    fn params(&self) -> Vec<(String, Option<f64>)> {
        self.meta().space.params().iter().map(|p| (p.name.clone(), p.period)).collect()
    }

    /// The training poses, (N, K) degrees.
    #[getter]
    fn train_poses<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyArray2<f64>>> {
        let m = self.meta();
        array2(py, m.train_poses.clone(), m.n_train(), m.space.len())
    }

    /// The method's settings as given and as chosen, as JSON.
    #[getter]
    fn settings_json(&self) -> String {
        self.meta().settings.to_string()
    }

    /// The normalisation stage as JSON, or `None` when images are used as they are.
    #[getter]
    fn normalize_json(&self) -> Option<String> {
        self.meta().normalize.as_ref().map(|n| serde_json::to_string(n).expect("the stage serialises"))
    }

    /// Whether the model has the robust stage in front ([`linpose::robust::Robust`]).
    #[getter]
    fn robust(&self) -> bool {
        self.inner.downcast_ref::<linpose::robust::Robust>().is_some()
    }

    /// How the normalisation was decided (JSON: the rule, the choice and every candidate's
    /// held-out score), or None for a model fitted without a rule.
    #[getter]
    fn stage_choice_json(&self) -> Option<String> {
        self.meta().stage_choice.as_ref().map(|c| serde_json::to_string(c).expect("the choice serialises"))
    }

    /// For a model linear in the pixels: its coefficients, one row of M per encoded parameter
    /// ((cos, sin) rows for a circular one); `None` for the others.
    #[getter]
    fn coefficients<'py>(&self, py: Python<'py>) -> PyResult<Option<Bound<'py, PyArray2<f64>>>> {
        let m = self.meta().spec.features();
        match self.inner.coefficients() {
            Some(c) => Ok(Some(array2(py, c.to_vec(), c.len() / m, m)?)),
            None => Ok(None),
        }
    }

    /// The arrays the model file holds: `(name, shape, values as float64)`.
    fn tensors<'py>(&self, py: Python<'py>) -> Vec<(String, Vec<usize>, Bound<'py, PyArray1<f64>>)> {
        use linpose::model::TensorData;
        self.inner
            .tensors()
            .into_iter()
            .map(|t| {
                let v: Vec<f64> = match t.data {
                    TensorData::F32(v) => v.iter().map(|&x| x as f64).collect(),
                    TensorData::F64(v) => v.to_vec(),
                };
                (t.name, t.shape, PyArray1::from_vec(py, v))
            })
            .collect()
    }

    /// Bytes of the numbers the model stores to serve queries (the paper's Table 1).
    #[getter]
    fn model_bytes(&self) -> usize {
        self.inner.model_bytes()
    }

    /// The Table 1 storage: `(terms, numbers)`, terms as `(name, value)` pairs.
    #[getter]
    fn storage(&self) -> (Vec<(String, usize)>, usize) {
        let s = self.inner.storage();
        (s.terms, s.numbers)
    }

    fn __repr__(&self) -> String {
        let m = self.meta();
        format!("<linpose model: {} on {} images of {}x{}>", m.method, m.n_train(), m.spec.width, m.spec.height)
    }
}

/// Fits `method` with `settings` (name, value) on the images `(x, height, width)` (rows of
/// `height` x `width` pixels) at the poses `y` ((n, K) degrees) of the parameters `params`;
/// `stages`: `(normalize, robust)`, normalize `"auto"`, `None` or `"off"`, `"all"`, `"geometry"`
/// or `"brightness"`, and robust whether the robust stage goes in front
/// ([`linpose::robust::Robust`]).
#[pyfunction]
#[pyo3(signature = (method, settings, images, y, params, stages=(None, false)))]
pub(crate) fn fit(
    py: Python<'_>,
    method: &str,
    settings: Vec<(String, String)>,
    images: (Bound<'_, PyAny>, u32, u32),
    y: PyReadonlyArray2<'_, f64>,
    params: Vec<(String, Option<f64>)>,
    stages: (Option<String>, bool),
) -> PyResult<Model> {
    let (normalize, robust) = stages;
    let normalize = normalize.as_deref();
    let (x, height, width) = images;
    let x = &x;
    let (_, _, spec) = method_of(method, settings)?;
    let stage = stage(normalize)?;
    let space = space(params)?;
    let x = pixels(x, "X")?;
    let (n, m) = x.shape();
    let image = ImageSpec { width, height, color: ColorMode::Gray };
    if m != image.features() {
        return Err(PyValueError::new_err(format!("X has {m} values per image, but images of {width}x{height} have {}", image.features())));
    }
    let (ny, k) = (y.shape()[0], y.shape()[1]);
    if ny != n || k != space.len() {
        return Err(PyValueError::new_err(format!("y has shape ({ny}, {k}); {n} images of {} pose parameters need ({n}, {})", space.len(), space.len())));
    }
    let poses: Vec<f64> = y.as_array().iter().copied().collect();
    // 8-bit images in place go to the library as they are; others as features.
    let input = match x.u8_slice() {
        Some(pixels) => Ok(pixels),
        None => Err(x.features("X")?.into_owned()),
    };
    let inner = py
        .detach(|| {
            let data = match input {
                Ok(pixels) => Dataset::from_u8(image, pixels, space, poses)?,
                Err(features) => Dataset::new(image, features, space, poses)?,
            };
            let model = spec.fit_with_stage(&data, stage)?;
            if robust {
                linpose::robust::Robust::fit(&data, model)
            } else {
                Ok(model)
            }
        })
        .map_err(py_err)?;
    Ok(Model { inner })
}

/// Reads a model file.
#[pyfunction]
pub(crate) fn load(py: Python<'_>, path: PathBuf) -> PyResult<Model> {
    let inner = py.detach(|| AnyModel::load(&path)).map_err(py_err)?;
    Ok(Model { inner })
}

/// The methods: `(name, summary, options)`, options as `(name, value, help)`.
#[pyfunction]
#[allow(clippy::type_complexity)]
pub(crate) fn methods() -> Vec<(&'static str, &'static str, Vec<(&'static str, &'static str, &'static str)>)> {
    linpose::METHODS.iter().map(|m| (m.name, m.summary, m.options.iter().map(|o| (o.name, o.value, o.help)).collect())).collect()
}

/// The names of the methods that fit from partial statistics merged over shards (`linpose.dask`).
#[pyfunction]
pub(crate) fn merging_methods() -> Vec<&'static str> {
    linpose::METHODS.iter().filter(|m| m.merges()).map(|m| m.name).collect()
}
