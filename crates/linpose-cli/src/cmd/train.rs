//! `linpose train`: fit a model on a data set and write the model file.

use crate::common::{check_output_file, load_dataset, write_json, ColorArg, DataArgs};
use anyhow::Context;
use linpose::{AnyModel, EigenspaceParams, Estimator, LinearParams, PoseModel, RefinedParams, RidgeRule, TrainSelection};
use serde::Serialize;
use std::path::PathBuf;
use std::time::Instant;

/// Estimation methods.
#[derive(clap::ValueEnum, Debug, Clone, Copy, PartialEq, Eq)]
pub enum Method {
    /// Okatani & Deguchi's linear model: minimum-norm exact fit through the Gram matrix.
    Linear,
    /// Murase & Nayar's parametric eigenspace: PCA, spline manifold, nearest neighbour.
    Eigenspace,
    /// Beyond the paper: the eigenspace searched continuously on its spline manifold
    /// (Levenberg-Marquardt from the closest coarse points; with one pose parameter, every lattice pose
    /// exactly), with noisy queries detected and matched apart; L and the images' binning chosen
    /// from held-out training views.
    Refined,
}

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
    #[arg(long, value_enum, default_value = "linear")]
    pub method: Method,
    /// Linear: ridge lambda added to the Gram matrix (0 = the paper's exact minimum-norm fit), or
    /// `auto` for the lambda with the smallest exact leave-one-out error.
    #[arg(long, value_name = "L|auto", default_value = "0", allow_negative_numbers = true)]
    pub ridge: String,
    /// Linear: train for query noise of +-A (fraction of full brightness): ridge lambda = N A^2/3,
    /// the optimum for independent pixel noise; `auto` estimates the noise of the training images.
    #[arg(long, value_name = "A|auto", conflicts_with = "ridge", allow_negative_numbers = true)]
    pub noise_level: Option<String>,
    /// Subtract the mean image and pose first (an intercept; the paper has none).
    #[arg(long)]
    pub center: bool,
    /// Eigenspace: number of eigenimages L (capped at N - 1).
    #[arg(long, value_name = "L", default_value_t = 20, conflicts_with = "energy")]
    pub components: usize,
    /// Eigenspace: instead of --components, keep the fewest eigenimages holding this fraction
    /// of the energy (e.g. 0.95).
    #[arg(long, value_name = "T")]
    pub energy: Option<f64>,
    /// Eigenspace: resample the appearance manifold every D degrees along each pose axis.
    #[arg(long, value_name = "D", default_value_t = 0.5, allow_negative_numbers = true)]
    pub manifold_step: f64,
    /// Refined: number of eigenimages L (default: chosen from held-out training views).
    #[arg(long, value_name = "L")]
    pub refined_components: Option<usize>,
    /// Refined: report poses on a lattice of D degrees (default 0.5, the eigenspace's manifold
    /// step; 0 = the continuous estimate).
    #[arg(long, value_name = "D")]
    pub resolution: Option<f64>,
    /// Refined: bin the images by B (each pixel the mean of a B x B block) before fitting and
    /// before each query (1 keeps them as given), or `auto` (the default) to choose B among 1,
    /// 2 and 4 by the held-out error of the training views: the coarsest within one standard
    /// error of the least.
    #[arg(long, value_name = "B|auto")]
    pub bin: Option<String>,
    /// Refined: how the manifold passes between the training views: `spline` (the C2 cubic
    /// spline, the eigenspace's), `local` (each knot's slope from its two neighbours alone,
    /// Catmull-Rom on uniform knots), or `auto` (the default) to choose by the held-out error
    /// of the training views, with L.
    #[arg(long, value_name = "spline|local|auto")]
    pub interpolant: Option<String>,
    /// Linear model: read the images from disk in blocks instead of all at once, for training
    /// sets larger than memory. With N <= M images this is the usual minimum-norm fit; with
    /// N > M it is least squares / ridge through X^T X (M x M), which needs --ridge when some
    /// pixels never vary. Says which path it took.
    #[arg(long, conflicts_with = "center")]
    pub stream: bool,
    /// How colour images become features.
    #[arg(long, value_enum, default_value = "gray")]
    pub color: ColorArg,
    /// The model file to write (safetensors).
    #[arg(long, value_name = "MODEL")]
    pub out: PathBuf,
    /// Also write a JSON summary (fit_s, n_train, model_bytes, ...).
    #[arg(long, value_name = "FILE")]
    pub json: Option<PathBuf>,
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
}

/// The linear model's parameters from the arguments.
fn linear_params(a: &TrainArgs) -> anyhow::Result<LinearParams> {
    let p = LinearParams::default().center(a.center);
    let number = |flag: &str, v: &str| v.parse::<f64>().map_err(|_| anyhow::anyhow!("{flag} {v}: expected a number or 'auto'"));
    Ok(match (a.noise_level.as_deref(), a.ridge.as_str()) {
        (Some("auto"), _) => p.ridge_rule(RidgeRule::NoiseAuto),
        (Some(v), _) => p.ridge_rule(RidgeRule::Noise(number("--noise-level", v)?)),
        (None, "auto") => p.ridge_rule(RidgeRule::Loo),
        (None, v) => p.ridge(number("--ridge", v)?),
    })
}

/// Runs `linpose train`.
pub fn run(a: &TrainArgs) -> anyhow::Result<()> {
    check_output_file(&a.out, "model")?;
    if let Some(j) = &a.json {
        check_output_file(j, "JSON")?;
    }
    let t0 = Instant::now();
    let manifest = a.data.manifest()?;
    let selection = match (&a.train_step, &a.train_list) {
        (Some(s), _) => TrainSelection::Step(*s),
        (None, Some(list)) => TrainSelection::read_list(list)?,
        (None, None) => TrainSelection::All,
    };
    let mask = manifest.training_mask(&selection)?;
    if a.stream {
        return run_streaming(a, manifest.subset(&mask)?, t0);
    }
    let train = load_dataset(manifest.subset(&mask)?, a.color.into())?;
    let load_s = t0.elapsed().as_secs_f64();
    let t1 = Instant::now();
    let model: AnyModel = match a.method {
        Method::Linear => linear_params(a)?.fit(&train)?.into(),
        Method::Eigenspace => {
            let mut p = EigenspaceParams::default().manifold_step(a.manifold_step).components(a.components);
            if let Some(t) = a.energy {
                p = p.energy(t);
            }
            p.fit(&train)?.into()
        }
        Method::Refined => {
            let mut p = RefinedParams::default();
            if let Some(l) = a.refined_components {
                p = p.components(l);
            }
            if let Some(r) = a.resolution {
                p = p.resolution(r);
            }
            match a.bin.as_deref() {
                None => {}
                Some("auto") => p = p.auto_bin(),
                Some(v) => p = p.bin(v.parse().map_err(|_| anyhow::anyhow!("--bin {v}: expected a whole number or 'auto'"))?),
            }
            match a.interpolant.as_deref() {
                None | Some("auto") => p = p.auto_interpolant(),
                Some(v) => p = p.interpolant(v.parse().map_err(|_| anyhow::anyhow!("--interpolant {v}: expected 'spline', 'local' or 'auto'"))?),
            }
            p.fit(&train)?.into()
        }
    };
    let fit_s = t1.elapsed().as_secs_f64();
    let file_bytes = linpose::model_file::save(&model, &a.out).context("writing the model")?;
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
    };
    eprintln!(
        "trained {} on {} images of {}x{} in {:.3} s (decoding {:.3} s); model {} bytes -> {}",
        summary.method,
        summary.n_train,
        meta.spec.width,
        meta.spec.height,
        fit_s,
        load_s,
        summary.model_bytes,
        a.out.display()
    );
    if let Some(j) = &a.json {
        write_json(j, &summary)?;
    }
    Ok(())
}

/// `linpose train --stream`: the linear model, images read in blocks (linpose::stream).
fn run_streaming(a: &TrainArgs, manifest: linpose::Manifest, t0: Instant) -> anyhow::Result<()> {
    if a.method != Method::Linear {
        anyhow::bail!("--stream trains the linear model only");
    }
    let n = manifest.len();
    let bar = crate::common::progress(n as u64, "reading");
    if a.noise_level.is_some() || a.ridge == "auto" {
        anyhow::bail!("--stream takes a numeric --ridge (0 for the exact fit); --ridge auto and --noise-level need the training set in memory");
    }
    let params = linear_params(a)?;
    let (model, stats) = linpose::methods::linear::stream::fit_linear(&manifest, a.color.into(), &params, &|k| bar.inc(k))?;
    bar.finish_and_clear();
    let fit_s = t0.elapsed().as_secs_f64();
    let model: AnyModel = model.into();
    let file_bytes = linpose::model_file::save(&model, &a.out).context("writing the model")?;
    let meta = model.meta();
    eprintln!(
        "trained linear (streamed; {}) on {n} images of {}x{} in {fit_s:.3} s (reading included); model {} bytes -> {}",
        stats.path,
        meta.spec.width,
        meta.spec.height,
        model.model_bytes(),
        a.out.display()
    );
    match stats.path {
        linpose::methods::linear::stream::SolverPath::LeastSquares => eprintln!(
            "  reading {:.3} s (overlapped; waited {:.3} s), accumulating X^T X and X^T P {:.3} s ({:.1} GFLOP/s{}), solving {:.3} s",
            stats.read_s,
            stats.wait_s,
            stats.accumulate_s,
            stats.accumulate_flops() / 1e9,
            if stats.integer_8bit { ", 8-bit integer arithmetic" } else { ", f64" },
            stats.solve_s
        ),
        linpose::methods::linear::stream::SolverPath::Gram => eprintln!("  reading {:.3} s, Gram matrix and solve {:.3} s", stats.read_s, stats.solve_s),
    }
    if let Some(j) = &a.json {
        let summary = TrainSummary {
            method: meta.method.clone(),
            data: a.data.data.display().to_string(),
            n_train: meta.n_train(),
            n_features: meta.spec.features(),
            load_s: 0.0,
            fit_s,
            model_bytes: model.model_bytes(),
            file_bytes,
            settings: meta.settings.clone(),
        };
        write_json(j, &summary)?;
    }
    Ok(())
}
