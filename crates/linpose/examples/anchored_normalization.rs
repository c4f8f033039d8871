//! A second pass behind the normalisation stage, tried and not adopted (docs/normalization.md,
//! "What it buys, and what it costs"): the stage centres every view, which throws away where the
//! object sat in the frame, a cue to its pose on objects like the `twin`. The second pass puts
//! that place back. For each query:
//!
//! 1. the method's model of the centred training views estimates the pose (the stage's position
//!    and scale, `--normalize geometry`);
//! 2. the place (centroid and radius of gyration) the training views have at that pose is
//!    interpolated from theirs: a local linear fit in the pose, tricube weights, over the 8
//!    training poses nearest on the error measure (the fewest of 4, 8, 12 and 20 that did best
//!    with the true pose on the twin);
//! 3. the query is resampled so that its object sits there ([`Normalizer::place`]) and the
//!    method's model of the training views as they are estimates the pose again.
//!
//! Trained on the registered views every `STEP` degrees (9 by default); the unseen views of the
//! registered set and of the moved and scaled set (`linpose synth --jitter 8,0.1,0`) estimated;
//! views the stage refuses are left out of both means. Prints one row per method: unseen mean
//! error, degrees.
//!
//!     cargo run --release -p linpose --example anchored_normalization -- REGISTERED MOVED [STEP]
use faer::linalg::solvers::Solve;
use faer::Mat;
use linpose::image_io::ColorMode;
use linpose::normalize::{NormalizeParams, Normalizer};
use linpose::{Dataset, Manifest, PoseModel, Settings, TrainSelection};
use std::path::PathBuf;

type Res<T> = Result<T, Box<dyn std::error::Error>>;

/// Training poses the place is interpolated from.
const NEAREST: usize = 8;

/// The place at `pose`: the constant term of a weighted local linear fit of the training views'
/// places in the pose differences (a circular parameter's difference wrapped).
fn place_at(train: &Dataset, places: &[[f64; 3]], pose: &[f64]) -> [f64; 3] {
    let space = train.space();
    let mut near: Vec<(f64, usize)> = (0..train.len()).map(|i| (space.error_deg(train.pose(i), pose), i)).collect();
    near.sort_by(|a, b| a.0.total_cmp(&b.0));
    near.truncate(NEAREST);
    let h = near.last().map_or(1.0, |n| n.0) * 1.0001 + 1e-9;
    let terms = |t: &[f64]| -> Vec<f64> {
        let diffs = space.params().iter().zip(t.iter().zip(pose)).map(|(p, (a, b))| {
            let d = a - b;
            p.period.map_or(d, |per| d - per * (d / per).round())
        });
        std::iter::once(1.0).chain(diffs).collect()
    };
    let n = space.len() + 1;
    let (mut a, mut b) = (Mat::<f64>::identity(n, n) * faer::Scale(1e-9), Mat::<f64>::zeros(n, 3));
    for &(d, i) in &near {
        let w = (1.0 - (d / h).powi(3)).powi(3);
        let f = terms(train.pose(i));
        for r in 0..n {
            (0..n).for_each(|c| a[(r, c)] += w * f[r] * f[c]);
            (0..3).for_each(|j| b[(r, j)] += w * f[r] * places[i][j]);
        }
    }
    let x = a.partial_piv_lu().solve(&b);
    [x[(0, 0)], x[(0, 1)], x[(0, 2)]]
}

fn main() -> Res<()> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    let usage = "usage: anchored_normalization REGISTERED MOVED [STEP]";
    let (reg, moved) = (PathBuf::from(args.first().ok_or(usage)?), PathBuf::from(args.get(1).ok_or(usage)?));
    let step: f64 = args.get(2).map_or(Ok(9.0), |s| s.parse())?;
    let manifest = Manifest::open(&reg, None)?;
    let mask = manifest.training_mask(&TrainSelection::Step(step))?;
    let registered = Dataset::load(manifest, ColorMode::Gray, &|_| {})?;
    let moved = Dataset::load(Manifest::open(&moved, None)?, ColorMode::Gray, &|_| {})?;
    let train = registered.subset(&mask)?;
    let stage = Normalizer::fit(&train, NormalizeParams::geometry())?;
    let places: Vec<[f64; 3]> = (0..train.len()).map(|i| stage.placement(train.row(i))).collect::<Result<_, _>>()?;
    let (m, k) = (train.n_features(), train.space().len());
    println!("| method | R, as given | R, centred | R, second pass | moved, centred | moved, second pass |");
    println!("|---|---|---|---|---|---|");
    for method in ["linear", "eigenspace", "refined"] {
        let spec = linpose::methods::find(method).ok_or("no such method")?.spec(&Settings::new())?;
        let plain = spec.fit(&train)?;
        let centred = spec.fit(&stage.apply_dataset(&train)?)?;
        let mut row = vec![];
        for (d, with_plain) in [(&registered, true), (&moved, false)] {
            // The images as given only on the registered set (the moved set has no such column).
            let (mut sums, mut n) = (vec![0.0f64; if with_plain { 3 } else { 2 }], 0usize);
            let (mut q, mut pose, mut again, mut as_given) = (vec![0.0f32; m], vec![0.0; k], vec![0.0; k], vec![0.0; k]);
            for i in (0..d.len()).filter(|&i| !mask[i]) {
                if stage.apply(d.row(i), &mut q).is_err() {
                    continue;
                }
                let truth = d.pose(i);
                centred.predict_into(&q, &mut pose)?;
                stage.place(d.row(i), place_at(&train, &places, &pose), &mut q)?;
                plain.predict_into(&q, &mut again)?;
                if with_plain {
                    plain.predict_into(d.row(i), &mut as_given)?;
                }
                let estimates = if with_plain { vec![&as_given, &pose, &again] } else { vec![&pose, &again] };
                for (s, p) in sums.iter_mut().zip(estimates) {
                    *s += d.space().error_deg(truth, p);
                }
                n += 1;
            }
            row.extend(sums.iter().map(|s| s / n as f64));
        }
        println!("| {method} | {} |", row.iter().map(|v| format!("{v:.3}")).collect::<Vec<_>>().join(" | "));
    }
    Ok(())
}
