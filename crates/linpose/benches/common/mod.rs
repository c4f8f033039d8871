//! Shared fixtures of the benchmarks: 160 x 120 8-bit images on the paper's training grid.
#![allow(dead_code)]

use linpose::image_io::{ColorMode, ImageSpec};
use linpose::{Dataset, Manifest, Param, PoseSpace};

pub const W: usize = 160;
pub const H: usize = 120;
pub const M: usize = W * H;

/// Pseudo-random 8-bit images.
pub fn images_u8(n: usize, seed: usize) -> Vec<u8> {
    (0..n * M)
        .map(|i| {
            let mut x = (i as u64) ^ ((seed as u64) << 40);
            x = (x ^ (x >> 33)).wrapping_mul(0xff51afd7ed558ccd);
            (x ^ (x >> 29)) as u8
        })
        .collect()
}

/// The paper's 222 training views (elevation 32..77 step 9, azimuth 0..324 step 9) with
/// pseudo-random 8-bit images, as features.
pub fn training_set() -> Dataset {
    let space = PoseSpace::new(vec![Param::linear("elevation"), Param::circular("azimuth", 360.0)]).unwrap();
    let (mut poses, mut names) = (Vec::new(), Vec::new());
    for e in (32..=77).step_by(9) {
        for a in (0..=324).step_by(9) {
            poses.extend([e as f64, a as f64]);
            names.push(format!("{e}_{a}.png"));
        }
    }
    let f = images_u8(names.len(), 1).iter().map(|&v| v as f32 / 255.0).collect();
    let spec = ImageSpec { width: W as u32, height: H as u32, color: ColorMode::Gray };
    Dataset::from_features(Manifest::new(".", space, names, poses).unwrap(), spec, f).unwrap()
}

/// The rendered duck on the paper's grid (1760 views, 160 x 120): the 9-degree training subset
/// (222 views) and every view as raw 8-bit pixels, for queries whose search behaves as on real
/// data (on random images a k-d tree degenerates).
pub fn rendered_duck() -> (Dataset, Vec<u8>) {
    use linpose::render::{objects, synth, RenderParams};
    let grid = synth::PoseGrid::paper();
    let data = synth::dataset(&objects::builtin("duck").unwrap(), &grid, &RenderParams::default(), std::path::Path::new("duck"), &|_| {}).unwrap();
    let mask = data.manifest().training_mask(&linpose::TrainSelection::Step(9.0)).unwrap();
    let pixels = data.features().iter().map(|&v| (v * 255.0).round() as u8).collect();
    (data.subset(&mask).unwrap(), pixels)
}

/// `train` with every black pixel raised to 1 (of 255): the duck on a background that is not
/// black, so that no step of the 8-bit products is skipped, for a model whose manifold the
/// raised views lie on (the raised queries against the black-trained model lie off it, and its
/// search costs more there than on any real view).
pub fn raised(train: &Dataset) -> Dataset {
    let f = train.features().iter().map(|&v| v.max(1.0 / 255.0)).collect();
    Dataset::from_features(train.manifest().clone(), train.spec(), f).unwrap()
}
