//! `linpose eval`'s arguments.

use crate::common::DataArgs;
use std::path::PathBuf;

/// Arguments of `linpose eval`.
#[derive(clap::Args, Debug)]
pub(crate) struct EvalArgs {
    /// The model file.
    #[arg(long, value_name = "MODEL")]
    pub model: PathBuf,
    #[command(flatten)]
    pub data: DataArgs,
    /// Add uniform noise of +-A of full brightness to every query pixel (0.05 = +-5%).
    #[arg(long, value_name = "A", default_value_t = 0.0, allow_negative_numbers = true)]
    pub noise: f64,
    /// Seed of the noise.
    #[arg(long, value_name = "S", default_value_t = 0)]
    pub seed: u64,
    /// Write the full report (summary and every sample) as JSON.
    #[arg(long, value_name = "FILE")]
    pub json: Option<PathBuf>,
    /// Hypotheses kept per sample (in the JSON), and counted for "truth among the top K".
    #[arg(long, value_name = "K", default_value_t = 3, value_parser = clap::value_parser!(u64).range(1..=8))]
    pub top: u64,
    /// The confidence under which an estimate is flagged.
    #[arg(long, value_name = "C", default_value_t = linpose::confidence::FLAG_BELOW)]
    pub flag_below: f64,
    /// With a many-object model: when a query is none of its objects, replacing the model's
    /// rule: `calibrated` (beyond the largest distance of the nearest object's held-out
    /// training views, in the recogniser's space and then in the object's own eigenspace), `off`
    /// (never), or a distance (the recogniser's, without the second stage).
    #[arg(long, value_name = "RULE")]
    pub unknown: Option<String>,
}
