//! The memory plan's own constants: what the process and its decoding threads take beside any
//! fit, and the share of the available memory a plan uses. What each method's and recogniser's
//! fit allocates is theirs ([`crate::model::footprint`]), its constants in their tuning files.
//!
//! Every estimate is checked against the peak resident memory of the release binary
//! (`/usr/bin/time -v`, "Maximum resident set size") on rendered data sets; the measurements
//! (2 cores, glibc's allocator) are tabled in [`super`]'s documentation. An estimate is meant as
//! an upper bound a little above the peak: too low and a plan that "fits" is killed, too high
//! and a set that would fit is streamed or refused.

/// The process itself: the binary, its libraries, the allocator's arenas and the thread pool.
/// Measured: 8.5 MiB peak for 36 images of 16 x 12 (one and two threads alike); 12 MiB leaves
/// room for the manifest and the small arrays no formula counts.
pub(crate) const OVERHEAD_BYTES: u64 = 12 << 20;

/// Per training image, whatever its size: the manifest (its name, its pose, the selection's
/// copy) and `poses.csv` as read. Measured: the linear model's streamed fit of 1,010,160 views
/// of 32 x 24 (three pose parameters, names of 25 characters) peaked at 267 and 284 MiB in two
/// runs, of which its arrays and the process take 30 MiB: 246 to 263 bytes an image; 288 is
/// above both. At 100,800 images this is 28 MiB, small beside any fit's own arrays.
pub(crate) const IMAGE_ENTRY_BYTES: u64 = 288;

/// Per thread and per feature of one image: each decoding thread holds an image as decoded
/// (up to 2 bytes a value for 16-bit images) and its row of f32 features. Read from the code
/// (2 + 4, rounded up to cover the decoder's own buffers); not measured apart (a few hundred
/// KiB per thread at 160 x 120).
pub(crate) const THREAD_FEATURE_BYTES: u64 = 16;

/// The share of the available memory a plan may use: the rest is left to the page cache, other
/// processes' growth while the fit runs, and the estimates' own error. A larger share trains
/// more sets in memory and risks the kernel's OOM killer more. Not tuned.
pub(crate) const USABLE_FRACTION: f64 = 0.9;
