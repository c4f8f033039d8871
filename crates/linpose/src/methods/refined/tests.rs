//! Tests of the refined eigenspace on synthetic images made here (never /work/shared).

use super::*;
use crate::dataset::Dataset;
use crate::kernels::Level;
use crate::methods::eigenspace::manifold::Grid;
use crate::methods::eigenspace::pca::Dimension;
use crate::model::{Estimator, PoseModel};
use noisy::NoiseScan;
use query::NoiseWant;
use scratch::QueryScratch;
use search::smallest;
use surface::Surface;
use crate::image_io::{ColorMode, ImageSpec};
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
    let pca = crate::methods::eigenspace::pca::fit(&d, Dimension::Fixed(6)).unwrap();
    let g = Grid::new(d.space(), d.poses(), d.manifest().images(), d.manifest().root()).unwrap();
    let dense = crate::methods::eigenspace::manifold::Manifold::build(d.space(), &g, &pca.coords, 6, 5.0).unwrap();
    let knots: Vec<f64> = g.sample_at.iter().flat_map(|&i| pca.coords[i * 6..(i + 1) * 6].iter().copied()).collect();
    let s = surface::Surface::new(d.space(), &g.axes, &knots, 6, surface::Interpolant::Spline).unwrap();
    let (mut pose, mut f) = ([0.0; 2], [0.0; 6]);
    let scale = knots.iter().fold(0f64, |a, v| a.max(v.abs()));
    for k in (0..dense.len()).step_by(7) {
        dense.pose(d.space(), k, &mut pose);
        s.clamp(&mut pose);
        s.eval(&pose, &mut f, None);
        for (c, &v) in f.iter().enumerate().take(6) {
            assert!((v - dense.points[k * 6 + c]).abs() < 1e-5 * scale, "point {k} coordinate {c}");
        }
    }
}

/// Along a knot line of the other axis the surface is the one-axis curve of its interpolant
/// through that line's knots, for either interpolant: the tensor product is wired per axis.
#[test]
fn the_surface_is_each_axis_curve_along_the_knot_lines() {
    use crate::methods::eigenspace::spline::Boundary;
    let d = train_set();
    let g = Grid::new(d.space(), d.poses(), d.manifest().images(), d.manifest().root()).unwrap();
    let shape = g.shape();
    let n: usize = shape.iter().product();
    let v: Vec<f64> = (0..n).map(|i| ((i * 7919) % 1013) as f64 / 500.0 - 1.0).collect();
    let boundary = |j: usize| d.space().params()[j].period.map_or(Boundary::NotAKnot, Boundary::Periodic);
    for interpolant in INTERPOLANTS.iter().copied() {
        let s = surface::Surface::new(d.space(), &g.axes, &v, 1, interpolant).unwrap();
        let line = |j: usize| interpolant.along(&g.axes[j], boundary(j)).unwrap();
        let (l0, l1) = (line(0), line(1));
        let mut f = [0.0];
        for k in 0..shape[0].max(shape[1]) {
            // Along axis 0 at knot k of axis 1, and along axis 1 at knot k of axis 0.
            let y0: Vec<f64> = (0..shape[0]).map(|i| v[i * shape[1] + k.min(shape[1] - 1)]).collect();
            let (lo, hi) = l0.span();
            for q in (k < shape[1]).then_some(0..9).into_iter().flatten() {
                let t = lo + (hi - lo) * (q as f64 + 0.37) / 9.0;
                let mut pose = [t, g.axes[1][k]];
                s.clamp(&mut pose);
                s.eval(&pose, &mut f, None);
                let want = l0.eval(&y0, &l0.slopes(&y0, 1), pose[0]);
                assert!((f[0] - want).abs() < 1e-5, "{interpolant} axis 0 at {pose:?}: {} vs {want}", f[0]);
            }
            if k < shape[0] {
                let y1 = &v[k * shape[1]..(k + 1) * shape[1]];
                let (lo, hi) = l1.span();
                for q in 0..9 {
                    let mut pose = [g.axes[0][k], lo + (hi - lo) * (q as f64 + 0.37) / 9.0];
                    s.clamp(&mut pose);
                    s.eval(&pose, &mut f, None);
                    let want = l1.eval(y1, &l1.slopes(y1, 1), pose[1]);
                    assert!((f[0] - want).abs() < 1e-5, "{interpolant} axis 1 at {pose:?}: {} vs {want}", f[0]);
                }
            }
        }
    }
}

/// Two surfaces on the same knots evaluated together give each one's own bits, values and
/// Jacobians, in full and on fewer coordinates.
#[test]
fn a_pair_of_surfaces_evaluates_as_each_alone() {
    let d = train_set();
    let g = Grid::new(d.space(), d.poses(), d.manifest().images(), d.manifest().root()).unwrap();
    let n = g.sample_at.len();
    let a: Vec<f64> = (0..n * 5).map(|i| ((i * 7919) % 1013) as f64 / 500.0 - 1.0).collect();
    let b: Vec<f64> = (0..n * 5).map(|i| ((i * 104729) % 997) as f64 / 300.0 - 1.5).collect();
    let (sa, sb) = (
        surface::Surface::new(d.space(), &g.axes, &a, 5, surface::Interpolant::Spline).unwrap(),
        surface::Surface::new(d.space(), &g.axes, &b, 5, surface::Interpolant::Spline).unwrap(),
    );
    let bits = |v: &[f64]| v.iter().map(|x| x.to_bits()).collect::<Vec<_>>();
    for (k, lo) in [(0usize, 5usize), (1, 3), (2, 5), (3, 1)] {
        let mut t = [33.3 + 9.1 * k as f64, 17.0 + 71.5 * k as f64];
        sa.clamp(&mut t);
        let (mut f, mut jf, mut gv, mut jg) = (vec![0.0; lo], vec![0.0; 2 * lo], vec![0.0; lo], vec![0.0; 2 * lo]);
        sa.eval_pair(&sb, &t, &mut f, Some(&mut jf), &mut gv, Some(&mut jg));
        let (mut f1, mut jf1, mut g1, mut jg1) = (vec![0.0; lo], vec![0.0; 2 * lo], vec![0.0; lo], vec![0.0; 2 * lo]);
        sa.eval(&t, &mut f1, Some(&mut jf1));
        sb.eval(&t, &mut g1, Some(&mut jg1));
        assert_eq!((bits(&f), bits(&jf), bits(&gv), bits(&jg)), (bits(&f1), bits(&jf1), bits(&g1), bits(&jg1)), "pose {t:?}, {lo} coordinates");
        sa.eval_pair(&sb, &t, &mut f, None, &mut gv, None);
        assert_eq!((bits(&f), bits(&gv)), (bits(&f1), bits(&g1)), "values only");
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
    let any = crate::AnyModel::new(model.clone());
    crate::model_file::save(&any, &path).unwrap();
    let back = crate::model_file::load(&path).unwrap();
    assert!(back.downcast_ref::<RefinedModel>().is_some());
    assert_eq!(back.predict(test.features()).unwrap(), est);
}

#[test]
fn selection_picks_the_least_held_out_error() {
    let d = train_set();
    let g = Grid::new(d.space(), d.poses(), d.manifest().images(), d.manifest().root()).unwrap();
    let c = select::choose(&d, &g, &RefinedParams::default(), 1).unwrap();
    let best = c.scored.iter().map(|s| s.1).fold(f64::INFINITY, f64::min);
    let first = c.scored.iter().find(|s| s.1 == best).unwrap().0;
    assert_eq!(c.components, first);
    // The plain metric is scored too, and a model fitted on these images uses it exactly when
    // it wins.
    let plain = c.plain.expect("the weighted default scores the plain metric");
    assert_eq!(c.least, best.min(plain));
    assert!(c.standard_error > 0.0 && c.standard_error < c.least, "{c:?}");
    let model = RefinedParams::default().bin(1).fit(&d).unwrap();
    assert_eq!(model.settings().plain_error, Some(plain));
    assert_eq!(model.settings().interpolation_variance.is_empty(), plain < best);
    // Unbinned, no candidate's query costs as much as the eigenspace's 20-row product.
    assert!(c.scored.iter().all(|s| s.0 <= 12), "{c:?}");
    assert!(model.components() <= 12, "{}", model.components());
    // Both interpolants are scored on the same folds; the chosen one has the least error (the
    // spline on a tie), and the model fitted on these images interpolates by it.
    assert_eq!(c.by_interpolant.iter().map(|b| b.0).collect::<Vec<_>>(), INTERPOLANTS);
    let least = c.by_interpolant.iter().map(|b| b.1).fold(f64::INFINITY, f64::min);
    assert_eq!(c.least, least);
    assert_eq!(c.interpolant, c.by_interpolant.iter().find(|b| b.1 == least).unwrap().0);
    assert_eq!(model.settings().interpolant, c.interpolant);
    assert_eq!(model.settings().interpolant_selection, c.by_interpolant);
    // Fixed, an interpolant is scored alone, to the same figures.
    for &(i, e) in &c.by_interpolant {
        let f = select::choose(&d, &g, &RefinedParams::default().interpolant(i), 1).unwrap();
        assert_eq!((f.interpolant, &f.by_interpolant[..]), (i, &[(i, e)][..]));
        if i == c.interpolant {
            assert_eq!((&f.scored, f.plain, f.components), (&c.scored, c.plain, c.components));
        }
    }
}

#[test]
fn a_model_written_before_the_interpolant_reads_as_the_spline() {
    let d = train_set();
    let model = RefinedParams::default().bin(2).interpolant(Interpolant::Local).components(8).fit(&d).unwrap();
    let s = model.settings();
    assert_eq!((s.interpolant, s.interpolant_selection.is_empty()), (Interpolant::Local, true));
    let mut v = serde_json::to_value(s).unwrap();
    let o = v.as_object_mut().unwrap();
    o.remove("interpolant").unwrap();
    o.remove("interpolant_selection").unwrap();
    o["params"].as_object_mut().unwrap().remove("interpolant").unwrap();
    let old: RefinedSettings = serde_json::from_value(v).unwrap();
    assert_eq!((old.interpolant, old.params.fixed_interpolant()), (Interpolant::Spline, Some(Interpolant::Spline)));
    assert!("cubic".parse::<Interpolant>().is_err());
    assert_eq!(INTERPOLANTS.iter().map(|i| i.to_string().parse::<Interpolant>().unwrap()).collect::<Vec<_>>(), INTERPOLANTS);
}

#[test]
fn every_knot_is_held_out_once() {
    let d = train_set();
    let g = Grid::new(d.space(), d.poses(), d.manifest().images(), d.manifest().root()).unwrap();
    let shape = g.shape();
    let folds = select::both_folds(&d, &g);
    // The first half are the odd knots' folds (one per usable axis), then the even ones'.
    assert_eq!(folds[..folds.len() / 2], select::folds(&d, &g)[..]);
    for (j, pair) in folds[..folds.len() / 2].iter().zip(&folds[folds.len() / 2..]).enumerate() {
        let axis = (0..shape.len()).filter(|&a| shape[a] >= 4).nth(j).unwrap();
        let circular = d.space().params()[axis].period.is_some();
        let n = shape[axis];
        for (flat, &i) in g.sample_at.iter().enumerate() {
            let k = flat / shape[axis + 1..].iter().product::<usize>() % n;
            let end = !circular && (k == 0 || k == n - 1);
            // Held out in exactly one of the two folds, or (a linear axis's ends) in neither.
            let held = [!pair.0[i], !pair.1[i]];
            assert_eq!(held.iter().filter(|&&h| h).count(), usize::from(!end), "axis {axis} knot {k}");
        }
    }
}

#[test]
fn the_one_standard_error_rule_takes_the_cheapest_within_it() {
    // (mean error, its standard error), costliest first.
    assert_eq!(select::coarsest_within(&[(1.0, 0.1), (1.05, 0.2), (1.2, 0.1)]), (1, 0.1));
    assert_eq!(select::coarsest_within(&[(1.0, 0.1), (1.1, 0.2), (1.05, 0.1)]), (2, 0.1));
    // The least's own standard error sets the tolerance; a tie in the least goes to the first.
    assert_eq!(select::coarsest_within(&[(2.0, 0.5), (1.0, 0.0), (1.0, 0.3)]), (2, 0.0));
    assert_eq!(select::coarsest_within(&[(0.5, 0.0), (0.6, 1.0)]), (0, 0.0));
    // Nothing held out (every error infinite): the cheapest; no candidate: index 0.
    assert_eq!(select::coarsest_within(&[(f64::INFINITY, 0.0), (f64::INFINITY, 0.0)]), (1, 0.0));
    assert_eq!(select::coarsest_within(&[]), (0, 0.0));
    assert_eq!(select::standard_error(&[1.0]), 0.0);
    // [0, 1, 2]: sample standard deviation 1, over sqrt(3).
    assert!((select::standard_error(&[0.0, 1.0, 2.0]) - 1.0 / 3f64.sqrt()).abs() < 1e-15);
    assert_eq!(select::below_eigenspace(1), 12);
    assert_eq!(select::below_eigenspace(2), 20);
    assert_eq!(select::below_eigenspace(4), 20);
}

#[test]
fn bad_parameters_are_errors() {
    let d = train_set();
    assert!(RefinedParams::default().components(0).fit(&d).is_err());
    assert!(RefinedParams::default().starts(0).fit(&d).is_err());
    assert!(RefinedParams::default().resolution(f64::NAN).fit(&d).is_err());
}

#[test]
fn noisy_queries_take_the_affine_match_and_stay_close() {
    let d = train_set();
    // L fixed: no selection, so the weighted metric is kept and the threshold measured.
    let model = RefinedParams::default().components(8).fit(&d).unwrap();
    let thr = model.settings().noise_threshold;
    assert!(thr > 0.0, "the threshold is measured on the training images");
    let test = grid(&[35.0, 55.0], &[7.5, 100.0, 200.0, 352.5]);
    let mut state = 7u64;
    let q: Vec<f32> = test
        .features()
        .iter()
        .map(|&v| {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            (v + 0.05 * (2.0 * (state >> 40) as f32 / (1u64 << 24) as f32 - 1.0)).clamp(0.0, 1.0)
        })
        .collect();
    let spec = test.spec();
    let m = spec.features();
    for x in q.chunks_exact(m) {
        assert!(crate::pixel_noise::pixel_noise(x, spec.width as usize, spec.height as usize, 1) > thr);
    }
    let est = model.predict(&q).unwrap();
    for i in 0..test.len() {
        let e = test.space().error_deg(test.pose(i), &est[2 * i..2 * i + 2]);
        assert!(e < 5.0, "view {i}: error {e}");
    }
}

#[test]
fn clip_bias_shape_is_the_mean_shift_of_clipped_noise() {
    // E[clip(v + n)] - v for n uniform on [-a, a], by the midpoint rule, against (a / 4) times
    // the shape, at the reference amplitude.
    let a = BIAS_AMPLITUDE as f64;
    for v in [0.0, 0.01, 0.05, 0.099, 0.3, 0.5, 0.95, 0.99, 1.0] {
        let k = 200_000;
        let mean: f64 = (0..k).map(|i| (v + a * (2.0 * (i as f64 + 0.5) / k as f64 - 1.0)).clamp(0.0, 1.0)).sum::<f64>() / k as f64;
        let want = (mean - v) / (a / 4.0);
        let got = clip_bias_shape(v as f32) as f64;
        assert!((got - want).abs() < 1e-4, "v = {v}: shape {got}, measured {want}");
    }
}

#[test]
fn the_affine_fit_recovers_gain_and_offset_exactly() {
    let f = [0.3, -1.2, 0.7, 2.0, -0.4];
    let g = [1.0, 0.5, -0.25, 0.0, 2.0];
    let c = [0.1, 0.2, 0.3, 0.4, 0.5];
    let wt = [1.0, 2.0, 0.5, 1.5, 1.0];
    let z: Vec<f64> = (0..5).map(|q| 1.7 * (f[q] + c[q]) - 0.3 * g[q]).collect();
    let (r, ab) = noisy::affine_fit(&z, &c, &wt, &f, &g);
    assert!(r < 1e-12, "residual {r}");
    assert!((ab[0] - 1.7).abs() < 1e-12 && (ab[1] + 0.3).abs() < 1e-12, "{ab:?}");
    // With no offset direction the gain alone is fitted.
    let (r, ab) = noisy::affine_fit(&z[..4], &c[..4], &wt[..4], &f[..4], &[0.0; 4]);
    assert!(ab[1] == 0.0 && r > 0.0);
}

#[test]
fn the_affine_match_recovers_training_poses_under_gain_and_background_offset() {
    // A training view scaled and with its background lifted (what clipped noise does on
    // average) is matched at its own pose by the noisy path, while the clean path is thrown.
    let d = train_set();
    let model = RefinedParams::default().components(8).fit(&d).unwrap();
    let m = d.n_features();
    let mut q = Vec::new();
    for i in [0, 17, 60, 119] {
        q.extend(d.row(i).iter().map(|&v| 0.8 * v + 0.03 * clip_bias_shape(v)));
    }
    let est = model.predict_noisy(&q).unwrap();
    for (k, i) in [0, 17, 60, 119].into_iter().enumerate() {
        let e = d.space().error_deg(d.pose(i), &est[2 * k..2 * k + 2]);
        assert!(e < 0.26, "view {i}: {:?} for {:?}", &est[2 * k..2 * k + 2], d.pose(i));
    }
    assert_eq!(q.len(), 4 * m);
}

#[test]
fn the_noisy_match_is_the_least_held_out_error_under_simulated_noise() {
    let d = train_set();
    let model = RefinedParams::default().fit(&d).unwrap();
    let s = model.settings();
    assert!(!s.noise_selection.is_empty(), "the training grid allows held-out folds");
    let best = s.noise_selection.iter().map(|c| c.2).fold(f64::INFINITY, f64::min);
    let first = s.noise_selection.iter().find(|c| c.2 == best).unwrap();
    assert_eq!((s.noise_components, s.noise_weighted), (first.0, first.1));
    assert_eq!(s.coord_variance.len(), s.components);
    // The choice is made on the training views alone: the same data gives the same model.
    let again = RefinedParams::default().fit(&d).unwrap();
    assert_eq!(again.settings(), s);
}

#[test]
fn the_starts_are_the_smallest_within_twice_the_least() {
    assert_eq!(smallest(&[3.0, 1.0, 1.5, 0.6, 5.0, 1.0], 3), vec![(0.6, 3), (1.0, 1), (1.0, 5)]);
    assert_eq!(smallest(&[3.0, 1.0, 1.5, 0.6, 5.0, 1.0], 1), vec![(0.6, 3)]);
    // An exact match (distance 0) leaves only the exact matches; the least is always kept.
    assert_eq!(smallest(&[0.2, 0.0, 0.1], 8), vec![(0.0, 1)]);
    assert_eq!(smallest(&[7.0; 20].iter().enumerate().map(|(i, v)| v + i as f32).collect::<Vec<_>>(), 2), vec![(7.0, 0), (8.0, 1)]);
}

#[test]
fn the_model_keeps_only_the_eigenimages_its_queries_use() {
    let d = train_set();
    // L fixed: the weighted metric, whose search uses 8 eigenimages (on the images as given,
    // so that the basis is compared with their PCA).
    let model = RefinedParams::default().components(8).bin(1).fit(&d).unwrap();
    let s = model.settings();
    // The clean search's L and the noisy match's L, no more (the eigenspace's 20 were kept
    // before).
    assert!(!s.interpolation_variance.is_empty(), "the weighted metric");
    assert_eq!(s.components, s.search().max(s.noise_components));
    let m = d.n_features();
    let tensors = model.tensors();
    assert_eq!(tensors[0].shape, vec![s.components, m], "basis");
    // The residual energy is the eigenvalues past the L kept.
    let pca = crate::methods::eigenspace::pca::fit(&d, Dimension::Fixed(s.components)).unwrap();
    let want = pca.eigenvalues[s.components..].iter().map(|v| v.max(0.0)).sum::<f64>() / d.len() as f64;
    assert!((s.residual_energy - want).abs() <= 1e-12 * want.max(1e-300), "{} vs {want}", s.residual_energy);
}

#[test]
fn u8_queries_match_f32_queries() {
    // 8-bit queries (clean and with clipped noise, so both matches run), in batches of every
    // size the two product paths take, against the same images as f32 features.
    let d = train_set();
    let model = RefinedParams::default().components(8).fit(&d).unwrap();
    let test = grid(&[35.0, 45.0, 65.0], &(0..8).map(|k| 45.0 * k as f64 + 7.5).collect::<Vec<_>>());
    let mut state = 99u64;
    let mut q8: Vec<u8> = test.features().iter().map(|&v| (v * 255.0).round() as u8).collect();
    let m = test.n_features();
    // Every other view noisy: +-10% uniform, clipped.
    for x in q8.chunks_exact_mut(m).step_by(2) {
        for v in x.iter_mut() {
            state = state.wrapping_mul(6364136223846793005).wrapping_add(1442695040888963407);
            let n = 25.5 * (2.0 * (state >> 40) as f64 / (1u64 << 24) as f64 - 1.0);
            *v = (*v as f64 + n).round().clamp(0.0, 255.0) as u8;
        }
    }
    let qf: Vec<f32> = q8.iter().map(|&v| v as f32 / 255.0).collect();
    let n = test.len();
    for x in q8.chunks_exact(m) {
        let xf: Vec<f32> = x.iter().map(|&v| v as f32 / 255.0).collect();
        let (a, b) = (crate::pixel_noise::pixel_variance_u8(x, W, H, 1) / (255.0 * 255.0), crate::pixel_noise::pixel_variance(&xf, W, H, 1));
        assert!((a - b).abs() <= 1e-5 * b.max(1e-12), "pixel variance {a} vs {b}");
    }
    let pf = model.predict(&qf).unwrap();
    for k in [1, 7, 8, n] {
        let mut p8 = vec![0.0; k * 2];
        model.predict_u8_into(&q8[..k * m], &mut p8).unwrap();
        for i in 0..k {
            let e = test.space().error_deg(&pf[2 * i..2 * i + 2], &p8[2 * i..2 * i + 2]);
            assert!(e < 1e-3, "batch of {k}, view {i}: {:?} vs {:?}", &p8[2 * i..2 * i + 2], &pf[2 * i..2 * i + 2]);
        }
    }
    let mut one = [0.0; 2];
    assert!(model.predict_u8_into(&vec![0u8; m], &mut one).is_err(), "a black image is refused");
    assert!(model.predict_u8_into(&q8[..m - 1], &mut one).is_err(), "a short image is refused");
}
/// The noisy scan's pruned pass gives the full pass's bits at every coarse point within twice
/// the least residual (the only ones the starts are taken from), and rules most others out.
#[test]
fn the_noisy_scan_keeps_every_point_within_twice_the_least() {
    let d = train_set();
    let model = RefinedParams::default().components(12).fit(&d).unwrap();
    // The scan of a model without the noisy tree (this one has it: two parameters on a lattice).
    let ns = &NoiseScan::new(&model, &model.noise_weights(0.0));
    let ln = ns.w0.len();
    assert!(ns.split > 0 && ns.split < ln, "split {} of {ln}", ns.split);
    let n = model.start_len();
    let c: Vec<f64> = model.mean_proj[..ln].iter().map(|&v| v as f64).collect();
    let mut ruled_out = 0;
    for (k, at) in [0usize, n / 3, n / 2, n - 1].into_iter().enumerate() {
        // A coarse point's coordinates, scaled (a gain) and perturbed (noise), mean added back.
        let z: Vec<f64> = (0..ln).map(|q| 0.9 * (model.start_points[q * n + at] as f64 + c[q]) + 0.01 * ((q * 7 + k) % 5) as f64 - 0.02).collect();
        let (mut all, mut pruned, mut v) = (Vec::new(), vec![f32::NAN; 3], Vec::new());
        ns.scan_all(&model.start_points, &model.bg_start, &z, &c, &mut all, &mut v);
        // Scratch reused from another query: every value is written.
        ns.scan(&model.start_points, &model.bg_start, &z, &c, &mut pruned, &mut v);
        assert_eq!(pruned.len(), n);
        let lo = all.iter().cloned().fold(f32::INFINITY, f32::min);
        for i in 0..n {
            if pruned[i] == f32::INFINITY && all[i] > 2.0 * lo {
                ruled_out += 1;
            } else {
                assert_eq!(pruned[i].to_bits(), all[i].to_bits(), "point {i}, query {k}");
            }
        }
    }
    assert!(ruled_out > n, "only {ruled_out} of {} ruled out", 4 * n);
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

#[test]
fn on_a_turntable_the_plain_metric_finds_the_eigenspace_manifold_point() {
    // One pose parameter: the clean search is the exact lattice search (every 0.5-degree pose
    // of the spline curve, lattice::Lattice), so with the eigenspace's metric and L it picks
    // the eigenspace's own nearest manifold point (the same spline resampled on the same lattice).
    let train = turntable(&(0..24).map(|k| 15.0 * k as f64).collect::<Vec<_>>());
    let queries = turntable(&(0..120).map(|k| 3.0 * k as f64 + 0.7).collect::<Vec<_>>());
    let refined = RefinedParams::default().components(6).weighted(false).fit(&train).unwrap();
    assert!(refined.lattice.is_some(), "a one-parameter model searches its lattice");
    let eigen = crate::methods::eigenspace::EigenspaceParams::default().components(6).fit(&train).unwrap();
    let (a, b) = (refined.predict(queries.features()).unwrap(), eigen.predict(queries.features()).unwrap());
    assert_eq!(a, b);
    // Off the lattice (resolution 0) the local search runs instead, and lands within a lattice
    // step of the lattice search's pose.
    let continuous = RefinedParams::default().components(6).weighted(false).resolution(0.0).fit(&train).unwrap();
    assert!(continuous.lattice.is_none());
    // A lattice past MAX_LATTICE poses keeps the local search too.
    let fine = RefinedParams::default().components(6).weighted(false).resolution(360.0 / (MAX_LATTICE + 1) as f64).fit(&train).unwrap();
    assert!(fine.lattice.is_none());
    let coarse = RefinedParams::default().components(6).weighted(false).resolution(360.0 / MAX_LATTICE as f64).fit(&train).unwrap();
    assert!(coarse.lattice.is_some());
    let c = continuous.predict(queries.features()).unwrap();
    for (i, (x, y)) in a.iter().zip(&c).enumerate() {
        assert!(queries.space().error_deg(&[*x], &[*y]) <= 0.5, "query {i}: {x} against {y}");
    }
}

#[test]
fn the_noise_threshold_separates_clean_and_noisy_training_views() {
    let d = train_set();
    let spec = d.spec();
    let (w, h, m) = (spec.width as usize, spec.height as usize, d.n_features());
    let t = select::noise_threshold(&d).unwrap();
    let clean = (0..d.len()).map(|i| crate::pixel_noise::pixel_noise(d.row(i), w, h, 1)).fold(0.0, f64::max);
    assert_eq!(t.clean, clean, "the noisiest clean training view");
    assert!(t.noisy > 2.0 * t.clean, "simulated +-5% noise stands well above the clean views: {t:?}");
    assert!((t.threshold / (t.clean * t.noisy).sqrt() - 1.0).abs() < 1e-12, "{t:?}");
    assert!(t.clean < t.threshold && t.threshold < t.noisy, "{t:?}");
    // Other noise draws at the smallest level land above it too.
    for seed in [1, 2, 3] {
        let mut q = d.features().to_vec();
        crate::eval::add_uniform_noise(&mut q, m, select::NOISE_LEVELS[0], seed).unwrap();
        for x in q.chunks_exact(m) {
            assert!(crate::pixel_noise::pixel_noise(x, w, h, 1) > t.threshold);
        }
    }
    let model = RefinedParams::default().components(8).fit(&d).unwrap();
    assert_eq!(model.settings().noise_threshold, t.threshold, "the model keeps the threshold");
    // No separation, or nothing measured: the clean maximum (0 turns detection off).
    assert_eq!(select::separating(1e-4, 4e-4), 2e-4);
    assert_eq!(select::separating(4e-4, 1e-4), 4e-4);
    assert_eq!(select::separating(4e-4, f64::INFINITY), 4e-4);
    assert_eq!(select::separating(0.0, 1e-3), 0.0);
}

/// The weighted squared distance from `y` to the surface at pose `t` (the first `wt.len()`
/// coordinates).
fn dist_at(s: &Surface, y: &[f32], wt: &[f64], t: &[f64]) -> f64 {
    let mut f = vec![0.0; y.len()];
    s.eval(t, &mut f, None);
    y.iter().zip(&f).zip(wt).map(|((&a, &b), &w)| w * (a as f64 - b) * (a as f64 - b)).sum()
}

#[test]
fn the_climb_ends_on_the_lattice_at_a_local_least() {
    let d = train_set();
    let model = RefinedParams::default().components(8).fit(&d).unwrap();
    let (s, l) = (&model.surface, model.components());
    let wt: Vec<f64> = (0..l).map(|c| 1.0 / (1.0 + c as f64)).collect();
    let mut f = vec![0.0; l];
    let step = 0.5;
    for (k, q) in [[33.3, 17.2], [50.0, 359.9], [68.8, 181.0], [30.0, 0.0], [70.0, 90.25]].iter().enumerate() {
        // A query off the lattice: the surface at a pose between lattice points, perturbed.
        s.eval(q, &mut f, None);
        let y: Vec<f32> = f.iter().enumerate().map(|(c, &v)| (v + 1e-3 * ((c + k) % 3) as f64) as f32).collect();
        for start in [[30.0, 0.0], [45.5, 12.0], [70.0, 359.5], [q[0] - q[0] % 0.5, q[1] - q[1] % 0.5]] {
            let mut t = start;
            let got = s.climb(&y, &wt, &mut t, step);
            // The climb sums the surface in another order than eval: equal to rounding.
            let at = dist_at(s, &y, &wt, &t);
            assert!((got - at).abs() <= 1e-12 * at, "start {start:?}: {got} against {at}");
            assert!(t.iter().all(|v| (v / step).fract() == 0.0), "on the lattice: {t:?}");
            assert!((30.0..=70.0).contains(&t[0]) && (0.0..360.0).contains(&t[1]), "in the domain: {t:?}");
            // No neighbour (azimuth wrapping, elevation inside its range) is closer.
            for de in [-step, 0.0, step] {
                for da in [-step, 0.0, step] {
                    let n = [t[0] + de, (t[1] + da).rem_euclid(360.0)];
                    if (30.0..=70.0).contains(&n[0]) {
                        assert!(dist_at(s, &y, &wt, &n) >= got * (1.0 - 1e-12), "start {start:?}: {t:?} has a closer neighbour {n:?}");
                    }
                }
            }
        }
    }
}

#[test]
fn a_clean_two_parameter_search_starts_from_the_coarse_tree() {
    let d = train_set();
    let model = RefinedParams::default().components(8).fit(&d).unwrap();
    let c = model.tree.as_ref().expect("two parameters reported on a lattice");
    // The lattice of twice the reporting step, anchored at the first knots: 41 elevations of
    // 30..70 by 1, 360 azimuths.
    assert_eq!(c.poses.len(), 41 * 360 * 2);
    assert_eq!((&c.poses[..2], &c.poses[c.poses.len() - 2..]), (&[30.0, 0.0][..], &[70.0, 359.0][..]));
    // Each coarse pose's point is the surface there, so a query at a coarse pose finds it.
    let ls = model.settings().search();
    let mut f = vec![0.0; ls];
    for i in [0, 7, 360 * 20 + 123, c.poses.len() / 2 - 1] {
        model.surface.eval(&c.poses[2 * i..2 * i + 2], &mut f, None);
        let y: Vec<f32> = f.iter().map(|&v| v as f32).collect();
        assert_eq!(c.tree.nearest(&y), i);
    }
    // Continuous estimates and turntables keep their own searches.
    assert!(RefinedParams::default().components(8).resolution(0.0).fit(&d).unwrap().tree.is_none());
    assert!(RefinedParams::default().components(8).fit(&turntable(&(0..24).map(|k| 15.0 * k as f64).collect::<Vec<_>>())).unwrap().tree.is_none());
}

#[test]
fn the_block_climb_walks_as_the_point_by_point_climb() {
    // Surface::climb_pair evaluates 3 x 3 lattice points at a time, summed in another order
    // than eval: the same walk, to the same lattice point, at the same cost to rounding, on a
    // plain distance and on the affine match of a pair of surfaces.
    let d = train_set();
    let model = RefinedParams::default().components(8).fit(&d).unwrap();
    let (s, bg, l) = (&model.surface, &model.bg_surface, model.components());
    let wt: Vec<f64> = (0..l).map(|c| 1.0 / (1.0 + c as f64)).collect();
    let c: Vec<f64> = model.mean_proj.iter().map(|&v| v as f64).collect();
    let (mut f, mut g) = (vec![0.0; l], vec![0.0; l]);
    for (k, q) in [[33.3, 17.2], [50.0, 359.9], [68.8, 181.0], [30.0, 0.0], [70.0, 90.25]].iter().enumerate() {
        s.eval_pair(bg, q, &mut f, None, &mut g, None);
        let y: Vec<f32> = f.iter().enumerate().map(|(i, &v)| (v + 1e-3 * ((i + k) % 3) as f64) as f32).collect();
        let z: Vec<f64> = (0..l).map(|i| 0.8 * (f[i] + c[i]) + 0.05 * g[i] + 1e-3 * ((i + k) % 3) as f64).collect();
        let aq = noisy::AffineQuery::new(&z, &c, &wt);
        for start in [[30.0, 0.0], [45.5, 12.0], [70.0, 359.5], [q[0] - q[0] % 0.5, q[1] - q[1] % 0.5]] {
            let (mut a, mut b) = (start, start);
            let ca = s.climb(&y, &wt, &mut a, 0.5);
            let cb = s.climb_by(&mut b, 0.5, |t| dist_at(s, &y, &wt, t));
            assert_eq!(a, b, "plain, start {start:?}");
            assert!((ca - cb).abs() <= 1e-12 * cb, "{ca} against {cb}");
            let (mut a, mut b) = (start, start);
            let ca = s.climb_pair(Some(bg), l, &mut a, 0.5, |fv, gv| aq.residual(fv, gv));
            let cb = s.climb_by(&mut b, 0.5, |t| {
                s.eval_pair(bg, t, &mut f, None, &mut g, None);
                noisy::affine_fit(&z, &c, &wt, &f, &g).0
            });
            assert_eq!(a, b, "affine, start {start:?}");
            // The residual is z.z less the fit: rounding relative to z.z.
            let zz: f64 = z.iter().zip(&wt).map(|(v, w)| w * v * v).sum();
            assert!((ca - cb).abs() <= 1e-12 * zz, "{ca} against {cb} (z.z {zz})");
        }
    }
}

#[test]
fn a_noisy_two_parameter_query_starts_from_the_noisy_tree() {
    // With two parameters on a lattice the noisy match starts from its own tree: a surface
    // point at a coarse pose, with a gain and an offset along g, starts at that pose or next to
    // it (the tree removes the offset's mean direction, not g at the pose) and the climb ends
    // there; on
    // a query halfway between two poses a half turn apart both basins are climbed.
    let d = train_set();
    let model = RefinedParams::default().components(8).fit(&d).unwrap();
    let (nt, ct) = (model.noisy_tree.as_ref().expect("noisy tree"), model.tree.as_ref().unwrap());
    assert!(model.noise_scan.w0.is_empty(), "the coarse scan is not built beside the tree");
    let ln = nt.scale.len();
    let c: Vec<f64> = model.mean_proj[..ln].iter().map(|&v| v as f64).collect();
    let (mut f, mut g) = (vec![0.0; ln], vec![0.0; ln]);
    let n = ct.poses.len() / 2;
    for i in [0, n / 7, n / 2, n - 1] {
        let t = &ct.poses[2 * i..2 * i + 2];
        model.surface.eval_pair(&model.bg_surface, t, &mut f, None, &mut g, None);
        let z: Vec<f64> = (0..ln).map(|q| 0.85 * (f[q] + c[q]) + 0.04 * g[q]).collect();
        let (start, _) = nt.starts(&z, &ct.poses).unwrap();
        let st = &ct.poses[2 * start..2 * start + 2];
        assert!(d.space().error_deg(t, st) <= 1.5, "coarse pose {t:?}: start {st:?}");
        // Through the whole noisy path (coordinates without the mean).
        let y: Vec<f32> = (0..model.components()).map(|q| if q < ln { (z[q] - c[q]) as f32 } else { 0.0 }).collect();
        let mut out = [0.0; 2];
        model.pose_of_noisy(&y, 0.0, &mut out);
        assert!(d.space().error_deg(t, &out) <= 0.5, "coarse pose {t:?}: {out:?}");
    }
    // The average of the points at two poses a half turn apart lies as close to both.
    let (mut f2, mut g2) = (vec![0.0; ln], vec![0.0; ln]);
    model.surface.eval_pair(&model.bg_surface, &[50.0, 40.0], &mut f, None, &mut g, None);
    model.surface.eval_pair(&model.bg_surface, &[50.0, 220.0], &mut f2, None, &mut g2, None);
    let z: Vec<f64> = (0..ln).map(|q| 0.5 * (f[q] + f2[q]) + c[q]).collect();
    let (first, second) = nt.starts(&z, &ct.poses).unwrap();
    let second = second.expect("a second basin within twice the distance");
    let gap = (ct.poses[2 * first + 1] - ct.poses[2 * second + 1]).abs();
    assert!(gap.min(360.0 - gap) > nt.apart[1] || (ct.poses[2 * first] - ct.poses[2 * second]).abs() > nt.apart[0], "{first} and {second} apart");
}
/// A query routed by the staged pixel-noise estimate gets the pose the whole estimate gives it
/// (f32 and 8-bit, clean and under +-5% and +-10% noise), and clean queries do stop after the
/// first pass: images 6 times as tall as the others here, so that 9 rows are sampled.
#[test]
fn the_staged_noise_estimate_routes_queries_as_the_whole_one() {
    let azim: Vec<f64> = (0..24).map(|k| 15.0 * k as f64).collect();
    let d = grid_tiled(&[30.0, 40.0, 50.0, 60.0, 70.0], &azim, 6);
    let model = RefinedParams::default().components(8).fit(&d).unwrap();
    let t = model.settings().noise_threshold;
    assert!(t > 0.0);
    let test = grid_tiled(&[35.0, 55.0], &[7.5, 100.0, 200.0, 352.5], 6);
    let spec = test.spec();
    let (w, h, m) = (spec.width as usize, spec.height as usize, test.n_features());
    assert!(crate::pixel_noise::sampled_rows(h) >= 2 * crate::pixel_noise::FIRST_EVERY);
    let mut stopped = 0;
    for a in [0.0, 0.05, 0.1] {
        let mut q = test.features().to_vec();
        crate::eval::add_uniform_noise(&mut q, m, a, 3).unwrap();
        let q8: Vec<u8> = q.iter().map(|&v| (v * 255.0).round() as u8).collect();
        let p = test.space().len();
        let (mut route, mut whole) = (vec![0.0; test.len() * p], vec![0.0; test.len() * p]);
        model.predict_with(&q, NoiseWant::Route, &mut route).unwrap();
        model.predict_with(&q, NoiseWant::Full, &mut whole).unwrap();
        assert_eq!(route, whole, "f32 at +-{a}");
        model.predict_u8_with(&q8, NoiseWant::Route, &mut route).unwrap();
        model.predict_u8_with(&q8, NoiseWant::Full, &mut whole).unwrap();
        assert_eq!(route, whole, "8-bit at +-{a}");
        for x in q.chunks_exact(m) {
            let energy = crate::linalg::energy(x);
            let early = model.early(NoiseWant::Route, energy, m).unwrap();
            let staged = crate::pixel_noise::pixel_variance_in(x, w, h, 1, &mut crate::pixel_noise::RowsF32::new(w, h, 1), early);
            let full = crate::pixel_noise::pixel_variance(x, w, h, 1);
            // The route's comparison: noise per unit energy times M against the threshold.
            let noisy = full * m as f64 / energy > t;
            assert_eq!(noisy, a > 0.0, "+-{a}: the whole estimate routes it");
            if staged != full {
                assert!(!noisy && staged < early, "+-{a}: only a clean query stops, under its early level");
                stopped += 1;
            }
        }
    }
    assert!(stopped > 0, "some clean queries stop after the first pass");
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

#[test]
fn a_binned_model_searches_as_a_model_of_the_binned_images() {
    // Clean queries: the same eigenspace of the same binned images, so the same poses as a
    // model fitted on images binned beforehand, given the images as they are.
    let d = train_set();
    let test = grid(&[35.0, 55.0], &[7.5, 100.0, 200.0, 352.5]);
    let a = RefinedParams::default().components(8).bin(2).fit(&d).unwrap();
    let b = RefinedParams::default().components(8).fit(&binned(&d, 2)).unwrap();
    assert_eq!(a.meta().spec, d.spec(), "the model takes images as given");
    assert_eq!((a.settings().bin, a.settings().params.fixed_bin()), (2, Some(2)));
    assert_eq!(a.predict(test.features()).unwrap(), b.predict(binned(&test, 2).features()).unwrap());
    // A query's noise is measured on the image as given: the threshold is that of a model
    // that does not bin, and +-5% noise on the images routes every query to the noisy match.
    let plain = RefinedParams::default().components(8).fit(&d).unwrap();
    let ta = a.settings().noise_threshold;
    assert!(ta > 0.0 && ta == plain.settings().noise_threshold, "threshold {ta}");
    let q = with_noise(test.features(), 0.05, 11);
    let s = d.spec();
    for x in q.chunks_exact(s.features()) {
        assert!(crate::pixel_noise::pixel_noise(x, s.width as usize, s.height as usize, 1) > ta);
    }
    let est = a.predict(&q).unwrap();
    for i in 0..test.len() {
        let e = test.space().error_deg(test.pose(i), &est[2 * i..2 * i + 2]);
        assert!(e < 5.0, "noisy view {i}: error {e}");
    }
    // Training poses are recovered.
    let own = a.predict(d.features()).unwrap();
    for i in 0..d.len() {
        assert!(d.space().error_deg(d.pose(i), &own[2 * i..2 * i + 2]) < 1e-6, "training view {i}");
    }
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

#[test]
fn binned_u8_queries_match_f32_queries() {
    // The 8-bit path's block sums (16-bit products where VNNI runs, two digit planes elsewhere)
    // against the f32 path's binned features, clean and noisy, in batches of every size the
    // product paths take, and on one thread three times the views (tasks of more than one
    // sub-chunk), by 2 (the AVX-512 binning where there is one) and by 3 (the portable one).
    let d = train_set();
    let (test, q8, qf) = mixed_queries(|i| i % 2 == 0, 5);
    let m = test.n_features();
    let n = test.len();
    for b in [2, 3] {
        let model = RefinedParams::default().components(8).bin(b).fit(&d).unwrap();
        let pf = model.predict(&qf).unwrap();
        for k in [1, 3, 4, 8, n] {
            let mut p8 = vec![0.0; k * 2];
            model.predict_u8_into(&q8[..k * m], &mut p8).unwrap();
            for i in 0..k {
                let e = test.space().error_deg(&pf[2 * i..2 * i + 2], &p8[2 * i..2 * i + 2]);
                assert!(e < 1e-3, "by {b}, batch of {k}, view {i}: {:?} vs {:?}", &p8[2 * i..2 * i + 2], &pf[2 * i..2 * i + 2]);
            }
        }
        let thrice = q8.repeat(3);
        let mut p8 = vec![0.0; 3 * n * 2];
        let one = rayon::ThreadPoolBuilder::new().num_threads(1).build().unwrap();
        one.install(|| model.predict_u8_into(&thrice, &mut p8)).unwrap();
        for (i, p) in p8.chunks_exact(2).enumerate() {
            let f = &pf[2 * (i % n)..2 * (i % n) + 2];
            assert!(test.space().error_deg(f, p) < 1e-3, "by {b}, one thread, query {i}: {p:?} vs {f:?}");
        }
        let mut one = [0.0; 2];
        assert!(model.predict_u8_into(&vec![0u8; m], &mut one).is_err(), "a black image is refused");
        assert!(model.predict_u8_into(&q8[..m - 1], &mut one).is_err(), "a short image is refused");
        assert!(model.predict(&qf[..m / 4]).is_err(), "a binned-size image is refused");
    }
}

#[test]
fn the_binning_factor_is_checked_and_kept_in_the_file() {
    let d = train_set();
    for b in [0, 5, 17] {
        let e = RefinedParams::default().components(8).bin(b).fit(&d).unwrap_err().to_string();
        assert!(e.contains("bin") && e.contains(&b.to_string()), "{e}");
    }
    let model = RefinedParams::default().components(8).bin(4).fit(&d).unwrap();
    let test = grid(&[35.0, 55.0], &[7.5, 100.0, 200.0, 352.5]);
    let est = model.predict(test.features()).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("m.safetensors");
    let any = crate::AnyModel::new(model.clone());
    crate::model_file::save(&any, &path).unwrap();
    let back = crate::model_file::load(&path).unwrap();
    assert_eq!(back.meta().settings["bin"], 4);
    assert_eq!(back.predict(test.features()).unwrap(), est);
    // A model written before binning existed has no factor: it takes images as they are.
    let mut settings = model.meta().settings.clone();
    settings["params"].as_object_mut().unwrap().remove("bin");
    settings.as_object_mut().unwrap().remove("bin");
    settings.as_object_mut().unwrap().remove("bin_selection");
    let old: RefinedSettings = serde_json::from_value(settings).unwrap();
    assert_eq!((old.bin, old.params.fixed_bin()), (1, Some(1)));
}

#[test]
fn the_automatic_binning_factor_is_the_coarsest_within_a_standard_error() {
    let d = train_set();
    let model = RefinedParams::default().auto_bin().fit(&d).unwrap();
    let s = model.settings();
    // 32 x 12 images: by 4 they keep 8 x 3 pixels, so all three candidates are scored.
    let factors: Vec<usize> = s.bin_selection.iter().map(|c| c.0).collect();
    assert_eq!(factors, BIN_CANDIDATES);
    // The coarsest within one standard error of the least (that least's own, recorded).
    let least = s.bin_selection.iter().map(|c| c.1).fold(f64::INFINITY, f64::min);
    let chosen = s.bin_selection.iter().rev().find(|c| c.1 <= least + s.bin_tolerance).unwrap().0;
    assert_eq!(s.bin, chosen, "{:?} {}", s.bin_selection, s.bin_tolerance);
    let b_least = s.bin_selection.iter().find(|c| c.1 == least).unwrap().0;
    let images = if b_least == 1 { d.clone() } else { binned(&d, b_least) };
    let g = Grid::new(images.space(), images.poses(), images.manifest().images(), images.manifest().root()).unwrap();
    let c = select::choose(&images, &g, &RefinedParams::default().bin(1), b_least).unwrap();
    assert_eq!((c.least, c.standard_error), (least, s.bin_tolerance));
    assert!(s.bin_tolerance > 0.0);
    // Each candidate's score is what the choice of L on its images gives.
    for &(b, e) in &s.bin_selection {
        let fixed = RefinedParams::default().bin(b).fit(&d).unwrap();
        let f = fixed.settings();
        let want = f.selection.iter().map(|c| c.1).chain(f.plain_error).fold(f64::INFINITY, f64::min);
        assert_eq!(e, want, "factor {b}");
        if b == s.bin {
            let test = grid(&[35.0, 55.0], &[7.5, 100.0, 200.0, 352.5]);
            assert_eq!(model.predict(test.features()).unwrap(), fixed.predict(test.features()).unwrap());
        }
    }
    // Too small an image for a factor leaves it out.
    let tiny = binned(&d, 2);
    let t = RefinedParams::default().auto_bin().fit(&tiny).unwrap();
    assert_eq!(t.settings().bin_selection.iter().map(|c| c.0).collect::<Vec<_>>(), [1, 2]);
}

/// `d` as colour images: each gray value v becomes (v, 0.7 v, 0.4 v + 0.1 on lit pixels), so the
/// three channels differ and are binned apart.
fn colour(d: &Dataset) -> Dataset {
    let f = d.features().iter().flat_map(|&v| [v, 0.7 * v, if v > 0.0 { 0.4 * v + 0.1 } else { 0.0 }]).collect();
    let spec = ImageSpec { color: ColorMode::Rgb, ..d.spec() };
    Dataset::from_features(d.manifest().clone(), spec, f).unwrap()
}

#[test]
fn binned_colour_u8_queries_match_f32_queries() {
    // Colour images binned channel by channel (the portable binning, then the 16-bit products
    // where VNNI runs): 8-bit queries against the f32 path, and the training poses recovered.
    let d = colour(&train_set());
    let test = colour(&grid(&[35.0, 65.0], &[7.5, 100.0, 200.0, 352.5]));
    let q8: Vec<u8> = test.features().iter().map(|&v| (v * 255.0).round() as u8).collect();
    let qf: Vec<f32> = q8.iter().map(|&v| v as f32 * crate::kernels::levels::S8).collect();
    for b in [2, 3] {
        let model = RefinedParams::default().components(8).bin(b).fit(&d).unwrap();
        assert_eq!(model.meta().spec.color, ColorMode::Rgb);
        let own = model.predict(d.features()).unwrap();
        for i in 0..d.len() {
            assert!(d.space().error_deg(d.pose(i), &own[2 * i..2 * i + 2]) < 1e-6, "by {b}, training view {i}");
        }
        let pf = model.predict(&qf).unwrap();
        let mut p8 = vec![0.0; test.len() * 2];
        model.predict_u8_into(&q8, &mut p8).unwrap();
        for i in 0..test.len() {
            let e = test.space().error_deg(&pf[2 * i..2 * i + 2], &p8[2 * i..2 * i + 2]);
            assert!(e < 1e-3, "by {b}, view {i}: {:?} vs {:?}", &p8[2 * i..2 * i + 2], &pf[2 * i..2 * i + 2]);
        }
    }
}

/// A model whose noisy match uses more eigenimages than its clean search (L_s = 4 here) computes
/// those extra coordinates for the queries routed to the noisy match only: on every projection
/// path (f32 and 8-bit, as given and binned by 2, batches of 1, 7 and every view, clean and
/// +-10% noisy views mixed), a noisy query's L coordinates and a clean query's L_s are the
/// query's projection on the file's basis and mean (its other coordinates 0), the route is the
/// one the search takes, and the poses are those of each query alone.
#[test]
fn the_noisy_match_s_extra_coordinates_serve_its_queries_only() {
    let d = train_set();
    let (test, q8, qf) = mixed_queries(|i| i % 3 != 1, 17);
    let m = test.n_features();
    let noisy: Vec<bool> = (0..test.len()).map(|i| i % 3 != 1).collect();
    for b in [1, 2] {
        let model = RefinedParams::default().components(4).bin(b).fit(&d).unwrap();
        let (l, ls) = (model.components(), model.settings().search());
        assert!(ls == 4 && model.extra_rows() == l - ls && l > ls && model.settings().noise_threshold > 0.0, "bin {b}: L {l}, L_s {ls}");
        // The reference: the file's basis and mean, in f64, on the (binned) f32 images.
        let t = model.tensors();
        let f32s = |d: &crate::model::TensorData| match d {
            crate::model::TensorData::F32(v) => v.clone(),
            crate::model::TensorData::F64(_) => panic!("f32 tensors"),
        };
        let (basis, mean) = (f32s(&t[0].data), f32s(&t[1].data));
        let mb = model.m;
        let xs: Vec<f32> = if b > 1 { model.binning.apply_all(&qf) } else { qf.clone() };
        let want: Vec<Vec<f64>> = xs
            .chunks_exact(mb)
            .map(|x| {
                let norm = x.iter().map(|&v| v as f64 * v as f64).sum::<f64>().sqrt();
                basis.chunks_exact(mb).map(|u| u.iter().zip(x.iter().zip(&mean)).map(|(&u, (&x, &c))| u as f64 * (x as f64 / norm - c as f64)).sum()).collect()
            })
            .collect();
        let check = |s: &QueryScratch, path: &str, tol: f64| {
            for (i, (y, w)) in s.y.chunks_exact(l).zip(&want).enumerate() {
                assert_eq!(s.noisy[i], noisy[i], "bin {b} {path}: view {i} routed");
                let scale = w.iter().fold(0f64, |a, v| a.max(v.abs()));
                for c in 0..l {
                    let w = if c < ls || noisy[i] { w[c] } else { 0.0 };
                    assert!((y[c] as f64 - w).abs() <= tol * scale, "bin {b} {path}: view {i} coordinate {c}: {} vs {w}", y[c]);
                }
            }
        };
        let n = test.len();
        for k in [1, 7, n] {
            let mut s = QueryScratch::default();
            model.project_binned(&qf[..k * m], NoiseWant::Route, &mut s);
            if k == n {
                check(&s, "f32", 1e-4);
            }
            let level = Level::detect();
            let mut s8 = QueryScratch::default();
            if b > 1 {
                model.project_u8_binned(level, &q8[..k * m], NoiseWant::Route, &mut s8);
            } else {
                model.project_u8(level, &q8[..k * m], NoiseWant::Route, &mut s8);
            }
            if k == n {
                check(&s8, "8-bit", 2e-3);
            }
            // Poses of the batch against each query alone.
            let p = test.space().len();
            let (mut batch, mut batch8) = (vec![0.0; k * p], vec![0.0; k * p]);
            model.predict_into(&qf[..k * m], &mut batch).unwrap();
            model.predict_u8_into(&q8[..k * m], &mut batch8).unwrap();
            for i in 0..k {
                let mut one = vec![0.0; p];
                model.predict_into(&qf[i * m..(i + 1) * m], &mut one).unwrap();
                assert_eq!(&batch[i * p..(i + 1) * p], &one[..], "bin {b}: batch of {k}, view {i}");
                model.predict_u8_into(&q8[i * m..(i + 1) * m], &mut one).unwrap();
                assert_eq!(&batch8[i * p..(i + 1) * p], &one[..], "bin {b} 8-bit: batch of {k}, view {i}");
            }
        }
    }
}
