//! Normalisation: the object found in each image, centred and scaled to a fixed size (and,
//! optionally, brought to a fixed brightness) before any method sees it, so that images taken
//! as a camera in a cell takes them (the object anywhere in the frame, nearer or farther,
//! brighter or darker) are compared with the training views as if they had been registered
//! like them. Murase & Nayar's system does this before recognition and pose; COIL's images were
//! prepared so by their makers.
//!
//! A [`Normalizer`] is fitted on the training images and stored in the model file
//! ([`crate::model::ModelMeta::normalize`]); training and query images go through the same
//! stage ([`Normalized`](crate::model::Normalized), a model wrapper any method's model fits in; for many objects, one stage
//! fitted on all their training views, [`crate::recognize::ObjectModel::fit_normalized`]). For
//! each image:
//!
//! 1. **Background.** Its level is 0 when the training views' backgrounds are dark, otherwise the
//!    median of the image's border, per image (so a change of lighting moves it). Everything
//!    after works on the image minus this level.
//! 2. **Object.** Foreground is where a pixel deviates from the level by more than a threshold:
//!    the one chosen from the training images' borders (their noise, at least half a gray
//!    level), raised to the query's own border noise when the border is background. Its
//!    8-connected regions are found; the heaviest (by summed deviation) and every region near
//!    it (within its size, `JOIN_GAP`) are the object, so a handle, a stem or a part that a dark
//!    band cuts off counts with it; regions lighter than 0.5% of the heaviest (`PART_SHARE`) are
//!    specks and are left out (normalize/tuning.rs).
//! 3. **Position and size.** The centroid and the radius of gyration (root-mean-square distance
//!    from the centroid) of the object's deviations.
//! 4. **Resampling.** The image is resampled (separable cubic, anti-aliased when shrinking) so
//!    that the centroid lies at the frame's centre and the radius equals the training views'
//!    median radius: one scale for both axes, so the aspect ratio is kept.
//! 5. **Brightness** (optional). The result is multiplied so that the object's weight per
//!    squared radius equals the training views' median: a change of exposure or of the light's
//!    strength is undone (clipped pixels stay clipped).
//!
//! A noisy query (its pixel noise, `find::noise`, more than twice the training views') is found
//! on a copy smoothed by a 5 x 5 box, its threshold from the smoothed noise, its weights freed of
//! clipped noise's lift, and its radius corrected by what the training views show at that noise
//! ([`Normalizer::noisy_radius`]): the noise would otherwise cut the object's faint parts away
//! and move its centre and size.
//!
//! An image is refused, with a [`Rejection`] that says why, only where this cannot work: no
//! object (nothing differs from the background), a value that is not a number, or, in a query,
//! an object that touches the frame edge where no training view does (part of it may be
//! outside, so its position and size are unknown). A training view with a second object apart
//! from the first (farther than its size, and heavy enough not to be a speck) stops training,
//! naming it; in a query such a region is left out. `eval` counts refused images apart.
//!
//! Whether to normalise at all, and what, is chosen on held-out training views by
//! [`crate::MethodSpec::fit_with_stage`]; [`StageChoice`] is the record of it.
//!
//! The stage is exact for a move by whole pixels: the moments are taken from the object's
//! bounding box corner and the resampling's weights depend only on the position within a pixel,
//! so the output is bit for bit the same.

mod choice;
mod find;
mod resample;
#[cfg(test)]
mod tests;
pub(crate) mod tuning;

pub use crate::error::Rejection;
pub use choice::{CandidateScore, NoisyScore, StageChoice, StageRule};

use crate::dataset::Dataset;
use crate::image_io::ImageSpec;
use crate::{Error, Result};
use find::{median, Placement};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};
use tuning::{CALIBRATION_NOISE, CALIBRATION_SEED, CALIBRATION_VIEWS, DARK_LEVEL, HALF_LEVEL, NOISE_FACTOR, NOISY};

/// What the stage normalises.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct NormalizeParams {
    /// Centre the object and scale it to a fixed size.
    pub geometry: bool,
    /// Bring the object to a fixed brightness.
    pub brightness: bool,
}

impl NormalizeParams {
    /// Nothing: images are used as they are.
    pub const OFF: NormalizeParams = NormalizeParams { geometry: false, brightness: false };

    /// Every choice, the simplest first: off, brightness, geometry, all.
    pub const CHOICES: [NormalizeParams; 4] = [
        NormalizeParams::OFF,
        NormalizeParams { geometry: false, brightness: true },
        NormalizeParams { geometry: true, brightness: false },
        NormalizeParams { geometry: true, brightness: true },
    ];

    /// Position and scale, not brightness.
    pub fn geometry() -> Self {
        NormalizeParams { geometry: true, brightness: false }
    }

    /// Position, scale and brightness.
    pub fn all() -> Self {
        NormalizeParams { geometry: true, brightness: true }
    }

    /// Whether it normalises anything.
    pub fn is_on(&self) -> bool {
        self.geometry || self.brightness
    }

    /// Its name: `off`, `geometry`, `brightness` or `all`.
    pub fn name(&self) -> &'static str {
        match (self.geometry, self.brightness) {
            (false, false) => "off",
            (true, false) => "geometry",
            (false, true) => "brightness",
            (true, true) => "all",
        }
    }

    /// The choice called `name` ([`NormalizeParams::name`]).
    pub fn from_name(name: &str) -> Result<Self> {
        Self::CHOICES.into_iter().find(|c| c.name() == name).ok_or_else(|| Error::invalid("normalisation", name, "expected off, geometry, brightness or all"))
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
    /// Whether the object may touch the frame edge: some training views do.
    pub edges: bool,
    /// Whether most training views touch the frame edge (the data is framed to its objects, as
    /// COIL's makers framed theirs), so that the border is not background and the noise is not
    /// measured on it.
    pub framed: bool,
    /// The largest pixel noise the training views show (Immerkaer's estimate of its standard
    /// deviation, a fraction of full brightness; clean images' edges and texture give a floor).
    /// A query with more than twice this (`NOISY`, normalize/tuning.rs) is found on a smoothed copy.
    pub noise: f32,
    /// The object's radius on noisy images against clean ones, calibrated on the training views:
    /// (pixel noise, log of the radius's ratio) points, sorted by the noise. Empty when the
    /// stage does not scale.
    #[serde(default)]
    pub noisy_radius: Vec<[f32; 2]>,
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
    pub fn fit_sets<D: std::borrow::Borrow<Dataset> + Sync>(sets: &[D], params: NormalizeParams) -> Result<Normalizer> {
        let sets: Vec<&Dataset> = sets.iter().map(|d| d.borrow()).collect();
        if !params.geometry && !params.brightness {
            return Err(Error::invalid("normalisation", "none", "ask for position and scale, brightness, or both"));
        }
        let Some(first) = sets.first() else { return Err(Error::invalid("normalisation", "no images", "needs training images to fit on")) };
        if let Some(d) = sets.iter().find(|d| d.spec() != first.spec()) {
            return Err(Error::invalid("normalisation", d.manifest().root().display(), "images of another size or colour than the first set's"));
        }
        // Every image as (set, index within it), in order.
        let rows: Vec<(&Dataset, usize)> = sets.iter().flat_map(|&d| (0..d.len()).map(move |i| (d, i))).collect();
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
                let p = find::locate(row(i), w, h, c, find::Rules { background, threshold, framed: true, edges: true }, None)
                    .map_err(|r| Error::Normalize { image: name(i).display().to_string(), reason: r })?;
                match p.apart {
                    Some(a) => Err(Error::Normalize {
                        image: name(i).display().to_string(),
                        reason: Rejection::SecondObject { share: a.share, gap: a.gap, limit: a.limit },
                    }),
                    None => Ok(p),
                }
            })
            .collect::<Result<_>>()?;
        // Queries may touch the frame edge when a training view does; when most do, the
        // border is the data's framing, not background.
        let touching = found.iter().filter(|p| p.touches.iter().any(|&t| t)).count();
        let (edges, framed) = (touching > 0, 2 * touching >= found.len());
        let noise = (0..rows.len()).into_par_iter().map(|i| find::noise(row(i), w, h, c)).reduce(|| 0.0, f32::max);
        let mut radii: Vec<f64> = found.iter().map(|p| p.radius).collect();
        let mut bright: Vec<f64> = found.iter().map(Placement::brightness).collect();
        let mut stage = Normalizer {
            width: spec.width,
            height: spec.height,
            channels: c,
            background,
            threshold,
            edges,
            framed,
            noise,
            noisy_radius: Vec::new(),
            radius: params.geometry.then(|| median64(&mut radii)),
            brightness: params.brightness.then(|| median64(&mut bright)),
        };
        if params.geometry {
            stage.noisy_radius = stage.calibrate_noisy_radius(&|i| row(i), &found);
        }
        Ok(stage)
    }

    /// How much larger than on the clean image the radius comes out on a noisy one, as a
    /// function of the noise: for each of [`CALIBRATION_NOISE`], the training views (up to
    /// [`CALIBRATION_VIEWS`] of them, evenly spread) with that noise added, their median pixel
    /// noise and the median log ratio of their radius to the clean view's. Sorted by the noise.
    fn calibrate_noisy_radius<'a>(&self, row: &(dyn Fn(usize) -> &'a [f32] + Sync), found: &[Placement]) -> Vec<[f32; 2]> {
        let step = found.len().div_ceil(CALIBRATION_VIEWS).max(1);
        let views: Vec<usize> = (0..found.len()).step_by(step).collect();
        let mut points = Vec::new();
        for (l, &amplitude) in CALIBRATION_NOISE.iter().enumerate() {
            let mut measured: Vec<(f32, f64)> = views
                .par_iter()
                .filter_map(|&i| {
                    let mut noisy = row(i).to_vec();
                    let m = noisy.len();
                    crate::pixel_noise::add_uniform_noise(&mut noisy, m, amplitude, CALIBRATION_SEED + (l * found.len() + i) as u64).ok()?;
                    let (p, sigma) = self.find(&noisy).ok()?;
                    sigma.map(|s| (s, (p.radius / found[i].radius).ln()))
                })
                .collect();
            if measured.len() * 2 < views.len() {
                continue;
            }
            let mid = measured.len() / 2;
            let sigma = *measured.select_nth_unstable_by(mid, |a, b| a.0.total_cmp(&b.0)).1;
            let bias = *measured.select_nth_unstable_by(mid, |a, b| a.1.total_cmp(&b.1)).1;
            points.push([sigma.0, bias.1 as f32]);
        }
        points.sort_by(|a, b| a[0].total_cmp(&b[0]));
        points
    }

    /// The calibrated log ratio of a noisy image's radius to its clean one's at pixel noise
    /// `sigma`: 0 at the training views' noise, linear between the calibrated points, the last
    /// point's beyond it.
    fn radius_bias(&self, sigma: f32) -> f64 {
        let mut prev = [NOISY * self.noise, 0.0];
        for &p in &self.noisy_radius {
            if sigma <= p[0] {
                let t = if p[0] > prev[0] { ((sigma - prev[0]) / (p[0] - prev[0])).clamp(0.0, 1.0) } else { 1.0 };
                return (prev[1] + t * (p[1] - prev[1])) as f64;
            }
            prev = p;
        }
        prev[1] as f64
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
        let edges = match (self.framed, self.edges) {
            (true, _) => "; the training views are framed to the object, so queries may touch the frame edge",
            (false, true) => "; some training views touch the frame edge, so queries may",
            _ => "",
        };
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
        let usable =
            self.threshold.is_finite() && self.threshold > 0.0 && self.noise.is_finite() && self.noise >= 0.0 && finite(self.radius) && finite(self.brightness);
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
        let (mut p, sigma) = self.find(image)?;
        // A noisy image's radius comes out larger by what the training views showed at that
        // noise.
        if let Some(s) = sigma {
            p.radius /= self.radius_bias(s).exp();
        }
        Ok(p)
    }

    /// The object in `image` as found, and the image's pixel noise when it is noisy (found on a
    /// smoothed copy), before any correction.
    fn find(&self, image: &[f32]) -> std::result::Result<(Placement, Option<f32>), Rejection> {
        let (w, h, c) = (self.width as usize, self.height as usize, self.channels);
        // A noisy query is found on a smoothed copy.
        let sigma = find::noise(image, w, h, c);
        let noisy = (sigma > NOISY * self.noise).then_some(sigma);
        let rules = find::Rules { background: self.background, threshold: self.threshold, framed: self.framed, edges: self.edges };
        find::locate(image, w, h, c, rules, noisy).map(|p| (p, noisy))
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

    /// How many regions of the foreground the stage takes as the object in `image`: 1 for an
    /// object seen in one piece, more where a dark part or a gap cuts it (a handle, a saucer).
    pub fn parts(&self, image: &[f32]) -> std::result::Result<usize, Rejection> {
        self.locate(image).map(|p| p.parts)
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
        let shifted: Vec<f32> = match c {
            1 => image.iter().map(|v| v - p.level[0]).collect(),
            _ => image.chunks_exact(c).flat_map(|px| px.iter().zip(&p.level).map(|(v, b)| v - b)).collect(),
        };
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
            Some((i, reason)) => Err(Error::Normalize { image: format!("query row {i} of the batch"), reason }),
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
