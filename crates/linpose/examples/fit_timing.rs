//! Times the linear fit on one COIL object several times in one process (first call included).
//!
//! cargo run --release --example fit_timing -- COIL_DIR OBJECT
use linpose::{Dataset, Estimator, LinearParams, Manifest, TrainSelection};
use std::time::Instant;

fn main() -> linpose::Result<()> {
    let args: Vec<String> = std::env::args().collect();
    let m = Manifest::open(args[1].as_ref(), Some(args[2].parse().expect("object number")))?;
    let mask = m.training_mask(&TrainSelection::Step(10.0))?;
    let train = Dataset::load(m.subset(&mask)?, Default::default(), &|_| {})?;
    for _ in 0..5 {
        let t = Instant::now();
        let model = LinearParams::default().fit(&train)?;
        println!("fit {:.6} s ({} weights)", t.elapsed().as_secs_f64(), model.weights().len());
    }
    Ok(())
}
