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
//!    [`pixel_noise`] (Immerkaer's estimate, which ignores smooth shading) above a threshold
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
//!    [`lattice::Lattice`] finds its least over every lattice pose exactly (on COIL-20 the same
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
//! pass ([`pixel_variance`], [`pixel_variance_u8`]; staged for routing: a query whose estimate
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

pub mod lattice;
mod method;
pub mod select;
pub mod surface;

use crate::binning::Binning;
use crate::dataset::Dataset;
use crate::kernels::{dot_q, dot_u8, dot_w, AlignedF32, Level};
use crate::methods::eigenspace::manifold::Grid;
use crate::methods::eigenspace::pca::{self, Dimension};
use crate::model::{batch_len, Estimator, Method, ModelMeta, PoseModel, Storage, Tensor, TensorSet};
use crate::pose::wrap_positive;
use crate::{Error, Result};
use faer::linalg::matmul::matmul;
use faer::{Accum, MatMut, MatRef, Par};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use surface::Surface;
pub use surface::{Interpolant, INTERPOLANTS};

pub use method::METHOD;

/// Most eigenimages considered by the automatic choice.
pub const MAX_AUTO_COMPONENTS: usize = 40;

/// Parameters of the refined eigenspace. The default chooses L from the training data, and
/// searches from the 8 best of 4 coarse points per knot interval along each axis (fewer starts
/// left the pot's search in the wrong region: 0.82 degrees clean with 3 of 2, 0.46 with 8 of 4).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct RefinedParams {
    components: Option<usize>,
    starts: usize,
    per_cell: usize,
    weighted: bool,
    resolution: f64,
    /// Images binned by this factor before anything else ([`crate::binning`]; 1: as given;
    /// None: chosen from the training data, [`BIN_CANDIDATES`]).
    #[serde(default = "bin_one")]
    bin: Option<usize>,
    /// How the surface interpolates between knots (None: chosen from the training data among
    /// [`INTERPOLANTS`]).
    #[serde(default = "spline_interpolant")]
    interpolant: Option<Interpolant>,
}

/// The interpolant asked for by models written before it existed: the spline.
fn spline_interpolant() -> Option<Interpolant> {
    Some(Interpolant::Spline)
}

/// The binning factor asked for by models written before it existed: none.
fn bin_one() -> Option<usize> {
    Some(1)
}

/// The binning factor of models written before it existed: 1.
fn one() -> usize {
    1
}

/// The binning factors the automatic choice scores (those that leave an image of at least 3 x 3
/// pixels): each halving of the resolution up to a quarter.
pub const BIN_CANDIDATES: &[usize] = &[1, 2, 4];

/// The weight floor, relative to the mean interpolation variance.
pub const WEIGHT_FLOOR: f64 = 0.01;

impl Default for RefinedParams {
    fn default() -> Self {
        RefinedParams { components: None, starts: 8, per_cell: 4, weighted: true, resolution: 0.5, bin: None, interpolant: None }
    }
}

impl RefinedParams {
    /// Keep `l` eigenimages (capped at N - 1 and the usable rank) instead of choosing L.
    pub fn components(mut self, l: usize) -> Self {
        self.components = Some(l);
        self
    }

    /// Choose L from the training data (the default).
    pub fn auto_components(mut self) -> Self {
        self.components = None;
        self
    }

    /// Refine from this many of the closest coarse points.
    pub fn starts(mut self, k: usize) -> Self {
        self.starts = k;
        self
    }

    /// Coarse points per knot interval along each axis.
    pub fn per_cell(mut self, k: usize) -> Self {
        self.per_cell = k;
        self
    }

    /// Weight each coordinate by the inverse of its interpolation error (the default).
    pub fn weighted(mut self, yes: bool) -> Self {
        self.weighted = yes;
        self
    }

    /// Report poses on the lattice of this many degrees (anchored at the first training value
    /// of each parameter), as the eigenspace's manifold resampled every 0.5 degrees does: the
    /// closest lattice point around the continuous estimate. 0 reports the continuous estimate.
    pub fn resolution(mut self, degrees: f64) -> Self {
        self.resolution = degrees;
        self
    }

    /// Bin the images by `factor` (each pixel the mean of a factor x factor block,
    /// [`crate::binning`]) before fitting and before each query; 1 keeps them as given. Noise is
    /// simulated on the images as given, then binned, as a query's would be.
    pub fn bin(mut self, factor: usize) -> Self {
        self.bin = Some(factor);
        self
    }

    /// Choose the binning factor from the training data (the default): among
    /// [`BIN_CANDIDATES`], the coarsest whose held-out error ([`select::choose`]) is within one
    /// standard error of the least ([`select::coarsest_within`]: cheaper
    /// queries and a smaller model where the training views cannot tell the factors apart).
    pub fn auto_bin(mut self) -> Self {
        self.bin = None;
        self
    }

    /// Interpolate the surface between knots by `interpolant` instead of choosing it.
    pub fn interpolant(mut self, interpolant: Interpolant) -> Self {
        self.interpolant = Some(interpolant);
        self
    }

    /// Choose the interpolant from the training data (the default): with L and the metric, by
    /// the same held-out views ([`select::choose`]), the spline on a tie.
    pub fn auto_interpolant(mut self) -> Self {
        self.interpolant = None;
        self
    }

    /// The interpolant asked for (None: chosen from the data).
    pub fn fixed_interpolant(&self) -> Option<Interpolant> {
        self.interpolant
    }

    /// The binning factor asked for (None: chosen from the data).
    pub fn fixed_bin(&self) -> Option<usize> {
        self.bin
    }

    /// The fixed L asked for (None: chosen from the data).
    pub fn fixed_components(&self) -> Option<usize> {
        self.components
    }

    fn validate(&self) -> Result<()> {
        if self.components == Some(0) {
            return Err(Error::invalid("components", 0, "at least one eigenimage is needed"));
        }
        if !(self.resolution.is_finite() && self.resolution >= 0.0) {
            return Err(Error::invalid("resolution", self.resolution, "must be a number of degrees >= 0"));
        }
        if !(1..=64).contains(&self.starts) {
            return Err(Error::invalid("starts", self.starts, "must be 1 to 64"));
        }
        if !(1..=16).contains(&self.per_cell) {
            return Err(Error::invalid("per cell", self.per_cell, "must be 1 to 16"));
        }
        if let Some(b) = self.bin.filter(|b| !(1..=crate::binning::MAX_FACTOR).contains(b)) {
            return Err(Error::invalid("bin", b, format!("must be 1 to {}", crate::binning::MAX_FACTOR)));
        }
        Ok(())
    }
}

/// What a fitted model records in [`ModelMeta::settings`].
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RefinedSettings {
    /// The parameters as given.
    pub params: RefinedParams,
    /// The binning factor of every image the model takes (1: none).
    #[serde(default = "one")]
    pub bin: usize,
    /// The automatic choice of the binning factor: each candidate with its held-out error
    /// (degrees), as [`Self::selection`]'s least and [`Self::plain_error`] (empty when fixed).
    #[serde(default)]
    pub bin_selection: Vec<(usize, f64)>,
    /// The standard error of the least of [`Self::bin_selection`]'s errors: the coarsest factor
    /// within it of the least was chosen ([`select::coarsest_within`]; 0 when fixed, and in
    /// models written before it, which took the least).
    #[serde(default)]
    pub bin_tolerance: f64,
    /// How the surface interpolates between knots (the spline in models written before the
    /// choice existed).
    #[serde(default)]
    pub interpolant: Interpolant,
    /// The automatic choice of the interpolant: each candidate with its least held-out error
    /// (degrees) on the chosen binning factor's images (empty when fixed).
    #[serde(default)]
    pub interpolant_selection: Vec<(Interpolant, f64)>,
    /// Eigenimages kept, L.
    pub components: usize,
    /// Eigenimages of the weighted search of a clean query (the first ones; 0: all). The rest
    /// serve only noisy queries (the affine match, up to all L).
    #[serde(default)]
    pub search_components: usize,
    /// Fraction of the training energy (about the mean) they hold.
    pub energy_kept: f64,
    /// Knots along each pose parameter.
    pub knot_shape: Vec<usize>,
    /// The automatic choice of L: each candidate with the mean pose error (degrees) of the
    /// held-out training views (empty when L was fixed).
    pub selection: Vec<(usize, f64)>,
    /// The held-out error of the plain (unweighted) search in the first 20 coordinates, the
    /// eigenspace's metric; when below every weighted L's, the model uses it for every query
    /// (None when not scored).
    #[serde(default)]
    pub plain_error: Option<f64>,
    /// Each coordinate's mean squared interpolation error over held-out knots (empty when the
    /// coordinates are not weighted).
    #[serde(default)]
    pub interpolation_variance: Vec<f64>,
    /// The training images' mean squared distance from the eigenspace (unit energy, mean
    /// subtracted): the discarded eigenvalues over N. A query further off than this carries
    /// noise, estimated per query (see the module doc).
    #[serde(default)]
    pub residual_energy: f64,
    /// The noise threshold ([`select::noise_threshold`]): between the largest pixel-noise
    /// estimate ([`pixel_noise`]) of a training image and the smallest of the training images
    /// with simulated noise. A query above it is treated as noisy and takes the affine match (0:
    /// never).
    #[serde(default)]
    pub noise_threshold: f64,
    /// Eigenimages of the affine match of a noisy query (the first ones).
    #[serde(default)]
    pub noise_components: usize,
    /// Whether the noisy match weights each coordinate by 1 / (sigma_l^2 + floor + nu).
    #[serde(default)]
    pub noise_weighted: bool,
    /// Each of the L coordinates' interpolation variance (unscaled, as `interpolation_variance`,
    /// but for all L), which weights the noisy match (empty when no knots could be held out).
    #[serde(default)]
    pub coord_variance: Vec<f64>,
    /// The automatic choice of the noisy match: each candidate (L, weighted) with the mean pose
    /// error (degrees) of the held-out training views under simulated noise
    /// ([`select::NOISE_LEVELS`]).
    #[serde(default)]
    pub noise_selection: Vec<(usize, bool, f64)>,
}

impl RefinedSettings {
    /// Eigenimages of the weighted search.
    pub fn search(&self) -> usize {
        if self.search_components == 0 || self.search_components > self.components {
            self.components
        } else {
            self.search_components
        }
    }
}

/// The most eigenimages the noisy match's choice considers (the eigenspace's default L); the
/// model keeps only as many as the chosen matches use.
pub const NOISE_COMPONENTS: usize = 20;

impl Estimator for RefinedParams {
    type Model = RefinedModel;

    fn method(&self) -> &'static Method {
        &METHOD
    }

    fn fit(&self, full: &Dataset) -> Result<RefinedModel> {
        self.validate()?;
        // The held-out fits take the binned images as given (bin 1).
        let inner = RefinedParams { bin: Some(1), ..*self };
        // The binning factor (with its images, grid and choice of L when scored), fixed or the
        // coarsest candidate within one standard error of the least held-out error.
        let (mut bin_selection, mut bin_tolerance) = (Vec::new(), 0.0);
        let (binning, train, grid, chosen) = match self.bin {
            Some(b) => {
                let binning = Binning::new(full.spec(), b)?;
                let (train, grid) = binned_views(full, binning)?;
                (binning, train, grid, None)
            }
            None => {
                let mut scored = Vec::new();
                for &b in BIN_CANDIDATES {
                    let Ok(binning) = Binning::new(full.spec(), b) else { continue };
                    let (train, grid) = binned_views(full, binning)?;
                    let choice = select::choose(train.as_ref().unwrap_or(full), &grid, &inner, b)?;
                    bin_selection.push((b, choice.least));
                    scored.push((binning, train, grid, choice));
                }
                // The coarsest factor within one standard error of the least held-out error.
                let k;
                (k, bin_tolerance) = select::coarsest_within(&scored.iter().map(|s| (s.3.least, s.3.standard_error)).collect::<Vec<_>>());
                let (binning, train, grid, choice) = scored.swap_remove(k);
                (binning, train, grid, Some(choice))
            }
        };
        let train = train.as_ref().unwrap_or(full);
        let views = Views { full, binning };
        let space = train.space();
        // L and the interpolant, each fixed or chosen on the held-out views.
        let chosen = match chosen {
            None if self.components.is_none() || self.interpolant.is_none() => Some(select::choose(train, &grid, &inner, binning.factor())?),
            c => c,
        };
        let interpolant = self.interpolant.or(chosen.as_ref().map(|c| c.interpolant)).unwrap_or_default();
        let interpolant_selection = match (self.interpolant, &chosen) {
            (None, Some(c)) => c.by_interpolant.clone(),
            _ => Vec::new(),
        };
        let (l_max, selection, plain_error) = match (self.components, chosen) {
            (None, Some(c)) => (c.components, c.scored, c.plain),
            (l, _) => (l.unwrap_or(select::FALLBACK_COMPONENTS), Vec::new(), None),
        };
        // Everything fitted from here on interpolates as the model will.
        let inner = RefinedParams { interpolant: Some(interpolant), ..inner };
        // The plain metric wins when it scored better on the held-out views than every weighted L.
        let best_weighted = selection.iter().map(|s| s.1).fold(f64::INFINITY, f64::min);
        let plain = plain_error.is_some_and(|e| e < best_weighted);
        // Chosen automatically, no query's product costs as much as the eigenspace's.
        let below = if self.components.is_some() { NOISE_COMPONENTS } else { select::below_eigenspace(binning.factor()) };
        let (l_max, weighted) = if plain { (NOISE_COMPONENTS.min(below), false) } else { (l_max, self.weighted) };
        // The affine match of noisy queries may use up to the eigenspace's L = 20 coordinates
        // (within that bound): they are kept (unweighted) past the L of the weighted search.
        let l_store = if weighted { l_max.max(NOISE_COMPONENTS.min(below)) } else { l_max };
        let mut pca = pca::fit(train, Dimension::Fixed(l_store))?;
        let l_search = l_max.min(pca.dim());
        // The match of noisy queries, chosen on held-out views under simulated noise.
        let (noise_components, noise_weighted, noise_selection) = match select::choose_noise(train, views, &grid, &inner, pca.dim())? {
            Some(chosen) => chosen,
            None => (NOISE_COMPONENTS.min(pca.dim()), false, Vec::new()),
        };
        // Only the eigenimages some query uses are kept: the weighted search's and the noisy
        // match's. A query projects on no more (cheaper than the eigenspace's 20 when both
        // use fewer), and the clean search's residual is the one its choice was scored with.
        if weighted {
            pca.truncate(l_search.max(noise_components));
        }
        let l = pca.dim();
        // Each coordinate weighted by the inverse of its interpolation error (see the module
        // doc): basis and knots scaled by sqrt(w), so the search is Euclidean.
        let coord_variance = select::interpolation_variance(train, &grid, &pca.coords, l, interpolant)?;
        let sigma2 = if weighted { coord_variance.as_ref().map(|s| s[..l_search].to_vec()) } else { None };
        let scale = search_scale(sigma2.as_deref(), l_search, l);
        // The route measures a query's noise on the image as given: so is the threshold.
        let noise_threshold = select::noise_threshold(full)?.threshold;
        let mut knots = Vec::with_capacity(grid.sample_at.len() * l);
        for &i in &grid.sample_at {
            knots.extend(pca.coords[i * l..(i + 1) * l].iter().zip(&scale).map(|(&v, &w)| (v * w) as f32));
        }
        let mut basis = pca.basis.clone();
        let m = train.n_features();
        for (c, &w) in scale.iter().enumerate() {
            basis[c * m..(c + 1) * m].iter_mut().for_each(|v| *v *= w);
        }
        let background = background_knots(views, &grid.sample_at, &basis, l);
        let settings = RefinedSettings {
            params: *self,
            bin: binning.factor(),
            bin_selection,
            bin_tolerance,
            interpolant,
            interpolant_selection,
            components: l,
            search_components: l_search,
            energy_kept: pca.energy_kept(),
            knot_shape: grid.shape(),
            selection,
            plain_error,
            interpolation_variance: sigma2.unwrap_or_default(),
            residual_energy: pca.eigenvalues[l..].iter().map(|&v| v.max(0.0)).sum::<f64>() / train.len() as f64,
            noise_threshold,
            noise_components,
            noise_weighted: noise_weighted && coord_variance.is_some(),
            coord_variance: coord_variance.unwrap_or_default(),
            noise_selection,
        };
        let meta = ModelMeta {
            method: METHOD.name.into(),
            spec: full.spec(),
            space: space.clone(),
            train_poses: train.poses().to_vec(),
            settings: serde_json::Value::Null,
        };
        let to32 = |v: &[f64]| v.iter().map(|&x| x as f32).collect::<Vec<f32>>();
        RefinedModel::new(meta, settings, to32(&basis), to32(&pca.mean), knots, background, grid.axes)
    }
}

/// The training images binned by `binning` (None when it keeps them as given) and their grid.
fn binned_views(full: &Dataset, binning: Binning) -> Result<(Option<Dataset>, Grid)> {
    let binned = if binning.bins() { Some(Dataset::from_features(full.manifest().clone(), binning.spec(), binning.apply_all(full.features()))?) } else { None };
    let d = binned.as_ref().unwrap_or(full);
    let grid = Grid::new(d.space(), d.poses(), d.manifest().images(), d.manifest().root())?;
    Ok((binned, grid))
}

/// Reference amplitude of [`clip_bias_shape`].
pub const BIAS_AMPLITUDE: f32 = 0.1;

/// How uniform noise of +-a clipped to [0, 1] moves a pixel of value v on average, up to the
/// factor a / 4: E[clip(v + n)] - v = (a / 4) (1 - v / a)^2 for v < a (brightening, 1 on black),
/// minus the mirror image below white, 0 in between. At the reference a = [`BIAS_AMPLITUDE`] this
/// shape, projected, is the offset direction g of the noisy match: on a black background it is
/// the background's silhouette, which clipped noise brightens by a / 4.
pub fn clip_bias_shape(v: f32) -> f32 {
    let lo = (1.0 - v / BIAS_AMPLITUDE).max(0.0);
    let hi = (1.0 - (1.0 - v) / BIAS_AMPLITUDE).max(0.0);
    lo * lo - hi * hi
}

/// The offset direction of each knot: the training image's [`clip_bias_shape`] (of its pixels
/// as given, then binned: the bias of a binned pixel is the mean of its pixels' biases) projected
/// on `basis` (L rows of the binned M, as stored), in the knots' order.
pub(crate) fn background_knots(views: Views<'_>, sample_at: &[usize], basis: &[f64], l: usize) -> Vec<f32> {
    let m = views.binning.spec().features();
    let per: Vec<Vec<f32>> = sample_at
        .par_iter()
        .map_init(Vec::new, |acc, &i| {
            let shape: Vec<f32> = views.full.row(i).iter().map(|&v| clip_bias_shape(v)).collect();
            let b: Vec<f64> = if views.binning.bins() {
                let mut out = vec![0.0; m];
                views.binning.apply(&shape, &mut out, acc);
                out.iter().map(|&v| v as f64).collect()
            } else {
                shape.iter().map(|&v| v as f64).collect()
            };
            (0..l).map(|c| basis[c * m..(c + 1) * m].iter().zip(&b).map(|(u, v)| u * v).sum::<f64>() as f32).collect()
        })
        .collect();
    per.concat()
}

/// The training views as given and the binning the model applies to them: what simulated noise
/// is added to (then binned, as a query's noise would be).
#[derive(Debug, Clone, Copy)]
pub struct Views<'a> {
    /// The training views as given.
    pub full: &'a Dataset,
    /// The binning of the model.
    pub binning: Binning,
}

/// A fitted refined eigenspace: L eigenimages, the mean image, the spline surface through the
/// training views' coordinates and the coarse start points, in f32.
#[derive(Debug, Clone)]
pub struct RefinedModel {
    meta: ModelMeta,
    settings: RefinedSettings,
    /// The mean image, then the L eigenimages (rows of M, scaled): one matrix, so that the
    /// rows a query's route takes are one range of it ([`Self::clean_rows`]: the mean's, for
    /// the residual, and the clean search's L_s; [`Self::noisy_rows`]: the noisy match's L;
    /// [`Self::extra_range`]: the L past L_s), each one pass; 64-byte aligned, so the 8-bit
    /// products read it in place.
    rows: AlignedF32,
    /// The clean rows in 16-bit fixed point, for 8-bit queries where [`dot_q::fast`] (derived,
    /// not stored in the file); none when `words` serves.
    quant: dot_q::FastRows,
    /// The extra rows ([`Self::extra_range`]) as `quant`.
    quant_x: dot_q::FastRows,
    /// For a model that bins, where [`dot_q::fast`]: the clean and noisy rows in 16-bit fixed
    /// point for the 16-bit block sums of 8-bit queries ([`dot_w`]; derived, not stored in the
    /// file).
    words: Option<Words>,
    /// The training views' mean residual energy off the clean search's L_s coordinates (the
    /// stored `residual_energy`, off all L, plus the knots' mean square in coordinates L_s..L):
    /// the level of a clean query's residual that means no noise.
    clean_residual_energy: f64,
    /// M, the pixels of an image (binned).
    m: usize,
    /// The binning of the images the model takes ([`ModelMeta::spec`]) into those it works on.
    binning: Binning,
    mean_proj: Vec<f32>,
    /// ||mean||^2.
    mean_sq: f64,
    /// 1 / w_l: each coordinate's interpolation variance plus the floor (ones when unweighted).
    inv_weight: Vec<f64>,
    knots: Vec<f32>,
    /// The offset direction g at each knot (N x L) and its surface.
    background: Vec<f32>,
    bg_surface: Surface,
    axes: Vec<Vec<f64>>,
    surface: Surface,
    /// Coarse surface points, coordinate-major (L x n: coordinate l of every point, then l + 1),
    /// so the scan over them runs along the points in SIMD lanes; their poses (n x D).
    start_points: Vec<f32>,
    /// The bounding boxes of every [`crate::kernels::scan::BOX`] coarse points in their first
    /// [`box_split`] coordinates, which rule boxes out before their points are scored.
    start_boxes: Vec<f32>,
    /// The offset surface at the start poses (L x n, as `start_points`).
    bg_start: Vec<f32>,
    start_poses: Vec<f64>,
    /// Points along each axis of the coarse grid, and whether the axis is circular.
    start_shape: Vec<(usize, bool)>,
    /// The noisy match's coarse scan.
    noise_scan: NoiseScan,
    /// The exact lattice search of a clean query on a one-parameter manifold (reported on a
    /// lattice): it replaces the coarse scan and the local search there.
    lattice: Option<lattice::Lattice>,
    /// The clean query's search on a manifold of more parameters (reported on a lattice): it
    /// replaces the coarse scan and the local search there.
    tree: Option<CoarseTree>,
    /// The noisy query's search beside `tree` (on its poses): it replaces the noisy match's
    /// coarse scan and local search there.
    noisy_tree: Option<NoisyTree>,
}

/// A binned model's rows for [`dot_w`] ([`RefinedModel`]'s `words`): the clean rows, and the
/// noisy rows when they differ (none: the same rows, no mean and L = L_s).
#[derive(Debug, Clone)]
struct Words {
    clean: dot_w::WordRows,
    noisy: Option<dot_w::WordRows>,
}

/// The start of a clean query's search on a manifold of two or more parameters reported on a
/// lattice: a k-d tree over the surface at every pose of the lattice of twice the reporting
/// step, in the search's L_s coordinates. A clean query's coordinates are scaled by the weights
/// of nu = 0, so the tree's nearest point is the closest such pose in that metric; from it
/// [`Surface::climb`] walks the reporting lattice with the query's own weights.
#[derive(Debug, Clone)]
struct CoarseTree {
    tree: crate::methods::eigenspace::kdtree::KdTree,
    /// The lattice's poses (n x D).
    poses: Vec<f64>,
}

/// Most poses of a [`CoarseTree`].
const MAX_TREE_POSES: usize = 1 << 20;

impl CoarseTree {
    /// The tree over `surface` on the lattice of `step` degrees anchored at each axis's first
    /// knot, in the first `ls` coordinates; None for one parameter, more than
    /// [`crate::methods::eigenspace::kdtree::MAX_DIM`] coordinates or more than [`MAX_TREE_POSES`] poses.
    fn new(surface: &Surface, space: &crate::PoseSpace, axes: &[Vec<f64>], ls: usize, step: f64) -> Option<CoarseTree> {
        let d = axes.len();
        if !(2..=8).contains(&d) || !(1..=crate::methods::eigenspace::kdtree::MAX_DIM).contains(&ls) || step <= 0.0 {
            return None;
        }
        let counts: Vec<f64> = axes.iter().zip(space.params()).map(|(a, p)| crate::methods::eigenspace::manifold::sample_count(a, p.period, step)).collect();
        if counts.iter().product::<f64>() > MAX_TREE_POSES as f64 {
            return None;
        }
        let at: Vec<Vec<f64>> =
            axes.iter().zip(space.params()).map(|(a, p)| crate::methods::eigenspace::manifold::sample_positions(a, p.period, step)).collect();
        let n: usize = at.iter().map(Vec::len).product();
        let (mut poses, mut points) = (Vec::with_capacity(n * d), Vec::with_capacity(n * ls));
        let mut f = vec![0.0; ls];
        let mut t = vec![0.0; d];
        for k in 0..n {
            // The eigenspace manifold's order (the last axis fastest), its circular values
            // wrapped into [0, period) and brought back into the surface's domain.
            crate::methods::eigenspace::manifold::pose_of(&at, space, k, &mut t);
            surface.clamp(&mut t);
            surface.eval(&t, &mut f, None);
            poses.extend_from_slice(&t);
            points.extend(f.iter().map(|&v| v as f32));
        }
        Some(CoarseTree { tree: crate::methods::eigenspace::kdtree::KdTree::new(&points, ls), poses })
    }
}

/// The start of a noisy query's search on a manifold of two or more parameters reported on a
/// lattice (beside a [`CoarseTree`], on its poses): a k-d tree over the surface points
/// m(t) = f(t) + c (the mean added back) of the noisy match's coordinates, scaled by the
/// square roots of its weights of nu = 0, with their part along `dir` removed and scaled to unit
/// length. The affine match fits z by alpha m(t) + beta g(t); `dir` is the offset surface's mean
/// direction over the lattice, so a fixed beta dir stands for beta g(t) and the unit length for
/// the gain: the tree's nearest point to the query's z, treated the same way, is the pose of
/// least angle between the two off `dir`. From it [`Surface::climb_pair`] walks the reporting
/// lattice on the affine match itself, with the query's own weights.
#[derive(Debug, Clone)]
struct NoisyTree {
    tree: crate::methods::eigenspace::kdtree::KdTree,
    /// The square roots of the weights the points were scaled by.
    scale: Vec<f64>,
    /// The unit offset direction removed (in the scaled coordinates).
    dir: Vec<f64>,
    /// Each axis's period (None: linear) and the distance along it beyond which a second start
    /// counts as another basin: twice the axis's widest knot interval.
    periods: Vec<Option<f64>>,
    apart: Vec<f64>,
}

impl NoisyTree {
    /// The tree over the poses `poses` (n x D) of the surfaces `f` and `g` (the offset) on the
    /// knots `axes` of `space`, `c` the mean's coordinates and `w0` the weights of nu = 0 (their
    /// count: the coordinates used); None when a point has no length left off `dir`.
    fn new(f: &Surface, g: &Surface, space: &crate::PoseSpace, axes: &[Vec<f64>], poses: &[f64], c: &[f64], w0: &[f64]) -> Option<NoisyTree> {
        let (d, ln) = (f.params(), w0.len());
        if !(1..=crate::methods::eigenspace::kdtree::MAX_DIM).contains(&ln) {
            return None;
        }
        let scale: Vec<f64> = w0.iter().map(|w| w.sqrt()).collect();
        let n = poses.len() / d;
        let (mut ms, mut dir) = (Vec::with_capacity(n * ln), vec![0.0; ln]);
        let (mut fv, mut gv) = (vec![0.0; ln], vec![0.0; ln]);
        for t in poses.chunks_exact(d) {
            f.eval_pair(g, t, &mut fv, None, &mut gv, None);
            for q in 0..ln {
                ms.push((fv[q] + c[q]) * scale[q]);
                dir[q] += gv[q] * scale[q];
            }
        }
        let norm = dir.iter().map(|v| v * v).sum::<f64>().sqrt();
        if norm > 0.0 && norm.is_finite() {
            dir.iter_mut().for_each(|v| *v /= norm);
        } else {
            dir.fill(0.0);
        }
        let mut points = vec![0f32; n * ln];
        for (m, p) in ms.chunks_exact(ln).zip(points.chunks_exact_mut(ln)) {
            if !Self::unit_off(m, &dir, p) {
                return None;
            }
        }
        let periods = space.params().iter().map(|p| p.period).collect();
        let apart = axes.iter().map(|a| 2.0 * a.windows(2).map(|w| w[1] - w[0]).fold(0.0, f64::max)).collect();
        Some(NoisyTree { tree: crate::methods::eigenspace::kdtree::KdTree::new(&points, ln), scale, dir, periods, apart })
    }

    /// `v` (scaled coordinates) less its part along `dir`, to unit length, into `out`; false
    /// when nothing is left.
    fn unit_off(v: &[f64], dir: &[f64], out: &mut [f32]) -> bool {
        let along: f64 = v.iter().zip(dir).map(|(a, b)| a * b).sum();
        let norm = v.iter().zip(dir).map(|(a, b)| (a - along * b) * (a - along * b)).sum::<f64>().sqrt();
        if !(norm > 0.0 && norm.is_finite()) {
            return false;
        }
        out.iter_mut().zip(v.iter().zip(dir)).for_each(|(o, (a, b))| *o = ((a - along * b) / norm) as f32);
        true
    }

    /// The starts of the query's coordinates `z` (mean added back, the first `scale.len()`) on
    /// the lattice `poses` (n x D): the tree's nearest point and, when one lies within twice
    /// its squared distance, the nearest one apart from it by more than `apart[j]` degrees
    /// along some axis j (circularly on a circular axis): a second basin, as on a nearly
    /// symmetric object, whose views a half turn apart differ little (both from one search,
    /// [`crate::methods::eigenspace::kdtree::KdTree::nearest_and_near`], under its distance). None when
    /// `z` has no length off the offset direction.
    fn starts(&self, z: &[f64], poses: &[f64]) -> Option<(usize, Option<usize>)> {
        let (ln, d, periods, apart) = (self.scale.len(), self.periods.len(), &self.periods, &self.apart);
        let (mut v, mut q) = ([0f64; crate::methods::eigenspace::kdtree::MAX_DIM], [0f32; crate::methods::eigenspace::kdtree::MAX_DIM]);
        v[..ln].iter_mut().zip(z.iter().zip(&self.scale)).for_each(|(o, (a, s))| *o = a * s);
        if !Self::unit_off(&v[..ln], &self.dir, &mut q[..ln]) {
            return None;
        }
        // One search for the nearest point and those within twice its squared distance, among
        // which the nearest of another basin (ties to the lower index).
        SEARCH_SCRATCH.with_borrow_mut(|sc| {
            let (i, _) = self.tree.nearest_and_near(&q[..ln], 2.0, &mut sc.near);
            let first = &poses[i * d..(i + 1) * d];
            let away = |k: usize| {
                poses[k * d..(k + 1) * d].iter().zip(first).zip(periods).zip(apart).any(|(((&a, &b), p), &r)| {
                    let gap = (a - b).abs();
                    p.map_or(gap, |per| gap.min(per - gap)) > r
                })
            };
            let second = sc.near.iter().filter(|&&(_, k)| away(k as usize)).min_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1))).map(|&(_, k)| k as usize);
            Some((i, second))
        })
    }

    fn bytes(&self) -> usize {
        self.tree.bytes() + (self.scale.len() + self.dir.len() + 2 * self.apart.len()) * 8
    }
}

/// The coarse scan of the noisy match: the affine fit of [`surface::affine_fit`] at every coarse
/// point with fixed weights w0 (a clean query's: nu = 0; the local search then uses the query's
/// own). With m_i = f_i + c and g_i the point's two surfaces, the w0-weighted products
/// A = m.m, B = m.g, C = g.g depend on the point alone, so a query costs two products per point,
/// u_i = (w0 z).m_i and v_i = (w0 z).g_i, and the residual z.z - u^2 / A - e^2 / S with
/// e = v - (B / A) u and S = C - B^2 / A (the fit on m, then on g's part orthogonal to m: two
/// non-negative terms, so nothing cancels when g is nearly parallel to m).
///
/// The same fit on the first [`noise_scan_split`] coordinates only leaves out non-negative
/// terms, so its residual is a lower bound of the whole one: a point whose partial residual
/// exceeds twice the whole residual of the point of least partial residual cannot be within
/// twice the least, and its block of points is not summed further.
#[derive(Debug, Clone, Default)]
struct NoiseScan {
    w0: Vec<f32>,
    /// Per point over all w0.len() coordinates: 1 / A, B / A, 1 / S (0 where the fit is
    /// degenerate).
    full: AffineTables,
    /// The same over the first `split` coordinates (empty when `split` is 0: no pruning).
    part: AffineTables,
    split: usize,
    /// The points whose partial fit is degenerate (1 / A or 1 / S set to 0): their partial
    /// residual leaves part of the fit out, so it is no lower bound and they are never ruled out.
    degenerate: Vec<usize>,
}

/// Per point: 1 / A, B / A, 1 / S of [`NoiseScan`] (0 where the fit is degenerate).
#[derive(Debug, Clone, Default)]
struct AffineTables {
    inv_a: Vec<f64>,
    b_over_a: Vec<f64>,
    inv_s: Vec<f64>,
}

impl AffineTables {
    /// The tables of the fit over the coordinates of `w0` (the first w0.len()).
    fn new(model: &RefinedModel, w0: &[f64]) -> AffineTables {
        let n = model.start_len();
        let (mut a, mut b, mut cc) = (vec![0f64; n], vec![0f64; n], vec![0f64; n]);
        for (q, &w) in w0.iter().enumerate() {
            let (col, gcol) = (&model.start_points[q * n..(q + 1) * n], &model.bg_start[q * n..(q + 1) * n]);
            let cq = model.mean_proj[q] as f64;
            for i in 0..n {
                let (m, g) = (col[i] as f64 + cq, gcol[i] as f64);
                a[i] += w * m * m;
                b[i] += w * m * g;
                cc[i] += w * g * g;
            }
        }
        let (mut inv_a, mut b_over_a, mut inv_s) = (vec![0f64; n], vec![0f64; n], vec![0f64; n]);
        for i in 0..n {
            if a[i] > 0.0 {
                (inv_a[i], b_over_a[i]) = (1.0 / a[i], b[i] / a[i]);
                let schur = cc[i] - b[i] * b[i] / a[i];
                if schur > 1e-9 * cc[i] && schur > 0.0 {
                    inv_s[i] = 1.0 / schur;
                }
            }
        }
        AffineTables { inv_a, b_over_a, inv_s }
    }

    /// The residuals of points `range`, in place of their products `u` (with `v`), for a query
    /// of weighted sums `ac` = (w0 z).c and `zz` = (w0 z).z.
    fn residuals(&self, range: std::ops::Range<usize>, u: &mut [f32], v: &[f32], ac: f64, zz: f64) {
        let (ba, ia, is) = (&self.b_over_a[range.clone()], &self.inv_a[range.clone()], &self.inv_s[range]);
        crate::kernels::scan::affine_residuals(Level::detect(), u, v, ba, ia, is, ac, zz);
    }

    fn len(&self) -> usize {
        3 * self.inv_a.len()
    }
}

impl NoiseScan {
    fn new(model: &RefinedModel, w0: &[f64]) -> NoiseScan {
        debug_assert!(w0.len() <= model.components());
        let split = noise_scan_split(w0.len());
        let part = if split > 0 { AffineTables::new(model, &w0[..split]) } else { AffineTables::default() };
        let degenerate = (0..part.inv_a.len()).filter(|&i| part.inv_a[i] == 0.0 || part.inv_s[i] == 0.0).collect();
        NoiseScan { w0: w0.iter().map(|&v| v as f32).collect(), full: AffineTables::new(model, w0), part, split, degenerate }
    }

    /// Numbers held, all counted as 8 bytes.
    fn len(&self) -> usize {
        self.w0.len() + self.full.len() + self.part.len() + self.degenerate.len()
    }

    /// The residual at every coarse point that can lie within twice the least (+inf at the
    /// others) of the query coordinates `z` (mean added back, the first w0.len()), `c` the mean's
    /// coordinates, into `u` (`v` is scratch; both are resized, and every value is written).
    /// Every residual given has the bits of [`Self::scan_all`]'s.
    fn scan(&self, cols: &[f32], gcols: &[f32], z: &[f64], c: &[f64], u: &mut Vec<f32>, v: &mut Vec<f32>) {
        let (n, ln, s) = (self.full.inv_a.len(), self.w0.len(), self.split);
        if s == 0 {
            return self.scan_all(cols, gcols, z, c, u, v);
        }
        let level = Level::detect();
        let a: Vec<f32> = z.iter().zip(&self.w0).map(|(&zq, &w)| w * zq as f32).collect();
        let (ac, zz) = Self::sums(&self.w0, z, c);
        let (ac_s, zz_s) = Self::sums(&self.w0[..s], &z[..s], &c[..s]);
        u.resize(n, 0.0);
        v.resize(n, 0.0);
        // Lower bounds: the fit on the first s coordinates.
        crate::kernels::scan::dots2(level, &cols[..s * n], &gcols[..s * n], &a[..s], u, v);
        self.part.residuals(0..n, u, v, ac_s, zz_s);
        // Any point's whole residual bounds the least; the least partial one's is likely close.
        let Some(first) = crate::kernels::scan::argmin(level, u) else {
            return self.scan_all(cols, gcols, z, c, u, v);
        };
        self.degenerate.iter().for_each(|&i| u[i] = 0.0);
        let (mut u1, mut v1) = ([0f32], [0f32]);
        crate::kernels::scan::dots2_at(level, &cols[..ln * n], &gcols[..ln * n], n, first, &a, &mut u1, &mut v1);
        self.full.residuals(first..first + 1, &mut u1, &v1, ac, zz);
        // Twice that residual bounds the cut of the starts; the slack covers the rounding of
        // the f32 products (about 1e-6 of z.z) many times over.
        let cut = (2.0 * u1[0] as f64 * (1.0 + 1e-4) + 1e-4 * zz) as f32;
        for (b, (ub, vb)) in u.chunks_mut(64).zip(v.chunks_mut(64)).enumerate() {
            if ub.iter().fold(false, |hit, &x| hit | !(x > cut)) {
                let i0 = b * 64;
                crate::kernels::scan::dots2_at(level, &cols[..ln * n], &gcols[..ln * n], n, i0, &a, ub, vb);
                self.full.residuals(i0..i0 + ub.len(), ub, vb, ac, zz);
            } else {
                ub.fill(f32::INFINITY);
            }
        }
    }

    /// The residual at every coarse point into `u` (see [`Self::scan`]).
    fn scan_all(&self, cols: &[f32], gcols: &[f32], z: &[f64], c: &[f64], u: &mut Vec<f32>, v: &mut Vec<f32>) {
        let n = self.full.inv_a.len();
        let ln = self.w0.len();
        let a: Vec<f32> = z.iter().zip(&self.w0).map(|(&zq, &w)| w * zq as f32).collect();
        let (ac, zz) = Self::sums(&self.w0, z, c);
        u.resize(n, 0.0);
        v.resize(n, 0.0);
        crate::kernels::scan::dots2(Level::detect(), &cols[..ln * n], &gcols[..ln * n], &a, u, v);
        self.full.residuals(0..n, u, v, ac, zz);
    }

    /// (w0 z).c and (w0 z).z over the coordinates of `w0`.
    fn sums(w0: &[f32], z: &[f64], c: &[f64]) -> (f64, f64) {
        let ac: f64 = z.iter().zip(w0).zip(c).map(|((&zq, &w), &cq)| w as f64 * zq * cq).sum();
        let zz: f64 = z.iter().zip(w0).map(|(&zq, &w)| w as f64 * zq * zq).sum();
        (ac, zz)
    }
}

impl RefinedModel {
    #[allow(clippy::too_many_arguments)]
    fn new(
        mut meta: ModelMeta,
        settings: RefinedSettings,
        basis: Vec<f32>,
        mean: Vec<f32>,
        knots: Vec<f32>,
        background: Vec<f32>,
        axes: Vec<Vec<f64>>,
    ) -> Result<Self> {
        let (l, m) = (settings.components, mean.len());
        let binning = Binning::new(meta.spec, settings.bin)?;
        assert_eq!(binning.spec().features(), m, "a mean image of the binned size");
        meta.settings = serde_json::to_value(&settings).expect("plain struct serialises");
        let k64: Vec<f64> = knots.iter().map(|&v| v as f64).collect();
        let surface = Surface::new(&meta.space, &axes, &k64, l, settings.interpolant)?;
        let start_poses = surface.grid_poses(settings.params.per_cell);
        let start_shape = surface.grid_shape(settings.params.per_cell);
        let d = axes.len();
        let b64: Vec<f64> = background.iter().map(|&v| v as f64).collect();
        let bg_surface = Surface::new(&meta.space, &axes, &b64, l, settings.interpolant)?;
        let n_start = start_poses.len() / d;
        let mut start_points = vec![0f32; n_start * l];
        let mut bg_start = vec![0f32; n_start * l];
        let mut f = vec![0.0; l];
        for (i, t) in start_poses.chunks_exact(d).enumerate() {
            surface.eval(t, &mut f, None);
            f.iter().enumerate().for_each(|(c, &v)| start_points[c * n_start + i] = v as f32);
            bg_surface.eval(t, &mut f, None);
            f.iter().enumerate().for_each(|(c, &v)| bg_start[c * n_start + i] = v as f32);
        }
        let mean_proj = basis.chunks_exact(m).map(|u| u.iter().zip(&mean).map(|(&a, &b)| a as f64 * b as f64).sum::<f64>() as f32).collect();
        let mean_sq = mean.iter().map(|&v| v as f64 * v as f64).sum();
        let ls = settings.search();
        let sigma2 = (settings.interpolation_variance.len() == ls).then_some(&settings.interpolation_variance[..]);
        let inv_weight = search_scale(sigma2, ls, l).iter().map(|s| 1.0 / (s * s)).collect();
        let step = settings.params.resolution;
        // The lattice search costs in proportion to the lattice (the local search does not):
        // kept for lattices of at most MAX_LATTICE poses.
        let lattice = surface
            .line_parts()
            .filter(|&(at, period, ..)| step > 0.0 && period.unwrap_or(at[at.len() - 1] - at[0]) / step <= MAX_LATTICE as f64)
            .map(|(at, period, values, slopes, dim)| lattice::Lattice::new(at, period, values, slopes, dim, ls, step));
        let tree = if lattice.is_none() { CoarseTree::new(&surface, &meta.space, &axes, ls, 2.0 * step) } else { None };
        // Only the clean coarse scan reads the boxes; the lattice and the tree replace it.
        let scanned = lattice.is_none() && tree.is_none();
        let start_boxes = if scanned { crate::kernels::scan::boxes(&start_points, n_start, box_split(l)) } else { Vec::new() };
        let rows = [mean, basis].concat();
        // The rows of each route (as clean_rows, noisy_rows, extra_range): the mean's only when
        // the residual is used.
        let r = uses_residual(&settings) as usize;
        let (clean, noisy, extra) = (&rows[(1 - r) * m..(1 + ls) * m], &rows[m..(1 + l) * m], &rows[(1 + ls) * m..]);
        let words = (binning.bins() && dot_q::fast(Level::detect()))
            .then(|| {
                let w = |r: &[f32]| dot_w::WordRows::new(r, m, binning.max_sum());
                let clean = w(clean)?;
                let noisy = if noisy.len() == clean.rows() * m && r == 0 { None } else { Some(w(noisy)?) };
                Some(Words { clean, noisy })
            })
            .flatten();
        let fast = |r: &[f32]| if words.is_some() || r.is_empty() { dot_q::FastRows::default() } else { dot_q::FastRows::new(r, m) };
        let (quant, quant_x) = (fast(clean), fast(extra));
        // Coordinates L_s.. are unscaled (search_scale), and the knots are the training views
        // (a full grid, one view a point): their mean square is the eigenvalue over N.
        let nk = knots.len() / l.max(1);
        let beyond: f64 = knots.chunks_exact(l.max(1)).map(|k| k[ls..].iter().map(|&v| v as f64 * v as f64).sum::<f64>()).sum::<f64>() / nk.max(1) as f64;
        let clean_residual_energy = settings.residual_energy + beyond;
        Ok(RefinedModel {
            meta,
            settings,
            quant,
            quant_x,
            words,
            clean_residual_energy,
            rows: AlignedF32::new(&rows),
            m,
            binning,
            mean_proj,
            mean_sq,
            inv_weight,
            knots,
            background,
            bg_surface,
            axes,
            surface,
            start_boxes,
            start_points,
            bg_start,
            start_poses,
            start_shape,
            noise_scan: NoiseScan::default(),
            lattice,
            tree,
            noisy_tree: None,
        })
        .map(|mut m: RefinedModel| {
            // Only a model that detects noisy queries routes any to the noisy match (the
            // automatic choice sets it on its candidates itself, `set_noise_match`).
            if m.settings.noise_threshold > 0.0 {
                let (ln, weighted) = (m.settings.noise_components, m.settings.noise_weighted);
                m.set_noise_match(ln, weighted);
            }
            m
        })
    }

    /// The settings as given and as chosen.
    pub fn settings(&self) -> &RefinedSettings {
        &self.settings
    }

    /// Number of eigenimages L.
    pub fn components(&self) -> usize {
        self.settings.components
    }

    /// Number of knots (training views on the grid).
    pub fn knots_len(&self) -> usize {
        self.knots.len() / self.components()
    }

    /// Number of coarse start points.
    pub fn start_len(&self) -> usize {
        self.start_poses.len() / self.axes.len()
    }

    /// Whether a clean query's search weights depend on its residual (the weighted metric:
    /// 1 / (sigma_l^2 + floor + nu)). The plain metric weighs every coordinate alike, so nu only
    /// scales the distance and its products with the mean are not needed.
    fn uses_residual(&self) -> bool {
        uses_residual(&self.settings)
    }

    /// The noisy match's coordinates past the clean search's L_s: what a query routed to it
    /// takes besides [`Self::clean_rows`] when it is routed after them (a model that does not
    /// bin).
    fn extra_rows(&self) -> usize {
        self.components() - self.settings.search()
    }

    /// The rows of `rows` ([mean, eigenimages]) a query the clean search serves takes: the
    /// mean's when used, then the first L_s eigenimages.
    fn clean_rows(&self) -> std::ops::Range<usize> {
        1 - self.uses_residual() as usize..1 + self.settings.search()
    }

    /// The rows a query routed to the noisy match before its products takes (a model that
    /// bins): every eigenimage, not the mean.
    fn noisy_rows(&self) -> std::ops::Range<usize> {
        1..1 + self.components()
    }

    /// The rows of [`Self::extra_rows`].
    fn extra_range(&self) -> std::ops::Range<usize> {
        1 + self.settings.search()..1 + self.components()
    }

    /// Whether a query goes to the noisy match: all of them for `NoiseWant::Full`, none for
    /// `None`, else when its route's value `route` (what [`Self::pose_routed`] compares) is over
    /// the threshold.
    #[inline]
    fn routed_noisy(&self, noise: NoiseWant, route: f64) -> bool {
        match noise {
            NoiseWant::None => false,
            NoiseWant::Full => true,
            NoiseWant::Route => self.settings.noise_threshold > 0.0 && route > self.settings.noise_threshold,
        }
    }

    /// The products of the queries `xq` (rows of M, the first the task's query `i0`; those at
    /// `sel` when given, else all) with `rows` rows `rr` into `s.raw` (rows of 1 + L, the mean's
    /// product first and eigenimage c's at 1 + c) from column `rr.start`: one f32 product over
    /// `xq` itself or over a copy of the selected queries.
    fn pass_f32(&self, xq: &[f32], i0: usize, sel: Option<&[usize]>, rr: std::ops::Range<usize>, s: &mut QueryScratch) {
        let (m, kr, k) = (self.m, 1 + self.components(), rr.len());
        let (src, nx) = selected(xq, m, sel, &mut s.gather_f32);
        if nx == 0 || k == 0 {
            return;
        }
        s.xout.resize(nx * k, 0.0);
        let ut = MatRef::from_column_major_slice(&self.rows[rr.start * m..rr.end * m], m, k);
        matmul(MatMut::from_row_major_slice_mut(&mut s.xout, nx, k), Accum::Replace, MatRef::from_row_major_slice(src, nx, m), ut, 1.0f32, Par::Seq);
        scatter(&s.xout, k, sel, i0, kr, rr.start, &mut s.raw);
    }

    /// As [`Self::pass_f32`] for 8-bit images of M pixel values, by `fr` (the rows `rr` in
    /// 16-bit fixed point, see [`dot_q::FastRows`]): from 8 queries on in one batch, else one at
    /// a time; their sums of squares into `s.xenergy` (by selected query).
    #[allow(clippy::too_many_arguments)]
    fn pass_u8(&self, level: Level, fr: &dot_q::FastRows, xq: &[u8], i0: usize, sel: Option<&[usize]>, rr: std::ops::Range<usize>, s: &mut QueryScratch) {
        let (m, kr, k) = (self.m, 1 + self.components(), rr.len());
        let (src, nx) = selected(xq, m, sel, &mut s.gather_u8);
        if nx == 0 || k == 0 {
            return;
        }
        s.xout.resize(nx * k, 0.0);
        s.xenergy.resize(nx, 0);
        let rows = &self.rows[rr.start * m..rr.end * m];
        if nx >= 8 {
            fr.dots_batch(level, src, m, rows, &mut s.xout, &mut s.xenergy, &mut s.products);
        } else {
            for ((x, r), e) in src.chunks_exact(m).zip(s.xout.chunks_exact_mut(k)).zip(s.xenergy.iter_mut()) {
                fr.dots(level, x, rows, r);
                *e = dot_u8::sum_squares(x);
            }
        }
        scatter(&s.xout, k, sel, i0, kr, rr.start, &mut s.raw);
    }

    /// The eigenspace coordinates, residual and noise of f32 queries (rows of M) into `s.y`
    /// (rows of L), `s.resid` and `s.noise`. In sub-chunks whose queries stay in cache from the
    /// products to the energy and noise (rayon splits the batch, see [`chunk_rows`]). Without
    /// `routed`: the products of every query with [`Self::clean_rows`] (the mean's, when used,
    /// summed with the query's energy in one pass, [`crate::linalg::energy_and_dot`]: a row
    /// fewer in the product, whose kernel takes 4 at a time), then each query's energy and,
    /// when `noise` says so, its pixel noise ([`pixel_variance`], staged at `early` times
    /// the noise threshold, see [`NoiseWant`]), which routes it; the queries routed to the noisy
    /// match take the [`Self::extra_range`] too. With `routed` (a model that bins: routed on the
    /// images as given, `s.noisy`) each query takes its route's rows alone, the clean ones
    /// [`Self::clean_rows`], the noisy ones [`Self::noisy_rows`]. Then [`Self::finish_query`].
    fn project_f32(&self, queries: &[f32], noise: NoiseWant, routed: bool, s: &mut QueryScratch) {
        let (l, m) = (self.components(), self.m);
        let n = queries.len() / m;
        let spec = self.binning.spec();
        let (w, h, ch) = (spec.width as usize, spec.height as usize, spec.color.channels());
        s.resize(n, l);
        let sub = if std::mem::size_of_val(queries) <= NOISE_SUB_F32_BYTES { n.max(1) } else { NOISE_SUB_F32 };
        let mut sel = std::mem::take(&mut s.xidx);
        let mut other = std::mem::take(&mut s.xidx2);
        // The clean search's eigenimages go through the product; the mean's product (the
        // first of [`Self::clean_rows`] when it is used) is summed with the energy.
        let (take_mean, eigen_clean) = (self.uses_residual(), 1..1 + self.settings.search());
        for (c, xq) in queries.chunks(sub * m).enumerate() {
            let (i0, nn) = (c * sub, xq.len() / m);
            if routed {
                sel.clear();
                other.clear();
                (0..nn).for_each(|j| if s.noisy[i0 + j] { sel.push(j) } else { other.push(j) });
                self.pass_f32(xq, i0, Some(&other[..]), eigen_clean.clone(), s);
                self.pass_f32(xq, i0, Some(&sel[..]), self.noisy_rows(), s);
            } else {
                self.pass_f32(xq, i0, None, eigen_clean.clone(), s);
            }
            for (i, x) in (i0..).zip(xq.chunks_exact(m)) {
                // The product with the mean, where the query takes it, in the pass that sums
                // its energy.
                let energy = if take_mean && !(routed && s.noisy[i]) {
                    let (energy, dot) = crate::linalg::energy_and_dot(x, &self.rows[..m]);
                    s.raw[i * (1 + l)] = dot as f32;
                    energy
                } else {
                    crate::linalg::energy(x)
                };
                s.benergy[i] = energy;
                s.pv[i] = match self.early(noise, energy, m) {
                    Some(early) => pixel_variance_in(x, w, h, ch, RowsF32::reuse(&mut s.rows_f32, w * ch, ch), early),
                    None => 0.0,
                };
                if !routed {
                    // The route's value as pose_of_coords forms it.
                    s.noisy[i] = self.routed_noisy(noise, s.pv[i] / energy * m as f64);
                }
            }
            if !routed && self.extra_rows() > 0 {
                sel.clear();
                sel.extend((0..nn).filter(|&j| s.noisy[i0 + j]));
                self.pass_f32(xq, i0, Some(&sel[..]), self.extra_range(), s);
            }
            for i in i0..i0 + nn {
                let mean = !(routed && s.noisy[i]);
                (s.resid[i], s.noise[i]) = self.finish_query(i, mean, s.benergy[i], s.pv[i], s);
            }
        }
        (s.xidx, s.xidx2) = (sel, other);
    }

    /// As [`Self::project_f32`] (not routed) for 8-bit images given as raw pixel values (n of
    /// them): the products by [`dot_q::FastRows::dots_batch`] (the integer kernel where it is
    /// fast, else [`dot_u8::dots_batch`]) from 8 queries on (one at a time below), the energy
    /// exact in integers, the pixel noise by [`pixel_variance_u8`], all in pixel values: the
    /// 1 / 255 of the features cancels in each ratio.
    fn project_u8(&self, level: Level, queries: &[u8], noise: NoiseWant, s: &mut QueryScratch) {
        let (l, m) = (self.components(), self.m);
        let spec = self.binning.spec();
        let (w, h, ch) = (spec.width as usize, spec.height as usize, spec.color.channels());
        s.resize(queries.len() / m, l);
        let mut sel = std::mem::take(&mut s.xidx);
        // In sub-chunks whose images stay in cache from the products to the noise pass.
        for (c, xq) in queries.chunks(NOISE_SUB_U8 * m).enumerate() {
            let (i0, nn) = (c * NOISE_SUB_U8, xq.len() / m);
            self.pass_u8(level, &self.quant, xq, i0, None, self.clean_rows(), s);
            for (i, x) in (i0..).zip(xq.chunks_exact(m)) {
                s.energy[i] = s.xenergy[i - i0];
                let energy = s.energy[i] as f64;
                s.pv[i] = match self.early(noise, energy, m) {
                    Some(early) => pixel_variance_u8_in(x, w, h, ch, RowsU8::reuse(&mut s.rows_u8, w * ch, ch), early),
                    None => 0.0,
                };
                // The route's value as pose_of_coords forms it.
                s.noisy[i] = self.routed_noisy(noise, s.pv[i] / energy * m as f64);
            }
            if self.extra_rows() > 0 {
                sel.clear();
                sel.extend((0..nn).filter(|&j| s.noisy[i0 + j]));
                self.pass_u8(level, &self.quant_x, xq, i0, Some(&sel[..]), self.extra_range(), s);
            }
            for i in i0..i0 + nn {
                (s.resid[i], s.noise[i]) = self.finish_query(i, true, s.energy[i] as f64, s.pv[i], s);
            }
        }
        s.xidx = sel;
    }

    /// The `early` of the staged pixel-noise estimate of a query of `m` pixels and energy
    /// `energy` (in the estimate's units), `None` for no estimate. The route compares the
    /// estimate times M / energy with the threshold ([`Self::poses_of`]).
    #[inline]
    fn early(&self, noise: NoiseWant, energy: f64, m: usize) -> Option<f64> {
        match noise {
            NoiseWant::None => None,
            NoiseWant::Full => Some(0.0),
            NoiseWant::Route => Some(NOISE_EARLY * self.settings.noise_threshold * energy / m as f64),
        }
    }

    /// Query `i` of the task from its products (`s.raw`'s row: the mean's, then eigenimage c's
    /// at 1 + c; L of them when it went to the noisy match, `s.noisy`, else L_s), the mean's
    /// product taken when `mean`, its energy ||x||^2 and its pixel variance `pv`, in the same
    /// units: the unit-energy, mean-subtracted coordinates into `s.y` (0 past those it took; NaN
    /// for a query of zero or non-finite energy), and its residual ||x / ||x|| - mean||^2 less
    /// the energy inside the search's L_s coordinates (0 when not used or not taken) and pixel
    /// noise per unit-energy coordinate.
    fn finish_query(&self, i: usize, mean: bool, energy: f64, pv: f64, s: &mut QueryScratch) -> (f64, f64) {
        let (l, ls) = (self.components(), self.settings.search());
        let y = &mut s.y[i * l..(i + 1) * l];
        let norm = energy.sqrt();
        if !(norm > 0.0 && norm.is_finite()) {
            y.fill(f32::NAN);
            return (0.0, 0.0);
        }
        let raw = &s.raw[i * (1 + l)..(i + 1) * (1 + l)];
        let took = if s.noisy[i] { l } else { ls };
        let inv = (1.0 / norm) as f32;
        y[..took].iter_mut().zip(&raw[1..1 + took]).zip(&self.mean_proj).for_each(|((v, &r), &c)| *v = r * inv - c);
        y[took..].fill(0.0);
        let resid = if mean && self.uses_residual() {
            // Unscaled coordinates: each scaled one's square times 1 / w_l.
            let inside: f64 = y[..ls].iter().zip(&self.inv_weight).map(|(&v, &iw)| v as f64 * v as f64 * iw).sum();
            1.0 - 2.0 * raw[0] as f64 / norm + self.mean_sq - inside
        } else {
            0.0
        };
        (resid, pv / energy)
    }

    /// The pose (degrees, circular values in [0, period)) of eigenspace coordinates `y`, of a
    /// query whose pixel noise is `noise` ([`pixel_noise`] of the image the model works on).
    pub fn pose_of_coords(&self, y: &[f32], residual: f64, noise: f64, out: &mut [f64]) {
        self.pose_routed(y, residual, noise, noise / self.m as f64, out)
    }

    /// [`Self::pose_of_coords`] with the route's value (the query's [`pixel_noise`], compared
    /// with the threshold) and the noisy match's nu (its pixel noise per unit-energy
    /// coordinate) given apart: a model that bins routes on the image as given and matches on
    /// the binned one.
    fn pose_routed(&self, y: &[f32], residual: f64, route: f64, noise_nu: f64, out: &mut [f64]) {
        let (l, d) = (self.components(), self.axes.len());
        // Noise per coordinate from the energy off the search's L_s coordinates beyond the
        // training views' (isotropic noise puts (M - L_s) times its per-coordinate variance
        // there: the residual the choice of L_s was scored with); the weights
        // 1 / (sigma_l^2 + floor + nu) relative to the stored 1 / (sigma_l^2 + floor).
        let (m, ls) = (self.m, self.settings.search());
        let nu = ((residual - self.clean_residual_energy) / (m.saturating_sub(ls).max(1)) as f64).max(0.0);
        if self.routed_noisy(NoiseWant::Route, route) {
            return self.pose_of_noisy(y, noise_nu, out);
        }
        let k = self.settings.params.starts.min(self.start_len());
        let mut t = [0f64; 8];
        SEARCH_SCRATCH.with_borrow_mut(|sc| {
            let SearchScratch { wt, w32, dist, buf, lb, .. } = sc;
            wt.clear();
            wt.extend(self.inv_weight.iter().enumerate().map(|(c, &iw)| if c < ls { iw / (iw + nu) } else { 0.0 }));
            if let Some(lat) = &self.lattice {
                let uniform = wt[..ls].iter().all(|&w| w == wt[0]).then_some(wt[0]);
                t[0] = lat.nearest(y, wt, uniform, buf);
                return;
            }
            if let Some(c) = &self.tree {
                let i = c.tree.nearest(&y[..ls]);
                t[..d].copy_from_slice(&c.poses[i * d..(i + 1) * d]);
                self.surface.climb(y, wt, &mut t[..d], self.settings.params.resolution);
                return;
            }
            w32.clear();
            w32.extend(wt.iter().map(|&w| w as f32));
            // Every coarse point's distance, then the k closest.
            dist.resize(self.start_len(), 0.0);
            let split = box_split(self.components());
            let lo = crate::kernels::scan::sq_dist_boxed(Level::detect(), &self.start_points, &self.start_boxes, split, y, w32, dist, lb);
            let best = smallest_under(dist, k, lo);
            buf.resize((d + 2) * l, 0.0);
            let mut best_cost = f64::INFINITY;
            for i in self.distinct_starts(&best) {
                let mut s = [0f64; 8];
                s[..d].copy_from_slice(&self.start_poses[i * d..(i + 1) * d]);
                let c = self.surface.refine(y, wt, &mut s[..d], buf);
                if c < best_cost {
                    (best_cost, t) = (c, s);
                }
            }
            if self.settings.params.resolution > 0.0 {
                self.surface.snap(y, wt, &mut t[..d], self.settings.params.resolution, &mut buf[..l]);
            }
        });
        self.write_pose(&t[..d], out);
    }

    /// The starts worth a local search among the closest coarse points `best` (increasing
    /// distance): those within twice the closest one's distance, less any next to a closer start
    /// on the coarse grid (one step along every axis), whose basin it shares.
    fn distinct_starts(&self, best: &[(f32, usize)]) -> Vec<usize> {
        let first = best.first().map_or(0.0, |b| b.0);
        let mut kept: Vec<usize> = Vec::with_capacity(best.len());
        for &(v, i) in best {
            if v > 2.0 * first.max(0.0) + f32::MIN_POSITIVE {
                break;
            }
            if !kept.iter().any(|&j| self.adjacent(i, j)) {
                kept.push(i);
            }
        }
        kept
    }

    /// Whether coarse points `i` and `j` are at most one grid step apart along every axis.
    fn adjacent(&self, mut i: usize, mut j: usize) -> bool {
        for &(n, circular) in self.start_shape.iter().rev() {
            let (a, b) = (i % n, j % n);
            let gap = a.abs_diff(b);
            if gap > 1 && !(circular && gap == n - 1) {
                return false;
            }
            (i, j) = (i / n, j / n);
        }
        true
    }

    /// The weights of the noisy match on the stored (scaled) coordinates, one per coordinate it
    /// uses, for pixel noise `nu` per unit-energy coordinate: the wanted weight on the unscaled
    /// coordinates (1, or 1 / (sigma_l^2 + floor + nu) when weighted) times 1 / scale^2.
    fn noise_weights(&self, nu: f64) -> Vec<f64> {
        let s = &self.settings;
        let l = self.components();
        let (ln, weighted) = (s.noise_components.clamp(1, l), s.noise_weighted && s.coord_variance.len() == l);
        let floor = if weighted { WEIGHT_FLOOR * s.coord_variance[..ln].iter().sum::<f64>() / ln as f64 } else { 0.0 };
        (0..ln).map(|q| if weighted { 1.0 / (s.coord_variance[q] + floor + nu) } else { 1.0 } * self.inv_weight[q]).collect()
    }

    /// Sets the noisy match (its eigenimages and whether it weights them), and the coarse scan's
    /// tables with it.
    pub(crate) fn set_noise_match(&mut self, components: usize, weighted: bool) {
        (self.settings.noise_components, self.settings.noise_weighted) = (components, weighted);
        let w0 = self.noise_weights(0.0);
        let c: Vec<f64> = self.mean_proj[..w0.len()].iter().map(|&v| v as f64).collect();
        self.noisy_tree = self.tree.as_ref().and_then(|ct| NoisyTree::new(&self.surface, &self.bg_surface, &self.meta.space, &self.axes, &ct.poses, &c, &w0));
        self.noise_scan = if self.noisy_tree.is_some() { NoiseScan::default() } else { NoiseScan::new(self, &w0) };
    }

    /// The pose of a noisy query's coordinates `y` (as [`Self::pose_of_coords`]), whose pixel
    /// noise puts variance `nu` on each unit-energy coordinate: the affine match. Clipped noise
    /// brightens a black background by a / 4 and adds energy, so the query is matched to
    /// alpha (f(t) + c) + beta g(t), the surface point (c the mean's coordinates) scaled by a free
    /// gain plus a free multiple of the offset direction g ([`clip_bias_shape`]), both solved
    /// per pose, in the first `noise_components` coordinates, weighted by
    /// 1 / (sigma_l^2 + floor + nu) when `noise_weighted`.
    ///
    /// With a [`NoisyTree`] (two or more parameters reported on a lattice) the starts are its
    /// nearest point and, within twice its distance, the nearest of another basin; from each
    /// [`Surface::climb_pair`] walks the reporting lattice on the affine match, and the closer
    /// end is the pose. Otherwise the coarse scan ([`NoiseScan`]) gives the starts of
    /// Levenberg-Marquardt ([`Surface::refine_affine`]), snapped to the lattice.
    fn pose_of_noisy(&self, y: &[f32], nu: f64, out: &mut [f64]) {
        let (l, d) = (self.components(), self.axes.len());
        let s = &self.settings;
        let wt = self.noise_weights(nu);
        let ln = wt.len();
        let c: Vec<f64> = self.mean_proj[..ln].iter().map(|&v| v as f64).collect();
        let z: Vec<f64> = y[..ln].iter().zip(&c).map(|(&v, &cv)| v as f64 + cv).collect();
        let (fs, bs) = (&self.surface, &self.bg_surface);
        if let (Some(nt), Some(ct)) = (&self.noisy_tree, &self.tree) {
            // A query with no length off the offset direction (never seen) starts from the
            // clean tree's nearest point.
            let (i, second) = nt.starts(&z, &ct.poses).unwrap_or_else(|| (ct.tree.nearest(&y[..s.search()]), None));
            let aq = surface::AffineQuery::new(&z, &c, &wt);
            let mut cost = |f: &[f64], g: &[f64]| aq.residual(f, g);
            let mut best = (f64::INFINITY, [0f64; 8]);
            for j in std::iter::once(i).chain(second) {
                let mut t = [0f64; 8];
                t[..d].copy_from_slice(&ct.poses[j * d..(j + 1) * d]);
                let cj = fs.climb_pair(Some(bs), ln, &mut t[..d], s.params.resolution, &mut cost);
                if cj < best.0 {
                    best = (cj, t);
                }
            }
            return self.write_pose(&best.1[..d], out);
        }
        let k = s.params.starts.min(self.start_len());
        let best = SEARCH_SCRATCH.with_borrow_mut(|sc| {
            self.noise_scan.scan(&self.start_points, &self.bg_start, &z, &c, &mut sc.dist, &mut sc.lb);
            smallest(&sc.dist, k)
        });
        let mut buf = vec![0.0; (2 * d + 5) * l];
        let (mut best_cost, mut t) = (f64::INFINITY, [0f64; 8]);
        for i in self.distinct_starts(&best) {
            let mut st = [0f64; 8];
            st[..d].copy_from_slice(&self.start_poses[i * d..(i + 1) * d]);
            let cst = fs.refine_affine(bs, &z, &c, &wt, &mut st[..d], &mut buf).0;
            if cst < best_cost {
                (best_cost, t) = (cst, st);
            }
        }
        if s.params.resolution > 0.0 {
            let (f, rest) = buf.split_at_mut(ln);
            let g = &mut rest[..ln];
            fs.snap_by(&mut t[..d], s.params.resolution, |tt| {
                fs.eval_pair(bs, tt, f, None, g, None);
                surface::affine_fit(&z, &c, &wt, f, g).0
            });
        }
        self.write_pose(&t[..d], out);
    }

    /// The pose `t` into `out`, circular values wrapped into [0, period).
    fn write_pose(&self, t: &[f64], out: &mut [f64]) {
        for ((o, &v), p) in out.iter_mut().zip(t).zip(self.meta.space.params()) {
            *o = match p.period {
                Some(per) => wrap_positive(v, per),
                None => v,
            };
        }
    }

    pub(crate) fn from_parts(meta: ModelMeta, t: &TensorSet) -> Result<Self> {
        let bad = |e: String| t.error(format!("damaged refined-eigenspace settings: {e}"));
        let settings: RefinedSettings = serde_json::from_value(meta.settings.clone()).map_err(|e| bad(e.to_string()))?;
        settings.params.validate().map_err(|e| bad(e.to_string()))?;
        let binning = Binning::new(meta.spec, settings.bin).map_err(|e| bad(e.to_string()))?;
        let (l, m, d) = (settings.components, binning.spec().features(), meta.space.len());
        if l == 0 || settings.knot_shape.len() != d || settings.knot_shape.iter().any(|&c| c == 0 || c > 1 << 16) {
            return Err(bad(format!("{l} components, knot shape {:?}", settings.knot_shape)));
        }
        let basis = t.f32("basis", &[l, m])?;
        let mean = t.f32("mean", &[m])?;
        let mut shape = settings.knot_shape.clone();
        shape.push(l);
        let knots = t.f32("knots", &shape)?;
        let background = t.f32("background", &shape)?;
        let mut axes = Vec::with_capacity(d);
        for (j, p) in meta.space.params().iter().enumerate() {
            let a = t.f64(&format!("knot_axis_{j}"), &[settings.knot_shape[j]])?;
            let span_ok = p.period.is_none_or(|per| a[a.len() - 1] - a[0] < per);
            if a.iter().any(|v| !v.is_finite()) || a.windows(2).any(|w| w[1] <= w[0]) || !span_ok {
                return Err(t.error(format!("knot positions of '{}' are not finite, increasing and within one period", p.name)));
            }
            axes.push(a);
        }
        if basis.iter().chain(&mean).chain(&knots).chain(&background).any(|v| !v.is_finite()) {
            return Err(t.error("the refined eigenspace holds non-finite values"));
        }
        let l_ok = settings.noise_components <= l && (settings.coord_variance.is_empty() || settings.coord_variance.len() == l);
        if !l_ok || settings.coord_variance.iter().any(|v| !(v.is_finite() && *v >= 0.0)) {
            return Err(bad(format!("noise match of {} components over {} variances", settings.noise_components, settings.coord_variance.len())));
        }
        RefinedModel::new(meta, settings, basis, mean, knots, background, axes).map_err(|e| t.error(e.to_string()))
    }
}

/// The scale sqrt(w_l) of each of `l` coordinates from their interpolation variances: w_l =
/// 1 / (sigma_l^2 + floor), the floor [`WEIGHT_FLOOR`] times the mean variance (so no coordinate
/// is trusted without bound); all ones without variances.
pub(crate) fn weights(sigma2: Option<&[f64]>, l: usize) -> Vec<f64> {
    match sigma2 {
        Some(s) => {
            let floor = (WEIGHT_FLOOR * s.iter().sum::<f64>() / l as f64).max(f64::MIN_POSITIVE);
            s.iter().map(|&v| (1.0 / (v + floor)).sqrt()).collect()
        }
        None => vec![1.0; l],
    }
}

/// The pixel noise of an image (rows of `w` pixels of `ch` interleaved channels) relative to its
/// energy: Immerkaer's estimate of the noise's standard deviation (Fast noise variance
/// estimation, CVIU 64:300-302, 1996: the mean absolute response to the difference of two
/// Laplacians, which cancels smooth shading and planes), squared and over the mean square pixel,
/// i.e. the variance each unit-energy coordinate gets from white noise, times M. Edges of a
/// clean image give it a floor, measured on the training images.
pub fn pixel_noise(x: &[f32], w: usize, h: usize, ch: usize) -> f64 {
    let ms = x.iter().map(|&v| v as f64 * v as f64).sum::<f64>() / x.len() as f64;
    if ms > 0.0 {
        pixel_variance(x, w, h, ch) / ms
    } else {
        0.0
    }
}

/// Immerkaer's estimate of the variance of an image's white noise (see [`pixel_noise`]).
pub fn pixel_variance(x: &[f32], w: usize, h: usize, ch: usize) -> f64 {
    pixel_variance_in(x, w, h, ch, &mut RowsF32::new(w * ch, h, ch), 0.0)
}

/// [`pixel_variance`] with the row buffer `rows` (of w x ch values), so a batch allocates it
/// once. With `early` > 0 it is staged: the estimate from the first quarter of the sampled rows
/// ([`Pass::First`]) when that is under `early` (the query is clearly clean: see
/// [`NOISE_EARLY`]), else the estimate from every sampled row, the same bits as unstaged.
fn pixel_variance_in(x: &[f32], w: usize, h: usize, ch: usize, rows: &mut RowsF32, early: f64) -> f64 {
    let pass = |rows: &mut RowsF32, pass: Pass| {
        #[cfg(target_arch = "x86_64")]
        if Level::detect().avx512() {
            // SAFETY: the CPU supports AVX-512 F/BW (detected).
            return unsafe { simd::pixel_variance_avx512(x, w, h, ch, rows, pass) };
        }
        immerkaer_pass(x, w, h, ch, rows, pass)
    };
    rows.sums.resize(sampled_rows(h), 0.0);
    staged(w, h, ch, rows, early, pass)
}

/// Immerkaer's variance from `pass` (a body summing the sampled rows a [`Pass`] takes, and
/// counting them), staged when `early` > 0 and at least two rows would be in the first pass:
/// the first pass's estimate when under `early`, else the whole sum from the first pass's and
/// the rest's ([`MaskRows::whole`]).
#[inline(always)]
fn staged<T, R: MaskRows<T>>(w: usize, h: usize, ch: usize, rows: &mut R, early: f64, pass: impl Fn(&mut R, Pass) -> (f64, usize)) -> f64 {
    let (sum, count) = if early > 0.0 && sampled_rows(h) >= 2 * FIRST_EVERY {
        let (first, count) = pass(rows, Pass::First);
        let v = variance_from(first, count, w * ch, ch);
        if v < early {
            return v;
        }
        let (rest, more) = pass(rows, Pass::Rest);
        (rows.whole(first, rest), count + more)
    } else {
        pass(rows, Pass::All)
    };
    variance_from(sum, count, w * ch, ch)
}

/// The bodies of [`pixel_variance`], [`pixel_variance_u8`] and [`smallest`] compiled for
/// AVX-512 (the same operations in the same order: the same bits, in wider vectors).
#[cfg(target_arch = "x86_64")]
mod simd {
    /// [`super::pixel_variance`] in AVX-512 registers, whole image in one call, with the
    /// portable body's bits: per sampled row the differences across its rows, 16 pixels a
    /// vector, the next vector's too, and from the two the differences at offsets ch and 2 ch
    /// (a permutation across both, as in [`pixel_variance_u8_avx512`]); the responses'
    /// absolute values summed in 16 f32 lanes (lane l taking response l of each vector, the
    /// last one partial, as [`super::RowsF32`] does), the lanes then added in f64.
    ///
    /// # Safety
    /// The CPU must support AVX-512 F and BW.
    #[target_feature(enable = "avx512f,avx512bw")]
    pub unsafe fn pixel_variance_avx512(x: &[f32], w: usize, h: usize, ch: usize, rows: &mut super::RowsF32, pass: super::Pass) -> (f64, usize) {
        use std::arch::x86_64::*;
        let row = w * ch;
        if w < 3 || h < 3 || 2 * ch > 16 || x.len() < row * h {
            return super::immerkaer_pass(x, w, h, ch, rows, pass);
        }
        let two = _mm512_set1_ps(2.0);
        macro_rules! diff {
            ($a:expr, $b:expr, $c:expr, $p:expr) => {{
                let p: usize = $p;
                let m = if p >= row { 0 } else { u16::MAX >> (16 - (row - p).min(16)) };
                let at = p.min(row);
                // SAFETY: masked to the row's values.
                let (av, bv, cv) =
                    unsafe { (_mm512_maskz_loadu_ps(m, $a.add(at)), _mm512_maskz_loadu_ps(m, $b.add(at)), _mm512_maskz_loadu_ps(m, $c.add(at))) };
                _mm512_add_ps(_mm512_sub_ps(av, _mm512_mul_ps(two, bv)), cv)
            }};
        }
        // Lane j of the shifted vectors: lane j + s of [cur, next].
        // SAFETY: 16 bytes from ch and from 2 ch lie within IOTA (2 ch <= 16).
        let (i1, i2) = unsafe {
            (
                _mm512_cvtepu8_epi32(_mm_loadu_si128(super::IOTA.as_ptr().add(ch) as *const _)),
                _mm512_cvtepu8_epi32(_mm_loadu_si128(super::IOTA.as_ptr().add(2 * ch) as *const _)),
            )
        };
        let n = row - 2 * ch;
        let (mut sum, mut count) = (0.0f64, 0usize);
        for (k, a, b, c) in super::SampledRows::new(x, row, h, pass) {
            let (a, b, c) = (a.as_ptr(), b.as_ptr(), c.as_ptr());
            let mut acc = _mm512_setzero_ps();
            let mut cur = diff!(a, b, c, 0);
            for q in (0..n).step_by(16) {
                let next = diff!(a, b, c, q + 16);
                let d1 = _mm512_permutex2var_ps(cur, i1, next);
                let d2 = _mm512_permutex2var_ps(cur, i2, next);
                let v = _mm512_add_ps(_mm512_sub_ps(cur, _mm512_mul_ps(two, d1)), d2);
                // The last vector's responses past n are 0 (adding 0 leaves a lane's sum).
                let keep = if q + 16 <= n { u16::MAX } else { u16::MAX >> (16 - (n - q)) };
                acc = _mm512_add_ps(acc, _mm512_maskz_mov_ps(keep, _mm512_abs_ps(v)));
                cur = next;
            }
            let mut lanes = [0f32; 16];
            // SAFETY: 16 f32.
            unsafe { _mm512_storeu_ps(lanes.as_mut_ptr(), acc) };
            let mut lane_sum = -0.0f64;
            for v in lanes {
                lane_sum += v as f64;
            }
            rows.sums[k] = lane_sum;
            sum += lane_sum;
            count += 1;
        }
        (sum, count)
    }

    /// [`super::pixel_variance_u8`] in AVX-512 BW registers, whole image in one call (a call
    /// per row cost as much as the row's 4 vectors at 128 pixels): per sampled row, the
    /// differences across its rows, 32 pixels a vector in i16 (0 past the row), the next
    /// vector's too, and from the two the differences at offsets ch and 2 ch (a permutation
    /// across both, in registers; written out and read back at those offsets, as the portable
    /// body does, each load waited on the store); the mask's responses' absolute values (0 past
    /// the row's responses) summed in
    /// pairs into 16 u32 lanes, flushed to u64 twice as often as `rows` says for its 32 lanes.
    /// The same integer sum, so the same value.
    ///
    /// # Safety
    /// The CPU must support AVX-512 F, BW and VL.
    #[target_feature(enable = "avx512f,avx512bw,avx512vl")]
    pub unsafe fn pixel_variance_u8_avx512(x: &[u8], w: usize, h: usize, ch: usize, rows: &mut super::RowsU8, pass: super::Pass) -> (f64, usize) {
        use std::arch::x86_64::*;
        let row = w * ch;
        if w < 3 || h < 3 || 2 * ch > 32 || x.len() < row * h {
            return super::immerkaer_pass(x, w, h, ch, rows, pass);
        }
        // (Macros, not closures: a closure does not take the function's target features, and
        // its intrinsics were called, not inlined.)
        macro_rules! diff {
            ($a:expr, $b:expr, $c:expr, $p:expr) => {{
                let p: usize = $p;
                let m = if p >= row { 0 } else { u32::MAX >> (32 - (row - p).min(32)) };
                let at = p.min(row);
                // SAFETY: masked to the row's pixels.
                let (av, bv, cv) = unsafe {
                    (
                        _mm512_cvtepu8_epi16(_mm256_maskz_loadu_epi8(m, $a.add(at) as *const i8)),
                        _mm512_cvtepu8_epi16(_mm256_maskz_loadu_epi8(m, $b.add(at) as *const i8)),
                        _mm512_cvtepu8_epi16(_mm256_maskz_loadu_epi8(m, $c.add(at) as *const i8)),
                    )
                };
                _mm512_sub_epi16(_mm512_add_epi16(av, cv), _mm512_add_epi16(bv, bv))
            }};
        }
        // Lane j of the shifted vectors: lane j + s of [cur, next] (from a constant: an index
        // array written on the stack stalled the vector load of it).
        // SAFETY: 32 bytes from ch and from 2 ch lie within IOTA (2 ch <= 32).
        let (i1, i2) = unsafe {
            (
                _mm512_cvtepu8_epi16(_mm256_loadu_si256(super::IOTA.as_ptr().add(ch) as *const _)),
                _mm512_cvtepu8_epi16(_mm256_loadu_si256(super::IOTA.as_ptr().add(2 * ch) as *const _)),
            )
        };
        let n32 = rows.keep.len();
        assert!(n32 >= row - 2 * ch && n32.is_multiple_of(32));
        // Each lane takes two responses a vector, twice the portable lanes' bound.
        let (mut acc, ones, flush_every) = (_mm512_setzero_si512(), _mm512_set1_epi16(1), (rows.flush_every / 2).max(1));
        let (mut total, mut since, mut count) = (0u64, 0usize, 0usize);
        for (_, a, b, c) in super::SampledRows::new(x, row, h, pass) {
            let (a, b, c) = (a.as_ptr(), b.as_ptr(), c.as_ptr());
            let mut cur = diff!(a, b, c, 0);
            for q in (0..n32).step_by(32) {
                let next = diff!(a, b, c, q + 32);
                let d1 = _mm512_permutex2var_epi16(cur, i1, next);
                let d2 = _mm512_permutex2var_epi16(cur, i2, next);
                let v = _mm512_abs_epi16(_mm512_sub_epi16(_mm512_add_epi16(cur, d2), _mm512_add_epi16(d1, d1)));
                // SAFETY: q + 32 <= n32 = keep.len().
                let v = _mm512_and_si512(v, unsafe { _mm512_loadu_si512(rows.keep.as_ptr().add(q) as *const _) });
                // Pairs of responses summed into i32 lanes (at most 4080 a vector).
                acc = _mm512_add_epi32(acc, _mm512_madd_epi16(v, ones));
                cur = next;
            }
            count += 1;
            since += 1;
            if since == flush_every {
                total += crate::kernels::sum_u32_lanes(acc);
                (acc, since) = (_mm512_setzero_si512(), 0);
            }
        }
        total += crate::kernels::sum_u32_lanes(acc);
        (total as f64, count)
    }

    /// # Safety
    /// The CPU must support AVX-512 F and BW.
    #[target_feature(enable = "avx512f,avx512bw")]
    pub unsafe fn smallest_avx512(dist: &[f32], k: usize, lo: f32) -> Vec<(f32, usize)> {
        super::smallest_body(dist, k, lo)
    }
}

/// Immerkaer's estimate (see [`pixel_noise`]) from every [`NOISE_ROW_STEP`]-th row of an image
/// of `w` pixels of `ch` channels per row: the estimate is a mean over pixels, and a sample of
/// rows costs less than the projection. `rows` sums the absolute mask responses along each.
#[cfg(test)]
fn immerkaer<T, R: MaskRows<T>>(x: &[T], w: usize, h: usize, ch: usize, rows: &mut R) -> f64 {
    let (sum, count) = immerkaer_pass(x, w, h, ch, rows, Pass::All);
    variance_from(sum, count, w * ch, ch)
}

/// The sum of the absolute mask responses along the sampled rows `pass` takes, and how many
/// rows those are (none in an image of fewer than 3 rows or columns).
#[inline(always)]
fn immerkaer_pass<T, R: MaskRows<T>>(x: &[T], w: usize, h: usize, ch: usize, rows: &mut R, pass: Pass) -> (f64, usize) {
    if w < 3 || h < 3 {
        return (0.0, 0);
    }
    let (mut sum, mut count) = (0.0f64, 0usize);
    for (k, a, b, c) in SampledRows::new(x, w * ch, h, pass) {
        let s = rows.row_sum(a, b, c);
        rows.keep(k, s);
        sum += s;
        count += 1;
    }
    sum += rows.total();
    (sum, count)
}

/// How many rows [`immerkaer`] samples in an image of `h` rows: rows 1, 1 + [`NOISE_ROW_STEP`],
/// .. up to h - 2.
fn sampled_rows(h: usize) -> usize {
    if h < 3 {
        0
    } else {
        (h - 3) / NOISE_ROW_STEP + 1
    }
}

/// Which of the sampled rows a pass of the noise estimate sums: all of them, or, for a query
/// that may be clearly clean ([`pixel_variance_in`]'s `early`), first every [`FIRST_EVERY`]-th
/// (from sampled row [`FIRST_AT`]) and then, unless those settle it, the rest.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Pass {
    All,
    First,
    Rest,
}

/// The first pass of a staged noise estimate takes every this many sampled rows...
const FIRST_EVERY: usize = 4;
/// ... from this one (rows 17, 49, 81, 113 of a 128-row image: away from the top edge, which on a
/// turntable is background).
const FIRST_AT: usize = 2;

impl Pass {
    /// Whether this pass sums sampled row `k`.
    #[inline(always)]
    fn takes(self, k: usize) -> bool {
        match self {
            Pass::All => true,
            Pass::First => k % FIRST_EVERY == FIRST_AT,
            Pass::Rest => k % FIRST_EVERY != FIRST_AT,
        }
    }

    /// The first sampled row after `k` this pass sums (`None`: the first of all).
    #[inline(always)]
    fn after(self, k: Option<usize>) -> usize {
        let mut k = k.map_or(0, |k| k + 1);
        while !self.takes(k) {
            k += 1;
        }
        k
    }
}

/// The rows [`immerkaer`] samples that a [`Pass`] sums, each as its index among the sampled
/// rows with the rows above and below it (an image of `row` values a row, at least 3 rows); the
/// next sample's cache lines are asked for while one is summed (they are too far apart for the
/// hardware prefetcher).
struct SampledRows<'a, T> {
    x: &'a [T],
    row: usize,
    /// The next sampled row to give, and how many there are.
    k: usize,
    n: usize,
    pass: Pass,
}

impl<'a, T> SampledRows<'a, T> {
    #[inline(always)]
    fn new(x: &'a [T], row: usize, h: usize, pass: Pass) -> Self {
        assert!(h >= 3 && x.len() >= row * h, "an image of at least 3 rows of {row} values");
        let k = pass.after(None);
        let rows = SampledRows { x, row, k, n: sampled_rows(h), pass };
        rows.prefetch(pass.after(Some(k)));
        rows
    }

    /// Asks for the cache lines of sampled row `k` and its neighbours (if there is such a row).
    #[inline(always)]
    fn prefetch(&self, k: usize) {
        if k < self.n {
            let yy = 1 + NOISE_ROW_STEP * k;
            prefetch(&self.x[(yy - 1) * self.row..(yy + 2) * self.row]);
        }
    }
}

impl<'a, T> Iterator for SampledRows<'a, T> {
    type Item = (usize, &'a [T], &'a [T], &'a [T]);

    #[inline(always)]
    fn next(&mut self) -> Option<Self::Item> {
        let (x, row, k) = (self.x, self.row, self.k);
        if k >= self.n {
            return None;
        }
        self.k = self.pass.after(Some(k));
        self.prefetch(self.pass.after(Some(self.k)));
        let yy = 1 + NOISE_ROW_STEP * k;
        Some((k, &x[(yy - 1) * row..yy * row], &x[yy * row..(yy + 1) * row], &x[(yy + 1) * row..(yy + 2) * row]))
    }
}

/// 0, 1, .., 63: the permutation indices of [`simd`]'s shifted vectors, widened to each
/// lane's width where they are loaded.
#[cfg(target_arch = "x86_64")]
static IOTA: [u8; 64] = {
    let mut v = [0u8; 64];
    let mut j = 0;
    while j < 64 {
        v[j] = j as u8;
        j += 1;
    }
    v
};

/// Immerkaer's variance from the sum of the mask's absolute responses over `count` rows of
/// `row` values of `ch` channels (less `ch` at each end); 0 without any.
fn variance_from(sum: f64, count: usize, row: usize, ch: usize) -> f64 {
    if count == 0 || row <= 2 * ch {
        return 0.0;
    }
    let total = ((row - 2 * ch) * count) as f64;
    let sigma = (std::f64::consts::PI / 2.0).sqrt() * sum / (6.0 * total);
    sigma * sigma
}

/// Hints every cache line of `v` into the caches (nothing off x86-64).
#[inline(always)]
fn prefetch<T>(v: &[T]) {
    #[cfg(target_arch = "x86_64")]
    {
        let (p, bytes) = (v.as_ptr() as *const i8, std::mem::size_of_val(v));
        for off in (0..bytes).step_by(64) {
            // SAFETY: a prefetch never faults; the address lies inside `v`.
            unsafe { std::arch::x86_64::_mm_prefetch::<{ std::arch::x86_64::_MM_HINT_T0 }>(p.add(off)) };
        }
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = v;
}

/// The row sums of [`immerkaer`]: the absolute responses along row b (its neighbours a and c) of
/// the second difference along x of the second difference across the three rows, over the row's
/// pixels less `ch` at each end. A trait with always-inlined methods (not a closure), so that the
/// AVX-512 builds of [`pixel_variance`] and [`pixel_variance_u8`] compile it for AVX-512 too.
trait MaskRows<T> {
    fn row_sum(&mut self, a: &[T], b: &[T], c: &[T]) -> f64;
    /// Keeps sampled row `k`'s sum `s` (as returned by `row_sum`) where the rows are summed
    /// again in their order (nothing by default).
    #[inline(always)]
    fn keep(&mut self, _k: usize, _s: f64) {}
    /// The sum over every sampled row from a staged estimate's two passes' sums (their sum by
    /// default: exact for integer sums).
    #[inline(always)]
    fn whole(&self, first: f64, rest: f64) -> f64 {
        first + rest
    }
    /// What the rows summed without returning it (0 when each row returns its own).
    fn total(&mut self) -> f64 {
        0.0
    }
}

/// f32 rows: the differences across rows into `dy`, then 16 lane sums so the loop vectorises
/// (the row's last responses into the first lanes, as a partial vector); each sampled row's sum
/// kept in `sums`, so a staged estimate adds them up in one pass's order.
struct RowsF32 {
    dy: Vec<f32>,
    sums: Vec<f64>,
    ch: usize,
}

impl RowsF32 {
    /// Made for an image of `h` rows of `row` values of `ch` channels.
    fn new(row: usize, h: usize, ch: usize) -> RowsF32 {
        RowsF32 { dy: vec![0f32; row], sums: vec![0.0; sampled_rows(h)], ch }
    }

    /// The buffer in `slot` (new if none) made for rows of `row` values of `ch` channels (every
    /// row overwrites it whole).
    fn reuse(slot: &mut Option<RowsF32>, row: usize, ch: usize) -> &mut RowsF32 {
        let r = slot.get_or_insert_with(|| RowsF32::new(row, 0, ch));
        r.ch = ch;
        r.dy.resize(row, 0.0);
        r
    }
}

impl MaskRows<f32> for RowsF32 {
    #[inline(always)]
    fn keep(&mut self, k: usize, s: f64) {
        self.sums[k] = s;
    }

    /// Every sampled row's kept sum, added in the order of one pass over them all (the same
    /// bits as unstaged).
    #[inline(always)]
    fn whole(&self, _first: f64, _rest: f64) -> f64 {
        self.sums.iter().fold(0.0, |s, &v| s + v)
    }

    #[inline(always)]
    fn row_sum(&mut self, a: &[f32], b: &[f32], c: &[f32]) -> f64 {
        let (dy, ch) = (&mut self.dy, self.ch);
        let n = dy.len() - 2 * ch;
        dy.iter_mut().zip(a.iter().zip(b).zip(c)).for_each(|(d, ((&p, &q), &r))| *d = p - 2.0 * q + r);
        let (d0, d1, d2) = (&dy[..n], &dy[ch..ch + n], &dy[2 * ch..2 * ch + n]);
        let mut lanes = [0f32; 16];
        let (c0, c1, c2) = (d0.chunks_exact(16), d1.chunks_exact(16), d2.chunks_exact(16));
        let (t0, t1, t2) = (c0.remainder(), c1.remainder(), c2.remainder());
        for ((p, q), r) in c0.zip(c1).zip(c2) {
            for l in 0..16 {
                lanes[l] += (p[l] - 2.0 * q[l] + r[l]).abs();
            }
        }
        // The rest into the first lanes (as a last, partial vector).
        for l in 0..t0.len() {
            lanes[l] += (t0[l] - 2.0 * t1[l] + t2[l]).abs();
        }
        let mut sum = -0.0f64;
        for v in lanes {
            sum += v as f64;
        }
        sum
    }
}

/// 8-bit rows, exact in integers: the differences across rows (within +-510) and the mask's
/// responses (within +-2040) in i16 lanes, over whole vectors of 32 (responses past the row's end
/// masked to 0), summed in 32 u32 lanes across rows and added up once per image (an integer sum:
/// the same value in any order), flushed to u64 before a lane could pass 2^32.
struct RowsU8 {
    /// The differences across rows, zero past the row's end.
    dy: Vec<i16>,
    /// All ones for the row's responses, 0 past them.
    keep: Vec<u16>,
    acc: [u32; 32],
    rows: usize,
    flush_every: usize,
    total: u64,
    ch: usize,
}

impl RowsU8 {
    /// The buffers in `slot` when they are made for rows of `row` values of `ch` channels, else
    /// new ones put there.
    fn reuse(slot: &mut Option<RowsU8>, row: usize, ch: usize) -> &mut RowsU8 {
        // The mask's length and the channels fix every buffer's (see new).
        if !slot.as_ref().is_some_and(|r| r.ch == ch && r.keep.len() == row.saturating_sub(2 * ch).div_ceil(32) * 32) {
            *slot = Some(RowsU8::new(row, ch));
        }
        slot.as_mut().expect("just filled")
    }

    fn new(row: usize, ch: usize) -> RowsU8 {
        let n = row.saturating_sub(2 * ch);
        let n32 = n.div_ceil(32) * 32;
        let mut keep = vec![0u16; n32];
        keep[..n].fill(u16::MAX);
        let flush_every = (u32::MAX as usize / ((n32 / 32).max(1) * 2040)).max(1);
        RowsU8 { dy: vec![0i16; n32 + 2 * ch], keep, acc: [0; 32], rows: 0, flush_every, total: 0, ch }
    }

    #[inline(always)]
    fn flush(&mut self) {
        self.total += self.acc.iter().map(|&v| v as u64).sum::<u64>();
        (self.acc, self.rows) = ([0; 32], 0);
    }
}

impl MaskRows<u8> for RowsU8 {
    #[inline(always)]
    fn row_sum(&mut self, a: &[u8], b: &[u8], c: &[u8]) -> f64 {
        let ch = self.ch;
        self.dy.iter_mut().zip(a.iter().zip(b).zip(c)).for_each(|(d, ((&p, &q), &r))| *d = p as i16 - 2 * q as i16 + r as i16);
        let n32 = self.keep.len();
        let (d0, d1, d2) = (&self.dy[..n32], &self.dy[ch..ch + n32], &self.dy[2 * ch..2 * ch + n32]);
        for (((p, q), r), m) in d0.chunks_exact(32).zip(d1.chunks_exact(32)).zip(d2.chunks_exact(32)).zip(self.keep.chunks_exact(32)) {
            for l in 0..32 {
                self.acc[l] += ((p[l] - 2 * q[l] + r[l]).unsigned_abs() & m[l]) as u32;
            }
        }
        self.rows += 1;
        if self.rows == self.flush_every {
            self.flush();
        }
        0.0
    }

    #[inline(always)]
    fn total(&mut self) -> f64 {
        self.flush();
        let t = self.total;
        self.total = 0;
        t as f64
    }
}

/// [`pixel_variance`] of an 8-bit image given as raw pixel values, in their units (255^2 times
/// that of its features, pixel / 255): the same mask and rows, summed exactly in integers (the
/// f32 path rounds, so the two agree to about 1e-6 relative).
pub fn pixel_variance_u8(x: &[u8], w: usize, h: usize, ch: usize) -> f64 {
    pixel_variance_u8_in(x, w, h, ch, &mut RowsU8::new(w * ch, ch), 0.0)
}

/// [`pixel_variance_u8`] with the row buffers `rows` (made for rows of w x ch values), so a
/// batch allocates them once; staged when `early` > 0, as [`pixel_variance_in`] (the two
/// passes' integer sums add up to the one pass's exactly).
fn pixel_variance_u8_in(x: &[u8], w: usize, h: usize, ch: usize, rows: &mut RowsU8, early: f64) -> f64 {
    let pass = |rows: &mut RowsU8, pass: Pass| {
        #[cfg(target_arch = "x86_64")]
        if Level::detect().avx512_vl() {
            // SAFETY: the CPU supports AVX-512 F/BW/VL (detected).
            return unsafe { simd::pixel_variance_u8_avx512(x, w, h, ch, rows, pass) };
        }
        immerkaer_pass(x, w, h, ch, rows, pass)
    };
    staged(w, h, ch, rows, early, pass)
}

/// Coordinates of the coarse points' bounding boxes ([`RefinedModel::start_boxes`],
/// [`crate::kernels::scan::sq_dist_boxed`]) of a model of `l`: the leading 8. perf of duck's
/// 8-bit views on one thread, the scan's samples over the product kernel's: boxes on 4
/// coordinates 0.48, 8 0.38 and 0.39, 12 0.43 and 0.44; the partial sums on 4 coordinates that
/// came before them 0.47.
fn box_split(l: usize) -> usize {
    8.min(l)
}

/// Whether a model with these settings uses the residual (the mean's products): see
/// [`RefinedModel::uses_residual`].
fn uses_residual(settings: &RefinedSettings) -> bool {
    !settings.interpolation_variance.is_empty()
}

/// The items of `xs` (runs of `m`) at `sel` (all when None) and their count: `xs` itself when
/// those are all of them, else a copy of them in `buf`.
fn selected<'a, T: Copy>(xs: &'a [T], m: usize, sel: Option<&[usize]>, buf: &'a mut Vec<T>) -> (&'a [T], usize) {
    let n = xs.len() / m;
    match sel {
        Some(sel) if sel.len() < n => {
            buf.clear();
            sel.iter().for_each(|&j| buf.extend_from_slice(&xs[j * m..(j + 1) * m]));
            (buf, sel.len())
        }
        _ => (xs, n),
    }
}

/// The products `out` (rows of `k`, one per selected query: those at `sel`, else all) into
/// `raw` (rows of `kr`) of the task's queries i0 + j, from column `col`.
fn scatter(out: &[f32], k: usize, sel: Option<&[usize]>, i0: usize, kr: usize, col: usize, raw: &mut [f32]) {
    for (t, o) in out.chunks_exact(k).enumerate() {
        let i = i0 + sel.map_or(t, |sel| sel[t]);
        raw[i * kr + col..i * kr + col + k].copy_from_slice(o);
    }
}

/// 8-bit queries per sub-chunk of [`RefinedModel::project_u8`]: whole register blocks of
/// [`dot_u8::BATCH_IMAGES`] and whole groups of [`dot_q::dots_batch`], and few enough that their
/// images (19.2 KB each at 160 x 120) are still in the L2 cache when the noise pass reads them
/// after the products (with the chunk's 192, that pass read them from memory: 2 us of a 17 us
/// query on one thread).
const NOISE_SUB_U8: usize = 8 * dot_u8::BATCH_IMAGES;
const _: () = assert!(NOISE_SUB_U8.is_multiple_of(dot_q::GROUP * dot_q::BLOCK));

/// f32 queries per sub-chunk of [`RefinedModel::project_f32`] (77 KB each at 160 x 120), for the
/// same reason, when the task's queries come to more than [`NOISE_SUB_F32_BYTES`].
const NOISE_SUB_F32: usize = 16;
/// Up to this many bytes, a task's f32 queries go as one product: a sub-chunk's product packs its
/// queries in blocks of 32 rows, so a task split into 16 and 2 (COIL's 72 views on one thread)
/// packed twice as much as one of 18 (perf: the pack 4,364 samples against the eigenspace's
/// 2,237, of 14,145 in all), and 18 COIL images (1.2 MB) stay in the 2 MB L2 cache anyway.
const NOISE_SUB_F32_BYTES: usize = 5 << 18;

/// Coordinates of the noisy scan's first pass ([`NoiseScan::scan`]) for a match on `ln`: half
/// of them, from 16 on (0: no first pass). The fit's two free parameters absorb much of a few
/// coordinates, so fewer prune little: at +-5% on the paper's grid, blocks of 64 coarse points
/// summed in full with 4 of twin's 12: 67%, 6: 18%, 8: 7.5%; duck (12) with 6: 6.5%, cap (16)
/// with 8: 4.6%, pot (20) with 10: 5.4% (with 6: 27%). The first pass costs a residual per point
/// too, so it pays from 16 on: perf of 8-bit +-5% queries, the scan's time over the product
/// kernel's, pot 1.58 -> 1.23, cap 1.31 -> 1.10 (two runs), but duck (12) 1.61 -> 1.72.
fn noise_scan_split(ln: usize) -> usize {
    if ln >= 16 {
        ln / 2
    } else {
        0
    }
}

/// Most lattice poses of a one-parameter model searched exactly ([`lattice::Lattice`]; 720 at the
/// default 0.5 degrees on a turntable); a finer `resolution` keeps the local search and snap.
pub const MAX_LATTICE: usize = 16_384;

/// Rows sampled by [`pixel_noise`].
const NOISE_ROW_STEP: usize = 8;

/// What a query's projection computes of its pixel noise.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum NoiseWant {
    /// Nothing (a model without the noisy match).
    None,
    /// The whole estimate: the noisy match weights its coordinates by it.
    Full,
    /// Enough to route the query: staged, a query whose first pass is under [`NOISE_EARLY`]
    /// times the threshold is clean without the rest.
    Route,
}

/// Where a staged pixel-noise estimate stops, relative to the model's noise threshold: a query
/// whose estimate from the first quarter of the sampled rows ([`Pass::First`]) is under half
/// the threshold is taken as clean without the rest (the estimate from every sampled row, as
/// unstaged, decides every other). The first quarter's estimate of a noisy image is near the
/// whole's: on the rendered objects' views (every 4th) and COIL-20's 72 per object under
/// simulated +-5% and +-10% noise, at least 1.06 times the threshold (COIL-9, whose least whole
/// estimate is 1.06 times it too), so half leaves a margin of 2. It stops at least 92% of the
/// clean views of 18 of those 25 objects, 88% of COIL-20's 1440 clean views in all, the least
/// COIL-17's 53% (whose clean views come to 0.45 times the threshold). (A numpy replica of the
/// 8-bit estimate on the image files; BENCHMARKS.md, fifteenth session.)
const NOISE_EARLY: f64 = 0.5;

/// The `k` smallest of `dist` no more than twice the smallest (the only ones
/// [`RefinedModel::distinct_starts`] keeps), with their indices, in increasing order (ties: the
/// lower index). Two passes: the minimum (vectorised), then the few points under twice it.
/// `k` is at least 1.
fn smallest(dist: &[f32], k: usize) -> Vec<(f32, usize)> {
    smallest_under(dist, k, crate::kernels::scan::least(Level::detect(), dist))
}

/// [`smallest`] given the least of `dist`, `lo`.
fn smallest_under(dist: &[f32], k: usize, lo: f32) -> Vec<(f32, usize)> {
    #[cfg(target_arch = "x86_64")]
    if Level::detect().avx512() {
        // SAFETY: the CPU supports AVX-512 F/BW (detected).
        return unsafe { simd::smallest_avx512(dist, k, lo) };
    }
    smallest_body(dist, k, lo)
}

/// The body of [`smallest_under`] (compiled for AVX-512 too: comparisons only, the same result).
#[inline(always)]
fn smallest_body(dist: &[f32], k: usize, lo: f32) -> Vec<(f32, usize)> {
    let cut = 2.0 * lo.max(0.0) + f32::MIN_POSITIVE;
    let mut best: Vec<(f32, usize)> = Vec::with_capacity(k + 1);
    // Blocks of 16 tested without branches first: few hold a point under the cut.
    for (b, c) in dist.chunks(16).enumerate() {
        if !c.iter().fold(false, |hit, &v| hit | (v <= cut)) {
            continue;
        }
        for (i, &v) in c.iter().enumerate() {
            if v <= cut && (best.len() < k || v < best[best.len() - 1].0) {
                let at = best.partition_point(|b| b.0 <= v);
                best.insert(at, (v, 16 * b + i));
                best.truncate(k);
            }
        }
    }
    best
}

/// The scale sqrt(w) of each of `l` coordinates: [`weights`] for the first `ls`, 1 for the rest.
fn search_scale(sigma2: Option<&[f64]>, ls: usize, l: usize) -> Vec<f64> {
    let mut s = weights(sigma2, ls);
    s.resize(l, 1.0);
    s
}

/// Queries projected and refined together by one rayon task (as the eigenspace chunks them).
fn chunk_rows(n: usize) -> usize {
    n.div_ceil(4 * rayon::current_num_threads().max(1)).clamp(8, 128)
}

impl RefinedModel {
    /// Estimates a batch (rows of M) through the noisy match whatever the queries' noise: how
    /// the automatic choice scores its candidates.
    pub(crate) fn predict_noisy(&self, queries: &[f32]) -> Result<Vec<f64>> {
        assert!(self.noisy_tree.is_some() || !self.noise_scan.w0.is_empty(), "the noisy match is set (set_noise_match)");
        let (l, m, p) = (self.components(), self.meta.spec.features(), self.meta.space.len());
        let n = queries.len() / m;
        let mut out = vec![0.0; n * p];
        let rows = chunk_rows(n);
        queries.par_chunks(rows * m).zip(out.par_chunks_mut(rows * p)).for_each_init(QueryScratch::default, |s, (q, o)| {
            self.project_binned(q, NoiseWant::Full, s);
            for ((c, o), &nu) in s.y.chunks_exact(l).zip(o.chunks_exact_mut(p)).zip(&s.noise) {
                if c[0].is_nan() {
                    o.fill(f64::NAN);
                } else {
                    self.pose_of_noisy(c, nu, o);
                }
            }
        });
        Ok(out)
    }
}

/// A clean query's search buffers (one per thread): the weights, in f64 and f32, the coarse
/// points' distances and the local search's scratch.
#[derive(Default)]
struct SearchScratch {
    wt: Vec<f64>,
    w32: Vec<f32>,
    dist: Vec<f32>,
    buf: Vec<f64>,
    lb: Vec<f32>,
    /// The noisy tree's points near a query ([`NoisyTree::starts`]).
    near: Vec<(f32, u32)>,
}

thread_local! {
    static SEARCH_SCRATCH: std::cell::RefCell<SearchScratch> = std::cell::RefCell::new(SearchScratch::default());
}

/// A query task's buffers: coordinates (rows of L), residuals and noise, the products (rows of
/// 1 + L: the mean's, then the eigenimages', see [`RefinedModel::finish_query`]), the 8-bit
/// queries' energies and the 8-bit products' buffers.
#[derive(Default)]
struct QueryScratch {
    y: Vec<f32>,
    resid: Vec<f64>,
    noise: Vec<f64>,
    raw: Vec<f32>,
    /// Whether each query goes to the noisy match, its pixel noise, and the buffers of a pass
    /// over some of a sub-chunk's queries: which (two lists), a copy of their images, their
    /// products and sums of squares.
    noisy: Vec<bool>,
    pv: Vec<f64>,
    xidx: Vec<usize>,
    xidx2: Vec<usize>,
    gather_f32: Vec<f32>,
    gather_u8: Vec<u8>,
    xout: Vec<f32>,
    xenergy: Vec<u64>,
    energy: Vec<u64>,
    products: dot_q::Scratch,
    rows_u8: Option<RowsU8>,
    rows_f32: Option<RowsF32>,
    /// Binned f32 queries and the binning's scratch, when the model bins; each query's energy
    /// (of the image projected), and when it bins, its route's value and pixel noise measured
    /// on the image as given, and that estimate's row buffers.
    binned: Vec<f32>,
    bin_acc: Vec<f32>,
    benergy: Vec<f64>,
    route: Vec<f64>,
    pv_full: Vec<f64>,
    rows_f32_full: Option<RowsF32>,
    rows_u8_full: Option<RowsU8>,
}

/// 8-bit queries per sub-chunk of the 16-bit products of [`RefinedModel::project_u8_binned`]:
/// whole register blocks, and few enough that their sums (9.6 KB each at 160 x 120 by 2) are
/// still in the L2 cache for the products (a task's 192 held 1.8 MB).
const BIN_SUB_U8: usize = 4 * dot_w::BLOCK;

/// A thread's buffers for binned 8-bit queries ([`RefinedModel::project_u8_binned`]): for the
/// 8-bit products, a task's block sums, their digit planes, the planes' products and sums of
/// squares; for the 16-bit ones, a sub-chunk's sums in lines and the kernel's step list; the
/// binning's scratch. Per thread, not per task, so that the buffers are not allocated for
/// every task.
#[derive(Default)]
struct BinScratch {
    planes: Vec<u8>,
    sums: Vec<u16>,
    acc: Vec<u16>,
    raw: Vec<f32>,
    energy: Vec<u64>,
    lines: Vec<dot_w::Line>,
    lines_x: Vec<dot_w::Line>,
    idx: Vec<u32>,
}

thread_local! {
    static BIN_SCRATCH: std::cell::RefCell<BinScratch> = std::cell::RefCell::new(BinScratch::default());
}

impl QueryScratch {
    /// Room for `n` queries of `l` coordinates (the products: 1 + l a query; the routes already
    /// in `noisy` are kept).
    fn resize(&mut self, n: usize, l: usize) {
        self.y.resize(n * l, 0.0);
        self.resid.resize(n, 0.0);
        self.noise.resize(n, 0.0);
        self.raw.resize(n * (1 + l), 0.0);
        self.noisy.resize(n, false);
        self.pv.resize(n, 0.0);
        self.energy.resize(n, 0);
        self.benergy.resize(n, 0.0);
    }
}

/// The error for the first query left NaN (zero or non-finite energy), if any.
fn no_black_query(out: &[f64], p: usize) -> Result<()> {
    match out.chunks_exact(p).position(|o| o[0].is_nan()) {
        Some(i) => Err(Error::invalid(
            "query",
            format!("#{i} of the batch"),
            "the image is all black or not finite (zero or non-finite energy), so it cannot be scaled to unit energy",
        )),
        None => Ok(()),
    }
}

impl RefinedModel {
    /// The poses of a task's projected queries into `out` (NaN for a query that could not be
    /// projected).
    fn poses_of(&self, s: &QueryScratch, out: &mut [f64]) {
        let (l, m, p) = (self.components(), self.m, self.meta.space.len());
        for (i, ((c, o), &r)) in s.y.chunks_exact(l).zip(out.chunks_exact_mut(p)).zip(&s.resid).enumerate() {
            if c[0].is_nan() {
                o.fill(f64::NAN);
            } else if self.binning.bins() {
                self.pose_routed(c, r, s.route[i], s.noise[i], o);
            } else {
                self.pose_of_coords(c, r, s.noise[i] * m as f64, o);
            }
        }
    }
}

impl RefinedModel {
    /// What a query's projection computes of its pixel noise: enough to route it, when the
    /// model has the noisy match.
    fn noise_want(&self) -> NoiseWant {
        if self.settings.noise_threshold > 0.0 {
            NoiseWant::Route
        } else {
            NoiseWant::None
        }
    }

    /// [`Self::project_f32`] of f32 queries as given: binned first when the model bins. Then
    /// the query's pixel noise is measured on the image as given, where noise stands out from
    /// the image's own detail at every factor (least +-5% estimate over largest clean one on
    /// duck's training views: 53.9 as given, 4.1 binned by 2, 0.69 by 4, where no threshold
    /// separates them), routing it against the threshold of the training images as given;
    /// the noisy match's nu is that noise binned (pv / b^2 for independent noise) per unit
    /// energy of the binned image.
    fn project_binned(&self, queries: &[f32], noise: NoiseWant, s: &mut QueryScratch) {
        if !self.binning.bins() {
            return self.project_f32(queries, noise, false, s);
        }
        let mut binned = std::mem::take(&mut s.binned);
        let (m, mb) = (self.meta.spec.features(), self.m);
        let n = queries.len() / m;
        binned.resize(n * mb, 0.0);
        s.route.resize(n, 0.0);
        s.pv_full.resize(n, 0.0);
        s.noisy.resize(n, false);
        let full = self.binning.full();
        let (w, h, ch) = (full.width as usize, full.height as usize, full.color.channels());
        // Each image binned, and its pixel noise measured as given (where noise stands out
        // from the image's own detail; binning averages it away faster than the detail), which
        // routes it.
        for (i, (x, o)) in queries.chunks_exact(m).zip(binned.chunks_exact_mut(mb)).enumerate() {
            self.binning.apply(x, o, &mut s.bin_acc);
            let energy = crate::linalg::energy(x);
            let pv = match self.early(noise, energy, m) {
                Some(early) => pixel_variance_in(x, w, h, ch, RowsF32::reuse(&mut s.rows_f32_full, w * ch, ch), early),
                None => 0.0,
            };
            (s.route[i], s.pv_full[i]) = (pv * m as f64 / energy, pv);
            s.noisy[i] = self.routed_noisy(noise, s.route[i]);
        }
        self.project_f32(&binned, NoiseWant::None, true, s);
        // The noisy match's nu: the noise of a binned pixel (pv / b^2, independent noise) per
        // unit energy of the binned image.
        let b2 = (self.binning.factor() * self.binning.factor()) as f64;
        for ((nu, &pv), &e) in s.noise.iter_mut().zip(&s.pv_full).zip(&s.benergy) {
            *nu = pv / (b2 * e);
        }
        s.binned = binned;
    }

    /// [`PoseModel::predict_into`], computing `noise` of each query's pixel noise.
    fn predict_with(&self, queries: &[f32], noise: NoiseWant, out: &mut [f64]) -> Result<()> {
        let (m, p) = (self.meta.spec.features(), self.meta.space.len());
        let n = batch_len(m, queries.len(), out.len(), p)?;
        let rows = chunk_rows(n);
        queries.par_chunks(rows * m).zip(out.par_chunks_mut(rows * p)).for_each_init(QueryScratch::default, |s, (q, o)| {
            self.project_binned(q, noise, s);
            self.poses_of(s, o);
        });
        no_black_query(out, p)
    }

    /// The 16-bit product rows when 8-bit queries at `level` take them (a model that bins, VNNI).
    fn words_at(&self, level: Level) -> Option<&Words> {
        self.words.as_ref().filter(|_| dot_q::fast(level))
    }

    /// [`Self::project_u8`] for a model that bins: each image's block sums, exact in integers
    /// (255 b^2 at most), go to the 16-bit products ([`dot_w`], where [`dot_q::fast`] and b <=
    /// 11), else split into two 8-bit digit planes, low and high, which the 8-bit products take
    /// as two images (a zero step of the high plane, the blocks darker than 256 / b^2 on average,
    /// is skipped; a query's products are low + 256 high); a query's energy is the sums' exact sum
    /// of squares (in units of the block sums: the scale cancels in each ratio, as in
    /// [`Self::project_u8`]). Its pixel noise is measured on the image as given
    /// ([`pixel_variance_u8`], staged), as [`Self::project_binned`] does.
    fn project_u8_binned(&self, level: Level, queries: &[u8], noise: NoiseWant, s: &mut QueryScratch) {
        let (l, mb) = (self.components(), self.m);
        let m = self.meta.spec.features();
        let n = queries.len() / m;
        let full = self.binning.full();
        let (w, h, ch) = (full.width as usize, full.height as usize, full.color.channels());
        s.resize(n, l);
        s.route.resize(n, 0.0);
        s.pv_full.resize(n, 0.0);
        let b2 = (self.binning.factor() * self.binning.factor()) as f64;
        let words = self.words_at(level);
        BIN_SCRATCH.with_borrow_mut(|b| {
            let BinScratch { planes, sums, acc, raw, energy, lines, lines_x, idx } = b;
            // Each image's block sums, and its pixel noise measured as given (as
            // [`Self::project_binned`]), in pixel values: the sums' energy, the route's value
            // and the noise.
            let rows_u8_full = &mut s.rows_u8_full;
            let mut sum_one = |x: &[u8], v: &mut [u16]| {
                let (e_binned, e_full) = self.binning.sums_energies_u8(level, x, v, acc);
                let e_full = e_full as f64;
                let pv = match self.early(noise, e_full, m) {
                    Some(early) => pixel_variance_u8_in(x, w, h, ch, RowsU8::reuse(rows_u8_full, w * ch, ch), early),
                    None => 0.0,
                };
                (e_binned, pv * m as f64 / e_full, pv)
            };
            let mut sel = std::mem::take(&mut s.xidx);
            match words {
                // In sub-chunks whose sums are still cached for the products; each query routed
                // first, then its route's rows alone (the clean ones' mean and L_s, the noisy
                // ones' L), each route's queries copied apart when the sub-chunk mixes them.
                Some(wd) => {
                    let steps = wd.clean.steps();
                    for (c, xq) in queries.chunks(BIN_SUB_U8 * m).enumerate() {
                        let (i0, nn) = (c * BIN_SUB_U8, xq.len() / m);
                        wd.clean.lines_of(nn, lines);
                        let values = dot_w::WordRows::values_mut(lines);
                        for ((i, x), v) in (i0..).zip(xq.chunks_exact(m)).zip(values.chunks_exact_mut(steps * dot_w::STEP)) {
                            (s.energy[i], s.route[i], s.pv_full[i]) = sum_one(x, v);
                            s.noisy[i] = self.routed_noisy(noise, s.route[i]);
                        }
                        let (two, one);
                        let routes: &[(Option<bool>, &dot_w::WordRows, std::ops::Range<usize>)] = match &wd.noisy {
                            Some(wn) => {
                                two = [(Some(false), &wd.clean, self.clean_rows()), (Some(true), wn, self.noisy_rows())];
                                &two
                            }
                            // The same rows for both routes: one pass.
                            None => {
                                one = [(None, &wd.clean, self.clean_rows())];
                                &one
                            }
                        };
                        for (route, wr, rr) in routes.iter().cloned() {
                            sel.clear();
                            sel.extend((0..nn).filter(|&j| route.is_none_or(|r| s.noisy[i0 + j] == r)));
                            let k = rr.len();
                            let (src, nx) = selected(lines, steps, Some(&sel[..]), lines_x);
                            if nx == 0 || k == 0 {
                                continue;
                            }
                            s.xout.resize(nx * k, 0.0);
                            wr.dots_batch(level, src, &mut s.xout, idx);
                            scatter(&s.xout, k, Some(&sel[..]), i0, 1 + l, rr.start, &mut s.raw);
                        }
                    }
                }
                None => {
                    sums.resize(n * mb, 0);
                    for ((i, x), v) in queries.chunks_exact(m).enumerate().zip(sums.chunks_exact_mut(mb)) {
                        (s.energy[i], s.route[i], s.pv_full[i]) = sum_one(x, v);
                        s.noisy[i] = self.routed_noisy(noise, s.route[i]);
                    }
                    planes.resize(2 * n * mb, 0);
                    for (v, p) in sums.chunks_exact(mb).zip(planes.chunks_exact_mut(2 * mb)) {
                        let (lo, hi) = p.split_at_mut(mb);
                        for ((&v, lo), hi) in v.iter().zip(lo).zip(hi) {
                            (*lo, *hi) = (v as u8, (v >> 8) as u8);
                        }
                    }
                    // Every query's clean rows, then the noisy ones' extra rows.
                    self.planes_pass(level, &self.quant, self.clean_rows(), &planes[..2 * n * mb], None, raw, energy, s);
                    if self.extra_rows() > 0 {
                        sel.clear();
                        sel.extend((0..n).filter(|&i| s.noisy[i]));
                        self.planes_pass(level, &self.quant_x, self.extra_range(), &planes[..2 * n * mb], Some(&sel[..]), raw, energy, s);
                    }
                }
            }
            s.xidx = sel;
            for i in 0..n {
                // The noisy match's nu in units of the block sums (b^2 times a binned pixel's
                // mean): a pixel's noise pv gives a block mean's pv / b^2, a block sum's b^2 pv.
                let energy = s.energy[i] as f64;
                let mean = words.is_none() || !s.noisy[i];
                (s.resid[i], _) = self.finish_query(i, mean, energy, 0.0, s);
                s.noise[i] = b2 * s.pv_full[i] / energy;
            }
        });
    }

    /// The products of binned 8-bit queries given as digit planes (`planes`: per query its low
    /// then its high plane, of M each; those at `sel` when given, else all) with the rows `rr`
    /// by `fr` (those rows in 16-bit fixed point) into `s.raw` as [`Self::pass_f32`]: each
    /// plane as an image (`raw` and `energy` hold their products and sums of squares), a
    /// query's products low + 256 high.
    #[allow(clippy::too_many_arguments)]
    fn planes_pass(
        &self,
        level: Level,
        fr: &dot_q::FastRows,
        rr: std::ops::Range<usize>,
        planes: &[u8],
        sel: Option<&[usize]>,
        raw: &mut Vec<f32>,
        energy: &mut Vec<u64>,
        s: &mut QueryScratch,
    ) {
        let (mb, k) = (self.m, rr.len());
        let (src, nx) = selected(planes, 2 * mb, sel, &mut s.gather_u8);
        if nx == 0 || k == 0 {
            return;
        }
        let rows = &self.rows[rr.start * mb..rr.end * mb];
        raw.resize(2 * nx * k, 0.0);
        energy.resize(2 * nx, 0);
        if 2 * nx >= 8 {
            fr.dots_batch(level, src, mb, rows, raw, energy, &mut s.products);
        } else {
            for (x, r) in src.chunks_exact(mb).zip(raw.chunks_exact_mut(k)) {
                fr.dots(level, x, rows, r);
            }
        }
        s.xout.resize(nx * k, 0.0);
        for (o, pair) in s.xout.chunks_exact_mut(k).zip(raw.chunks_exact(2 * k)) {
            let (lo, hi) = pair.split_at(k);
            o.iter_mut().zip(lo.iter().zip(hi)).for_each(|(r, (&a, &b))| *r = a + 256.0 * b);
        }
        scatter(&s.xout, k, sel, 0, 1 + self.components(), rr.start, &mut s.raw);
    }

    /// [`PoseModel::predict_u8_into`], computing `noise` of each query's pixel noise.
    fn predict_u8_with(&self, queries: &[u8], noise: NoiseWant, out: &mut [f64]) -> Result<()> {
        let (m, p) = (self.meta.spec.features(), self.meta.space.len());
        let n = batch_len(m, queries.len(), out.len(), p)?;
        let level = Level::detect();
        let block = if self.words_at(level).is_some() { dot_w::BLOCK } else { self.quant.block(level) };
        let rows = if n >= 8 { crate::methods::eigenspace::u8_task_rows(n, block) } else { n };
        queries.par_chunks(rows * m).zip(out.par_chunks_mut(rows * p)).for_each_init(QueryScratch::default, |s, (q, o)| {
            if self.binning.bins() {
                self.project_u8_binned(level, q, noise, s);
            } else {
                self.project_u8(level, q, noise, s);
            }
            self.poses_of(s, o);
        });
        no_black_query(out, p)
    }
}

impl PoseModel for RefinedModel {
    fn method(&self) -> &'static Method {
        &METHOD
    }

    fn storage(&self) -> Storage {
        self.table1_storage()
    }

    fn meta(&self) -> &ModelMeta {
        &self.meta
    }

    fn predict_into(&self, queries: &[f32], out: &mut [f64]) -> Result<()> {
        self.predict_with(queries, self.noise_want(), out)
    }

    /// 8-bit queries: the projection by [`dot_q::FastRows`] (16-bit fixed point where VNNI runs
    /// it, else [`dot_u8::dots_batch`]), then the search; the estimates of
    /// [`PoseModel::predict_into`] on the same images as features but for near ties.
    fn predict_u8_into(&self, queries: &[u8], out: &mut [f64]) -> Result<()> {
        self.predict_u8_with(queries, self.noise_want(), out)
    }

    /// Everything held to serve queries: basis, mean and their projections, the surface's knot
    /// values and slopes (2^D N L), the coarse start points with their poses, the knot positions,
    /// the lattice search or the coarse tree with its poses.
    fn model_bytes(&self) -> usize {
        (self.rows.len()
            + self.mean_proj.len()
            + self.surface.len()
            + self.bg_surface.len()
            + self.start_points.len()
            + self.start_boxes.len()
            + self.bg_start.len())
            * 4
            + self.noise_scan.len() * 8
            + self.lattice.as_ref().map_or(0, lattice::Lattice::bytes)
            + self.tree.as_ref().map_or(0, |c| c.tree.bytes() + c.poses.len() * 8)
            + self.noisy_tree.as_ref().map_or(0, NoisyTree::bytes)
            + (self.start_poses.len() + self.axes.iter().map(Vec::len).sum::<usize>()) * 8
    }

    fn tensors(&self) -> Vec<Tensor> {
        let (l, m) = (self.components(), self.m);
        let mut shape = self.settings.knot_shape.clone();
        shape.push(l);
        let mut v = vec![
            Tensor::f32("basis", vec![l, m], self.rows[m..].to_vec()),
            Tensor::f32("mean", vec![m], self.rows[..m].to_vec()),
            Tensor::f32("knots", shape.clone(), self.knots.clone()),
            Tensor::f32("background", shape, self.background.clone()),
        ];
        for (j, a) in self.axes.iter().enumerate() {
            v.push(Tensor::f64(&format!("knot_axis_{j}"), vec![a.len()], a.clone()));
        }
        v
    }
}

#[cfg(test)]
mod tests;
