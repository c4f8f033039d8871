//! The eigenspace's manifold kept as its knots, for more pose parameters than a dense lattice
//! serves ([`crate::manifold::dense_lattice`]): the training views' coordinates (N x L) and the
//! tensor-product spline through them (the surface the dense lattice would have resampled,
//! [`Surface`]), searched continuously. A query's starts are the points of the surface at
//! [`KNOT_START_PER_CELL`] points per knot interval (the training views among them) nearest to
//! it in the eigenspace ([`KnotStarts`]: the nearest, and those within [`KNOT_START_RATIO`] of
//! its squared distance and not next to a nearer one on their grid, at most [`KNOT_STARTS`]);
//! from each, Levenberg-Marquardt on the distance to the surface
//! ([`Surface::refine`]); the least end, snapped to the lattice of `manifold_step` degrees
//! anchored at each parameter's first training value ([`Surface::snap`]), is the pose: the pose
//! the dense lattice would report where the search finds the right basin. Storage and time grow
//! with the training views: N L knots in the file, the surface's 2^D N L values and slopes and
//! the start points with their tree derived when loaded.

use crate::manifold::knots::{KnotStarts, StartScratch};
use crate::manifold::surface::{Interpolant, Surface};
use crate::manifold::tuning::{KNOT_STARTS, KNOT_START_PER_CELL, KNOT_START_RATIO};
use crate::pose::{wrap_positive, PoseSpace};
use crate::Result;
use std::cell::RefCell;

/// The continuous search of an eigenspace kept as its knots.
#[derive(Debug, Clone)]
pub(crate) struct KnotSearch {
    pub(super) surface: Surface,
    starts: KnotStarts,
    /// The reporting lattice (degrees).
    step: f64,
    /// Unit weights (L): the eigenspace's plain distance.
    ones: Vec<f64>,
}

/// A query's buffers.
#[derive(Debug, Default)]
struct Scratch {
    starts: StartScratch,
    list: Vec<usize>,
    buf: Vec<f64>,
}

thread_local! {
    static SCRATCH: RefCell<Scratch> = RefCell::new(Scratch::default());
}

impl KnotSearch {
    /// The search over `knots` (N x `l`, row-major over the grid `axes` of `space`), reporting on
    /// the lattice of `step` degrees; its starts found by a k-d tree where `tree` allows.
    pub(crate) fn new(space: &PoseSpace, axes: &[Vec<f64>], knots: &[f32], l: usize, step: f64, tree: bool) -> Result<KnotSearch> {
        let k64: Vec<f64> = knots.iter().map(|&v| v as f64).collect();
        let surface = Surface::new(space, axes, &k64, l, Interpolant::Spline)?;
        let starts = KnotStarts::new(&surface, l, KNOT_START_PER_CELL, tree);
        Ok(KnotSearch { surface, starts, step, ones: vec![1.0; l] })
    }

    /// Whether the starts are found by a k-d tree.
    pub(crate) fn has_tree(&self) -> bool {
        self.starts.has_tree()
    }

    /// Bytes held beside the knots: the surface's values and slopes, the start points.
    pub(crate) fn bytes(&self) -> usize {
        self.surface.len() * 4 + self.starts.bytes()
    }

    /// The pose of coordinates `y` (circular values in [0, period)) into `out`.
    pub(crate) fn pose_of(&self, space: &PoseSpace, y: &[f32], out: &mut [f64]) {
        let d = space.len();
        let mut t = [0f64; 8];
        SCRATCH.with_borrow_mut(|s| {
            let Scratch { starts, list, buf } = s;
            self.starts.starts(y, KNOT_START_RATIO, KNOT_STARTS, starts, list);
            buf.resize((d + 2) * self.ones.len(), 0.0);
            let mut best = f64::INFINITY;
            for &k in list.iter() {
                let mut p = [0f64; 8];
                p[..d].copy_from_slice(self.starts.pose(k));
                let c = self.surface.refine(y, &self.ones, &mut p[..d], buf);
                if c < best || best.is_nan() {
                    (best, t) = (c, p);
                }
            }
            self.surface.snap(y, &self.ones, &mut t[..d], self.step, &mut buf[..self.ones.len()]);
        });
        write_pose(space, &t[..d], out);
    }

    /// The pose of coordinates `y` in the basin of `start` (a pose): Levenberg-Marquardt from
    /// it, snapped to the lattice, into `out`.
    pub(crate) fn pose_from(&self, space: &PoseSpace, y: &[f32], start: &[f64], out: &mut [f64]) {
        let d = space.len();
        let mut t = start.to_vec();
        self.surface.clamp(&mut t);
        SCRATCH.with_borrow_mut(|s| {
            let buf = &mut s.buf;
            buf.resize((d + 2) * self.ones.len(), 0.0);
            self.surface.refine(y, &self.ones, &mut t, buf);
            self.surface.snap(y, &self.ones, &mut t, self.step, &mut buf[..self.ones.len()]);
        });
        write_pose(space, &t, out);
    }
}

/// `t` into `out`, circular values wrapped into [0, period).
fn write_pose(space: &PoseSpace, t: &[f64], out: &mut [f64]) {
    for ((o, &v), p) in out.iter_mut().zip(t).zip(space.params()) {
        *o = p.period.map_or(v, |per| wrap_positive(v, per));
    }
}
