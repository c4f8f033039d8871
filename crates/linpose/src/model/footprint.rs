//! What a fit allocates, as the memory plan ([`crate::memory`]) counts it before anything is
//! read. Each method says it of its own fit ([`Footprint`], made from settings by its
//! [`Method`](super::Method)'s `footprint`), and each recogniser of its own
//! ([`crate::recognize::Recognizer`]), as a sum of named parts ([`Parts`]) from the sizes of the
//! job ([`Sizes`]): the plan adds the images, the process and its threads, and names no method.
//!
//! An estimate is meant as an upper bound a little above the peak resident memory: its
//! coefficients are read from what the code allocates, and where the code alone does not settle
//! one, measured (each in its module's tuning file, the measurements tabled in
//! [`crate::memory`]'s documentation).

use super::tuning::{HEAP_MATRIX_BYTES, ROW_BYTES};
use crate::error::{Error, StreamChange};
use std::sync::Arc;

/// The sizes a fit's memory depends on.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Sizes {
    /// Training images N.
    pub(crate) n: usize,
    /// Features per image M.
    pub(crate) m: usize,
    /// Encoded pose values K.
    pub(crate) k: usize,
    /// Values per pixel (3 for RGB features).
    pub(crate) channels: usize,
    /// Points of the pose lattice the fit resamples or searches ([`Footprint::lattice_step`]).
    pub(crate) lattice: usize,
    /// Pose parameters D.
    pub(crate) params: usize,
}

/// A sum of named parts, in bytes.
#[derive(Debug, Default)]
pub(crate) struct Parts {
    parts: Vec<(f64, String)>,
    /// What the whole is called, whatever part is largest.
    name: Option<String>,
}

impl Parts {
    /// With `bytes` more, called `what` (nothing when `bytes` is not positive).
    pub(crate) fn add(mut self, bytes: f64, what: impl Into<String>) -> Self {
        if bytes > 0.0 {
            self.parts.push((bytes, what.into()));
        }
        self
    }

    /// The bytes of every part.
    pub(crate) fn total(&self) -> f64 {
        self.parts.iter().map(|p| p.0).sum()
    }

    /// The larger of two stages that do not overlap (one's arrays freed before the other
    /// allocates its own), added.
    pub(crate) fn stage(self, a: Parts, b: Parts) -> Self {
        let larger = if a.total() >= b.total() { a } else { b };
        larger.parts.into_iter().fold(self, |s, (v, w)| s.add(v, w))
    }

    /// With every part of `other` added.
    pub(crate) fn join(self, other: Parts) -> Self {
        other.parts.into_iter().fold(self, |s, (v, w)| s.add(v, w))
    }

    /// Called `what` as a whole, whatever part is largest.
    pub(crate) fn named(mut self, what: impl Into<String>) -> Self {
        self.name = Some(what.into());
        self
    }

    /// What the whole is called: its name, else its largest part's; None for no parts.
    pub(crate) fn what(&self) -> Option<String> {
        self.name.clone().or_else(|| self.parts.iter().max_by(|a, b| a.0.total_cmp(&b.0)).map(|p| p.1.clone()))
    }
}

/// Bytes of an N x N system of `per` bytes per N^2 and [`ROW_BYTES`] per row, with a freed
/// N x N matrix the heap may keep ([`HEAP_MATRIX_BYTES`]).
pub(crate) fn system(n: f64, per: f64) -> f64 {
    let matrix = 8.0 * n * n;
    per * n * n + ROW_BYTES * n + if matrix < HEAP_MATRIX_BYTES as f64 { matrix } else { 0.0 }
}

/// A method's fit with its settings, as far as memory goes.
pub(crate) trait Footprint: std::fmt::Debug + Send + Sync {
    /// What the fit allocates beside the training images as f32.
    fn fit(&self, s: &Sizes) -> Parts;

    /// The step (degrees) of the pose lattice the fit resamples or searches, from which the plan
    /// counts [`Sizes::lattice`] over the training poses; None when it has none.
    fn lattice_step(&self) -> Option<f64> {
        None
    }

    /// What the method's streamed fit ([`super::Method::fit_streamed`]) allocates, when it does
    /// not load the set; None when it does (it needs then what the fit in memory needs).
    fn streamed(&self, _s: &Sizes) -> Option<Parts> {
        None
    }

    /// Whether the plan takes the streamed path whenever it fits, even where the fit in memory
    /// fits too (the linear model with more images than features: least squares through X^T X,
    /// less memory and time, the same model). Otherwise only when the fit in memory does not fit.
    fn stream_first(&self, _s: &Sizes) -> bool {
        false
    }

    /// A setting that keeps the streamed fit from taking the job, if one does (a method that
    /// streams).
    fn stream_block(&self) -> Option<StreamBlock> {
        None
    }
}

/// A setting that keeps a fit from streaming: why, the error of a streamed fit asked for with
/// it, and the fit with it changed.
#[derive(Debug)]
pub(crate) struct StreamBlock {
    /// In words, after "not streamed: ".
    pub(crate) reason: &'static str,
    /// What to change for the fit to stream.
    pub(crate) change: StreamChange,
    /// The error of a streamed fit asked for with the setting.
    pub(crate) error: Error,
    /// The fit with the setting changed as [`StreamBlock::change`] says.
    pub(crate) unblocked: Arc<dyn Footprint>,
}
