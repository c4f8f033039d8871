//! The robust stage on rendered scenes: the duck on a turntable trained in the studio, queried
//! between its training views over a textured background, partly hidden.

#![cfg(feature = "render")]

use crate::render::background::Background;
use crate::render::scene::Scene;
use crate::render::synth::{dataset, PoseGrid};
use crate::render::{objects, Grid, RenderParams};
use crate::robust::Robust;
use crate::{AnyModel, Dataset, EigenspaceParams, Estimator, PoseModel, RefinedParams};

fn render(object: &str, azimuth: &str, scene: Option<Scene>) -> Dataset {
    render_at(object, azimuth, scene, (64, 48))
}

fn render_at(object: &str, azimuth: &str, scene: Option<Scene>, (w, h): (u32, u32)) -> Dataset {
    let mut grid = PoseGrid::new(Grid::parse("elevation", "30").unwrap(), Grid::parse("azimuth", azimuth).unwrap()).unwrap();
    if let Some(s) = scene {
        grid = grid.with_scene(s);
    }
    let params = RenderParams::default().width(w).height(h);
    dataset(&objects::builtin(object).unwrap(), &grid, &params, std::path::Path::new("<render>"), &|_| {}).unwrap()
}

/// Mean pose error of `model` over `data`'s views (azimuth only).
fn mean_error(model: &dyn PoseModel, data: &Dataset) -> f64 {
    let est = model.predict(data.features()).unwrap();
    let p = data.space().len();
    (0..data.len()).map(|i| data.space().error_deg(&est[i * p..(i + 1) * p], data.pose(i))).sum::<f64>() / data.len() as f64
}

fn scene(occlude: f64, seed: u64) -> Scene {
    Scene::new(Background::Texture, occlude, seed).unwrap()
}

/// The check's statistic by its formula, as the stage computed it before its products were
/// vectorised: the stage's full rows binned, their Gram matrix inverted, then p = S^T xb, the
/// coefficients and the reconstruction, each a plain f64 sum through a closure `row(i, j)`.
fn reference_share(stage: &super::Stage, x: &[f32]) -> Option<f64> {
    let (k, mb) = (stage.settings.rows, stage.binning.spec().features());
    let bin = |v: &[f32]| {
        let mut out = vec![0f32; mb];
        stage.binning.apply(v, &mut out, &mut Vec::new());
        out
    };
    let rows: Vec<Vec<f32>> = stage.rows.chunks_exact(stage.m).map(bin).collect();
    let row = |i: usize, j: usize| rows[j][i] as f64;
    let mut gram = vec![0f64; k * k];
    for i in 0..mb {
        for a in 0..k {
            for c in 0..k {
                gram[a * k + c] += row(i, a) * row(i, c);
            }
        }
    }
    let ginv = super::search::invert(&gram, k).unwrap();
    let xb = bin(x);
    let energy: f64 = xb.iter().map(|&v| v as f64 * v as f64).sum();
    if !(energy > 0.0 && energy.is_finite()) {
        return None;
    }
    let mut p = vec![0f64; k];
    for (i, &v) in xb.iter().enumerate() {
        if v != 0.0 {
            p.iter_mut().enumerate().for_each(|(j, a)| *a += row(i, j) * v as f64);
        }
    }
    let coef: Vec<f64> = (0..k).map(|a| (0..k).map(|c| ginv[a * k + c] * p[c]).sum()).collect();
    let recon: Vec<f64> = (0..mb).map(|i| (0..k).map(|j| row(i, j) * coef[j]).sum()).collect();
    let peak = recon.iter().fold(0f64, |a, &v| a.max(v));
    let dark: f64 = recon.iter().zip(&xb).filter(|(&r, _)| r < super::tuning::DARK * peak).map(|(_, &v)| v as f64 * v as f64).sum();
    Some(dark / energy)
}

#[test]
fn the_check_is_its_formula_to_the_last_bit() {
    // Views binned by 2 (64 x 48) and by 4 (128 x 96): studio views between the training views
    // and texture scenes 0-40% hidden. The vectorised products add in the formula's order, so
    // the tolerance is 0; the shares must also fall on both sides of the threshold.
    for size in [(64, 48), (128, 96)] {
        let train = render_at("duck", "0:350:10", None, size);
        let stage = super::Stage::fit(&train).unwrap();
        let mut sides = [0usize; 2];
        let sets = [("studio", None), ("texture", Some(scene(0.0, 7))), ("20% hidden", Some(scene(0.2, 8))), ("40% hidden", Some(scene(0.4, 9)))];
        for (set, s) in sets {
            let q = render_at("duck", "5:355:20", s, size);
            for i in 0..q.len() {
                let (xb, share) = stage.check(q.row(i));
                assert_eq!(xb.len(), stage.binning.spec().features());
                let want = reference_share(&stage, q.row(i));
                assert_eq!(share.map(f64::to_bits), want.map(f64::to_bits), "{size:?}, {set}, view {i}: {share:?} against {want:?}");
                sides[(share.unwrap() > stage.settings.threshold) as usize] += 1;
            }
        }
        eprintln!("{size:?}: binned by {}, {} views within the threshold, {} beyond", stage.settings.bin, sides[0], sides[1]);
        assert!(sides[0] >= 18 && sides[1] >= 18, "{size:?}: {sides:?} within and beyond the threshold");
    }
    // A query of no energy has no share.
    let stage = super::Stage::fit(&render("duck", "0:350:30", None)).unwrap();
    assert_eq!(stage.check(&vec![0.0; 64 * 48]).1, None);
}

#[test]
fn robust_estimate_is_near_the_truth_where_the_plain_one_is_not() {
    let train = render("duck", "0:350:10", None);
    let plain = AnyModel::new(EigenspaceParams::default().fit(&train).unwrap());
    let robust = Robust::fit(&train, plain.clone()).unwrap();
    eprintln!("studio: plain {:.2}", mean_error(&plain, &render("duck", "5:355:20", None)));
    for occlude in [0.0, 0.2] {
        let queries = render("duck", "5:355:20", Some(scene(occlude, 1)));
        let (p, r) = (mean_error(&plain, &queries), mean_error(&robust, &queries));
        eprintln!("occlude {occlude}: plain {p:.2}, robust {r:.2}");
        assert!(r < 1.5 && p > 10.0 * r, "occlude {occlude}: plain {p:.2} degrees, robust {r:.2}");
    }
}

#[test]
fn studio_queries_give_identical_answers() {
    let train = render("duck", "0:350:10", None);
    let queries = render("duck", "5:355:10", None);
    for inner in [AnyModel::new(EigenspaceParams::default().fit(&train).unwrap()), AnyModel::new(RefinedParams::default().fit(&train).unwrap())] {
        let robust = Robust::fit(&train, inner.clone()).unwrap();
        let r = robust.downcast_ref::<Robust>().unwrap();
        assert!((0..queries.len()).all(|i| r.repair(queries.row(i)).is_none()), "a studio view taken for a scene");
        assert_eq!(robust.predict(queries.features()).unwrap(), inner.predict(queries.features()).unwrap());
        assert_eq!(robust.estimate(queries.features(), 3).unwrap(), inner.estimate(queries.features(), 3).unwrap());
    }
}

#[test]
fn the_stage_survives_its_model_file() {
    let train = render("duck", "0:350:20", None);
    let robust = Robust::fit(&train, AnyModel::new(EigenspaceParams::default().components(8).fit(&train).unwrap())).unwrap();
    let back = AnyModel::from_bytes(std::path::Path::new("<bytes>"), &robust.to_bytes().unwrap()).unwrap();
    let b = back.downcast_ref::<Robust>().expect("the stage read back");
    assert_eq!(b.settings(), robust.downcast_ref::<Robust>().unwrap().settings());
    let queries = render("duck", "10:350:40", Some(scene(0.2, 3)));
    assert_eq!(back.predict(queries.features()).unwrap(), robust.predict(queries.features()).unwrap());
    let (views, poses) = b.stage.views().expect("the training views read back");
    assert_eq!((views.len(), poses.len()), (18 * b.stage.binning.spec().features(), 18 * 2));
    // A file written before the answer's check (no views) still reads, and checks nothing.
    let t: Vec<_> = robust.tensors().into_iter().filter(|t| !t.name.starts_with("robust.views") && t.name != "robust.poses").collect();
    let mut meta = std::collections::BTreeMap::new();
    meta.insert(super::META_KEY, serde_json::to_string(b.settings()).unwrap());
    meta.insert("method", robust.meta().method.clone());
    meta.insert("linpose.meta", serde_json::to_string(robust.meta()).unwrap());
    let old = crate::model::file::write_parts(meta, t).unwrap();
    let back = AnyModel::from_bytes(std::path::Path::new("<bytes>"), &old).unwrap();
    assert!(back.downcast_ref::<Robust>().unwrap().stage.views().is_none());
    assert_eq!(back.predict(render("duck", "10:350:40", None).features()).unwrap(), robust.predict(render("duck", "10:350:40", None).features()).unwrap());
}

/// The duck at 128 x 128 (binned by 4) trained every 10 degrees, its stage, and its training
/// view `row` fitted as a query: the training views, the stage, the view, binned, and its fit.
fn fitted_view(row: usize) -> (Dataset, super::Stage, Vec<f32>, Vec<f32>, super::Fit) {
    let train = render_at("duck", "0:350:10", None, (128, 128));
    let stage = super::Stage::fit(&train).unwrap();
    let x = train.row(row).to_vec();
    let (xb, _) = stage.check(&x);
    let fit = stage.fit_binned(&xb);
    (train, stage, x, xb, fit)
}

#[test]
fn the_answer_is_the_candidate_the_query_s_own_pixels_support() {
    // A training view of the duck as the query, every bin of the stage's support kept: of its
    // own pose and the pose half a turn away, the check picks its own, in either order.
    let (train, stage, x, xb, fit) = fitted_view(4);
    let evidence = stage.evidence(xb, &fit, &vec![true; x.len()]);
    let space = train.space();
    let (right, wrong) = (train.pose(4).to_vec(), vec![train.pose(4)[0], train.pose(4)[1] + 180.0]);
    assert_eq!(stage.verify(&evidence, &[&wrong, &right], space), 1);
    assert_eq!(stage.verify(&evidence, &[&right, &wrong], space), 0);
}

#[test]
fn the_fit_s_own_pose_answers_when_no_candidate_of_the_method_is_near_it() {
    // A training view of the duck as the query, every bin of the support kept: the training view
    // nearest the fit is the view itself. A method whose only candidate is half a turn away is
    // overruled by the fit's pose; one within a few degrees of it keeps its answer, and the fit's
    // pose is not offered against it.
    use super::verify::Answer;
    let (train, stage, x, xb, fit) = fitted_view(4);
    let evidence = stage.evidence(xb, &fit, &vec![true; x.len()]);
    let space = train.space();
    let right = train.pose(4).to_vec();
    assert_eq!(evidence.fit_pose.as_deref(), Some(right.as_slice()));
    let wrong = vec![right[0], right[1] + 180.0];
    assert_eq!(stage.answer(&evidence, &[&wrong], space), Answer::Fit(&right));
    let near = vec![right[0], right[1] + 5.0];
    assert_eq!(stage.answer(&evidence, &[&near], space), Answer::Method(0));
}

#[test]
fn the_confidence_flags_a_view_too_hidden_to_tell() {
    let train = render("duck", "0:350:10", None);
    let robust = Robust::fit(&train, AnyModel::new(EigenspaceParams::default().fit(&train).unwrap())).unwrap();
    let below = crate::confidence::FLAG_BELOW;
    // The same views, lightly and heavily hidden (the same seed: the same backgrounds).
    let light = render("duck", "5:355:30", Some(scene(0.1, 2)));
    let heavy = render("duck", "5:355:30", Some(scene(0.8, 2)));
    let (el, eh) = (robust.estimate(light.features(), 3).unwrap(), robust.estimate(heavy.features(), 3).unwrap());
    let r = robust.downcast_ref::<Robust>().unwrap();
    // The factor the stage's calibration puts on a repaired query's confidence.
    let factor = |x: &[f32]| r.repair(x).map_or(1.0, |(_, shown)| super::hidden::clear(r.settings().hidden, shown));
    let (mut right, mut right_scaled_under, mut light_flagged, mut heavy_flagged) = (0, 0, 0, 0);
    for i in 0..light.len() {
        let error = light.space().error_deg(&el[i].pose, light.pose(i));
        let (fl, fh) = (factor(light.row(i)), factor(heavy.row(i)));
        eprintln!(
            "view {i}: 10% hidden off {error:.1} (factor {fl:.2}, confidence {:.2}), 80% hidden off {:.1} factor {fh:.2}, confidence {:.2}",
            el[i].confidence,
            heavy.space().error_deg(&eh[i].pose, heavy.pose(i)),
            eh[i].confidence
        );
        if error <= crate::confidence::GROSS_DEG {
            right += 1;
            right_scaled_under += (fl < below) as usize;
        }
        light_flagged += el[i].flagged(below) as usize;
        heavy_flagged += eh[i].flagged(below) as usize;
    }
    let n = light.len();
    // Lightly hidden: read right, and the calibration leaves their confidence to the method
    // (whose own confidence flags some: 4 of the 12 when the repair replaced the duck's detail
    // too, 5 since it keeps it, `detail.rs`; COIL-20's false flags stayed 2.5 / 10 / 23% at 0 /
    // 20 / 40% hidden, `bench/scenes.py`).
    assert!(
        right == n && right_scaled_under == 0 && light_flagged * 2 <= n,
        "10% hidden: {right} of {n} read right, {right_scaled_under} scaled under the flag, {light_flagged} flagged"
    );
    // Heavily hidden: flagged, all but at most one. Since the dense first pass (`scan.rs`) two
    // of the twelve read within 20 degrees even so, and one (view 6, 36 degrees off) has its
    // method agree with its fit at a confidence of 0.81: the calibration puts 0.81 on the share
    // it shows (0.29), which the training views' own hidden views read right that often. On
    // COIL-20 at 40% hidden 11 of 12 gross errors are flagged (`bench/scenes.py`).
    assert!(heavy_flagged + 1 >= n, "80% hidden: {heavy_flagged} of {n} flagged");
}

#[test]
fn the_hidden_share_calibration_is_reproducible_and_old_settings_still_read() {
    let train = render("duck", "0:350:20", None);
    let fit = || *crate::robust::Stage::fit(&train).unwrap().settings();
    let (a, b) = (fit(), fit());
    assert_eq!(a, b);
    let [_, slope] = a.hidden.expect("a fitted stage is calibrated");
    assert!(slope > 0.0, "{a:?}");
    // A model file's settings from before the calibration: no `hidden`, the fixed ramp.
    let old: crate::robust::RobustSettings = serde_json::from_str(r#"{"bin":4,"rows":17,"threshold":0.05}"#).unwrap();
    assert_eq!(old.hidden, None);
    let json = serde_json::to_string(&old).unwrap();
    assert!(!json.contains("hidden"), "{json}");
}

/// The duck between two training views, put at (x, y) and scale `s` in a `w` x `h` texture
/// scene: the scene's features and the frame's box.
#[test]
fn the_repair_keeps_the_object_s_specks_and_replaces_an_occluder() {
    // A studio view of the duck (128 x 128, binned by 4) fitted as a query, then two parts of
    // the object marked unexplained and their pixels changed: one bin on its left (a speck,
    // under tuning::SPECK of the object's bright bins) and every bright bin right of its
    // middle (an occluder over much of it). The repair keeps the speck's pixels as the query has
    // them and replaces the occluder's by the reconstruction.
    let (_, stage, x, xb, mut fit) = fitted_view(3);
    let (wb, b) = (stage.binning.spec().width as usize, stage.binning.factor());
    let w = 128;
    let mut recon = vec![0f64; xb.len()];
    super::check::Basis::reconstruct(&stage.binned, &fit.coef, &mut recon);
    let peak = recon.iter().fold(0f64, |a, &v| a.max(v));
    let object: Vec<usize> = (0..xb.len()).filter(|&i| recon[i] > 0.5 * peak).collect();
    let middle = object.iter().map(|&i| i % wb).sum::<usize>() / object.len();
    let occluder: Vec<usize> = object.iter().copied().filter(|&i| i % wb >= middle).collect();
    let speck = object.iter().copied().filter(|&i| i % wb + 3 <= middle).max_by(|&a, &c| recon[a].total_cmp(&recon[c])).unwrap();
    fit.inlier.iter_mut().for_each(|v| *v = true);
    fit.inlier[speck] = false;
    occluder.iter().for_each(|&i| fit.inlier[i] = false);
    let mut q = x.clone();
    let pixels = |bin: usize| (0..b * b).map(move |k| (bin / wb * b + k / b) * w + bin % wb * b + k % b);
    for bin in std::iter::once(speck).chain(occluder.iter().copied()) {
        pixels(bin).for_each(|i| q[i] += 0.5);
    }
    let out = stage.repair(&q, &fit);
    assert!(pixels(speck).all(|i| out[i] == q[i]), "the speck's own pixels are kept");
    let replaced = occluder.iter().flat_map(|&bin| pixels(bin)).filter(|&i| out[i] != q[i]).count();
    assert_eq!(replaced, occluder.len() * b * b, "every pixel of the occluder ({} bins) is replaced", occluder.len());
}

#[test]
fn the_fill_is_solved_again_on_the_pixels_kept() {
    // A query in the span of the stage's rows (a studio view's reconstruction, 128 x 128) with
    // the bright bins right of the object's middle hidden (their pixels changed, marked
    // unexplained), and a fit whose coefficients are off (its eigenimages' weights at 0.8, as
    // a fit on a subset of the object extrapolates): the hidden pixels are filled with the
    // query's own values, solved again on the pixels kept.
    let (_, stage, _, xb, mut fit) = fitted_view(3);
    let coef: Vec<f32> = fit.coef.iter().map(|&c| c as f32).collect();
    let x: Vec<f32> = (0..stage.m).map(|i| stage.reconstruct_at(&coef, i)).collect();
    let (wb, b, w) = (stage.binning.spec().width as usize, stage.binning.factor(), 128);
    let mut recon = vec![0f64; xb.len()];
    super::check::Basis::reconstruct(&stage.binned, &fit.coef, &mut recon);
    let peak = recon.iter().fold(0f64, |a, &v| a.max(v));
    let object: Vec<usize> = (0..xb.len()).filter(|&i| recon[i] > 0.5 * peak).collect();
    let middle = object.iter().map(|&i| i % wb).sum::<usize>() / object.len();
    let hidden: Vec<usize> = object.into_iter().filter(|&i| i % wb >= middle).collect();
    fit.inlier.iter_mut().for_each(|v| *v = true);
    hidden.iter().for_each(|&i| fit.inlier[i] = false);
    fit.coef.iter_mut().skip(1).for_each(|c| *c *= 0.8);
    let pixels: Vec<usize> = hidden.iter().flat_map(|&bin| (0..b * b).map(move |k| (bin / wb * b + k / b) * w + bin % wb * b + k % b)).collect();
    let mut q = x.clone();
    pixels.iter().for_each(|&i| q[i] += 0.5);
    let out = stage.repair(&q, &fit);
    let worst = pixels.iter().map(|&i| (out[i] - x[i]).abs()).fold(0f32, f32::max);
    assert!(worst < 1e-3, "the hidden pixels are the query's own values to {worst}");
}

fn in_scene(view: &Dataset, (w, h): (u32, u32), s: f64, seed: u64) -> (Vec<f32>, crate::image_io::ImageSpec, [f64; 4]) {
    use crate::render::background::BackgroundSpec;
    use crate::render::place::Canvas;
    use crate::render::scene::SceneSpec;
    let spec = view.spec();
    let pixels: Vec<u8> = view.row(0).iter().map(|&v| (v * 255.0).round() as u8).collect();
    let mask: Vec<bool> = pixels.iter().map(|&v| v > 0).collect();
    let canvas = Canvas::new(w, h, [s, s]).unwrap();
    let scene = SceneSpec { background: BackgroundSpec::Texture, occlude: 0.0, seed, canvas: Some(canvas) }.open(spec.width, spec.height).unwrap();
    let (big, record) = scene.place(0, "duck", spec, &mask, &pixels).unwrap();
    (big.iter().map(|&v| crate::image_io::feature_of_u8(v)).collect(), canvas.spec(spec), record.bbox.unwrap())
}

#[test]
fn the_object_is_found_anywhere_in_a_larger_scene() {
    let train = render("duck", "0:350:10", None);
    let robust = Robust::fit(&train, AnyModel::new(RefinedParams::default().fit(&train).unwrap())).unwrap();
    let plain = AnyModel::new(RefinedParams::default().fit(&train).unwrap());
    assert!(plain.scene_search().is_none(), "only the robust stage searches scenes");
    let search = robust.scene_search().unwrap();
    let view = render("duck", "125", None);
    let mut near = 0;
    let placements = [(0.85, 1), (1.0, 2), (1.15, 3), (0.9, 4), (1.05, 5), (1.2, 6)];
    for (s, seed) in placements {
        let (scene, spec, truth) = in_scene(&view, (160, 120), s, seed);
        let found = search.locate(&scene, spec).unwrap().remove(0);
        let centre = |b: [f64; 4]| (b[0] + b[2] / 2.0, b[1] + b[3] / 2.0);
        let (a, b) = (centre(found.bbox), centre(truth));
        let off = (a.0 - b.0).hypot(a.1 - b.1);
        let est = search.estimate_located(std::slice::from_ref(&found), 1).unwrap().remove(0);
        assert_eq!(search.predict_located(std::slice::from_ref(&found)).unwrap(), est.pose, "the pose is the checked estimate's");
        let error = view.space().error_deg(&est.pose, view.pose(0));
        eprintln!("scale {s}: box {:?} (truth {truth:?}), centre off {off:.2} px, pose off {error:.2} degrees, shown {:.2}", found.bbox, found.shown);
        // The box and the pose settled together (`settle.rs`): 0.2 - 0.9 degrees here, the box's
        // scale within 2% (before the settle, 0 - 4.8 degrees and up to 6% off in scale).
        if off <= 3.0 && (found.scale / s - 1.0).abs() < 0.05 {
            near += 1;
            assert!(error < 2.0, "scale {s}: pose off by {error:.2} degrees");
        }
    }
    // 64 x 48 views leave the search 16 x 12 coarse cells: most placements are found (all six
    // here; COIL-20's 128 x 128 views: bench/locate.py).
    assert!(near >= 5, "{near} of {} boxes within 3 pixels and 5% of the scale", placements.len());
    // A scene smaller than the smallest scale's view is refused by its size.
    let small = vec![0.5f32; 40 * 30];
    let spec = crate::image_io::ImageSpec { width: 40, height: 30, color: crate::image_io::ColorMode::Gray };
    let e = search.locate(&small, spec).unwrap_err().to_string();
    assert!(e.contains("40x30"), "{e}");
}

#[test]
fn a_training_view_in_a_scene_settles_at_its_own_box_and_pose() {
    // The duck's training view at 120 degrees (128 x 128) pasted into a scene at scale 1.1: the
    // settle started at the view's own box and pose stays there; started 2.5 pixels and 4
    // degrees off, it comes back to within half a pixel and 1.5 degrees (the pose and the box
    // trade against each other along a flat valley: 0.24 pixels and 1.0 degree here).
    let train = render_at("duck", "0:350:10", None, (128, 128));
    let stage = super::Stage::fit(&train).unwrap();
    let space = train.space();
    let (scene, spec, truth) = in_scene(&render_at("duck", "120", None, (128, 128)), (320, 240), 1.1, 9);
    let scene = stage.scene(&scene, spec).unwrap();
    let (_, _, evidence) = stage.apply(&stage.cut(&scene, truth).view).expect("a view on a textured background needs the repair");
    let centre = |b: [f64; 4]| (b[0] + b[2] / 2.0, b[1] + b[3] / 2.0);
    let off = |b: [f64; 4]| (centre(b).0 - centre(truth).0).hypot(centre(b).1 - centre(truth).1);
    let (bbox, pose) = stage.settle(&scene, truth, &[30.0, 120.0], evidence.theta, space).expect("the duck's poses are a lattice");
    assert!(off(bbox) < 0.25 && space.error_deg(&pose, &[30.0, 120.0]) < 0.25, "from the truth to {bbox:?} at {pose:?}");
    let start = [truth[0] + 2.0, truth[1] - 1.5, truth[2], truth[3]];
    let (bbox, pose) = stage.settle(&scene, start, &[30.0, 124.0], evidence.theta, space).unwrap();
    let error = space.error_deg(&pose, &[30.0, 120.0]);
    eprintln!("settled: box {bbox:?} (truth {truth:?}), centre off {:.2} px, pose {pose:?}", off(bbox));
    assert!(off(bbox) < 0.5, "the centre {:.2} pixels off", off(bbox));
    assert!((bbox[2] / truth[2] - 1.0).abs() < 0.02, "the width {} against {}", bbox[2], truth[2]);
    assert!(error < 1.5, "the pose {error:.2} degrees off");
    // A view between two training views (125 degrees): the box is the frame of the view at the
    // settled pose, each neighbouring training view placed alone; the render's frame does not
    // move with the pose, so both land on the truth (0.32 px; the pose from 122 to 123.5).
    let (scene, spec, truth) = in_scene(&render_at("duck", "125", None, (128, 128)), (320, 240), 0.9, 11);
    let scene = stage.scene(&scene, spec).unwrap();
    let start = [truth[0] - 1.5, truth[1] + 2.0, truth[2], truth[3]];
    let (bbox, pose) = stage.settle(&scene, start, &[30.0, 122.0], evidence.theta, space).unwrap();
    let (centre, error) = ((centre(bbox).0 - centre(truth).0).hypot(centre(bbox).1 - centre(truth).1), space.error_deg(&pose, &[30.0, 125.0]));
    eprintln!("between: box {bbox:?} (truth {truth:?}), centre off {centre:.2} px, pose {pose:?}");
    assert!(centre < 0.5 && (bbox[2] / truth[2] - 1.0).abs() < 0.02 && error < 2.0, "the centre {centre:.2} pixels, the pose {error:.2} degrees off");
}

/// The objects' training views (every 10 degrees) as one set.
fn objects(names: &[&str]) -> crate::ObjectSet {
    crate::ObjectSet::new(names.iter().map(|n| n.to_string()).collect(), names.iter().map(|n| render(n, "0:350:10", None)).collect()).unwrap()
}

/// A many-object model of `names` (eigenspace pose models), plain and behind the robust stage.
fn object_models(names: &[&str]) -> (crate::recognize::ObjectModel, crate::recognize::ObjectModel) {
    use crate::recognize::{ObjectModel, RecognizerParams, Unknown};
    let set = objects(names);
    let pose = crate::Method::from_name("eigenspace").unwrap().default_spec();
    let plain = ObjectModel::fit(&set, &RecognizerParams::default().unknown(Unknown::Off), &pose).unwrap();
    let robust = plain.clone().with_robust(&set).unwrap();
    (plain, robust)
}

/// The share of `model`'s answers naming `object`, and their mean pose error (recognised ones).
fn recognised(model: &crate::recognize::ObjectModel, queries: &Dataset, object: usize) -> (f64, f64) {
    let est = model.estimate(queries.features(), 1).unwrap();
    let ok: Vec<usize> = (0..est.len()).filter(|&i| est[i].recognition.object == Some(object)).collect();
    let err = ok.iter().map(|&i| queries.space().error_deg(&est[i].pose.as_ref().unwrap().pose, queries.pose(i))).sum::<f64>() / ok.len().max(1) as f64;
    (ok.len() as f64 / est.len() as f64, err)
}

#[test]
fn many_objects_are_recognised_in_scenes_where_the_plain_model_is_not() {
    let names = ["duck", "pot", "cap"];
    let (plain, robust) = object_models(&names);
    let (mut p, mut r) = (0.0, 0.0);
    for (k, name) in names.iter().enumerate() {
        let queries = render(name, "5:355:20", Some(scene(0.2, 4 + k as u64)));
        let ((pr, pe), (rr, re)) = (recognised(&plain, &queries, k), recognised(&robust, &queries, k));
        eprintln!("{name}: plain recognised {pr:.2} (pose {pe:.1}), robust {rr:.2} (pose {re:.1})");
        assert!(rr >= 0.9 && re < 15.0, "{name}: robust recognised {rr:.2}, pose error {re:.1} degrees");
        (p, r) = (p + pr / 3.0, r + rr / 3.0);
    }
    assert!(p < 0.7, "the plain model recognised {p:.2} of the scenes: no test of the stage");
}

#[test]
fn many_objects_answer_studio_queries_as_without_the_stage() {
    let names = ["duck", "pot", "cap"];
    let (plain, robust) = object_models(&names);
    for name in names {
        let q = render(name, "5:355:10", None);
        let f = q.features();
        assert_eq!(robust.estimate(f, 3).unwrap(), plain.estimate(f, 3).unwrap(), "{name}");
        assert_eq!(robust.recognize(f).unwrap(), plain.recognize(f).unwrap(), "{name}");
        assert_eq!(robust.distances(f).unwrap(), plain.distances(f).unwrap(), "{name}");
        assert_eq!(robust.hypotheses(f, 2).unwrap(), plain.hypotheses(f, 2).unwrap(), "{name}");
    }
}

#[test]
fn the_stages_of_many_objects_survive_their_model_file() {
    let (plain, robust) = object_models(&["duck", "cap"]);
    assert!(plain.robust_settings().is_empty() && robust.robust_settings().len() == 2);
    assert!(robust.model_bytes() > plain.model_bytes());
    let back = crate::recognize::ObjectModel::from_bytes(std::path::Path::new("<bytes>"), &robust.to_bytes().unwrap()).unwrap();
    assert_eq!(back.robust_settings(), robust.robust_settings());
    let queries = render("cap", "10:350:40", Some(scene(0.2, 3)));
    let est = back.estimate(queries.features(), 2).unwrap();
    assert_eq!(est, robust.estimate(queries.features(), 2).unwrap());
    assert_ne!(est, plain.estimate(queries.features(), 2).unwrap(), "the scenes were answered plainly");
    let plain_back = crate::recognize::ObjectModel::from_bytes(std::path::Path::new("<bytes>"), &plain.to_bytes().unwrap()).unwrap();
    assert!(plain_back.robust_settings().is_empty());
}

#[test]
fn many_objects_take_the_stage_of_gray_views_of_their_own_objects() {
    let (plain, _) = object_models(&["duck", "cap"]);
    let e = plain.with_robust(&objects(&["duck", "pot"])).unwrap_err().to_string();
    assert!(e.contains("robust stage"), "{e}");
}

#[test]
fn the_repair_keeps_the_object_s_own_detail_and_still_finds_the_occluder() {
    // The duck (128 x 128, trained every 10 degrees) between its training views, over a
    // texture and 20% hidden, against the same views in the studio: the pixels where the two
    // differ are the outliers. The tolerance the training views' own residuals set
    // (`detail.rs`) keeps much more of the object's own pixels than the fit's one threshold
    // (a stage without its views), and hardly more of the outliers.
    let train = render_at("duck", "0:350:10", None, (128, 128));
    let stage = super::Stage::fit(&train).unwrap();
    let single = stage.clone().without_views();
    let studio = render_at("duck", "5:355:30", None, (128, 128));
    let scenes = render_at("duck", "5:355:30", Some(scene(0.2, 1)), (128, 128));
    let (mut lost, mut kept_out) = ([0f64; 2], [0f64; 2]);
    for i in 0..studio.len() {
        let (s, q) = (studio.row(i), scenes.row(i));
        let (xb, _) = stage.check(q);
        let fit = stage.fit_binned(&xb);
        let outlier: Vec<bool> = s.iter().zip(q).map(|(a, b)| a != b).collect();
        let object = |p: usize| !outlier[p] && s[p] > 0.04;
        let share = |n: usize, d: usize| n as f64 / d.max(1) as f64 / studio.len() as f64;
        for (j, st) in [&stage, &single].into_iter().enumerate() {
            let (_, kept) = st.repaired(q, &fit);
            lost[j] += share((0..s.len()).filter(|&p| object(p) && !kept[p]).count(), (0..s.len()).filter(|&p| object(p)).count());
            kept_out[j] += share((0..s.len()).filter(|&p| outlier[p] && kept[p]).count(), outlier.iter().filter(|&&o| o).count());
        }
    }
    assert!(lost[0] < 0.6 * lost[1], "object's own pixels replaced: {:.3} with the training views' detail, {:.3} without", lost[0], lost[1]);
    assert!(kept_out[0] < kept_out[1] + 0.02, "outliers kept: {:.3} with the training views' detail, {:.3} without", kept_out[0], kept_out[1]);
}

/// The reread (`reread.rs`) takes an answer a few degrees off back to the pose of a view between
/// the training views, from its binned pixels alone, and keeps it within half a knot interval of
/// where it started; a stage without its views leaves the answer as it is.
#[test]
fn the_answer_is_read_again_from_the_query_s_own_pixels() {
    let train = render_at("duck", "0:350:10", None, (96, 72));
    let stage = super::Stage::fit(&train).unwrap();
    let between = render_at("duck", "45:45:1", None, (96, 72));
    let (xb, _) = stage.check(between.row(0));
    let evidence = super::Evidence { fit_pose: None, xb, kept: Vec::new(), theta: 0.02, settled: None };
    let space = train.space();
    let truth = between.pose(0);
    for off in [-3.0, 3.0] {
        let start = [truth[0], truth[1] + off];
        let read = stage.reread(&evidence, &start, space);
        assert!(space.error_deg(&read, truth) < 1.0, "from {start:?}: {read:?}");
        assert!((read[1] - start[1]).abs() <= 5.0 + 1e-9, "{read:?} beyond half a knot interval of {start:?}");
    }
    let bare = stage.clone().without_views();
    assert_eq!(bare.reread(&evidence, &[truth[0], truth[1] + 3.0], space), vec![truth[0], truth[1] + 3.0]);
}

#[test]
fn the_dense_first_pass_holds_the_training_views_and_reads_hidden_views_between_them() {
    // The lattice's views at the training poses are the binned training views themselves, and
    // there are four per training interval.
    let train = render_at("duck", "0:350:10", None, (128, 128));
    let stage = super::Stage::fit(&train).unwrap();
    let lattice = stage.lattice.as_ref().expect("views on a ring have a lattice");
    let (views, _) = stage.views().unwrap();
    let mb = views.len() / train.len();
    assert_eq!(lattice.poses.len() / lattice.params, 4 * train.len());
    for i in [0, 7, 35] {
        let h = (0..lattice.poses.len() / lattice.params).find(|&h| train.space().error_deg(lattice.pose(h), train.pose(i)) < 1e-9).unwrap();
        let at: Vec<f32> = stage.support.iter().map(|&j| views[i * mb + j as usize]).collect();
        let got = &lattice.table.values()[h * stage.support.len()..(h + 1) * stage.support.len()];
        assert!(at.iter().zip(got).all(|(a, b)| (a - b).abs() <= 1e-5 * (1.0 + a.abs())), "view {i}");
    }
    // Views halfway between the training views, 40% hidden over texture: the fit's pose, the
    // lattice's, against the training view nearest the coefficients of a fit without it.
    let queries = render_at("duck", "5:355:20", Some(scene(0.4, 3)), (128, 128));
    let bare = stage.clone().without_views();
    let (mut dense, mut plain) = (Vec::new(), Vec::new());
    for i in 0..queries.len() {
        let (xb, _) = stage.check(queries.row(i));
        let fit = stage.fit_binned(&xb);
        // The largest parameter error (the azimuth's).
        dense.push(train.space().param_errors_deg(queries.pose(i), fit.pose.as_deref().unwrap()).into_iter().fold(0.0, f64::max));
        let fit = bare.fit_binned(&xb);
        plain.push(if super::hidden::reads_right_at(&bare, &train, queries.pose(i), &fit) { 0.0 } else { 180.0 });
    }
    let right = |e: &[f64]| e.iter().filter(|&&e| e <= crate::confidence::GROSS_DEG).count();
    eprintln!("dense {dense:.1?}; right {} against {} of {}", right(&dense), right(&plain), queries.len());
    // Right means within the reread's reach: half a training interval.
    assert!(dense.iter().all(|&e| e <= 5.0 + 1e-9 || e > crate::confidence::GROSS_DEG), "a pose between");
    assert!(right(&dense) >= right(&plain) && right(&dense) + 1 >= queries.len(), "{} against {}", right(&dense), right(&plain));
}
