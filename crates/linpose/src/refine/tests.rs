//! Tests of the refined eigenspace on synthetic images made here (never /work/shared).

use super::*;
use crate::image_io::{ColorMode, ImageSpec};
use crate::{Manifest, Param, PoseSpace};

const W: usize = 32;
const H: usize = 12;

/// A smooth image of (elevation, azimuth): a lobe turning with the azimuth, rising with the
/// elevation.
fn image(elev: f64, azim: f64) -> Vec<f32> {
    let (a, e) = (azim.to_radians(), (elev - 30.0) / 60.0);
    let mut f = Vec::with_capacity(W * H);
    for j in 0..H {
        for i in 0..W {
            let u = i as f64 / W as f64 * std::f64::consts::TAU;
            let v = j as f64 / H as f64;
            let lobe = (4.0 * ((u - a).cos() - 1.0)).exp() * (-(v - e).powi(2) / 0.08).exp();
            f.push((0.15 + 0.6 * lobe + 0.1 * (u + 2.0 * a).cos() * v + 0.05 * (3.0 * u - a).sin()) as f32);
        }
    }
    f
}

fn grid(elev: &[f64], azim: &[f64]) -> Dataset {
    let space = PoseSpace::new(vec![Param::linear("elevation"), Param::circular("azimuth", 360.0)]).unwrap();
    let (mut poses, mut names, mut f) = (Vec::new(), Vec::new(), Vec::new());
    for &e in elev {
        for &a in azim {
            poses.extend([e, a]);
            names.push(format!("{e}_{a}.png"));
            f.extend(image(e, a));
        }
    }
    let spec = ImageSpec { width: W as u32, height: H as u32, color: ColorMode::Gray };
    Dataset::from_features(Manifest::new(".", space, names, poses).unwrap(), spec, f).unwrap()
}

fn train_set() -> Dataset {
    grid(&[30.0, 40.0, 50.0, 60.0, 70.0], &(0..24).map(|k| 15.0 * k as f64).collect::<Vec<_>>())
}

#[test]
fn training_poses_are_recovered() {
    let d = train_set();
    let model = RefinedParams::default().components(8).fit(&d).unwrap();
    let est = model.predict(d.features()).unwrap();
    for i in 0..d.len() {
        let e = d.space().error_deg(d.pose(i), &est[2 * i..2 * i + 2]);
        assert!(e < 1e-6, "sample {i}: {:?} for {:?}", &est[2 * i..2 * i + 2], d.pose(i));
    }
}

#[test]
fn surface_resamples_to_the_eigenspace_manifold() {
    // The surface at the eigenspace's dense positions gives its manifold points (same spline).
    let d = train_set();
    let pca = crate::eigenspace::pca::fit(&d, Dimension::Fixed(6)).unwrap();
    let g = Grid::new(d.space(), d.poses(), d.manifest().images(), d.manifest().root()).unwrap();
    let dense = crate::eigenspace::manifold::Manifold::build(d.space(), &g, &pca.coords, 6, 5.0).unwrap();
    let knots: Vec<f64> = g.sample_at.iter().flat_map(|&i| pca.coords[i * 6..(i + 1) * 6].iter().copied()).collect();
    let s = surface::Surface::new(d.space(), &g.axes, &knots, 6).unwrap();
    let (mut pose, mut f) = ([0.0; 2], [0.0; 6]);
    let scale = knots.iter().fold(0f64, |a, v| a.max(v.abs()));
    for k in (0..dense.len()).step_by(7) {
        dense.pose(d.space(), k, &mut pose);
        s.clamp(&mut pose);
        s.eval(&pose, &mut f, None);
        for c in 0..6 {
            assert!((f[c] - dense.points[k * 6 + c]).abs() < 1e-5 * scale, "point {k} coordinate {c}");
        }
    }
}

#[test]
fn unseen_views_are_close_and_the_file_round_trips() {
    let d = train_set();
    let model = RefinedParams::default().fit(&d).unwrap();
    assert!(!model.settings().selection.is_empty(), "L is chosen from held-out views");
    let test = grid(&[35.0, 55.0], &[7.5, 100.0, 200.0, 352.5]);
    let est = model.predict(test.features()).unwrap();
    for i in 0..test.len() {
        let e = test.space().error_deg(test.pose(i), &est[2 * i..2 * i + 2]);
        assert!(e < 2.0, "view {i}: error {e}");
    }
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("m.safetensors");
    let any: crate::AnyModel = model.clone().into();
    crate::model_file::save(&any, &path).unwrap();
    let back = crate::model_file::load(&path).unwrap();
    assert!(matches!(back, crate::AnyModel::Refined(_)));
    assert_eq!(back.predict(test.features()).unwrap(), est);
}

#[test]
fn selection_picks_the_least_held_out_error() {
    let d = train_set();
    let g = Grid::new(d.space(), d.poses(), d.manifest().images(), d.manifest().root()).unwrap();
    let (l, scored) = select::choose_components(&d, &g, &RefinedParams::default()).unwrap();
    let best = scored.iter().map(|s| s.1).fold(f64::INFINITY, f64::min);
    let first = scored.iter().find(|s| s.1 == best).unwrap().0;
    assert_eq!(l, first);
}

#[test]
fn bad_parameters_are_errors() {
    let d = train_set();
    assert!(RefinedParams::default().components(0).fit(&d).is_err());
    assert!(RefinedParams::default().starts(0).fit(&d).is_err());
    assert!(RefinedParams::default().resolution(f64::NAN).fit(&d).is_err());
}
