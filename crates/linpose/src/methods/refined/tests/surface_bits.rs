//! The SIMD kernels of this module against their portable bodies, bit for bit (the portable
//! bodies are what a machine without AVX-512 runs).
use crate::kernels::surface::{lane_distance, lane_distance_body};
use crate::kernels::Level;
use crate::manifold::surface::*;
use crate::pose::{wrap_positive, PoseSpace};
use crate::methods::refined::noisy::AffineQuery;
use crate::Param;

/// A surface and an offset surface of `dim` coordinates on a 6 x 37 grid (elevation 30 to
/// 70, azimuth around), from a fixed pseudo-random sequence.
fn pair(dim: usize) -> (Surface, Surface) {
    let space = PoseSpace::new(vec![Param::linear("e"), Param::circular("a", 360.0)]).unwrap();
    let axes = vec![(0..6).map(|k| 30.0 + 8.0 * k as f64).collect::<Vec<_>>(), (0..37).map(|k| 9.5 * k as f64).collect::<Vec<_>>()];
    let n = 6 * 37 * dim;
    let f: Vec<f64> = (0..n).map(|i| ((i * 7919) % 1013) as f64 / 500.0 - 1.0).collect();
    let g: Vec<f64> = (0..n).map(|i| ((i * 104729) % 997) as f64 / 3000.0).collect();
    (Surface::new(&space, &axes, &f, dim, Interpolant::Spline).unwrap(), Surface::new(&space, &axes, &g, dim, Interpolant::Spline).unwrap())
}

fn bits(v: &[f64]) -> Vec<u64> {
    v.iter().map(|x| x.to_bits()).collect()
}

#[test]
fn the_block_and_the_costs_give_their_portable_bits() {
    for dim in [1, 5, 12, 20, 32] {
        let (s, o) = pair(dim);
        let lanes = dim.div_ceil(8) * 8;
        let z: Vec<f64> = (0..dim).map(|i| 0.3 - 0.05 * i as f64).collect();
        let c: Vec<f64> = (0..dim).map(|i| 0.01 * i as f64).collect();
        let w: Vec<f64> = (0..dim).map(|i| 1.0 / (1.0 + i as f64)).collect();
        let q = AffineQuery::new(&z, &c, &w);
        let (mut y, mut wl) = (vec![0.0; lanes], vec![0.0; lanes]);
        y[..dim].copy_from_slice(&z);
        wl[..dim].copy_from_slice(&w);
        // Blocks inside one knot cell, across cells, at the ends of the linear axis and
        // across the circular one's wrap.
        for (e, a) in [(33.0, 17.0), (38.0, 9.5), (30.0, 0.0), (70.0, 359.5), (54.0, 180.0)] {
            let p0 = [-0.5, 0.0, 0.5].map(|d: f64| Some(e + d).filter(|v| (30.0..=70.0).contains(v)));
            let p1 = [-0.5, 0.0, 0.5].map(|d: f64| Some(wrap_positive(a + d, 360.0)));
            for other in [None, Some(&o)] {
                let (mut fa, mut ga) = ([[0f64; BLOCK_DIM]; 9], [[0f64; BLOCK_DIM]; 9]);
                let (mut fb, mut gb) = ([[0f64; BLOCK_DIM]; 9], [[0f64; BLOCK_DIM]; 9]);
                s.block2(other, dim, &p0, &p1, &mut fa, &mut ga);
                s.block2_body(other, dim, &p0, &p1, &mut fb, &mut gb);
                for k in 0..9 {
                    assert_eq!((bits(&fa[k]), bits(&ga[k])), (bits(&fb[k]), bits(&gb[k])), "dim {dim}, ({e}, {a}), point {k}");
                    let (f, g) = (&fa[k][..lanes], &ga[k][..lanes]);
                    assert_eq!(q.residual(f, g).to_bits(), q.residual_body(f, g).to_bits(), "dim {dim}, point {k}");
                    assert_eq!(lane_distance(Level::detect(), &y, &wl, f).to_bits(), lane_distance_body(&y, &wl, f).to_bits(), "dim {dim}, point {k}");
                    // The block's points are the surface's to rounding.
                    if let (Some(t0), Some(t1)) = (p0[k % 3], p1[k / 3]) {
                        let mut v = vec![0.0; dim];
                        s.eval(&[t0, t1], &mut v, None);
                        for (x, want) in fa[k][..dim].iter().zip(&v) {
                            assert!((x - want).abs() <= 1e-12 * (1.0 + want.abs()), "dim {dim}, point {k}: {x} against {want}");
                        }
                    }
                }
            }
        }
    }
}

#[test]
fn two_parameter_values_give_the_general_paths_bits() {
    for dim in [3, 12, 20] {
        let (s, o) = pair(dim);
        for t in [[33.3, 17.2], [70.0, 359.9], [30.0, 0.0], [51.7, 200.05]] {
            let (mut f, mut g, mut jf, mut jg) = (vec![0.0; dim], vec![0.0; dim], vec![0.0; 2 * dim], vec![0.0; 2 * dim]);
            // The general path (with derivatives) against values2, portable and dispatched.
            s.eval_body(&t, &mut f, Some(&mut jf), Some((&o, &mut g, Some(&mut jg))));
            let (mut f2, mut g2) = (vec![0.0; dim], vec![0.0; dim]);
            s.values2(&t, &mut f2, Some((&o, &mut g2)));
            assert_eq!((bits(&f), bits(&g)), (bits(&f2), bits(&g2)), "portable, {t:?}");
            s.eval_pair(&o, &t, &mut f2, None, &mut g2, None);
            assert_eq!((bits(&f), bits(&g)), (bits(&f2), bits(&g2)), "dispatched, {t:?}");
            // With derivatives, dispatched (the CPU's best build) against the portable body.
            let (mut f3, mut g3, mut jf3, mut jg3) = (vec![0.0; dim], vec![0.0; dim], vec![0.0; 2 * dim], vec![0.0; 2 * dim]);
            s.eval_pair(&o, &t, &mut f3, Some(&mut jf3), &mut g3, Some(&mut jg3));
            assert_eq!((bits(&f), bits(&jf), bits(&g), bits(&jg)), (bits(&f3), bits(&jf3), bits(&g3), bits(&jg3)), "dispatched pair, {t:?}");
            s.eval(&t, &mut f3, Some(&mut jf3));
            assert_eq!((bits(&f), bits(&jf)), (bits(&f3), bits(&jf3)), "dispatched, {t:?}");
        }
    }
}
