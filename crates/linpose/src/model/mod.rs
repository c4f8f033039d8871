//! What every method shares: the [`Estimator`] (parameters that fit) and [`PoseModel`] (a fitted
//! model) traits, what a model records about itself ([`ModelMeta`]), and [`AnyModel`], a fitted
//! model of any method.
//!
//! One trait pair serves every method, so the command line, the evaluator, the experiment and
//! the benchmarks never care which method they hold. What differs between methods (their name,
//! settings, Table 1 storage terms, how a model file is read back) is described by the method
//! itself: see [`Method`] and the registry [`crate::methods::METHODS`].

pub(crate) mod file;
pub(crate) mod footprint;
mod located;
mod method;
mod normalized;
pub(crate) mod partial_fit;
pub(crate) mod split;
mod tensor;
mod tuning;

pub(crate) use located::Kept;
pub use located::{Located, SceneSearch};
pub(crate) use method::Stream;
pub use method::{Method, MethodOption, MethodSpec, Origin, Settings};
pub use normalized::Normalized;
pub use tensor::{Tensor, TensorData, TensorSet};

use crate::confidence::Estimate;
use crate::dataset::Dataset;
use crate::image_io::ImageSpec;
use crate::pose::PoseSpace;
use crate::{Error, Result};
use serde::{Deserialize, Serialize};
use std::any::Any;
use std::sync::Arc;

/// Fits a model from training data. Implemented by each method's parameter struct.
pub trait Estimator {
    /// The fitted model.
    type Model: PoseModel;

    /// The method these parameters belong to.
    fn method(&self) -> &'static Method;

    /// Validates the parameters, then fits.
    fn fit(&self, train: &Dataset) -> Result<Self::Model>;

    /// The exact leave-one-out estimates on the training set (row i: the pose the model fitted
    /// without sample i gives sample i, degrees), for a method that has them in closed form;
    /// `None` for the others.
    fn leave_one_out(&self, _train: &Dataset) -> Option<Result<Vec<f64>>> {
        None
    }
}

/// A fitted pose model.
pub trait PoseModel: Any + Send + Sync + std::fmt::Debug {
    /// The method that fitted it.
    fn method(&self) -> &'static Method;

    /// What the model knows about its training: method, image spec, parameters, training poses.
    fn meta(&self) -> &ModelMeta;

    /// Estimates the poses (degrees) of `queries`: rows of [`ImageSpec::features`] values, written
    /// to `out` as rows of [`PoseSpace::len`] values.
    fn predict_into(&self, queries: &[f32], out: &mut [f64]) -> Result<()>;

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

    /// Estimates the poses of `queries` (as [`PoseModel::predict`]) with, for each, up to `top`
    /// ranked hypotheses and a confidence ([`crate::confidence`]): the estimate's pose is the
    /// one `predict` gives.
    fn estimate(&self, queries: &[f32], top: usize) -> Result<Vec<Estimate>>;

    /// Bytes of the numbers the model stores to serve queries (the storage of the paper's
    /// Table 1), counted at the precision they are served in.
    fn model_bytes(&self) -> usize;

    /// The terms of the method's Table 1 storage formula ([`Method::storage`]) with their values
    /// for this model, and the formula evaluated: how many numbers it stores.
    fn storage(&self) -> Storage;

    /// The named arrays written to a model file.
    fn tensors(&self) -> Vec<Tensor>;

    /// The model's file bytes (safetensors: numpy's and PyTorch's loaders read the arrays as
    /// they are; the metadata is in the header). The same model always gives the same bytes.
    fn to_bytes(&self) -> Result<Vec<u8>> {
        file::model_bytes(self)
    }

    /// Writes the model file atomically (temporary name, then rename): its size in bytes.
    /// [`AnyModel::load`] reads it back.
    fn save(&self, path: &std::path::Path) -> Result<u64> {
        file::save_bytes(&self.to_bytes()?, path)
    }

    /// For a model whose encoded estimate is linear in the pixels, its coefficient vectors: one
    /// row of M values per encoded parameter (the paper's Fig. 2). `None` for other models.
    fn coefficients(&self) -> Option<&[f64]> {
        None
    }

    /// For a model behind a normalisation stage ([`crate::model::Normalized`]): the stage and
    /// the method's own model, which takes normalised images, so a caller that normalises the
    /// queries itself (to count the refused ones apart) does it once. `None` for other models.
    fn behind_stage(&self) -> Option<(&crate::normalize::Normalizer, &dyn PoseModel)> {
        None
    }

    /// For a model that finds its object in images larger than its training views (the robust
    /// stage, [`crate::robust::Robust`]): the search. `None` for other models.
    fn scene_search(&self) -> Option<&dyn SceneSearch> {
        None
    }
}

/// A model's storage in the terms of the paper's Table 1.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Storage {
    /// Each term of the formula with its value (`("M", 19200)`).
    pub terms: Vec<(String, usize)>,
    /// The formula evaluated: numbers stored.
    pub numbers: usize,
}

impl Storage {
    /// A storage of `numbers` numbers with the formula's `terms`.
    pub fn new(terms: &[(&str, usize)], numbers: usize) -> Self {
        Storage { terms: terms.iter().map(|&(k, v)| (k.to_string(), v)).collect(), numbers }
    }
}

/// The error for query `i` of a batch that cannot be scaled to unit energy (all black, or not
/// finite), for the methods that scale their queries.
pub(crate) fn unscalable_query(i: usize) -> Error {
    Error::invalid(
        "query",
        format!("row {i} of the batch"),
        "the image is all black or not finite (zero or non-finite energy), so it cannot be scaled to unit energy",
    )
}

/// Checks that `len` values form whole rows of `m` features.
pub(crate) fn check_queries(m: usize, len: usize, context: &str) -> Result<()> {
    if !len.is_multiple_of(m) || len == 0 {
        return Err(Error::FeatureMismatch { expected: m, got: len, context: context.to_string() });
    }
    Ok(())
}

/// The number of queries in a batch of `len` values of `m` features, checking that the output
/// holds `per_query` values for each; errors name the mismatch.
pub(crate) fn batch_len(m: usize, len: usize, out_len: usize, per_query: usize) -> Result<usize> {
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
    /// The method's name ([`Method::name`]).
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
    /// The normalisation stage every image goes through before the method sees it
    /// ([`crate::normalize`]); `None`: images are used as they are.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub normalize: Option<crate::normalize::Normalizer>,
    /// How the normalisation was decided, when training decided it ([`crate::MethodSpec::fit_with_stage`]):
    /// chosen on held-out training views, or as the caller fixed it. `None` for a model fitted
    /// without a rule (a method's own `fit`).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub stage_choice: Option<crate::normalize::StageChoice>,
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

/// A fitted model of any method, as a model file or [`MethodSpec::fit`] gives it: a
/// [`PoseModel`] itself, and [`AnyModel::downcast_ref`] gives the method's own type. Cloning
/// shares the model.
#[derive(Clone)]
pub struct AnyModel(Arc<dyn PoseModel>);

impl AnyModel {
    /// Wraps a fitted model.
    pub fn new(model: impl PoseModel) -> Self {
        AnyModel(Arc::new(model))
    }

    /// The model as its method's own type, when it is a `T`.
    pub fn downcast_ref<T: PoseModel>(&self) -> Option<&T> {
        let any: &dyn Any = &*self.0;
        any.downcast_ref()
    }

    /// The model as a shared `dyn PoseModel`.
    pub fn shared(&self) -> Arc<dyn PoseModel> {
        Arc::clone(&self.0)
    }
}

impl PoseModel for AnyModel {
    fn method(&self) -> &'static Method {
        self.0.method()
    }
    fn meta(&self) -> &ModelMeta {
        self.0.meta()
    }
    fn predict_into(&self, queries: &[f32], out: &mut [f64]) -> Result<()> {
        self.0.predict_into(queries, out)
    }
    fn predict_u8_into(&self, queries: &[u8], out: &mut [f64]) -> Result<()> {
        self.0.predict_u8_into(queries, out)
    }
    fn estimate(&self, queries: &[f32], top: usize) -> Result<Vec<Estimate>> {
        self.0.estimate(queries, top)
    }
    fn model_bytes(&self) -> usize {
        self.0.model_bytes()
    }
    fn storage(&self) -> Storage {
        self.0.storage()
    }
    fn tensors(&self) -> Vec<Tensor> {
        self.0.tensors()
    }
    fn to_bytes(&self) -> Result<Vec<u8>> {
        self.0.to_bytes()
    }
    fn coefficients(&self) -> Option<&[f64]> {
        self.0.coefficients()
    }
    fn behind_stage(&self) -> Option<(&crate::normalize::Normalizer, &dyn PoseModel)> {
        self.0.behind_stage()
    }
    fn scene_search(&self) -> Option<&dyn SceneSearch> {
        self.0.scene_search()
    }
}

impl std::fmt::Debug for AnyModel {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        self.0.fmt(f)
    }
}
