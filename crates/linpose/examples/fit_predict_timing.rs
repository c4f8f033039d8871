//! Times one method's fit and predict through the library on one data set, in one process, as
//! `bench/python_vs_rust.py` times the same work from Python: the fit from the training views'
//! 8-bit pixels in memory (decoded first, not timed; [`Dataset::from_u8`] then the fit), the
//! predict of every view as 8-bit images in one batch, and the predict of one image (each
//! followed by an untimed one half the set away, as the Python side alternates its calls). Each
//! measurement is repeated for at least REPS times and 0.3 s; medians. Prints one JSON object.
//!
//! With `--serve` it times one block of calls per request instead, so that other processes can
//! alternate their blocks with these (all then see the same stretches of a shared machine's
//! load): each line read from stdin, `fit SECONDS`, `predict SECONDS` (calls repeated for that
//! long, at least one) or `one FIRST COUNT` (views FIRST.., each followed by the untimed one
//! half the set away), is answered by a line with the block's median seconds. It says `ready`
//! once loaded and fitted; end of input ends it.
//!
//!     cargo run --release -p linpose --example fit_predict_timing -- DIR [--object O]
//!         --train-step S --method NAME [--reps R] [--serve]
use linpose::image_io::ColorMode;
use linpose::{Dataset, Manifest, PoseModel, Settings, TrainSelection};
use std::io::{BufRead, Write};
use std::path::PathBuf;
use std::time::Instant;

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let (mut dir, mut object, mut step, mut method, mut reps, mut serve) = (None, None, None, String::from("linear"), 5usize, false);
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        match a.as_str() {
            "--object" => object = Some(args.next().ok_or("--object O")?.parse()?),
            "--train-step" => step = Some(args.next().ok_or("--train-step S")?.parse::<f64>()?),
            "--method" => method = args.next().ok_or("--method NAME")?,
            "--reps" => reps = args.next().ok_or("--reps R")?.parse()?,
            "--serve" => serve = true,
            _ => dir = Some(PathBuf::from(a)),
        }
    }
    let usage = "usage: fit_predict_timing DIR [--object O] --train-step S --method NAME [--reps R] [--serve]";
    let (dir, step) = (dir.ok_or(usage)?, step.ok_or(usage)?);
    let manifest = Manifest::open(&dir, object)?;
    let mask = manifest.training_mask(&TrainSelection::Step(step))?;
    let data = Dataset::load(manifest, ColorMode::Gray, &|_| {})?;
    let train = data.subset(&mask)?;
    let spec = linpose::methods::find(&method).ok_or("unknown method")?.spec(&Settings::new())?;
    let pixels: Vec<u8> = data.features().iter().map(|&v| (v * 255.0).round() as u8).collect();
    let train_pixels: Vec<u8> = train.features().iter().map(|&v| (v * 255.0).round() as u8).collect();
    let (m, k) = (data.n_features(), data.space().len());
    let mut out = vec![0.0; data.len() * k];
    let (mut fit, mut predict, mut one) = (vec![], vec![], vec![]);
    let fit_once = || Dataset::from_u8(train.spec(), &train_pixels, train.space().clone(), train.poses().to_vec()).and_then(|d| spec.fit(&d));
    let mut model = fit_once()?;
    let mut o1 = vec![0.0; k];
    let view = |i: usize| &pixels[(i % data.len()) * m..(i % data.len() + 1) * m];
    if serve {
        let mut stdout = std::io::stdout().lock();
        writeln!(stdout, "ready")?;
        stdout.flush()?;
        for line in std::io::stdin().lock().lines() {
            let line = line?;
            let words: Vec<&str> = line.split_whitespace().collect();
            let block = |secs: &str| secs.parse::<f64>().map_err(|e| format!("{line:?}: {e}"));
            let mut times = vec![];
            match words[..] {
                ["fit", secs] => {
                    let (secs, start) = (block(secs)?, Instant::now());
                    while times.is_empty() || start.elapsed().as_secs_f64() < secs {
                        let t = Instant::now();
                        model = fit_once()?;
                        times.push(t.elapsed().as_secs_f64());
                    }
                }
                ["predict", secs] => {
                    let (secs, start) = (block(secs)?, Instant::now());
                    while times.is_empty() || start.elapsed().as_secs_f64() < secs {
                        let t = Instant::now();
                        model.predict_u8_into(&pixels, &mut out)?;
                        times.push(t.elapsed().as_secs_f64());
                    }
                }
                ["one", first, count] => {
                    let (first, count): (usize, usize) = (first.parse()?, count.parse()?);
                    for i in first..first + count.max(1) {
                        let t = Instant::now();
                        model.predict_u8_into(view(i), &mut o1)?;
                        times.push(t.elapsed().as_secs_f64());
                        model.predict_u8_into(view(i + data.len() / 2), &mut o1)?;
                    }
                }
                _ => return Err(format!("unknown request {line:?}: fit SECONDS, predict SECONDS or one FIRST COUNT").into()),
            }
            writeln!(stdout, "{}", median(times))?;
            stdout.flush()?;
        }
        return Ok(());
    }
    let start = Instant::now();
    while fit.len() < reps || start.elapsed().as_secs_f64() < 0.3 {
        let t = Instant::now();
        model = fit_once()?;
        fit.push(t.elapsed().as_secs_f64());
    }
    let start = Instant::now();
    while predict.len() < reps || start.elapsed().as_secs_f64() < 0.3 {
        let t = Instant::now();
        model.predict_u8_into(&pixels, &mut out)?;
        predict.push(t.elapsed().as_secs_f64());
    }
    // In the order `bench/python_vs_rust.py` predicts them: view i timed, then the view half the
    // set away (there, the core call alternated with the estimator), so that no timed query
    // follows its neighbour, whose part of the tables would still be in the cache.
    for i in 0..2000 {
        let t = Instant::now();
        model.predict_u8_into(view(i), &mut o1)?;
        one.push(t.elapsed().as_secs_f64());
        model.predict_u8_into(view(i + data.len() / 2), &mut o1)?;
    }
    println!(
        "{{\"method\":\"{method}\",\"n_train\":{},\"n_eval\":{},\"fit_s\":{},\"predict_s\":{},\"predict_one_s\":{}}}",
        train.len(),
        data.len(),
        median(fit),
        median(predict),
        median(one)
    );
    Ok(())
}
