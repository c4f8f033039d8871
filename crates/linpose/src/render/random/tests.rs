//! The zoo: reproducible, varied, in frame, and the front-back class as symmetric as claimed.

use super::*;
use crate::render::{render, RenderParams};
use image::GrayImage;

fn tiny() -> RenderParams {
    RenderParams::default().width(40).height(30)
}

/// Mean absolute difference of two images, in gray levels.
fn mean_diff(a: &GrayImage, b: &GrayImage) -> f64 {
    let sum: u64 = a.as_raw().iter().zip(b.as_raw()).map(|(&x, &y)| x.abs_diff(y) as u64).sum();
    sum as f64 / a.as_raw().len() as f64
}

#[test]
fn a_seed_gives_the_same_mesh_and_pixels_and_seeds_differ() {
    for seed in [0, 1, 2, 3, 12345] {
        let (a, b) = (random(seed).unwrap(), random(seed).unwrap());
        assert_eq!(a, b, "seed {seed}");
        assert_eq!(random_kind(seed), random_kind(seed));
        assert_eq!(render(&a, 40.0, 50.0, &tiny()).unwrap(), render(&b, 40.0, 50.0, &tiny()).unwrap());
    }
    let images: Vec<GrayImage> = (0..8).map(|s| render(&random(s).unwrap(), 40.0, 50.0, &tiny()).unwrap()).collect();
    for i in 0..images.len() {
        for j in 0..i {
            assert!(mean_diff(&images[i], &images[j]) > 1.0, "seeds {i} and {j} look alike");
        }
    }
}

#[test]
fn every_class_appears_in_about_its_share() {
    let kinds: Vec<RandomKind> = (0..40).map(random_kind).collect();
    for class in RandomClass::ALL {
        let n = kinds.iter().filter(|k| k.class == class).count();
        // Expected 16, 12 and 12 of 40.
        assert!((6..=22).contains(&n), "{class}: {n} of 40");
    }
    for k in &kinds {
        assert!(k.description.starts_with(k.class.name()) && !k.description.contains('\n'), "{k:?}");
    }
    assert_eq!(random_name(7), "random-7");
}

#[test]
fn every_seed_renders_in_frame_at_the_default_camera() {
    let (w, h) = (40usize, 30usize);
    for seed in 0..40 {
        let mesh = random(seed).unwrap();
        for (e, a) in [(32.0, 0.0), (32.0, 135.0), (55.0, 250.0), (78.0, 300.0)] {
            let img = render(&mesh, a, e, &tiny()).unwrap();
            let px = img.as_raw();
            let lit = px.iter().filter(|&&v| v > 0).count();
            assert!(lit >= w * h / 20, "seed {seed} at ({e}, {a}): only {lit} pixels");
            let border = (0..w).flat_map(|x| [x, (h - 1) * w + x]).chain((0..h).flat_map(|y| [y * w, y * w + w - 1]));
            assert!(border.into_iter().all(|i| px[i] == 0), "seed {seed} at ({e}, {a}) touches the border");
        }
    }
}

#[test]
fn no_seed_fails() {
    for seed in (0..200).chain([u64::MAX, u64::MAX / 3, 1 << 63]) {
        let m = random(seed).unwrap_or_else(|e| panic!("seed {seed}: {e}"));
        assert!(m.triangles().len() > 1000);
    }
}

/// (difference a half turn apart, a quarter turn apart), summed over a few poses.
fn turn_diffs(mesh: &Mesh) -> (f64, f64) {
    let p = RenderParams::default().width(80).height(60);
    let (mut half, mut quarter) = (0.0, 0.0);
    for (e, a) in [(32.0, 20.0), (50.0, 110.0), (70.0, 200.0)] {
        let at = |t: f64| render(mesh, a + t, e, &p).unwrap();
        let base = at(0.0);
        half += mean_diff(&base, &at(180.0));
        quarter += mean_diff(&base, &at(90.0));
    }
    (half, quarter)
}

#[test]
fn front_back_objects_look_alike_a_half_turn_apart_and_others_do_not() {
    let (mut sym, mut asym) = (0, 0);
    for seed in 0..40 {
        let class = random_kind(seed).class;
        let (half, quarter) = turn_diffs(&random(seed).unwrap());
        let ratio = half / quarter;
        match class {
            RandomClass::FrontBack if sym < 5 => {
                sym += 1;
                assert!(ratio < 0.15, "seed {seed}: a half turn changes the image by {half:.2}, a quarter turn by {quarter:.2}");
                assert!(half > 0.0, "seed {seed}: the mark does not show");
            }
            RandomClass::Asymmetric if asym < 5 => {
                asym += 1;
                assert!(ratio > 0.3, "seed {seed}: asymmetric, yet a half turn changes little ({half:.2} vs {quarter:.2})");
            }
            _ => {}
        }
    }
}
