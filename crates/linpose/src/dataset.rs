//! A data set in memory: images as feature rows with their poses, built from arrays already in
//! memory ([`Dataset::new`]) or decoded from a data set folder ([`Dataset::load`]).

use crate::image_io::{read_features, ColorMode, ImageSpec};
use crate::manifest::Manifest;
use crate::pose::PoseSpace;
use crate::{Error, Result};
use rayon::prelude::*;

/// Images as feature rows (f32 in [0, 1]) with their poses.
#[derive(Debug, Clone)]
pub struct Dataset {
    manifest: Manifest,
    spec: ImageSpec,
    features: Vec<f32>,
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
    /// the same images gives. Converted in parallel; 8-bit values need no finiteness check.
    pub fn from_u8(spec: ImageSpec, pixels: &[u8], space: PoseSpace, poses: Vec<f64>) -> Result<Self> {
        let n = poses.len() / space.len().max(1);
        let manifest = Manifest::new("", space, (0..n).map(|i| format!("sample {i}")).collect(), poses)?;
        if pixels.len() != n * spec.features() {
            return Err(Error::Dataset {
                path: manifest.root().to_path_buf(),
                message: format!("{} pixel values for {n} images of {} features", pixels.len(), spec.features()),
            });
        }
        let features = pixels.par_iter().with_min_len(1 << 16).map(|&v| crate::image_io::feature_of_u8(v)).collect();
        Ok(Dataset { manifest, spec, features })
    }

    /// Decodes every image of `manifest` (in parallel). All images must have the size of the
    /// first; `progress` is called with the number of images decoded since its last call.
    pub fn load(manifest: Manifest, color: ColorMode, progress: &(dyn Fn(u64) + Sync)) -> Result<Self> {
        let first = manifest.image_path(0);
        let mut row0 = Vec::new();
        let (w, h) = read_features(&first, color, None, "", &mut row0)?;
        let spec = ImageSpec { width: w, height: h, color };
        let m = spec.features();
        let n = manifest.len();
        // Refused, not aborted, when the whole data set cannot be held in memory.
        let too_big = || Error::Dataset {
            path: manifest.root().to_path_buf(),
            message: format!("{n} images of {w}x{h} ({m} features each) need more memory than can be allocated"),
        };
        let total = n.checked_mul(m).ok_or_else(too_big)?;
        let mut features: Vec<f32> = Vec::new();
        features.try_reserve_exact(total).map_err(|_| too_big())?;
        features.resize(total, 0.0);
        features[..m].copy_from_slice(&row0);
        progress(1);
        let context = format!("the size of the data set's first image, {}", manifest.images()[0]);
        let results: Vec<Result<()>> = features[m..]
            .par_chunks_mut(m)
            .enumerate()
            .map(|(k, slot)| {
                let mut row = Vec::with_capacity(m);
                read_features(&manifest.image_path(k + 1), color, Some((w, h)), &context, &mut row)?;
                slot.copy_from_slice(&row);
                progress(1);
                Ok(())
            })
            .collect();
        // The first failing image in manifest order, so the error is the same on every run.
        results.into_iter().collect::<Result<Vec<()>>>()?;
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
        Ok(Dataset { manifest, spec, features })
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

    /// All features, one row of M values per sample.
    pub fn features(&self) -> &[f32] {
        &self.features
    }

    /// Sample `i`'s features.
    pub fn row(&self, i: usize) -> &[f32] {
        let m = self.n_features();
        &self.features[i * m..(i + 1) * m]
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
        let mut features = Vec::with_capacity(manifest.len() * self.n_features());
        for (i, _) in mask.iter().enumerate().filter(|(_, &m)| m) {
            features.extend_from_slice(self.row(i));
        }
        Ok(Dataset { manifest, spec: self.spec, features })
    }
}
