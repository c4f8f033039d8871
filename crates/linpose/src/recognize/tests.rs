//! The recognition rule on distances given by hand; the recognisers on rendered objects are in
//! `tests/recognize.rs`.

use super::*;

#[test]
fn the_nearest_object_wins_and_beyond_its_threshold_the_query_is_unknown() {
    let r = Recognition::from_distances(&[0.5, 0.2, 0.4], &[1.0, 0.3, 1.0]);
    assert_eq!((r.object, r.nearest, r.distance, r.second, r.threshold), (Some(1), 1, 0.2, 0.4, 0.3));
    assert!((r.confidence - 0.75).abs() < 1e-12);
    // Beyond object 1's threshold, though within the others': unknown, the nearest still named.
    let r = Recognition::from_distances(&[0.5, 0.35, 0.4], &[1.0, 0.3, 1.0]);
    assert_eq!((r.object, r.nearest), (None, 1));
    // A tie goes to the lower index, with no margin; one object has no second.
    let r = Recognition::from_distances(&[0.2, 0.2], &[1.0, 1.0]);
    assert_eq!((r.object, r.confidence), (Some(0), 0.0));
    let r = Recognition::from_distances(&[0.2], &[f64::INFINITY]);
    assert_eq!((r.object, r.second, r.confidence), (Some(0), f64::INFINITY, 1.0));
}

#[test]
fn parameters_are_checked_and_named() {
    assert!(RecognizerParams::default().validate().is_ok());
    let e = RecognizerParams::default().components(0).validate().unwrap_err().to_string();
    assert!(e.contains("components"), "{e}");
    let e = RecognizerParams::default().manifold_step(-1.0).validate().unwrap_err().to_string();
    assert!(e.contains("manifold step"), "{e}");
    let e = RecognizerParams::default().unknown(Unknown::Threshold(f64::NAN)).validate().unwrap_err().to_string();
    assert!(e.contains("unknown threshold"), "{e}");
    assert!(std::ptr::eq(Recognizer::from_name("linear").unwrap(), &linear::RECOGNIZER));
    let e = Recognizer::from_name("svm").unwrap_err().to_string();
    assert!(e.contains("universal, linear"), "{e}");
}

#[test]
fn the_own_distance_is_the_image_space_distance_to_the_nearest_manifold_point() {
    use crate::image_io::{ColorMode, ImageSpec};
    use crate::model::TensorData;
    use crate::{Dataset, ObjectSet, Param, PoseSpace};
    // One object on a turntable seen from three elevations (a manifold of two parameters), 48
    // pixels: a lobe turning round whose width follows the elevation.
    let space = PoseSpace::new(vec![Param::linear("elevation"), Param::circular("azimuth", 360.0)]).unwrap();
    let image = |e: f64, a: f64| -> Vec<f32> {
        (0..48)
            .map(|p| {
                let u = p as f64 / 48.0 * std::f64::consts::TAU;
                (0.1 + ((2.0 + e / 20.0) * ((u - a.to_radians()).cos() - 1.0)).exp()) as f32
            })
            .collect()
    };
    let poses: Vec<f64> = [20.0, 40.0, 60.0].iter().flat_map(|&e| (0..24).flat_map(move |k| [e, 15.0 * k as f64])).collect();
    let spec = ImageSpec { width: 48, height: 1, color: ColorMode::Gray };
    let d = Dataset::new(spec, poses.chunks(2).flat_map(|p| image(p[0], p[1])).collect(), space, poses.clone()).unwrap();
    let objects = ObjectSet::new(vec!["lobe".into()], vec![d]).unwrap();
    let fit = own::OwnSpaces::fit(&objects, &RecognizerParams::default().components(6).manifold_step(2.0), false).unwrap();
    assert_eq!(fit.components, vec![6]);
    // Every fold held a knot out: along each axis with enough knots, both parities.
    assert!(!fit.held_out[0].is_empty() && fit.held_out[0].iter().all(|&v| v.is_finite() && v > 0.0));
    let t = fit.model.tensors();
    let f32s = |name: &str| match &t.iter().find(|x| x.name == name).unwrap().data {
        TensorData::F32(v) => v.clone(),
        TensorData::F64(_) => unreachable!(),
    };
    let (basis, mean, points) = (f32s("recognizer.own.0.basis"), f32s("recognizer.own.0.mean"), f32s("recognizer.own.0.manifold.0"));
    let queries: Vec<f32> = [(30.0, 7.0), (55.0, 200.0), (20.0, 45.0)].iter().flat_map(|&(e, a)| image(e, a)).chain((0..48).map(|p| (p % 5) as f32)).collect();
    let mut got = vec![0.0; 4];
    fit.model.distances(0, &queries, &mut got);
    for (x, got) in queries.chunks_exact(48).zip(got) {
        // Plainly in f64: the unit-energy image's residual off the eigenspace, and its coordinates'
        // distance to every manifold point.
        let norm = x.iter().map(|&v| v as f64 * v as f64).sum::<f64>().sqrt();
        let c: Vec<f64> = x.iter().zip(&mean).map(|(&v, &mu)| v as f64 / norm - mu as f64).collect();
        let y: Vec<f64> = basis.chunks_exact(48).map(|u| u.iter().zip(&c).map(|(&a, b)| a as f64 * b).sum()).collect();
        let residual = c.iter().map(|v| v * v).sum::<f64>() - y.iter().map(|v| v * v).sum::<f64>();
        let nearest = points.chunks_exact(6).map(|p| p.iter().zip(&y).map(|(&a, b)| (a as f64 - b).powi(2)).sum::<f64>()).fold(f64::INFINITY, f64::min);
        let want = (residual.max(0.0) + nearest).sqrt();
        assert!((got - want).abs() < 1e-4 * (1.0 + want), "{got} against {want}");
    }
}

#[test]
fn the_nearer_object_is_the_one_every_object_measured_in_full_gives() {
    use crate::render::synth::{dataset, PoseGrid};
    use crate::render::{objects, Grid, RenderParams};
    use crate::{Dataset, ObjectSet};
    use std::path::Path;
    // The five built-in objects at 32 x 24, trained every 20 degrees; the views between them are
    // the queries, each set against every object as if recognised as it, at its own distance
    // there: the pruned search (bounds from the norms, the first coordinates and the residuals)
    // must name the same nearer object, at the same distance, as every object's distance
    // measured in full.
    let grid = |a: &str| PoseGrid::new(Grid::parse("elevation", "30").unwrap(), Grid::parse("azimuth", a).unwrap()).unwrap();
    let params = RenderParams::default().width(32).height(24);
    let names: Vec<String> = objects::OBJECTS[..5].iter().map(|o| o.0.to_string()).collect();
    let render =
        |a: &str| -> Vec<Dataset> { names.iter().map(|n| dataset(&objects::builtin(n).unwrap(), &grid(a), &params, Path::new(n), &|_| {}).unwrap()).collect() };
    let train = ObjectSet::new(names.clone(), render("0:340:20")).unwrap();
    let fit = own::OwnSpaces::fit(&train, &RecognizerParams::default().components(8), false).unwrap();
    let queries: Vec<f32> = render("10:350:20").iter().flat_map(|d| d.features().to_vec()).collect();
    let binned = fit.model.binned(&queries);
    let n = queries.len() / train.spec().features();
    let k = names.len();
    let mut full = vec![vec![0.0; n]; k];
    for (j, f) in full.iter_mut().enumerate() {
        fit.model.distances(j, &binned, f);
    }
    let mut found = 0;
    for named in 0..k {
        let d: Vec<f64> = full[named].clone();
        let got = fit.model.nearer(&binned, &vec![named; n], &d);
        for (i, got) in got.iter().enumerate() {
            let want = (0..k).filter(|&j| j != named && full[j][i] < d[i]).min_by(|&a, &b| full[a][i].total_cmp(&full[b][i])).map(|j| (j, full[j][i]));
            assert_eq!(got.map(|g| g.0), want.map(|w| w.0), "query {i} named {named}");
            if let (Some(g), Some(w)) = (got, want) {
                // The same distance up to the f32 projection's rounding (one query alone, or in a batch).
                assert!((g.1 - w.1).abs() <= 1e-5 * (1.0 + w.1), "query {i}: {} against {}", g.1, w.1);
                found += 1;
            }
        }
    }
    // Most views named as another object have a nearer one (their own, at least).
    assert!(found > n * (k - 1) / 2, "{found} of {}", n * (k - 1));
}

/// Objects of three pose parameters: each manifold resampled at a few points per knot interval
/// (not every 0.5 degrees), the views between training views recognised with their poses, and
/// the model file read back alike.
#[test]
fn objects_of_three_pose_parameters_are_recognised_with_their_poses() {
    use crate::methods::eigenspace::tests::knots::{between3, train3};
    use crate::{Dataset, EigenspaceParams, ObjectSet};
    // A second object: the first's images mirrored left to right.
    let mirrored = |d: &Dataset| {
        let w = d.spec().width as usize;
        let f = d.features().chunks_exact(w).flat_map(|row| row.iter().rev().copied()).collect();
        Dataset::from_features(d.manifest().clone(), d.spec(), f).unwrap()
    };
    let train = train3(20);
    let objects = ObjectSet::new(vec!["a".into(), "b".into()], vec![train.clone(), mirrored(&train)]).unwrap();
    let model = ObjectModel::fit(&objects, &RecognizerParams::default(), &EigenspaceParams::default().components(12).into()).unwrap();
    // 4 x 18 x 5 knots, 4 points a knot interval: 13 x 72 x 17 points an object.
    let storage = model.recognizer_storage();
    assert!(storage.terms.contains(&("N_dense".to_string(), 2 * 13 * 72 * 17)), "{storage:?}");
    let test = between3();
    let queries: Vec<f32> = test.features().iter().copied().chain(mirrored(&test).features().iter().copied()).collect();
    let est = model.estimate(&queries, 2).unwrap();
    let n = test.len();
    for (q, e) in est.iter().enumerate() {
        assert_eq!(e.recognition.object, Some(q / n), "view {q}: {:?}", e.recognition);
        let pose = &e.pose.as_ref().unwrap().pose;
        let err = test.space().error_deg(test.pose(q % n), pose);
        assert!(err <= 1.0, "view {q}: pose {pose:?}, error {err}");
    }
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("objects.safetensors");
    model.save(&path).unwrap();
    assert_eq!(ObjectModel::load(&path).unwrap().estimate(&queries, 2).unwrap(), est);
}

#[test]
fn recognisers_are_listed_once_each() {
    for (i, r) in RECOGNIZERS.iter().enumerate() {
        assert!(RECOGNIZERS[..i].iter().all(|o| o.name != r.name), "{} twice", r.name);
        assert!(std::ptr::eq(find(r.name).unwrap(), *r));
        // Parameters name their recogniser by its name, and read it back.
        let p = RecognizerParams::new(r);
        let back: RecognizerParams = serde_json::from_str(&serde_json::to_string(&p).unwrap()).unwrap();
        assert!(std::ptr::eq(back.kind, *r));
    }
    assert!(serde_json::from_str::<RecognizerParams>(&serde_json::to_string(&RecognizerParams::default()).unwrap().replace("universal", "svm")).is_err());
}
