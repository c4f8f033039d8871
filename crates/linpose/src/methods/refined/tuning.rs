//! Every tuning constant of the refined eigenspace, in one place: for each, what it trades and
//! how its value was chosen.
//!
//! Three kinds of evidence stand behind them, and each constant says which:
//!
//! - **Chosen on the comparison's unseen views.** `bench/beyond_compare.py` fits the method on the
//!   paper's rendered objects (duck, pot, cap, twin, column: views every 9 degrees, queried on all
//!   1,760, clean and under uniform +-5% and +-10% noise) and on COIL-20 (every tenth degree,
//!   queried on all 72 views). Where a value was picked by those errors, the views that picked it
//!   are the views that report the method's accuracy: they were not held out from the choice.
//! - **A `perf` profile or a timing taken on one day** (this 2-core machine, one thread unless
//!   said), with the date: a cost trade-off, whose best value may move with the machine.
//! - **Not tuned**: set once, never compared with another value. Said as such.
//!
//! The parameters' defaults ([`DEFAULT_STARTS`], [`DEFAULT_PER_CELL`], [`DEFAULT_RESOLUTION`]) are
//! here too; the settings the method chooses itself on held-out training views (L, the metric,
//! the interpolant, the binning factor, the noisy match, the noise threshold) are not constants.
//! The pixel-noise estimate's own sampling (every 8th row, a first pass of a quarter of them) is
//! in the estimator's tuning file ([`crate::pixel_noise`]'s `tuning.rs`). Constants fixed by the
//! maths or the hardware (the 7 products per knot of the lattice search, SIMD lane counts, array
//! sizes) stay beside their code.

// ---------------------------------------------------------------------------------------------
// The parameters' defaults and bounds
// ---------------------------------------------------------------------------------------------

/// Coarse points Levenberg-Marquardt starts from (at most; only the distinct ones within
/// [`START_RATIO`] of the closest are searched). More starts cost more searches and reach more
/// basins. Chosen on the comparison's unseen views with [`DEFAULT_PER_CELL`]: 8 starts of 4 points
/// per knot interval took pot's clean error from 0.82 degrees (3 starts of 2) to 0.46
/// (2026-11-21). Two-parameter models reported on a lattice and turntables no longer take this
/// path (the coarse tree, the lattice search).
pub(crate) const DEFAULT_STARTS: usize = 8;

/// Coarse points per knot interval along each axis (the scan's grid): denser starts land in the
/// right basin more often and cost a longer scan. Chosen with [`DEFAULT_STARTS`] (see there).
pub(crate) const DEFAULT_PER_CELL: usize = 4;

/// The reporting lattice (degrees): the eigenspace's manifold step, so that both report on the
/// same poses (the paper's 0.5 degrees). Not tuned.
pub(crate) const DEFAULT_RESOLUTION: f64 = 0.5;

/// The most starts and points per cell a model accepts: bounds on a query's and a model's cost,
/// far above the defaults. Not tuned.
pub(crate) const MAX_STARTS: usize = 64;
/// See [`MAX_STARTS`].
pub(crate) const MAX_PER_CELL: usize = 16;

// ---------------------------------------------------------------------------------------------
// The automatic choices on held-out training views
// ---------------------------------------------------------------------------------------------

/// The numbers of eigenimages L the weighted search is scored with (those within each fold's
/// rank and [`QUERY_OVERHEAD_ROWS`]' bound): the eigenspace's 20 and steps of 4 below it. A finer
/// list costs a model fit per fold and candidate. Not tuned.
pub(crate) const CANDIDATES: &[usize] = &[8, 12, 16, 20];

/// Eigenimages of each fold's PCA in the choice of L. Every candidate is at most 20, and each
/// coordinate's interpolation error is its own, so past 20 this costs fitting time only. Not
/// tuned.
pub(crate) const MAX_AUTO_COMPONENTS: usize = 40;

/// L when no axis has enough knots to hold views out: the eigenspace's default (Murase & Nayar
/// used 8 to 20). Not tuned.
pub(crate) const FALLBACK_COMPONENTS: usize = 20;


/// The most eigenimages the noisy match and the plain (unweighted) metric use: the eigenspace's
/// L, so that no automatic choice projects a query on more rows than the eigenspace does. Not
/// tuned.
pub(crate) const NOISE_COMPONENTS: usize = 20;

/// A query's work besides its product with the eigenimages, in rows of that product on the image
/// as given (the mean's row for the weighted metric's residual, the pixel-noise pass, the
/// search): L is chosen only among candidates with L + this under the eigenspace's
/// [`NOISE_COMPONENTS`] b^2 rows (b the binning factor), so that a query costs less than the
/// eigenspace's. From one `perf` profile of COIL-9's unbinned 8-bit queries (plain metric, 16
/// rows; 2026-11-23), samples over one row's: the noise pass 1.3, the lattice search 1.0, with
/// the mean's row 3.3, rounded up. With 16 rows allowed unbinned, COIL-9's queries had timed at
/// 0.90-1.04 of the eigenspace's over nine runs; with 12, at most 0.92 over five.
pub(crate) const QUERY_OVERHEAD_ROWS: usize = 4;

/// The binning factors scored: each halving of the resolution up to a quarter (an image must
/// keep at least 3 x 3 pixels). A factor of 8 was never tried. Not tuned.
pub(crate) const BIN_CANDIDATES: &[usize] = &[1, 2, 4];

/// The weights' floor, relative to the mean interpolation variance: w_l = 1 / (sigma_l^2 +
/// floor + nu). Without it a coordinate the held-out knots happened to interpolate almost
/// exactly would be trusted without bound; a larger floor flattens the weights towards the plain
/// metric. Not tuned (1% since the first version, 2026-11-21).
pub(crate) const WEIGHT_FLOOR: f64 = 0.01;

/// The uniform noise amplitudes (fractions of full brightness, clipped to [0, 1]) simulated on
/// held-out training views to choose the noisy match, and the smallest of them to set the noise
/// threshold: the paper's +-5% and +-10% (its Fig. 4), the levels the comparison queries with.
pub(crate) const NOISE_LEVELS: &[f64] = &[0.05, 0.1];

/// Seed of that simulated noise: any value; fixed so that a fit is reproducible.
pub(crate) const NOISE_SEED: u64 = 0x5e1ec7;

/// Training images given simulated noise at once when the threshold is measured (block b takes
/// the seed [`NOISE_SEED`] + b): bounds the memory of the noisy copies. Any value; it fixes which
/// draws each image gets.
pub(crate) const NOISE_BLOCK: usize = 64;

// ---------------------------------------------------------------------------------------------
// The noisy match
// ---------------------------------------------------------------------------------------------

/// The amplitude at which clipped noise's mean shift is taken as the offset direction g
/// ([`super::noisy::clip_bias_shape`]): its scale is solved per pose, but its shape (how far up
/// from black the brightening reaches) depends on the amplitude. The larger of [`NOISE_LEVELS`].
/// Not tuned.
pub(crate) const BIAS_AMPLITUDE: f32 = 0.1;

/// Where the staged pixel-noise estimate stops, relative to the model's noise threshold: a query
/// whose estimate from the first quarter of the sampled rows is under this fraction of the
/// threshold is clean without the rest. Lower stops fewer clean queries early; higher risks
/// stopping a noisy one (the whole estimate decides every query that goes on). Chosen by a numpy
/// replica of the 8-bit estimate on the comparison's images (every 4th rendered view, all of
/// COIL-20's, clean and under simulated +-5% and +-10% noise; 2026-11-22): the first quarter of a
/// noisy image came to at least 1.06 times the threshold, so a half leaves a margin of 2; it
/// stops 88% of COIL-20's clean views, at least 92% on 18 of the 25 objects, the least COIL-17's
/// 53%.
pub(crate) const NOISE_EARLY: f64 = 0.5;

/// The noisy tree's second start: the nearest point of another basin is climbed too when within
/// this ratio of the nearest point's squared distance (a nearly symmetric object's views a half
/// turn apart). Chosen on the comparison's unseen views, where twin's errors at +-5% and +-10%
/// were 19.7 / 25.1 degrees with the first start alone and 12.3 / 16.5 with the second
/// (2026-11-22); other ratios were not tried.
pub(crate) const SECOND_BASIN_RATIO: f32 = 2.0;

/// How far apart, in knot intervals (the widest along the axis), a second start must lie from
/// the first to count as another basin. Chosen with [`SECOND_BASIN_RATIO`]; not tuned.
pub(crate) const SECOND_BASIN_APART: f64 = 2.0;

/// The noisy scan's first pass takes the first half of the match's coordinates, from this many
/// on (fewer: no first pass). The fit's gain and offset absorb much of a few coordinates, so a
/// short first pass rules little out, and the pass costs a residual per point. From one day's
/// profiles at +-5% (2026-11-21): blocks summed in full with 4 of twin's 12 coordinates 67%, 6:
/// 18%, 8: 7.5%; the scan's time over the product kernel's, pot (20) 1.58 -> 1.23, cap (16)
/// 1.31 -> 1.10, duck (12) 1.61 -> 1.72 (slower).
pub(crate) const NOISE_SCAN_SPLIT_FROM: usize = 16;

/// Coarse points per block of the noisy scan's pruning: a block is summed in full when any of
/// its points' lower bounds is under the cut. Not tuned.
pub(crate) const NOISE_SCAN_BLOCK: usize = 64;

/// The noisy scan's cut is raised by this relative and absolute (times z.z) slack over the
/// rounding of its f32 products (about 1e-6 of z.z), so that no point within the cut in exact
/// arithmetic is ruled out. A margin, not tuned.
pub(crate) const NOISE_SCAN_SLACK: f64 = 1e-4;

/// The affine fit's two-term system (gain and offset) counts as singular below this ratio of its
/// determinant to its diagonal's product, and the fit falls back to the gain alone: an offset
/// direction nearly parallel to the surface point carries no information of its own. A numerical
/// guard, not tuned.
pub(crate) const DEGENERATE: f64 = 1e-9;

// ---------------------------------------------------------------------------------------------
// The clean search
// ---------------------------------------------------------------------------------------------

/// The starts of a local search are the coarse points within this ratio of the closest one's
/// distance (the same ratio bounds the scans' pruning, which keeps every such point exact). A
/// larger ratio searches more basins, at a search each. Not tuned.
pub(crate) const START_RATIO: f32 = 2.0;

/// The leading coordinates of the clean scan's bounding boxes (16 coarse points each), which rule
/// boxes out before their points are scored. From one day's `perf` of duck's 8-bit views
/// (2026-11-21), the scan's samples over the product kernel's: 4 coordinates 0.48, 8 0.38 and
/// 0.39, 12 0.43 and 0.44.
pub(crate) const BOX_SPLIT: usize = 8;

/// [`crate::manifold::tuning::STEP_TOL`] for the noisy match, whose iteration converges only linearly (Kaufman's Jacobian
/// leaves out part of the gain's and offset's dependence on the pose). Chosen on the
/// comparison's unseen views (2026-11-21): against 0.01 a third fewer Jacobian evaluations (twin
/// +-5%: 12.4 -> 8.3 a query), the errors moving by -0.001 to +0.37 degrees (twin +-10% 16.52
/// -> 16.89); 0.1 took twin +-5% to 14.03, near the eigenspace's 14.43.
pub(crate) const AFFINE_STEP_TOL: f64 = 5e-2;

/// Most lattice poses of a one-parameter model searched exactly ([`super::search::lattice`]:
/// 720 at 0.5 degrees on a turntable): its cost grows with the lattice, the local search's does
/// not. The crossover was not measured.
pub(crate) const MAX_LATTICE: usize = 16_384;

/// Most intervals of an even lattice the pruned lattice search evaluates; with more left it
/// scans every pose (a query with very unequal weights bounds little). On COIL-20's f32 and 8-bit
/// views (2,880 searches) 2,872 left at most 8 of the 36 intervals. From one day's `perf` of
/// COIL-5's 8-bit queries (2026-11-22): the search's samples 579-659 -> 377-442, the eigenspace's
/// k-d tree 272-307.
pub(crate) const PRUNE_MAX: usize = 8;

/// The coarse tree's lattice, in reporting steps: the tree holds the surface on the lattice of
/// twice the reporting step, and the climb on the reporting lattice takes it from there. A
/// coarser tree is smaller and leaves the climb more steps. Chosen against the coarse scan (not
/// against other factors) on the comparison's unseen views (2026-11-22): twin clean 8.79 ->
/// 6.86 degrees, duck 0.047 -> 0.044, cap 0.104 -> 0.101, pot 0.463 -> 0.464, column 2.575 ->
/// 2.577.
pub(crate) const TREE_STEP: f64 = 2.0;

/// Most poses of a coarse tree (2^20, with L coordinates each): a bound on the model's memory,
/// past which the coarse scan and the local search serve. Not tuned.
pub(crate) const MAX_TREE_POSES: usize = 1 << 20;

// ---------------------------------------------------------------------------------------------
// A batch's sub-chunks (cache sizes)
// ---------------------------------------------------------------------------------------------

/// 8-bit queries per sub-chunk of the projection: few enough that their images (19.2 KB each at
/// 160 x 120) are still in the L2 cache when the pixel-noise pass reads them after the products,
/// in whole register blocks of both 8-bit kernels. From one day's profile (2026-11-21): with the
/// task's 192, that pass read them from memory, 2 us of a 17 us query.
pub(crate) const NOISE_SUB_U8: usize = 8 * crate::kernels::dot_u8::BATCH_IMAGES;

/// f32 queries per sub-chunk (77 KB each at 160 x 120), for the same reason, when a task's
/// queries come to more than [`NOISE_SUB_F32_BYTES`]. One day's timing (2026-11-21), with the
/// sub-chunks of [`NOISE_SUB_U8`]: duck on 2 threads, 15.7 -> 11.7 us a query.
pub(crate) const NOISE_SUB_F32: usize = 16;

/// Up to this many bytes a task's f32 queries go as one product: the product packs queries in
/// blocks of 32 rows, so COIL's 72 views on one thread (tasks of 18) split 16 + 2 packed twice
/// as much as the eigenspace's one product; and 18 COIL images (1.2 MB) stay in the 2 MB L2
/// cache anyway. One day's profile and timing (2026-11-22): COIL-5, refined over eigenspace time
/// 1.22-1.29 -> 1.03-1.05.
pub(crate) const NOISE_SUB_F32_BYTES: usize = 5 << 18;

/// Binned 8-bit queries per sub-chunk of the 16-bit products: their block sums (9.6 KB each at
/// 160 x 120 by 2) are still in the L2 cache for the products (a task's 192 held 1.8 MB), in
/// whole register blocks. Chosen from the cache sizes (2026-11-23); not timed against others.
pub(crate) const BIN_SUB_U8: usize = 4 * crate::kernels::dot_w::BLOCK;

const _: () = assert!(NOISE_SUB_U8.is_multiple_of(crate::kernels::dot_q::GROUP * crate::kernels::dot_q::BLOCK));

// ---------------------------------------------------------------------------------------------
// The second look's search in another basin
// ---------------------------------------------------------------------------------------------

/// The lattice (degrees) a query's pose climbs on in another basin (`second_look`) when
/// the model reports continuous poses (`resolution` 0): the default reporting lattice. Not tuned.
pub(crate) const HYPOTHESIS_STEP: f64 = DEFAULT_RESOLUTION;

// ---------------------------------------------------------------------------------------------
// What a fit costs in memory (the memory plan's estimate, `crate::memory`, whose documentation
// tables the measurements)
// ---------------------------------------------------------------------------------------------

/// The method's working copies at the images' full size, in bytes per training image and
/// feature (besides the f32 images themselves): the held-out views as given for the noisy
/// match, their copies under two levels of simulated noise, the fold's own views. Measured
/// with [`BINNED_BYTES`] on 1,440 images of 160 x 120 fitted with bin 1 (599 MiB) and bin 4
/// (421 MiB): 5.15, rounded up.
pub(crate) const FULL_BYTES: f64 = 5.5;

/// The method's working copies at the binned size, in bytes per training image and binned
/// feature: the held-out folds' views, their f64 transposed copy in each fold's PCA, the final
/// PCA's copy. Measured with [`FULL_BYTES`] (see there): 7.45, rounded up.
pub(crate) const BINNED_BYTES: f64 = 7.5;

/// Bytes per N^2: the final PCA's Gram matrix and eigendecomposition (as
/// `crate::manifold::tuning::EVD_SYSTEM_BYTES`) and 4 more, because the peak of one and the same
/// fit varies between runs (its held-out fits run side by side, two at a time, and free at
/// different moments): 322 to 389 MiB over five runs on 2,880 images of 16 x 12, where 36 N^2
/// gave 398 MiB.
pub(crate) const SYSTEM_BYTES: f64 = 40.0;

/// The structures per point of the reporting lattice (the surface's lattice search, its coarse
/// tree, the noisy match's tables, for each candidate fitted on held-out views, two interpolants
/// at a time). Measured: 84 MiB above the PCA on 2,880 images of 16 x 12 over a lattice of
/// 43,920 points (about 2 KiB a point). A model reporting continuous poses (`resolution` 0) is
/// counted on the lattice of [`DEFAULT_RESOLUTION`].
pub(crate) const LATTICE_BYTES: f64 = 2048.0;

// ---------------------------------------------------------------------------------------------
// Knots between the training rolls
// ---------------------------------------------------------------------------------------------

/// The parts each knot interval of a camera roll is split into by turned training views
/// (`manifold::roll`): more parts hold the surface to the images at more rolls, and each adds
/// a knot per training view along the other axes (the model's knots and their slopes, the
/// fitting's turns and projections) and, past 2, denser search starts along the roll. Chosen on
/// the three-parameter bench's unseen views (`bench/three_params.py`, the duck at 160 x 120,
/// training rolls 20 degrees apart, the unseen rolls halfway between them and on them;
/// 2026-11-29): unseen mean 2.15 degrees with none, 0.56 with 2, 0.62 with 3, 0.60 with 4; with
/// 2 the model file 2.41 -> 2.46 MB, training +1.2 s of CPU on 11.6, the query unchanged (the
/// same starts).
pub(crate) const ROLL_SPLIT: usize = 2;

/// The largest roll split a model file may record: a bound on a model's knots, far above
/// [`ROLL_SPLIT`]. Not tuned.
pub(crate) const MAX_ROLL_SPLIT: usize = 16;

/// The most [`RefinedSettings::roll_turn_error`](super::RefinedSettings::roll_turn_error) at
/// which a camera roll's intervals are split by default: below it, turning a training view to
/// the next training roll reproduces the view there well enough to stand for the views between.
/// Not tuned: set between the rendered duck's 0.005 (160 x 120) and 0.025 (48 x 36), whose roll
/// turns the image, and the test images' `roll` that moves a band instead (above it, as its test
/// asserts).
pub(crate) const ROLL_TURN_MAX: f64 = 0.25;
