//! The recognisers' tuning constants, each with what it trades and how it was set: the universal
//! recogniser's search and calibration, the linear recogniser's singular ridge, and what the
//! linear recogniser's fit costs in memory for the memory plan ([`crate::memory`], whose
//! documentation tables the measurements; the universal eigenspace's PCA and manifold cost what
//! the eigenspace's do: `crate::manifold::tuning`).

/// Manifold points per segment of the universal recogniser's pruned search: 16 points 0.5
/// degrees apart are an 8-degree arc, short enough for a tight sphere. Not tuned: the answer is
/// exact whatever its value; only the speed depends on it.
pub(crate) const SEGMENT: usize = 16;

/// Coordinates of a query computed first when its distance to one object's manifold only
/// matters under a bound (`Universal::own_distances_under`): with the first q coordinates y' and
/// the energy R^2 left past them, a point p of a segment of centre c and radius r lies at least
/// sqrt((||y' - c'|| - r)^2 + (R - ||p''||)^2) away, p'' its coordinates past q. Not tuned: the
/// answer is exact whatever its value; only the speed depends on it.
pub(crate) const PREFIX: usize = 4;

/// Segments per group of the pruned search's first level (256 points): a query's bounds are
/// computed for every group, then for the segments of the groups within reach. Not tuned, as
/// [`SEGMENT`].
pub(crate) const GROUP: usize = 16;

/// Which nearest other view calibrates a model fitted without poses (`universal::nearest_other`):
/// the second, that is, each view is held out together with its nearest other view (the linear
/// recogniser holds the same views out: `linear.rs`). A view held out of views sampled along a
/// turntable has two neighbours about one step away, one on each side, while a fresh view between
/// two training views lies about half a step from the nearer: the nearest and the second nearest
/// both measure the step. But a view can have a near-duplicate among the others (the `twin`'s
/// back looks like its front; a view listed twice), and then the nearest measures nothing: held
/// out alone, every unseen view of the rendered `twin` (5 built-in objects at elevation 40,
/// trained every 10 degrees, views 5 degrees off) was reported unknown, 36 of its 36. Held out
/// with its nearest, one duplicate per view is survived; more repeats than that (an object of
/// three identical sides) would call for a larger value. Not tuned on figures: the smallest value
/// the twin's one duplicate per view requires.
pub(crate) const NEIGHBOUR: usize = 2;

/// The ridge, relative to the largest diagonal entry of G times N, that the linear recogniser
/// solves a singular G (repeated views) with: ten times the pivot below which the Gram
/// factorisation refuses a system as singular (`GramSystem::factor`), so the fit is the
/// minimum-norm one to about that relative precision. Numerical, not tuned.
pub(crate) const SINGULAR_RIDGE: f64 = 1e-12;

/// Bytes per N^2 of the linear recogniser of many objects: G, its shifted copy and factor (as
/// the linear model's `GRAM_SYSTEM_BYTES`) and the factor's inverse (another N x N), read from
/// the code; measured within 10% above on three objects of 1,440 images.
pub(crate) const LINEAR_RECOGNIZER_BYTES: f64 = 32.0;
