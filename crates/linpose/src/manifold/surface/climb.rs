//! The climb: a walk over the reporting lattice to a local least of a cost of the surface's
//! values.

use super::Surface;
use crate::kernels::{surface as kernel, Level};

impl Surface {
    /// Moves `t`, a pose on the lattice of `step` degrees anchored at the first knot of each axis,
    /// to a local least over that lattice of the distance to `y` (weighted by `wt`): to the best
    /// of its 3^D - 1 neighbours (a circular axis wraps, a linear one ends at its last lattice
    /// point) as long as one is closer; returns its squared distance. Every move lowers the
    /// distance, so no pose is visited twice and the walk ends (from the coarse tree's point it
    /// takes a step or two).
    pub(crate) fn climb(&self, y: &[f32], wt: &[f64], t: &mut [f64], step: f64) -> f64 {
        // Coordinates of zero weight add nothing.
        let lo = wt.iter().rposition(|&w| w != 0.0).map_or(0, |i| i + 1).min(y.len());
        let lanes = lo.div_ceil(8) * 8;
        // On the stack up to the block climb's width (a query's only allocation otherwise).
        let (mut stack, mut heap) = ([0f64; 2 * BLOCK_DIM], Vec::new());
        let both = if 2 * lanes <= stack.len() {
            &mut stack[..2 * lanes]
        } else {
            heap.resize(2 * lanes, 0.0);
            &mut heap[..]
        };
        let (y64, w64) = both.split_at_mut(lanes);
        y64[..lo].iter_mut().zip(y).for_each(|(o, &v)| *o = v as f64);
        w64[..lo].copy_from_slice(&wt[..lo]);
        let (y64, w64) = (&*y64, &*w64);
        let level = Level::detect();
        self.climb_pair(None, lo, t, step, |f, _| kernel::lane_distance(level, y64, w64, f))
    }

    /// The lattice of `step` degrees at `t` (anchored at each axis's first knot): per axis the
    /// index of the lattice point nearest to t (wrapped on a circular axis, kept in the domain
    /// on a linear one), the count of a circular axis's points or the last index of a linear
    /// one's, and whether the axis is circular.
    fn lattice_at(&self, t: &[f64], step: f64) -> ([i64; 8], [i64; 8], [bool; 8]) {
        let (mut idx, mut count, mut circ) = ([0i64; 8], [0i64; 8], [false; 8]);
        for j in 0..self.params() {
            let (lo, hi) = self.splines[j].span();
            idx[j] = ((t[j] - lo) / step).round() as i64;
            (count[j], circ[j]) = match self.periods[j] {
                Some(p) => ((p / step).round() as i64, true),
                None => (((hi - lo) / step + 1e-9).floor() as i64, false),
            };
            idx[j] = if circ[j] { idx[j].rem_euclid(count[j].max(1)) } else { idx[j].clamp(0, count[j]) };
        }
        (idx, count, circ)
    }

    /// [`Surface::climb`] on any `cost` of the pose (which evaluates what it needs at the pose
    /// it is given): `t` moves to a local least of it over the lattice of `step` degrees, which
    /// is returned.
    pub(crate) fn climb_by(&self, t: &mut [f64], step: f64, mut cost: impl FnMut(&[f64]) -> f64) -> f64 {
        let d = self.params();
        let mut at = |idx: &[i64; 8], pose: &mut [f64; 8]| {
            for j in 0..d {
                pose[j] = self.splines[j].span().0 + idx[j] as f64 * step;
            }
            cost(&pose[..d])
        };
        let (mut idx, count, circ) = self.lattice_at(t, step);
        let mut pose = [0f64; 8];
        let mut best = at(&idx, &mut pose);
        let mut best_pose = pose;
        loop {
            let mut moved = None;
            let mut cand = [0i64; 8];
            'next: for code in 0..3usize.pow(d as u32) {
                let mut c = code;
                for j in 0..d {
                    let k = lattice_step(idx[j] + (c % 3) as i64 - 1, count[j], circ[j]);
                    c /= 3;
                    let Some(k) = k else { continue 'next };
                    cand[j] = k;
                }
                if cand[..d] == idx[..d] {
                    continue;
                }
                let v = at(&cand, &mut pose);
                if v < best {
                    (best, best_pose, moved) = (v, pose, Some(cand));
                }
            }
            match moved {
                Some(c) => idx = c,
                None => break,
            }
        }
        t.copy_from_slice(&best_pose[..d]);
        best
    }
}

/// Lattice index `k` along an axis of [`Surface::lattice_at`]'s `count` and `circ`: wrapped on
/// a circular axis, None past either end of a linear one.
fn lattice_step(k: i64, count: i64, circ: bool) -> Option<i64> {
    if circ {
        Some(k.rem_euclid(count.max(1)))
    } else {
        (0..=count).contains(&k).then_some(k)
    }
}

/// The lattice indices of a 3 x 3 block along each axis (None past a linear axis's end).
type BlockAt = [[Option<i64>; 3]; 2];

/// Most coordinates [`Surface::climb_pair`] evaluates in blocks (more go point by point).
pub(crate) use crate::kernels::surface::BLOCK_DIM;

impl Surface {
    /// [`Surface::climb_by`] on a cost of the surface's values (the first `lo` coordinates) and,
    /// with `other` (a surface on the same knots), of its values at the same pose:
    /// `cost(f, g)`, each given in `lo` rounded up to a multiple of 8 values, zero beyond `lo`
    /// (`g` all zero without `other`), so that the cost can sum them 8 lanes at a time. With two parameters the 3 x 3 lattice points
    /// around the walk's pose are evaluated together (`Surface::block2`): the sums along the
    /// second axis are shared by the three points along the first, about 84 vector terms for
    /// the 9 points instead of 144 (their values agree with [`Surface::eval`]'s to rounding; the
    /// sums are taken in another order). The walk is [`Surface::climb_by`]'s: the same
    /// neighbours in the same order, to the best one while it is closer. After a move the
    /// points the new block shares with the last keep their costs: 3 new points after a move
    /// along one axis, 5 after a diagonal one, instead of 9.
    pub(crate) fn climb_pair(&self, other: Option<&Surface>, lo: usize, t: &mut [f64], step: f64, mut cost: impl FnMut(&[f64], &[f64]) -> f64) -> f64 {
        let d = self.params();
        let lanes = lo.div_ceil(8) * 8;
        if d != 2 || lo > BLOCK_DIM {
            let (mut f, mut g) = (vec![0.0; lanes], vec![0.0; lanes]);
            return self.climb_by(t, step, |pose| {
                match other {
                    Some(o) => self.eval_pair(o, pose, &mut f[..lo], None, &mut g[..lo], None),
                    None => self.eval(pose, &mut f[..lo], None),
                }
                cost(&f, &g)
            });
        }
        let (idx8, count, circ) = self.lattice_at(t, step);
        let mut idx = [idx8[0], idx8[1]];
        // Lanes from lo on stay zero: block2 writes the first lo.
        let mut fv = [[0f64; BLOCK_DIM]; 9];
        let mut gv = [[0f64; BLOCK_DIM]; 9];
        let mut best = f64::NAN;
        // The last block's lattice indices and costs: after a move, the points the new block
        // shares with it keep their costs (a point's values do not depend on the others
        // evaluated with it), and only the new row and column are evaluated.
        let mut last: Option<(BlockAt, [f64; 9])> = None;
        loop {
            // The 3 lattice indices along each axis (None outside a linear axis).
            let mut at = [[None; 3]; 2];
            for j in 0..2 {
                for (s3, slot) in at[j].iter_mut().enumerate() {
                    *slot = lattice_step(idx[j] + s3 as i64 - 1, count[j], circ[j]);
                }
            }
            let pos = |j: usize, k: i64| self.splines[j].span().0 + k as f64 * step;
            let mut costs = [f64::NAN; 9];
            // Per axis, where each position stood in the last block (None: new).
            let mut was = [[None; 3]; 2];
            if let Some((old_at, old_costs)) = &last {
                for j in 0..2 {
                    for s3 in 0..3 {
                        was[j][s3] = at[j][s3].and_then(|k| old_at[j].iter().position(|&o| o == Some(k)));
                    }
                }
                for code in 0..9 {
                    if let (Some(a), Some(b)) = (was[0][code % 3], was[1][code / 3]) {
                        costs[code] = old_costs[a + 3 * b];
                    }
                }
            }
            // The points not kept, as at most two grids: the new positions along the first
            // axis at every second-axis position, then the kept ones at the new second-axis
            // positions.
            let fresh0 = std::array::from_fn::<_, 3, _>(|s3| was[0][s3].is_none());
            let fresh1 = std::array::from_fn::<_, 3, _>(|s3| was[1][s3].is_none());
            let grid = |sel0: [bool; 3], sel1: [bool; 3]| {
                (
                    std::array::from_fn::<_, 3, _>(|s3| if sel0[s3] { at[0][s3].map(|k| pos(0, k)) } else { None }),
                    std::array::from_fn::<_, 3, _>(|s3| if sel1[s3] { at[1][s3].map(|k| pos(1, k)) } else { None }),
                )
            };
            for (sel0, sel1) in [(fresh0, [true; 3]), (fresh0.map(|f| !f), fresh1)] {
                let (p0, p1) = grid(sel0, sel1);
                if p0.iter().any(Option::is_some) && p1.iter().any(Option::is_some) {
                    self.block2(other, lo, &p0, &p1, &mut fv, &mut gv);
                    for code in 0..9 {
                        if p0[code % 3].is_some() && p1[code / 3].is_some() {
                            costs[code] = cost(&fv[code][..lanes], &gv[code][..lanes]);
                        }
                    }
                }
            }
            if last.is_none() {
                best = costs[4];
            }
            // climb_by's order: the first axis fastest.
            let mut moved = None;
            for (code, &v) in costs.iter().enumerate() {
                let (a, b) = (code % 3, code / 3);
                if code == 4 || at[0][a].is_none() || at[1][b].is_none() {
                    continue;
                }
                if v < best {
                    (best, moved) = (v, Some([at[0][a].unwrap(), at[1][b].unwrap()]));
                }
            }
            match moved {
                Some(c) => idx = c,
                None => break,
            }
            last = Some((at, costs));
        }
        for j in 0..2 {
            t[j] = self.splines[j].span().0 + idx[j] as f64 * step;
        }
        best
    }

    /// For D = 2: the first `lo` values of this surface (into `fv`) and of `other` (into `gv`)
    /// at the 3 x 3 poses (`p0[a]`, `p1[b]`), point a + 3 b; a None position is skipped. For each
    /// position b and each knot interval of the first axis among the p0, the 4 sums along the
    /// second axis (value and slope at the interval's two knots) are formed once; each point
    /// then sums those 4 with its first-axis weights.
    pub(crate) fn block2(
        &self,
        other: Option<&Surface>,
        lo: usize,
        p0: &[Option<f64>; 3],
        p1: &[Option<f64>; 3],
        fv: &mut [[f64; BLOCK_DIM]; 9],
        gv: &mut [[f64; BLOCK_DIM]; 9],
    ) {
        let block = || kernel::Block { w0: p0.map(|p| p.map(|t| self.splines[0].weights_d(t))), w1: p1.map(|p| p.map(|t| self.splines[1].weights_d(t))), lo };
        if !kernel::block2(Level::detect(), self.grid2(), self.coefs(), other.map(Surface::coefs), block, fv, gv) {
            self.block2_body(other, lo, p0, p1, fv, gv)
        }
    }

    #[inline(always)]
    pub(crate) fn block2_body(
        &self,
        other: Option<&Surface>,
        lo: usize,
        p0: &[Option<f64>; 3],
        p1: &[Option<f64>; 3],
        fv: &mut [[f64; BLOCK_DIM]; 9],
        gv: &mut [[f64; BLOCK_DIM]; 9],
    ) {
        let n = self.shape[0] * self.shape[1];
        let w0: [Option<([f64; 4], usize, usize)>; 3] = p0.map(|p| {
            p.map(|t| {
                let (w, _, i, j) = self.splines[0].weights_d(t);
                (w, i, j)
            })
        });
        let w1: [Option<([f64; 4], usize, usize)>; 3] = p1.map(|p| {
            p.map(|t| {
                let (w, _, i, j) = self.splines[1].weights_d(t);
                (w, i, j)
            })
        });
        // h[p][..lo]: sum over q of w1[q] coef[row(p, q)], for one interval and one b.
        let mut h = [[0f64; BLOCK_DIM]; 4];
        let mut hg = [[0f64; BLOCK_DIM]; 4];
        for (b, w1b) in w1.iter().enumerate() {
            let Some((wq, i1, j1)) = *w1b else { continue };
            let k1 = [i1 * self.stride[1], j1 * self.stride[1]];
            let mut done = [false; 3];
            for a in 0..3 {
                let Some((_, i0, j0)) = w0[a] else { continue };
                if done[a] {
                    continue;
                }
                let k0 = [i0 * self.stride[0], j0 * self.stride[0]];
                for p in 0..4 {
                    let sum = |acc: &mut [f64; BLOCK_DIM], coef: &[f32], dim: usize| {
                        let acc = &mut acc[..lo];
                        acc.fill(0.0);
                        for q in 0..4 {
                            let row = (((p & 1) | (q & 1) << 1) * n + k0[p >> 1] + k1[q >> 1]) * dim;
                            let w = wq[q];
                            acc.iter_mut().zip(&coef[row..row + lo]).for_each(|(v, &x)| *v += w * x as f64);
                        }
                    };
                    sum(&mut h[p], &self.coef, self.dim);
                    if let Some(o) = other {
                        sum(&mut hg[p], &o.coef, o.dim);
                    }
                }
                // Every first-axis position in this interval takes its point from these sums.
                for a2 in a..3 {
                    let Some((wp, i2, _)) = w0[a2] else { continue };
                    if i2 != i0 {
                        continue;
                    }
                    done[a2] = true;
                    let point = |out: &mut [f64; BLOCK_DIM], h: &[[f64; BLOCK_DIM]; 4]| {
                        let out = &mut out[..lo];
                        out.fill(0.0);
                        for (p, hp) in h.iter().enumerate() {
                            let w = wp[p];
                            out.iter_mut().zip(&hp[..lo]).for_each(|(v, &x)| *v += w * x);
                        }
                    };
                    point(&mut fv[a2 + 3 * b], &h);
                    if other.is_some() {
                        point(&mut gv[a2 + 3 * b], &hg);
                    }
                }
            }
        }
    }
}
