//! Times `predict` of saved models on one data set (optionally with noise), medians of REPS,
//! alternating the models so they see the same machine load. With `--u8` the queries are 8-bit
//! images (the features times 255, rounded: what `linpose predict` decodes from image files)
//! and go through `predict_u8_into`.
//!
//!     cargo bench -p linpose --bench predict_timing -- DIR [--object O] [--noise A]
//!         [--reps R] [--u8] MODEL...
use linpose::image_io::ColorMode;
use linpose::{Dataset, Manifest, PoseModel};
use std::path::PathBuf;
use std::time::Instant;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let (mut dir, mut object, mut noise, mut reps, mut models, mut u8) = (None, None, 0.0, 5usize, vec![], false);
    let mut args = std::env::args().skip(1).filter(|a| a != "--bench");
    while let Some(a) = args.next() {
        match a.as_str() {
            "--object" => object = Some(args.next().ok_or("--object O")?.parse()?),
            "--noise" => noise = args.next().ok_or("--noise A")?.parse()?,
            "--reps" => reps = args.next().ok_or("--reps R")?.parse()?,
            "--u8" => u8 = true,
            _ if dir.is_none() => dir = Some(PathBuf::from(a)),
            _ => models.push(PathBuf::from(a)),
        }
    }
    let dir = dir.ok_or("usage: predict_timing DIR [--object O] [--noise A] [--reps R] [--u8] MODEL...")?;
    let data = Dataset::load(Manifest::open(&dir, object)?, ColorMode::Gray, &|_| {})?;
    let mut queries = data.features().to_vec();
    linpose::bench::add_uniform_noise(&mut queries, data.n_features(), noise, 0)?;
    let pixels: Vec<u8> = if u8 { queries.iter().map(|&v| (v * 255.0).round().clamp(0.0, 255.0) as u8).collect() } else { vec![] };
    let mut out = vec![0.0; data.len() * data.space().len()];
    let loaded: Vec<_> = models.iter().map(|p| linpose::AnyModel::load(p)).collect::<Result<_, _>>()?;
    let mut times = vec![vec![]; loaded.len()];
    for _ in 0..reps {
        for (m, t) in loaded.iter().zip(&mut times) {
            let t0 = Instant::now();
            if u8 {
                m.predict_u8_into(&pixels, &mut out)?;
            } else {
                m.predict_into(&queries, &mut out)?;
            }
            std::hint::black_box(&out);
            t.push(t0.elapsed().as_secs_f64() / data.len() as f64 * 1e6);
        }
    }
    let load = std::fs::read_to_string("/proc/loadavg").unwrap_or_default();
    println!(
        "{} {} queries, noise {noise}, threads {}, load {}",
        data.len(),
        if u8 { "8-bit" } else { "f32" },
        rayon::current_num_threads(),
        load.split_whitespace().take(3).collect::<Vec<_>>().join(" ")
    );
    for (p, mut t) in models.iter().zip(times) {
        t.sort_by(f64::total_cmp);
        println!("{:>9.2} us/query (min {:.2})  {}", t[t.len() / 2], t[0], p.display());
    }
    Ok(())
}
