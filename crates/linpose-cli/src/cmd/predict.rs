//! `linpose predict`: estimate the pose of images with a trained model.

use crate::common::progress;
use anyhow::Context;
use linpose::image_io::{read_query, QueryImage};
use linpose::PoseModel;
use rayon::prelude::*;
use serde::Serialize;
use std::collections::BTreeMap;
use std::io::Write;
use std::path::{Path, PathBuf};

/// Images decoded and estimated per batch: bounds memory whatever the number of images.
const BATCH: usize = 512;

/// Arguments of `linpose predict`.
#[derive(clap::Args, Debug)]
pub struct PredictArgs {
    /// The model file.
    #[arg(long, value_name = "MODEL")]
    pub model: PathBuf,
    /// Images (PNG, PGM, PPM), or folders whose images are all estimated (sorted by name).
    #[arg(value_name = "IMAGE", required_unless_present = "list")]
    pub images: Vec<PathBuf>,
    /// Also estimate the images listed in FILE, one path per line (for more paths than a
    /// command line holds).
    #[arg(long, value_name = "FILE")]
    pub list: Option<PathBuf>,
    /// Print one JSON object per image instead of text.
    #[arg(long)]
    pub json: bool,
}

#[derive(Serialize)]
struct Estimate<'a> {
    image: &'a str,
    pose: BTreeMap<&'a str, f64>,
}

/// Expands folders into their image files.
fn expand(paths: &[PathBuf]) -> anyhow::Result<Vec<PathBuf>> {
    let mut out = Vec::new();
    for p in paths {
        if p.is_dir() {
            let mut files: Vec<PathBuf> = std::fs::read_dir(p)
                .with_context(|| format!("{}: cannot list folder", p.display()))?
                .filter_map(|e| e.ok().map(|e| e.path()))
                .filter(|f| is_image_name(f))
                .collect();
            files.sort();
            if files.is_empty() {
                anyhow::bail!("{}: the folder holds no PNG, PGM or PPM image", p.display());
            }
            out.extend(files);
        } else {
            out.push(p.clone());
        }
    }
    Ok(out)
}

fn is_image_name(p: &Path) -> bool {
    matches!(p.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase).as_deref(), Some("png" | "pgm" | "ppm" | "pnm"))
}

/// Runs `linpose predict`.
pub fn run(a: &PredictArgs) -> anyhow::Result<()> {
    let model = linpose::model_file::load(&a.model)?;
    let meta = model.meta();
    let (spec, space) = (meta.spec, &meta.space);
    let m = spec.features();
    let mut paths = a.images.clone();
    if let Some(list) = &a.list {
        let text = std::fs::read_to_string(list).with_context(|| format!("{}: cannot read the list", list.display()))?;
        paths.extend(text.lines().map(str::trim).filter(|l| !l.is_empty()).map(PathBuf::from));
    }
    let files = expand(&paths)?;
    let bar = progress(files.len() as u64, "estimating");
    let stdout = std::io::stdout();
    let mut out = std::io::BufWriter::new(stdout.lock());
    let mut features = vec![0f32; BATCH.min(files.len()) * m];
    let mut pixels = vec![0u8; BATCH.min(files.len()) * m];
    let mut poses = vec![0f64; BATCH * space.len()];
    let context = format!("the size of the model's training images ({})", a.model.display());
    for chunk in files.chunks(BATCH) {
        // Decoded in parallel; 8-bit gray (or RGB made gray) images stay 8-bit for the model's
        // 8-bit path, any other image becomes f32 features.
        let feats = &mut features[..chunk.len() * m];
        let pix = &mut pixels[..chunk.len() * m];
        let all_u8 = feats
            .par_chunks_mut(m)
            .zip(pix.par_chunks_mut(m))
            .zip(chunk.par_iter())
            .map(|((slot, slot8), path)| read_one(path, spec, &context, slot, slot8))
            .collect::<linpose::Result<Vec<bool>>>()?
            .into_iter()
            .all(|b| b);
        let est = &mut poses[..chunk.len() * space.len()];
        if all_u8 {
            model.predict_u8_into(pix, est)?;
        } else {
            for (f, p) in feats.chunks_exact_mut(m).zip(pix.chunks_exact(m)) {
                if f[0].is_nan() {
                    f.iter_mut().zip(p).for_each(|(f, &v)| *f = v as f32 * (1.0 / 255.0));
                }
            }
            model.predict_into(feats, est)?;
        }
        for (path, pose) in chunk.iter().zip(est.chunks_exact(space.len())) {
            let name = path.display().to_string();
            if a.json {
                let e = Estimate { image: &name, pose: space.params().iter().map(|p| p.name.as_str()).zip(pose.iter().copied()).collect() };
                serde_json::to_writer(&mut out, &e)?;
                writeln!(out)?;
            } else {
                write!(out, "{name}")?;
                for (p, v) in space.params().iter().zip(pose) {
                    write!(out, "\t{}={v:.4}", p.name)?;
                }
                writeln!(out)?;
            }
        }
        bar.inc(chunk.len() as u64);
    }
    bar.finish_and_clear();
    out.flush()?;
    Ok(())
}

/// Decodes one image into `pixels` (8-bit gray, returning true) or else `features` (returning
/// false; `features[0]` is NaN after an 8-bit image, marking the row to convert if needed).
fn read_one(path: &Path, spec: linpose::image_io::ImageSpec, context: &str, features: &mut [f32], pixels: &mut [u8]) -> linpose::Result<bool> {
    match read_query(path, spec, context)? {
        QueryImage::Gray8(v) => {
            pixels.copy_from_slice(&v);
            features[0] = f32::NAN;
            Ok(true)
        }
        QueryImage::Features(f) => {
            features.copy_from_slice(&f);
            Ok(false)
        }
    }
}
