//! Synthetic data sets: an object rendered on a grid of poses, in memory or written to disk in
//! the directory format (`OUT/poses.csv`, `OUT/dataset.toml` and PNG images beside them).
//!
//! Writing streams: images are rendered and encoded in parallel a chunk at a time and go straight
//! to disk, so a data set of any size needs only a chunk's worth of memory. Nothing half-written
//! is ever left at OUT: everything is written into a temporary folder beside it, which is renamed
//! to OUT once complete (and removed on error). OUT must not exist yet or be an empty folder.

use super::tuning::CHUNK;
use super::{Grid, Jitter, Mesh, RenderParams, Renderer};
use crate::dataset::Dataset;
use crate::image_io::{ColorMode, ImageSpec};
use crate::manifest::Manifest;
use crate::pose::{Param, PoseSpace};
use crate::{Error, Result};
use image::codecs::png::{CompressionType, FilterType, PngEncoder};
use image::{ExtendedColorType, ImageEncoder};
use rayon::prelude::*;
use std::fs;
use std::path::{Path, PathBuf};

/// Most images one data set may have (the manifest's row limit).
pub const MAX_IMAGES: usize = crate::manifest::MAX_ROWS;

/// The poses of a data set: every elevation, and for each every azimuth (elevation-major), with
/// their image names.
#[derive(Debug, Clone)]
pub struct PoseGrid {
    elevation: Grid,
    azimuth: Grid,
    jitter: Option<Jitter>,
}

impl PoseGrid {
    /// The product of two grids; refuses more than [`MAX_IMAGES`] poses.
    pub fn new(elevation: Grid, azimuth: Grid) -> Result<Self> {
        let n = elevation.len() as u64 * azimuth.len() as u64;
        if n > MAX_IMAGES as u64 {
            return Err(Error::invalid(
                "grid",
                format!("{} elevations x {} azimuths", elevation.len(), azimuth.len()),
                format!("{n} images; at most {MAX_IMAGES} are allowed"),
            ));
        }
        Ok(PoseGrid { elevation, azimuth, jitter: None })
    }

    /// The paper's 16 x 110 = 1760 poses.
    pub fn paper() -> Self {
        PoseGrid { elevation: Grid::paper_elevation(), azimuth: Grid::paper_azimuth(), jitter: None }
    }

    /// Every view jittered by `jitter` (its own draw each, [`Jitter::view`]); the data set then
    /// gets `jitter.csv` beside `poses.csv`.
    pub fn with_jitter(mut self, jitter: Jitter) -> Result<Self> {
        jitter.validate()?;
        self.jitter = Some(jitter);
        Ok(self)
    }

    /// The jitter of the views, if any.
    pub fn jitter(&self) -> Option<&Jitter> {
        self.jitter.as_ref()
    }

    /// The render parameters of view `i`: `params`, jittered when the grid is.
    pub fn params_of(&self, i: usize, params: &RenderParams) -> Result<RenderParams> {
        match &self.jitter {
            Some(j) => j.view(i).apply(params),
            None => Ok(params.clone()),
        }
    }

    /// `jitter.csv`: header `image,dx,dy,scale,exposure` (pixels right and down, factors), one row
    /// per view, values printed so they read back exactly; None when not jittered.
    pub fn jitter_csv(&self) -> Option<String> {
        let j = self.jitter.as_ref()?;
        let mut s = String::from("image,dx,dy,scale,exposure\n");
        for i in 0..self.len() {
            let v = j.view(i);
            s.push_str(&format!("{},{},{},{},{}\n", self.image_name(i), v.dx, v.dy, v.scale, v.exposure));
        }
        Some(s)
    }

    /// Number of poses.
    pub fn len(&self) -> usize {
        self.elevation.len() * self.azimuth.len()
    }

    /// Whether there is no pose.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// (elevation, azimuth) of pose `i`, degrees.
    pub fn pose(&self, i: usize) -> (f64, f64) {
        let na = self.azimuth.len();
        (self.elevation.value(i / na), self.azimuth.value(i % na))
    }

    /// Image file name of pose `i`: `e032.0_a000.0.png`, with as many decimals as the grids have
    /// (at least one), so names are distinct and sort by pose.
    pub fn image_name(&self, i: usize) -> String {
        let (e, a) = self.pose(i);
        let (de, da) = (self.elevation.decimals().max(1) as usize, self.azimuth.decimals().max(1) as usize);
        format!("e{e:0w1$.de$}_a{a:0w2$.da$}.png", w1 = de + 4, w2 = da + 4)
    }

    /// The manifest of the data set at `root`: parameters `elevation` (linear) and `azimuth`
    /// (period 360).
    pub fn manifest(&self, root: &Path) -> Result<Manifest> {
        let space = PoseSpace::new(vec![Param::linear("elevation"), Param::circular("azimuth", 360.0)])?;
        let images = (0..self.len()).map(|i| self.image_name(i)).collect();
        let poses = (0..self.len()).flat_map(|i| <[f64; 2]>::from(self.pose(i))).collect();
        Manifest::new(root, space, images, poses)
    }

    /// `poses.csv`: header `image,elevation,azimuth`, values printed so they read back exactly.
    pub fn poses_csv(&self) -> String {
        let mut s = String::from("image,elevation,azimuth\n");
        for i in 0..self.len() {
            let (e, a) = self.pose(i);
            s.push_str(&format!("{},{e},{a}\n", self.image_name(i)));
        }
        s
    }
}

/// `dataset.toml` of a synthetic data set.
pub const DATASET_TOML: &str = "azimuth = { period = 360 }\nelevation = { linear = true }\n";

/// Renders every pose of `grid` into memory: a [`Dataset`] whose features are the 8-bit pixels
/// / 255, exactly as if the images had been written and read back. `root` names the data set;
/// `progress` is called with the number of images rendered since its last call.
pub fn dataset(mesh: &Mesh, grid: &PoseGrid, params: &RenderParams, root: &Path, progress: &(dyn Fn(u64) + Sync)) -> Result<Dataset> {
    let manifest = grid.manifest(root)?;
    let pixels = render_u8(mesh, grid, params, progress)?;
    let spec = ImageSpec { width: params.get_width(), height: params.get_height(), color: ColorMode::Gray };
    Dataset::from_pixels(manifest, spec, pixels)
}

/// Renders every pose of `grid` into memory as 8-bit gray images, one after another in the
/// grid's order (row-major, width x height each): the pixels [`write_dataset`] would write.
/// `progress` is called with the number of images rendered since its last call.
pub fn render_u8(mesh: &Mesh, grid: &PoseGrid, params: &RenderParams, progress: &(dyn Fn(u64) + Sync)) -> Result<Vec<u8>> {
    if let Some(j) = &grid.jitter {
        j.fits(params)?;
    }
    Renderer::new(params)?;
    let m = params.get_width() as usize * params.get_height() as usize;
    let total = grid.len().checked_mul(m).filter(|&t| t <= isize::MAX as usize);
    let too_big = || Error::invalid("grid", grid.len(), format!("{} images of {m} pixels need more memory than can be allocated", grid.len()));
    let total = total.ok_or_else(too_big)?;
    let mut pixels: Vec<u8> = Vec::new();
    pixels.try_reserve_exact(total).map_err(|_| too_big())?;
    pixels.resize(total, 0);
    pixels.par_chunks_mut(m).enumerate().try_for_each_init(
        || Renderer::new(params).expect("validated"),
        |r, (i, out)| {
            let (e, a) = grid.pose(i);
            if grid.jitter.is_some() {
                r.set_params(&grid.params_of(i, params)?)?;
            }
            r.render_into(mesh, a, e, out)?;
            progress(1);
            Ok::<(), Error>(())
        },
    )?;
    Ok(pixels)
}

/// Encodes 8-bit gray pixels as a PNG, with fast compression.
pub fn encode_png(pixels: &[u8], width: u32, height: u32) -> Result<Vec<u8>> {
    let mut out = Vec::with_capacity(pixels.len() / 2);
    PngEncoder::new_with_quality(&mut out, CompressionType::Fast, FilterType::Sub)
        .write_image(pixels, width, height, ExtendedColorType::L8)
        .map_err(|e| Error::invalid("image", format!("{width}x{height}"), format!("PNG encoding failed: {e}")))?;
    Ok(out)
}

/// Renders every pose of `grid` and writes the data set to `out` (see the module doc). `progress`
/// is called with the number of images written since its last call. Returns the image count.
pub fn write_dataset(mesh: &Mesh, grid: &PoseGrid, params: &RenderParams, out: &Path, progress: &(dyn Fn(u64) + Sync)) -> Result<u64> {
    Renderer::new(params)?;
    if let Some(j) = &grid.jitter {
        j.fits(params)?;
    }
    let replace_empty = match fs::metadata(out) {
        Ok(m) if m.is_dir() => {
            let mut entries = fs::read_dir(out).map_err(|e| Error::io(out, e))?;
            if entries.next().is_some() {
                return Err(Error::Dataset {
                    path: out.to_path_buf(),
                    message: "the output folder exists and is not empty; give a new folder (it is created) or an empty one".into(),
                });
            }
            true
        }
        Ok(_) => return Err(Error::Dataset { path: out.to_path_buf(), message: "exists and is not a folder".into() }),
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => false,
        Err(e) => return Err(Error::io(out, e)),
    };
    let tmp = temp_dir(out);
    if let Some(parent) = tmp.parent().filter(|p| !p.as_os_str().is_empty()) {
        fs::create_dir_all(parent).map_err(|e| Error::io(parent, e))?;
    }
    fs::create_dir(&tmp).map_err(|e| Error::io(&tmp, e))?;
    let result = fill(mesh, grid, params, &tmp, progress).and_then(|()| {
        if replace_empty {
            fs::remove_dir(out).map_err(|e| Error::io(out, e))?;
        }
        fs::rename(&tmp, out).map_err(|e| Error::io(out, e))
    });
    if result.is_err() {
        let _ = fs::remove_dir_all(&tmp);
    } else {
        crate::atomic::remove_stale_temps(out);
    }
    result.map(|()| grid.len() as u64)
}

/// `.NAME.tmp-PID` beside `out`.
fn temp_dir(out: &Path) -> PathBuf {
    let name = out.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_else(|| "dataset".into());
    out.with_file_name(format!(".{name}.tmp-{}", std::process::id()))
}

/// Writes the images, then dataset.toml and poses.csv, into the folder `dir`.
fn fill(mesh: &Mesh, grid: &PoseGrid, params: &RenderParams, dir: &Path, progress: &(dyn Fn(u64) + Sync)) -> Result<()> {
    let (w, h) = (params.get_width(), params.get_height());
    let n = grid.len();
    for start in (0..n).step_by(CHUNK) {
        let results: Vec<Result<()>> = (start..(start + CHUNK).min(n))
            .into_par_iter()
            .map_init(
                || (Renderer::new(params).expect("validated"), vec![0u8; w as usize * h as usize]),
                |(r, pixels), i| {
                    let (e, a) = grid.pose(i);
                    if grid.jitter.is_some() {
                        r.set_params(&grid.params_of(i, params)?)?;
                    }
                    r.render_into(mesh, a, e, pixels)?;
                    let png = encode_png(pixels, w, h)?;
                    let path = dir.join(grid.image_name(i));
                    fs::write(&path, png).map_err(|e| Error::io(&path, e))?;
                    progress(1);
                    Ok(())
                },
            )
            .collect();
        // The first failure in pose order, so the error is the same on every run.
        results.into_iter().collect::<Result<Vec<()>>>()?;
    }
    if let Some(csv) = grid.jitter_csv() {
        crate::atomic::write_atomic(&dir.join("jitter.csv"), csv.as_bytes())?;
    }
    crate::atomic::write_atomic(&dir.join("dataset.toml"), DATASET_TOML.as_bytes())?;
    crate::atomic::write_atomic(&dir.join("poses.csv"), grid.poses_csv().as_bytes())
}
