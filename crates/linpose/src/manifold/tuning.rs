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
