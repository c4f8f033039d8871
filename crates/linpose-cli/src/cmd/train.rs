//! `linpose train`: fit a model on a data set and write the model file.

use crate::args::method::{self, as_flag};
use crate::args::TrainArgs;
use crate::common::{check_output_file, load_dataset, write_json};
use crate::plan::{self, MemorySummary};
use anyhow::Context;
use linpose::memory::{Path, Plan};
use linpose::model::Normalized;
use linpose::normalize::{NormalizeParams, StageChoice, StageRule};
use linpose::{AnyModel, PoseModel};
use serde::Serialize;
use std::time::Instant;

#[derive(Serialize)]
struct TrainSummary {
    method: String,
    data: String,
    n_train: usize,
    n_features: usize,
    load_s: f64,
    fit_s: f64,
    model_bytes: usize,
    file_bytes: u64,
    /// The storage in the paper's Table 1 terms: the method's formula, its terms' values and
    /// the numbers it gives.
    storage: StorageSummary,
    settings: serde_json::Value,
    #[serde(skip_serializing_if = "Option::is_none")]
    normalize: Option<linpose::normalize::Normalizer>,
    /// How the normalisation was decided.
    #[serde(skip_serializing_if = "Option::is_none")]
    stage_choice: Option<StageChoice>,
    /// The memory plan: the path taken and what it needed.
    memory: MemorySummary,
}

/// A model's storage in the paper's Table 1 terms.
#[derive(Serialize)]
struct StorageSummary {
    formula: &'static str,
    #[serde(flatten)]
    terms: linpose::model::Storage,
}

/// No normalisation stage.
const OFF: StageRule = StageRule::Fixed(NormalizeParams::OFF);

/// Runs `linpose train`.
pub(crate) fn run(a: &TrainArgs) -> anyhow::Result<()> {
    let out = match (&a.out, a.shard, &a.partial) {
        (_, Some(shard), Some(partial)) => return crate::cmd::shard::train_shard(a, shard, partial),
        (Some(out), _, _) => out,
        _ => anyhow::bail!("--out MODEL is required (or --shard I/N with --partial FILE)"),
    };
    check_output_file(out, "model")?;
    if let Some(j) = &a.json {
        check_output_file(j, "JSON")?;
    }
    let method = method::method(&a.method);
    let settings = &a.settings.settings;
    // The settings are read before any image is.
    let spec = method.spec(settings).map_err(as_flag)?;
    if a.stream && !method.streams() {
        let can: Vec<&str> = linpose::METHODS.iter().filter(|m| m.streams()).map(|m| m.name).collect();
        anyhow::bail!("--stream: the {} method fits in memory only (streamed: {})", method.name, can.join(", "));
    }
    let rule = a.stage_rule();
    if a.stream && a.forces_stage() {
        anyhow::bail!("--stream with --normalize: the normalisation is fitted in memory only");
    }
    let many_only = a.recognizer.is_some() || a.recognizer_components.is_some() || a.unknown.is_some() || !a.leave_out.is_empty();
    if let linpose::Source::Many(_) = linpose::Source::open(&a.data.data, a.data.object)? {
        if a.stream {
            anyhow::bail!("{}: a data set of many objects is fitted in memory (not yet: --stream)", a.data.data.display());
        }
        let params = crate::cmd::objects::recognizer_params(a)?;
        return crate::cmd::objects::train(a, &params, method, &spec, rule);
    }
    if many_only {
        anyhow::bail!(
            "--recognizer, --recognizer-components, --unknown and --leave-out are for data sets of many objects; {} holds one",
            a.data.data.display()
        );
    }
    let t0 = Instant::now();
    let manifest = a.data.manifest()?;
    let manifest = manifest.subset(&manifest.training_mask(&a.selection()?)?)?;
    // The path, from the sizes alone, before any image is decoded. A stage is chosen only for
    // a set that fits in memory normalised; a larger one is used as it is.
    let (plan, off) = match rule {
        // A stage is chosen only for a set fitted in memory, and where its held-out folds fit
        // there too; a set streamed from disk is used as it is.
        StageRule::Auto => match plan::plan_one(a, &manifest, method, OFF)? {
            p if p.path == Path::Streamed => (p, Some("streamed from disk: the stage is fitted in memory only")),
            p => match plan::plan_one(a, &manifest, method, rule) {
                Ok(q) if q.path != Path::Streamed => (q, None),
                _ => (p, Some("the training set is too large to choose its normalisation in memory")),
            },
        },
        StageRule::Fixed(_) => (plan::plan_one(a, &manifest, method, rule)?, None),
    };
    plan::say(&plan);
    if a.robust && plan.path == Path::Streamed {
        anyhow::bail!("--robust: the robust stage is fitted in memory, and this training set is streamed from disk");
    }
    let (model, load_s, fit_s, how) = if plan.path == Path::Streamed {
        // Each image read as many times as the method passes over the set.
        let m = manifest.first_image_spec(a.color.into())?.features();
        let bar = crate::common::progress(method.stream_reads(manifest.len(), m), "reading");
        let (model, how) = method.fit_streamed(&manifest, a.color.into(), settings, &|k| bar.inc(k)).map_err(as_flag)?;
        bar.finish_and_clear();
        let choice = match rule {
            StageRule::Auto => StageChoice::off(off.unwrap_or("streamed from disk")),
            StageRule::Fixed(p) => StageChoice::fixed(p),
        };
        (AnyModel::new(Normalized::recorded(None, model, Some(choice))), 0.0, t0.elapsed().as_secs_f64(), Some(how))
    } else {
        let train = load_dataset(manifest, a.color.into())?;
        let load_s = t0.elapsed().as_secs_f64();
        let t1 = Instant::now();
        let model = match off {
            Some(why) => spec.fit_with_choice(&train, StageChoice::off(why))?,
            None => spec.fit_with_stage(&train, rule)?,
        };
        let model = if a.robust { linpose::robust::Robust::fit(&train, model)? } else { model };
        (model, load_s, t1.elapsed().as_secs_f64(), None)
    };
    let file_bytes = model.save(out).context("writing the model")?;
    report(a, Trained { out, model: &model, load_s, fit_s, file_bytes, how }, &plan)
}

/// What a training run made, for its [`report`].
struct Trained<'a> {
    /// The model file written.
    out: &'a std::path::Path,
    /// The model.
    model: &'a AnyModel,
    /// Seconds spent decoding the images (0 when streamed: the fit's seconds include the reading).
    load_s: f64,
    /// Seconds spent fitting.
    fit_s: f64,
    /// The model file's size in bytes.
    file_bytes: u64,
    /// A streamed fit's line saying how it was fitted (None when fitted in memory).
    how: Option<String>,
}

/// Says what was trained, and writes the JSON summary when asked.
fn report(a: &TrainArgs, trained: Trained<'_>, plan: &Plan) -> anyhow::Result<()> {
    let Trained { out, model, load_s, fit_s, file_bytes, how } = trained;
    let meta = model.meta();
    let summary = TrainSummary {
        method: meta.method.clone(),
        data: a.data.data.display().to_string(),
        n_train: meta.n_train(),
        n_features: meta.spec.features(),
        load_s,
        fit_s,
        model_bytes: model.model_bytes(),
        file_bytes,
        storage: StorageSummary { formula: model.method().storage, terms: model.storage() },
        settings: meta.settings.clone(),
        normalize: meta.normalize.clone(),
        stage_choice: meta.stage_choice.clone(),
        memory: MemorySummary::of(plan),
    };
    let timing = match how {
        Some(_) => format!("in {fit_s:.3} s (streamed, reading included)"),
        None => format!("in {fit_s:.3} s (decoding {load_s:.3} s)"),
    };
    eprintln!(
        "trained {} on {} images of {}x{} {timing}; model {} bytes -> {}",
        summary.method,
        summary.n_train,
        meta.spec.width,
        meta.spec.height,
        summary.model_bytes,
        out.display()
    );
    if let Some(how) = how {
        eprintln!("  {how}");
    }
    if let Some(c) = &meta.stage_choice {
        eprintln!("  {}", c.describe());
    }
    if let Some(n) = &meta.normalize {
        eprintln!("  {}", n.describe());
    }
    if let Some(j) = &a.json {
        write_json(j, &summary)?;
    }
    Ok(())
}
