//! Tests of the refined eigenspace on synthetic images made here, by topic, and the fixtures they
//! share.

mod choices;
mod clean_search;
mod fitting;
mod knots;
mod manifold;
mod noisy_match;
mod queries;
mod roll;
mod surface_bits;

use super::*;
use super::noisy::{clip_bias_shape, NoiseScan};
use super::query::NoiseWant;
use super::scratch::QueryScratch;
use super::search::smallest;
use crate::manifold::folds::{self, both_folds};
use crate::manifold::surface::Surface;
use crate::manifold::Interpolant;
use super::tuning::{BIAS_AMPLITUDE, BIN_CANDIDATES, MAX_LATTICE, NOISE_LEVELS};
use crate::dataset::Dataset;
use crate::image_io::{ColorMode, ImageSpec};
use crate::kernels::Level;
use crate::manifold::grid::Grid;
use crate::manifold::pca::Dimension;
use crate::model::{Estimator, PoseModel};
use crate::{Manifest, Param, PoseSpace};

// The eigenspace tests' synthetic turntable images.
use crate::methods::eigenspace::tests::{image, H, W};

fn grid(elev: &[f64], azim: &[f64]) -> Dataset {
    grid_tiled(elev, azim, 1)
}

/// [`grid`] with each image `tiles` times as tall (repeated below itself).
fn grid_tiled(elev: &[f64], azim: &[f64], tiles: usize) -> Dataset {
    let space = PoseSpace::new(vec![Param::linear("elevation"), Param::circular("azimuth", 360.0)]).unwrap();
    let (mut poses, mut names, mut f) = (Vec::new(), Vec::new(), Vec::new());
    for &e in elev {
        for &a in azim {
            poses.extend([e, a]);
            names.push(format!("{e}_{a}.png"));
            let x = image(e, a);
            for _ in 0..tiles {
                f.extend_from_slice(&x);
            }
        }
    }
    let spec = ImageSpec { width: W as u32, height: (H * tiles) as u32, color: ColorMode::Gray };
    Dataset::from_features(Manifest::new(".", space, names, poses).unwrap(), spec, f).unwrap()
}

fn train_set() -> Dataset {
    grid(&[30.0, 40.0, 50.0, 60.0, 70.0], &(0..24).map(|k| 15.0 * k as f64).collect::<Vec<_>>())
}

/// A turntable: one circular parameter, the synthetic object seen from 40 degrees of elevation.
fn turntable(azim: &[f64]) -> Dataset {
    let space = PoseSpace::new(vec![Param::circular("azimuth", 360.0)]).unwrap();
    let (mut poses, mut names, mut f) = (Vec::new(), Vec::new(), Vec::new());
    for &a in azim {
        poses.push(a);
        names.push(format!("{a}.png"));
        f.extend(image(40.0, a));
    }
    let spec = ImageSpec { width: W as u32, height: H as u32, color: ColorMode::Gray };
    Dataset::from_features(Manifest::new(".", space, names, poses).unwrap(), spec, f).unwrap()
}

/// The weighted squared distance from `y` to the surface at pose `t` (the first `wt.len()`
/// coordinates).
fn dist_at(s: &Surface, y: &[f32], wt: &[f64], t: &[f64]) -> f64 {
    let mut f = vec![0.0; y.len()];
    s.eval(t, &mut f, None);
    y.iter().zip(&f).zip(wt).map(|((&a, &b), &w)| w * (a as f64 - b) * (a as f64 - b)).sum()
}

/// `d`'s images binned by `b`, as a data set of its own.
fn binned(d: &Dataset, b: usize) -> Dataset {
    let bin = crate::binning::Binning::new(d.spec(), b).unwrap();
    Dataset::from_features(d.manifest().clone(), bin.spec(), bin.apply_all(d.features())).unwrap()
}

/// `x` with uniform noise of +-`a` (clipped to [0, 1]) from the tests' LCG.
fn with_noise(x: &[f32], a: f32, seed: u64) -> Vec<f32> {
    let mut state = seed;
    x.iter()
        .map(|&v| {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (v + a * (2.0 * (state >> 40) as f32 / (1u64 << 24) as f32 - 1.0)).clamp(0.0, 1.0)
        })
        .collect()
}

/// 24 unseen views as 8-bit images and as their f32 features, those `noisy` picks under +-10%
/// noise (seed `seed` + the view's index), clipped and rounded.
fn mixed_queries(noisy: impl Fn(usize) -> bool, seed: u64) -> (Dataset, Vec<u8>, Vec<f32>) {
    let test = grid(&[35.0, 45.0, 65.0], &(0..8).map(|k| 45.0 * k as f64 + 7.5).collect::<Vec<_>>());
    let m = test.n_features();
    let mut q8: Vec<u8> = test.features().iter().map(|&v| (v * 255.0).round() as u8).collect();
    for (i, x) in q8.chunks_exact_mut(m).enumerate().filter(|(i, _)| noisy(*i)) {
        let v = with_noise(&x.iter().map(|&v| v as f32 / 255.0).collect::<Vec<_>>(), 0.1, seed + i as u64);
        x.iter_mut().zip(v).for_each(|(v, f)| *v = (f * 255.0).round() as u8);
    }
    let qf: Vec<f32> = q8.iter().map(|&v| v as f32 * crate::kernels::levels::S8).collect();
    (test, q8, qf)
}

/// `d` as colour images: each gray value v becomes (v, 0.7 v, 0.4 v + 0.1 on lit pixels), so the
/// three channels differ and are binned apart.
fn colour(d: &Dataset) -> Dataset {
    let f = d.features().iter().flat_map(|&v| [v, 0.7 * v, if v > 0.0 { 0.4 * v + 0.1 } else { 0.0 }]).collect();
    let spec = ImageSpec { color: ColorMode::Rgb, ..d.spec() };
    Dataset::from_features(d.manifest().clone(), spec, f).unwrap()
}
