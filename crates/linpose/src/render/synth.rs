//! Synthetic data sets: an object rendered on a grid of poses, in memory or written to disk in
//! the directory format (`OUT/poses.csv`, `OUT/dataset.toml` and PNG images beside them), and,
//! when the grid has a scene ([`PoseGrid::with_scene`]), `OUT/scene.csv` recording each view's.
//!
//! Writing streams: images are rendered and encoded in parallel a chunk at a time and go straight
//! to disk, and `poses.csv`, `jitter.csv` and `scene.csv` are written row by row, so a data set of any size (up
//! to [`MAX_IMAGES`] views) needs only a chunk's worth of memory. Nothing half-written
//! is ever left at OUT: everything is written into a temporary folder beside it, which is renamed
//! to OUT once complete (and removed on error). OUT must not exist yet or be an empty folder.

use super::scene::{write_scene_csv, Scene, SceneRecord};
use super::tuning::CHUNK;
use super::view::ViewRenderer;
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
use std::io::Write;
use std::path::Path;
use std::sync::Arc;

/// Most images one data set may have (the manifest's row limit).
pub const MAX_IMAGES: usize = crate::manifest::MAX_ROWS;

/// The poses of a data set: the product of a grid of elevations, one of azimuths and, when given,
/// one of rolls and one of light azimuths, in that order (elevation-major: the last parameter
/// varies fastest), with their image names.
///
/// The poses' columns are `elevation`, `azimuth`, then `roll` and `light` when the grid has them.
/// Roll turns the camera about its optical axis ([`super::Camera::roll`]); light is the world
/// azimuth of the light ([`super::Light::azimuth_deg`]), its elevation and strength staying those
/// of the render parameters.
#[derive(Debug, Clone)]
pub struct PoseGrid {
    elevation: Grid,
    azimuth: Grid,
    roll: Option<Grid>,
    light: Option<Grid>,
    jitter: Option<Jitter>,
    scene: Option<Arc<Scene>>,
}

impl PoseGrid {
    /// The product of two grids; refuses more than [`MAX_IMAGES`] poses.
    pub fn new(elevation: Grid, azimuth: Grid) -> Result<Self> {
        PoseGrid { elevation, azimuth, roll: None, light: None, jitter: None, scene: None }.checked()
    }

    /// The paper's 16 x 110 = 1760 poses.
    pub fn paper() -> Self {
        PoseGrid { elevation: Grid::paper_elevation(), azimuth: Grid::paper_azimuth(), roll: None, light: None, jitter: None, scene: None }
    }

    /// Every pose also at every roll of `roll` (degrees, the camera turned about its optical
    /// axis): a `roll` column after `azimuth`. Refuses more than [`MAX_IMAGES`] poses in all.
    pub fn with_roll(mut self, roll: Grid) -> Result<Self> {
        self.roll = Some(roll);
        self.checked()
    }

    /// Every pose also under every light azimuth of `light` (degrees, world azimuth of the light):
    /// a `light` column after `azimuth` (and `roll`). Refuses more than [`MAX_IMAGES`] poses in all.
    pub fn with_light(mut self, light: Grid) -> Result<Self> {
        self.light = Some(light);
        self.checked()
    }

    /// Refuses a product of more than [`MAX_IMAGES`] poses, naming each grid's size.
    fn checked(self) -> Result<Self> {
        let n: u128 = self.axes().iter().map(|(_, g)| g.len() as u128).product();
        if n > MAX_IMAGES as u128 {
            let sizes: Vec<String> = self.axes().iter().map(|(name, g)| format!("{} {name}s", g.len())).collect();
            return Err(Error::invalid("grid", sizes.join(" x "), format!("{n} images; at most {MAX_IMAGES} are allowed")));
        }
        Ok(self)
    }

    /// The grids with their parameters' names, in the poses' column order.
    fn axes(&self) -> Vec<(&'static str, &Grid)> {
        let mut axes = vec![("elevation", &self.elevation), ("azimuth", &self.azimuth)];
        axes.extend(self.roll.as_ref().map(|g| ("roll", g)));
        axes.extend(self.light.as_ref().map(|g| ("light", g)));
        axes
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

    /// Every view put into `scene`: the object over the scene's background (a uniform level is
    /// the render parameters' background), occluders in front, each view its own draw. Unless
    /// the scene is only a uniform level, the data set then gets `scene.csv` beside `poses.csv`,
    /// a [`SceneRecord`] per view.
    pub fn with_scene(mut self, scene: Scene) -> Self {
        self.scene = Some(Arc::new(scene));
        self
    }

    /// The scene of the views, if any.
    pub fn scene(&self) -> Option<&Scene> {
        self.scene.as_deref()
    }

    /// Whether the views are written with a `scene.csv`: a scene that is more than a level.
    fn has_scene_csv(&self) -> bool {
        self.scene().is_some_and(|s| !s.is_plain())
    }

    /// `params` with the scene's uniform level as its background, when the scene's background is one.
    fn scene_params(&self, params: &RenderParams) -> RenderParams {
        match self.scene().map(|s| s.background()) {
            Some(super::background::Background::Level(v)) => params.clone().background(*v),
            _ => params.clone(),
        }
    }

    /// Whether views differ in more than their pose on the turntable (roll, light or jitter), so
    /// that each needs its own render parameters ([`PoseGrid::params_of`]).
    pub(crate) fn per_view_params(&self) -> bool {
        self.roll.is_some() || self.light.is_some() || self.jitter.is_some()
    }

    /// The render parameters of view `i`: `params` with the view's roll and light azimuth when
    /// the grid has them, jittered when the grid is.
    pub fn params_of(&self, i: usize, params: &RenderParams) -> Result<RenderParams> {
        let mut p = match &self.jitter {
            Some(j) => j.view(i).apply(params)?,
            None => params.clone(),
        };
        let [_, _, r, l] = self.index(i);
        if let Some(g) = &self.roll {
            p = p.clone().camera(p.get_camera().clone().roll(g.value(r)));
        }
        if let Some(g) = &self.light {
            p = p.clone().light(p.get_light().clone().azimuth_deg(g.value(l)));
        }
        Ok(p)
    }

    /// `jitter.csv`: header `image,dx,dy,scale,exposure` (pixels right and down, factors), one row
    /// per view, values printed so they read back exactly; None when not jittered.
    pub fn jitter_csv(&self) -> Option<String> {
        self.jitter.as_ref()?;
        let mut s = Vec::new();
        self.write_jitter_csv(&mut s).expect("writing to memory");
        Some(String::from_utf8(s).expect("ASCII"))
    }

    /// Writes `jitter.csv` row by row (nothing when not jittered).
    fn write_jitter_csv(&self, w: &mut impl Write) -> std::io::Result<()> {
        let Some(j) = &self.jitter else { return Ok(()) };
        w.write_all(b"image,dx,dy,scale,exposure\n")?;
        for i in 0..self.len() {
            let v = j.view(i);
            writeln!(w, "{},{},{},{},{}", self.image_name(i), v.dx, v.dy, v.scale, v.exposure)?;
        }
        Ok(())
    }

    /// Number of poses.
    pub fn len(&self) -> usize {
        self.axes().iter().map(|(_, g)| g.len()).product()
    }

    /// Whether there is no pose.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }

    /// The index of pose `i` in each grid: elevation, azimuth, roll, light (0 for a grid not given).
    fn index(&self, i: usize) -> [usize; 4] {
        let (nr, nl) = (self.roll.as_ref().map_or(1, Grid::len), self.light.as_ref().map_or(1, Grid::len));
        let na = self.azimuth.len();
        let (l, rest) = (i % nl, i / nl);
        let (r, rest) = (rest % nr, rest / nr);
        [rest / na, rest % na, r, l]
    }

    /// (elevation, azimuth) of pose `i`, degrees.
    pub fn pose(&self, i: usize) -> (f64, f64) {
        let [e, a, _, _] = self.index(i);
        (self.elevation.value(e), self.azimuth.value(a))
    }

    /// The names of the poses' columns: `elevation`, `azimuth`, then `roll` and `light` when the
    /// grid has them.
    pub fn names(&self) -> Vec<&'static str> {
        self.axes().iter().map(|(name, _)| *name).collect()
    }

    /// The values of pose `i` in the column order of [`PoseGrid::names`], degrees.
    pub fn values(&self, i: usize) -> Vec<f64> {
        let [e, a, r, l] = self.index(i);
        let mut v = vec![self.elevation.value(e), self.azimuth.value(a)];
        v.extend(self.roll.as_ref().map(|g| g.value(r)));
        v.extend(self.light.as_ref().map(|g| g.value(l)));
        v
    }

    /// Image file name of pose `i`: `e032.0_a000.0.png`, then `_r-30.0` and `_l045.0` before
    /// `.png` when the grid has rolls and lights, with as many decimals as the grids have (at
    /// least one), so names are distinct and sort by pose (among values of one sign).
    pub fn image_name(&self, i: usize) -> String {
        let [e, a, r, l] = self.index(i);
        let mut name = String::new();
        let mut part = |prefix: &str, g: &Grid, k: usize| {
            let d = g.decimals().max(1) as usize;
            name.push_str(&format!("{prefix}{:0w$.d$}", g.value(k), w = d + 4));
        };
        part("e", &self.elevation, e);
        part("_a", &self.azimuth, a);
        if let Some(g) = &self.roll {
            part("_r", g, r);
        }
        if let Some(g) = &self.light {
            part("_l", g, l);
        }
        name.push_str(".png");
        name
    }

    /// The pose parameters: `elevation` linear, `azimuth` circular with period 360; `roll` and
    /// `light` circular with period 360 when their grid goes round a whole turn
    /// ([`Grid`]: one more step after the last value reaches 360 degrees past the first), linear
    /// otherwise (a partial range is an interval: nothing joins its ends).
    pub fn params(&self) -> Vec<Param> {
        let turn = |name: &str, g: &Grid| if g.covers_turn() { Param::circular(name, 360.0) } else { Param::linear(name) };
        let mut params = vec![Param::linear("elevation"), Param::circular("azimuth", 360.0)];
        params.extend(self.roll.as_ref().map(|g| turn("roll", g)));
        params.extend(self.light.as_ref().map(|g| turn("light", g)));
        params
    }

    /// The pose space of [`PoseGrid::params`].
    pub fn space(&self) -> Result<PoseSpace> {
        PoseSpace::new(self.params())
    }

    /// The manifest of the data set at `root`, its space [`PoseGrid::space`].
    pub fn manifest(&self, root: &Path) -> Result<Manifest> {
        let images = (0..self.len()).map(|i| self.image_name(i)).collect();
        let poses = (0..self.len()).flat_map(|i| self.values(i)).collect();
        Manifest::new(root, self.space()?, images, poses)
    }

    /// `poses.csv`: header `image,elevation,azimuth` (then `,roll`, `,light`), values printed so
    /// they read back exactly.
    pub fn poses_csv(&self) -> String {
        let mut s = Vec::new();
        self.write_poses_csv(&mut s).expect("writing to memory");
        String::from_utf8(s).expect("ASCII")
    }

    /// Writes `poses.csv` row by row.
    fn write_poses_csv(&self, w: &mut impl Write) -> std::io::Result<()> {
        writeln!(w, "image,{}", self.names().join(","))?;
        for i in 0..self.len() {
            w.write_all(self.image_name(i).as_bytes())?;
            for v in self.values(i) {
                write!(w, ",{v}")?;
            }
            w.write_all(b"\n")?;
        }
        Ok(())
    }

    /// `dataset.toml`: each parameter's period (`{ period = 360 }`) or `{ linear = true }`, as
    /// [`PoseGrid::space`] has it; [`DATASET_TOML`] without roll or light.
    pub fn dataset_toml(&self) -> String {
        let mut s = String::from(DATASET_TOML);
        for p in &self.params()[2..] {
            match p.period {
                Some(t) => s.push_str(&format!("{} = {{ period = {t} }}\n", p.name)),
                None => s.push_str(&format!("{} = {{ linear = true }}\n", p.name)),
            }
        }
        s
    }
}

/// `dataset.toml` of a synthetic data set of elevation and azimuth.
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
    Ok(render_views(mesh, grid, params, false, progress)?.pixels)
}

/// Views rendered in memory with what their scenes are: [`render_scenes`]'s result.
#[derive(Debug, Clone)]
pub struct SceneViews {
    /// The 8-bit gray images, one after another in the grid's order (width x height each).
    pub pixels: Vec<u8>,
    /// The object's pixels in each image (those it covers any part of, occluded or not),
    /// laid out as `pixels`.
    pub masks: Vec<bool>,
    /// Each view's scene, when the grid's scene is more than a uniform level (else empty).
    pub records: Vec<SceneRecord>,
}

/// Renders every pose of `grid` into memory as [`render_u8`] does, with each view's object mask
/// and scene record.
pub fn render_scenes(mesh: &Mesh, grid: &PoseGrid, params: &RenderParams, progress: &(dyn Fn(u64) + Sync)) -> Result<SceneViews> {
    render_views(mesh, grid, params, true, progress)
}

/// Renders every pose of `grid` into memory, with the object's masks when `masks`.
fn render_views(mesh: &Mesh, grid: &PoseGrid, params: &RenderParams, masks: bool, progress: &(dyn Fn(u64) + Sync)) -> Result<SceneViews> {
    let params = &grid.scene_params(params);
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
    let mut mask: Vec<bool> = Vec::new();
    if masks {
        mask.try_reserve_exact(total).map_err(|_| too_big())?;
        mask.resize(total, false);
    }
    let mut mask_chunks: Vec<Option<&mut [bool]>> = if masks { mask.chunks_mut(m).map(Some).collect() } else { (0..grid.len()).map(|_| None).collect() };
    let records: Vec<Option<SceneRecord>> = pixels
        .par_chunks_mut(m)
        .zip(mask_chunks.par_iter_mut())
        .enumerate()
        .map_init(
            || ViewRenderer::new(params).expect("validated"),
            |r, (i, (out, mask))| {
                let record = r.render(mesh, grid, params, i, out, mask.as_deref_mut())?;
                progress(1);
                Ok::<_, Error>(record)
            },
        )
        .collect::<Result<_>>()?;
    drop(mask_chunks);
    Ok(SceneViews { pixels, masks: mask, records: records.into_iter().flatten().collect() })
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
    let params = &grid.scene_params(params);
    Renderer::new(params)?;
    if let Some(j) = &grid.jitter {
        j.fits(params)?;
    }
    crate::atomic::write_folder(out, |tmp| fill(mesh, grid, params, tmp, progress))?;
    Ok(grid.len() as u64)
}

/// Writes the images (and scene.csv), then dataset.toml and poses.csv, into the folder `dir`.
fn fill(mesh: &Mesh, grid: &PoseGrid, params: &RenderParams, dir: &Path, progress: &(dyn Fn(u64) + Sync)) -> Result<()> {
    let (w, h) = (params.get_width(), params.get_height());
    let n = grid.len();
    let scene_path = dir.join("scene.csv");
    let mut scenes = match grid.has_scene_csv() {
        true => Some(std::io::BufWriter::new(fs::File::create(&scene_path).map_err(|e| Error::io(&scene_path, e))?)),
        false => None,
    };
    for start in (0..n).step_by(CHUNK) {
        let results: Vec<Result<Option<SceneRecord>>> = (start..(start + CHUNK).min(n))
            .into_par_iter()
            .map_init(
                || (ViewRenderer::new(params).expect("validated"), vec![0u8; w as usize * h as usize]),
                |(r, pixels), i| {
                    let record = r.render(mesh, grid, params, i, pixels, None)?;
                    let png = encode_png(pixels, w, h)?;
                    let path = dir.join(grid.image_name(i));
                    fs::write(&path, png).map_err(|e| Error::io(&path, e))?;
                    progress(1);
                    Ok(record)
                },
            )
            .collect();
        // The first failure in pose order, so the error is the same on every run.
        let records: Vec<SceneRecord> = results.into_iter().collect::<Result<Vec<_>>>()?.into_iter().flatten().collect();
        if let Some(w) = scenes.as_mut() {
            write_scene_csv(w, &records, start == 0).map_err(|e| rename_io(e, &scene_path))?;
        }
    }
    if let Some(w) = scenes {
        let file = w.into_inner().map_err(|e| Error::io(&scene_path, e.into_error()))?;
        file.sync_all().map_err(|e| Error::io(&scene_path, e))?;
    }
    // The tables go to disk row by row: their memory does not grow with the number of views.
    if grid.jitter.is_some() {
        crate::atomic::write_atomic_with(&dir.join("jitter.csv"), |w| grid.write_jitter_csv(w))?;
    }
    crate::atomic::write_atomic(&dir.join("dataset.toml"), grid.dataset_toml().as_bytes())?;
    crate::atomic::write_atomic_with(&dir.join("poses.csv"), |w| grid.write_poses_csv(w))
}

/// An I/O error of `scene.csv` made to name `path`.
fn rename_io(e: Error, path: &Path) -> Error {
    match e {
        Error::Io { source, .. } => Error::io(path, source),
        e => e,
    }
}
