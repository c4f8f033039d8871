//! A model of any method behind the normalisation stage: [`Normalized`] normalises each query
//! as its training images were, then asks the method's own model. Its metadata carries the stage
//! (`normalize`) and how it was decided (`stage_choice`), so the model file keeps both and
//! [`crate::model_file::load`] puts the stage back.

use crate::confidence::Estimate;
use crate::dataset::Dataset;
use crate::model::{AnyModel, Method, MethodSpec, ModelMeta, PoseModel, Storage, Tensor};
use crate::normalize::{NormalizeParams, Normalizer, StageChoice};
use crate::Result;

/// A fitted model whose queries go through a [`Normalizer`] first.
///
/// ```
/// use linpose::normalize::NormalizeParams;
/// use linpose::model::Normalized;
/// use linpose::render::synth::{dataset, PoseGrid};
/// use linpose::render::{objects, Grid, RenderParams};
/// use linpose::{EigenspaceParams, MethodSpec, PoseModel};
///
/// // The duck on a turntable, every 20 degrees, 48 x 36 pixels.
/// let grid = PoseGrid::new(Grid::parse("elevation", "30")?, Grid::parse("azimuth", "0:340:20")?)?;
/// let params = RenderParams::default().width(48).height(36);
/// let data = dataset(&objects::builtin("duck")?, &grid, &params, std::path::Path::new("<render>"), &|_| {})?;
/// let spec: MethodSpec = EigenspaceParams::default().components(8).into();
/// let model = Normalized::fit(&spec, &data, NormalizeParams::geometry())?;
/// assert!(model.meta().normalize.is_some());
/// let pose = model.predict(data.row(3))?;
/// assert!(data.space().error_deg(&pose, data.pose(3)) < 1.0);
/// # Ok::<(), linpose::Error>(())
/// ```
#[derive(Debug)]
pub struct Normalized {
    /// `None`: the queries go to the method's model as they are (training chose no stage).
    stage: Option<Normalizer>,
    inner: AnyModel,
    meta: ModelMeta,
}

impl Normalized {
    /// Fits the stage on `train`, normalises `train` with it and fits `spec` on the result.
    pub fn fit(spec: &MethodSpec, train: &Dataset, params: NormalizeParams) -> Result<AnyModel> {
        let stage = Normalizer::fit(train, params)?;
        let data = stage.apply_dataset(train)?;
        let inner = spec.fit(&data)?;
        Ok(AnyModel::new(Normalized::new(stage, inner)))
    }

    /// `inner` (fitted on images normalised by `stage`) behind `stage`.
    pub fn new(stage: Normalizer, inner: AnyModel) -> Self {
        Self::recorded(Some(stage), inner, None)
    }

    /// `inner` behind `stage` (none: the images as they are), with the record of how the stage
    /// was decided in its metadata.
    pub fn recorded(stage: Option<Normalizer>, inner: AnyModel, choice: Option<StageChoice>) -> Self {
        let mut meta = inner.meta().clone();
        meta.normalize = stage.clone();
        meta.stage_choice = choice;
        Normalized { stage, inner, meta }
    }

    /// The stage (`None` when the images go to the method as they are).
    pub fn stage(&self) -> Option<&Normalizer> {
        self.stage.as_ref()
    }

    /// The method's own model (which expects normalised images).
    pub fn inner(&self) -> &AnyModel {
        &self.inner
    }

    /// Normalises a batch of queries; a refused one is an error naming its place in the batch.
    fn normalise<'q>(&self, queries: &'q [f32]) -> Result<std::borrow::Cow<'q, [f32]>> {
        match &self.stage {
            Some(stage) => {
                crate::model::check_queries(stage.features(), queries.len(), "query batch")?;
                Ok(stage.apply_queries(queries)?.into())
            }
            None => Ok(queries.into()),
        }
    }
}

impl PoseModel for Normalized {
    fn method(&self) -> &'static Method {
        self.inner.method()
    }
    fn meta(&self) -> &ModelMeta {
        &self.meta
    }
    fn predict_into(&self, queries: &[f32], out: &mut [f64]) -> Result<()> {
        let q = self.normalise(queries)?;
        self.inner.predict_into(&q, out)
    }
    fn predict_u8_into(&self, queries: &[u8], out: &mut [f64]) -> Result<()> {
        match &self.stage {
            // The method's own 8-bit path, where nothing is normalised.
            None => self.inner.predict_u8_into(queries, out),
            Some(_) => {
                let f: Vec<f32> = queries.iter().map(|&v| v as f32 * crate::kernels::levels::S8).collect();
                self.predict_into(&f, out)
            }
        }
    }
    fn estimate(&self, queries: &[f32], top: usize) -> Result<Vec<Estimate>> {
        let q = self.normalise(queries)?;
        self.inner.estimate(&q, top)
    }
    fn model_bytes(&self) -> usize {
        // The stage's numbers: threshold, radius, brightness.
        self.inner.model_bytes() + self.stage.as_ref().map_or(0, |_| 3 * std::mem::size_of::<f64>())
    }
    fn storage(&self) -> Storage {
        self.inner.storage()
    }
    fn tensors(&self) -> Vec<Tensor> {
        self.inner.tensors()
    }
    fn coefficients(&self) -> Option<&[f64]> {
        self.inner.coefficients()
    }
    fn behind_stage(&self) -> Option<(&Normalizer, &dyn PoseModel)> {
        self.stage.as_ref().map(|s| (s, &self.inner as &dyn PoseModel))
    }
}
