//! Fitting and model files: what a fitted model recovers, keeps and writes.

use super::*;

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
    any.save(&path).unwrap();
    let back = crate::AnyModel::load(&path).unwrap();
    assert!(back.downcast_ref::<RefinedModel>().is_some());
    assert_eq!(back.predict(test.features()).unwrap(), est);
}

#[test]
fn interpolant_names_read_back() {
    assert!("cubic".parse::<Interpolant>().is_err());
    assert_eq!(INTERPOLANTS.iter().map(|i| i.to_string().parse::<Interpolant>().unwrap()).collect::<Vec<_>>(), INTERPOLANTS);
}

#[test]
fn bad_parameters_are_errors() {
    let d = train_set();
    assert!(RefinedParams::default().components(0).fit(&d).is_err());
    assert!(RefinedParams::default().starts(0).fit(&d).is_err());
    assert!(RefinedParams::default().resolution(f64::NAN).fit(&d).is_err());
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
    let pca = crate::manifold::pca::fit(&d, Dimension::Fixed(s.components)).unwrap();
    let want = pca.eigenvalues[s.components..].iter().map(|v| v.max(0.0)).sum::<f64>() / d.len() as f64;
    assert!((s.residual_energy - want).abs() <= 1e-12 * want.max(1e-300), "{} vs {want}", s.residual_energy);
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
    any.save(&path).unwrap();
    let back = crate::AnyModel::load(&path).unwrap();
    assert_eq!(back.meta().settings["bin"], 4);
    assert_eq!(back.predict(test.features()).unwrap(), est);
    // Settings without a factor are damaged, not read as some default.
    for key in ["bin", "bin_selection"] {
        let mut settings = model.meta().settings.clone();
        settings.as_object_mut().unwrap().remove(key);
        assert!(serde_json::from_value::<RefinedSettings>(settings).is_err(), "settings without {key}");
    }
}
