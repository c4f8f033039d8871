//! `linpose predict`: estimate the pose of images with a trained model.

use crate::common::progress;
use anyhow::Context;
use linpose::image_io::read_features;
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
    #[arg(value_name = "IMAGE", required = true)]
    pub images: Vec<PathBuf>,
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
    let files = expand(&a.images)?;
    let bar = progress(files.len() as u64, "estimating");
    let stdout = std::io::stdout();
    let mut out = std::io::BufWriter::new(stdout.lock());
    let mut features = vec![0f32; BATCH.min(files.len()) * m];
    let mut poses = vec![0f64; BATCH * space.len()];
    let context = format!("the size of the model's training images ({})", a.model.display());
    for chunk in files.chunks(BATCH) {
        let feats = &mut features[..chunk.len() * m];
        feats
            .par_chunks_mut(m)
            .zip(chunk.par_iter())
            .map(|(slot, path)| {
                let mut row = Vec::with_capacity(m);
                read_features(path, spec.color, Some((spec.width, spec.height)), &context, &mut row)?;
                slot.copy_from_slice(&row);
                Ok(())
            })
            .collect::<linpose::Result<Vec<()>>>()?;
        let est = &mut poses[..chunk.len() * space.len()];
        model.predict_into(feats, est)?;
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
