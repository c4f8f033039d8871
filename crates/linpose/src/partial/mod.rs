//! Training statistics that merge: what the linear model and the eigenspace need from a shard of
//! the training set is a sum, so shards summed apart (other processes, other machines) add up to
//! the statistics of the whole set, and the model fitted from the merged sum is the
//! single-process model, up to the order of the sums' rounding.
//!
//! Two ways to split the set, picked from the sizes so that no shuffle is needed either way
//! ([`Split`]):
//! - [`Split::Images`]: shards of images, for the linear model with more images than pixels
//!   (N > M). A shard gives X^T X (M x M), X^T P (M x K) and P^T P over its images
//!   (streamed fit (`methods::linear::stream`)'s least-squares path, which takes a fixed ridge and no
//!   centring); the merged model is W = (X^T X + lambda I)^{-1} X^T P. A partial holds about
//!   4 M^2 bytes (X^T X's lower triangle in f64), whatever its number of images.
//! - [`Split::Pixels`]: shards of pixels (feature columns) of every image, for the linear model
//!   with N <= M (the paper's minimum-norm fit through the N x N Gram matrix, every ridge rule and
//!   centring) and for the eigenspace (whose PCA is the eigendecomposition of the Gram matrix of
//!   the centred unit-energy images, which follows from X X^T (the eigenspace's `pca` module).
//!   A shard gives X_s X_s^T over its pixels (centred about the mean image for a centred linear
//!   model: the mean of a pixel needs only that pixel) and keeps its pixels, which the weights
//!   (W = X^T D) or the eigenimages (Xc^T V) are made of when finishing. A partial holds
//!   4 N^2 bytes (the Gram matrix's lower triangle) and 4 N w bytes for its w pixels.
//!
//! Which methods fit so, and how each cuts a set, is the method's to say
//! ([`Method::merges`]; its `partial.rs`): these statistics find the method by the name they
//! record, and name none themselves.
//!
//! Each partial records what must agree to merge: the method and its settings, the image size,
//! the pose parameters, the training set (a fingerprint of its image names and poses), and which
//! images or pixels it covers; merging refuses a mismatch or an overlap by name, and finishing
//! refuses a set whose shards do not cover it all.

mod file;
mod tuning;

pub use crate::model::partial_fit::Split;

use crate::dataset::Dataset;
use crate::image_io::{read_features, ColorMode, ImageSpec};
use crate::linalg::mean_row;
use crate::manifest::Manifest;
use crate::model::partial_fit::PartialFit;
use crate::model::{AnyModel, Method, Settings};
use crate::normal_equations::rows::{accumulate_rows, disk_reader, BLOCK};
use crate::normal_equations::NormalEquations;
use crate::pose::PoseSpace;
use crate::{Error, Result};
use faer::Mat;
use serde::{Deserialize, Serialize};
use std::ops::Range;
use std::sync::Arc;
use tuning::CONTENT_SAMPLE;

/// A shard's data for [`Partial::accumulate`].
#[derive(Debug, Clone, Copy)]
pub enum Shard<'a> {
    /// Images `start..start + features.len() / M`, one row of M features each.
    Images {
        /// The first image's index in the training set.
        start: usize,
        /// Row-major, M features an image.
        features: &'a [f32],
    },
    /// Pixels (features) `start..start + features.len() / N` of every training image.
    Pixels {
        /// The first pixel's index in an image's features.
        start: usize,
        /// Row-major N x w: image i's w pixels in row i.
        features: &'a [f32],
    },
}

/// What two partials must share to merge (stored in a partial file's header).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
struct Header {
    method: String,
    /// The settings by name, sorted.
    settings: Vec<(String, String)>,
    spec: ImageSpec,
    space: PoseSpace,
    /// Training images in the whole set.
    n: usize,
    split: Split,
    /// FNV-1a of the training set's image names and poses.
    fingerprint: String,
    /// FNV-1a of the bytes of a sample of the training set's image files
    /// ([`content_fingerprint`]), once a shard was read from disk; `None` for statistics of
    /// images given in memory (and in files written before it was recorded).
    #[serde(default)]
    content: Option<String>,
    /// The training set's folder and image names ([`Split::Pixels`] only: finishing rebuilds it).
    root: String,
    names: Vec<String>,
}

/// Sums over the images or pixels accumulated so far.
enum Stats {
    Images(Box<NormalEquations>),
    Pixels {
        /// X X^T's lower triangle, packed row by row (N (N + 1) / 2).
        gram: Vec<f64>,
        /// The pixels accumulated: (first pixel, N x w row-major).
        blocks: Vec<(usize, Vec<f32>)>,
    },
}

/// Training statistics of part of a training set, which merge with those of the other parts
/// into the model of the whole (see the module documentation).
///
/// ```
/// use linpose::image_io::{ColorMode, ImageSpec};
/// use linpose::partial::{Partial, Shard};
/// use linpose::{Dataset, Estimator, LinearParams, Manifest, Param, PoseModel, PoseSpace, Settings};
///
/// // 40 views of 6 x 5 pixels: more images than pixels, so shards are sets of images.
/// let space = PoseSpace::new(vec![Param::circular("azimuth", 360.0)])?;
/// let poses: Vec<f64> = (0..40).map(|i| 9.0 * i as f64).collect();
/// let x: Vec<f32> = poses.iter().flat_map(|a| (0..30).map(move |p| (0.5 + 0.4 * (a.to_radians() + p as f64 * 0.7).sin()) as f32)).collect();
/// let names: Vec<String> = (0..40).map(|i| format!("{i}.png")).collect();
/// let manifest = Manifest::new(".", space, names, poses)?;
/// let spec = ImageSpec { width: 6, height: 5, color: ColorMode::Gray };
///
/// let settings = Settings::new().set("ridge", "1e-3");
/// let mut a = Partial::new(linpose::Method::from_name("linear")?, &settings, &manifest, spec)?;
/// let mut b = a.empty();
/// a.accumulate(Shard::Images { start: 0, features: &x[..25 * 30] })?;
/// b.accumulate(Shard::Images { start: 25, features: &x[25 * 30..] })?;
/// a.merge(b)?;
/// let merged = a.finish()?;
///
/// let whole = LinearParams::default().ridge(1e-3).fit(&Dataset::from_features(manifest, spec, x.clone())?)?;
/// let q = &x[7 * 30..8 * 30];
/// assert!((merged.predict(q)?[0] - whole.predict(q)?[0]).abs() < 1e-4);
/// # Ok::<(), linpose::Error>(())
/// ```
pub struct Partial {
    header: Header,
    method: &'static Method,
    /// The method's fit from the sums, with its settings.
    fit: Arc<dyn PartialFit>,
    /// The training poses (N x parameters).
    poses: Vec<f64>,
    /// Images or pixels accumulated: sorted, disjoint ranges.
    covered: Vec<Range<usize>>,
    stats: Stats,
    /// Where it came from, for errors: a file, or "shard I/N".
    source: String,
}

impl std::fmt::Debug for Partial {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(&self.describe())
    }
}

impl Partial {
    /// Empty statistics for fitting `method` with `settings` on the images of `manifest`, each
    /// of `spec`. Errors name a method or setting that cannot be fitted from partial statistics.
    pub fn new(method: &'static Method, settings: &Settings, manifest: &Manifest, spec: ImageSpec) -> Result<Self> {
        let (n, m) = (manifest.len(), spec.features());
        let fit = partial_fit(method, settings)?;
        let split = fit.split(n, m)?;
        let mut sorted: Vec<(String, String)> = settings.iter().map(|(a, b)| (a.to_string(), b.to_string())).collect();
        sorted.sort();
        let (root, names) = match split {
            Split::Pixels => (manifest.root().display().to_string(), manifest.images().to_vec()),
            Split::Images => (String::new(), Vec::new()),
        };
        let header = Header {
            method: method.name.to_string(),
            settings: sorted,
            spec,
            space: manifest.space().clone(),
            n,
            split,
            fingerprint: fingerprint(manifest),
            content: None,
            root,
            names,
        };
        Ok(Partial::empty_of(header, method, fit, manifest.poses().to_vec(), "partial statistics".into()))
    }

    /// [`Partial::new`] for the images of `manifest` read with `color`, their size taken from
    /// the first image's header (every other must have it; reading a shard checks).
    pub fn for_images(method: &'static Method, settings: &Settings, manifest: &Manifest, color: ColorMode) -> Result<Self> {
        if manifest.is_empty() {
            return Err(Error::Dataset { path: manifest.root().to_path_buf(), message: "no training images".into() });
        }
        Partial::new(method, settings, manifest, manifest.first_image_spec(color)?)
    }

    fn empty_of(header: Header, method: &'static Method, fit: Arc<dyn PartialFit>, poses: Vec<f64>, source: String) -> Self {
        let (n, m, k) = (header.n, header.spec.features(), header.space.encoded_len());
        let stats = match header.split {
            Split::Images => Stats::Images(Box::new(NormalEquations::new(m, k))),
            Split::Pixels => Stats::Pixels { gram: vec![0.0; n * (n + 1) / 2], blocks: Vec::new() },
        };
        Partial { header, method, fit, poses, covered: Vec::new(), stats, source }
    }

    /// Empty statistics for the same fit (to accumulate another shard in).
    pub fn empty(&self) -> Self {
        Partial::empty_of(self.header.clone(), self.method, self.fit.clone(), self.poses.clone(), self.source.clone())
    }

    /// How the training set is cut into shards.
    pub fn split(&self) -> Split {
        self.header.split
    }

    /// Images (or, for [`Split::Pixels`], features per image) to share between the shards.
    pub fn units(&self) -> usize {
        match self.header.split {
            Split::Images => self.header.n,
            Split::Pixels => self.header.spec.features(),
        }
    }

    /// The training images' width and height.
    pub fn image_size(&self) -> (u32, u32) {
        (self.header.spec.width, self.header.spec.height)
    }

    /// The images or pixels accumulated, as sorted disjoint ranges.
    pub fn covered(&self) -> &[Range<usize>] {
        &self.covered
    }

    /// The method.
    pub fn method(&self) -> &'static Method {
        self.method
    }

    /// The images or pixels shard `index` of `count` covers: the set cut into `count` nearly
    /// equal consecutive runs.
    pub fn shard_range(&self, index: usize, count: usize) -> Result<Range<usize>> {
        let units = self.units();
        if count == 0 || index >= count {
            return Err(Error::invalid("shard", format!("{}/{count}", index + 1), "expected I/N with 1 <= I <= N"));
        }
        if count > units {
            return Err(Error::invalid(
                "shard",
                format!("{}/{count}", index + 1),
                format!("more shards than the {units} {} to share", self.header.split.unit()),
            ));
        }
        Ok(index * units / count..(index + 1) * units / count)
    }

    /// Names this partial in errors (e.g. its file).
    pub fn with_source(mut self, source: impl Into<String>) -> Self {
        self.source = source.into();
        self
    }

    /// Adds a shard's images or pixels; refuses the other kind of shard, a size that does not
    /// fit, values that are not finite, and a range already accumulated.
    pub fn accumulate(&mut self, shard: Shard<'_>) -> Result<()> {
        let (n, m) = (self.header.n, self.header.spec.features());
        let (start, features, per, split) = match shard {
            Shard::Images { start, features } => (start, features, m, Split::Images),
            Shard::Pixels { start, features } => (start, features, n, Split::Pixels),
        };
        if split != self.header.split {
            return Err(self.error(format!("a shard of {} given, but this fit is split into shards of {}", split.unit(), self.header.split.unit())));
        }
        if features.is_empty() || !features.len().is_multiple_of(per) {
            return Err(self.error(format!("a shard of {} values, not a whole number of {} of {per} values", features.len(), split.unit())));
        }
        let range = start..start + features.len() / per;
        if range.end > self.units() {
            return Err(self.error(format!("{} {}..{} given, but the set has {}", split.unit(), range.start, range.end, self.units())));
        }
        if let Some(i) = features.iter().position(|v| !v.is_finite()) {
            return Err(self.error(format!("a non-finite value in {} {}", split.unit(), start + i / per)));
        }
        self.cover(range.clone())?;
        let k = self.header.space.encoded_len();
        match &mut self.stats {
            Stats::Images(ne) => {
                let mut p = vec![0.0; range.len() * k];
                for (i, row) in range.clone().zip(p.chunks_exact_mut(k)) {
                    self.header.space.encode(&self.poses[i * self.header.space.len()..(i + 1) * self.header.space.len()], row);
                }
                let mut q = vec![0u8; features.len()];
                let exact = crate::kernels::levels::quantize(features, &mut q);
                ne.add(features, exact.then_some(&q[..]), &p);
            }
            Stats::Pixels { gram, blocks } => {
                let w = range.len();
                let mean = self.fit.centred().then(|| mean_row(features, n, w));
                let g = crate::linalg::gram_f32(features, n, w, mean.as_deref());
                add_lower(gram, &g);
                blocks.push((start, features.to_vec()));
            }
        }
        Ok(())
    }

    /// Reads shard `index` of `count` of `manifest`'s images (the training set this partial was
    /// made for) from disk and accumulates it; `progress` is called with images read.
    pub fn read_shard(&mut self, manifest: &Manifest, color: ColorMode, index: usize, count: usize, progress: &(dyn Fn(u64) + Sync)) -> Result<()> {
        if fingerprint(manifest) != self.header.fingerprint || manifest.space() != &self.header.space {
            return Err(self.error("the data set is not the training set these statistics were made for (other images or poses)"));
        }
        if color != self.header.spec.color {
            return Err(self.error("the colour handling differs from the statistics'"));
        }
        // Two data sets with one manifest (two objects rendered on one grid) differ in their
        // images: the statistics record which images they were read from.
        let content = content_fingerprint(manifest)?;
        if let Some(had) = self.header.content.as_ref().filter(|&had| *had != content) {
            return Err(self.error(format!(
                "the data set's images are not those these statistics were read from (their fingerprint {content} here, {had} there): \
                 the same image names and poses, other pixels"
            )));
        }
        self.header.content = Some(content);
        let range = self.shard_range(index, count)?;
        let spec = self.header.spec;
        let (w, h, m) = (spec.width, spec.height, spec.features());
        let context = format!("the size of the training images, {w}x{h}");
        let mut row = Vec::with_capacity(m);
        match self.header.split {
            Split::Images => {
                if range.is_empty() {
                    return Ok(());
                }
                self.cover(range.clone())?;
                let Stats::Images(ne) = &mut self.stats else { unreachable!("split and stats agree") };
                if let Err(e) = accumulate_rows(manifest, m, range, BLOCK, disk_reader(manifest, spec, context, progress), ne) {
                    // A shard that failed half-way leaves nothing half-added behind.
                    self.covered.clear();
                    self.stats = Stats::Images(Box::new(NormalEquations::new(m, self.header.space.encoded_len())));
                    return Err(e);
                }
                Ok(())
            }
            Split::Pixels => {
                let n = self.header.n;
                let width = range.len();
                let mut cols = vec![0f32; n * width];
                for i in 0..n {
                    row.clear();
                    read_features(&manifest.image_path(i), color, Some((w, h)), &context, &mut row)?;
                    cols[i * width..(i + 1) * width].copy_from_slice(&row[range.clone()]);
                    progress(1);
                }
                self.accumulate(Shard::Pixels { start: range.start, features: &cols })
            }
        }
    }

    /// Adds another partial's statistics (of other images or pixels of the same fit). Refuses,
    /// naming both, statistics of another method, settings, image size, pose parameters or
    /// training set, and images or pixels both hold.
    pub fn merge(&mut self, other: Partial) -> Result<()> {
        let (a, b) = (&self.header, &other.header);
        let differ = |what: &str, x: String, y: String| -> Result<()> {
            if x == y {
                return Ok(());
            }
            Err(self.error(format!("cannot merge with {}: {what} {x} here, {y} there", other.source)))
        };
        differ("method", a.method.clone(), b.method.clone())?;
        let show = |s: &[(String, String)]| {
            if s.is_empty() {
                "(defaults)".to_string()
            } else {
                s.iter().map(|(k, v)| format!("{k}={v}")).collect::<Vec<_>>().join(",")
            }
        };
        differ("settings", show(&a.settings), show(&b.settings))?;
        differ(
            "image size",
            format!("{}x{} ({:?})", a.spec.width, a.spec.height, a.spec.color),
            format!("{}x{} ({:?})", b.spec.width, b.spec.height, b.spec.color),
        )?;
        let params = |s: &PoseSpace| s.params().iter().map(|p| p.name.clone()).collect::<Vec<_>>().join(",");
        differ("pose parameters", params(&a.space), params(&b.space))?;
        if a.space != b.space {
            differ("pose parameters", format!("{:?}", a.space), format!("{:?}", b.space))?;
        }
        differ("training images", a.n.to_string(), b.n.to_string())?;
        differ("shards of", a.split.unit().into(), b.split.unit().into())?;
        differ("training set (fingerprint of image names and poses)", a.fingerprint.clone(), b.fingerprint.clone())?;
        if let (Some(x), Some(y)) = (&a.content, &b.content) {
            differ(
                &format!("training images (fingerprint of the bytes of {} image files spread over the set; the same names and poses)", CONTENT_SAMPLE),
                x.clone(),
                y.clone(),
            )?;
        }
        let content = a.content.clone().or_else(|| b.content.clone());
        // Every overlap is refused before anything is marked, so a refused merge changes nothing.
        if let Some(r) = other.covered.iter().find(|r| self.covered.iter().any(|c| c.start < r.end && r.start < c.end)) {
            return Err(self.error(format!(
                "cannot merge with {}: both hold {} {}..{} (the same shard twice?)",
                other.source,
                self.header.split.unit(),
                r.start,
                r.end
            )));
        }
        for r in &other.covered {
            self.cover(r.clone())?;
        }
        self.header.content = content;
        match (&mut self.stats, other.stats) {
            (Stats::Images(x), Stats::Images(y)) => x.merge(&y),
            (Stats::Pixels { gram, blocks }, Stats::Pixels { gram: g2, blocks: b2 }) => {
                gram.iter_mut().zip(&g2).for_each(|(a, &b)| *a += b);
                blocks.extend(b2);
            }
            _ => unreachable!("the split was checked"),
        }
        Ok(())
    }

    /// The Gram matrix X X^T summed so far over the pixels held ([`Split::Pixels`]; centred
    /// about the mean image for a centred linear model); None for shards of images.
    pub fn gram(&self) -> Option<Mat<f64>> {
        match &self.stats {
            Stats::Pixels { gram, .. } => Some(unpack_lower(gram, self.header.n)),
            Stats::Images(_) => None,
        }
    }

    /// Whether every image (or pixel) of the set has been accumulated.
    pub fn is_complete(&self) -> bool {
        self.covered.len() == 1 && self.covered[0] == (0..self.units())
    }

    /// The model fitted from the statistics of the whole set; refuses statistics that do not
    /// cover it, naming what is missing.
    pub fn finish(self) -> Result<AnyModel> {
        if !self.is_complete() {
            return Err(self.error(format!("the statistics do not cover the training set: missing {}", self.missing())));
        }
        let h = &self.header;
        let (n, m) = (h.n, h.spec.features());
        match self.stats {
            Stats::Images(ne) => self.fit.fit_from_normal_equations(*ne, &h.space, &self.poses, h.spec),
            Stats::Pixels { gram, mut blocks } => {
                blocks.sort_by_key(|b| b.0);
                let mut x = vec![0f32; n * m];
                for (p0, cols) in &blocks {
                    let w = cols.len() / n;
                    for i in 0..n {
                        x[i * m + p0..i * m + p0 + w].copy_from_slice(&cols[i * w..(i + 1) * w]);
                    }
                }
                drop(blocks);
                let manifest = Manifest::new(&h.root, h.space.clone(), h.names.clone(), self.poses)?;
                let train = Dataset::from_features(manifest, h.spec, x)?;
                let g = unpack_lower(&gram, n);
                drop(gram);
                self.fit.fit_from_gram(&train, g)
            }
        }
    }

    /// What the statistics are, in one line.
    pub fn describe(&self) -> String {
        let h = &self.header;
        let held: usize = self.covered.iter().map(|r| r.len()).sum();
        let what = match h.split {
            Split::Images => format!("X^T X of {} features, summed over {held} of {} images", h.spec.features(), h.n),
            Split::Pixels => format!("the {}x{} Gram matrix over {held} of {} pixels, and those pixels", h.n, h.n, h.spec.features()),
        };
        format!("partial statistics of the {} method on {}x{} images: {what}", h.method, h.spec.width, h.spec.height)
    }

    /// Bytes the statistics take in memory (and about that in a file).
    pub fn bytes(&self) -> usize {
        match &self.stats {
            Stats::Images(ne) => {
                let m = ne.m();
                m * (m + 1) / 2 * 8 + m * self.header.space.encoded_len() * 8
            }
            Stats::Pixels { gram, blocks } => gram.len() * 8 + blocks.iter().map(|b| b.1.len() * 4).sum::<usize>(),
        }
    }

    /// The missing ranges, in words.
    fn missing(&self) -> String {
        let mut gaps = Vec::new();
        let mut at = 0;
        for r in &self.covered {
            if r.start > at {
                gaps.push(format!("{}..{}", at, r.start));
            }
            at = r.end;
        }
        if at < self.units() {
            gaps.push(format!("{}..{}", at, self.units()));
        }
        format!("{} {} of {}", self.header.split.unit(), gaps.join(", "), self.units())
    }

    /// Marks `range` accumulated; refuses one that overlaps what is.
    fn cover(&mut self, range: Range<usize>) -> Result<()> {
        if range.is_empty() {
            return Ok(());
        }
        if let Some(r) = self.covered.iter().find(|r| r.start < range.end && range.start < r.end) {
            return Err(self.error(format!(
                "{} {}..{} accumulated twice (already holds {}..{})",
                self.header.split.unit(),
                range.start,
                range.end,
                r.start,
                r.end
            )));
        }
        self.covered.push(range);
        self.covered.sort_by_key(|r| r.start);
        // Join touching runs.
        let mut joined: Vec<Range<usize>> = Vec::with_capacity(self.covered.len());
        for r in self.covered.drain(..) {
            match joined.last_mut() {
                Some(last) if last.end == r.start => last.end = r.end,
                _ => joined.push(r),
            }
        }
        self.covered = joined;
        Ok(())
    }

    fn error(&self, message: impl Into<String>) -> Error {
        Error::Partial { source_name: self.source.clone(), message: message.into() }
    }
}

/// The fit of `method` with `settings` from partial statistics; an error for a method that has
/// none, naming those that have.
fn partial_fit(method: &'static Method, settings: &Settings) -> Result<Arc<dyn PartialFit>> {
    let fit = method.partial.ok_or_else(|| {
        let merging: Vec<&str> = crate::methods::METHODS.iter().filter(|m| m.merges()).map(|m| m.name).collect();
        Error::invalid("method", method.name, format!("fits in one process only; {} fit from merged partial statistics", merging.join(" and ")))
    })?;
    fit(settings)
}

/// Adds the lower triangle of the symmetric `g` to `packed` (row by row).
fn add_lower(packed: &mut [f64], g: &Mat<f64>) {
    let n = g.nrows();
    for r in 0..n {
        let row = &mut packed[r * (r + 1) / 2..r * (r + 1) / 2 + r + 1];
        row.iter_mut().enumerate().for_each(|(c, v)| *v += g[(r, c)]);
    }
}

/// The symmetric n x n matrix of a lower triangle packed row by row.
fn unpack_lower(packed: &[f64], n: usize) -> Mat<f64> {
    Mat::from_fn(n, n, |i, j| {
        let (r, c) = if i >= j { (i, j) } else { (j, i) };
        packed[r * (r + 1) / 2 + c]
    })
}

/// FNV-1a (64-bit) of the image names and the poses' bits, as 16 hex digits.
fn fingerprint(manifest: &Manifest) -> String {
    let mut h = Fnv::new();
    for name in manifest.images() {
        h.eat(name.as_bytes());
        h.eat(&[0]);
    }
    for p in manifest.poses() {
        h.eat(&p.to_bits().to_le_bytes());
    }
    h.hex()
}

/// FNV-1a (64-bit) of the bytes of [`CONTENT_SAMPLE`] image files of `manifest` spread evenly
/// over it (the first and the last among them; all of a smaller set), as 16 hex digits: what
/// tells apart two data sets with the same image names and poses (two objects rendered on one
/// grid). Every shard reads the same files, whichever images it sums, so the fingerprints of
/// shards of one data set agree.
fn content_fingerprint(manifest: &Manifest) -> Result<String> {
    let n = manifest.len();
    let mut h = Fnv::new();
    let k = CONTENT_SAMPLE.min(n);
    let mut last = usize::MAX;
    for j in 0..k {
        let i = if k <= 1 { 0 } else { j * (n - 1) / (k - 1) };
        if i == last {
            continue;
        }
        last = i;
        let path = manifest.image_path(i);
        let bytes = std::fs::read(&path).map_err(|e| Error::io(&path, e))?;
        h.eat(&(i as u64).to_le_bytes());
        h.eat(&(bytes.len() as u64).to_le_bytes());
        h.eat(&bytes);
    }
    Ok(h.hex())
}

/// The 64-bit FNV-1a hash.
struct Fnv(u64);

impl Fnv {
    fn new() -> Self {
        Fnv(0xcbf2_9ce4_8422_2325)
    }

    fn eat(&mut self, bytes: &[u8]) {
        for &b in bytes {
            self.0 ^= b as u64;
            self.0 = self.0.wrapping_mul(0x0000_0100_0000_01b3);
        }
    }

    fn hex(&self) -> String {
        format!("{:016x}", self.0)
    }
}

#[cfg(test)]
mod tests;
