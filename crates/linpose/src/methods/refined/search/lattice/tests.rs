use super::*;
use crate::manifold::surface::{Interpolant, Surface, INTERPOLANTS};
use crate::pose::{Param, PoseSpace};

struct Rng(u64);
impl Rng {
    fn next(&mut self) -> f64 {
        self.0 ^= self.0 << 13;
        self.0 ^= self.0 >> 7;
        self.0 ^= self.0 << 17;
        (self.0 >> 11) as f64 / (1u64 << 53) as f64 - 0.5
    }
}

/// A random curve of `dim` coordinates through knots at `at`.
fn curve(at: &[f64], dim: usize, circular: bool, interpolant: Interpolant, rng: &mut Rng) -> Surface {
    let space = PoseSpace::new(vec![if circular { Param::circular("azimuth", 360.0) } else { Param::linear("elevation") }]).unwrap();
    let knots: Vec<f64> = (0..at.len() * dim).map(|_| rng.next()).collect();
    Surface::new(&space, &[at.to_vec()], &knots, dim, interpolant).unwrap()
}

/// Every lattice pose of `s` (and the end of a linear axis) with its weighted squared
/// distance to `y`, evaluated point by point.
fn brute(s: &Surface, y: &[f32], wt: &[f64], step: f64) -> Vec<(f64, f64)> {
    let (at, period, _, _, dim) = s.line_parts().unwrap();
    let (lo, hi) = (at[0], at[at.len() - 1]);
    let mut poses: Vec<f64> = (0..).map(|k| lo + k as f64 * step).take_while(|&t| if period.is_some() { t < hi - 1e-9 } else { t <= hi + 1e-9 }).collect();
    if period.is_none() && *poses.last().unwrap() < hi {
        poses.push(hi);
    }
    let mut f = vec![0.0; dim];
    poses
        .into_iter()
        .map(|t| {
            let mut tc = [t];
            s.clamp(&mut tc);
            s.eval(&tc, &mut f, None);
            (t, y.iter().zip(&f).zip(wt).map(|((&a, &b), &w)| w * (a as f64 - b) * (a as f64 - b)).sum())
        })
        .collect()
}

#[test]
fn the_lattice_search_finds_the_least_of_every_lattice_pose() {
    let mut rng = Rng(0x2545_f491_4f6c_dd1d);
    let even36: Vec<f64> = (0..36).map(|k| 10.0 * k as f64).collect();
    let uneven: Vec<f64> = (0..20).map(|k| 18.0 * k as f64 + if k % 3 == 1 { 4.3 } else { 0.0 }).collect();
    let linear: Vec<f64> = (0..12).map(|k| 20.0 + 5.0 * k as f64 + if k == 11 { 0.3 } else { 0.0 }).collect();
    // One interval off the lattice's step: even, with its end off the lattice.
    let single = [20.0, 25.3];
    let cases: [(&[f64], bool, usize, usize); 5] =
        [(&even36, true, 20, 20), (&even36, true, 12, 8), (&uneven, true, 9, 9), (&linear, false, 6, 6), (&single, false, 5, 5)];
    let mut pruned = 0;
    // Each case with either interpolant: the search takes any cubic Hermite curve.
    for (k, (at, circular, dim, ls)) in cases.into_iter().flat_map(|c| [c, c]).enumerate() {
        let s = curve(at, dim, circular, INTERPOLANTS[k % 2], &mut rng);
        let (knots, period, v, sl, d) = s.line_parts().unwrap();
        let lat = Lattice::new(knots, period, v, sl, d, ls, 0.5);
        let even = std::ptr::eq(at, &even36[..]) || std::ptr::eq(at, &single[..]);
        assert_eq!(lat.even.is_empty(), !even, "evenly spaced knots take the bounded search");
        assert_eq!(lat.end.is_some(), std::ptr::eq(at, &single[..]) || std::ptr::eq(at, &linear[..]));
        let mut scratch = Vec::new();
        let mut f = vec![0.0; dim];
        for q in 0..60 {
            // Queries near the curve (a pose off the lattice, plus noise) and far from it.
            let t = knots[0] + (rng.next() + 0.5) * (knots[knots.len() - 1] - knots[0]);
            s.eval(&[t], &mut f, None);
            let spread = if q % 3 == 0 { 0.3 } else { 0.003 };
            let y: Vec<f32> = f.iter().map(|&x| (x + spread * rng.next()) as f32).collect();
            let uniform = q % 2 == 0;
            let wt: Vec<f64> = (0..dim)
                .map(|l| {
                    if l >= ls {
                        0.0
                    } else if uniform {
                        0.7
                    } else {
                        0.2 + rng.next().abs()
                    }
                })
                .collect();
            let got = lat.nearest(&y, &wt, uniform.then_some(0.7), &mut scratch);
            let port = Level::supported()[0];
            let portable =
                if lat.even.is_empty() { lat.nearest_body(&y, &wt, uniform.then_some(0.7), &mut scratch, port) } else { lat.nearest_even(&y, &wt, port) };
            assert_eq!(got.to_bits(), portable.to_bits(), "the AVX-512 build gives the portable one's pose");
            if !lat.even.is_empty() {
                pruned += pruned_as_full(&lat, &y, &wt) as usize;
            }
            let all = brute(&s, &y, &wt, 0.5);
            let least = all.iter().map(|p| p.1).fold(f64::INFINITY, f64::min);
            let at_got = all.iter().find(|p| (p.0 - got).abs() < 1e-9).unwrap_or_else(|| panic!("{got} is not a lattice pose"));
            // The least up to the rounding of the expanded distance.
            assert!(at_got.1 <= least + 1e-12 * (1.0 + least), "query {q}: {got} at {} against the least {least}", at_got.1);
        }
    }
    if Level::detect().avx512() {
        assert!(pruned >= 20, "the uniform queries near the curve take the pruned scan: {pruned}");
    }
}

/// Whether the pruned scan of an even lattice ran for `y` (else it left the full scan to
/// run), asserting that it found the full scan's poses within the cut; false without AVX-512.
fn pruned_as_full(lat: &Lattice, y: &[f32], wt: &[f64]) -> bool {
    let ls = lat.ls;
    let (wmin, wmax) = wt[..ls].iter().fold((f64::INFINITY, 0f64), |(a, b), &w| (a.min(w), b.max(w)));
    let yy: f64 = y[..ls].iter().map(|&v| v as f64 * v as f64).sum();
    let slack = 1e-5 * (1.0 + yy + lat.norm_max + yy.sqrt() * lat.span_max);
    let cut_of = |least: f32| ((wmax * (least as f64 + slack)) / wmin + slack) as f32;
    let (c, nj) = (lat.cols, lat.even.len());
    let np = lat.norms.len() / nj;
    let mut buf = vec![0f32; 2 * (c + 16) + (nj * np).max(np + PRUNE_MAX * lat.herm_t.len() / 4)];
    let (mut full, mut pruned) = (Vec::new(), Vec::new());
    let q = crate::kernels::lattice::EvenQuery { yy: yy as f32, slack };
    match crate::kernels::lattice::even_scans::<PRUNE_MAX>(Level::detect(), lat.view(), y, q, &cut_of, &mut buf, (&mut pruned, &mut full)) {
        None => return false,
        Some(false) => {
            assert!(pruned.is_empty());
            return false;
        }
        Some(true) => {}
    }
    pruned.sort_unstable();
    full.sort_unstable();
    assert!(!full.is_empty());
    assert_eq!(pruned, full, "the pruned scan's poses are the full scan's");
    true
}
