//! The clean search: the coarse starts, the lattice search on a turntable, the coarse tree.

use super::*;

#[test]
fn the_starts_are_the_smallest_within_twice_the_least() {
    assert_eq!(smallest(&[3.0, 1.0, 1.5, 0.6, 5.0, 1.0], 3), vec![(0.6, 3), (1.0, 1), (1.0, 5)]);
    assert_eq!(smallest(&[3.0, 1.0, 1.5, 0.6, 5.0, 1.0], 1), vec![(0.6, 3)]);
    // An exact match (distance 0) leaves only the exact matches; the least is always kept.
    assert_eq!(smallest(&[0.2, 0.0, 0.1], 8), vec![(0.0, 1)]);
    assert_eq!(smallest(&[7.0; 20].iter().enumerate().map(|(i, v)| v + i as f32).collect::<Vec<_>>(), 2), vec![(7.0, 0), (8.0, 1)]);
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
