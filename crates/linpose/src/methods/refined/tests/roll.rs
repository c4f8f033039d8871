//! A camera roll: knots between the training rolls, training views turned in the image
//! (`manifold::roll`), on a rendered duck whose roll turns the camera about its optical axis.

use super::*;
use crate::render::synth::{dataset, PoseGrid};
use crate::render::{objects, Grid as RenderGrid, RenderParams};
use std::path::Path;

/// The duck at 48 x 36, azimuth every 20 degrees, elevation 32, 50, 68 and roll -30 to 30 every
/// 10: the training views at roll -30, -10, 10 and 30 (knots 20 degrees apart), and the views at
/// roll -20, 0 and 20, halfway between, at the training azimuths and elevations.
fn rolled_duck() -> (Dataset, Dataset) {
    let mesh = objects::builtin("duck").unwrap();
    let grid = PoseGrid::new(RenderGrid::parse("elevation", "32:68:18").unwrap(), RenderGrid::parse("azimuth", "0:340:20").unwrap())
        .unwrap()
        .with_roll(RenderGrid::parse("roll", "-30:30:10").unwrap())
        .unwrap();
    let all = dataset(&mesh, &grid, &RenderParams::default().width(48).height(36), Path::new("<render>"), &|_| {}).unwrap();
    let r = all.space().in_plane_roll().unwrap();
    let on_knot: Vec<bool> = (0..all.len()).map(|i| (all.pose(i)[r] + 30.0) % 20.0 == 0.0).collect();
    let between: Vec<bool> = on_knot.iter().map(|k| !k).collect();
    (all.subset(&on_knot).unwrap(), all.subset(&between).unwrap())
}

fn mean_error(model: &RefinedModel, d: &Dataset) -> f64 {
    let est = model.predict(d.features()).unwrap();
    let p = d.space().len();
    (0..d.len()).map(|i| d.space().error_deg(d.pose(i), &est[i * p..(i + 1) * p])).sum::<f64>() / d.len() as f64
}

#[test]
fn turned_views_between_the_training_rolls_hold_the_surface_to_the_images_there() {
    let (train, between) = rolled_duck();
    let split = RefinedParams::default().fit(&train).unwrap();
    let s = split.settings();
    // A roll that only turns the image: turning a training view to the next training roll
    // reproduces the view there but for its corners and the bilinear blur.
    let turn = s.roll_turn_error.unwrap();
    assert!(turn < 0.05, "{turn}");
    assert_eq!((s.roll_split, s.knot_shape.clone()), (Some(2), vec![3, 18, 7]));
    assert_eq!(split.knots_len(), 3 * 18 * 7);
    let plain = RefinedParams::default().roll_split(1).fit(&train).unwrap();
    assert_eq!((plain.settings().roll_split, plain.settings().knot_shape.clone()), (None, vec![3, 18, 4]));
    // The searches start from the same points: the turned views refine the surface only.
    assert_eq!(split.start_poses, plain.start_poses);
    let (e_split, e_plain) = (mean_error(&split, &between), mean_error(&plain, &between));
    assert!(e_split < 0.5 * e_plain, "between the training rolls: {e_split} with the turned views, {e_plain} without");
    // The training views stay where they are.
    assert!(mean_error(&split, &train) <= mean_error(&plain, &train) + 0.1);
}
