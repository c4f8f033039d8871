//! What the manifold methods share: the principal components of the training views (`pca`; with
//! more views than pixels from their scatter, `scatter`),
//! the projector that takes a query's coordinates on them (`projector`), the training views'
//! grid of poses and its dense resampling (`grid`), the splines and surfaces through the views'
//! coordinates (`spline`, `surface`, [`Interpolant`]), the k-d tree over manifold points
//! (`kdtree`), the knots a camera roll adds between the training rolls, training views turned in
//! the image (`roll`), the coarse candidates of a continuous search from the training views (`knots`),
//! and the held-out folds every automatic choice is scored on (`folds`).
//!
//! Whether a manifold is resampled on a dense lattice of poses or kept as its knots (the
//! training views' coordinates) and searched continuously is one rule, [`dense_lattice`]: the
//! lattice for at most two pose parameters, the knots beyond (`tuning.rs` says what it trades).
//!
//! The eigenspace, the refined method, the second look and the recognisers build on this module;
//! it depends on none of them, so each of those can change without the others.

pub(crate) mod folds;
pub(crate) mod grid;
pub(crate) mod kdtree;
pub(crate) mod knots;
pub(crate) mod pca;
pub(crate) mod projector;
pub(crate) mod roll;
pub(crate) mod scatter;
pub(crate) mod spline;
pub(crate) mod surface;
pub(crate) mod tuning;

pub use surface::Interpolant;
pub(crate) use surface::INTERPOLANTS;

/// Whether a manifold over `params` pose parameters is resampled on a dense lattice of poses
/// (every parameter every few tenths of a degree: the eigenspace's manifold points, the refined
/// method's lattice search and coarse tree, the recognisers' manifold points) rather than kept as
/// its knots, the training views' coordinates, and searched continuously from the nearest of them
/// (Levenberg-Marquardt on the surface through them). At most
/// [`tuning::LATTICE_MAX_PARAMS`] parameters.
pub(crate) fn dense_lattice(params: usize) -> bool {
    params <= tuning::LATTICE_MAX_PARAMS
}

/// Queries projected and searched together by one rayon task: at most 128 (a 128 x 19,200 block
/// of queries against the basis stays in cache), at least 8, and small enough that a batch gives
/// every thread a few tasks.
pub(crate) fn chunk_rows(n: usize) -> usize {
    n.div_ceil(4 * rayon::current_num_threads().max(1)).clamp(8, 128)
}
