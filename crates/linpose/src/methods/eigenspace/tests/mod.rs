//! End-to-end tests of the eigenspace method on synthetic images: smooth functions of the pose,
//! made here (tests read no data from outside the repository). `knots.rs`: three and four pose
//! parameters, the manifold kept as its knots.

pub(crate) mod knots;

use super::*;
use crate::image_io::{ColorMode, ImageSpec};
use crate::manifold::projector::U8_BATCH;
use crate::{Manifest, Param, PoseSpace, TrainSelection};

pub(crate) const W: usize = 32;
pub(crate) const H: usize = 12;

/// A W x H image of a pose: a bright lobe that turns with the azimuth and rises with the
/// elevation, over a background with its own azimuth dependence. Smooth in both angles. Shared
/// with the refined method's tests.
pub(crate) fn image(elev: f64, azim: f64) -> Vec<f32> {
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

/// [`image`] with a third pose parameter, a roll (degrees): a horizontal band that moves up with
/// it, its brightness along the azimuth turning with the roll and the azimuth; and a fourth, a
/// light (degrees): the background's brightness rises with it from the left. Smooth in all four.
pub(crate) fn image4(elev: f64, azim: f64, roll: f64, light: f64) -> Vec<f32> {
    let (a, r, g) = (azim.to_radians(), roll.to_radians(), light / 60.0);
    let mut f = image(elev, azim);
    for j in 0..H {
        for i in 0..W {
            let u = i as f64 / W as f64 * std::f64::consts::TAU;
            let v = j as f64 / H as f64;
            let band = (-(v - 0.5 - 0.3 * r).powi(2) / 0.05).exp() * (0.6 + 0.4 * (u - a + 2.0 * r).cos());
            f[j * W + i] += (0.3 * band + 0.1 * g * (1.0 - u / std::f64::consts::TAU)) as f32;
        }
    }
    f
}

/// The data set of every combination of `axes` (each parameter's values, the last fastest), of
/// `image4`'s parameters (elevation, azimuth, roll and, with four axes, light; azimuth
/// circular), named by their values.
pub(crate) fn grid_of(axes: &[Vec<f64>]) -> Dataset {
    let names = ["elevation", "azimuth", "roll", "light"];
    let params = (0..axes.len()).map(|j| if j == 1 { Param::circular(names[j], 360.0) } else { Param::linear(names[j]) }).collect();
    let space = PoseSpace::new(params).unwrap();
    let n: usize = axes.iter().map(Vec::len).product();
    let (mut poses, mut images, mut f) = (Vec::new(), Vec::new(), Vec::new());
    for mut k in 0..n {
        let mut p = vec![0.0; axes.len()];
        for j in (0..axes.len()).rev() {
            p[j] = axes[j][k % axes[j].len()];
            k /= axes[j].len();
        }
        let q = [p[0], p[1], *p.get(2).unwrap_or(&0.0), *p.get(3).unwrap_or(&0.0)];
        f.extend(image4(q[0], q[1], q[2], q[3]));
        images.push(format!("{}.png", p.iter().map(|v| v.to_string()).collect::<Vec<_>>().join("_")));
        poses.extend(p);
    }
    Dataset::from_features(Manifest::new(".", space, images, poses).unwrap(), spec(), f).unwrap()
}

fn spec() -> ImageSpec {
    ImageSpec { width: W as u32, height: H as u32, color: ColorMode::Gray }
}

/// COIL-like: 72 views 5 degrees apart, azimuth only.
fn turntable() -> Dataset {
    let space = PoseSpace::new(vec![Param::circular("azimuth", 360.0)]).unwrap();
    let poses: Vec<f64> = (0..72).map(|k| 5.0 * k as f64).collect();
    let images = (0..72).map(|k| format!("v{k}.png")).collect();
    let f = poses.iter().flat_map(|&a| image(45.0, a)).collect();
    Dataset::from_features(Manifest::new(".", space, images, poses).unwrap(), spec(), f).unwrap()
}

/// The paper's two angles on a coarse grid: elevation 30..66 step 3, azimuth 0..357 step 3.
fn sphere() -> Dataset {
    let space = PoseSpace::new(vec![Param::linear("elevation"), Param::circular("azimuth", 360.0)]).unwrap();
    let (mut poses, mut images, mut f) = (Vec::new(), Vec::new(), Vec::new());
    for el in (30..=66).step_by(3) {
        for az in (0..360).step_by(3) {
            poses.extend([el as f64, az as f64]);
            images.push(format!("{el}_{az}.png"));
            f.extend(image(el as f64, az as f64));
        }
    }
    Dataset::from_features(Manifest::new(".", space, images, poses).unwrap(), spec(), f).unwrap()
}

fn split(d: &Dataset, step: f64) -> (Dataset, Vec<bool>) {
    let mask = d.manifest().training_mask(&TrainSelection::Step(step)).unwrap();
    (d.subset(&mask).unwrap(), mask)
}

fn errors(model: &EigenspaceModel, d: &Dataset) -> Vec<f64> {
    let est = model.predict(d.features()).unwrap();
    let p = d.space().len();
    (0..d.len()).map(|i| d.space().error_deg(d.pose(i), &est[i * p..(i + 1) * p])).collect()
}

#[test]
fn one_parameter_recovers_training_poses_exactly_and_interpolates() {
    let d = turntable();
    let (train, mask) = split(&d, 10.0);
    assert_eq!(train.len(), 36);
    let model = EigenspaceParams::default().fit(&train).unwrap();
    assert_eq!(model.manifold_len(), 720);
    let e = errors(&model, &d);
    for (i, (&err, &seen)) in e.iter().zip(&mask).enumerate() {
        if seen {
            assert_eq!(err, 0.0, "training view {} is not recovered exactly", d.manifest().images()[i]);
        } else {
            // Halfway between two training views, on a smooth curve: the spline's error is small.
            assert!(err <= 1.0, "unseen view {} off by {err} degrees", d.manifest().images()[i]);
        }
    }
}

#[test]
fn two_parameters_recover_training_poses_exactly_and_interpolate() {
    let d = sphere();
    let (train, mask) = split(&d, 9.0);
    assert_eq!(train.len(), 5 * 40);
    let model = EigenspaceParams::default().components(12).manifold_step(1.0).fit(&train).unwrap();
    // Elevation 30..66 every degree (37 values; the knots are 30, 39, ..., 66) by azimuth 360.
    assert_eq!(model.settings().manifold_shape, vec![37, 360]);
    let e = errors(&model, &d);
    let mut unseen = Vec::new();
    for (i, (&err, &seen)) in e.iter().zip(&mask).enumerate() {
        if seen {
            assert!(err < 1e-9, "training view {} off by {err}", d.manifest().images()[i]);
        } else {
            unseen.push(err);
        }
    }
    let mean = unseen.iter().sum::<f64>() / unseen.len() as f64;
    assert!(mean < 1.0, "unseen mean error {mean}");
}

#[test]
fn manifold_at_the_training_step_passes_through_every_training_projection() {
    let d = sphere();
    let (train, _) = split(&d, 9.0);
    let model = EigenspaceParams::default().components(10).manifold_step(9.0).fit(&train).unwrap();
    assert_eq!(model.manifold_len(), train.len());
    let l = model.components();
    let mut y = vec![0f32; train.len() * l];
    model.project_into(train.features(), &mut y).unwrap();
    // The knots are the f64 coordinates rounded to f32; the f32 projection of the same image
    // differs by the f32 product's rounding, about sqrt(M) * eps_f32 against coordinates of
    // order one.
    let tol = 8.0 * ((W * H) as f32).sqrt() * f32::EPSILON;
    for i in 0..train.len() {
        let k = (0..model.manifold_len())
            .find(|&k| train.space().same_pose(&model.manifold_pose(k), train.pose(i), 1e-9))
            .expect("every training pose is a manifold point");
        let (a, b) = (&model.manifold_points()[k * l..(k + 1) * l], &y[i * l..(i + 1) * l]);
        for (x, z) in a.iter().zip(b) {
            assert!((x - z).abs() <= tol, "image {i}: manifold {x} vs projection {z}");
        }
    }
}

#[test]
fn tree_and_brute_force_give_the_same_poses() {
    let d = sphere();
    let (train, _) = split(&d, 9.0);
    let base = EigenspaceParams::default().components(8).manifold_step(1.0);
    let tree = base.search(SearchKind::KdTree).fit(&train).unwrap();
    let brute = base.search(SearchKind::Brute).fit(&train).unwrap();
    assert_eq!(tree.settings().search, SearchKind::KdTree);
    assert_eq!(brute.settings().search, SearchKind::Brute);
    assert_eq!(tree.predict(d.features()).unwrap(), brute.predict(d.features()).unwrap());
}

#[test]
fn model_file_round_trip_gives_the_same_predictions() {
    let d = sphere();
    let (train, _) = split(&d, 9.0);
    // 0.999 of the energy takes more than 32 components here, so this also covers brute force
    // beyond the tree's sizes; a coarse manifold keeps the debug build quick.
    let model = EigenspaceParams::default().energy(0.999).manifold_step(1.5).fit(&train).unwrap();
    assert!(model.components() > search::MAX_TREE_DIM);
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("m.safetensors");
    model.save(&path).unwrap();
    let back = crate::AnyModel::load(&path).unwrap();
    assert!(back.downcast_ref::<EigenspaceModel>().is_some());
    // serde_json reads floats back to within an ulp or so, so compare the metadata field by field.
    let (a, b) = (back.meta(), model.meta());
    assert_eq!((&a.method, a.spec, &a.space, &a.train_poses), (&b.method, b.spec, &b.space, &b.train_poses));
    assert_eq!(a.settings["components"], b.settings["components"]);
    assert_eq!(a.settings["manifold_shape"], b.settings["manifold_shape"]);
    assert_eq!(back.model_bytes(), model.model_bytes());
    assert_eq!(back.predict(d.features()).unwrap(), model.predict(d.features()).unwrap());
    // A manifold whose stored shape disagrees with the metadata is an error naming the tensor.
    let mut meta = model.meta().clone();
    meta.settings["manifold_shape"][0] = serde_json::json!(model.settings().manifold_shape[0] + 1);
    let set = crate::model::TensorSet { path: path.clone(), tensors: model.tensors() };
    let e = EigenspaceModel::from_parts(meta, &set).unwrap_err().to_string();
    assert!(e.contains("'manifold'") && e.contains("shape"), "{e}");
}

#[test]
fn model_bytes_count_every_stored_number() {
    let d = turntable();
    let (train, _) = split(&d, 10.0);
    let model = EigenspaceParams::default().fit(&train).unwrap();
    // 20 asked; the synthetic images' spectrum falls below the usable rank a little before.
    let l = model.components();
    assert!((15..=20).contains(&l), "{l}");
    // The second look: K components of images binned by b, and the training views' coordinates.
    let look = model.settings().second_look.clone().unwrap();
    let (k, mb) = (look.components, (W / look.bin) * (H / look.bin));
    assert!(k < train.len() && (W / look.bin) * (H / look.bin) >= train.len(), "{look:?}");
    assert_eq!(model.model_bytes(), (720 * l + l * W * H + W * H + k * mb + mb + train.len() * k) * 4 + 720 * 8);
}

#[test]
fn invalid_parameters_are_refused() {
    let (train, _) = split(&turntable(), 10.0);
    for (p, name) in [
        (EigenspaceParams::default().components(0), "components"),
        (EigenspaceParams::default().energy(0.0), "energy"),
        (EigenspaceParams::default().energy(1.5), "energy"),
        (EigenspaceParams::default().energy(f64::NAN), "energy"),
        (EigenspaceParams::default().manifold_step(0.0), "manifold step"),
        (EigenspaceParams::default().manifold_step(f64::INFINITY), "manifold step"),
        (EigenspaceParams::default().manifold_step(1e-9), "manifold step"),
    ] {
        let e = p.fit(&train).unwrap_err().to_string();
        assert!(e.contains(name), "{e}");
    }
}

#[test]
fn incomplete_grid_and_black_images_are_named() {
    let d = sphere();
    let (train, _) = split(&d, 9.0);
    let mask: Vec<bool> = (0..train.len()).map(|i| train.pose(i) != [39.0, 90.0]).collect();
    let holed = train.subset(&mask).unwrap();
    let e = EigenspaceParams::default().fit(&holed).unwrap_err().to_string();
    assert!(e.contains("elevation = 39, azimuth = 90"), "{e}");

    let mut f = train.features().to_vec();
    f[5 * W * H..6 * W * H].fill(0.0);
    let black = Dataset::from_features(train.manifest().clone(), spec(), f).unwrap();
    let e = EigenspaceParams::default().fit(&black).unwrap_err().to_string();
    assert!(e.contains(&train.manifest().images()[5]) && e.contains("all black"), "{e}");

    let model = EigenspaceParams::default().fit(&train).unwrap();
    let mut q = d.features()[..20 * W * H].to_vec();
    q[17 * W * H..18 * W * H].fill(0.0);
    let e = model.predict(&q).unwrap_err().to_string();
    assert!(e.contains("row 17 of the batch") && e.contains("all black"), "{e}");
    assert!(model.predict(&q[..W * H - 1]).is_err());
}

/// The 8-bit path (SIMD products, integer energy) finds the same manifold point as the f32 path
/// for 8-bit images, and its coordinates agree within 1e-5 (f32 rounding, or the 16-bit weights
/// of the integer kernel where it runs).
#[test]
fn u8_queries_match_f32_queries() {
    let d = turntable();
    let q8: Vec<u8> = d.features().iter().map(|&v| (v * 255.0).round().clamp(0.0, 255.0) as u8).collect();
    let qf: Vec<f32> = q8.iter().map(|&v| v as f32 / 255.0).collect();
    let (train, _) = split(&d, 10.0);
    let model = EigenspaceParams::default().components(8).fit(&train).unwrap();
    let (n, l) = (d.len(), model.components());
    let (mut yf, mut y8) = (vec![0f32; n * l], vec![0f32; n * l]);
    model.project_into(&qf, &mut yf).unwrap();
    model.project_u8_into(&q8, &mut y8).unwrap();
    for (a, b) in yf.iter().zip(&y8) {
        assert!((a - b).abs() < 1e-5, "{a} vs {b}");
    }
    // A batch (the blocked products) and one query at a time give the same bits.
    let qb: Vec<u8> = q8.iter().copied().cycle().take(5 * q8.len()).collect();
    let mut yb = vec![0f32; 5 * n * l];
    model.project_u8_into(&qb, &mut yb).unwrap();
    let mut one = vec![0f32; l];
    for (q, y) in qb.chunks_exact(W * H).zip(yb.chunks_exact(l)) {
        model.project_u8_into(q, &mut one).unwrap();
        assert_eq!(one.iter().map(|v| v.to_bits()).collect::<Vec<_>>(), y.iter().map(|v| v.to_bits()).collect::<Vec<_>>());
    }
    // A batch large enough to be split across threads (crate::model::split) gives the bits of
    // the same images in batches run whole on the calling thread.
    let copies = split::SPLIT_FROM_PIXELS.div_ceil(q8.len()) + 1;
    let qs: Vec<u8> = q8.iter().copied().cycle().take(copies * q8.len()).collect();
    assert!(split::splits(copies * n, W * H));
    let (mut ys, mut ps, mut p1) = (vec![0f32; copies * n * l], vec![0.0; copies * n], vec![0.0; n]);
    model.project_u8_into(&qs, &mut ys).unwrap();
    model.predict_u8_into(&qs, &mut ps).unwrap();
    model.predict_u8_into(&q8, &mut p1).unwrap();
    for (ys, ps) in ys.chunks_exact(n * l).zip(ps.chunks_exact(n)) {
        assert_eq!(ys.iter().map(|v| v.to_bits()).collect::<Vec<_>>(), y8.iter().map(|v| v.to_bits()).collect::<Vec<_>>());
        assert_eq!(ps, &p1[..]);
    }
    let mut p8 = vec![0.0; n];
    model.predict_u8_into(&q8, &mut p8).unwrap();
    let pf = model.predict(&qf).unwrap();
    let same = pf.iter().zip(&p8).filter(|(a, b)| a == b).count();
    assert!(same >= n - 1, "{same} of {n} estimates identical");
    assert!(model.predict_u8_into(&vec![0u8; W * H], &mut [0.0]).is_err(), "a black image is refused");
}

/// A batch too small to split runs whole (in tasks of at most U8_BATCH); a larger one splits in
/// whole blocks of at least half the threshold's pixels, at most U8_BATCH.
#[test]
fn u8_tasks_follow_the_split_threshold() {
    for m in [64, 128 * 128, 640 * 480] {
        for block in [4, 6, 16] {
            for n in [8, 72, 100, 1000, 10_000] {
                let (rows, parallel) = u8_tasks(n, m, block);
                assert_eq!(parallel, split::splits(n, m), "{n} x {m}");
                assert!(rows.is_multiple_of(block) && rows <= U8_BATCH, "{n} x {m}: {rows}");
                if parallel {
                    assert!(rows >= split::min_task_queries(m).min(U8_BATCH / block * block), "{n} x {m}: {rows}");
                } else {
                    assert_eq!(rows, (n.div_ceil(block) * block).min(U8_BATCH / block * block), "{n} x {m}");
                }
            }
        }
    }
    assert!(split::splits(10_000, 640 * 480));
}
