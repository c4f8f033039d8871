//! An exact k-d tree for the nearest manifold point.
//!
//! Each node splits its points at the median of its widest coordinate (the spread taken over
//! the node's own points), so on an eigenspace manifold the splits fall on the leading
//! components, where the points spread, again and again. (A tree that cycles through the
//! coordinates would split each of the first components once and the leading ones no more
//! often than the rest, though a manifold's points vary most along them.)
//!
//! The search is the classic branch and bound with the incremental cell distance (Arya & Mount):
//! the nearer child first, the farther one only when the squared distance from the query to its
//! cell can beat the best point so far. Leaves hold [`LEAF`] points stored coordinate by
//! coordinate, so one leaf's distances are [`LEAF`]-lane vector operations; each distance sums
//! the squared differences coordinate by coordinate in order, the sum brute force computes, so
//! the tree returns brute force's point: the least distance, ties to the lower index (the
//! pruning keeps cells whose bound equals the best distance).

use crate::kernels::{kdtree, Level};

/// Points per leaf (one AVX-512 vector of f32).
pub(crate) const LEAF: usize = kdtree::LEAF;

/// Largest dimension the tree is built for (the incremental distance keeps one offset per
/// coordinate on the stack).
pub(crate) const MAX_DIM: usize = kdtree::MAX_DIM;

/// A node: `dim < u32::MAX` splits coordinate `dim` at `split`, child `a` holding the points
/// with that coordinate <= `split` and `b` those >= `split`; `dim == u32::MAX` is leaf `a`.
#[derive(Debug, Clone, Copy)]
struct Node {
    dim: u32,
    split: f32,
    a: u32,
    b: u32,
}

const IS_LEAF: u32 = u32::MAX;

/// A node of the search with a lower bound of its cell's squared distance from the query.
#[derive(Debug, Clone, Copy)]
struct Cell {
    node: u32,
    bound: f32,
}

/// The tree over `n` points of `dim` coordinates.
#[derive(Debug, Clone)]
pub(crate) struct KdTree {
    dim: usize,
    nodes: Vec<Node>,
    /// Per leaf, `dim` rows of [`LEAF`] coordinates; unused lanes hold +infinity (never nearest).
    leaves: Vec<f32>,
    /// Per leaf, the [`LEAF`] points' indices (`u32::MAX` in unused lanes).
    items: Vec<u32>,
}

impl KdTree {
    /// Builds the tree over `points` (rows of `dim` finite coordinates, fewer than 2^32 rows,
    /// `1 <= dim <= MAX_DIM`).
    pub(crate) fn new(points: &[f32], dim: usize) -> KdTree {
        assert!((1..=MAX_DIM).contains(&dim) && points.len().is_multiple_of(dim), "rows of 1 to {MAX_DIM} coordinates");
        let n = points.len() / dim;
        assert!(n < u32::MAX as usize, "fewer than 2^32 points");
        let mut ids: Vec<u32> = (0..n as u32).collect();
        let mut t = KdTree { dim, nodes: Vec::with_capacity(2 * n / LEAF + 1), leaves: Vec::new(), items: Vec::new() };
        t.build(points, &mut ids);
        t
    }

    fn build(&mut self, points: &[f32], ids: &mut [u32]) -> u32 {
        let dim = self.dim;
        let at = self.nodes.len() as u32;
        if ids.len() <= LEAF {
            let (leaf, base) = (self.items.len() / LEAF, self.leaves.len());
            self.leaves.resize(base + dim * LEAF, f32::INFINITY);
            for (j, &i) in ids.iter().enumerate() {
                for (l, &v) in points[i as usize * dim..][..dim].iter().enumerate() {
                    self.leaves[base + l * LEAF + j] = v;
                }
            }
            self.items.extend(ids.iter().copied().chain(std::iter::repeat(u32::MAX)).take(LEAF));
            self.nodes.push(Node { dim: IS_LEAF, split: 0.0, a: leaf as u32, b: 0 });
            return at;
        }
        let coord = |i: u32, l: usize| points[i as usize * dim + l];
        // Every coordinate's range in one pass over the node's points (row by row).
        let (mut lo, mut hi) = ([f32::INFINITY; MAX_DIM], [f32::NEG_INFINITY; MAX_DIM]);
        for &i in ids.iter() {
            let p = &points[i as usize * dim..][..dim];
            for l in 0..dim {
                (lo[l], hi[l]) = (lo[l].min(p[l]), hi[l].max(p[l]));
            }
        }
        let mut widest = (f32::NEG_INFINITY, 0);
        for l in 0..dim {
            if hi[l] - lo[l] > widest.0 {
                widest = (hi[l] - lo[l], l);
            }
        }
        let l = widest.1;
        // Split by count, so the depth is log2(n / LEAF) whatever the values (equal points too).
        let mid = ids.len() / 2;
        ids.select_nth_unstable_by(mid, |&x, &y| coord(x, l).total_cmp(&coord(y, l)));
        let split = coord(ids[mid], l);
        self.nodes.push(Node { dim: l as u32, split, a: 0, b: 0 });
        let (left, right) = ids.split_at_mut(mid);
        let a = self.build(points, left);
        let b = self.build(points, right);
        let node = &mut self.nodes[at as usize];
        (node.a, node.b) = (a, b);
        at
    }

    /// Bytes held: nodes, leaves and indices.
    pub(crate) fn bytes(&self) -> usize {
        self.nodes.len() * std::mem::size_of::<Node>() + self.leaves.len() * 4 + self.items.len() * 4
    }

    /// The index of the point nearest to `q` (`dim` coordinates): brute force's answer, the
    /// least squared distance summed coordinate by coordinate, ties to the lower index; 0 when
    /// no distance compares (a query with a NaN), as brute force gives.
    pub(crate) fn nearest(&self, q: &[f32]) -> usize {
        self.nearest_with_distance(q).0
    }

    /// [`KdTree::nearest`] with its squared distance (infinite when no distance compares).
    pub(crate) fn nearest_with_distance(&self, q: &[f32]) -> (usize, f32) {
        assert_eq!(q.len(), self.dim, "a query of the tree's dimension");
        let mut best = (f32::INFINITY, u32::MAX);
        let mut off = [0f32; MAX_DIM];
        let level = Level::detect();
        self.visit(Cell { node: 0, bound: 0.0 }, 1.0, &mut off, q, &mut best, &mut |rows, items, best| kdtree::scan(level, rows, items, q, best));
        if best.1 == u32::MAX {
            (0, f32::INFINITY)
        } else {
            (best.1 as usize, best.0)
        }
    }

    /// The point nearest to `q` with its squared distance, and, into `near`, every point within
    /// `reach` (at least 1) times that squared distance, with its squared distance, in no
    /// particular order: one branch and bound whose cells are kept while they can hold a point
    /// within `reach` times the best distance so far. As that best only falls, no cell that
    /// could hold a point within `reach` times the final one is ever dropped; the points
    /// collected beyond it on the way are removed at the end. (A second search for the nearest
    /// point of some kind within that reach, started after the first, scans again the cells
    /// around the first point.)
    ///
    /// The distances are [`kdtree::near_distance`]'s (four chains of fused multiply-adds, a quarter of
    /// the dependent adds of [`KdTree::nearest`]'s sums), so the point is brute force's under
    /// them, ties to the lower index, and may differ from [`KdTree::nearest`]'s where two
    /// points' distances agree to the last bits.
    pub(crate) fn nearest_and_near(&self, q: &[f32], reach: f32, near: &mut Vec<(f32, u32)>) -> (usize, f32) {
        assert_eq!(q.len(), self.dim, "a query of the tree's dimension");
        assert!(reach >= 1.0, "a reach of at least 1");
        near.clear();
        let mut best = (f32::INFINITY, u32::MAX);
        let mut off = [0f32; MAX_DIM];
        let level = Level::detect();
        self.visit(Cell { node: 0, bound: 0.0 }, reach, &mut off, q, &mut best, &mut |rows, items, best| {
            kdtree::scan_near(level, rows, items, q, best, reach, near)
        });
        let bound = reach * best.0;
        near.retain(|&(a, _)| a <= bound);
        if best.1 == u32::MAX {
            (0, f32::INFINITY)
        } else {
            (best.1 as usize, best.0)
        }
    }

    /// The branch and bound from `cell`: `leaf` scores a leaf's rows and items into `best`; a
    /// cell is visited while its squared distance from `q` is at most `reach` times the best.
    fn visit(
        &self,
        cell: Cell,
        reach: f32,
        off: &mut [f32; MAX_DIM],
        q: &[f32],
        best: &mut (f32, u32),
        leaf: &mut impl FnMut(&[f32], &[u32], &mut (f32, u32)),
    ) {
        let Cell { node, bound } = cell;
        let nd = self.nodes[node as usize];
        if nd.dim == IS_LEAF {
            let at = nd.a as usize;
            return leaf(&self.leaves[at * self.dim * LEAF..][..self.dim * LEAF], &self.items[at * LEAF..][..LEAF], best);
        }
        let l = nd.dim as usize;
        let d = q[l] - nd.split;
        let (near, far) = if d <= 0.0 { (nd.a, nd.b) } else { (nd.b, nd.a) };
        self.visit(Cell { node: near, bound }, reach, off, q, best, leaf);
        // The far cell lies beyond the split in coordinate l: its squared distance from q is at
        // least the bound with that coordinate's offset replaced by d.
        let old = off[l];
        let far_bound = bound - old * old + d * d;
        if far_bound <= reach * best.0 {
            off[l] = d;
            self.visit(Cell { node: far, bound: far_bound }, reach, off, q, best, leaf);
            off[l] = old;
        }
    }
}
