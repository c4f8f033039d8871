//! Times `predict` of saved models on one data set (optionally with noise), medians of REPS,
//! alternating the models so they see the same machine load.
//!
//!     cargo run --release -p linpose --example predict_timing -- DIR [--object O] [--noise A]
//!         [--reps R] MODEL...
use linpose::image_io::ColorMode;
use linpose::{Dataset, Manifest, PoseModel};
use std::path::PathBuf;
use std::time::Instant;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let (mut dir, mut object, mut noise, mut reps, mut models) = (None, None, 0.0, 5usize, vec![]);
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        match a.as_str() {
            "--object" => object = Some(args.next().ok_or("--object O")?.parse()?),
            "--noise" => noise = args.next().ok_or("--noise A")?.parse()?,
            "--reps" => reps = args.next().ok_or("--reps R")?.parse()?,
            _ if dir.is_none() => dir = Some(PathBuf::from(a)),
            _ => models.push(PathBuf::from(a)),
        }
    }
    let dir = dir.ok_or("usage: predict_timing DIR [--object O] [--noise A] [--reps R] MODEL...")?;
    let data = Dataset::load(Manifest::open(&dir, object)?, ColorMode::Gray, &|_| {})?;
    let mut queries = data.features().to_vec();
    linpose::eval::add_uniform_noise(&mut queries, data.n_features(), noise, 0)?;
    let loaded: Vec<_> = models.iter().map(|p| linpose::model_file::load(p)).collect::<Result<_, _>>()?;
    let mut times = vec![vec![]; loaded.len()];
    for _ in 0..reps {
        for (m, t) in loaded.iter().zip(&mut times) {
            let t0 = Instant::now();
            std::hint::black_box(m.predict(&queries)?);
            t.push(t0.elapsed().as_secs_f64() / data.len() as f64 * 1e6);
        }
    }
    let load = std::fs::read_to_string("/proc/loadavg").unwrap_or_default();
    println!("{} queries, noise {noise}, threads {}, load {}", data.len(), rayon::current_num_threads(), load.split_whitespace().take(3).collect::<Vec<_>>().join(" "));
    for (p, mut t) in models.iter().zip(times) {
        t.sort_by(f64::total_cmp);
        println!("{:>9.2} us/query (min {:.2})  {}", t[t.len() / 2], t[0], p.display());
    }
    Ok(())
}
