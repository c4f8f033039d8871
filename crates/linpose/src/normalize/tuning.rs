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

/// A region of the foreground is part of the object when the gap between its bounding box and
/// the heaviest region's is at most this many times that region's size (the longer side of its
/// bounding box); farther regions are left out of the object. What it trades: too small, and a
/// part cut off by a dark band or a gap (a mug's handle, a cup's saucer, a toy's wheel) is left
/// out of the centre and size, which then move with the pose as the part turns out of view;
/// too large, and a second object or clutter beside the first counts as part of it. Set from
/// geometry, not fitted: a rigid object's parts lie within its bounding sphere, so a part's gap
/// to the largest part is at most the sphere's diameter, which is about the largest part's size
/// unless that part is small against the whole; a second object on the turntable stands at
/// least its own size away for the two to be told apart at all. Measured: the parts the zoo's
/// seeds 0-399 and COIL-20 cut off lie within 0.4 of it (docs/normalization.md).
pub(crate) const JOIN_GAP: f64 = 1.0;

/// A region of the foreground lighter than this share of the heaviest region's weight is a speck
/// (noise, dust, a sliver of the object's rim) and is left out of the object wherever it lies.
/// What it trades: specks near the object, joined, move its centre and radius by what noise
/// happens to put there (a noisy query's smoothed background has a few); a part as light as this,
/// left out, moves them by its share. Measured, not fitted: COIL-20's detached slivers weigh at
/// most 0.16% of the object, the parts a dark band or gap cuts off in zoo seeds 0-399 at least
/// 2.9% (94 parts); 0.5% lies between.
pub(crate) const PART_SHARE: f64 = 0.005;

/// A region away from the object ([`JOIN_GAP`]) in a training view is a second object, and
/// training stops naming the view, when its weight (summed deviation from the background) is at
/// least this share of the object's heaviest region's; lighter ones are specks of noise or dust.
/// In a query such regions are left out of the object without a word (clutter beside it). The
/// rendered objects and COIL-20 have no region away from the object; 5% refuses any second
/// object of a twentieth of the first's weight. Not tuned further.
pub(crate) const BLOB_SHARE: f64 = 0.05;

/// A query is noisy, and its object is found on a smoothed copy ([`SMOOTH`]), when its pixel
/// noise (Immerkaer's estimate from the median response, `find::noise`) is more than this many
/// times the largest the training views show. Clean images' estimate is a floor set by 8-bit
/// rounding and the texture of objects that fill the frame; twice the floor keeps every clean
/// view on the exact path. Not tuned on the evaluations.
pub(crate) const NOISY: f32 = 2.0;

/// The pixel noise that decides whether a query is noisy is measured on every this many rows:
/// a 128-row image keeps 32 (4,000 responses, whose median moves by a few percent against all
/// rows'), and the estimate costs a quarter of measuring every row (it was 44% of a COIL-20
/// query's normalisation). Not tuned.
pub(crate) const NOISE_ROW_STEP: usize = 4;

/// The half-width of the box a noisy query is smoothed with before its object is found: 5 x 5
/// pixels, which divides white noise's deviation by 5, so that the raised threshold no longer
/// cuts the object's dark parts away (at +-10%, parts 0.02 above the background stay in the
/// object rather than 0.16). A larger box removes more noise and merges more of the
/// background's edge into the object; the radius is corrected for the box's spread either way.
pub(crate) const SMOOTH: usize = 2;

/// A noisy query's smoothed pixels are foreground where they deviate from the background by
/// more than this many times the smoothed noise's standard deviation (its pixel noise over the
/// box's side): 3.3, as [`NOISE_FACTOR`] times the 90th percentile (1.64 deviations) of Gaussian
/// noise, which smoothing makes of any noise. Measured on the image itself, not on its border,
/// so it serves data framed to the object too. Not tuned.
pub(crate) const NOISE_SIGMAS: f32 = 3.3;

/// The uniform noise amplitudes the training views are given to calibrate the radius that noisy
/// queries' objects are found at ([`super::Normalizer::noisy_radius`]): the smoothed threshold
/// keeps the object's faint edge where noise lifts it and cuts it where noise lowers it, so the
/// radius comes out 0.1-0.3% large at +-2-10% (the cap, the duck; the column's dark ends 0.3-0.6%),
/// which costs the refined method on the cap 0.289 against 0.178 degrees at +-5% (corrected by
/// the median). The paper's two levels, as the refined method's noisy match simulates; between
/// and beyond them the correction is interpolated linearly and held. Not tuned.
pub(crate) const CALIBRATION_NOISE: &[f64] = &[0.05, 0.1];

/// At most this many training views (evenly spread) are given noise for that calibration: the
/// median of 256 ratios is exact to well under the spread between views (0.1% at +-5%), at the
/// cost of 512 noisy finds. Not tuned.
pub(crate) const CALIBRATION_VIEWS: usize = 256;

/// Seed of the calibration's noise: any value; fixed so that a fit is reproducible.
pub(crate) const CALIBRATION_SEED: u64 = 0xca1b;
