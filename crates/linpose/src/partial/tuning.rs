//! Partial statistics' tuning constants, each with what it trades and how it was set.

/// Image files whose bytes make a partial's content fingerprint (spread evenly over the
/// training set; `content_fingerprint`). What it trades: every shard reads these files whole
/// besides its own images, and two data sets that differ only in images outside the sample
/// merge unnoticed. 16 files are a few hundred kB on a set of any size, and two objects, or
/// two renderings of one object, differ in every view. Chosen by hand; not measured.
pub(crate) const CONTENT_SAMPLE: usize = 16;
