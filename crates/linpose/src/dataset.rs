//! A data set in memory: images as feature rows with their poses, built from arrays already in
//! memory ([`Dataset::new`]) or decoded from a data set folder ([`Dataset::load`]).

use crate::image_io::{read_features, ColorMode, ImageSpec};
use crate::manifest::Manifest;
use crate::pose::PoseSpace;
use crate::{Error, Result};
use rayon::prelude::*;
use std::sync::OnceLock;

/// Images as feature rows (f32 in [0, 1]) with their poses.
///
/// A data set made from 8-bit values ([`Dataset::from_u8`], [`Dataset::from_pixels`], the
/// renderer) keeps them ([`Dataset::pixels_u8`]) and makes the f32 features from them on first
/// use: the linear model's fit reads the 8-bit values only (a quarter of the bytes), and a
/// method that needs the features then holds both (1.25x the features' memory).
#[derive(Debug, Clone)]
pub struct Dataset {
    manifest: Manifest,
    spec: ImageSpec,
    /// The features; made from `pixels` on first use when those are given.
    features: OnceLock<Vec<f32>>,
    /// The 8-bit values the features are made of, when the data set was built from them.
    pixels: Option<Vec<u8>>,
}

impl Dataset {
    /// A data set from arrays in memory: `features` holds one row of `spec.features()` values per
    /// sample (gray values in [0, 1], row-major pixels), `poses` one row of `space.len()` values
    /// (degrees). Samples are named `sample 0`, `sample 1`, ... in errors and evaluations.
    ///
    /// ```
    /// use linpose::image_io::{ColorMode, ImageSpec};
    /// use linpose::{Dataset, Param, PoseSpace};
    ///
    /// let space = PoseSpace::new(vec![Param::circular("azimuth", 360.0)])?;
    /// let spec = ImageSpec { width: 2, height: 1, color: ColorMode::Gray };
    /// let data = Dataset::new(spec, vec![0.0, 1.0, 1.0, 0.0], space, vec![0.0, 180.0])?;
    /// assert_eq!((data.len(), data.pose(1)), (2, &[180.0][..]));
    /// # Ok::<(), linpose::Error>(())
    /// ```
    pub fn new(spec: ImageSpec, features: Vec<f32>, space: PoseSpace, poses: Vec<f64>) -> Result<Self> {
        let n = poses.len() / space.len().max(1);
        let manifest = Manifest::new("", space, (0..n).map(|i| format!("sample {i}")).collect(), poses)?;
        Self::from_features(manifest, spec, features)
    }

    /// A data set of 8-bit images in memory: `pixels` holds one row of `spec.features()` values
    /// per sample (gray levels, or interleaved channels for RGB), which become the features the
    /// image reader makes of them (v / 255, the same bits), so the model is the one a folder of
    /// the same images gives. Samples are named `sample 0`, `sample 1`, ...
    pub fn from_u8(spec: ImageSpec, pixels: &[u8], space: PoseSpace, poses: Vec<f64>) -> Result<Self> {
        let n = poses.len() / space.len().max(1);
        let manifest = Manifest::new("", space, (0..n).map(|i| format!("sample {i}")).collect(), poses)?;
        Self::from_pixels(manifest, spec, pixels)
    }

    /// A data set of the images of `manifest` whose 8-bit values are in memory
    /// (`manifest.len()` rows of `spec.features()`; taken, or copied from a slice), kept as they
    /// are: the features are made from them on first use. 8-bit values need no finiteness check.
    pub fn from_pixels(manifest: Manifest, spec: ImageSpec, pixels: impl Into<Vec<u8>>) -> Result<Self> {
        let pixels = pixels.into();
        if pixels.len() != manifest.len() * spec.features() {
            return Err(Error::Dataset {
                path: manifest.root().to_path_buf(),
                message: format!("{} pixel values for {} images of {} features", pixels.len(), manifest.len(), spec.features()),
            });
        }
        Ok(Dataset { manifest, spec, features: OnceLock::new(), pixels: Some(pixels) })
    }

    /// Decodes every image of `manifest` (in parallel). All images must have the size of the
    /// first; `progress` is called with the number of images decoded since its last call.
    pub fn load(manifest: Manifest, color: ColorMode, progress: &(dyn Fn(u64) + Sync)) -> Result<Self> {
        let mut row0 = Vec::new();
        let (w, h) = read_features(&manifest.image_path(0), color, None, "", &mut row0)?;
        let spec = ImageSpec { width: w, height: h, color };
        let context = first_image_context(&manifest);
        let features = read_rows(&manifest, spec, &row0, progress, |path, slot| {
            let mut row = Vec::with_capacity(slot.len());
            read_features(path, color, Some((w, h)), &context, &mut row)?;
            slot.copy_from_slice(&row);
            Ok(())
        })?;
        Self::from_features(manifest, spec, features)
    }

    /// A data set of the images of `manifest` whose features are already in memory
    /// (`manifest.len()` rows of `spec.features()`).
    pub fn from_features(manifest: Manifest, spec: ImageSpec, features: Vec<f32>) -> Result<Self> {
        if features.len() != manifest.len() * spec.features() {
            return Err(Error::Dataset {
                path: manifest.root().to_path_buf(),
                message: format!("{} feature values for {} images of {} features", features.len(), manifest.len(), spec.features()),
            });
        }
        if let Some(i) = features.iter().position(|v| !v.is_finite()) {
            return Err(Error::Dataset { path: manifest.image_path(i / spec.features()), message: "image has a non-finite value".into() });
        }
        Ok(Dataset { manifest, spec, features: OnceLock::from(features), pixels: None })
    }

    /// The manifest: image names and poses.
    pub fn manifest(&self) -> &Manifest {
        &self.manifest
    }

    /// The pose parameters.
    pub fn space(&self) -> &PoseSpace {
        self.manifest.space()
    }

    /// Image size and colour handling.
    pub fn spec(&self) -> ImageSpec {
        self.spec
    }

    /// Number of samples N.
    pub fn len(&self) -> usize {
        self.manifest.len()
    }

    /// Whether the data set has no samples (never true once built).
    pub fn is_empty(&self) -> bool {
        self.manifest.is_empty()
    }

    /// Features per sample M.
    pub fn n_features(&self) -> usize {
        self.spec.features()
    }

    /// All features, one row of M values per sample. For a data set made from 8-bit values, made
    /// on the first call (v / 255, the image reader's bits; on the calling thread, so a call from
    /// inside a parallel loop cannot wait on itself).
    pub fn features(&self) -> &[f32] {
        self.features.get_or_init(|| {
            let pixels = self.pixels.as_deref().expect("a data set holds its features or its 8-bit values");
            pixels.iter().map(|&v| crate::image_io::feature_of_u8(v)).collect()
        })
    }

    /// The 8-bit values the features are made of (`features()[i] == feature_of_u8(pixels[i])`),
    /// when the data set was built from them; None for one read as features.
    pub fn pixels_u8(&self) -> Option<&[u8]> {
        self.pixels.as_deref()
    }

    /// The rows as they are held: the 8-bit values where the data set keeps them, else the
    /// features.
    pub fn rows(&self) -> Rows<'_> {
        match &self.pixels {
            Some(p) => Rows::U8(p),
            None => Rows::F32(self.features()),
        }
    }

    /// Sample `i`'s features.
    pub fn row(&self, i: usize) -> &[f32] {
        let m = self.n_features();
        &self.features()[i * m..(i + 1) * m]
    }

    /// All poses, row-major.
    pub fn poses(&self) -> &[f64] {
        self.manifest.poses()
    }

    /// Sample `i`'s pose.
    pub fn pose(&self, i: usize) -> &[f64] {
        self.manifest.pose(i)
    }

    /// The samples where `mask` is true, copied.
    pub fn subset(&self, mask: &[bool]) -> Result<Self> {
        let manifest = self.manifest.subset(mask)?;
        let m = self.n_features();
        let kept = || mask.iter().enumerate().filter(|(_, &k)| k).map(|(i, _)| i);
        if let Some(pixels) = &self.pixels {
            let rows: Vec<u8> = kept().flat_map(|i| &pixels[i * m..(i + 1) * m]).copied().collect();
            return Ok(Dataset { manifest, spec: self.spec, features: OnceLock::new(), pixels: Some(rows) });
        }
        let mut features = Vec::with_capacity(manifest.len() * m);
        for i in kept() {
            features.extend_from_slice(self.row(i));
        }
        Ok(Dataset { manifest, spec: self.spec, features: OnceLock::from(features), pixels: None })
    }
}

pub use crate::kernels::Rows;

/// The rows `idx` (strictly ascending) of `rows` (rows of `m` values), one after another:
/// borrowed when they are one run of `rows` (a batch taken whole, or one object's views), else
/// copied.
pub(crate) fn rows_at<'a, T: Copy>(rows: &'a [T], m: usize, idx: &[usize]) -> std::borrow::Cow<'a, [T]> {
    debug_assert!(idx.windows(2).all(|w| w[0] < w[1]), "rows in strictly ascending order");
    match (idx.first(), idx.last()) {
        (Some(&a), Some(&b)) if b.checked_sub(a) == Some(idx.len() - 1) => std::borrow::Cow::Borrowed(&rows[a * m..(b + 1) * m]),
        _ => std::borrow::Cow::Owned(idx.iter().flat_map(|&i| rows[i * m..(i + 1) * m].iter().copied()).collect()),
    }
}

/// The first image of `manifest` when it is 8-bit gray (colour turned gray): its size and
/// pixels, where [`load_gray8_into`] starts; `None` when it is not.
pub fn first_gray8(manifest: &Manifest) -> Result<Option<(ImageSpec, Vec<u8>)>> {
    use crate::image_io::{read_image, QueryImage};
    let (w, h, first) = read_image(&manifest.image_path(0), ColorMode::Gray)?;
    let QueryImage::Gray8(row0) = first else { return Ok(None) };
    Ok(Some((ImageSpec { width: w, height: h, color: ColorMode::Gray }, row0)))
}

/// The images of `manifest` as 8-bit gray values (colour turned gray as the reader does), read in
/// parallel into a buffer the caller holds (`out`: `manifest.len()` rows of `spec.features()`, as
/// a caller's array allocator lays them out), after [`first_gray8`] gave `spec` and `row0`: false,
/// with `out` partly written, when an image is not 8-bit (16-bit, say: then read the features
/// with [`Dataset::load`]). Sizes are checked against the first image.
pub fn load_gray8_into(manifest: &Manifest, spec: ImageSpec, row0: &[u8], out: &mut [u8], progress: &(dyn Fn(u64) + Sync)) -> Result<bool> {
    use crate::image_io::{read_query, QueryImage};
    use std::sync::atomic::{AtomicBool, Ordering};
    let context = first_image_context(manifest);
    let wider = AtomicBool::new(false);
    fill_rows(manifest, spec, row0, out, progress, |path, slot| {
        match read_query(path, spec, &context)? {
            QueryImage::Gray8(v) => slot.copy_from_slice(&v),
            QueryImage::Features(_) => wider.store(true, Ordering::Relaxed),
        }
        Ok(())
    })?;
    Ok(!wider.into_inner())
}

/// What the images of a data set must match: the size of its first image.
fn first_image_context(manifest: &Manifest) -> String {
    format!("the size of the data set's first image, {}", manifest.images()[0])
}

/// One buffer of `manifest.len()` rows of `spec.features()` values: `row0` (the first image,
/// already read), then every other image read into its row by `read` (in parallel). Refused,
/// not aborted, when the buffer cannot be held in memory; the error of the first failing image
/// in manifest order, so it is the same on every run.
fn read_rows<T: Copy + Default + Send + Sync>(
    manifest: &Manifest,
    spec: ImageSpec,
    row0: &[T],
    progress: &(dyn Fn(u64) + Sync),
    read: impl Fn(&std::path::Path, &mut [T]) -> Result<()> + Sync,
) -> Result<Vec<T>> {
    let mut rows = alloc_rows(manifest, spec)?;
    fill_rows(manifest, spec, row0, &mut rows, progress, read)?;
    Ok(rows)
}

/// A buffer for every image of `manifest` at `spec`, refused (not aborted) when it cannot be
/// held in memory.
fn alloc_rows<T: Copy + Default>(manifest: &Manifest, spec: ImageSpec) -> Result<Vec<T>> {
    let (m, n) = (spec.features(), manifest.len());
    let too_big = || Error::Dataset {
        path: manifest.root().to_path_buf(),
        message: format!("{n} images of {}x{} ({m} features each) need more memory than can be allocated", spec.width, spec.height),
    };
    let total = n.checked_mul(m).ok_or_else(too_big)?;
    let mut rows: Vec<T> = Vec::new();
    rows.try_reserve_exact(total).map_err(|_| too_big())?;
    rows.resize(total, T::default());
    Ok(rows)
}

/// [`read_rows`] into `rows` (every image's row): `row0` first, then the others by `read`.
fn fill_rows<T: Copy + Send + Sync>(
    manifest: &Manifest,
    spec: ImageSpec,
    row0: &[T],
    rows: &mut [T],
    progress: &(dyn Fn(u64) + Sync),
    read: impl Fn(&std::path::Path, &mut [T]) -> Result<()> + Sync,
) -> Result<()> {
    let m = spec.features();
    if manifest.len().checked_mul(m) != Some(rows.len()) || row0.len() != m {
        return Err(Error::invalid("rows", rows.len(), format!("{} images of {m} values", manifest.len())));
    }
    rows[..m].copy_from_slice(row0);
    progress(1);
    let results: Vec<Result<()>> = rows[m..]
        .par_chunks_mut(m)
        .enumerate()
        .map(|(k, slot)| {
            read(&manifest.image_path(k + 1), slot)?;
            progress(1);
            Ok(())
        })
        .collect();
    results.into_iter().collect::<Result<Vec<()>>>()?;
    Ok(())
}
