//! `train`'s memory plan ([`linpose::memory`]): the job from the training set's sizes (the
//! manifest, and the first image's header: no pixel is read), planned against `--memory-budget`
//! or the memory the machine has available, before any image is decoded; the line that says
//! which path and why; the summary's record of it; and a plan that cannot fit said in the
//! command line's words (its flags), so the user knows what to change.

use crate::args::method::as_flag;
use crate::args::TrainArgs;
use linpose::image_io::ImageSpec;
use linpose::memory::{format_bytes, Job, Limit, Path, Plan, Remedy, StreamChange};
use linpose::normalize::StageRule;
use linpose::recognize::RecognizerParams;
use linpose::{Catalog, Manifest, Method};
use serde::Serialize;

/// The plan in the JSON summary.
#[derive(Serialize)]
pub(crate) struct MemorySummary {
    /// "in memory" or "streamed".
    path: &'static str,
    /// What the chosen path needs (bytes).
    estimate_bytes: u64,
    /// What each path needs (streamed: null when the method or its settings cannot stream).
    in_memory_bytes: u64,
    streamed_bytes: Option<u64>,
    /// The bytes the plan was held to (null when the available memory could not be read), and
    /// whence: "budget", "available" or "unknown".
    limit_bytes: Option<u64>,
    limit: &'static str,
}

impl MemorySummary {
    /// The summary of `plan`.
    pub(crate) fn of(plan: &Plan) -> Self {
        MemorySummary {
            path: plan.path.name(),
            estimate_bytes: plan.chosen().bytes,
            in_memory_bytes: plan.in_memory.bytes,
            streamed_bytes: plan.streamed.as_ref().map(|e| e.bytes),
            limit_bytes: plan.limit.usable(),
            limit: match plan.limit {
                Limit::Budget(_) => "budget",
                Limit::Available(_) => "available",
                _ => "unknown",
            },
        }
    }
}

/// The limit `train` plans against: `--memory-budget`, else the machine's available memory.
fn limit(a: &TrainArgs) -> Limit {
    a.memory_budget.map_or_else(Limit::detect, Limit::Budget)
}

/// Plans training on the images of `manifest` (one object); [`say`] tells which path.
pub(crate) fn plan_one(a: &TrainArgs, manifest: &Manifest, method: &'static Method, stage: StageRule) -> anyhow::Result<Plan> {
    let spec = manifest.first_image_spec(a.color.into())?;
    let job = Job::for_manifest(manifest, spec, method, &a.settings.settings)
        .map_err(as_flag)?
        .normalized(stage.normalises())
        .choosing_stage(stage == StageRule::Auto);
    let force = match (a.stream, a.in_memory) {
        (true, _) => Some(Path::Streamed),
        (_, true) => Some(Path::InMemory),
        _ => None,
    };
    linpose::memory::plan(&job, &limit(a), force).map_err(|e| explain(e, spec, a))
}

/// Says on stderr which path a plan takes.
pub(crate) fn say(plan: &Plan) {
    eprintln!("{}", plan.describe());
}

/// Plans training on a catalog of many objects (in memory); [`say`] tells which path.
pub(crate) fn plan_objects(a: &TrainArgs, catalog: &Catalog, method: &'static Method, params: &RecognizerParams, stage: StageRule) -> anyhow::Result<Plan> {
    let first = catalog.manifests().first().ok_or_else(|| anyhow::anyhow!("{}: no object to train on", a.data.data.display()))?;
    let spec = first.first_image_spec(a.color.into())?;
    let job = Job::for_objects(catalog.manifests(), spec, method, &a.settings.settings, params)
        .map_err(as_flag)?
        .normalized(stage.normalises())
        .choosing_stage(stage == StageRule::Auto);
    linpose::memory::plan(&job, &limit(a), None).map_err(|e| explain(e, spec, a))
}

/// A plan's error in the command line's words: the remedies with the flags that give them.
fn explain(e: linpose::Error, spec: ImageSpec, a: &TrainArgs) -> anyhow::Error {
    let linpose::Error::NotEnoughMemory { needs, remedies } = e else { return as_flag(e) };
    let budget = a.memory_budget.is_some();
    let hints: Vec<String> = remedies
        .iter()
        .map(|r| match r {
            Remedy::FewerImages { at_most, shards } => format!(
                "fewer training images, at most {at_most} (--train-step or --train-list; or the set split into {shards} shards of that many, one model each)"
            ),
            Remedy::SmallerImages { at_most } => {
                // The same aspect at that many features.
                let scale = (*at_most as f64 / spec.features() as f64).sqrt();
                let (w, h) = ((spec.width as f64 * scale).floor().max(1.0), (spec.height as f64 * scale).floor().max(1.0));
                format!("smaller images, at most {at_most} features each (e.g. {w}x{h} instead of {}x{})", spec.width, spec.height)
            }
            Remedy::MoreMemory { bytes, budget: true } => {
                // Rounded up, so that the value given fits.
                let size = if *bytes < 1 << 30 {
                    format!("{}M", bytes.div_ceil(1 << 20))
                } else {
                    format!("{:.1}G", (*bytes as f64 / (1u64 << 30) as f64 * 10.0).ceil() / 10.0)
                };
                format!("--memory-budget {size} or more, if the machine has that much free")
            }
            Remedy::MoreMemory { bytes, .. } => format!(
                "a machine with {} available{}",
                format_bytes(*bytes),
                if budget { "" } else { " (or --memory-budget, if more is free than was measured)" }
            ),
            Remedy::Stream { change, bytes } => {
                let what = match change {
                    StreamChange::FixedRidge => "a fixed --ridge (e.g. 1e-3) instead of --ridge auto",
                    StreamChange::FixedNoiseLevel => "a fixed --ridge (e.g. 1e-3) instead of --noise-level",
                    StreamChange::NoCentring => "no --center",
                    StreamChange::NoNormalization => "--no-normalize",
                    _ => "other settings",
                };
                format!("{what}: streaming then needs {}", format_bytes(*bytes))
            }
            r => r.to_string(),
        })
        .collect();
    anyhow::anyhow!("not enough memory to train: {needs}; what would help: {}", hints.join("; "))
}
