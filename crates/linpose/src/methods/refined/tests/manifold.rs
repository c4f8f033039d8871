//! The surface: its values against the eigenspace's manifold and each axis's curve, pairs of
//! surfaces, and the climb.

use super::*;

#[test]
fn surface_resamples_to_the_eigenspace_manifold() {
    // The surface at the eigenspace's dense positions gives its manifold points (same spline).
    let d = train_set();
    let pca = crate::manifold::pca::fit(&d, Dimension::Fixed(6)).unwrap();
    let g = Grid::new(d.space(), d.poses(), d.manifest().images(), d.manifest().root()).unwrap();
    let dense = crate::manifold::grid::Manifold::build(d.space(), &g, &pca.coords, 6, 5.0).unwrap();
    let knots: Vec<f64> = g.sample_at.iter().flat_map(|&i| pca.coords[i * 6..(i + 1) * 6].iter().copied()).collect();
    let s = crate::manifold::surface::Surface::new(d.space(), &g.axes, &knots, 6, crate::manifold::surface::Interpolant::Spline).unwrap();
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
    use crate::manifold::spline::Boundary;
    let d = train_set();
    let g = Grid::new(d.space(), d.poses(), d.manifest().images(), d.manifest().root()).unwrap();
    let shape = g.shape();
    let n: usize = shape.iter().product();
    let v: Vec<f64> = (0..n).map(|i| ((i * 7919) % 1013) as f64 / 500.0 - 1.0).collect();
    let boundary = |j: usize| d.space().params()[j].period.map_or(Boundary::NotAKnot, Boundary::Periodic);
    for interpolant in INTERPOLANTS.iter().copied() {
        let s = crate::manifold::surface::Surface::new(d.space(), &g.axes, &v, 1, interpolant).unwrap();
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
        crate::manifold::surface::Surface::new(d.space(), &g.axes, &a, 5, crate::manifold::surface::Interpolant::Spline).unwrap(),
        crate::manifold::surface::Surface::new(d.space(), &g.axes, &b, 5, crate::manifold::surface::Interpolant::Spline).unwrap(),
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
