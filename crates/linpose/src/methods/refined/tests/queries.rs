//! Queries through every projection path (f32 and 8-bit, as given and binned, gray and colour)
//! and the route by pixel noise.

use super::*;

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
        crate::pixel_noise::add_uniform_noise(&mut q, m, a, 3).unwrap();
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

/// The small-batch rule (crate::model::split) on the refined path: a batch large enough to be
/// split across threads gives the estimates of the same images in a batch run whole on the
/// calling thread, as given and binned, clean and noisy.
#[test]
fn u8_batches_split_or_whole_give_the_same_estimates() {
    let d = train_set();
    let (test, q8, _) = mixed_queries(|i| i % 3 == 0, 11);
    let (n, m) = (test.len(), test.n_features());
    assert!(!crate::model::split::splits(n, m));
    let copies = crate::model::split::SPLIT_FROM_PIXELS.div_ceil(q8.len()) + 1;
    assert!(crate::model::split::splits(copies * n, m));
    let many = q8.repeat(copies);
    for b in [1, 2] {
        let model = RefinedParams::default().components(8).bin(b).fit(&d).unwrap();
        let (mut whole, mut split) = (vec![0.0; n * 2], vec![0.0; copies * n * 2]);
        model.predict_u8_into(&q8, &mut whole).unwrap();
        model.predict_u8_into(&many, &mut split).unwrap();
        for (c, p) in split.chunks_exact(n * 2).enumerate() {
            assert_eq!(p, &whole[..], "by {b}, copy {c}");
        }
    }
}
