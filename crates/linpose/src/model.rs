//! The estimator traits shared by every method, what a fitted model records about itself, and
//! [`AnyModel`], the closed set of models a file can hold.
//!
//! One trait pair serves every method (STYLE.md): an [`Estimator`] (the parameters) fits a
//! [`PoseModel`] (the fitted model) from a training [`Dataset`]; the CLI, the evaluator and the
//! benchmarks only ever hold these.

use crate::dataset::Dataset;
use crate::image_io::ImageSpec;
use crate::pose::PoseSpace;
use crate::{Error, Result};
use serde::{Deserialize, Serialize};

/// Fits a model from training data. Implemented by each method's parameter struct.
pub trait Estimator {
    /// The fitted model.
    type Model: PoseModel;
    /// Validates the parameters, then fits.
    fn fit(&self, train: &Dataset) -> Result<Self::Model>;
}

/// A fitted pose model.
pub trait PoseModel: Send + Sync {
    /// What the model knows about its training: method, image spec, parameters, training poses.
    fn meta(&self) -> &ModelMeta;

    /// Estimates the poses (degrees) of `queries`: rows of [`ImageSpec::features`] values, written
    /// to `out` as rows of [`PoseSpace::len`] values.
    fn predict_into(&self, queries: &[f32], out: &mut [f64]) -> Result<()>;

    /// Bytes of the numbers the model stores to serve queries (the storage of the paper's
    /// Table 1), counted at the precision they are served in.
    fn model_bytes(&self) -> usize;

    /// The named arrays written to a model file.
    fn tensors(&self) -> Vec<Tensor>;

    /// As [`PoseModel::predict_into`] for 8-bit gray images given as their raw pixel values
    /// (value v means the feature v / 255): the fast path for decoded 8-bit images, with the
    /// 1 / 255 folded into the model. It agrees with `predict_into` on the same image to f32
    /// rounding. The default converts to features and calls `predict_into`.
    fn predict_u8_into(&self, queries: &[u8], out: &mut [f64]) -> Result<()> {
        let f: Vec<f32> = queries.iter().map(|&v| v as f32 * crate::kernels::levels::S8).collect();
        self.predict_into(&f, out)
    }

    /// Estimates the poses of `queries`, returning them row-major.
    fn predict(&self, queries: &[f32]) -> Result<Vec<f64>> {
        let m = self.meta().spec.features();
        check_queries(m, queries.len(), "query batch")?;
        let mut out = vec![0.0; queries.len() / m * self.meta().space.len()];
        self.predict_into(queries, &mut out)?;
        Ok(out)
    }
}

/// Checks that `len` values form whole rows of `m` features.
pub fn check_queries(m: usize, len: usize, context: &str) -> Result<()> {
    if !len.is_multiple_of(m) || len == 0 {
        return Err(Error::FeatureMismatch { expected: m, got: len, context: context.to_string() });
    }
    Ok(())
}

/// The number of queries in a batch of `len` values of `m` features, checking that the output
/// holds `per_query` values for each; errors name the mismatch.
pub fn batch_len(m: usize, len: usize, out_len: usize, per_query: usize) -> Result<usize> {
    check_queries(m, len, "query batch")?;
    let n = len / m;
    if out_len != n * per_query {
        return Err(Error::invalid("output length", out_len, format!("{n} queries need {}", n * per_query)));
    }
    Ok(n)
}

/// What a model records about its training, enough to be used on its own.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct ModelMeta {
    /// The method's name (`linear`, `eigenspace`, ...).
    pub method: String,
    /// Image size and preprocessing.
    pub spec: ImageSpec,
    /// Pose parameters with their periods.
    pub space: PoseSpace,
    /// Training poses, one row per training sample (degrees), so evaluation can tell seen views
    /// from unseen ones.
    pub train_poses: Vec<f64>,
    /// The method's settings as given and as chosen (e.g. a selected ridge), for the record.
    pub settings: serde_json::Value,
}

impl ModelMeta {
    /// Number of training samples.
    pub fn n_train(&self) -> usize {
        self.train_poses.len() / self.space.len()
    }

    /// Whether `pose` is one of the training poses (within 1e-6 degrees).
    pub fn is_seen(&self, pose: &[f64]) -> bool {
        self.train_poses.chunks_exact(self.space.len()).any(|t| self.space.same_pose(t, pose, 1e-6))
    }
}

/// Element type of a stored array.
#[derive(Debug, Clone, PartialEq)]
pub enum TensorData {
    /// 32-bit floats.
    F32(Vec<f32>),
    /// 64-bit floats.
    F64(Vec<f64>),
}

/// A named array as stored in a model file.
#[derive(Debug, Clone, PartialEq)]
pub struct Tensor {
    /// Its name in the file.
    pub name: String,
    /// Its shape.
    pub shape: Vec<usize>,
    /// Its values, row-major.
    pub data: TensorData,
}

impl Tensor {
    /// An f32 array.
    pub fn f32(name: &str, shape: Vec<usize>, data: Vec<f32>) -> Self {
        debug_assert_eq!(shape.iter().product::<usize>(), data.len());
        Tensor { name: name.into(), shape, data: TensorData::F32(data) }
    }

    /// An f64 array.
    pub fn f64(name: &str, shape: Vec<usize>, data: Vec<f64>) -> Self {
        debug_assert_eq!(shape.iter().product::<usize>(), data.len());
        Tensor { name: name.into(), shape, data: TensorData::F64(data) }
    }
}

/// The arrays read back from a model file, looked up by name with their shape checked.
#[derive(Debug)]
pub struct TensorSet {
    pub(crate) path: std::path::PathBuf,
    pub(crate) tensors: Vec<Tensor>,
}

impl TensorSet {
    fn get(&self, name: &str, shape: &[usize]) -> Result<&Tensor> {
        let t = self
            .tensors
            .iter()
            .find(|t| t.name == name)
            .ok_or_else(|| Error::ModelFile { path: self.path.clone(), message: format!("the model file has no tensor '{name}'") })?;
        if t.shape != shape {
            return Err(Error::ModelFile {
                path: self.path.clone(),
                message: format!("tensor '{name}' has shape {:?}, but the metadata implies {:?}", t.shape, shape),
            });
        }
        Ok(t)
    }

    /// The f32 tensor `name`, which must have `shape`.
    pub fn f32(&self, name: &str, shape: &[usize]) -> Result<Vec<f32>> {
        match &self.get(name, shape)?.data {
            TensorData::F32(v) => Ok(v.clone()),
            TensorData::F64(_) => Err(self.wrong_type(name, "F32")),
        }
    }

    /// The f64 tensor `name`, which must have `shape`.
    pub fn f64(&self, name: &str, shape: &[usize]) -> Result<Vec<f64>> {
        match &self.get(name, shape)?.data {
            TensorData::F64(v) => Ok(v.clone()),
            TensorData::F32(_) => Err(self.wrong_type(name, "F64")),
        }
    }

    /// Whether a tensor called `name` is present.
    pub fn has(&self, name: &str) -> bool {
        self.tensors.iter().any(|t| t.name == name)
    }

    /// An error about this file.
    pub fn error(&self, message: impl Into<String>) -> Error {
        Error::ModelFile { path: self.path.clone(), message: message.into() }
    }

    fn wrong_type(&self, name: &str, want: &str) -> Error {
        self.error(format!("tensor '{name}' must have dtype {want}"))
    }
}

/// Every kind of model linpose can write and read back.
#[derive(Debug, Clone)]
#[non_exhaustive]
// A program holds one or a few models, and boxing would change how users match on them.
#[allow(clippy::large_enum_variant)]
pub enum AnyModel {
    /// Okatani & Deguchi's linear model.
    Linear(crate::methods::linear::LinearModel),
    /// Murase & Nayar's parametric eigenspace.
    Eigenspace(crate::methods::eigenspace::EigenspaceModel),
    /// The eigenspace searched continuously on its spline manifold (beyond the paper).
    Refined(crate::methods::refined::RefinedModel),
}

impl AnyModel {
    fn inner(&self) -> &dyn PoseModel {
        match self {
            AnyModel::Linear(m) => m,
            AnyModel::Eigenspace(m) => m,
            AnyModel::Refined(m) => m,
        }
    }

    /// Rebuilds a model of `meta.method` from the arrays of a file.
    pub(crate) fn from_parts(meta: ModelMeta, tensors: &TensorSet) -> Result<Self> {
        match meta.method.as_str() {
            crate::methods::linear::METHOD => Ok(AnyModel::Linear(crate::methods::linear::LinearModel::from_parts(meta, tensors)?)),
            crate::methods::eigenspace::METHOD => Ok(AnyModel::Eigenspace(crate::methods::eigenspace::EigenspaceModel::from_parts(meta, tensors)?)),
            crate::methods::refined::METHOD => Ok(AnyModel::Refined(crate::methods::refined::RefinedModel::from_parts(meta, tensors)?)),
            other => Err(tensors.error(format!("unknown method '{other}' (this linpose knows: {})", crate::METHODS.join(", ")))),
        }
    }
}

impl PoseModel for AnyModel {
    fn meta(&self) -> &ModelMeta {
        self.inner().meta()
    }
    fn predict_into(&self, queries: &[f32], out: &mut [f64]) -> Result<()> {
        self.inner().predict_into(queries, out)
    }
    fn predict_u8_into(&self, queries: &[u8], out: &mut [f64]) -> Result<()> {
        self.inner().predict_u8_into(queries, out)
    }
    fn model_bytes(&self) -> usize {
        self.inner().model_bytes()
    }
    fn tensors(&self) -> Vec<Tensor> {
        self.inner().tensors()
    }
}

impl From<crate::methods::linear::LinearModel> for AnyModel {
    fn from(m: crate::methods::linear::LinearModel) -> Self {
        AnyModel::Linear(m)
    }
}

impl From<crate::methods::eigenspace::EigenspaceModel> for AnyModel {
    fn from(m: crate::methods::eigenspace::EigenspaceModel) -> Self {
        AnyModel::Eigenspace(m)
    }
}

impl From<crate::methods::refined::RefinedModel> for AnyModel {
    fn from(m: crate::methods::refined::RefinedModel) -> Self {
        AnyModel::Refined(m)
    }
}
