//! # linpose
//!
//! Appearance-based pose estimation. linpose estimates the pose of an object from an image, given
//! images of the object under known poses (a turntable, a robot arm, a render farm). It implements
//! Okatani & Deguchi's linear model (MVA 2000) - each pose parameter a linear function of the
//! pixels, fitted as the minimum-norm exact solution through the N x N Gram matrix - and the
//! method that paper measures itself against, Murase & Nayar's parametric eigenspace.
//!
//! ```
//! use linpose::{Dataset, Estimator, LinearParams, Manifest, Param, PoseModel, PoseSpace};
//! use linpose::image_io::{ColorMode, ImageSpec};
//!
//! // Four 2x2 "images" of a turntable angle, with their poses.
//! let space = PoseSpace::new(vec![Param::circular("azimuth", 360.0)])?;
//! let manifest = Manifest::new(".", space, (0..4).map(|i| format!("{i}.png")).collect(), vec![0.0, 90.0, 180.0, 270.0])?;
//! let spec = ImageSpec { width: 2, height: 2, color: ColorMode::Gray };
//! let pixels = vec![1.0, 0.6, 0.0, 0.2, 0.2, 1.0, 0.6, 0.0, 0.0, 0.2, 1.0, 0.6, 0.6, 0.0, 0.2, 1.0];
//! let data = Dataset::from_features(manifest, spec, pixels)?;
//!
//! let model = LinearParams::default().fit(&data)?;
//! let pose = model.predict(data.row(1))?;
//! assert!((pose[0] - 90.0).abs() < 1e-3);
//! # Ok::<(), linpose::Error>(())
//! ```
#![deny(missing_docs)]
// `!(x > t)` is how this crate rejects NaN together with the values at or below t (it is true for
// NaN, where `x <= t` is false); the lint's rewrite would hide that.
#![allow(clippy::neg_cmp_op_on_partial_ord)]

pub mod atomic;
pub mod binning;
pub mod dataset;
pub mod error;
pub mod eval;
pub mod experiment;
pub mod image_io;
pub(crate) mod kernels;
pub mod linalg;
pub mod manifest;
pub mod methods;
pub mod model;
pub mod model_file;
pub mod pose;
pub mod render;

pub use dataset::Dataset;
pub use error::{Error, Result};
pub use eval::{evaluate, EvalReport};
#[doc(hidden)]
pub use kernels::bench;
pub use manifest::{Manifest, TrainSelection};
pub use methods::eigenspace::{EigenspaceModel, EigenspaceParams};
pub use methods::linear::ridge::RidgeRule;
pub use methods::linear::{LinearModel, LinearParams};
pub use methods::refined::{RefinedModel, RefinedParams};
pub use methods::MethodSpec;
pub use model::{AnyModel, Estimator, ModelMeta, PoseModel};
pub use pose::{ErrorSummary, Param, PoseSpace};

/// The methods a model can be trained with, by name.
pub const METHODS: &[&str] = &[methods::linear::METHOD, methods::eigenspace::METHOD, methods::refined::METHOD];

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
