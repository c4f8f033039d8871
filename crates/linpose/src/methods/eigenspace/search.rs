//! Nearest manifold point: a k-d tree ([`crate::manifold::kdtree`]) or brute force.
//!
//! Brute force pads the L coordinates with zeros to the next of a few sizes (4, 8, ..., 24, 32),
//! whose fixed width lets the distance loop unroll and vectorise; a zero added to both the query
//! and every point leaves every distance unchanged. Both searches sum a distance's squared
//! differences coordinate by coordinate in order, so the tree returns brute force's point, ties
//! included. Beyond 32 coordinates only brute force is available.

use crate::manifold::kdtree::KdTree;
use crate::{Error, Result};
use serde::{Deserialize, Serialize};
use super::tuning::AUTO_TREE_FROM;

/// Largest eigenspace dimension a k-d tree is built for.
pub(crate) const MAX_TREE_DIM: usize = crate::manifold::kdtree::MAX_DIM;

/// How the nearest manifold point is found.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum SearchKind {
    /// The faster of the two for the manifold's size and dimension (measured by the `eigen_search` example).
    #[default]
    Auto,
    /// A k-d tree (at most 32 dimensions).
    KdTree,
    /// Every point, every query.
    Brute,
}

impl std::fmt::Display for SearchKind {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(match self {
            SearchKind::Auto => "auto",
            SearchKind::KdTree => "kdtree",
            SearchKind::Brute => "brute",
        })
    }
}

/// What [`SearchKind::Auto`] picks for `points` manifold points of `dim` coordinates: the k-d
/// tree from 64 points on, brute force below that and whenever L exceeds [`MAX_TREE_DIM`].
/// Measured with benches/eigen_search.rs (one thread, points on a smooth curve or sheet, queries
/// near it, as appearance manifolds and their queries are; 2026-11-22 on this tree): brute force
/// costs about 0.0095 us x points x L / 20 and wins at 32 points on the 8-D sheet only (0.09
/// against 0.13 us); from 64 points on the tree wins everywhere (0.12-0.18 against 0.18-0.99 us)
/// and stays within 0.1 to 1.2 us up to 65,536 points (1024 points on a curve at L = 20, about
/// COIL's 720: 0.20 against 9.3 us; the 65,536-point sheet at L = 20: 1.05 against 621 us).
pub(crate) fn auto_kind(points: usize, dim: usize) -> SearchKind {
    if dim <= MAX_TREE_DIM && points >= AUTO_TREE_FROM {
        SearchKind::KdTree
    } else {
        SearchKind::Brute
    }
}

/// Points padded to K coordinates, for brute force.
#[derive(Debug, Clone)]
struct Fixed<const K: usize> {
    points: Vec<[f32; K]>,
}

impl<const K: usize> Fixed<K> {
    fn new(points: &[f32], dim: usize) -> Self {
        let points: Vec<[f32; K]> = points
            .chunks_exact(dim)
            .map(|p| {
                let mut a = [0f32; K];
                a[..dim].copy_from_slice(p);
                a
            })
            .collect();
        Fixed { points }
    }

    #[inline]
    fn nearest(&self, q: &[f32]) -> usize {
        let mut a = [0f32; K];
        a[..q.len()].copy_from_slice(q);
        let mut best = (f32::INFINITY, 0);
        for (k, p) in self.points.iter().enumerate() {
            let mut acc = [0f32; K];
            for l in 0..K {
                let d = p[l] - a[l];
                acc[l] = d * d;
            }
            let s: f32 = acc.iter().sum();
            if s < best.0 {
                best = (s, k);
            }
        }
        best.1
    }
}

#[derive(Debug, Clone)]
enum Store {
    K4(Fixed<4>),
    K8(Fixed<8>),
    K12(Fixed<12>),
    K16(Fixed<16>),
    K20(Fixed<20>),
    K24(Fixed<24>),
    K32(Fixed<32>),
    Dyn(Vec<f32>),
    Tree(KdTree),
}

/// A nearest-neighbour index over the manifold's points.
#[derive(Debug, Clone)]
#[cfg_attr(not(feature = "bench"), allow(unreachable_pub))] // public through crate::bench
pub struct NearestIndex {
    dim: usize,
    kind: SearchKind,
    store: Store,
}

#[cfg_attr(not(feature = "bench"), allow(unreachable_pub))] // public through crate::bench
impl NearestIndex {
    /// Indexes `points` (rows of `dim` coordinates) for `kind` of search; `Auto` is resolved by
    /// [`auto_kind`].
    pub fn new(points: &[f32], dim: usize, kind: SearchKind) -> Result<Self> {
        if dim == 0 || points.is_empty() || !points.len().is_multiple_of(dim) {
            return Err(Error::invalid("manifold points", points.len(), format!("need whole rows of {dim} > 0 coordinates")));
        }
        let n = points.len() / dim;
        if n > u32::MAX as usize {
            return Err(Error::invalid("manifold points", n, "more than 2^32 points"));
        }
        let kind = match kind {
            SearchKind::Auto => auto_kind(n, dim),
            SearchKind::KdTree if dim > MAX_TREE_DIM => {
                return Err(Error::invalid(
                    "search",
                    "kdtree",
                    format!("the k-d tree supports at most {MAX_TREE_DIM} eigenspace dimensions, the model has {dim}; use brute force or auto"),
                ))
            }
            k => k,
        };
        let store = match dim {
            _ if kind == SearchKind::KdTree => Store::Tree(KdTree::new(points, dim)),
            0..=4 => Store::K4(Fixed::new(points, dim)),
            5..=8 => Store::K8(Fixed::new(points, dim)),
            9..=12 => Store::K12(Fixed::new(points, dim)),
            13..=16 => Store::K16(Fixed::new(points, dim)),
            17..=20 => Store::K20(Fixed::new(points, dim)),
            21..=24 => Store::K24(Fixed::new(points, dim)),
            25..=32 => Store::K32(Fixed::new(points, dim)),
            _ => Store::Dyn(points.to_vec()),
        };
        Ok(NearestIndex { dim, kind, store })
    }

    /// The search in use (never `Auto`).
    pub fn kind(&self) -> SearchKind {
        self.kind
    }

    /// The index of the point nearest to `q` (`dim` coordinates); ties go to the lower index
    /// (the tree gives brute force's answer).
    #[inline]
    pub fn nearest(&self, q: &[f32]) -> usize {
        debug_assert_eq!(q.len(), self.dim);
        match &self.store {
            Store::K4(f) => f.nearest(q),
            Store::K8(f) => f.nearest(q),
            Store::K12(f) => f.nearest(q),
            Store::K16(f) => f.nearest(q),
            Store::K20(f) => f.nearest(q),
            Store::K24(f) => f.nearest(q),
            Store::K32(f) => f.nearest(q),
            Store::Tree(t) => t.nearest(q),
            Store::Dyn(points) => {
                let mut best = (f32::INFINITY, 0);
                for (k, p) in points.chunks_exact(self.dim).enumerate() {
                    let s: f32 = p.iter().zip(q).map(|(a, b)| (a - b) * (a - b)).sum();
                    if s < best.0 {
                        best = (s, k);
                    }
                }
                best.1
            }
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use rand::{Rng, SeedableRng};
    use rand_chacha::ChaCha8Rng;

    fn dist(p: &[f32], q: &[f32]) -> f32 {
        p.iter().zip(q).map(|(a, b)| (a - b) * (a - b)).sum()
    }

    /// `n` points of `dim` coordinates on a curve (like a manifold) plus noise.
    fn curve_points(rng: &mut ChaCha8Rng, dim: usize, n: usize) -> Vec<f32> {
        (0..n)
            .flat_map(|k| {
                let t = k as f32 * 0.01;
                (0..dim).map(move |l| (t * (l as f32 + 1.0)).sin()).collect::<Vec<_>>()
            })
            .map(|v| v + rng.random_range(-1e-3..1e-3))
            .collect()
    }

    /// The tree finds brute force's point, for every padding class of brute force and beyond the
    /// tree's dimensions (where Auto takes brute force).
    #[test]
    fn tree_and_brute_agree() {
        let mut rng = ChaCha8Rng::seed_from_u64(7);
        for (dim, n) in [(1, 300), (3, 20_000), (5, 2000), (12, 3000), (20, 5000), (27, 1500), (40, 500)] {
            let points = curve_points(&mut rng, dim, n);
            let brute = NearestIndex::new(&points, dim, SearchKind::Brute).unwrap();
            let tree = NearestIndex::new(&points, dim, if dim <= MAX_TREE_DIM { SearchKind::KdTree } else { SearchKind::Auto }).unwrap();
            for _ in 0..200 {
                let q: Vec<f32> = (0..dim).map(|_| rng.random_range(-1.2..1.2)).collect();
                let (a, b) = (brute.nearest(&q), tree.nearest(&q));
                let (da, db) = (dist(&points[a * dim..(a + 1) * dim], &q), dist(&points[b * dim..(b + 1) * dim], &q));
                assert_eq!(a, b, "dim {dim}: brute {a} ({da}) vs tree {b} ({db})");
            }
            // Queries near the points, as eigenspace queries are near their manifold.
            for k in (0..n).step_by(53) {
                let q: Vec<f32> = points[k * dim..(k + 1) * dim].iter().map(|v| v + rng.random_range(-2e-3..2e-3)).collect();
                assert_eq!(brute.nearest(&q), tree.nearest(&q), "dim {dim}, near point {k}");
            }
            // Every point finds itself.
            for k in (0..n).step_by(97) {
                assert_eq!(tree.nearest(&points[k * dim..(k + 1) * dim]), k);
            }
        }
    }

    /// The search with its near points is brute force under its own distance
    /// ([`crate::manifold::kdtree::near_distance`]): the nearest point (ties to the lower
    /// index) with its distance, which is the plain search's within f32 rounding, and exactly the
    /// points within the reach times that distance (each once, with its distance); the nearest
    /// of those outside a window of indices around the first (as the refined search picks a
    /// second basin) is brute force's over the points outside it within the reach.
    #[test]
    fn the_tree_s_near_points_are_brute_force_s() {
        use crate::kernels::kdtree::near_distance;
        let mut rng = ChaCha8Rng::seed_from_u64(13);
        let mut near = Vec::new();
        for (dim, n) in [(2, 3000), (12, 4000), (20, 2000)] {
            let points = curve_points(&mut rng, dim, n);
            let tree = KdTree::new(&points, dim);
            let at = |i: usize| &points[i * dim..(i + 1) * dim];
            for k in 0..100 {
                let q: Vec<f32> = if k % 2 == 0 {
                    (0..dim).map(|_| rng.random_range(-1.2..1.2)).collect()
                } else {
                    let i = rng.random_range(0..n);
                    at(i).iter().map(|v| v + rng.random_range(-0.05..0.05)).collect()
                };
                let nd: Vec<f32> = (0..n).map(|i| near_distance(at(i), &q)).collect();
                let first = (0..n).fold(0, |b, i| if nd[i] < nd[b] { i } else { b });
                let d1 = nd[first];
                let plain = dist(at(tree.nearest(&q)), &q);
                assert!((d1 - plain).abs() <= 1e-5 * plain.max(1e-30), "dim {dim}, query {k}: {d1} against {plain}");
                for reach in [1.0, 2.0, 4.0] {
                    assert_eq!(tree.nearest_and_near(&q, reach, &mut near), (first, d1), "dim {dim}, query {k}");
                    let mut got = near.clone();
                    got.sort_by_key(|p| p.1);
                    let want: Vec<(f32, u32)> = (0..n).filter(|&i| nd[i] <= reach * d1).map(|i| (nd[i], i as u32)).collect();
                    assert_eq!(got, want, "dim {dim}, query {k}, reach {reach}");
                    let keep = |i: usize| i.abs_diff(first) > 40;
                    let second = near.iter().filter(|p| keep(p.1 as usize)).min_by(|x, y| x.0.total_cmp(&y.0).then(x.1.cmp(&y.1))).map(|p| p.1 as usize);
                    let brute = (0..n).filter(|&i| keep(i) && nd[i] <= reach * d1).min_by(|&x, &y| nd[x].total_cmp(&nd[y]).then(x.cmp(&y)));
                    assert_eq!(second, brute, "dim {dim}, query {k}, reach {reach}");
                }
            }
        }
    }

    /// Exact ties go to the lower index, as under brute force: repeated points, a grid of
    /// points with queries on the cell centres (equidistant from several points), a query with
    /// a NaN (no distance compares: point 0) and one so far away that every distance is
    /// infinite (point 0).
    #[test]
    fn tree_breaks_ties_as_brute_force_does() {
        let mut rng = ChaCha8Rng::seed_from_u64(11);
        let dim = 3;
        let mut points: Vec<f32> = (0..400).flat_map(|k| [(k % 20) as f32, (k / 20) as f32, 0.0]).collect();
        // Every point again, shuffled in after the originals, and some three times.
        let again: Vec<f32> = (0..600).flat_map(|k| [((k * 7) % 20) as f32, ((k * 13) % 20) as f32, 0.0]).collect();
        points.extend(again);
        let brute = NearestIndex::new(&points, dim, SearchKind::Brute).unwrap();
        let tree = NearestIndex::new(&points, dim, SearchKind::KdTree).unwrap();
        for _ in 0..500 {
            let q = [rng.random_range(0..20) as f32 + 0.5, rng.random_range(0..20) as f32 + 0.5 * rng.random_range(0..2) as f32, 0.0];
            assert_eq!(brute.nearest(&q), tree.nearest(&q), "{q:?}");
        }
        for q in [[f32::NAN, 1.0, 0.0], [3e38, -3e38, 3e38]] {
            assert_eq!((brute.nearest(&q), tree.nearest(&q)), (0, 0), "{q:?}");
        }
    }

    #[test]
    fn tree_beyond_its_dimension_is_refused() {
        let e = NearestIndex::new(&[0.0; 33], 33, SearchKind::KdTree).unwrap_err();
        assert!(e.to_string().contains("at most 32"), "{e}");
        assert_eq!(NearestIndex::new(&[0.0; 33], 33, SearchKind::Auto).unwrap().kind(), SearchKind::Brute);
    }
}
