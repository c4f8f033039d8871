//! Every constant of the normalisation stage, in one place: what it trades and how its value was
//! chosen. None of them was fitted to the jittered queries the stage is measured on
//! (BENCHMARKS.md, "Normalisation"); each was set from what the training images of the rendered
//! objects and of COIL-20 show, or from the size of a gray level.

/// Half a gray level of an 8-bit image (a fraction of full brightness): the smallest threshold
/// between background and object. A pixel that differs from the background by less than this is
/// what 8-bit quantisation makes of the background itself. Not tuned: fixed by the 8-bit images
/// the data sets are stored in.
pub(crate) const HALF_LEVEL: f32 = 0.5 / 255.0;

/// The background counts as dark (its level is 0, not measured per image) when the median of the
/// training views' border medians is at most this (two gray levels). A dark background measured
/// per image would take the object for background wherever it covers most of the border, which
/// COIL-20's views, framed to the edge by their makers, do (10% of them have a border median of
/// 2 to 9 gray levels, the median over the 1,440 views is 0). Rendered views: 0.
pub(crate) const DARK_LEVEL: f32 = 2.0 / 255.0;

/// The threshold is this many times the 90th percentile of the border's deviations from the
/// background level (and at least [`HALF_LEVEL`]): the border is background when the object does
/// not touch it, so the 90th percentile measures the camera's noise. For Gaussian noise of
/// deviation s it is 1.64 s, so the threshold is 3.3 s (1 background pixel in 1,000 over it, an
/// isolated speck left out as in [`BLOB_SHARE`]); for uniform noise of +-a clipped at black
/// (the evaluations' noise on a dark background) 1.6 a, over every noise value. Not tuned on
/// the measured queries: set from those two noise models.
pub(crate) const NOISE_FACTOR: f32 = 2.0;

/// A second region of the foreground is another object (the image is refused as several blobs)
/// when its weight (summed deviation from the background) is at least this share of the largest
/// region's; smaller regions are specks of noise or dust and are left out of the object's
/// position and size. The training views of COIL-20 show detached parts of at most 1.3% of the
/// object's weight (object 19's thin parts), the rendered objects none; 5% keeps a margin of
/// almost 4 above COIL's largest while refusing any second object of a twentieth of the first's
/// weight. Not tuned further.
pub(crate) const BLOB_SHARE: f64 = 0.05;
