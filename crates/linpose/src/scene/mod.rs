//! Data sets put into scenes: every view of an existing data set - a turntable's, COIL's, a
//! rendered one - with its object found against the studio backdrop ([`find_object`]), the
//! backdrop replaced by a scene's background and occluders painted in front
//! ([`crate::render::scene::Scene`]), so that methods trained on the studio views can be measured
//! on cluttered and occluded ones of the same poses.
//!
//! [`write_scenes`] writes the new data set in the directory format: for one object, `OUT/` with
//! the views (PNG, same names; another format's name gets `.png`), `poses.csv` (the same poses,
//! in the same order), `dataset.toml` (the same parameters) and `scene.csv` (each view's
//! [`SceneRecord`]); for several objects (any layout [`Source::open`] reads), a folder of object
//! folders, `OUT/<object>/`, each as for one. Every command reads it as it reads the original.
//!
//! The object is found in each view as [`find_object`] does: the backdrop's level is the median
//! of the frame's border and its spread the median of the border's deviations from it (so the
//! object may cover up to half the border); the object is the pixels that deviate by more than
//! five times the spread (and at least 1.5 gray levels), their largest 8-connected region and
//! the regions near it (within its size; specks under 0.5% of it or 4 pixels left out), and the
//! backdrop regions it encloses up to a quarter of its size filled (a dark part of the object,
//! or a handle's hole, which cannot be told apart; a larger one, a ring's hole, gets the scene's
//! background). A view whose border is not a uniform backdrop, or where nothing but specks
//! differs from it, is refused, naming the file.
//!
//! With a canvas ([`crate::render::place::Canvas`]), each view's object and occluders are
//! scaled and placed somewhere on a larger image of the background instead, and `scene.csv`
//! records the frame's box there.
//!
//! A view keeps its colour: gray views get gray backgrounds, colour views colour ones; 16-bit
//! images are written as 8-bit. View i (counted over the objects in order) draws its scene from
//! the scene's streams of i, so the same data set, scene and seed give the same bytes.

mod segment;
mod tuning;

use tuning::CHUNK;

pub use segment::{find_object, ObjectMask};

use crate::image_io::{self, ColorMode, ImageSpec};
use crate::manifest::Manifest;
use crate::render::scene::{write_scene_csv, Scene, SceneRecord, SceneSpec};
use crate::{Error, Result, Source};
use image::codecs::png::{CompressionType, FilterType, PngEncoder};
use image::{ExtendedColorType, ImageEncoder};
use rayon::prelude::*;
use std::collections::HashSet;
use std::fs;
use std::path::{Component, Path};

/// What [`write_scenes`] wrote.
#[derive(Debug, Clone, PartialEq)]
pub struct SceneSummary {
    /// Objects (folders written).
    pub objects: usize,
    /// Views.
    pub views: usize,
    /// The mean, smallest and largest share of the object the occluders hide.
    pub hidden: [f64; 3],
    /// The mean share of the object's pixels that were holes filled.
    pub filled: f64,
}

/// One view put into its scene.
#[derive(Debug, Clone, PartialEq)]
pub struct Restaged {
    /// The object found in the studio view.
    pub object: ObjectMask,
    /// The view's scene.
    pub record: SceneRecord,
}

/// Puts view `view` (`pixels`, 8-bit, `spec`'s size and channels) into `scene` in place: its
/// object found against the studio backdrop, the rest replaced by the scene's background, the
/// occluders painted. `image` names the view in the record and `path` in errors.
pub fn restage_view(scene: &Scene, view: usize, image: &str, path: &Path, spec: ImageSpec, pixels: &mut [u8]) -> Result<Restaged> {
    let object = find_object(path, spec, pixels)?;
    let record = scene.restage(view, image, spec, &object.mask, pixels);
    Ok(Restaged { object, record })
}

/// Puts every view of `source` into the scene `spec` and writes the new data set to `out` (see
/// the [module](self)), which must not exist yet or be empty; nothing half-written is left there
/// on error. A view whose object cannot be told from its backdrop stops it, the error naming
/// the file. `progress` is called with the number of views written since its last call.
pub fn write_scenes(source: &Source, spec: &SceneSpec, out: &Path, progress: &(dyn Fn(u64) + Sync)) -> Result<SceneSummary> {
    let objects: Vec<(Option<&str>, &Manifest)> = match source {
        Source::One(m) => vec![(None, m)],
        Source::Many(c) => c.names().iter().map(|n| Some(n.as_str())).zip(c.manifests()).collect(),
    };
    for (name, m) in &objects {
        if let Some(n) = name {
            folder_name(n, m.root())?;
        }
        output_names(m)?;
    }
    let first = objects[0].1.first_image_spec(ColorMode::Gray)?;
    let scene = spec.open(first.width, first.height)?;
    let mut records: Vec<SceneRecord> = Vec::new();
    let mut filled = 0.0;
    crate::atomic::write_folder(out, |tmp| {
        let mut view = 0;
        for (name, m) in &objects {
            let dir = match name {
                Some(n) => tmp.join(n),
                None => tmp.to_path_buf(),
            };
            fs::create_dir_all(&dir).map_err(|e| Error::io(&dir, e))?;
            let size = (first.width, first.height);
            let done = write_object(&scene, m, size, view, &dir, progress)?;
            view += m.len();
            filled += done.iter().map(|r| r.object.filled as f64 / r.object.mask.iter().filter(|&&v| v).count().max(1) as f64).sum::<f64>();
            records.extend(done.into_iter().map(|r| r.record));
        }
        Ok(())
    })?;
    let n = records.len() as f64;
    let hidden = records.iter().map(|r| r.hidden);
    let summary = SceneSummary {
        objects: objects.len(),
        views: records.len(),
        hidden: [hidden.clone().sum::<f64>() / n, hidden.clone().fold(f64::INFINITY, f64::min), hidden.fold(0.0, f64::max)],
        filled: filled / n,
    };
    Ok(summary)
}

/// Writes one object's views in their scenes into `dir`, with poses.csv, dataset.toml and
/// scene.csv; its first view is view `first` of the scene. Every view must be `size`.
fn write_object(scene: &Scene, m: &Manifest, size: (u32, u32), first: usize, dir: &Path, progress: &(dyn Fn(u64) + Sync)) -> Result<Vec<Restaged>> {
    let names = output_names(m)?;
    let mut done = Vec::with_capacity(m.len());
    let csv_path = dir.join("scene.csv");
    let mut csv = std::io::BufWriter::new(fs::File::create(&csv_path).map_err(|e| Error::io(&csv_path, e))?);
    for start in (0..m.len()).step_by(CHUNK) {
        let chunk: Vec<Result<Restaged>> = (start..(start + CHUNK).min(m.len()))
            .into_par_iter()
            .map(|i| {
                let path = m.image_path(i);
                let (spec, mut pixels) = image_io::read_u8(&path)?;
                if (spec.width, spec.height) != size {
                    return Err(Error::ImageSizeMismatch {
                        path,
                        expected_w: size.0,
                        expected_h: size.1,
                        got_w: spec.width,
                        got_h: spec.height,
                        context: "the data set's first image".into(),
                    });
                }
                let (r, png) = match scene.canvas() {
                    Some(c) => {
                        let object = find_object(&path, spec, &pixels)?;
                        let (canvas, record) = scene.place(first + i, &names[i], spec, &object.mask, &pixels).expect("the scene has a canvas");
                        (Restaged { object, record }, encode_png(&canvas, c.spec(spec))?)
                    }
                    None => {
                        let r = restage_view(scene, first + i, &names[i], &path, spec, &mut pixels)?;
                        (r, encode_png(&pixels, spec)?)
                    }
                };
                let target = dir.join(&names[i]);
                if let Some(parent) = target.parent() {
                    fs::create_dir_all(parent).map_err(|e| Error::io(parent, e))?;
                }
                fs::write(&target, png).map_err(|e| Error::io(&target, e))?;
                progress(1);
                Ok(r)
            })
            .collect();
        // The first failure in the data set's order, so the error is the same on every run.
        let chunk = chunk.into_iter().collect::<Result<Vec<_>>>()?;
        let records: Vec<SceneRecord> = chunk.iter().map(|r| r.record.clone()).collect();
        write_scene_csv(&mut csv, &records, start == 0).map_err(|e| match e {
            Error::Io { source, .. } => Error::io(&csv_path, source),
            e => e,
        })?;
        done.extend(chunk);
    }
    csv.into_inner().map_err(|e| Error::io(&csv_path, e.into_error()))?.sync_all().map_err(|e| Error::io(&csv_path, e))?;
    crate::atomic::write_atomic(&dir.join("dataset.toml"), dataset_toml(m).as_bytes())?;
    let poses = dir.join("poses.csv");
    crate::atomic::write_atomic(&poses, &poses_csv(m, &names)?)?;
    Ok(done)
}

/// The name each image of `m` is written under: its own when it ends in `.png` (in any case),
/// else with `.png` for its extension. Refused: two images that would share a name.
fn output_names(m: &Manifest) -> Result<Vec<String>> {
    let mut seen = HashSet::new();
    m.images()
        .iter()
        .map(|name| {
            let p = Path::new(name);
            let png = p.extension().and_then(|e| e.to_str()).is_some_and(|e| e.eq_ignore_ascii_case("png"));
            let out = if png { name.clone() } else { p.with_extension("png").to_string_lossy().into_owned() };
            if !seen.insert(out.clone()) {
                return Err(Error::Dataset {
                    path: m.root().join(name),
                    message: format!("would be written as {out}, which another image of the data set is written as (the scene's images are PNG)"),
                });
            }
            Ok(out)
        })
        .collect()
}

/// Refuses an object name that cannot be a folder's: empty, a path, `.` or `..`.
fn folder_name(name: &str, root: &Path) -> Result<()> {
    let mut parts = Path::new(name).components();
    match (parts.next(), parts.next()) {
        (Some(Component::Normal(_)), None) if !name.contains(['/', '\\']) => Ok(()),
        _ => Err(Error::Dataset { path: root.to_path_buf(), message: format!("object '{name}' cannot name a folder of the scene's data set") }),
    }
}

/// `poses.csv` of the images `names` with `m`'s poses, values printed so they read back exactly.
fn poses_csv(m: &Manifest, names: &[String]) -> Result<Vec<u8>> {
    let mut w = csv::WriterBuilder::new().from_writer(Vec::new());
    let io = |e: csv::Error| Error::io(m.root().join("poses.csv"), std::io::Error::other(e.to_string()));
    let header: Vec<&str> = std::iter::once("image").chain(m.space().params().iter().map(|p| p.name.as_str())).collect();
    w.write_record(&header).map_err(io)?;
    for (i, name) in names.iter().enumerate() {
        let row: Vec<String> = std::iter::once(name.clone()).chain(m.pose(i).iter().map(|v| v.to_string())).collect();
        w.write_record(&row).map_err(io)?;
    }
    w.into_inner().map_err(|e| Error::io(m.root().join("poses.csv"), std::io::Error::other(e.to_string())))
}

/// `dataset.toml` saying every parameter's period or that it is linear.
fn dataset_toml(m: &Manifest) -> String {
    let mut s = String::new();
    for p in m.space().params() {
        let bare = !p.name.is_empty() && p.name.bytes().all(|b| b.is_ascii_alphanumeric() || b == b'_' || b == b'-');
        let key = if bare { p.name.clone() } else { format!("\"{}\"", p.name.replace('\\', "\\\\").replace('"', "\\\"")) };
        match p.period {
            Some(t) => s.push_str(&format!("{key} = {{ period = {t} }}\n")),
            None => s.push_str(&format!("{key} = {{ linear = true }}\n")),
        }
    }
    s
}

/// Encodes 8-bit pixels of `spec`'s colour as a PNG, with fast compression.
fn encode_png(pixels: &[u8], spec: ImageSpec) -> Result<Vec<u8>> {
    let mut out = Vec::with_capacity(pixels.len() / 2);
    let color = match spec.color {
        ColorMode::Gray => ExtendedColorType::L8,
        ColorMode::Rgb => ExtendedColorType::Rgb8,
    };
    PngEncoder::new_with_quality(&mut out, CompressionType::Fast, FilterType::Sub)
        .write_image(pixels, spec.width, spec.height, color)
        .map_err(|e| Error::invalid("image", format!("{}x{}", spec.width, spec.height), format!("PNG encoding failed: {e}")))?;
    Ok(out)
}
