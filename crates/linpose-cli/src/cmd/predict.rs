//! `linpose predict`: estimate the pose of images with a trained model.

use crate::args::PredictArgs;
use crate::common::progress;
use crate::queries::{cannot_normalise, compact, each_row, eight_bit_as_features, read_one, read_refusal, refusals, report_refused, BATCH};
use anyhow::Context;
use linpose::image_io::has_image_extension;
use linpose::PoseModel;
use rayon::prelude::*;
use serde::Serialize;
use std::collections::BTreeMap;
use std::io::Write;
use std::path::PathBuf;

#[derive(Serialize)]
struct Estimate<'a> {
    image: &'a str,
    pose: BTreeMap<&'a str, f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    confidence: Option<f64>,
    #[serde(skip_serializing_if = "Option::is_none")]
    flagged: Option<bool>,
    #[serde(skip_serializing_if = "Option::is_none")]
    hypotheses: Option<Vec<Hypothesis<'a>>>,
    /// For an image larger than the training views: the object's box (left, top, width, height).
    #[serde(rename = "box", skip_serializing_if = "Option::is_none")]
    bbox: Option<[f64; 4]>,
    /// For an image larger than the training views: the share of the object's pixels used.
    #[serde(skip_serializing_if = "Option::is_none")]
    shown: Option<f64>,
}

/// A pose, its estimate (with --top) and, for a scene, where the object was found.
type Outcome = (Vec<f64>, Option<linpose::confidence::Estimate>, Option<linpose::model::Located>);

/// The image at `path`, larger than the training views, searched for the object by `search`
/// and estimated (with `top` hypotheses when asked for).
fn scene_estimate(
    search: &dyn linpose::model::SceneSearch,
    path: &std::path::Path,
    color: linpose::image_io::ColorMode,
    top: Option<u64>,
) -> linpose::Result<Outcome> {
    let (spec, scene) = linpose::image_io::read_any_size(path, color)?;
    let found = search.locate(&scene, spec)?;
    let (pose, est) = match top {
        Some(t) => {
            let e = search.estimate_located(&found, t as usize)?.remove(0);
            (e.pose.clone(), Some(e))
        }
        None => (search.predict_located(&found[..1])?, None),
    };
    Ok((pose, est, found.into_iter().next()))
}

/// An image with no estimate, and why.
#[derive(Serialize)]
struct Refused<'a> {
    image: &'a str,
    refused: &'a str,
}

#[derive(Serialize)]
struct Hypothesis<'a> {
    pose: BTreeMap<&'a str, f64>,
    score: f64,
}

/// Expands folders into their image files.
fn expand(paths: &[PathBuf]) -> anyhow::Result<Vec<PathBuf>> {
    let mut out = Vec::new();
    for p in paths {
        if p.is_dir() {
            let mut files: Vec<PathBuf> = std::fs::read_dir(p)
                .with_context(|| format!("{}: cannot list folder", p.display()))?
                .filter_map(|e| e.ok().map(|e| e.path()))
                .filter(|f| has_image_extension(f))
                .collect();
            files.sort();
            if files.is_empty() {
                anyhow::bail!("{}: the folder holds no PNG, PGM, PPM, JPEG or TIFF image (.png, .pgm, .ppm, .pnm, .jpg, .jpeg, .tif, .tiff)", p.display());
            }
            out.extend(files);
        } else {
            out.push(p.clone());
        }
    }
    Ok(out)
}

/// The images and folders given, then those of the --list file.
fn query_paths(a: &PredictArgs) -> anyhow::Result<Vec<PathBuf>> {
    let mut paths = a.images.clone();
    if let Some(list) = &a.list {
        let text = std::fs::read_to_string(list).with_context(|| format!("{}: cannot read the list", list.display()))?;
        paths.extend(text.lines().map(str::trim).filter(|l| !l.is_empty()).map(PathBuf::from));
    }
    Ok(paths)
}

/// Runs `linpose predict`.
pub(crate) fn run(a: &PredictArgs) -> anyhow::Result<()> {
    if !(a.flag_below.is_finite() && (0.0..=1.0).contains(&a.flag_below)) {
        anyhow::bail!("--flag-below {} is outside [0, 1]: it is a confidence", a.flag_below);
    }
    if linpose::model_file::holds_objects(&a.model)? {
        return crate::cmd::objects::predict(a, &expand(&query_paths(a)?)?);
    }
    let model = linpose::AnyModel::load(&a.model)?;
    let meta = model.meta();
    let (spec, space) = (meta.spec, &meta.space);
    let m = spec.features();
    let files = expand(&query_paths(a)?)?;
    let bar = progress(files.len() as u64, "estimating");
    let mut out = crate::queries::Output::open(a.out.as_deref())?;
    let mut features = vec![0f32; BATCH.min(files.len()) * m];
    let mut pixels = vec![0u8; BATCH.min(files.len()) * m];
    let context = format!("the size of the model's training images ({})", a.model.display());
    let mut refused = 0usize;
    let k = space.len();
    for chunk in files.chunks(BATCH) {
        let n = chunk.len();
        // Decoded in parallel; 8-bit gray (or RGB made gray) images stay 8-bit for the model's
        // 8-bit path, any other image becomes f32 features. An image that cannot be read has
        // no estimate and leaves the others theirs.
        let feats = &mut features[..n * m];
        let pix = &mut pixels[..n * m];
        let read: Vec<linpose::Result<bool>> = feats
            .par_chunks_mut(m)
            .zip(pix.par_chunks_mut(m))
            .zip(chunk.par_iter())
            .map(|((slot, slot8), path)| read_one(path, spec, &context, slot, slot8))
            .collect();
        // Each image's outcome: None until estimated or refused.
        let mut reasons: Vec<Option<String>> = read.iter().zip(chunk).map(|(r, path)| r.as_ref().err().map(|e| read_refusal(path, e))).collect();
        // Images larger than the training views, for a model that finds its object in them:
        // searched and estimated one by one below.
        let scenes: Vec<usize> = match model.scene_search() {
            Some(_) => (0..n)
                .filter(|&i| matches!(read[i], Err(linpose::Error::ImageSizeMismatch { got_w, got_h, .. }) if got_w >= spec.width && got_h >= spec.height))
                .collect(),
            None => Vec::new(),
        };
        scenes.iter().for_each(|&i| reasons[i] = None);
        let mut rows: Vec<usize> = (0..n).filter(|&i| reasons[i].is_none() && !scenes.contains(&i)).collect();
        compact(feats, m, &rows);
        compact(pix, m, &rows);
        let mut all_u8 = rows.iter().all(|&i| matches!(read[i], Ok(true)));
        let (mut feats, pix) = (&mut feats[..rows.len() * m], &mut pix[..rows.len() * m]);
        // A model behind a normalisation stage: the images it refuses are left out; the rest
        // are normalised once and given to the method's own model.
        let mut normalised;
        let mut target: &dyn PoseModel = &model;
        if let (Some((stage, inner)), false) = (model.behind_stage(), rows.is_empty()) {
            eight_bit_as_features(feats, pix, m);
            all_u8 = false;
            let (normal, verdicts) = stage.apply_batch(feats);
            for (&i, v) in rows.iter().zip(&verdicts) {
                if let Some(r) = v {
                    reasons[i] = Some(cannot_normalise(r));
                }
            }
            rows.retain(|&i| reasons[i].is_none());
            normalised = normal;
            feats = &mut normalised[..];
            target = inner;
        }
        if !all_u8 || a.top.is_some() {
            // Hypotheses are ranked on features: the 8-bit path's estimates agree but for near
            // ties, and the first hypothesis must be the estimate printed.
            eight_bit_as_features(feats, pix, m);
        }
        let (feats, pix) = (&*feats, &*pix);
        let outcomes = each_row(rows.len(), |r| -> linpose::Result<Vec<(Vec<f64>, Option<linpose::confidence::Estimate>)>> {
            if let Some(top) = a.top {
                let ranked = target.estimate(&feats[r.start * m..r.end * m], top as usize)?;
                return Ok(ranked.into_iter().map(|e| (e.pose.clone(), Some(e))).collect());
            }
            let mut est = vec![0f64; r.len() * k];
            if all_u8 {
                target.predict_u8_into(&pix[r.start * m..r.end * m], &mut est)?;
            } else {
                target.predict_into(&feats[r.start * m..r.end * m], &mut est)?;
            }
            Ok(est.chunks_exact(k).map(|p| (p.to_vec(), None)).collect())
        });
        let mut estimates: Vec<Option<Outcome>> = (0..n).map(|_| None).collect();
        for (&i, o) in rows.iter().zip(outcomes) {
            match o {
                Ok((pose, e)) => estimates[i] = Some((pose, e, None)),
                Err(why) => reasons[i] = Some(why),
            }
        }
        if let Some(search) = model.scene_search() {
            let found: Vec<linpose::Result<Outcome>> = scenes.par_iter().map(|&i| scene_estimate(search, &chunk[i], spec.color, a.top)).collect();
            for (&i, f) in scenes.iter().zip(found) {
                match f {
                    Ok(o) => estimates[i] = Some(o),
                    Err(e) => reasons[i] = Some(read_refusal(&chunk[i], &e)),
                }
            }
        }
        let named = |pose: &[f64]| -> BTreeMap<&str, f64> { space.params().iter().map(|p| p.name.as_str()).zip(pose.iter().copied()).collect() };
        for (i, path) in chunk.iter().enumerate() {
            let name = path.display().to_string();
            let Some((pose, r, found)) = &estimates[i] else {
                let why = reasons[i].as_deref().unwrap_or("no estimate");
                if a.strict {
                    out.flush()?;
                    anyhow::bail!("{name}: {why}");
                }
                report_refused(&bar, path, why);
                if a.json {
                    serde_json::to_writer(&mut out, &Refused { image: &name, refused: why })?;
                    writeln!(out)?;
                }
                refused += 1;
                continue;
            };
            let r = r.as_ref();
            if a.json {
                let e = Estimate {
                    image: &name,
                    pose: named(pose),
                    confidence: r.map(|r| r.confidence),
                    flagged: r.map(|r| r.flagged(a.flag_below)),
                    hypotheses: r.map(|r| r.hypotheses.iter().map(|h| Hypothesis { pose: named(&h.pose), score: h.score }).collect()),
                    bbox: found.as_ref().map(|f| f.bbox),
                    shown: found.as_ref().map(|f| f.shown),
                };
                serde_json::to_writer(&mut out, &e)?;
                writeln!(out)?;
            } else {
                write!(out, "{name}")?;
                for (p, v) in space.params().iter().zip(pose) {
                    write!(out, "\t{}={v:.4}", p.name)?;
                }
                if let Some(f) = found {
                    let [x, y, w, h] = f.bbox;
                    write!(out, "\tbox={x:.1},{y:.1},{w:.1},{h:.1}\tshown={:.3}", f.shown)?;
                }
                if let Some(r) = r {
                    write!(out, "\tconfidence={:.3}", r.confidence)?;
                    if r.flagged(a.flag_below) {
                        write!(out, "\tFLAGGED")?;
                    }
                    for (k, h) in r.hypotheses.iter().enumerate().skip(1) {
                        write!(out, "\t#{}:", k + 1)?;
                        for (p, v) in space.params().iter().zip(&h.pose) {
                            write!(out, " {}={v:.4}", p.name)?;
                        }
                        write!(out, " score={:.3}", h.score)?;
                    }
                }
                writeln!(out)?;
            }
        }
        bar.inc(n as u64);
    }
    bar.finish_and_clear();
    out.finish()?;
    refusals(refused, files.len())
}
