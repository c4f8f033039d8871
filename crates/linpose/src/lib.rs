//! # linpose
//!
//! Appearance-based pose estimation. Given images of an object under known poses (a turntable, a
//! robot arm, a render farm), linpose learns to tell the pose of a new image. It implements
//! Okatani & Deguchi's linear model (MVA 2000: each pose parameter a linear function of the
//! pixels, fitted as the minimum-norm exact solution through the N x N Gram matrix, circular
//! parameters as (cos, sin)), the method that paper measures itself against, Murase & Nayar's
//! parametric eigenspace, and a refined eigenspace of its own. The maths and the protocol are in
//! the repository's `docs/method.md`.
//!
//! ```
//! use linpose::{Dataset, Estimator, LinearParams, Param, PoseModel, PoseSpace};
//! use linpose::image_io::{ColorMode, ImageSpec};
//!
//! // Four 2x2 "images" of a turntable angle, with their poses.
//! let space = PoseSpace::new(vec![Param::circular("azimuth", 360.0)])?;
//! let spec = ImageSpec { width: 2, height: 2, color: ColorMode::Gray };
//! let pixels = vec![1.0, 0.6, 0.0, 0.2, 0.2, 1.0, 0.6, 0.0, 0.0, 0.2, 1.0, 0.6, 0.6, 0.0, 0.2, 1.0];
//! let data = Dataset::new(spec, pixels, space, vec![0.0, 90.0, 180.0, 270.0])?;
//!
//! let model = LinearParams::default().fit(&data)?;
//! let pose = model.predict(data.row(1))?;
//! assert!((pose[0] - 90.0).abs() < 1e-3);
//! # Ok::<(), linpose::Error>(())
//! ```
//!
//! ## The pieces
//!
//! - **Data**: a [`Dataset`] holds images as feature rows with their poses in a [`PoseSpace`]
//!   (parameters, [`Param`], linear or circular): built in memory ([`Dataset::new`]) or read from
//!   a folder ([`Manifest::open`], then [`Dataset::load`]); [`TrainSelection`] picks the training
//!   views. [`image_io`] says how images become features and reads query images.
//! - **Methods**: each method's parameters are an [`Estimator`] that fits a [`PoseModel`]:
//!   [`LinearParams`] / [`LinearModel`], [`EigenspaceParams`] / [`EigenspaceModel`],
//!   [`RefinedParams`] / [`RefinedModel`] (one folder each under [`methods`]). [`METHODS`] lists
//!   them as [`Method`]s; a method with its parameters is a [`MethodSpec`], or comes from
//!   settings by name ([`Settings`], [`Method::spec`]); a fitted model of any method is an
//!   [`AnyModel`].
//! - **Confidence**: [`PoseModel::estimate`] gives each estimate its ranked hypotheses
//!   ([`Hypothesis`]) and a confidence ([`Estimate`]), so a front taken for a back is flagged
//!   ([`confidence`]).
//! - **Normalisation**: [`normalize`] finds the object in each image and centres and scales it
//!   (optionally its brightness too) before a method sees it, so a camera's images need not be
//!   registered like the training views ([`model::Normalized`] puts any method's model
//!   behind the stage; the model file keeps it).
//! - **Model files**: [`model_file`] saves and loads models as safetensors.
//! - **Memory**: [`memory`] plans a training run before it allocates: what fitting in memory and
//!   streaming need, against the memory there is, and which to take.
//! - **Evaluation**: [`evaluate`] estimates every view of a data set, optionally under pixel
//!   noise, and measures the pose error ([`PoseSpace::error_deg`]) over all and unseen views, and
//!   how well the confidence flags the gross errors ([`evaluate`], [`EvalOptions`]).
//! - **The renderer** (cargo feature `render`, off by default): `render` makes turntable data sets
//!   of built-in objects, meshes or procedural objects (`render::objects::random`, a zoo to
//!   measure robustness on), optionally in scenes: over a cluttered background, partly hidden
//!   by occluders (`render::scene`); `scene` puts the views of any data set into such scenes.
//!
//! Errors are one [`Error`] type that names the file, line or value at fault.
#![deny(missing_docs)]
#![warn(unreachable_pub)]
// `!(x > t)` is how this crate rejects NaN together with the values at or below t (it is true for
// NaN, where `x <= t` is false); the lint's rewrite would hide that.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod atomic;
#[cfg(feature = "bench")]
#[doc(hidden)]
pub mod bench;
pub(crate) mod binning;
pub mod catalog;
pub mod confidence;
pub mod dataset;
pub mod error;
pub mod eval;
pub(crate) mod huge;
pub mod image_io;
pub(crate) mod kernels;
pub(crate) mod linalg;
pub mod manifest;
pub(crate) mod manifold;
pub mod memory;
pub mod methods;
pub mod model;
pub mod model_file;
pub(crate) mod normal_equations;
pub mod normalize;
pub mod partial;
pub(crate) mod pixel_noise;
pub mod pose;
pub mod recognize;
#[cfg(feature = "render")]
pub mod render;
pub mod robust;
#[cfg(feature = "render")]
pub mod scene;
pub(crate) mod second_look;
pub(crate) mod stage_choice;
pub(crate) mod tuning;

pub use catalog::{Catalog, ObjectSet, Source};
pub use confidence::{Estimate, Hypothesis};
pub use dataset::Dataset;
pub use error::{Error, Result};
pub use eval::{evaluate, EvalOptions, EvalReport};
pub use manifest::{Manifest, TrainSelection};
pub use methods::eigenspace::{EigenspaceModel, EigenspaceParams};
pub use methods::linear::ridge::RidgeRule;
pub use methods::linear::{LinearModel, LinearParams};
pub use methods::refined::{RefinedModel, RefinedParams};
pub use methods::METHODS;
pub use model::{AnyModel, Estimator, Method, MethodSpec, ModelMeta, PoseModel, Settings};
pub use pose::{ErrorSummary, Param, PoseSpace};

#[cfg(test)]
mod autotraits {
    fn is_send_sync<T: Send + Sync>() {}

    #[test]
    fn models_are_send_and_sync() {
        is_send_sync::<crate::LinearModel>();
        is_send_sync::<crate::EigenspaceModel>();
        is_send_sync::<crate::RefinedModel>();
        is_send_sync::<crate::AnyModel>();
        is_send_sync::<crate::Dataset>();
    }
}
