//! Fits the eigenspace on one data set and estimates every sample, timing fit and predict inside
//! the process, next to the numpy peer's figures for the same data when given.
//!
//!     cargo run --release -p linpose --example eigen_eval -- DIR [--object O] [--train-step S]
//!         [--noise A] [--search auto|kdtree|brute] [--peer PEER_JSON]
//!
//! DIR is a data set folder (poses.csv) or a COIL folder with --object. PEER_JSON is
//! `peer.py DIR --train-step S --only eigenspace --json PEER_JSON`, run just before on the same
//! machine, so the ratios compare like with like.

use linpose::image_io::ColorMode;
use linpose::methods::eigenspace::SearchKind;
use linpose::{Dataset, EigenspaceParams, Estimator, Manifest, PoseModel, TrainSelection};
use std::path::PathBuf;
use std::time::Instant;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let (mut dir, mut object, mut step, mut peer, mut noise, mut search) = (None, None, 9.0, None, 0.0, SearchKind::Auto);
    let mut args = std::env::args().skip(1);
    while let Some(a) = args.next() {
        match a.as_str() {
            "--object" => object = Some(args.next().ok_or("--object O")?.parse()?),
            "--train-step" => step = args.next().ok_or("--train-step S")?.parse()?,
            "--peer" => peer = Some(PathBuf::from(args.next().ok_or("--peer FILE")?)),
            "--noise" => noise = args.next().ok_or("--noise A")?.parse()?,
            "--search" => {
                search = match args.next().as_deref() {
                    Some("kdtree") => SearchKind::KdTree,
                    Some("brute") => SearchKind::Brute,
                    Some("auto") => SearchKind::Auto,
                    _ => return Err("--search auto|kdtree|brute".into()),
                }
            }
            _ => dir = Some(PathBuf::from(a)),
        }
    }
    let dir = dir.ok_or("usage: eigen_eval DIR [--object O] [--train-step S] [--peer PEER_JSON]")?;
    let data = Dataset::load(Manifest::open(&dir, object)?, ColorMode::Gray, &|_| {})?;
    let mask = data.manifest().training_mask(&TrainSelection::Step(step))?;
    let train = data.subset(&mask)?;
    let t0 = Instant::now();
    let model = EigenspaceParams::default().search(search).fit(&train)?;
    let fit_s = t0.elapsed().as_secs_f64();
    let mut queries = data.features().to_vec();
    linpose::eval::add_uniform_noise(&mut queries, data.n_features(), noise, 0)?;
    let t0 = Instant::now();
    let est = model.predict(&queries)?;
    let predict_s = t0.elapsed().as_secs_f64();
    // The projection on its own, to show where predict's time goes.
    let mut y = vec![0f32; data.len() * model.components()];
    let t0 = Instant::now();
    model.project_into(&queries, &mut y)?;
    let project_s = t0.elapsed().as_secs_f64();
    let p = data.space().len();
    let unseen: Vec<f64> = (0..data.len()).filter(|&i| !mask[i]).map(|i| data.space().error_deg(data.pose(i), &est[i * p..(i + 1) * p])).collect();
    let mean = unseen.iter().sum::<f64>() / unseen.len().max(1) as f64;
    let s = model.settings();
    println!(
        "{}: {} train / {} eval, L = {}, manifold {:?} ({} points, search {}), model_bytes {}",
        dir.display(),
        train.len(),
        data.len(),
        s.components,
        s.manifold_shape,
        model.manifold_len(),
        s.search,
        model.model_bytes()
    );
    println!("ours: unseen mean {mean:.4} deg, fit_s {fit_s:.4}, predict_s {predict_s:.4} (projection alone {project_s:.4})");
    if let Some(path) = peer {
        let v: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&path)?)?;
        let e = &v["eigenspace"];
        let (pm, pf, pp) =
            (e["unseen"]["mean_deg"].as_f64().unwrap_or(f64::NAN), e["fit_s"].as_f64().unwrap_or(f64::NAN), e["predict_s"].as_f64().unwrap_or(f64::NAN));
        println!("peer: unseen mean {pm:.4} deg, fit_s {pf:.4}, predict_s {pp:.4}, model_bytes {}", e["model_bytes"]);
        println!("ratio ours/peer: fit {:.3}, predict {:.3}", fit_s / pf, predict_s / pp);
    }
    Ok(())
}
