//! The manifold's tuning constants, each with what it trades and how it was set.

/// The fewest knots along an axis for it to give held-out folds: holding out every other knot of
/// fewer would leave a curve of one or two knots. Not tuned.
pub(crate) const MIN_FOLD_KNOTS: usize = 4;

/// Most pose parameters of a manifold resampled on a dense lattice ([`super::dense_lattice`]);
/// with more, the manifold is kept as its knots (the training views' coordinates, N L numbers,
/// with the surface's slopes derived from them when loaded) and a query's pose is found from the
/// nearest training views by Levenberg-Marquardt on the surface. What it trades: the lattice
/// holds (range / step)^K points whatever the training set, and its nearest point is the least of
/// the distance over the whole lattice, with no start to choose; the knots hold N points, and the
/// continuous search can end in the wrong basin where the nearest training views mislead (the
/// second look then decides the basin). At the default 0.5 degrees, two parameters make at most
/// 720 x 720 points (41 MB of f32 at L = 20); three, on a duck rendered at azimuth 0-354,
/// elevation 32-68 and roll -30 to 30 degrees (360 training views, 160 x 120), 720 x 73 x 121 =
/// 6.4 million points: an eigenspace model of 513 MB trained in 107 s, where the knots make a
/// model of 4.4 MB trained in 4.7 s with the same unseen error (4.8 degrees; the refined method
/// 120 MB in 1,286 s against 2.7 MB in 12 s; both with the normalisation's choice, on 2 shared
/// cores, 2026-11-29). Set by the size of the lattice, not by a comparison of errors: every
/// model of one or two parameters keeps the lattice.
pub(crate) const LATTICE_MAX_PARAMS: usize = 2;

/// Points per knot interval along each axis at which a manifold kept as its knots is resampled
/// where a method needs points rather than a surface (the recognisers' nearest-point distances):
/// P^K points per training view. A finer resampling brings a point's distance nearer the
/// surface's, at P^K times the knots' memory. Not tuned.
pub(crate) const KNOT_RESAMPLE: usize = 4;

/// Coarse points per knot interval along each axis from which the continuous search on a
/// manifold kept as its knots starts (the eigenspace's and the refined method's): the surface at
/// P^D points per training view, the training views among them. What it trades: the nearest
/// training views in the eigenspace can all lie in a neighbouring cell (on a rendered duck seen
/// from above, turning the turntable and rolling the camera by as much look alike), and a start
/// between them lands in the query's own cell; each point costs L numbers, and the scan over them
/// L products a query. Measured on a stand-in three-parameter set (the duck rendered at
/// azimuth 0-354 every 6, elevation 32-77 every 9, rolled -30 to 30 every 10 degrees as an image
/// rotation; trained on the every-other-value lattice, 360 views; its 1,740 other views within
/// the training range): with P = 1 the eigenspace's own search ended farther from 185 of the
/// queries than the dense lattice's nearest point, unseen error 6.37 degrees (3.3% over 20)
/// against the lattice's 4.84; with P = 2, 46 queries, 4.80 degrees, none over 20 (2026-11-29).
pub(crate) const KNOT_START_PER_CELL: usize = 2;

/// The continuous search's starts among those coarse points (the eigenspace's): the nearest,
/// and the others within this ratio of its squared distance that are not next to a nearer start
/// on their grid, at most [`KNOT_STARTS`]. Each start costs one Levenberg-Marquardt search; more
/// reach more basins. The refined method's ratio (its `START_RATIO`), not tuned.
pub(crate) const KNOT_START_RATIO: f32 = 2.0;

/// See [`KNOT_START_RATIO`]. Not tuned.
pub(crate) const KNOT_STARTS: usize = 4;

/// Most Levenberg-Marquardt iterations from a start (the refined method's searches, the
/// eigenspace's on a manifold kept as its knots). Not tuned.
pub(crate) const MAX_ITER: usize = 8;

/// A Levenberg-Marquardt step below this many degrees ends a clean search: a fiftieth of the
/// reporting lattice (the refined method's default 0.5 degrees), which the pose is snapped to
/// anyway. Not compared with other values.
pub(crate) const STEP_TOL: f64 = 1e-2;

/// Levenberg-Marquardt's damping: it starts at this fraction of the normal matrix's largest
/// diagonal entry, grows by [`DAMPING_UP`] after a failed step and shrinks by [`DAMPING_DOWN`]
/// (to at least [`DAMPING_MIN`]) after a successful one, with at most [`DAMPING_TRIES`] tries a
/// step. Customary values, not tuned.
pub(crate) const DAMPING_START: f64 = 1e-3;
/// See [`DAMPING_START`].
pub(crate) const DAMPING_UP: f64 = 4.0;
/// See [`DAMPING_START`].
pub(crate) const DAMPING_DOWN: f64 = 3.0;
/// See [`DAMPING_START`].
pub(crate) const DAMPING_MIN: f64 = 1e-12;
/// See [`DAMPING_START`].
pub(crate) const DAMPING_TRIES: usize = 12;

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

/// Bytes per N^2 of a PCA through the Gram matrix ([`super::pca`]: the eigenspace's, the
/// universal recogniser's): the Gram matrix of the centred unit-energy images and its
/// eigendecomposition (the eigenvectors and faer's workspace), for the memory plan
/// ([`crate::memory`], whose documentation tables the measurements). Measured 29 to 31 N^2
/// (N = 2,880 and 5,760, 16 x 12 images) and 42 at N = 1,440 (with the heap's spare N x N
/// matrix, `crate::huge::HEAP_MATRIX_BYTES`, 34); rounded up.
pub(crate) const EVD_SYSTEM_BYTES: f64 = 36.0;

/// Bytes per resampled manifold point and eigenimage ([`super::grid`]), for the memory plan: the
/// spline's f64 cube, its resampled f64 points, their f32 copy and the search tree's. Read from
/// the code (8 + 8 + 4 + 4).
pub(crate) const MANIFOLD_VALUE_BYTES: f64 = 24.0;

/// Bytes per knot-surface point and eigenimage of a manifold kept as its knots (more than two
/// pose parameters: 2^D points per training view, [`crate::memory`]'s lattice), for the memory
/// plan: the surface's f32 values and slopes and the f64 spline cube they are built from, the
/// start points (f32) and their k-d tree. Measured: the eigenspace's streamed fit of 1,010,160
/// views of 32 x 24 (three parameters, L = 20: 161.6 million such values) peaked at 2.71 GiB,
/// of which its other arrays (the coordinates, the knots, the manifest, the file's bytes) take
/// about 0.6 GiB: 14 bytes a value; 16 rounds it up.
pub(crate) const KNOT_VALUE_BYTES: f64 = 16.0;

/// Images per block of the scatter route of the PCA ([`super::scatter`], more images than
/// features): each block is turned to unit energy in f64 (8 M bytes an image: 6 MiB at 32 x 24)
/// and added to the M x M scatter by one matrix product, large enough to run at the product's
/// speed (a block of 1,024 images against 768 features is 1.2 GFLOP) and small beside the
/// scatter's own memory for M of a few thousand. Chosen by hand; not timed against other values.
pub(crate) const SCATTER_BLOCK: usize = 1024;

/// Most knots of a spline along one pose parameter ([`super::spline::check_knots`]): its slope
/// operator is dense, 24 n^2 bytes with its system while it is built (16,384 knots: 6 GiB) and an
/// LU of n^3 operations (16,384: about a minute on 2 cores), so a longer axis is refused before
/// anything is allocated rather than failing to allocate. Chosen from the memory; 10,000 knots
/// (2.2 GiB) trained in 113 s with the eigenspace's second look (one pose parameter, 32 x 24).
pub(crate) const MAX_SPLINE_KNOTS: usize = 16_384;

/// Most pairs of neighbouring training rolls whose turned views are compared to tell whether a
/// roll turns the image (`roll::turn_error`, spread evenly over the grid): more pairs give a
/// steadier ratio and cost a turned image each (about 0.2 ms at 160 x 120), in every fit. The
/// ratio is far from its threshold either way (0.005 on the rendered duck at 160 x 120, 0.025
/// at 48 x 36, against 0.25). Not tuned.
pub(crate) const TURN_PAIRS: usize = 64;
