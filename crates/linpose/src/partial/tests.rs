//! Merged partial statistics against the single-process fit, on rendered turntables (8-bit) and
//! on images that are not 8-bit; and the refusals.

use super::*;
use crate::manifold::pca::{self, Dimension};
use crate::methods::eigenspace::{EigenspaceModel, EigenspaceParams, METHOD as EIGENSPACE};
use crate::methods::linear::ridge::RidgeRule;
use crate::methods::linear::{LinearModel, LinearParams, METHOD as LINEAR};
use crate::model::{Estimator, PoseModel};
use crate::render::synth::{dataset, PoseGrid};
use crate::render::{objects, Grid, RenderParams};
use std::path::Path;

/// A rendered duck: `azimuth` and `elevation` grids, `w` x `h` pixels (8-bit).
fn duck(elevation: &str, azimuth: &str, w: u32, h: u32) -> Dataset {
    let mesh = objects::builtin("duck").unwrap();
    let grid = PoseGrid::new(Grid::parse("elevation", elevation).unwrap(), Grid::parse("azimuth", azimuth).unwrap()).unwrap();
    dataset(&mesh, &grid, &RenderParams::default().width(w).height(h), Path::new("<render>"), &|_| {}).unwrap()
}

/// The same images with every value nudged off the 8-bit levels (the f64 accumulation).
fn off_levels(d: &Dataset) -> Dataset {
    let f = d.features().iter().enumerate().map(|(i, &v)| v * 0.999 + (i % 7) as f32 * 1e-4).collect();
    Dataset::from_features(d.manifest().clone(), d.spec(), f).unwrap()
}

/// Partials of `count` shards of `d`, each accumulated from its own slice of the features.
fn shards(method: &'static Method, settings: &Settings, d: &Dataset, count: usize) -> Vec<Partial> {
    let (n, m) = (d.len(), d.n_features());
    let proto = Partial::new(method, settings, d.manifest(), d.spec()).unwrap();
    (0..count)
        .map(|i| {
            let mut p = proto.empty().with_source(format!("shard {}/{count}", i + 1));
            let r = p.shard_range(i, count).unwrap();
            match p.split() {
                Split::Images => p.accumulate(Shard::Images { start: r.start, features: &d.features()[r.start * m..r.end * m] }).unwrap(),
                Split::Pixels => {
                    let cols: Vec<f32> = (0..n).flat_map(|j| d.features()[j * m + r.start..j * m + r.end].iter().copied()).collect();
                    p.accumulate(Shard::Pixels { start: r.start, features: &cols }).unwrap()
                }
            }
            p
        })
        .collect()
}

/// Merges pair-wise as a reduction tree would, each partial through a file's bytes.
fn merge_tree(mut parts: Vec<Partial>) -> Partial {
    parts = parts.into_iter().map(|p| Partial::from_bytes(Path::new("shard.safetensors"), &p.to_bytes().unwrap()).unwrap()).collect();
    while parts.len() > 1 {
        let mut next = Vec::new();
        let mut it = parts.into_iter();
        while let Some(mut a) = it.next() {
            if let Some(b) = it.next() {
                a.merge(b).unwrap();
            }
            next.push(a);
        }
        parts = next;
    }
    parts.pop().unwrap()
}

fn rel(want: &[f64], got: &[f64]) -> f64 {
    assert_eq!(want.len(), got.len());
    let num: f64 = want.iter().zip(got).map(|(a, b)| (a - b) * (a - b)).sum();
    let den: f64 = want.iter().map(|a| a * a).sum();
    (num / den).sqrt()
}

fn linear(model: &AnyModel) -> &LinearModel {
    model.downcast_ref::<LinearModel>().unwrap()
}

/// More images than pixels: shards of images; the merged least-squares model is the streamed
/// fit's and the in-memory ridge fit's, for 8-bit images and for values off the levels.
#[test]
fn image_shards_merge_into_the_single_process_model() {
    let eight = duck("30:60:10", "0:357:3", 16, 12); // 480 images of 192 pixels
    for d in [eight.clone(), off_levels(&eight)] {
        let settings = Settings::new().set("ridge", "1e-3");
        let want = LinearParams::default().ridge(1e-3).fit(&d).unwrap();
        let parts = shards(&LINEAR, &settings, &d, 1);
        assert_eq!(parts[0].split(), Split::Images);
        let one = parts.into_iter().next().unwrap().finish().unwrap();
        for count in [2, 3, 5] {
            let merged = merge_tree(shards(&LINEAR, &settings, &d, count)).finish().unwrap();
            let r = rel(linear(&one).weights(), linear(&merged).weights());
            assert!(r < 1e-9, "{count} shards against one: {r:e}");
            let r = rel(want.weights(), linear(&merged).weights());
            assert!(r < 1e-9, "{count} shards against the in-memory fit: {r:e}");
            assert_eq!(merged.meta().train_poses, d.poses());
        }
    }
}

/// Ridge 0 with more images than pixels: the minimum-norm least-squares fit, the background's
/// pixels (zero in every image) weighted 0.
#[test]
fn ridge_zero_gives_the_least_squares_fit_with_dark_pixels_at_zero() {
    let d = duck("30:60:10", "0:357:3", 16, 12);
    let model = merge_tree(shards(&LINEAR, &Settings::new(), &d, 3)).finish().unwrap();
    let (n, m) = (d.len(), d.n_features());
    let dark: Vec<usize> = (0..m).filter(|&p| (0..n).all(|i| d.features()[i * m + p] == 0.0)).collect();
    assert!(!dark.is_empty(), "the rendered background has pixels that are never lit");
    let w = linear(&model).weights();
    let k = d.space().encoded_len();
    for j in 0..k {
        assert!(dark.iter().all(|&p| w[j * m + p] == 0.0));
    }
    // The normal equations hold: X^T (X W - P) = 0 on the lit pixels, to rounding.
    let p = crate::methods::linear::encoded_poses(&d);
    let mut worst: f64 = 0.0;
    let mut scale: f64 = 0.0;
    for q in 0..m {
        for j in 0..k {
            let g: f64 = (0..n)
                .map(|i| d.features()[i * m + q] as f64 * ((0..m).map(|r| d.features()[i * m + r] as f64 * w[j * m + r]).sum::<f64>() - p[i * k + j]))
                .sum();
            let s: f64 = (0..n).map(|i| (d.features()[i * m + q] as f64 * p[i * k + j]).abs()).sum();
            worst = worst.max(g.abs());
            scale = scale.max(s);
        }
    }
    assert!(worst < 1e-8 * scale, "normal equations' residual {worst:e} against {scale:e}");
}

/// N <= M: shards of pixels; the merged Gram gives the in-memory model, uncentred with the
/// leave-one-out ridge and centred.
#[test]
fn pixel_shards_merge_into_the_single_process_model() {
    let d = duck("40", "0:355:5", 32, 24); // 72 images of 768 pixels
    for (settings, params) in [
        (Settings::new(), LinearParams::default()),
        (Settings::new().set("ridge", "auto"), LinearParams::default().ridge_rule(RidgeRule::Loo)),
        (Settings::new().set("center", "true"), LinearParams::default().center(true)),
    ] {
        let want = params.fit(&d).unwrap();
        for count in [1, 2, 5] {
            let parts = shards(&LINEAR, &settings, &d, count);
            assert_eq!(parts[0].split(), Split::Pixels);
            let got = merge_tree(parts).finish().unwrap();
            let r = rel(want.weights(), linear(&got).weights());
            assert!(r < 1e-9, "{settings:?}, {count} shards: {r:e}");
            let (a, b) = (&got.meta().settings, &want.meta().settings);
            assert_eq!(a["params"], b["params"], "{settings:?}");
            let lambda = (a["lambda"].as_f64().unwrap(), b["lambda"].as_f64().unwrap());
            assert!((lambda.0 - lambda.1).abs() <= 1e-9 * lambda.1, "{settings:?}: lambda {lambda:?}");
        }
    }
}

/// The eigenspace's PCA from the merged Gram matrix is the single-process PCA (mean, eigenimages,
/// coordinates, eigenvalues), and so is the model.
#[test]
fn eigenspace_pca_from_merged_gram_is_the_single_process_pca() {
    for d in [duck("40", "0:355:5", 32, 24), off_levels(&duck("30:50:10", "0:350:10", 24, 16))] {
        let (n, m) = (d.len(), d.n_features());
        let want = pca::fit(&d, Dimension::Fixed(12)).unwrap();
        for count in [1, 3] {
            let merged = merge_tree(shards(&EIGENSPACE, &Settings::new(), &d, count));
            let g = merged.gram().unwrap();
            assert_eq!(g.nrows(), n);
            let got = pca::fit_with_gram(&d, Dimension::Fixed(12), g).unwrap();
            assert_eq!(got.dim(), want.dim());
            let l = want.dim();
            for (what, a, b) in [
                ("mean", &want.mean, &got.mean),
                ("eigenimages", &want.basis, &got.basis),
                ("coordinates", &want.coords, &got.coords),
                ("eigenvalues", &want.eigenvalues[..l].to_vec(), &got.eigenvalues[..l].to_vec()),
            ] {
                let r = rel(a, b);
                assert!(r < 1e-9, "{what}, {count} shards, M = {m}: {r:e}");
            }
            let model = merged.finish().unwrap();
            let single = EigenspaceParams::default().fit(&d).unwrap();
            let e = model.downcast_ref::<EigenspaceModel>().unwrap();
            let q = d.row(5);
            assert!(d.space().error_deg(&single.predict(q).unwrap(), &e.predict(q).unwrap()) < 1e-3);
        }
    }
}

/// A ridge for the 16 x 12 renders, some of whose views are too alike to tell apart exactly.
fn tiny() -> Settings {
    Settings::new().set("ridge", "1e-6")
}

#[test]
fn mismatched_partials_are_refused_by_name() {
    let d = duck("40", "0:355:5", 16, 12);
    let a = || shards(&LINEAR, &tiny(), &d, 2).into_iter().next().unwrap();
    let second = || shards(&LINEAR, &tiny(), &d, 2).pop().unwrap();
    let merge_err = |b: Partial| {
        let mut x = a();
        x.merge(b).unwrap_err().to_string()
    };
    // Other image size.
    let small = duck("40", "0:355:5", 8, 6);
    let e = merge_err(shards(&LINEAR, &tiny(), &small, 2).pop().unwrap());
    assert!(e.contains("image size 16x12") && e.contains("8x6"), "{e}");
    // Other settings.
    let e = merge_err(shards(&LINEAR, &Settings::new().set("ridge", "1e-3"), &d, 2).pop().unwrap());
    assert!(e.contains("settings") && e.contains("ridge=1e-3"), "{e}");
    // Other method.
    let e = merge_err(shards(&EIGENSPACE, &Settings::new(), &d, 2).pop().unwrap());
    assert!(e.contains("method linear here, eigenspace there"), "{e}");
    // Other poses (another training set of the same size).
    let mut poses = d.poses().to_vec();
    poses[3] += 1.0;
    let other =
        Dataset::from_features(Manifest::new(".", d.space().clone(), d.manifest().images().to_vec(), poses).unwrap(), d.spec(), d.features().to_vec()).unwrap();
    let e = merge_err(shards(&LINEAR, &tiny(), &other, 2).pop().unwrap());
    assert!(e.contains("fingerprint"), "{e}");
    // The same shard twice.
    let e = merge_err(a());
    assert!(e.contains("both hold pixels 0..96"), "{e}");
    // A refused merge changes nothing: the right shard still completes the set.
    let mut x = a();
    assert!(x.merge(a()).is_err());
    x.merge(second()).unwrap();
    assert!(x.is_complete() && x.finish().is_ok());
    // A shard missing.
    let e = a().finish().unwrap_err().to_string();
    assert!(e.contains("missing pixels 96..192 of 192"), "{e}");
    // The shards in either order give the same model.
    let (mut x, mut y) = (a(), second());
    x.merge(second()).unwrap();
    y.merge(a()).unwrap();
    assert_eq!(linear(&x.finish().unwrap()).weights(), linear(&y.finish().unwrap()).weights());
    // The wrong kind of shard, and a shard past the end.
    let mut p = a().empty();
    let e = p.accumulate(Shard::Images { start: 0, features: &d.features()[..192] }).unwrap_err().to_string();
    assert!(e.contains("shards of pixels"), "{e}");
    let e = p.accumulate(Shard::Pixels { start: 190, features: &vec![0.0; 72 * 4] }).unwrap_err().to_string();
    assert!(e.contains("190..194"), "{e}");
    assert!(p.shard_range(2, 2).is_err() && p.shard_range(0, 193).is_err());
}

#[test]
fn methods_and_settings_that_cannot_merge_are_refused() {
    let d = duck("30:60:10", "0:357:3", 16, 12); // N > M
    let refined = crate::methods::find("refined").unwrap();
    let e = Partial::new(refined, &Settings::new(), d.manifest(), d.spec()).unwrap_err().to_string();
    assert!(e.contains("one process"), "{e}");
    for s in [Settings::new().set("ridge", "auto"), Settings::new().set("center", "true")] {
        let e = Partial::new(&LINEAR, &s, d.manifest(), d.spec()).unwrap_err().to_string();
        assert!(e.contains("shards of images"), "{e}");
    }
}

#[test]
fn files_are_told_apart_from_models() {
    let d = duck("40", "0:355:5", 16, 12);
    let p = shards(&LINEAR, &tiny(), &d, 1).pop().unwrap();
    let bytes = p.to_bytes().unwrap();
    let e = crate::AnyModel::from_bytes(Path::new("p.safetensors"), &bytes).unwrap_err().to_string();
    assert!(e.contains("linpose merge"), "{e}");
    let model = p.finish().unwrap().to_bytes().unwrap();
    let e = Partial::from_bytes(Path::new("m.safetensors"), &model).unwrap_err().to_string();
    assert!(e.contains("not a file of partial training statistics"), "{e}");
}
