//! The manifold's tuning constants, each with what it trades and how it was set.

/// The fewest knots along an axis for it to give held-out folds: holding out every other knot of
/// fewer would leave a curve of one or two knots. Not tuned.
pub(crate) const MIN_FOLD_KNOTS: usize = 4;
