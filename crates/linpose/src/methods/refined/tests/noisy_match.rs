//! The noisy match: the offset direction, the affine fit, the noisy scan and tree.

use super::*;

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
