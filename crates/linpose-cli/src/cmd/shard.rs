//! `linpose train --shard I/N --partial OUT` and `linpose merge`: training on several machines
//! (or processes) without a distributed engine. Each shard sums its part of the training
//! statistics ([`linpose::partial`]: X^T X over a run of images, or X X^T over a run of pixels)
//! into a partial statistics file; `merge` adds the files and fits the model, which is the
//! single-process model up to the rounding of the sums' order.

use crate::args::method::{self, as_flag};
use crate::args::ShardArg;
use crate::args::TrainArgs;
use crate::common::{check_output_file, write_json};
use anyhow::Context;
use linpose::partial::Partial;
use linpose::PoseModel;
use serde::Serialize;
use std::path::PathBuf;
use std::time::Instant;

#[derive(Serialize)]
struct ShardSummary {
    method: String,
    data: String,
    shard: String,
    split: &'static str,
    range: [usize; 2],
    units: usize,
    n_train: usize,
    seconds: f64,
    file_bytes: u64,
}

/// `train --shard I/N --partial OUT`: the shard's partial statistics.
pub(crate) fn train_shard(a: &TrainArgs, shard: ShardArg, out: &std::path::Path) -> anyhow::Result<()> {
    check_output_file(out, "partial statistics")?;
    if let Some(j) = &a.json {
        check_output_file(j, "JSON")?;
    }
    if a.stream || a.forces_stage() {
        anyhow::bail!("--shard: statistics are read shard by shard already (no --stream), and without --normalize (fitted in memory only)");
    }
    let method = method::method(&a.method);
    let settings = &a.settings.settings;
    method.spec(settings).map_err(as_flag)?;
    if let linpose::Source::Many(_) = linpose::Source::open(&a.data.data, a.data.object)? {
        anyhow::bail!("{}: a data set of many objects is fitted in one process (not yet: --shard)", a.data.data.display());
    }
    let t0 = Instant::now();
    let manifest = a.data.manifest()?;
    let manifest = manifest.subset(&manifest.training_mask(&a.selection()?)?)?;
    let color = a.color.into();
    let mut partial =
        Partial::for_images(method, settings, &manifest, color).map_err(as_flag)?.with_source(format!("shard {}/{}", shard.index + 1, shard.count));
    let range = partial.shard_range(shard.index, shard.count).map_err(as_flag)?;
    let split = partial.split();
    let (w, h) = partial.image_size();
    // A shard of images reads its images; a shard of pixels reads every image for its pixels.
    let reads = match split {
        linpose::partial::Split::Images => range.len(),
        linpose::partial::Split::Pixels => manifest.len(),
    };
    let bar = crate::common::progress(reads as u64, "reading");
    partial.read_shard(&manifest, color, shard.index, shard.count, &|k| bar.inc(k))?;
    bar.finish_and_clear();
    let file_bytes = partial.save(out).context("writing the partial statistics")?;
    let seconds = t0.elapsed().as_secs_f64();
    eprintln!(
        "shard {}/{}: {} {}..{} of {}, {}x{}, {} training images, in {seconds:.3} s; {} bytes -> {}",
        shard.index + 1,
        shard.count,
        split.unit(),
        range.start,
        range.end,
        partial.units(),
        w,
        h,
        manifest.len(),
        file_bytes,
        out.display()
    );
    if let Some(j) = &a.json {
        let summary = ShardSummary {
            method: method.name.into(),
            data: a.data.data.display().to_string(),
            shard: format!("{}/{}", shard.index + 1, shard.count),
            split: split.unit(),
            range: [range.start, range.end],
            units: partial.units(),
            n_train: manifest.len(),
            seconds,
            file_bytes,
        };
        write_json(j, &summary)?;
    }
    Ok(())
}

/// Arguments of `linpose merge`.
#[derive(clap::Args, Debug)]
pub(crate) struct MergeArgs {
    /// Partial statistics files (`train --shard I/N --partial FILE`), every shard of one fit, in
    /// any order.
    #[arg(required = true, value_name = "PARTIAL")]
    pub partials: Vec<PathBuf>,
    /// The model file to write (safetensors).
    #[arg(long, value_name = "MODEL")]
    pub out: PathBuf,
    /// Also write a JSON summary (n_train, merge_s, fit_s, model_bytes, ...).
    #[arg(long, value_name = "FILE")]
    pub json: Option<PathBuf>,
}

#[derive(Serialize)]
struct MergeSummary {
    method: String,
    partials: usize,
    n_train: usize,
    n_features: usize,
    merge_s: f64,
    fit_s: f64,
    model_bytes: usize,
    file_bytes: u64,
}

/// Runs `linpose merge`: adds the partial statistics one file at a time (two in memory at
/// most) and fits the model.
pub(crate) fn merge(a: &MergeArgs) -> anyhow::Result<()> {
    check_output_file(&a.out, "model")?;
    if let Some(j) = &a.json {
        check_output_file(j, "JSON")?;
    }
    let t0 = Instant::now();
    let mut total: Option<Partial> = None;
    for path in &a.partials {
        let p = Partial::load(path)?;
        match &mut total {
            None => total = Some(p),
            Some(t) => t.merge(p)?,
        }
    }
    let total = total.expect("clap requires one file");
    let merge_s = t0.elapsed().as_secs_f64();
    let t1 = Instant::now();
    let model = total.finish()?;
    let fit_s = t1.elapsed().as_secs_f64();
    let file_bytes = model.save(&a.out).context("writing the model")?;
    let meta = model.meta();
    eprintln!(
        "merged {} partial statistics in {merge_s:.3} s and fitted {} on {} images of {}x{} in {fit_s:.3} s; model {} bytes -> {}",
        a.partials.len(),
        meta.method,
        meta.n_train(),
        meta.spec.width,
        meta.spec.height,
        model.model_bytes(),
        a.out.display()
    );
    if let Some(j) = &a.json {
        let summary = MergeSummary {
            method: meta.method.clone(),
            partials: a.partials.len(),
            n_train: meta.n_train(),
            n_features: meta.spec.features(),
            merge_s,
            fit_s,
            model_bytes: model.model_bytes(),
            file_bytes,
        };
        write_json(j, &summary)?;
    }
    Ok(())
}
