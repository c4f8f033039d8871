//! The refined eigenspace, linpose's own method beyond the paper: Murase & Nayar's eigenspace and
//! spline manifold ([`crate::methods::eigenspace`]), with the manifold kept as a surface and
//! searched there instead of resampled densely, noisy queries detected and matched apart, and
//! every setting chosen from held-out training views. `docs/refined.md` describes the method for
//! users; this is the map of its code.
//!
//! ```
//! use linpose::image_io::{ColorMode, ImageSpec};
//! use linpose::{Dataset, Estimator, Param, PoseModel, PoseSpace, RefinedParams};
//!
//! // A turntable seen every 10 degrees: 36 "images" of 64 pixels, a bright lobe turning round.
//! let space = PoseSpace::new(vec![Param::circular("azimuth", 360.0)])?;
//! let poses: Vec<f64> = (0..36).map(|k| 10.0 * k as f64).collect();
//! let image = |a: f64| (0..64).map(move |p| {
//!     let u = p as f64 / 64.0 * std::f64::consts::TAU;
//!     (0.2 + (3.0 * ((u - a.to_radians()).cos() - 1.0)).exp()) as f32
//! });
//! let pixels = poses.iter().flat_map(|&a| image(a)).collect();
//! let data = Dataset::new(ImageSpec { width: 64, height: 1, color: ColorMode::Gray }, pixels, space, poses)?;
//!
//! // Every setting chosen from held-out training views; `settings()` says what was chosen.
//! let model = RefinedParams::default().fit(&data)?;
//! let view: Vec<f32> = image(123.0).collect(); // between two training views
//! let pose = model.predict(&view)?;
//! assert!((pose[0] - 123.0).abs() <= 1.0, "{pose:?} with {:?}", model.settings().interpolant);
//! # Ok::<(), linpose::Error>(())
//! ```
//!
//! # A query
//!
//! 1. **Route** (`query.rs`). A model that bins takes the query's b x b block means
//!    (the crate's binning). The query's pixel noise (Immerkaer's estimate,
//!    which ignores smooth shading) is measured on the image as given, where noise stands out from
//!    the image's own detail (binning averages noise away faster than detail); above the model's
//!    noise threshold the query is noisy.
//! 2. **Project** (`projection/`, through the eigenspace's shared projector).
//!    As the eigenspace does (unit energy, the mean subtracted), but on the eigenimages its route
//!    uses only: a clean query on the clean search's L_s and the mean, whose product gives its
//!    residual off the eigenspace; a noisy one on the noisy match's.
//! 3. **Clean search** (`search/`). The least distance to the surface
//!    (`crate::manifold::surface`: the tensor-product cubic spline through the training views' coordinates, or
//!    the local cubic through the same knots, [`Interpolant`]), weighted per coordinate by
//!    w_l = 1 / (sigma_l^2 + floor + nu): sigma_l^2 is coordinate l's interpolation error on
//!    held-out training knots, so coordinates the surface interpolates badly count less; the
//!    floor (a fraction of their mean) bounds the trust in any one; nu is the query's own noise
//!    per coordinate, its residual beyond the training views' over the M - L_s coordinates it
//!    spreads over for isotropic noise. With one pose parameter the search is exact over every
//!    pose of the reporting lattice; with two, reported on a lattice, it starts from a k-d tree
//!    over the surface on a coarser lattice and climbs the reporting one; otherwise (more than
//!    two, whose manifold is kept as its knots, `manifold::dense_lattice`: no lattice
//!    is resampled) Levenberg-Marquardt runs from the closest coarse surface points (two per
//!    knot interval along each axis with more than two parameters) and its end is snapped to
//!    the lattice; the noisy match likewise.
//! 4. **Noisy match** (`noisy/`). Uniform noise clipped to [0, 1] is not zero-mean:
//!    it brightens a dark background by about a / 4 and adds energy, a silhouette-shaped change
//!    in the leading, most trusted coordinates that a plain distance takes for a change of pose.
//!    So a noisy query's coordinates z (the mean added back) are matched against
//!    alpha (f(t) + c) + beta g(t), the surface point with a free gain alpha and a free multiple
//!    beta of the offset direction g (what clipped noise adds on average, projected), both solved
//!    per pose in closed form.
//! 5. **Report.** The pose on the lattice of `resolution` degrees (by default the eigenspace's
//!    0.5, anchored at each parameter's first training value), or the continuous estimate.
//! 6. **Second look** (`second_look`, the query's pose in another basin in `basin.rs`).
//!    Where every principal component of the training views puts the query nearer another basin
//!    of the pose space (a nearly symmetric object's other side), the route's search runs again
//!    there; the same look gives the ranked hypotheses and the confidence.
//!
//! # A fit
//!
//! `fit.rs` and `select.rs` choose from the training views alone, by the pose error of
//! held-out training views (every other knot along each axis held out, then the others, the
//! manifold fitted without them): L and the metric (weighted, or the eigenspace's plain distance
//! when that scores better), the interpolant, the binning factor (the coarsest within one
//! standard error of the least error: coarser images interpolate better, their products cost
//! b^2 times less, and pixel noise's variance is divided by b^2), the noisy match's L and weighting
//! (on held-out views under simulated noise) and the noise threshold (between the noisiest clean
//! training image and the least noisy one under simulated noise). No automatic choice makes a
//! query cost as much as the eigenspace's, and the model keeps only the eigenimages its queries
//! use. With a camera roll (a `roll` beside `elevation` and `azimuth`) whose training views show
//! that it turns the image, the surface also passes through training views turned to the rolls
//! between the training rolls (`crate::manifold::roll`), knots of the surface only: the choices
//! above are made on the training views. Every tuning constant, with how it was chosen, is in
//! `tuning.rs`.
//!
//! Trained in f64, served in f32: basis, mean and surface are stored as f32, the projections are
//! f32 (or exact integer) products, the searches run in f64 on the f32 numbers.
//!
//! # Files
//!
//! `params.rs` (parameters and recorded settings), `fit.rs` and `select.rs` (fitting), `model.rs`
//! (the model, its file parts and [`crate::PoseModel`]), `query.rs` (batches and routes),
//! `projection/`, `search/` (the clean searches, the lattice search among them), `noisy/` (the
//! affine match, its tree and its scan), `lm.rs` (Levenberg-Marquardt on the shared surface of
//! `crate::manifold::surface`, which evaluates and climbs), `scratch.rs` (per-thread buffers),
//! `basin.rs` (the search in another basin), `tuning.rs`, `method.rs` (the registry entry),
//! `tests/`.

mod fit;
mod footprint;
mod lm;
mod basin;
mod method;
mod model;
mod noisy;
mod params;
mod projection;
mod query;
mod scratch;
mod search;
mod tuning;
pub(crate) mod select;

pub(crate) use method::METHOD;
pub use model::RefinedModel;
pub use params::{RefinedParams, RefinedSettings};
pub use crate::manifold::Interpolant;
pub(crate) use crate::manifold::INTERPOLANTS;

pub(crate) use fit::Views;

#[cfg(test)]
mod tests;
