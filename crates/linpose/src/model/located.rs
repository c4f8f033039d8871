//! Queries larger than the training views: a model that can find its object in a larger image
//! (a scene) says so by [`PoseModel::scene_search`], and gives the object's box and the query the
//! method takes. The robust stage is the one that can ([`crate::robust::Robust`]): it searches
//! the scene for the box its training views' eigenspace explains best.

use super::PoseModel;
use crate::image_io::ImageSpec;
use crate::Result;
use serde::{Deserialize, Serialize};

/// The object found in a scene.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Located {
    /// The box of the training view's frame in the scene: left, top, width and height in
    /// pixels, the scene's top-left corner at (0, 0).
    pub bbox: [f64; 4],
    /// The box's size over the training views' (the object's scale in the scene).
    pub scale: f64,
    /// The share of the object's pixels the estimate used: of the object's bright pixels in the
    /// reconstruction, those the query explains (1 when the query needed no repair).
    pub shown: f64,
    /// Whether the query was repaired (its unexplained pixels replaced by the reconstruction).
    pub repaired: bool,
    /// The box resampled to the training views' size, repaired where it was: the query the
    /// method takes.
    #[serde(skip)]
    pub view: Vec<f32>,
    /// What the answer to a repaired view is checked against (`crate::robust`); empty when not
    /// repaired.
    #[serde(skip)]
    pub(crate) kept: Kept,
}

/// What the robust stage's check of a repaired view's answer needs besides the view.
#[derive(Debug, Clone, Default, PartialEq)]
pub(crate) struct Kept {
    /// The bins of the view the repair kept whole.
    pub(crate) bins: Vec<u32>,
    /// The fit's threshold.
    pub(crate) theta: f32,
    /// The pose of the training view nearest the fit (None: no training views kept).
    pub(crate) fit_pose: Option<Vec<f64>>,
    /// The pose the box was settled with (None: not settled).
    pub(crate) settled: Option<Vec<f64>>,
}

/// A model that finds its object in images larger than its training views.
pub trait SceneSearch: Sync {
    /// Finds the object in each of `scenes` (rows of `spec`'s features, each image larger than
    /// the training views) and makes the query the method takes from it.
    fn locate(&self, scenes: &[f32], spec: ImageSpec) -> Result<Vec<Located>>;

    /// The method's own model, which takes [`Located::view`].
    fn method_model(&self) -> &dyn PoseModel;

    /// The poses of located queries (rows of P): the method's on each [`Located::view`], unless
    /// the search checks the answers to the views it repaired (the robust stage does, against
    /// the view's own pixels), when they are [`SceneSearch::estimate_located`]'s.
    fn predict_located(&self, found: &[Located]) -> Result<Vec<f64>> {
        let views: Vec<f32> = found.iter().flat_map(|f| f.view.iter().copied()).collect();
        self.method_model().predict(&views)
    }

    /// The estimates of located queries: the method's, the confidence of a repaired one scaled
    /// by how far a query showing its share of the object ([`Located::shown`]) can be trusted,
    /// as for a query of the training views' size.
    fn estimate_located(&self, found: &[Located], top: usize) -> Result<Vec<crate::confidence::Estimate>>;
}
