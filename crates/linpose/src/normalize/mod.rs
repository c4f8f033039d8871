//! Normalisation: the object found in each image, centred and scaled to a fixed size (and,
//! optionally, brought to a fixed brightness) before any method sees it, so that images taken
//! as a camera in a cell takes them (the object anywhere in the frame, nearer or farther,
//! brighter or darker) are compared with the training views as if they had been registered
//! like them. Murase & Nayar's system does this before recognition and pose; COIL's images were
//! prepared so by their makers.
//!
//! A [`Normalizer`] is fitted on the training images and stored in the model file
//! ([`crate::model::ModelMeta::normalize`]); training and query images go through the same
//! stage ([`Normalized`], a model wrapper any method's model fits in; for many objects, one stage
//! fitted on all their training views, [`crate::recognize::ObjectModel::fit_normalized`]). For
//! each image:
//!
//! 1. **Background.** Its level is 0 when the training views' backgrounds are dark, otherwise the
//!    median of the image's border, per image (so a change of lighting moves it). Everything
//!    after works on the image minus this level.
//! 2. **Object.** Foreground is where a pixel deviates from the level by more than a threshold:
//!    the one chosen from the training images' borders (their noise, at least half a gray
//!    level), raised to the query's own border noise when the border is background. Its
//!    8-connected regions are found; the largest (by summed deviation) is the object, regions of
//!    less than 5% (`BLOB_SHARE`, normalize/tuning.rs) of its weight are specks and are left out.
//! 3. **Position and size.** The centroid and the radius of gyration (root-mean-square distance
//!    from the centroid) of the object's deviations.
//! 4. **Resampling.** The image is resampled (separable cubic, anti-aliased when shrinking) so
//!    that the centroid lies at the frame's centre and the radius equals the training views'
//!    median radius: one scale for both axes, so the aspect ratio is kept.
//! 5. **Brightness** (optional). The result is multiplied so that the object's weight per
//!    squared radius equals the training views' median: a change of exposure or of the light's
//!    strength is undone (clipped pixels stay clipped).
//!
//! Where this cannot work the image is refused with a [`Rejection`] that says why: no object
//! (nothing differs from the background), several blobs (a second region of at least
//! 5% (`BLOB_SHARE`, normalize/tuning.rs) of the object's weight: two objects, or one in pieces), or the object
//! touches the frame edge (part of it may be outside, so its position and size are unknown).
//! Touching the edge is refused only when the training views keep the object inside the frame;
//! data sets framed to the edge by their makers (COIL's) touch it in most views, and then the
//! edge is the data's convention. `eval` counts refused images apart.
//!
//! The stage is exact for a move by whole pixels: the moments are taken from the object's
//! bounding box corner and the resampling's weights depend only on the position within a pixel,
//! so the output is bit for bit the same.

mod find;
mod model;
mod resample;
#[cfg(test)]
mod tests;
pub(crate) mod tuning;

pub use model::Normalized;

use crate::dataset::Dataset;
use crate::image_io::ImageSpec;
use crate::{Error, Result};
use find::{median, Placement};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use tuning::{DARK_LEVEL, HALF_LEVEL, NOISE_FACTOR};

/// What the stage normalises.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct NormalizeParams {
    /// Centre the object and scale it to a fixed size.
    pub geometry: bool,
    /// Bring the object to a fixed brightness.
    pub brightness: bool,
}

impl NormalizeParams {
    /// Position and scale, not brightness: what `--normalize` asks for.
    pub fn geometry() -> Self {
        NormalizeParams { geometry: true, brightness: false }
    }
}

/// How the background's level is found.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum Background {
    /// Black: level 0 in every image (the training views' borders are dark).
    Dark,
    /// Measured in each image: the median of its border.
    Border,
}

/// Why an image cannot be normalised.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum Rejection {
    /// Nothing differs from the background by more than the threshold.
    #[error("no object found: no pixel differs from the background (level {level:.4}) by more than {threshold:.4}")]
    Empty {
        /// The threshold used.
        threshold: f32,
        /// The background level (first channel).
        level: f32,
    },
    /// A second region as heavy as a share of the object's.
    #[error("several blobs: {count} separate regions, the second with {:.0}% of the largest one's weight (two objects, or one in pieces); crop the image to one object", share * 100.0)]
    SeveralBlobs {
        /// Regions of at least 5% (`BLOB_SHARE`, normalize/tuning.rs) of the largest.
        count: usize,
        /// The second region's weight over the largest's.
        share: f64,
    },
    /// The object reaches the frame edge while the training views keep it inside.
    #[error("the object touches the frame edge ({}), so part of it may be outside the image and its position and size are unknown; the training views keep it inside the frame", sides_text(sides))]
    TouchesEdge {
        /// Left, right, top, bottom.
        sides: [bool; 4],
    },
    /// The image has a value that is not a finite number.
    #[error("the image has a value that is not a finite number")]
    NotFinite,
    /// A placement asked of [`Normalizer::place`] that is not a finite position and a positive
    /// radius.
    #[error("cannot place the object at column {}, row {} with radius {}: a finite position and a positive radius are needed", at[0], at[1], at[2])]
    Placement {
        /// The placement asked.
        at: [f64; 3],
    },
    /// The image (or the output) has another number of values than the stage's images.
    #[error("{got} values where the stage's images have {expected}")]
    Size {
        /// Values per image of the stage.
        expected: usize,
        /// Values given.
        got: usize,
    },
}

fn sides_text(s: &[bool; 4]) -> String {
    ["left", "right", "top", "bottom"].iter().zip(s).filter(|(_, &t)| t).map(|(n, _)| *n).collect::<Vec<_>>().join(", ")
}

/// The fitted stage: what it found on the training images, stored in the model file.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Normalizer {
    /// Width of the images (pixels).
    pub width: u32,
    /// Height of the images.
    pub height: u32,
    /// Interleaved channels per pixel (1 or 3).
    pub channels: usize,
    /// How the background's level is found.
    pub background: Background,
    /// The smallest deviation from the background that is foreground (a fraction of full
    /// brightness).
    pub threshold: f32,
    /// Whether the object may touch the frame edge (the training views do, most of them).
    pub edges: bool,
    /// The radius of gyration the object is scaled to (pixels): the training views' median.
    /// `None`: position and scale are left alone.
    pub radius: Option<f64>,
    /// The brightness (weight per squared radius) the object is brought to: the training views'
    /// median. `None`: brightness is left alone.
    pub brightness: Option<f64>,
}

impl Normalizer {
    /// Fits the stage on `train`'s images: the background, the threshold, whether the object may
    /// touch the edge, and the target radius and brightness. A training image the stage cannot
    /// normalise is an error naming it.
    pub fn fit(train: &Dataset, params: NormalizeParams) -> Result<Normalizer> {
        Self::fit_sets(std::slice::from_ref(train), params)
    }

    /// As [`Normalizer::fit`], on the images of several data sets of one image size together
    /// (the training views of several objects: one stage for all of them).
    pub fn fit_sets(sets: &[Dataset], params: NormalizeParams) -> Result<Normalizer> {
        if !params.geometry && !params.brightness {
            return Err(Error::invalid("normalisation", "none", "ask for position and scale, brightness, or both"));
        }
        let Some(first) = sets.first() else { return Err(Error::invalid("normalisation", "no images", "needs training images to fit on")) };
        if let Some(d) = sets.iter().find(|d| d.spec() != first.spec()) {
            return Err(Error::invalid("normalisation", d.manifest().root().display(), "images of another size or colour than the first set's"));
        }
        // Every image as (set, index within it), in order.
        let rows: Vec<(&Dataset, usize)> = sets.iter().flat_map(|d| (0..d.len()).map(move |i| (d, i))).collect();
        let row = |i: usize| rows[i].0.row(rows[i].1);
        let spec = first.spec();
        let (w, h, c) = (spec.width as usize, spec.height as usize, spec.color.channels());
        if w < 3 || h < 3 {
            return Err(Error::invalid("normalisation", format!("{w}x{h} images"), "needs images of at least 3x3 pixels"));
        }
        let borders: Vec<find::Border> = (0..rows.len()).into_par_iter().map(|i| find::border(row(i), w, h, c, None)).collect();
        let mut medians: Vec<f32> = borders.iter().map(|b| b.median[..c].iter().sum::<f32>() / c as f32).collect();
        let background = if median(&mut medians) <= DARK_LEVEL { Background::Dark } else { Background::Border };
        let dark = [0.0f32; 3];
        let mut q90: Vec<f32> = match background {
            Background::Dark => (0..rows.len()).into_par_iter().map(|i| find::border(row(i), w, h, c, Some(dark)).q90).collect(),
            Background::Border => borders.iter().map(|b| b.q90).collect(),
        };
        let threshold = HALF_LEVEL.max(NOISE_FACTOR * median(&mut q90));
        let name = |i: usize| rows[i].0.manifest().image_path(rows[i].1);
        let found: Vec<Placement> = (0..rows.len())
            .into_par_iter()
            .map(|i| {
                find::locate(row(i), w, h, c, background, threshold, true).map_err(|r| Error::Normalize { image: name(i).display().to_string(), reason: r })
            })
            .collect::<Result<_>>()?;
        let touching: Vec<usize> = (0..found.len()).filter(|&i| found[i].touches.iter().any(|&t| t)).collect();
        let edges = 2 * touching.len() >= found.len();
        if !edges {
            if let Some(&i) = touching.first() {
                return Err(Error::Normalize { image: name(i).display().to_string(), reason: Rejection::TouchesEdge { sides: found[i].touches } });
            }
        }
        let mut radii: Vec<f64> = found.iter().map(|p| p.radius).collect();
        let mut bright: Vec<f64> = found.iter().map(Placement::brightness).collect();
        Ok(Normalizer {
            width: spec.width,
            height: spec.height,
            channels: c,
            background,
            threshold,
            edges,
            radius: params.geometry.then(|| median64(&mut radii)),
            brightness: params.brightness.then(|| median64(&mut bright)),
        })
    }

    /// One line saying what the stage does, for the record.
    pub fn describe(&self) -> String {
        let background = match self.background {
            Background::Dark => "dark background".to_string(),
            Background::Border => "background measured on each image's border".to_string(),
        };
        let mut what = Vec::new();
        if let Some(r) = self.radius {
            what.push(format!("object centred and scaled to a radius of gyration of {r:.2} pixels"));
        }
        if let Some(b) = self.brightness {
            what.push(format!("brought to brightness {b:.4}"));
        }
        let edges = if self.edges { "; the training views touch the frame edge, so queries may" } else { "" };
        format!("normalised: {}; {background}, threshold {:.4}{edges}", what.join(", "), self.threshold)
    }

    /// What the stage normalises.
    pub fn params(&self) -> NormalizeParams {
        NormalizeParams { geometry: self.radius.is_some(), brightness: self.brightness.is_some() }
    }

    /// Features per image.
    pub fn features(&self) -> usize {
        self.width as usize * self.height as usize * self.channels
    }

    /// Checks that the stage fits images of `spec`.
    pub(crate) fn check_spec(&self, spec: &ImageSpec) -> std::result::Result<(), String> {
        if (spec.width, spec.height, spec.color.channels()) != (self.width, self.height, self.channels) {
            return Err(format!(
                "normalisation for {}x{}x{} images in a model of {}x{}x{}",
                self.width,
                self.height,
                self.channels,
                spec.width,
                spec.height,
                spec.color.channels()
            ));
        }
        let finite = |v: Option<f64>| v.is_none_or(|v| v.is_finite() && v > 0.0);
        let usable = self.threshold.is_finite() && self.threshold > 0.0 && finite(self.radius) && finite(self.brightness);
        if !usable || self.params() == NormalizeParams::default() {
            return Err("damaged normalisation settings".into());
        }
        Ok(())
    }

    /// Finds the object in `image` (one row of [`Normalizer::features`] values) without
    /// resampling it: `Ok` when [`Normalizer::apply`] would normalise it.
    pub fn check(&self, image: &[f32]) -> std::result::Result<(), Rejection> {
        self.locate(image).map(|_| ())
    }

    fn locate(&self, image: &[f32]) -> std::result::Result<Placement, Rejection> {
        if image.len() != self.features() {
            return Err(Rejection::Size { expected: self.features(), got: image.len() });
        }
        find::locate(image, self.width as usize, self.height as usize, self.channels, self.background, self.threshold, self.edges)
    }

    /// Normalises `image` into `out` (both one row of [`Normalizer::features`] values): the
    /// image minus its background level, resampled so that the object is centred at its fixed
    /// size, times the brightness gain.
    pub fn apply(&self, image: &[f32], out: &mut [f32]) -> std::result::Result<(), Rejection> {
        let centre = [(self.width as f64 - 1.0) / 2.0, (self.height as f64 - 1.0) / 2.0];
        self.resample(image, self.radius.map(|r| [centre[0], centre[1], r]), out)
    }

    /// The object's centroid (column, row, in pixels of the frame) and radius of gyration in
    /// `image`, as the stage finds them.
    pub fn placement(&self, image: &[f32]) -> std::result::Result<[f64; 3], Rejection> {
        let p = self.locate(image)?;
        Ok([p.origin.0 as f64 + p.cx, p.origin.1 as f64 + p.cy, p.radius])
    }

    /// As [`Normalizer::apply`], but the object's centroid goes to `at[0], at[1]` (column, row,
    /// in pixels of the frame) and its radius of gyration becomes `at[2]`, whether or not the
    /// stage normalises position and scale: [`Normalizer::placement`]'s numbers put an image
    /// back where it was.
    pub fn place(&self, image: &[f32], at: [f64; 3], out: &mut [f32]) -> std::result::Result<(), Rejection> {
        if !(at.iter().all(|v| v.is_finite()) && at[2] > 0.0) {
            return Err(Rejection::Placement { at });
        }
        self.resample(image, Some(at), out)
    }

    /// The image minus its background level, times the brightness gain, resampled so that the
    /// object's centroid and radius become `at` (left in place when `None`).
    fn resample(&self, image: &[f32], at: Option<[f64; 3]>, out: &mut [f32]) -> std::result::Result<(), Rejection> {
        if out.len() != self.features() {
            return Err(Rejection::Size { expected: self.features(), got: out.len() });
        }
        let p = self.locate(image)?;
        let (w, h, c) = (self.width as usize, self.height as usize, self.channels);
        let shifted: Vec<f32> = image.chunks_exact(c).flat_map(|px| px.iter().zip(&p.level).map(|(v, b)| v - b)).collect();
        let gain = self.brightness.map_or(1.0, |b| (b / p.brightness()) as f32);
        match at {
            Some([x, y, r]) => {
                // Output position u samples the source at `origin + rel + (u - centre) * step`;
                // the centroid, at `origin + cx`, lands on u = x.
                let step = p.radius / r;
                let tx = resample::taps(w, p.origin.0, p.cx + ((w as f64 - 1.0) / 2.0 - x) * step, step);
                let ty = resample::taps(h, p.origin.1, p.cy + ((h as f64 - 1.0) / 2.0 - y) * step, step);
                resample::resample(&shifted, (w, h, c), &tx, &ty, gain, out);
            }
            None => out.iter_mut().zip(&shifted).for_each(|(o, v)| *o = v * gain),
        }
        Ok(())
    }

    /// Normalises a batch of images (rows of [`Normalizer::features`] values): the normalised
    /// rows of the images it accepts, in order, and for every image `None` or why it refused it.
    pub fn apply_batch(&self, images: &[f32]) -> (Vec<f32>, Vec<Option<Rejection>>) {
        let m = self.features();
        let mut out = vec![0.0f32; images.len() / m * m];
        let verdicts: Vec<Option<Rejection>> = out.par_chunks_mut(m).zip(images.par_chunks_exact(m)).map(|(o, q)| self.apply(q, o).err()).collect();
        let mut kept = 0;
        for (i, v) in verdicts.iter().enumerate() {
            if v.is_none() {
                out.copy_within(i * m..(i + 1) * m, kept * m);
                kept += 1;
            }
        }
        out.truncate(kept * m);
        (out, verdicts)
    }

    /// Normalises a batch of queries (rows of [`Normalizer::features`] values); the first one the
    /// stage refuses is an error naming its place in the batch.
    pub(crate) fn apply_queries(&self, queries: &[f32]) -> Result<Vec<f32>> {
        let (rows, verdicts) = self.apply_batch(queries);
        match verdicts.into_iter().enumerate().find_map(|(i, v)| v.map(|r| (i, r))) {
            Some((i, reason)) => Err(Error::Normalize { image: format!("query #{i} of the batch"), reason }),
            None => Ok(rows),
        }
    }

    /// Normalises every image of `data`; an image the stage refuses is an error naming it.
    pub fn apply_dataset(&self, data: &Dataset) -> Result<Dataset> {
        let m = self.features();
        let mut out = vec![0.0f32; data.len() * m];
        let results: Vec<std::result::Result<(), Rejection>> = out.par_chunks_mut(m).enumerate().map(|(i, row)| self.apply(data.row(i), row)).collect();
        // The first refused image in data set order, so the error is the same on every run.
        if let Some((i, Err(r))) = results.into_iter().enumerate().find(|(_, r)| r.is_err()) {
            return Err(Error::Normalize { image: data.manifest().image_path(i).display().to_string(), reason: r });
        }
        Dataset::from_features(data.manifest().clone(), data.spec(), out)
    }
}

/// The upper median of `v` (reordered; not empty).
pub(crate) fn median64(v: &mut [f64]) -> f64 {
    let k = v.len() / 2;
    *v.select_nth_unstable_by(k, f64::total_cmp).1
}
