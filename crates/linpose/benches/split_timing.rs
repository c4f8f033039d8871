//! Times 8-bit predicts of small batches from the caller's own thread, for the threshold in
//! `crates/linpose/src/model/split.rs` (from how many query pixels a batch is split across
//! rayon's threads): every method fitted on one data set, then batches of each size (the data
//! set's images repeated as needed) predicted REPS times in a row; the median per batch size.
//! Prints one JSON object: `{"method": {"n": seconds, ...}, ...}`.
//!
//! `--whole` makes the calling thread the only thread of its own rayon pool first, so every
//! batch runs whole on it (no split, no pool round trip); without it the library decides, and
//! `LINPOSE_SPLIT_FROM_PIXELS=0` splits every batch as before the threshold.
//! `bench/split_timing.py` alternates the three in rounds.
//!
//! `--gap MS` makes the caller sleep MS milliseconds before each timed predict, as a caller
//! waiting for its next camera frame does: rayon's workers go to sleep in between, and a split
//! batch pays for waking them.
//!
//!     cargo bench -p linpose --bench split_timing -- DIR [--object O] --train-step S
//!         [--sizes 8,16,36,72,144,288] [--reps R] [--whole] [--gap MS]
use linpose::image_io::ColorMode;
use linpose::{Dataset, Manifest, PoseModel, Settings, TrainSelection};
use std::path::PathBuf;
use std::time::Instant;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let (mut dir, mut object, mut step, mut reps, mut whole, mut gap) = (None, None, None, 300usize, false, 0.0f64);
    let mut sizes = vec![8usize, 16, 36, 72, 144, 288];
    let mut args = std::env::args().skip(1).filter(|a| a != "--bench");
    while let Some(a) = args.next() {
        match a.as_str() {
            "--object" => object = Some(args.next().ok_or("--object O")?.parse()?),
            "--train-step" => step = Some(args.next().ok_or("--train-step S")?.parse::<f64>()?),
            "--sizes" => sizes = args.next().ok_or("--sizes A,B,...")?.split(',').map(str::parse).collect::<Result<_, _>>()?,
            "--reps" => reps = args.next().ok_or("--reps R")?.parse()?,
            "--whole" => whole = true,
            "--gap" => gap = args.next().ok_or("--gap MS")?.parse()?,
            _ => dir = Some(PathBuf::from(a)),
        }
    }
    let usage = "usage: split_timing DIR [--object O] --train-step S [--sizes A,B,...] [--reps R] [--whole] [--gap MS]";
    let gap = std::time::Duration::try_from_secs_f64(gap / 1e3).map_err(|_| "--gap MS: a number of milliseconds, 0 or more")?;
    let (dir, step) = (dir.ok_or(usage)?, step.ok_or(usage)?);
    // The calling thread as the one thread of a pool of its own: parallel iterators then run on it.
    let _pool = if whole { Some(rayon::ThreadPoolBuilder::new().num_threads(1).use_current_thread().build()?) } else { None };
    let manifest = Manifest::open(&dir, object)?;
    let mask = manifest.training_mask(&TrainSelection::Step(step))?;
    let data = Dataset::load(manifest, ColorMode::Gray, &|_| {})?;
    let train = data.subset(&mask)?;
    let pixels: Vec<u8> = data.features().iter().map(|&v| (v * 255.0).round() as u8).collect();
    let (m, k) = (data.n_features(), data.space().len());
    let mut json = Vec::new();
    for method in ["linear", "eigenspace", "refined"] {
        let model = linpose::Method::from_name(method)?.spec(&Settings::new())?.fit(&train)?;
        let mut row = Vec::new();
        for &n in &sizes {
            let batch: Vec<u8> = pixels.iter().copied().cycle().take(n * m).collect();
            let mut out = vec![0.0; n * k];
            model.predict_u8_into(&batch, &mut out)?;
            let mut ts: Vec<f64> = (0..reps)
                .map(|_| {
                    if !gap.is_zero() {
                        std::thread::sleep(gap);
                    }
                    let t = Instant::now();
                    model.predict_u8_into(&batch, &mut out).map(|_| t.elapsed().as_secs_f64())
                })
                .collect::<Result<_, _>>()?;
            ts.sort_by(f64::total_cmp);
            row.push(format!("\"{n}\":{}", ts[ts.len() / 2]));
        }
        json.push(format!("\"{method}\":{{{}}}", row.join(",")));
    }
    println!("{{{}}}", json.join(","));
    Ok(())
}
