//! `linpose eval`: estimate every sample of a data set and report the errors.

use crate::args::EvalArgs;
use crate::common::{check_output_file, load_dataset, write_json};
use crate::queries::print_refused;
use linpose::render::ViewJitter;
use linpose::{ErrorSummary, PoseModel};
use serde::Serialize;
use std::collections::{HashMap, HashSet};

/// Runs `linpose eval`.
pub(crate) fn run(a: &EvalArgs) -> anyhow::Result<()> {
    if let Some(j) = &a.json {
        check_output_file(j, "JSON")?;
    }
    if !(a.noise.is_finite() && (0.0..=1.0).contains(&a.noise)) {
        anyhow::bail!("--noise {} is outside [0, 1]: it is a fraction of full brightness (0.05 = +-5%)", a.noise);
    }
    if linpose::model_file::holds_objects(&a.model)? {
        return crate::cmd::objects::eval(a);
    }
    if a.unknown.is_some() {
        anyhow::bail!("--unknown: {} holds one object's pose model; the option is for a many-object model", a.model.display());
    }
    let model = linpose::AnyModel::load(&a.model)?;
    if let linpose::Source::Many(c) = linpose::Source::open(&a.data.data, a.data.object)? {
        anyhow::bail!(
            "{}: the data set holds {} objects ({}), but {} holds one object's pose model; train a many-object model on it, or give one object's data",
            a.data.data.display(),
            c.len(),
            c.names().join(", "),
            a.model.display()
        );
    }
    let manifest = a.data.manifest()?;
    let (data, unreadable) = load_readable(manifest, model.meta().spec)?;
    if !(a.flag_below.is_finite() && (0.0..=1.0).contains(&a.flag_below)) {
        anyhow::bail!("--flag-below {} is outside [0, 1]: it is a confidence", a.flag_below);
    }
    let opt = linpose::EvalOptions { top: a.top as usize, flag_below: a.flag_below, ..linpose::EvalOptions::new(a.noise, a.seed) };
    let mut r = linpose::evaluate(&model, &data, &opt)?;
    r.rejected.extend(unreadable);
    println!("{} model, {} training views; {} samples evaluated, noise +-{}", r.method, r.n_train, r.n_eval, r.noise);
    print_refused(r.rejected.len(), r.rejected.iter().map(|x| format!("{}: {}", x.image, x.reason)));
    println!("{:<8} {:>6} {:>10} {:>10} {:>10} {:>10}", "", "n", "mean", "median", "p90", "max");
    let line =
        |name: &str, s: &ErrorSummary| println!("{name:<8} {:>6} {:>10.4} {:>10.4} {:>10.4} {:>10.4}", s.n, s.mean_deg, s.median_deg, s.p90_deg, s.max_deg);
    line("all", &r.all);
    match &r.unseen {
        Some(u) => line("unseen", u),
        None => println!("unseen   (every sample is a training view)"),
    }
    // With three or more parameters the error above is over the camera's placement (the rotation
    // angle with a roll); each parameter's own difference follows, a light's among them.
    if r.params.len() >= 3 {
        let (over, per) = match &r.param_unseen {
            Some(u) => ("unseen", u),
            None => ("all", &r.param_all),
        };
        for (name, s) in r.params.iter().zip(per) {
            line(&format!("{over} {name}"), s);
        }
    }
    println!("errors in degrees; model {} bytes; estimation {:.4} s", r.model_bytes, r.predict_s);
    if let Some(c) = &r.confidence {
        println!(
            "confidence ({} views): {:.1}% flagged (under {}); {:.1}% gross errors (over {} degrees), {:.1}% of them flagged; truth among the top {}: {:.1}%",
            c.over,
            100.0 * c.flagged_share,
            r.flag_below,
            100.0 * c.gross_share,
            linpose::confidence::GROSS_DEG,
            100.0 * c.gross_flagged_share,
            r.top,
            100.0 * c.in_top_share
        );
        println!("{:<14} {:>6} {:>12} {:>8}", "confidence", "n", "mean error", "gross");
        for b in &c.reliability {
            let close = if b.hi >= 1.0 { ']' } else { ')' };
            println!("[{:.2}, {:.2}{close}   {:>6} {:>12.4} {:>7.1}%", b.lo, b.hi, b.n, b.mean_error_deg, 100.0 * b.gross_share);
        }
    }
    let by_jitter = jitter_table(&a.data.data, &r)?;
    if let Some(j) = &a.json {
        write_json(j, &Report { report: &r, by_jitter })?;
    }
    crate::queries::refusals(r.rejected.len(), r.rejected.len() + r.n_eval)
}

/// The eval JSON: the library's report, and the error against the jitter when the data set has it.
#[derive(Serialize)]
struct Report<'a> {
    #[serde(flatten)]
    report: &'a linpose::EvalReport,
    #[serde(skip_serializing_if = "Vec::is_empty")]
    by_jitter: Vec<JitterBin>,
}

/// The views whose jitter along one axis fell in [lo, hi).
#[derive(Serialize)]
struct JitterBin {
    /// "shift" (pixels from the registered position), "scale" or "exposure" (|factor - 1|).
    axis: &'static str,
    lo: f64,
    hi: f64,
    /// Unseen views estimated in the bin, and their mean error (degrees; null when none).
    n: usize,
    mean_error_deg: Option<f64>,
    /// Views in the bin the model's normalisation refused.
    refused: usize,
}

/// How much of one kind of jitter a view has.
type Amount = fn(&ViewJitter) -> f64;

/// Bins per jitter axis.
const JITTER_BINS: usize = 4;

/// When the data set has a `jitter.csv` (`synth --jitter`), prints the unseen views' mean error
/// against the amount of shift, scale and exposure, and returns the table.
fn jitter_table(dir: &std::path::Path, r: &linpose::EvalReport) -> anyhow::Result<Vec<JitterBin>> {
    let path = dir.join("jitter.csv");
    if !path.is_file() {
        return Ok(Vec::new());
    }
    let jitter: HashMap<String, ViewJitter> = linpose::render::jitter::read_csv(&path)?.into_iter().collect();
    let refused: HashSet<&str> = r.rejected.iter().map(|x| x.image.as_str()).collect();
    let axes: [(&'static str, Amount); 3] = [("shift", |v| v.dx.hypot(v.dy)), ("scale", |v| (v.scale - 1.0).abs()), ("exposure", |v| (v.exposure - 1.0).abs())];
    let mut table = Vec::new();
    for (axis, amount) in axes {
        let top = jitter.values().map(amount).fold(0.0, f64::max);
        if top == 0.0 {
            continue;
        }
        let bin = |x: f64| ((x / top * JITTER_BINS as f64) as usize).min(JITTER_BINS - 1);
        let mut rows: Vec<JitterBin> = (0..JITTER_BINS)
            .map(|b| JitterBin {
                axis,
                lo: top * b as f64 / JITTER_BINS as f64,
                hi: top * (b + 1) as f64 / JITTER_BINS as f64,
                n: 0,
                mean_error_deg: None,
                refused: 0,
            })
            .collect();
        let mut sums = [0.0; JITTER_BINS];
        for s in r.samples.iter().filter(|s| !s.seen) {
            if let Some(v) = jitter.get(&s.image) {
                let b = bin(amount(v));
                rows[b].n += 1;
                sums[b] += s.error_deg;
            }
        }
        for (name, v) in &jitter {
            if refused.contains(name.as_str()) {
                rows[bin(amount(v))].refused += 1;
            }
        }
        for (row, sum) in rows.iter_mut().zip(sums) {
            row.mean_error_deg = (row.n > 0).then(|| sum / row.n as f64);
        }
        table.extend(rows);
    }
    println!("unseen error against the jitter ({}):", path.display());
    println!("{:<9} {:>16} {:>6} {:>10} {:>8}", "jitter", "amount", "n", "mean", "refused");
    for b in &table {
        let unit = if b.axis == "shift" { " px" } else { "" };
        let mean = b.mean_error_deg.map_or("-".to_string(), |m| format!("{m:.4}"));
        println!("{:<9} {:>16} {:>6} {:>10} {:>8}", b.axis, format!("{:.3}-{:.3}{unit}", b.lo, b.hi), b.n, mean, b.refused);
    }
    Ok(table)
}

/// The data set's images that can be read at the model's size `spec`, and each other one with
/// why (unreadable, damaged, another size), counted apart as eval counts images the model
/// refuses. Every image is checked only when the whole set does not load.
fn load_readable(manifest: linpose::Manifest, spec: linpose::image_io::ImageSpec) -> anyhow::Result<(linpose::Dataset, Vec<linpose::eval::Rejected>)> {
    let whole = manifest.clone();
    let e = match load_dataset(manifest, spec.color) {
        Ok(d) => return Ok((d, Vec::new())),
        Err(e) => e,
    };
    let why = crate::queries::unreadable(&whole, spec);
    if why.iter().all(Option::is_none) {
        return Err(e);
    }
    let mask: Vec<bool> = why.iter().map(Option::is_none).collect();
    if !mask.iter().any(|&k| k) {
        anyhow::bail!("{}: none of the data set's {} images can be read, the first: {}", whole.root().display(), whole.len(), why[0].as_deref().unwrap_or(""));
    }
    let data = load_dataset(whole.subset(&mask)?, spec.color)?;
    let rejected =
        why.into_iter().enumerate().filter_map(|(i, w)| w.map(|reason| linpose::eval::Rejected { image: whole.images()[i].clone(), reason })).collect();
    Ok((data, rejected))
}
