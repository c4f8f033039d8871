//! What a method gives to be fitted from partial statistics ([`crate::partial`]): how a training
//! set is cut into shards for it ([`Split`]), whether the sums are of centred images, and the
//! model from the merged sums. A method that fits so says it in its [`Method`](super::Method)'s
//! `partial`; the partial statistics find the method by name and ask it, and name no method
//! themselves.

use super::AnyModel;
use crate::dataset::Dataset;
use crate::image_io::ImageSpec;
use crate::normal_equations::NormalEquations;
use crate::pose::PoseSpace;
use crate::{Error, Result};
use faer::Mat;
use serde::{Deserialize, Serialize};

/// How a training set is cut into shards.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Split {
    /// Shards of images: each sums X^T X and X^T P over its images.
    Images,
    /// Shards of pixels: each sums X X^T over its pixels of every image, and keeps them.
    Pixels,
}

impl Split {
    /// What a shard holds, in words.
    pub fn unit(self) -> &'static str {
        match self {
            Split::Images => "images",
            Split::Pixels => "pixels",
        }
    }
}

/// A method's fit, with its settings, from statistics summed over shards of the training set.
pub(crate) trait PartialFit: std::fmt::Debug + Send + Sync {
    /// How `n` images of `m` features are cut into shards; an error saying what keeps these
    /// settings from being fitted so.
    fn split(&self, n: usize, m: usize) -> Result<Split>;

    /// Whether a shard of pixels sums the Gram matrix of the images centred about the mean image
    /// (the mean of a pixel needs only that pixel).
    fn centred(&self) -> bool {
        false
    }

    /// The model of the whole set `train` from its Gram matrix X X^T ([`Split::Pixels`]).
    fn fit_from_gram(&self, train: &Dataset, gram: Mat<f64>) -> Result<AnyModel>;

    /// The model from the whole set's normal equations ([`Split::Images`]): images of `spec`,
    /// their poses `poses` in `space`.
    fn fit_from_normal_equations(&self, _ne: NormalEquations, _space: &PoseSpace, _poses: &[f64], _spec: ImageSpec) -> Result<AnyModel> {
        Err(Error::invalid("split", Split::Images.unit(), "this method's statistics are summed over shards of pixels"))
    }
}
