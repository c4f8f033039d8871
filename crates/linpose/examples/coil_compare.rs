//! The eigenspace method on COIL-20 against the numpy peer, object by object: train every 10
//! degrees (36 views), 20 components, manifold every 0.5 degrees, evaluate all 72 views.
//!
//!     cargo run --release -p linpose --example coil_compare -- [COIL_DIR] [PEER_JSON_DIR]
//!
//! COIL_DIR defaults to /work/shared/datasets/coil-20-proc; nothing is done when it is absent.
//! PEER_JSON_DIR holds `peer_obj{O}.json` from
//! `peer.py DIR_O --train-step 10 --only eigenspace --json peer_obj{O}.json`, run on per-object
//! folders (poses.csv `image,azimuth` with azimuth = 5 K, symlinks to the PNGs).

use linpose::image_io::ColorMode;
use linpose::{Dataset, EigenspaceParams, Estimator, Manifest, PoseModel, TrainSelection};
use std::path::PathBuf;
use std::time::Instant;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let mut args = std::env::args().skip(1);
    let dir = PathBuf::from(args.next().unwrap_or_else(|| "/work/shared/datasets/coil-20-proc".into()));
    let peer_dir = args.next().map(PathBuf::from);
    if !dir.is_dir() {
        println!("{} is not present; nothing to compare", dir.display());
        return Ok(());
    }
    println!("| object | ours unseen mean (deg) | peer (deg) | ours - peer | ours fit_s | peer fit_s | ours predict_s | peer predict_s |");
    println!("|---|---|---|---|---|---|---|---|");
    let (mut ours_all, mut peer_all, mut worst) = (Vec::new(), Vec::new(), 0f64);
    for object in 1..=20u32 {
        let data = Dataset::load(Manifest::open(&dir, Some(object))?, ColorMode::Gray, &|_| {})?;
        let mask = data.manifest().training_mask(&TrainSelection::Step(10.0))?;
        let train = data.subset(&mask)?;
        let t0 = Instant::now();
        let model = EigenspaceParams::default().components(20).manifold_step(0.5).fit(&train)?;
        let fit_s = t0.elapsed().as_secs_f64();
        let t0 = Instant::now();
        let est = model.predict(data.features())?;
        let predict_s = t0.elapsed().as_secs_f64();
        let unseen: Vec<f64> = (0..data.len()).filter(|&i| !mask[i]).map(|i| data.space().error_deg(data.pose(i), &est[i..i + 1])).collect();
        let ours = unseen.iter().sum::<f64>() / unseen.len() as f64;
        ours_all.push(ours);
        let peer = peer_dir.as_ref().and_then(|d| {
            let text = std::fs::read_to_string(d.join(format!("peer_obj{object}.json"))).ok()?;
            let v: serde_json::Value = serde_json::from_str(&text).ok()?;
            let e = &v["eigenspace"];
            Some((e["unseen"]["mean_deg"].as_f64()?, e["fit_s"].as_f64()?, e["predict_s"].as_f64()?))
        });
        match peer {
            Some((p, pf, pp)) => {
                peer_all.push(p);
                worst = worst.max((ours - p).abs());
                println!("| {object} | {ours:.3} | {p:.3} | {:+.3} | {fit_s:.4} | {pf:.4} | {predict_s:.4} | {pp:.4} |", ours - p);
            }
            None => println!("| {object} | {ours:.3} | - | - | {fit_s:.4} | - | {predict_s:.4} | - |"),
        }
    }
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len() as f64;
    println!("\nmean over objects: ours {:.3} deg", mean(&ours_all));
    if peer_all.len() == ours_all.len() {
        let (o, p) = (mean(&ours_all), mean(&peer_all));
        println!("peer {p:.3} deg; difference {:+.3} deg; largest per-object difference {worst:.3} deg", o - p);
    }
    Ok(())
}
