//! The constants of finding an object against its studio backdrop ([`super::segment`]): what
//! each trades and how its value was set. They were set on rendered views and on COIL-20's, not
//! on the scenes' measurements.

/// The backdrop's spread is this quantile of the border pixels' deviations from its level (their
/// median): the median, so that the object may cover up to half the border. COIL-20's views
/// are framed to their objects, which cover more than a quarter of the border of some (7 views
/// of the cars were refused with the 75th percentile), where a higher quantile is the object's
/// brightness, not the backdrop's noise. For Gaussian noise
/// of deviation s, the median deviation is 0.67 s.
pub(crate) const SPREAD_QUANTILE: f64 = 0.5;

/// A pixel is the object when it deviates from the backdrop's level (in any channel) by more than
/// this many times the backdrop's spread ([`SPREAD_QUANTILE`]): 3.4 s for Gaussian noise of
/// deviation s, about one backdrop pixel in 1,500 over it (an isolated speck, left out by
/// [`SPECK_PIXELS`]). What it trades: lower, and the backdrop's noise joins the object's rim;
/// higher, and the object's parts near the backdrop's level are lost. Not tuned.
pub(crate) const SPREAD_FACTOR: f64 = 5.0;

/// The smallest threshold, gray levels: a pixel differing from the backdrop by one level is
/// what 8-bit rounding and a flat backdrop's faint shading make of the backdrop (COIL-20's
/// backdrops are one level: 0, or 3 to 5 for the duck). A consequence of 8-bit images, not
/// tuned.
pub(crate) const MIN_THRESHOLD: f64 = 1.5;

/// The threshold beyond which the border is not a uniform backdrop and the view is refused: 24
/// gray levels, a median deviation of 5 levels, which no view of the rendered sets or of COIL-20
/// reaches (none is refused) and uniform camera noise of +-10% (a median deviation of 13
/// levels) exceeds. An object against clutter cannot be told from it by its level.
pub(crate) const MAX_THRESHOLD: f64 = 24.0;

/// A region of the object's pixels smaller than this share of the largest region is a speck
/// (noise, dust, a sliver of a reflection) and is left out; larger ones near it are parts of the
/// object (a handle, a stem, a part a dark band cuts off). The normalisation stage's share for
/// the same question (docs/normalization.md); not tuned here.
pub(crate) const SPECK_SHARE: f64 = 0.005;

/// A region of fewer pixels than this is a speck however large the object: a backdrop's noise
/// makes isolated pixels and pairs over the threshold, an object's part a few pixels wide is
/// no part worth keeping. Not tuned.
pub(crate) const SPECK_PIXELS: usize = 4;

/// A region counts as a part of the object when the gap between its bounding box and the
/// largest region's is at most this many times that region's larger side: a rigid object's
/// parts lie within its bounding sphere (the normalisation stage's rule, docs/normalization.md).
pub(crate) const JOIN_GAP: f64 = 1.0;

/// A hole in the object (backdrop pixels it encloses on every side) is filled, kept as the
/// studio view has it, when it is at most this share of the object's pixels. An enclosed region
/// at the backdrop's level is either a part of the object as dark (or bright) as the backdrop -
/// an eye, a letter, a car's windscreen - or a hole through the object that shows the backdrop -
/// a cup's handle, a ring - and its pixels cannot tell which. Measured: the dark parts that
/// COIL-20's objects enclose are up to 15% of the object (the toy cars' windscreens, on every
/// view), the rendered objects' up to 4%; holes through a handle are 1.6-6.6% (the pot, the
/// mug, COIL-20's cup), the rendered ring's hole 11-58%. Filling up to a quarter keeps every dark
/// part and every handle's hole (which then keeps the studio's backdrop, a few percent of the
/// object) and replaces the backdrop in a ring's hole at most poses. What it trades: lower, and
/// dark parts of the object become clutter; higher, and more of the studio backdrop stays. Set
/// from those measurements, between the two, not tuned on the scenes.
pub(crate) const HOLE_SHARE: f64 = 0.25;

/// A view whose object has fewer pixels than this is refused: what differs from the backdrop is
/// specks, not an object. Not tuned.
pub(crate) const MIN_OBJECT_PIXELS: usize = 16;

/// Views read, put into scenes and written per parallel chunk, as `synth` renders them: a chunk
/// is checked for failures before the next starts, so a view that is refused stops the work
/// within a chunk. Chosen by hand; not measured.
pub(crate) const CHUNK: usize = 256;
