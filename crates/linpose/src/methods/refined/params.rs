//! The parameters of the refined eigenspace as given, and what a fitted model records of them and of
//! what it chose.

use crate::manifold::surface::Interpolant;
use super::tuning::{DEFAULT_PER_CELL, DEFAULT_RESOLUTION, DEFAULT_STARTS, MAX_PER_CELL, MAX_ROLL_SPLIT, MAX_STARTS};
use crate::{Error, Result};
use serde::{Deserialize, Serialize};

/// Parameters of the refined eigenspace. The default chooses L, the metric, the interpolant and
/// the binning factor from the training data, reports poses on the 0.5-degree lattice, and where
/// a local search serves, searches from the best 8 of 4 coarse points per knot interval along
/// each axis.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct RefinedParams {
    pub(crate) components: Option<usize>,
    pub(crate) starts: usize,
    pub(crate) per_cell: usize,
    pub(crate) weighted: bool,
    pub(crate) resolution: f64,
    /// Images binned by this factor before anything else (1: as given; None: chosen from the
    /// training data among 1, 2 and 4).
    pub(crate) bin: Option<usize>,
    /// How the surface interpolates between knots (None: chosen from the training data: the spline or the
    /// local cubic).
    pub(crate) interpolant: Option<Interpolant>,
    /// The parts each knot interval of a camera roll is split into by turned training views
    /// (None: two where the training views show that a roll turns the image).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub(crate) roll_split: Option<usize>,
}

impl Default for RefinedParams {
    fn default() -> Self {
        RefinedParams {
            components: None,
            starts: DEFAULT_STARTS,
            per_cell: DEFAULT_PER_CELL,
            weighted: true,
            resolution: DEFAULT_RESOLUTION,
            bin: None,
            interpolant: None,
            roll_split: None,
        }
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

    /// Coarse points per knot interval along each axis, where a local search serves from a
    /// grid of coarse points (one or two pose parameters; with more, the manifold is kept as its
    /// knots and the coarse points are fixed at two per knot interval).
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

    /// Bin the images by `factor` (each pixel the mean of a factor x factor block) before fitting
    /// and before each query; 1 keeps them as given. Noise is simulated on the images as given,
    /// then binned, as a query's would be.
    pub fn bin(mut self, factor: usize) -> Self {
        self.bin = Some(factor);
        self
    }

    /// Choose the binning factor from the training data (the default): among 1, 2 and 4, the
    /// coarsest whose error on held-out training views is within one standard error of the
    /// least (cheaper queries and a smaller model where the training views cannot tell the
    /// factors apart).
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
    /// the same held-out training views, the spline on a tie.
    pub fn auto_interpolant(mut self) -> Self {
        self.interpolant = None;
        self
    }

    /// With a camera roll (a `roll` beside `elevation` and `azimuth`, which turns the image in
    /// its plane): split each interval between the training rolls into `parts` by training
    /// views turned to the rolls between, which the surface passes through as extra knots
    /// (`docs/refined.md`); 1 keeps the training views alone. By default the split is two
    /// parts (a knot halfway) where turning each training view to the next training roll
    /// reproduces the view there ([`RefinedSettings::roll_turn_error`]), else none.
    pub fn roll_split(mut self, parts: usize) -> Self {
        self.roll_split = Some(parts);
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

    pub(crate) fn validate(&self) -> Result<()> {
        if self.components == Some(0) {
            return Err(Error::invalid("components", 0, "at least one eigenimage is needed"));
        }
        if !(self.resolution.is_finite() && self.resolution >= 0.0) {
            return Err(Error::invalid("resolution", self.resolution, "must be a number of degrees >= 0"));
        }
        if let Some(s) = self.roll_split.filter(|s| !(1..=MAX_ROLL_SPLIT).contains(s)) {
            return Err(Error::invalid("roll split", s, format!("must be 1 to {MAX_ROLL_SPLIT}")));
        }
        if !(1..=MAX_STARTS).contains(&self.starts) {
            return Err(Error::invalid("starts", self.starts, format!("must be 1 to {MAX_STARTS}")));
        }
        if !(1..=MAX_PER_CELL).contains(&self.per_cell) {
            return Err(Error::invalid("per cell", self.per_cell, format!("must be 1 to {MAX_PER_CELL}")));
        }
        if let Some(b) = self.bin.filter(|b| !(1..=crate::binning::MAX_FACTOR).contains(b)) {
            return Err(Error::invalid("bin", b, format!("must be 1 to {}", crate::binning::MAX_FACTOR)));
        }
        Ok(())
    }
}

/// What a fitted model records in [`ModelMeta::settings`](crate::ModelMeta::settings).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct RefinedSettings {
    /// The parameters as given.
    pub params: RefinedParams,
    /// The binning factor of every image the model takes (1: none).
    pub bin: usize,
    /// The automatic choice of the binning factor: each candidate with its held-out error
    /// (degrees), as [`Self::selection`]'s least and [`Self::plain_error`] (empty when fixed).
    pub bin_selection: Vec<(usize, f64)>,
    /// The standard error of the least of [`Self::bin_selection`]'s errors: the coarsest factor
    /// within it of the least was chosen (the one-standard-error rule; 0 when fixed).
    pub bin_tolerance: f64,
    /// How the surface interpolates between knots.
    pub interpolant: Interpolant,
    /// The automatic choice of the interpolant: each candidate with its least held-out error
    /// (degrees) on the chosen binning factor's images (empty when fixed).
    pub interpolant_selection: Vec<(Interpolant, f64)>,
    /// Eigenimages kept, L.
    pub components: usize,
    /// Eigenimages of the weighted search of a clean query (the first ones, at least one). The
    /// rest serve only noisy queries (the affine match, up to all L).
    pub search_components: usize,
    /// Fraction of the training energy (about the mean) they hold.
    pub energy_kept: f64,
    /// Knots along each pose parameter (with a camera roll, the roll's training values and the
    /// turned views between them, [`Self::roll_split`]).
    pub knot_shape: Vec<usize>,
    /// The parts each knot interval of a camera roll (a `roll` beside `elevation` and `azimuth`)
    /// is split into by training views turned in the image, which the surface passes through as
    /// extra knots (`docs/refined.md`); None when its knots are the training views alone.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub roll_split: Option<usize>,
    /// With a camera roll: how far each training view turned in the image to the next training
    /// roll lands from the view there, relative to how far apart the two views are (the sum of
    /// squared differences over every such pair, `manifold::roll`): near 0 where a roll turns the
    /// image and nothing else. Above 0.25 the automatic split is none.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    pub roll_turn_error: Option<f64>,
    /// The automatic choice of L: each candidate with the mean pose error (degrees) of the
    /// held-out training views (empty when L was fixed).
    pub selection: Vec<(usize, f64)>,
    /// The held-out error of the plain (unweighted) search in the first 20 coordinates, the
    /// eigenspace's metric; when below every weighted L's, the model uses it for every query
    /// (None when not scored).
    pub plain_error: Option<f64>,
    /// Each coordinate's mean squared interpolation error over held-out knots (empty when the
    /// coordinates are not weighted).
    pub interpolation_variance: Vec<f64>,
    /// The training images' mean squared distance from the eigenspace (unit energy, mean
    /// subtracted): the discarded eigenvalues over N. A query further off than this carries
    /// noise, estimated per query (see the [module doc](super)).
    pub residual_energy: f64,
    /// The noise threshold: between the largest pixel-noise estimate (Immerkaer's, over the mean
    /// square pixel) of a training image and the smallest of the training images with simulated
    /// +-5% noise. A query above it is treated as noisy and takes the affine match (0: never).
    pub noise_threshold: f64,
    /// Eigenimages of the affine match of a noisy query (the first ones).
    pub noise_components: usize,
    /// Whether the noisy match weights each coordinate by 1 / (sigma_l^2 + floor + nu).
    pub noise_weighted: bool,
    /// Each of the L coordinates' interpolation variance (unscaled, as `interpolation_variance`,
    /// but for all L), which weights the noisy match (empty when no knots could be held out).
    pub coord_variance: Vec<f64>,
    /// The automatic choice of the noisy match: each candidate (L, weighted) with the mean pose
    /// error (degrees) of the held-out training views under simulated +-5% and +-10% noise.
    pub noise_selection: Vec<(usize, bool, f64)>,
    /// The second look that decides between the estimate and its rivals and scores them
    /// (`second_look`); absent only in the models fitted for the choices themselves.
    pub second_look: Option<crate::second_look::SecondLookSettings>,
}

impl RefinedSettings {
    /// Eigenimages of the weighted search.
    pub fn search(&self) -> usize {
        self.search_components
    }
}
