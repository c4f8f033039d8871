//! The pixel-noise estimate's sampling (the rows a query's estimate reads): for each constant
//! what it trades and how its value was set.

/// Rows sampled by [`super::pixel_noise`]: every this many. Fewer rows cost less and estimate the
/// noise from fewer pixels (a 128-row image keeps 16). A tuning constant, not tuned: 8 since the
/// estimate was introduced (2026-11-21).
pub(crate) const NOISE_ROW_STEP: usize = 8;

/// The first pass of a staged noise estimate takes every this many sampled rows (a quarter: a
/// clean image settled there costs a quarter of the estimate; fewer rows would tell noise from
/// detail less surely). Chosen with the refined method's stop level (its `tuning::NOISE_EARLY`,
/// 2026-11-22); other fractions were not tried.
pub(crate) const FIRST_EVERY: usize = 4;

/// ... from this one (rows 17, 49, 81, 113 of a 128-row image: away from the top edge, which on a
/// turntable is background). Not tuned.
pub(crate) const FIRST_AT: usize = 2;
