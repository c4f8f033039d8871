//! `linpose train`: fit a model on a data set and write the model file.

use crate::cmd::memory_plan::{self, MemorySummary};
use crate::cmd::method_args::{self, as_flag, MethodArgs};
use crate::common::{check_output_file, load_dataset, write_json, ColorArg, DataArgs};
use anyhow::Context;
use linpose::memory::{Path, Plan};
use linpose::normalize::{NormalizeParams, Normalized, StageChoice, StageRule};
use linpose::{AnyModel, PoseModel, TrainSelection};
use serde::Serialize;
use std::path::PathBuf;
use std::time::Instant;

/// Arguments of `linpose train`.
#[derive(clap::Args, Debug)]
pub struct TrainArgs {
    #[command(flatten)]
    pub data: DataArgs,
    /// Train on samples whose every parameter is a multiple of S degrees from its smallest value
    /// (the paper: 9; COIL: 10). Default: every sample.
    #[arg(long, value_name = "S", conflicts_with = "train_list", allow_negative_numbers = true)]
    pub train_step: Option<f64>,
    /// Train on the images listed in FILE (one path per line, as in poses.csv).
    #[arg(long, value_name = "FILE")]
    pub train_list: Option<PathBuf>,
    /// Estimation method.
    #[arg(long, default_value = "linear", value_parser = method_args::method_names())]
    pub method: String,
    #[command(flatten)]
    pub settings: MethodArgs,
    /// Read the images from disk in blocks instead of all at once, with a method that can (an
    /// error names them; docs/cli.md says how each does it). Without it, train streams by itself
    /// when the set does not fit in memory but streamed does (see --memory-budget). Says how it
    /// fitted.
    #[arg(long)]
    pub stream: bool,
    /// Decode every image into memory and fit there, even with more images than features, where
    /// train would take the streamed least-squares path by itself (the same model with a
    /// ridge); checked against the memory all the same.
    #[arg(long, conflicts_with = "stream")]
    pub in_memory: bool,
    /// The memory training may use, e.g. 512M, 8G, 1.5GiB (K, M, G, T: powers of 1024), instead
    /// of 90% of what the machine has available. Before reading the images, train estimates
    /// what fitting in memory and streaming need, takes the path that fits (saying which and
    /// why), and refuses, naming the numbers and what would help, when none does.
    #[arg(long, value_name = "SIZE", value_parser = memory_plan::parse_budget)]
    pub memory_budget: Option<u64>,
    /// How colour images become features.
    #[arg(long, value_enum, default_value = "gray")]
    pub color: ColorArg,
    /// The normalisation stage: find the object in every image, centre it, scale it to a fixed
    /// size and bring it to a fixed brightness before the method sees it (stored in the model,
    /// applied to queries too). Without this flag train chooses it on held-out training views
    /// among off, brightness, geometry and all, and says what it chose; `--normalize WHAT`
    /// forces one (`all` when the flag is given alone; `auto`: the choice).
    #[arg(long, value_enum, value_name = "WHAT", num_args = 0..=1, default_missing_value = "all", conflicts_with = "no_normalize")]
    pub normalize: Option<NormalizeArg>,
    /// Use the images as they are: no normalisation stage (as `--normalize off`).
    #[arg(long)]
    pub no_normalize: bool,
    /// With a data set of many objects: how a query's object is told, `universal` (Murase &
    /// Nayar's universal eigenspace, the nearest object manifold) or `linear` (the paper's
    /// linear model with one-hot object targets). Default: universal.
    #[arg(long, value_name = "NAME", value_parser = ["universal", "linear"])]
    pub recognizer: Option<String>,
    /// With many objects: dimensions of the universal eigenspace (default 20), and at most those
    /// of each object's own eigenspace (the second stage of `--unknown calibrated`).
    #[arg(long, value_name = "L")]
    pub recognizer_components: Option<usize>,
    /// With many objects: when a query is none of them: `calibrated` (the default: beyond the
    /// largest distance of the nearest object's held-out training views, in the recogniser's
    /// space and then in the object's own eigenspace), `off`, or a distance (the recogniser's,
    /// without the second stage).
    #[arg(long, value_name = "RULE")]
    pub unknown: Option<String>,
    /// With many objects: leave these objects (comma-separated names) out of training, e.g. to
    /// measure how their views are reported unknown.
    #[arg(long, value_name = "NAMES", value_delimiter = ',')]
    pub leave_out: Vec<String>,
    /// The model file to write (safetensors).
    #[arg(long, value_name = "MODEL", required_unless_present = "shard", conflicts_with = "shard")]
    pub out: Option<PathBuf>,
    /// Sum only shard I of N of the training statistics (a run of images, or with fewer images
    /// than pixels a run of pixels of every image) into the file --partial names, for
    /// `linpose merge` to add up with the other shards' into the model: training split across
    /// processes or machines. The linear model and the eigenspace.
    #[arg(long, value_name = "I/N", requires = "partial")]
    pub shard: Option<crate::cmd::shard::ShardArg>,
    /// The partial statistics file --shard writes (safetensors).
    #[arg(long, value_name = "FILE", requires = "shard")]
    pub partial: Option<PathBuf>,
    /// Also write a JSON summary (fit_s, n_train, model_bytes, ...).
    #[arg(long, value_name = "FILE")]
    pub json: Option<PathBuf>,
}

impl TrainArgs {
    /// The training views `--train-step` or `--train-list` pick (every view when neither).
    pub fn selection(&self) -> anyhow::Result<TrainSelection> {
        Ok(match (&self.train_step, &self.train_list) {
            (Some(s), _) => TrainSelection::Step(*s),
            (None, Some(list)) => TrainSelection::read_list(list)?,
            (None, None) => TrainSelection::All,
        })
    }
}

/// What `--normalize` normalises.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub enum NormalizeArg {
    /// Chosen on held-out training views (what train does without the flag).
    Auto,
    /// Position, scale and brightness.
    All,
    /// Position and scale.
    Geometry,
    /// Brightness.
    Brightness,
    /// Nothing: the images as they are.
    Off,
}

impl TrainArgs {
    /// What the normalisation flags ask for: chosen on held-out views unless fixed.
    pub fn stage_rule(&self) -> StageRule {
        let fixed = |geometry, brightness| StageRule::Fixed(NormalizeParams { geometry, brightness });
        match (self.no_normalize, self.normalize) {
            (true, _) | (_, Some(NormalizeArg::Off)) => StageRule::Fixed(NormalizeParams::OFF),
            (_, None | Some(NormalizeArg::Auto)) => StageRule::Auto,
            (_, Some(NormalizeArg::All)) => fixed(true, true),
            (_, Some(NormalizeArg::Geometry)) => fixed(true, false),
            (_, Some(NormalizeArg::Brightness)) => fixed(false, true),
        }
    }

    /// Whether the flags force a stage (not off, not chosen).
    pub fn forces_stage(&self) -> bool {
        matches!(self.stage_rule(), StageRule::Fixed(p) if p.is_on())
    }
}

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
    settings: serde_json::Value,
    #[serde(skip_serializing_if = "Option::is_none")]
    normalize: Option<linpose::normalize::Normalizer>,
    /// How the normalisation was decided.
    #[serde(skip_serializing_if = "Option::is_none")]
    stage_choice: Option<StageChoice>,
    /// The memory plan: the path taken and what it needed.
    memory: MemorySummary,
}

/// No normalisation stage.
const OFF: StageRule = StageRule::Fixed(NormalizeParams::OFF);

/// Runs `linpose train`.
pub fn run(a: &TrainArgs) -> anyhow::Result<()> {
    let out = match (&a.out, a.shard, &a.partial) {
        (_, Some(shard), Some(partial)) => return crate::cmd::shard::train_shard(a, shard, partial),
        (Some(out), _, _) => out,
        _ => anyhow::bail!("--out MODEL is required (or --shard I/N with --partial FILE)"),
    };
    check_output_file(out, "model")?;
    if let Some(j) = &a.json {
        check_output_file(j, "JSON")?;
    }
    let method = method_args::method(&a.method);
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
        StageRule::Auto => match memory_plan::plan_one(a, &manifest, method, OFF)? {
            p if p.path == Path::Streamed => (p, Some("streamed from disk: the stage is fitted in memory only")),
            p => match memory_plan::plan_one(a, &manifest, method, rule) {
                Ok(q) if q.path != Path::Streamed => (q, None),
                _ => (p, Some("the training set is too large to choose its normalisation in memory")),
            },
        },
        StageRule::Fixed(_) => (memory_plan::plan_one(a, &manifest, method, rule)?, None),
    };
    memory_plan::say(&plan);
    let (model, load_s, fit_s, how) = if plan.path == Path::Streamed {
        let bar = crate::common::progress(manifest.len() as u64, "reading");
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
            Some(why) => linpose::stage_choice::fit_chosen(&spec, &train, StageChoice::off(why))?,
            None => linpose::stage_choice::fit(&spec, &train, rule)?,
        };
        (model, load_s, t1.elapsed().as_secs_f64(), None)
    };
    let file_bytes = linpose::model_file::save(&model, out).context("writing the model")?;
    report(a, out, &model, load_s, fit_s, file_bytes, how, &plan)
}

/// Says what was trained, and writes the JSON summary when asked.
#[allow(clippy::too_many_arguments)]
fn report(
    a: &TrainArgs,
    out: &std::path::Path,
    model: &AnyModel,
    load_s: f64,
    fit_s: f64,
    file_bytes: u64,
    how: Option<String>,
    plan: &Plan,
) -> anyhow::Result<()> {
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
