//! The `linpose` command: thin subcommands over the linpose library.

use clap::{Parser, Subcommand};
use std::process::ExitCode;

mod cmd;
mod common;

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
    Train(cmd::train::TrainArgs),
    /// Estimate the pose of images with a trained model.
    Predict(cmd::predict::PredictArgs),
    /// Estimate every sample of a data set and report the errors.
    Eval(cmd::eval::EvalArgs),
}

fn run(cli: Cli) -> anyhow::Result<()> {
    match cli.command {
        Command::Train(a) => cmd::train::run(&a),
        Command::Predict(a) => cmd::predict::run(&a),
        Command::Eval(a) => cmd::eval::run(&a),
    }
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
            eprintln!("linpose: error: {e:#}");
            ExitCode::FAILURE
        }
    }
}
