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
//!     cargo bench -p linpose --bench fit_predict_timing -- DIR [--object O]
//!         --train-step S --method NAME [--reps R] [--serve]
use linpose::image_io::ColorMode;
use linpose::{Dataset, Manifest, PoseModel, Settings, TrainSelection};
use std::io::{BufRead, Write};
use std::path::PathBuf;
use std::time::Instant;

type Res<T> = Result<T, Box<dyn std::error::Error>>;

fn median(mut v: Vec<f64>) -> f64 {
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}

/// Seconds of each call of `f`, repeated for at least `reps` calls and `secs` seconds.
fn repeat(reps: usize, secs: f64, mut f: impl FnMut() -> Res<()>) -> Res<Vec<f64>> {
    let (mut times, start) = (vec![], Instant::now());
    while times.len() < reps || start.elapsed().as_secs_f64() < secs {
        let t = Instant::now();
        f()?;
        times.push(t.elapsed().as_secs_f64());
    }
    Ok(times)
}

/// Seconds of `predict` on each of views `first..first + count` (`view(i)`, of `n`), each
/// followed by an untimed one on the view half the set away, so that no timed query follows its
/// neighbour, whose part of the tables would still be in the cache (the order in which
/// `bench/python_vs_rust.py` predicts them too).
fn singles<'a>(first: usize, count: usize, n: usize, view: impl Fn(usize) -> &'a [u8], mut predict: impl FnMut(&[u8]) -> Res<()>) -> Res<Vec<f64>> {
    let mut times = vec![];
    for i in first..first + count {
        let t = Instant::now();
        predict(view(i))?;
        times.push(t.elapsed().as_secs_f64());
        predict(view(i + n / 2))?;
    }
    Ok(times)
}

fn main() -> Res<()> {
    let (mut dir, mut object, mut step, mut method, mut reps, mut serve) = (None, None, None, String::from("linear"), 5usize, false);
    let mut args = std::env::args().skip(1).filter(|a| a != "--bench");
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
    let spec = linpose::Method::from_name(&method)?.spec(&Settings::new())?;
    let pixels: Vec<u8> = data.features().iter().map(|&v| (v * 255.0).round() as u8).collect();
    let train_pixels: Vec<u8> = train.features().iter().map(|&v| (v * 255.0).round() as u8).collect();
    let (m, k) = (data.n_features(), data.space().len());
    let mut out = vec![0.0; data.len() * k];
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
            let times = match words[..] {
                ["fit", secs] => repeat(1, block(secs)?, || {
                    model = fit_once()?;
                    Ok(())
                })?,
                ["predict", secs] => repeat(1, block(secs)?, || Ok(model.predict_u8_into(&pixels, &mut out)?))?,
                ["one", first, count] => singles(first.parse()?, count.parse::<usize>()?.max(1), data.len(), view, |v| Ok(model.predict_u8_into(v, &mut o1)?))?,
                _ => return Err(format!("unknown request {line:?}: fit SECONDS, predict SECONDS or one FIRST COUNT").into()),
            };
            writeln!(stdout, "{}", median(times))?;
            stdout.flush()?;
        }
        return Ok(());
    }
    let fit = repeat(reps, 0.3, || {
        model = fit_once()?;
        Ok(())
    })?;
    let predict = repeat(reps, 0.3, || Ok(model.predict_u8_into(&pixels, &mut out)?))?;
    let one = singles(0, 2000, data.len(), view, |v| Ok(model.predict_u8_into(v, &mut o1)?))?;
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
