//! `linpose train`'s arguments, which the many-object, shard and memory-plan code read too.

use super::method::{self, MethodArgs};
use crate::common::{ColorArg, DataArgs};
use linpose::normalize::{NormalizeParams, StageRule};
use linpose::TrainSelection;
use std::path::PathBuf;

/// Arguments of `linpose train`.
#[derive(clap::Args, Debug)]
pub(crate) struct TrainArgs {
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
    #[arg(long, default_value = "linear", value_parser = method::method_names())]
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
    #[arg(long, value_name = "SIZE", value_parser = parse_budget)]
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
    /// The robust stage: a query the training views' eigenspace does not explain (a cluttered
    /// background, an occluder) has the pixels it cannot explain found and replaced by the
    /// robust reconstruction before the method sees it (stored in the model); a query it
    /// explains goes as it is. Gray views fitted in memory. With many objects, each object has
    /// its stage and the one whose fit explains the most pixels repairs the query.
    #[arg(long, conflicts_with = "stream")]
    pub robust: bool,
    /// With a data set of many objects: how a query's object is told (default: the first listed).
    #[arg(long, value_name = "NAME", value_parser = recognizer_names())]
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
    /// processes or machines. With a method that can (an error names them).
    #[arg(long, value_name = "I/N", requires = "partial")]
    pub shard: Option<ShardArg>,
    /// The partial statistics file --shard writes (safetensors).
    #[arg(long, value_name = "FILE", requires = "shard")]
    pub partial: Option<PathBuf>,
    /// Also write a JSON summary (fit_s, n_train, model_bytes, ...).
    #[arg(long, value_name = "FILE")]
    pub json: Option<PathBuf>,
}

impl TrainArgs {
    /// The training views `--train-step` or `--train-list` pick (every view when neither).
    pub(crate) fn selection(&self) -> anyhow::Result<TrainSelection> {
        Ok(match (&self.train_step, &self.train_list) {
            (Some(s), _) => TrainSelection::Step(*s),
            (None, Some(list)) => TrainSelection::read_list(list)?,
            (None, None) => TrainSelection::All,
        })
    }
}

/// What `--normalize` normalises.
#[derive(clap::ValueEnum, Clone, Copy, Debug, PartialEq, Eq)]
pub(crate) enum NormalizeArg {
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
    pub(crate) fn stage_rule(&self) -> StageRule {
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
    pub(crate) fn forces_stage(&self) -> bool {
        matches!(self.stage_rule(), StageRule::Fixed(p) if p.is_on())
    }
}

/// Which shard of how many: `I/N`, 1 <= I <= N.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) struct ShardArg {
    /// 0-based.
    pub index: usize,
    pub count: usize,
}

impl std::str::FromStr for ShardArg {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        let bad = || format!("'{s}': expected I/N, shard I of N, with 1 <= I <= N (e.g. 2/4)");
        let (i, n) = s.split_once('/').ok_or_else(bad)?;
        let (i, n): (usize, usize) = (i.trim().parse().map_err(|_| bad())?, n.trim().parse().map_err(|_| bad())?);
        if i == 0 || i > n {
            return Err(bad());
        }
        Ok(ShardArg { index: i - 1, count: n })
    }
}

/// `--memory-budget SIZE` as bytes, or clap's error naming the value.
pub(crate) fn parse_budget(text: &str) -> Result<u64, String> {
    linpose::memory::parse_size(text).map_err(|e| e.to_string())
}

/// The recognisers' names, from the library's registry, as clap's possible values, each with its
/// summary.
fn recognizer_names() -> clap::builder::PossibleValuesParser {
    clap::builder::PossibleValuesParser::new(linpose::recognize::RECOGNIZERS.iter().map(|r| clap::builder::PossibleValue::new(r.name).help(r.summary)))
}
