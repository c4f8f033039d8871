//! Many objects: which object an image shows, then its pose, and "none of these".
//!
//! Murase & Nayar recognise first and estimate the pose second: every object's training images
//! share one "universal" eigenspace, each object is an appearance manifold in it, and a query is
//! the object whose manifold holds the nearest point; the pose then comes from that object's own
//! model. Okatani & Deguchi's linear model takes over "after object recognition is completed".
//! linpose does the whole job with any pose method:
//!
//! - a **recogniser** ([`Recognizer`], listed in [`RECOGNIZERS`]) scores a query against every
//!   object with a distance (smaller: more like that object): `universal`, the distance to each
//!   object's manifold in the universal eigenspace (`universal.rs`), or `linear`, the paper's
//!   minimum-norm linear model with one-hot object targets (through the same Gram matrix as the
//!   pose fit, one more solve), the distance of its K outputs from each object's one-hot vector
//!   (`linear.rs`). A new recogniser is a new file defining its [`Recognizer`] and one word in
//!   the `registry!` line below;
//! - **"none of these"**: the query is unknown when its distance to the nearest object exceeds
//!   what that object's own held-out training views show ([`Unknown::Calibrated`]: the largest
//!   distance of a training view to the object's model fitted without it, so a fresh view of a
//!   known object, which lies between two training views, is rarely beyond it), or a threshold
//!   given ([`Unknown::Threshold`]); then, calibrated the same way, when its distance to that
//!   object's manifold in the object's own eigenspace is beyond what its held-out views show
//!   (`own.rs`: the shared space cannot see the details that tell, say, two toy cars apart), or
//!   when another object's manifold, in that object's own eigenspace, lies nearer still (the
//!   recogniser named an object the query is not most like);
//! - the **pose** of a recognised query comes from its object's own pose model, fitted by any
//!   method ([`crate::MethodSpec`]);
//! - **without poses** ([`ObjectModel::fit_views`]), for views whose poses nobody recorded: each
//!   object's manifold is its training views' points rather than a curve through them, the
//!   held-out distance is a view's distance to its second nearest other view (`universal.rs`,
//!   `NEIGHBOUR`), and there is no pose to estimate.
//!
//! [`ObjectModel`] holds the recogniser, the thresholds, the objects' names and their pose
//! models; [`crate::model_file`] saves it as one file. [`ObjectModel::fit_normalized`] puts all
//! of it behind one normalisation stage ([`crate::normalize`]) fitted on every object's training
//! views, as Murase & Nayar segment and normalise before recognising, for queries not
//! registered like the training views.
//!
//! ```
//! use linpose::image_io::{ColorMode, ImageSpec};
//! use linpose::recognize::{ObjectModel, RecognizerParams};
//! use linpose::{Dataset, Method, ObjectSet, Param, PoseSpace};
//!
//! // Two "objects" on a turntable, 36 views each of 64 pixels: a bright lobe turning round, and
//! // two lobes.
//! let space = PoseSpace::new(vec![Param::circular("azimuth", 360.0)])?;
//! let spec = ImageSpec { width: 64, height: 1, color: ColorMode::Gray };
//! let image = |lobes: f64, a: f64| (0..64).map(move |p| {
//!     let u = p as f64 / 64.0 * std::f64::consts::TAU;
//!     (0.1 + (3.0 * ((lobes * (u - a.to_radians())).cos() - 1.0)).exp()) as f32
//! });
//! let poses: Vec<f64> = (0..36).map(|k| 10.0 * k as f64).collect();
//! let object = |lobes: f64| Dataset::new(spec, poses.iter().flat_map(|&a| image(lobes, a)).collect(), space.clone(), poses.clone());
//! let objects = ObjectSet::new(vec!["one".into(), "two".into()], vec![object(1.0)?, object(2.0)?])?;
//!
//! let pose = linpose::Method::from_name("eigenspace")?.default_spec();
//! let model = ObjectModel::fit(&objects, &RecognizerParams::default().components(6), &pose)?;
//! let view: Vec<f32> = image(2.0, 123.0).collect(); // object "two", between training views
//! let found = &model.estimate(&view, 1)?[0];
//! assert_eq!(found.recognition.object, Some(1));
//! assert!((found.pose.as_ref().unwrap().pose[0] - 123.0).abs() < 3.0);
//! # Ok::<(), linpose::Error>(())
//! ```

mod model;
mod own;
mod robust;
mod tuning;

#[cfg(test)]
mod tests;

macro_rules! registry {
    ($($r:ident),+ $(,)?) => {
        $(mod $r;)+

        /// Every recogniser linpose has, in the order the command line lists them; the first is
        /// the default.
        pub static RECOGNIZERS: &[&Recognizer] = &[$(&$r::RECOGNIZER),+];
    };
}

registry!(universal, linear);

pub use model::{Labels, ObjectEstimate, ObjectHypothesis, ObjectModel, ObjectSettings, OwnSettings};

use crate::catalog::ObjectSet;
use crate::dataset::Dataset;
use crate::model::footprint::{Parts, Sizes};
use crate::model::{Tensor, TensorSet};
use crate::{Error, Result};
use serde::{Deserialize, Serialize};
use std::sync::Arc;

/// Reads a fitted recogniser back from a model file's arrays: objects, features per image, and
/// the dimensions its fit kept ([`Fitted::components`]).
pub(crate) type LoadRecognizer = fn(&TensorSet, usize, usize, usize) -> Result<Arc<dyn Recognize>>;

/// A recogniser, how a query's object is told, as the registry knows it: its name, what it is,
/// its storage formula, and how it is fitted, read back from a model file and costed in memory.
/// Each recogniser's file defines one, and [`RECOGNIZERS`] lists them.
pub struct Recognizer {
    /// Its name on the command line and in model files.
    pub name: &'static str,
    /// What it is, in one line.
    pub summary: &'static str,
    /// Its storage in the paper's Table 1 terms, with the second stage's: each object's own
    /// eigenimages and mean (K (M L_k + M), every L_k equal) and manifold points (N_own L_k).
    pub storage: &'static str,
    /// Fits it on the training views of every object, given also row after row in one data set
    /// (object 0's first); with `views_only` (the last argument) without reading their poses.
    pub(crate) fit: fn(&ObjectSet, &Dataset, &RecognizerParams, bool) -> Result<Fitted>,
    /// Reads it back from a model file's arrays.
    pub(crate) load: LoadRecognizer,
    /// What its fit allocates, for the memory plan ([`crate::memory`]): all objects' images
    /// (N, the lattice points of one object), the number of objects and the parameters.
    pub(crate) footprint: fn(&Sizes, usize, &RecognizerParams) -> Parts,
}

impl std::fmt::Debug for Recognizer {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_tuple("Recognizer").field(&self.name).finish()
    }
}

impl PartialEq for Recognizer {
    fn eq(&self, other: &Self) -> bool {
        self.name == other.name
    }
}

impl Recognizer {
    /// The recogniser called `name`, or an error naming those there are.
    pub fn from_name(name: &str) -> Result<&'static Recognizer> {
        find(name).ok_or_else(|| {
            let names: Vec<&str> = RECOGNIZERS.iter().map(|r| r.name).collect();
            Error::invalid("recognizer", name, format!("known recognisers: {}", names.join(", ")))
        })
    }
}

/// The recogniser called `name`.
pub(crate) fn find(name: &str) -> Option<&'static Recognizer> {
    RECOGNIZERS.iter().copied().find(|r| r.name == name)
}

/// A recogniser as fitted ([`Recognizer`]'s `fit`): the model, the dimensions of its eigenspace
/// and the fraction of the training energy they hold (0 and 1 for a recogniser without one), and
/// per object its training views' held-out distances (empty for an object too sparse to hold
/// views out).
pub(crate) struct Fitted {
    pub(crate) model: Arc<dyn Recognize>,
    pub(crate) components: usize,
    pub(crate) energy_kept: f64,
    pub(crate) held_out: Vec<Vec<f64>>,
}

/// A fitted recogniser: what an [`ObjectModel`] asks of it.
pub(crate) trait Recognize: std::fmt::Debug + Send + Sync {
    /// Each query's distance to each object into `out` (rows of K, one per object).
    fn distances(&self, queries: &[f32], out: &mut [f64]);

    /// Which object each of the `n` queries shows, with the objects' `thresholds`: by default the
    /// nearest by [`Recognize::distances`]. An error names a query whose distances are not finite
    /// (it cannot be scaled to unit energy).
    fn recognize(&self, queries: &[f32], n: usize, thresholds: &[f64]) -> Result<Vec<Recognition>> {
        let k = thresholds.len();
        let d = checked_distances(self, queries, n, k)?;
        Ok(d.chunks_exact(k).map(|d| Recognition::from_distances(d, thresholds)).collect())
    }

    /// Numbers it stores (f32).
    fn stored_numbers(&self) -> usize;

    /// Its own terms of the paper's Table 1 storage with their values (before M, K and the
    /// second stage's, which every recogniser shares).
    fn storage_terms(&self) -> Vec<(&'static str, usize)> {
        Vec::new()
    }

    /// Its arrays for a model file (names start with `recognizer.`).
    fn arrays(&self) -> Vec<Tensor>;
}

/// The distances of `n` queries to `k` objects ([`Recognize::distances`]); an error names the
/// first query with a distance that is not finite.
pub(crate) fn checked_distances<R: Recognize + ?Sized>(r: &R, queries: &[f32], n: usize, k: usize) -> Result<Vec<f64>> {
    let mut out = vec![0.0; n * k];
    r.distances(queries, &mut out);
    if let Some(i) = out.chunks_exact(k).position(|d| d.iter().any(|v| !v.is_finite())) {
        return Err(crate::model::unscalable_query(i));
    }
    Ok(out)
}

/// A recogniser by its name in JSON (model files, summaries).
mod by_name {
    use super::Recognizer;
    use serde::{Deserialize, Deserializer, Serializer};

    pub(super) fn serialize<S: Serializer>(r: &&'static Recognizer, s: S) -> Result<S::Ok, S::Error> {
        s.serialize_str(r.name)
    }

    pub(super) fn deserialize<'de, D: Deserializer<'de>>(d: D) -> Result<&'static Recognizer, D::Error> {
        let name = String::deserialize(d)?;
        Recognizer::from_name(&name).map_err(serde::de::Error::custom)
    }
}

/// When a query is reported as none of the known objects.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Unknown {
    /// Beyond the largest distance any held-out training view of the nearest object shows (each
    /// training view against its object's model fitted without it), calibrated per object, in
    /// the recogniser's space and then in the object's own eigenspace (`own.rs`): unknown when
    /// either is exceeded, or when another object's own manifold lies nearer the query than the
    /// recognised object's.
    Calibrated,
    /// Beyond this distance in the recogniser's measure, for every object; the second stage is
    /// off (its distances are each object's own, on another scale).
    Threshold(f64),
    /// Never: every query is one of the known objects.
    Off,
}

/// Parameters of a recogniser.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct RecognizerParams {
    /// Which recogniser (default: the first of [`RECOGNIZERS`], the universal eigenspace).
    #[serde(with = "by_name")]
    pub kind: &'static Recognizer,
    /// Dimensions of the universal eigenspace (default 20, as Murase & Nayar; capped at N - 1).
    pub components: usize,
    /// The manifolds' resampling step in the universal eigenspace (degrees, default 0.5). With
    /// more than two pose parameters the manifolds are resampled at a few points per knot
    /// interval instead, and the step is not used.
    pub manifold_step: f64,
    /// When a query is none of the objects (default: calibrated).
    pub unknown: Unknown,
}

impl Default for RecognizerParams {
    fn default() -> Self {
        RecognizerParams { kind: RECOGNIZERS[0], components: 20, manifold_step: 0.5, unknown: Unknown::Calibrated }
    }
}

impl RecognizerParams {
    /// The recogniser `kind` with the other parameters' defaults.
    pub fn new(kind: &'static Recognizer) -> Self {
        RecognizerParams { kind, ..Self::default() }
    }

    /// With `l` universal eigenspace dimensions.
    pub fn components(mut self, l: usize) -> Self {
        self.components = l;
        self
    }

    /// With the manifolds resampled every `degrees`.
    pub fn manifold_step(mut self, degrees: f64) -> Self {
        self.manifold_step = degrees;
        self
    }

    /// With the unknown-object rule `unknown`.
    pub fn unknown(mut self, unknown: Unknown) -> Self {
        self.unknown = unknown;
        self
    }

    pub(crate) fn validate(&self) -> Result<()> {
        if self.components == 0 {
            return Err(Error::invalid("components", 0, "the universal eigenspace needs at least one dimension"));
        }
        if !(self.manifold_step.is_finite() && self.manifold_step > 0.0) {
            return Err(Error::invalid("manifold step", self.manifold_step, "must be a positive number of degrees"));
        }
        if let Unknown::Threshold(t) = self.unknown {
            if !(t.is_finite() && t > 0.0) {
                return Err(Error::invalid("unknown threshold", t, "must be a positive distance"));
            }
        }
        Ok(())
    }
}

/// Which object a query shows.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct Recognition {
    /// The object's index ([`ObjectModel::names`]), `None` when the query is none of them.
    pub object: Option<usize>,
    /// The nearest object, even when the query is reported unknown.
    pub nearest: usize,
    /// The query's distance to the nearest object (the recogniser's measure).
    pub distance: f64,
    /// Its distance to the second nearest object (infinite with one object).
    pub second: f64,
    /// The distance beyond which the query is unknown for the nearest object.
    pub threshold: f64,
    /// Its distance to the nearest object's manifold in that object's own eigenspace, the
    /// second stage ([`Unknown::Calibrated`]); `None` when not measured (the first stage already
    /// rejected the query, or the second stage is off), NaN for a query that cannot be scaled to
    /// unit energy (then unknown).
    pub own_distance: Option<f64>,
    /// The distance in the object's own eigenspace beyond which the query is unknown (infinite
    /// when the second stage is off).
    pub own_threshold: f64,
    /// Another object whose own manifold lies nearer the query than the nearest object's does,
    /// in its own eigenspace (then unknown): the nearest such. `None` when there is none or the
    /// query was not measured against the others (rejected before, or the second stage off).
    pub own_nearer: Option<usize>,
    /// How far the nearest object stands out from the second: 1 - (distance / second)^2, in
    /// [0, 1] (0: a tie, 1: the second infinitely farther). A margin, not a probability.
    pub confidence: f64,
}

impl Recognition {
    /// The recognition of a query whose distances to the objects are `d` (finite, at least one)
    /// with the per-object thresholds `thresholds`.
    pub(crate) fn from_distances(d: &[f64], thresholds: &[f64]) -> Self {
        let mut best = 0;
        for k in 1..d.len() {
            if d[k] < d[best] {
                best = k;
            }
        }
        let second = d.iter().enumerate().filter(|&(k, _)| k != best).map(|(_, &v)| v).fold(f64::INFINITY, f64::min);
        Self::from_nearest(best, d[best], second, thresholds)
    }

    /// The recognition of a query whose nearest object is `best` at `distance`, the second
    /// nearest at `second`.
    pub(crate) fn from_nearest(best: usize, distance: f64, second: f64, thresholds: &[f64]) -> Self {
        let confidence = if second.is_finite() && second > 0.0 { (1.0 - (distance / second).powi(2)).clamp(0.0, 1.0) } else { 1.0 };
        let threshold = thresholds[best];
        let object = if distance <= threshold { Some(best) } else { None };
        Recognition { object, nearest: best, distance, second, threshold, own_distance: None, own_threshold: f64::INFINITY, own_nearer: None, confidence }
    }
}
