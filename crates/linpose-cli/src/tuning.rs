//! The command line's tuning constants outside its folders (`cmd/` and `study/` keep theirs in
//! their own `tuning.rs`): for each, what it trades and how its value was set.

/// Images decoded and estimated per batch of `predict` and `eval`: bounds memory whatever the
/// number of images (a batch's images are held decoded together), while a larger batch gives the
/// model's batched products and the threads more to share. Chosen by hand; not measured.
pub(crate) const BATCH: usize = 512;
