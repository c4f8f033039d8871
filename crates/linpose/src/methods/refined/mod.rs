//! The refined eigenspace (beyond the paper): Murase & Nayar's eigenspace and spline manifold,
//! searched continuously instead of on a dense grid of resampled points.
//!
//! 1. Training is the eigenspace's: unit-energy images, the mean subtracted, the top L
//!    eigenimages from the N x N Gram matrix ([`crate::methods::eigenspace::pca`]).
//! 2. The manifold is the same tensor-product cubic spline through the training views'
//!    coordinates (periodic along a circular axis), but it is kept as the spline itself
//!    ([`surface`]): its N knots with their slopes, not N_dense resampled points. The eigenspace
//!    resampled every 0.5 degrees stores 65,520 x L numbers on the paper's grid; this stores
//!    4 x 222 x L, so the model is a fraction of the eigenspace's size. Or, chosen on held-out
//!    views, the local cubic through the same knots ([`Interpolant::Local`]: each slope from the
//!    knot's two neighbours alone, Catmull-Rom on even knots), which does not ring where a
//!    coordinate changes abruptly between two views (chosen on 31 of the comparison's 35 rows).
//! 3. A query is projected as in the eigenspace; the closest of a coarse set of surface points
//!    (`per_cell` per knot interval along each axis) give the starts, and from each
//!    Levenberg-Marquardt minimises the distance to the surface in the pose itself. The pose is
//!    continuous: no 0.5-degree quantisation, and a query costs the projection (L M) plus a few
//!    thousand operations, against a k-d tree over 65,520 points for the eigenspace.
//!
//! 4. The distance is weighted per coordinate, w_l = 1 / (sigma_l^2 + floor + nu): sigma_l^2 is
//!    coordinate l's interpolation error, measured on held-out training knots (the spline through
//!    the other knots, evaluated at theirs), the floor 1% of the mean, and nu the query's own
//!    noise per coordinate, estimated from its energy off the eigenspace beyond the training
//!    views' ((M - L) nu for isotropic noise). Coordinates the spline interpolates badly count
//!    less.
//!
//!    That nu proved far too small for the paper's noise (uniform +-a, clipped to [0, 255]: on a
//!    black background it brightens by about a/4, a silhouette-shaped change that lands in the
//!    leading, most trusted coordinates). So a noisy query is detected from the image itself:
//!    [`pixel_noise`](crate::pixel_noise::pixel_noise) (Immerkaer's estimate, which ignores smooth shading) above a threshold
//!    means noise: the geometric mean of the largest value of a clean training image and the
//!    least of the training images under simulated +-5% noise ([`select::noise_threshold`];
//!    the largest clean value itself would let about one clean query in N + 1 through, as a
//!    fresh view is as likely as any training view to be the noisiest; on the paper's grid and
//!    COIL-20 every +-5% / +-10% query is detected and no clean one). Such a query takes the
//!    affine match: its coordinates z (mean added back) against alpha (f(t) + c) + beta g(t),
//!    with the gain alpha (the noise's extra energy shrinks a unit-energy query) and the offset
//!    beta solved per pose, g the surface through the knots' [`clip_bias_shape`] (what clipped noise
//!    adds on average, projected). Its eigenimages (8-20) and whether it weights coordinates by
//!    1 / (sigma_l^2 + floor + nu), nu the query's own pixel noise per coordinate, are chosen on
//!    held-out training views under simulated noise ([`select::choose_noise`]). The eigenspace
//!    matches noisy queries as clean ones: at +-10% on the paper's grid this halves to thirds
//!    its error (cap 1.09 -> 0.32 degrees, twin 23.7 -> 16.4, column 5.58 -> 2.88).
//! 5. The pose is reported on the eigenspace's 0.5-degree lattice (the closest lattice point
//!    around the continuous estimate), or continuous with `resolution(0.0)`. With one pose
//!    parameter (a turntable) a clean query skips the coarse scan and the local search: the
//!    distance to the spline curve is a polynomial in the pose on each knot interval, and
//!    [`search::lattice::Lattice`] finds its least over every lattice pose exactly (on COIL-20 the same
//!    estimates as the local search; perf of obj5's 8-bit queries on one thread, the search's
//!    samples over the product kernel's: 0.12, the k-d tree of the eigenspace's 0.07). With two or
//!    more, a clean query reported on a lattice skips them too (`CoarseTree`): the nearest of
//!    the surface's points on the lattice of twice the step (a k-d tree in the coordinates, which
//!    carry the weights of nu = 0), then [`Surface::climb`] on the reporting lattice with the
//!    query's own weights. The local search from coarse starts had ended in a worse basin on
//!    some views: twin clean 8.79 -> 6.86 degrees, duck 0.047 -> 0.044, cap 0.104 -> 0.101,
//!    pot 0.463 -> 0.464, column 2.575 -> 2.577 (BENCHMARKS.md). A noisy query there skips
//!    the noisy coarse scan and Levenberg-Marquardt as well (`NoisyTree`): the nearest
//!    point of a k-d tree over the same lattice in which the affine match's gain and mean offset
//!    are divided out (each point off the offset's mean direction, at unit length), and the
//!    nearest of another basin when within twice its distance; from each [`Surface::climb_pair`]
//!    walks the reporting lattice on the affine match itself. On the paper's grid at +-5% and
//!    +-10% this gave 0.17 / 0.44 (duck), 0.18 / 0.31 (cap), 0.49 / 0.51 (pot), 2.51 / 2.65
//!    (column) and 12.3 / 16.5 (twin, where the second basin, a half turn away, matters: 19.7 /
//!    25.1 without it) against the scan's 0.18 / 0.42, 0.19 / 0.32, 0.49 / 0.51, 2.79 / 2.90
//!    and 13.2 / 16.9.
//!
//! Every hyper-parameter is chosen from the training data alone ([`select`]): the number of
//! eigenimages L (among 8, 12, 16, 20, and at most 12 on images as given, so a query, its
//! product and its other work, costs less than the eigenspace's product) by the pose error of held-out training views, with the
//! manifold built without them (every other knot along each axis held out in turn, the odd
//! ones, then the even ones), and the weights as above. The same held-out views also score the
//! plain metric (unweighted, the eigenspace's, in 20 coordinates, 12 on images as given); when
//! it beats every weighted L, the model uses it for every query (on COIL-20 the weighted metric
//! wins by far on some objects, obj6: 0.39 against 5.38 degrees, and loses on others, obj20:
//! 2.29 against 1.76). They score every candidate with either interpolant ([`INTERPOLANTS`], on
//! each fold's one eigenspace), and the interpolant of the least error wins (the spline on a
//! tie; `interpolant(i)`, `linpose train --interpolant spline|local`, fixes it).
//!
//! The model keeps only the eigenimages its queries use: the weighted search's L and the noisy
//! match's (the eigenspace keeps 20), so the basis, the surface and each query's projection
//! shrink with them (duck: 12 of 20). A query projects on the rows its route uses alone: a
//! clean one on the search's L_s and the mean (for its residual), a noisy one on the L kept,
//! without the mean. A model that bins routes each query on the image as given before its products,
//! so each takes one pass over its route's rows; one that does not routes after the clean
//! rows' pass, and only a query sent to the noisy match takes its eigenimages past L_s (COIL-19:
//! 16 against 12) in a second. The clean search's nu comes from the residual off its own L_s
//! coordinates, the residual its choice was scored with.
//!
//! Cost of a query: the projection on its route's eigenimages (and a clean one's on the mean,
//! whose product gives the residual), by the eigenspace's own kernels (one f32 product per
//! sub-chunk of a batch and route, the mean's product summed with the energy,
//! [`crate::linalg::energy_and_dot`]; for 8-bit images [`crate::kernels::dot_u8::dots_batch`],
//! the mean a row of the product and the energy summed exactly in the same pass), in sub-chunks small enough that the images are still cached for the sampled pixel-noise
//! pass ([`pixel_variance`](crate::pixel_noise::pixel_variance), [`pixel_variance_u8`](crate::pixel_noise::pixel_variance_u8_in); staged for routing: a query whose estimate
//! from a quarter of the sampled rows is under half the threshold is clean without the rest,
//! see `NOISE_EARLY`); a scan of the coarse points in register
//! blocks ([`crate::kernels::scan`]) that rules most of them out on the leading coordinates first
//! (the distance to bounding boxes of 16 coarse points in the first 8 coordinates, or for a
//! noisy query the affine fit on the first half of 16 or more coordinates, bounds the whole from
//! below; every point within twice the least is still scored exactly); and Levenberg-Marquardt
//! from the distinct closest ones only (a start next to a closer one on the coarse grid shares
//! its basin), the noisy match evaluating its two surfaces together
//! ([`surface::Surface::eval_pair`]). That scan and search serve only where no lattice search
//! or tree does: a resolution of 0 or a manifold too large for them. On a turntable the lattice
//! search replaces both; with more parameters the two trees give the starts and the climb
//! ([`surface::Surface::climb_pair`]) evaluates 3 x 3 lattice points at a time (after a move
//! only those the last block did not hold), the noisy match's residual and the clean distance
//! summed 8 coordinates a vector.
//! bench/beyond_compare.py measures it against the eigenspace; BENCHMARKS.md holds the figures.
//!
//! Binning (`auto_bin()`, the default, or `bin(b)`; `linpose train --bin auto|B`): the model
//! takes images as given and bins them by a box filter ([`crate::binning`]) before everything
//! above, in training and for each query, by the factor among [`BIN_CANDIDATES`] (1, 2, 4)
//! chosen by the one-standard-error rule ([`select::coarsest_within`]): the coarsest whose
//! held-out error (the choice of L run on each one's images) is within one standard error of
//! the least. The spline through binned
//! views interpolates better (their fine detail, stripes and edges, aliases between training
//! views), independent pixel noise's variance is divided by b^2, and every product costs b^2
//! times less. Simulated noise (the noisy match's choice, the offset direction) is added to the
//! images as given and then binned, as a query's noise would be. A query's pixel noise is
//! measured on the image as given, against the threshold of the training images as given: on
//! binned images the estimate no longer tells noise from detail (least +-5% value over largest
//! clean one on duck's training views: 53.9 as given, 4.1 by 2, 0.69 by 4). An 8-bit query's
//! block sums are exact integers of at most 255 b^2, multiplied as 16-bit values
//! ([`crate::kernels::dot_w`]: `vpdpwssd`, 32 sums an instruction against the weights' 16-bit
//! fixed point) where AVX-512 VNNI runs, else as two planes of 8-bit digits through the 8-bit
//! products (on COIL-17 by 2, 8-bit queries over the eigenspace's time went 1.20 -> 0.62). On
//! the comparison's 35 rows the choice took 4 on 30 and 2 on 5, and with the choice of the
//! interpolant met the peer's error on all 35; with the spline alone it missed on COIL-11
//! (0.375 against 0.347). By the least held-out error alone (spline only, L up to 20 as
//! given) it had taken 4 on 17,
//! 2 on 8 and 1 on 10, and missed the peer on COIL-1 (0.500 against 0.472), with 5 rows slower
//! than the eigenspace: BENCHMARKS.md.
//!
//! Trained in f64, served in f32: basis, mean and knot slopes are stored as f32, the projection is
//! an f32 product, the iteration runs in f64 on the f32 numbers.

mod fit;
mod method;
mod model;
mod noisy;
mod params;
mod projection;
mod query;
mod scratch;
mod search;
mod tuning;
pub(crate) mod select;
pub(crate) mod surface;

pub use method::METHOD;
pub use model::RefinedModel;
pub use params::{RefinedParams, RefinedSettings};
pub use surface::{Interpolant, INTERPOLANTS};

pub(crate) use fit::Views;

#[cfg(test)]
mod tests;
