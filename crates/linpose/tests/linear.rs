//! The linear model's claims as identities.
//!
//! Tolerances: the fit is f64 through a Cholesky factorisation of G = X X^T, whose condition
//! number for these smooth synthetic images is below ~1e6, so residuals of ~1e-9 on O(1) labels
//! leave ample margin over machine epsilon (2.2e-16) times that condition number.

use linpose::image_io::{ColorMode, ImageSpec};
use linpose::{Dataset, Estimator, LinearParams, Manifest, Param, PoseModel, PoseSpace};

/// Smooth synthetic images of an elevation and a turntable angle: two Gaussian blobs circling
/// the image centre with the azimuth, raised with the elevation, over a faint fixed texture.
/// Nearby poses look alike and the images are linearly independent.
fn synthetic(n_az: usize, elevations: &[f64], w: u32, h: u32) -> Dataset {
    let space = PoseSpace::new(vec![Param::linear("elevation"), Param::circular("azimuth", 360.0)]).unwrap();
    let mut poses = Vec::new();
    let mut feats = Vec::new();
    let (wf, hf) = (w as f64, h as f64);
    for &el in elevations {
        for a in 0..n_az {
            let az = a as f64 * 360.0 / n_az as f64;
            let r = az.to_radians();
            poses.extend([el, az]);
            let lift = el / 90.0 * 0.3 * hf;
            let blobs = [(0.3, 0.0, 1.0), (0.2, 2.5, 0.6)];
            for y in 0..h {
                for x in 0..w {
                    let (xf, yf) = (x as f64, y as f64);
                    let mut v = 0.05 * (((x * 31 + y * 17) % 7) as f64 / 7.0);
                    for (rad, ph, amp) in blobs {
                        let cx = wf / 2.0 + rad * wf * (r + ph).cos();
                        let cy = hf / 2.0 + 0.25 * hf * (r + ph).sin() - lift;
                        let d2 = ((xf - cx) / wf).powi(2) + ((yf - cy) / hf).powi(2);
                        v += amp * (-d2 / 0.02).exp();
                    }
                    feats.push(v.clamp(0.0, 1.0) as f32);
                }
            }
        }
    }
    Dataset::new(ImageSpec { width: w, height: h, color: ColorMode::Gray }, feats, space, poses).unwrap()
}

#[test]
fn min_norm_model_reproduces_its_training_labels() {
    let data = synthetic(24, &[10.0, 30.0, 50.0], 20, 15);
    let model = LinearParams::default().fit(&data).unwrap();
    let space = data.space();
    let mut want = vec![0.0; space.encoded_len()];
    for i in 0..data.len() {
        space.encode(data.pose(i), &mut want);
        let got = model.predict_encoded_f64(data.row(i));
        for (g, w) in got.iter().zip(&want) {
            assert!((g - w).abs() < 1e-9 * w.abs().max(1.0), "sample {i}: {g} vs {w}");
        }
    }
    // The f32 serving path decodes the training poses to well under a thousandth of a degree.
    let est = model.predict(data.features()).unwrap();
    for i in 0..data.len() {
        let e = space.error_deg(data.pose(i), &est[i * 2..i * 2 + 2]);
        assert!(e < 1e-3, "sample {i}: {e} degrees");
    }
}

#[test]
fn weights_lie_in_the_span_of_the_training_images() {
    // Minimum norm: W = X^T D, so a query orthogonal to every training image estimates 0.
    let data = synthetic(12, &[20.0, 40.0], 8, 6);
    let model = LinearParams::default().fit(&data).unwrap();
    let m = data.n_features();
    // Gram-Schmidt a random vector against the training rows.
    let mut q: Vec<f64> = (0..m).map(|i| ((i * 37 % 11) as f64) - 5.0).collect();
    for _ in 0..2 {
        let rows: Vec<Vec<f64>> = (0..data.len()).map(|i| data.row(i).iter().map(|&v| v as f64).collect()).collect();
        let mut basis: Vec<Vec<f64>> = Vec::new();
        for r in rows {
            let mut v = r.clone();
            for b in &basis {
                let d: f64 = v.iter().zip(b).map(|(a, c)| a * c).sum();
                v.iter_mut().zip(b).for_each(|(a, c)| *a -= d * c);
            }
            let nrm = v.iter().map(|a| a * a).sum::<f64>().sqrt();
            v.iter_mut().for_each(|a| *a /= nrm);
            basis.push(v);
        }
        for b in &basis {
            let d: f64 = q.iter().zip(b).map(|(a, c)| a * c).sum();
            q.iter_mut().zip(b).for_each(|(a, c)| *a -= d * c);
        }
    }
    let w = model.weights();
    for j in 0..3 {
        let p: f64 = w[j * m..(j + 1) * m].iter().zip(&q).map(|(a, b)| a * b).sum();
        assert!(p.abs() < 1e-8, "w_{j} . q = {p}");
    }
}

#[test]
fn small_case_worked_by_hand() {
    // X = [[1,0,1],[0,1,1]], p = [1, 2]: G = [[2,1],[1,2]], d = G^-1 p = [0, 1], w = X^T d = [0,1,1].
    let space = PoseSpace::new(vec![Param::linear("tilt")]).unwrap();
    let spec = ImageSpec { width: 3, height: 1, color: ColorMode::Gray };
    let data = Dataset::new(spec, vec![1.0, 0.0, 1.0, 0.0, 1.0, 1.0], space, vec![1.0, 2.0]).unwrap();
    let model = LinearParams::default().fit(&data).unwrap();
    let w = model.weights();
    for (g, want) in w.iter().zip([0.0, 1.0, 1.0]) {
        assert!((g - want).abs() < 1e-14, "{w:?}");
    }
    assert!((model.predict(&[1.0, 1.0, 0.0]).unwrap()[0] - 1.0).abs() < 1e-6);
    // Ridge lambda: d = (G + lambda I)^-1 p; with lambda = 1, G + I = [[3,1],[1,3]], d = [1/8, 5/8].
    let ridge = LinearParams::default().ridge(1.0).fit(&data).unwrap();
    for (g, want) in ridge.weights().iter().zip([1.0 / 8.0, 5.0 / 8.0, 6.0 / 8.0]) {
        assert!((g - want).abs() < 1e-14, "{:?}", ridge.weights());
    }
}

#[test]
fn centred_model_reproduces_labels_and_has_an_intercept() {
    let data = synthetic(16, &[15.0, 45.0], 10, 8);
    let model = LinearParams::default().center(true).fit(&data).unwrap();
    let mut want = [0.0; 3];
    for i in 0..data.len() {
        data.space().encode(data.pose(i), &mut want);
        for (g, w) in model.predict_encoded_f64(data.row(i)).iter().zip(&want) {
            assert!((g - w).abs() < 1e-9 * w.abs().max(1.0), "sample {i}: {g} vs {w}");
        }
    }
    // A constant image shift moves the uncentred estimate but is absorbed by an intercept only
    // along the mean; the bias is the mean pose minus W^T mean image, non-zero here.
    assert!(model.bias().iter().any(|b| b.abs() > 1e-6));
}

#[test]
fn closed_form_leave_one_out_equals_refitting() {
    let data = synthetic(12, &[20.0, 40.0], 9, 7);
    for params in [LinearParams::default(), LinearParams::default().ridge(0.5)] {
        let loo = params.leave_one_out(&data).unwrap().unwrap();
        for i in [0, 5, 17] {
            let mask: Vec<bool> = (0..data.len()).map(|j| j != i).collect();
            let model = params.fit(&data.subset(&mask).unwrap()).unwrap();
            let enc = model.predict_encoded_f64(data.row(i));
            let mut pose = [0.0; 2];
            data.space().decode(&enc, &mut pose);
            assert!(data.space().error_deg(&pose, &loo[i * 2..i * 2 + 2]) < 1e-7, "{params:?} sample {i}");
        }
    }
}

#[test]
fn duplicate_images_with_different_poses_are_named() {
    let space = PoseSpace::new(vec![Param::circular("azimuth", 360.0)]).unwrap();
    let manifest = Manifest::new(".", space, vec!["a.png".into(), "b.png".into(), "c.png".into()], vec![0.0, 10.0, 20.0]).unwrap();
    let spec = ImageSpec { width: 2, height: 1, color: ColorMode::Gray };
    let data = Dataset::from_features(manifest, spec, vec![0.1, 0.2, 0.3, 0.9, 0.1, 0.2]).unwrap();
    let e = LinearParams::default().fit(&data).unwrap_err().to_string();
    assert!(e.contains("'a.png' and 'c.png' are identical") && e.contains("ridge"), "{e}");
}

#[test]
fn duplicates_are_found_in_8_bit_and_centred_data_and_near_duplicates_are_not() {
    // 40 images of 64 x 48 8-bit values; image 31 repeats image 12.
    let (n, m) = (40, 64 * 48);
    let space = PoseSpace::new(vec![Param::circular("azimuth", 360.0)]).unwrap();
    let spec = ImageSpec { width: 64, height: 48, color: ColorMode::Gray };
    let mut px: Vec<u8> = (0..n * m).map(|i| ((i * 2654435761usize) >> 11) as u8).collect();
    px.copy_within(12 * m..13 * m, 31 * m);
    let poses: Vec<f64> = (0..n).map(|i| i as f64 * 9.0).collect();
    for center in [false, true] {
        let data = Dataset::from_u8(spec, &px, space.clone(), poses.clone()).unwrap();
        let e = LinearParams::default().center(center).fit(&data).unwrap_err().to_string();
        assert!(e.contains("'sample 12' and 'sample 31' are identical"), "centre {center}: {e}");
    }
    // One level apart in one pixel of 3072: not identical, and the fit goes on.
    px[31 * m + 1000] ^= 1;
    let data = Dataset::from_u8(spec, &px, space, poses).unwrap();
    assert!(LinearParams::default().fit(&data).is_ok());
}

#[test]
fn a_data_set_of_8_bit_values_fits_the_model_its_features_fit() {
    // The fit reads the 8-bit values themselves (Gram, weights): the same bits as from the
    // features they make, centred or not.
    let (n, m) = (30, 40 * 32);
    let space = PoseSpace::new(vec![Param::circular("azimuth", 360.0)]).unwrap();
    let spec = ImageSpec { width: 40, height: 32, color: ColorMode::Gray };
    let px: Vec<u8> = (0..n * m).map(|i| ((i * 2654435761usize) >> 13) as u8).collect();
    let poses: Vec<f64> = (0..n).map(|i| i as f64 * 12.0).collect();
    let from_u8 = Dataset::from_u8(spec, &px, space.clone(), poses.clone()).unwrap();
    let features = px.iter().map(|&v| linpose::image_io::feature_of_u8(v)).collect();
    let from_f32 = Dataset::new(spec, features, space, poses).unwrap();
    assert!(from_u8.pixels_u8().is_some() && from_f32.pixels_u8().is_none());
    for params in [LinearParams::default(), LinearParams::default().center(true)] {
        let (a, b) = (params.fit(&from_u8).unwrap(), params.fit(&from_f32).unwrap());
        assert!(a.weights().iter().zip(b.weights()).all(|(x, y)| x.to_bits() == y.to_bits()), "{params:?}");
    }
    assert_eq!(from_u8.features(), from_f32.features());
}

#[test]
fn linearly_dependent_images_are_a_clear_error() {
    // Three images where the third is the sum of the first two: G is singular.
    let space = PoseSpace::new(vec![Param::linear("tilt")]).unwrap();
    let spec = ImageSpec { width: 3, height: 1, color: ColorMode::Gray };
    let data = Dataset::new(spec, vec![0.25, 0.0, 0.5, 0.0, 0.5, 0.25, 0.25, 0.5, 0.75], space, vec![0.0, 1.0, 2.0]).unwrap();
    let e = LinearParams::default().fit(&data).unwrap_err().to_string();
    assert!(e.contains("singular") && e.contains("--ridge"), "{e}");
    assert!(LinearParams::default().ridge(1e-3).fit(&data).is_ok());
}

#[test]
fn invalid_ridge_is_refused() {
    let data = synthetic(8, &[10.0], 4, 4);
    for bad in [-1.0, f64::NAN, f64::INFINITY] {
        let e = LinearParams::default().ridge(bad).fit(&data).unwrap_err().to_string();
        assert!(e.contains("ridge"), "{e}");
    }
}

#[test]
fn model_file_round_trip_keeps_the_estimates() {
    let data = synthetic(16, &[15.0, 45.0], 10, 8);
    let model = LinearParams::default().fit(&data).unwrap();
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("m.safetensors");
    model.save(&path).unwrap();
    let back = linpose::AnyModel::load(&path).unwrap();
    assert_eq!(back.meta(), model.meta());
    assert_eq!(back.predict(data.features()).unwrap(), model.predict(data.features()).unwrap());
    assert_eq!(back.model_bytes(), model.model_bytes());
}

#[test]
fn loo_rule_picks_the_minimum_of_its_curve_and_agrees_with_refitting() {
    use linpose::methods::linear::ridge::RidgeRule;
    let data = synthetic(12, &[20.0, 40.0], 9, 7);
    let model = LinearParams::default().ridge_rule(RidgeRule::Loo).fit(&data).unwrap();
    let s = &model.meta().settings;
    let lambda = s["lambda"].as_f64().unwrap();
    let loo = s["loo_mean_deg"].as_f64().unwrap();
    // The chosen lambda's LOO error, recomputed by the independent closed form of leave_one_out
    // (itself tested against refitting), is the selection's and no worse than lambda = 0's.
    let mean_loo = |params: &LinearParams| {
        let est = params.leave_one_out(&data).unwrap().unwrap();
        (0..data.len()).map(|i| data.space().error_deg(data.pose(i), &est[i * 2..i * 2 + 2])).sum::<f64>() / data.len() as f64
    };
    let at_chosen = mean_loo(&LinearParams::default().ridge(lambda));
    assert!((at_chosen - loo).abs() < 1e-6 * loo.max(1.0), "{at_chosen} vs {loo}");
    assert!(loo <= mean_loo(&LinearParams::default()) + 1e-9);
    // Noise-optimal lambda is N a^2 / 3.
    let m = LinearParams::default().ridge_rule(RidgeRule::Noise(0.1)).fit(&data).unwrap();
    let want = data.len() as f64 * 0.01 / 3.0;
    assert!((m.meta().settings["lambda"].as_f64().unwrap() - want).abs() < 1e-12);
    assert!(LinearParams::default().ridge_rule(RidgeRule::Noise(1.5)).fit(&data).is_err());
}

#[test]
fn noise_aware_training_beats_the_exact_fit_under_clipped_noise() {
    use linpose::methods::linear::ridge::RidgeRule;
    // Blobs on a black background, as a turntable image: clipped noise brightens the background.
    let data = synthetic(36, &[10.0, 30.0, 50.0], 24, 18);
    let mask: Vec<bool> = (0..data.len()).map(|i| (i % 36) % 2 == 0).collect();
    let train = data.subset(&mask).unwrap();
    let plain = LinearParams::default().fit(&train).unwrap();
    let aware = LinearParams::default().ridge_rule(RidgeRule::Noise(0.1)).fit(&train).unwrap();
    let unseen = |m: &dyn PoseModel| linpose::evaluate(m, &data, &linpose::EvalOptions::new(0.1, 7)).unwrap().unseen.unwrap().mean_deg;
    let (p, a) = (unseen(&plain), unseen(&aware));
    assert!(a < 0.8 * p, "noise-aware {a} vs plain {p}");
}
