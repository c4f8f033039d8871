//! The `linpose` command: thin subcommands over the linpose library.

#![warn(unreachable_pub)]

use clap::{Parser, Subcommand};
use std::process::ExitCode;

mod args;
mod cmd;
mod common;
mod plan;
mod queries;
mod report;
mod study;
mod tuning;

/// Pose estimation from appearance: Okatani & Deguchi's linear model and Murase & Nayar's
/// parametric eigenspace, with a turntable renderer to make data anywhere.
#[derive(Parser, Debug)]
#[command(name = "linpose", version, about, propagate_version = true)]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand, Debug)]
enum Command {
    /// Train a model on a data set and write it to a model file.
    Train(args::TrainArgs),
    /// Add up partial training statistics (train --shard I/N --partial FILE) into the model.
    Merge(cmd::shard::MergeArgs),
    /// Estimate the pose of images with a trained model.
    Predict(args::PredictArgs),
    /// Estimate every sample of a data set and report the errors.
    Eval(args::EvalArgs),
    /// Render a turntable data set of a built-in object or a mesh.
    Synth(cmd::synth::SynthArgs),
    /// Put a data set's views into scenes: a cluttered background, occluders.
    Scene(cmd::scene::SceneArgs),
    /// Run the paper's experiments and write a report (the main job).
    Experiment(cmd::experiment::ExperimentArgs),
}

fn run(cli: Cli) -> anyhow::Result<()> {
    match cli.command {
        Command::Train(a) => cmd::train::run(&a),
        Command::Merge(a) => cmd::shard::merge(&a),
        Command::Predict(a) => cmd::predict::run(&a),
        Command::Eval(a) => cmd::eval::run(&a),
        Command::Synth(a) => cmd::synth::run(&a),
        Command::Scene(a) => cmd::scene::run(&a),
        Command::Experiment(a) => cmd::experiment::run(&a),
    }
}

/// The error and its causes on one line, like anyhow's `{:#}`, but skipping a cause whose text
/// the message already holds (the library's errors name their source in their own text).
fn message(e: &anyhow::Error) -> String {
    let mut out = String::new();
    for cause in e.chain() {
        let text = cause.to_string();
        if out.contains(&text) {
            continue;
        }
        if !out.is_empty() {
            out.push_str(": ");
        }
        out.push_str(&text);
    }
    out
}

fn main() -> ExitCode {
    let cli = Cli::parse();
    match run(cli) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            // A closed pipe (`linpose predict ... | head`) is not an error.
            if e.chain().any(|c| c.downcast_ref::<std::io::Error>().is_some_and(|io| io.kind() == std::io::ErrorKind::BrokenPipe)) {
                return ExitCode::SUCCESS;
            }
            eprintln!("linpose: error: {}", message(&e));
            // Some images refused (each named), every other one estimated: its own status.
            if e.downcast_ref::<queries::SomeRefused>().is_some() {
                return ExitCode::from(queries::SomeRefused::EXIT_CODE);
            }
            ExitCode::FAILURE
        }
    }
}
