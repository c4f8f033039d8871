//! The manifold's tuning constants, each with what it trades and how it was set.

/// The fewest knots along an axis for it to give held-out folds: holding out every other knot of
/// fewer would leave a curve of one or two knots. Not tuned.
pub(crate) const MIN_FOLD_KNOTS: usize = 4;

/// From this many 8-bit images on, a product takes the batch kernel (its register blocks of
/// several images) instead of one image at a time; fewer leave the blocks mostly empty. The
/// results are the same bits either way. Chosen by hand; not measured.
pub(crate) const BATCH_FROM: usize = 8;

/// Most 8-bit queries per parallel task of a batch (a multiple of the kernels' blocks: 6 images
/// in `dot_u8::dots_batch`, 16 in `dot_q::dots_batch`): a larger task reads the weights from the
/// outer caches fewer times, a smaller one shares a batch between more threads. 192 is
/// `dot_u8`'s cache block of images, which it was defined as before (33f96bd). Not timed
/// against other values.
pub(crate) const U8_BATCH: usize = 192;

/// Bytes per N^2 of a PCA through the Gram matrix ([`super::pca`]: the eigenspace's, the
/// universal recogniser's): the Gram matrix of the centred unit-energy images and its
/// eigendecomposition (the eigenvectors and faer's workspace), for the memory plan
/// ([`crate::memory`], whose documentation tables the measurements). Measured 29 to 31 N^2
/// (N = 2,880 and 5,760, 16 x 12 images) and 42 at N = 1,440 (with the heap's spare N x N
/// matrix, `crate::huge::HEAP_MATRIX_BYTES`, 34); rounded up.
pub(crate) const EVD_SYSTEM_BYTES: f64 = 36.0;

/// Bytes per resampled manifold point and eigenimage ([`super::grid`]), for the memory plan: the
/// spline's f64 cube, its resampled f64 points, their f32 copy and the search tree's. Read from
/// the code (8 + 8 + 4 + 4).
pub(crate) const MANIFOLD_VALUE_BYTES: f64 = 24.0;
