//! Murase & Nayar's universal eigenspace: every object's training images, scaled to unit energy,
//! share one eigenspace (the crate's Gram-matrix PCA, `methods::eigenspace::pca`); each object's
//! training coordinates are joined by the same splines as the parametric eigenspace's manifold and
//! resampled densely; a query's distance to an object is its distance to the nearest point of
//! that object's manifold, in the eigenspace (its residual off the eigenspace is the same for
//! every object, so it would not change which object is nearest).
//! With more than two pose parameters the manifolds are resampled at a few points per knot
//! interval instead of every `manifold_step` degrees (`Manifold::build_for`): points that grow
//! with the training views, not with the pose ranges.
//!
//! The held-out distance of a training view is its distance to its object's manifold interpolated
//! from the object's other knots, at its own pose (every other knot held out along each axis,
//! then the others: `manifold::folds::both_folds`), what calibrates the unknown-object threshold.

use super::tuning::{GROUP, NEIGHBOUR, PREFIX, SEGMENT};
use super::{Fitted, Recognition, Recognize, Recognizer, RecognizerParams};
use crate::catalog::ObjectSet;
use crate::dataset::Dataset;
use crate::kernels::{dispatch, Level};
use crate::linalg::squared_distance;
use crate::manifold::chunk_rows;
use crate::manifold::grid::{Grid, Manifold};
use crate::manifold::pca::{self, Dimension};
use crate::manifold::projector::{unit_coords, Projector};
use crate::manifold::surface::Surface;
use crate::manifold::tuning::{EVD_SYSTEM_BYTES, MANIFOLD_VALUE_BYTES};
use crate::manifold::Interpolant;
use crate::model::footprint::{system, Parts, Sizes};
use crate::model::{Tensor, TensorSet};
use crate::{Error, Result};
use rayon::prelude::*;
use std::sync::Arc;

/// The universal eigenspace in the recogniser registry.
pub(crate) static RECOGNIZER: Recognizer = Recognizer {
    name: "universal",
    summary: "Murase & Nayar's universal eigenspace of every object's training views, the nearest object manifold",
    storage: "N_dense L + M L + M + K (M L_k + M) + N_own L_k",
    fit: |objects, all, params, views_only| {
        let fit = Universal::fit(objects, all, params, views_only)?;
        let components = fit.model.components();
        Ok(Fitted { model: Arc::new(fit.model), components, energy_kept: fit.energy_kept, held_out: fit.held_out })
    },
    load: |t, objects, m, components| {
        if components == 0 {
            return Err(t.error("damaged object model: a universal eigenspace of 0 dimensions"));
        }
        Ok(Arc::new(Universal::from_parts(t, "recognizer.", objects, m, components)?))
    },
    footprint,
};

/// What fitting allocates, for the memory plan; bytes, with N images of all objects, M features,
/// L dimensions and P points of each object's manifold: a concatenated f64 transposed copy of
/// the images (8 N M), the PCA's Gram matrix and eigendecomposition (36 N^2) and the eigenspace
/// with every object's manifold (16 M L + 24 P L per object).
fn footprint(s: &Sizes, objects: usize, params: &RecognizerParams) -> Parts {
    let (t, m) = (s.n as f64, s.m as f64);
    let l = params.components.min(s.n.saturating_sub(1)).min(s.m).max(1) as f64;
    Parts::default()
        .add(8.0 * t * m, "the images' f64 transposed copy")
        .add(system(t, EVD_SYSTEM_BYTES), format!("N x N Gram of all {} images and its eigendecomposition", s.n))
        .add(16.0 * m * l + MANIFOLD_VALUE_BYTES * (s.lattice * objects) as f64 * l, "the universal eigenspace")
}

/// A fitted universal eigenspace with every object's manifold in it.
#[derive(Debug, Clone)]
pub(crate) struct Universal {
    /// The eigenimages (L x M).
    proj: Projector,
    /// The mean unit-energy training image (M).
    mean: Vec<f32>,
    /// Each eigenimage's product with the mean.
    mean_proj: Vec<f32>,
    /// The squared norm of the mean.
    mean_sq: f64,
    /// Each object's manifold points (rows of L).
    points: Vec<Vec<f32>>,
    /// Each object's least and largest manifold point norm: a centred query c lies at least
    /// | ||c|| - ||p|| | from a point p, so at least this far outside the range from them all.
    norms: Vec<(f64, f64)>,
    /// Per segment, the least and largest norm of its points' coordinates past the first
    /// [`PREFIX`] ([`Universal::own_distances_under`]'s second bound).
    tails: Vec<(f64, f64)>,
    /// The manifolds cut into segments of [`SEGMENT`] consecutive points (neighbours along the
    /// last pose axis), each with a bounding sphere, and runs of [`GROUP`] segments of one object
    /// into groups with a sphere of their own: a query's distance to a segment's points is at
    /// least its distance to the centre less the radius, so most groups and segments are never
    /// searched ([`Universal::nearest_two`]). Per segment: its object and first point.
    segments: Vec<(u32, u32)>,
    centres: Vec<f32>,
    radii: Vec<f64>,
    /// Per group: its object, first segment and number of segments; centres; radii.
    groups: Vec<(u32, u32, u32)>,
    group_centres: Vec<f32>,
    group_radii: Vec<f64>,
}

/// A search's working space, reused from query to query.
#[derive(Default)]
struct Scratch {
    bounds: Vec<(f64, u32)>,
    group_lb: Vec<f64>,
    best: Vec<f64>,
    lowest: Vec<(f64, u32)>,
    /// One group's segments' squared distances from the query's centre.
    segment_sq: Vec<f64>,
}

/// What fitting measured: the eigenspace's dimension and energy, and each object's held-out
/// distances (empty for an object too sparse to hold knots out).
pub(crate) struct UniversalFit {
    pub model: Universal,
    pub energy_kept: f64,
    pub held_out: Vec<Vec<f64>>,
}

impl Universal {
    /// Fits on the training views of `objects`, whose images are also given row after row in
    /// `all` (object 0's first).
    ///
    /// With `views_only`, each object's manifold is its training views' points themselves and
    /// a view is held out together with its nearest other view: its held-out distance is its
    /// distance to the second nearest other view of its object ([`nearest_other`]); the poses
    /// are not read.
    pub(super) fn fit(objects: &ObjectSet, all: &Dataset, params: &RecognizerParams, views_only: bool) -> Result<UniversalFit> {
        if views_only {
            let pca = pca::fit(all, Dimension::Fixed(params.components))?;
            let l = pca.dim();
            let mut offset = 0;
            let (mut points, mut held_out) = (Vec::with_capacity(objects.len()), Vec::with_capacity(objects.len()));
            for d in objects.objects() {
                let coords = &pca.coords[offset * l..(offset + d.len()) * l];
                offset += d.len();
                points.push(to32(coords));
                held_out.push(nearest_other(coords, l, None));
            }
            let model = Universal::new(to32(&pca.basis), to32(&pca.mean), points)?;
            return Ok(UniversalFit { model, energy_kept: pca.energy_kept(), held_out });
        }
        let space = objects.space();
        let step = params.manifold_step;
        // The grids first: an object that cannot make a manifold fails before any arithmetic.
        let grids: Vec<Grid> = objects
            .objects()
            .iter()
            .zip(objects.names())
            .map(|(d, name)| {
                Grid::new(space, d.poses(), d.manifest().images(), d.manifest().root())
                    .map_err(|e| Error::Dataset { path: d.manifest().root().to_path_buf(), message: format!("object '{name}': {e}") })
            })
            .collect::<Result<_>>()?;
        let pca = pca::fit(all, Dimension::Fixed(params.components))?;
        let l = pca.dim();
        let mut offset = 0;
        let mut points = Vec::with_capacity(objects.len());
        let mut held_out = Vec::with_capacity(objects.len());
        for (d, grid) in objects.objects().iter().zip(&grids) {
            let coords = &pca.coords[offset * l..(offset + d.len()) * l];
            offset += d.len();
            let dense = Manifold::build_for(space, grid, coords, l, step)?;
            points.push(dense.points.iter().map(|&v| v as f32).collect::<Vec<f32>>());
            held_out.push(held_out_distances(d, grid, coords, l)?);
        }
        let model = Universal::new(to32(&pca.basis), to32(&pca.mean), points)?;
        Ok(UniversalFit { model, energy_kept: pca.energy_kept(), held_out })
    }

    /// The model of eigenimages `basis` (L x M), mean image `mean` and each object's manifold
    /// points `points` (rows of L).
    pub(super) fn new(basis: Vec<f32>, mean: Vec<f32>, points: Vec<Vec<f32>>) -> Result<Self> {
        let m = mean.len();
        let l = basis.len() / m;
        if let Some(k) = points.iter().position(|p| p.is_empty() || !p.len().is_multiple_of(l)) {
            return Err(Error::invalid("manifold points", points[k].len(), format!("object {k}: need whole rows of {l} coordinates")));
        }
        let rows = 0..l;
        let proj = Projector::new(&basis, m);
        let mean_proj = proj.dots_f64(&rows, &mean);
        let (mut segments, mut centres, mut radii) = (Vec::new(), Vec::new(), Vec::new());
        for (k, p) in points.iter().enumerate() {
            let n = p.len() / l;
            for start in (0..n).step_by(SEGMENT) {
                let (c, r) = sphere(&p[start * l..(start + SEGMENT).min(n) * l], l);
                segments.push((k as u32, start as u32));
                centres.extend(c);
                radii.push(r);
            }
        }
        let (mut groups, mut group_centres, mut group_radii) = (Vec::new(), Vec::new(), Vec::new());
        let mut s0 = 0;
        while s0 < segments.len() {
            let k = segments[s0].0;
            let mut s1 = s0;
            while s1 < segments.len() && s1 - s0 < GROUP && segments[s1].0 == k {
                s1 += 1;
            }
            let p = &points[k as usize];
            let (a, b) = (segments[s0].1 as usize, (segments[s1 - 1].1 as usize + SEGMENT).min(p.len() / l));
            let (c, r) = sphere(&p[a * l..b * l], l);
            groups.push((k, s0 as u32, (s1 - s0) as u32));
            group_centres.extend(c);
            group_radii.push(r);
            s0 = s1;
        }
        let norms = points.iter().map(|p| norm_range(p, l, 0)).collect();
        let q = PREFIX.min(l);
        let tails = segments
            .iter()
            .map(|&(k, start)| {
                let p = &points[k as usize];
                let (a, b) = (start as usize, (start as usize + SEGMENT).min(p.len() / l));
                norm_range(&p[a * l..b * l], l, q)
            })
            .collect();
        let mean_sq = mean.iter().map(|&v| v as f64 * v as f64).sum();
        Ok(Universal { proj, mean, mean_proj, mean_sq, points, norms, tails, segments, centres, radii, groups, group_centres, group_radii })
    }

    /// Dimensions L.
    pub(super) fn components(&self) -> usize {
        self.mean_proj.len()
    }

    /// Each query's distance to each object's manifold into `out` (rows of K); a query that
    /// cannot be scaled to unit energy gets NaN.
    pub(super) fn distances(&self, queries: &[f32], out: &mut [f64]) {
        let (l, m, k) = (self.components(), self.mean.len(), self.points.len());
        let n = queries.len() / m;
        let rows = chunk_rows(n);
        queries.par_chunks(rows * m).zip(out.par_chunks_mut(rows * k)).for_each(|(q, o)| {
            let mut y = vec![0f32; q.len() / m * l];
            self.proj.f32_products(&(0..l), q, &mut y);
            for ((x, y), o) in q.chunks_exact(m).zip(y.chunks_exact_mut(l)).zip(o.chunks_exact_mut(k)) {
                if unit_coords(crate::linalg::energy(x), &self.mean_proj, y).is_none() {
                    o.fill(f64::NAN);
                    continue;
                }
                for (k, o) in o.iter_mut().enumerate() {
                    *o = self.distance_to(k, y);
                }
            }
        });
    }

    /// Each query's nearest object, its distance and the second nearest object's distance (infinite
    /// with one object), into `out`; a query that cannot be scaled to unit energy gets NaN
    /// distances. Manifold segments are searched in the order of their bounding spheres' lower
    /// bounds and the search stops at the first bound beyond the second nearest object's distance
    /// found: the same answer as searching every point ([`Universal::distances`]; ties to the
    /// lower object index).
    pub(super) fn nearest_two(&self, queries: &[f32], out: &mut [(usize, f64, f64)]) {
        let (l, m) = (self.components(), self.mean.len());
        let n = queries.len() / m;
        let rows = chunk_rows(n);
        queries.par_chunks(rows * m).zip(out.par_chunks_mut(rows)).for_each(|(q, o)| {
            let mut y = vec![0f32; q.len() / m * l];
            self.proj.f32_products(&(0..l), q, &mut y);
            let mut scratch = Scratch::default();
            for ((x, y), o) in q.chunks_exact(m).zip(y.chunks_exact_mut(l)).zip(o.iter_mut()) {
                *o = match unit_coords(crate::linalg::energy(x), &self.mean_proj, y) {
                    Some(_) => self.search(y, &mut scratch),
                    None => (0, f64::NAN, f64::NAN),
                };
            }
        });
    }

    /// For a model of one object (its own eigenspace, [`super::own`]): each query's distance, in
    /// image space, from its unit-energy image to the object's manifold, sqrt(r^2 + d^2) with r
    /// the residual off the eigenspace (||x - mu||^2 less the squared coordinates, x the
    /// unit-energy query, the eigenimages orthonormal) and d the distance within it to the
    /// nearest manifold point ([`Universal::nearest_two`]'s search); NaN for a query that cannot
    /// be scaled to unit energy.
    pub(super) fn own_distances(&self, queries: &[f32], out: &mut [f64]) {
        let (l, m) = (self.components(), self.mean.len());
        let rows = chunk_rows(queries.len() / m);
        queries.par_chunks(rows * m).zip(out.par_chunks_mut(rows)).for_each(|(q, o)| {
            let mut y = vec![0f32; q.len() / m * l];
            self.proj.f32_products(&(0..l), q, &mut y);
            let mut scratch = Scratch::default();
            for ((x, y), o) in q.chunks_exact(m).zip(y.chunks_exact_mut(l)).zip(o.iter_mut()) {
                let (energy, dot) = crate::linalg::energy_and_dot(x, &self.mean);
                *o = self.own_distance(energy, dot, y, f64::INFINITY, &mut scratch);
            }
        });
    }

    /// [`Universal::own_distances`] (a model of one object) where only a distance under each
    /// query's `bound` matters, on the calling thread. A query gets, instead of its distance, a
    /// lower bound of it that reaches its bound, when one does: first how far its centred image
    /// lies outside the range of the manifold points' norms (one product with the mean), then the
    /// bound from its first [`PREFIX`] coordinates and each segment's sphere and tail norms, then
    /// its residual off the eigenspace (the whole projection, no search of the manifold).
    pub(super) fn own_distances_under(&self, queries: &[f32], bounds: &[f64], out: &mut [f64]) {
        let (l, m) = (self.components(), self.mean.len());
        let q = PREFIX.min(l);
        let (lo, hi) = self.norms[0];
        // A bound is lowered by 1e-6 in the squared distance: a distance computed in full carries
        // the rounding of the f32 projection (about 1e-7 of the unit energy in its square), and
        // a bound must not pass it.
        let shy = |v: f64| (v * v - 1e-6).max(0.0).sqrt();
        let (mut head, mut y, mut scratch) = (vec![0f32; q], vec![0f32; l], Scratch::default());
        for ((x, &b), o) in queries.chunks_exact(m).zip(bounds).zip(out.iter_mut()) {
            let (energy, dot) = crate::linalg::energy_and_dot(x, &self.mean);
            if !(energy > 0.0 && energy.is_finite()) {
                *o = f64::NAN;
                continue;
            }
            let c2 = self.centred_sq(energy, dot).max(0.0);
            let c = c2.sqrt();
            let outside = shy((c - hi).max(lo - c).max(0.0));
            if outside >= b {
                *o = outside;
                continue;
            }
            // Product by product: a matrix product's set-up costs more than these q dots.
            for (h, r) in head.iter_mut().zip(self.proj.range(&(0..q)).chunks_exact(m)) {
                *h = crate::linalg::dot_f32(x, r);
            }
            unit_coords(energy, &self.mean_proj[..q], &mut head);
            let rest = (c2 - head.iter().map(|&v| v as f64 * v as f64).sum::<f64>()).max(0.0).sqrt();
            let mut least = f64::INFINITY;
            for ((&r, &(tlo, thi)), c) in self.radii.iter().zip(&self.tails).zip(self.centres.chunks_exact(l)) {
                // The tail's term first: it alone may already pass the least found.
                let t = (rest - thi).max(tlo - rest).max(0.0);
                if t * t >= least {
                    continue;
                }
                let a = (distance(&head, &c[..q]) - r).max(0.0);
                least = least.min(a * a + t * t);
            }
            let near = shy(least.sqrt());
            if near >= b {
                *o = near;
                continue;
            }
            self.proj.f32_products(&(0..l), x, &mut y);
            *o = self.own_distance(energy, dot, &mut y, b, &mut scratch);
        }
    }

    /// The squared norm of a query's unit-energy image less the mean, from the image's energy
    /// and its product with the mean.
    fn centred_sq(&self, energy: f64, dot: f64) -> f64 {
        1.0 - 2.0 * dot / energy.sqrt() + self.mean_sq
    }

    /// One query's distance to the object's manifold ([`Universal::own_distances`]), from its
    /// image's energy and product with the mean and its raw coordinates `y` (made unit-energy
    /// coordinates here); its residual alone when that reaches `bound`.
    fn own_distance(&self, energy: f64, dot: f64, y: &mut [f32], bound: f64, scratch: &mut Scratch) -> f64 {
        if unit_coords(energy, &self.mean_proj, y).is_none() {
            return f64::NAN;
        }
        let centred = self.centred_sq(energy, dot);
        let inside: f64 = y.iter().map(|&v| v as f64 * v as f64).sum();
        let residual = (centred - inside).max(0.0);
        if residual >= bound * bound {
            return residual.sqrt();
        }
        let d = self.search(y, scratch).1;
        (residual + d * d).sqrt()
    }

    /// The nearest object to unit-energy coordinates `y`, its distance and the second nearest
    /// object's distance: the pruned search of [`Universal::nearest_two`].
    fn search(&self, y: &[f32], scratch: &mut Scratch) -> (usize, f64, f64) {
        let l = self.components();
        let k_objects = self.points.len();
        let Scratch { bounds, group_lb, best, lowest, segment_sq } = scratch;
        let level = Level::detect();
        best.resize(k_objects, f64::INFINITY);
        lowest.resize(k_objects, (f64::INFINITY, 0));
        // Every group's bound, and each object's group of least bound.
        lowest.fill((f64::INFINITY, 0));
        group_lb.resize(self.group_radii.len(), 0.0);
        sq_distances(level, y, &self.group_centres, l, group_lb);
        for (g, (lb, r)) in group_lb.iter_mut().zip(&self.group_radii).enumerate() {
            *lb = (lb.sqrt() - r).max(0.0);
            let k = self.groups[g].0 as usize;
            if *lb < lowest[k].0 {
                lowest[k] = (*lb, g as u32);
            }
        }
        // An upper bound on the second nearest object's distance: the exact distances to the
        // groups of least bound of the two objects with the least bounds. Only the segments of
        // groups within it, and themselves within it, can matter.
        let reach = if k_objects > 1 {
            let mut by_object = lowest.clone();
            by_object.select_nth_unstable_by(1, |a, b| a.0.total_cmp(&b.0));
            by_object[..2].iter().map(|&(_, g)| self.group_distance(g as usize, y)).fold(0.0, f64::max)
        } else {
            // One object: its group of least bound holds a point within this distance.
            self.group_distance(lowest[0].1 as usize, y)
        };
        bounds.clear();
        for (g, &glb) in group_lb.iter().enumerate() {
            if glb > reach {
                continue;
            }
            let (first, count) = (self.groups[g].1 as usize, self.groups[g].2 as usize);
            segment_sq.resize(count, 0.0);
            sq_distances(level, y, &self.centres[first * l..(first + count) * l], l, segment_sq);
            for (s, &d2) in (first..first + count).zip(segment_sq.iter()) {
                let lb = (d2.sqrt() - self.radii[s]).max(0.0);
                if lb <= reach {
                    bounds.push((lb, s as u32));
                }
            }
        }
        bounds.sort_unstable_by(|a, b| a.0.total_cmp(&b.0));
        best.fill(f64::INFINITY);
        // The two nearest objects so far (distance, object); a segment whose bound exceeds the
        // second cannot change them, nor one whose bound exceeds its own object's distance so
        // far (with one object, the second stays infinite: its own distance prunes).
        let (mut first, mut second) = ((f64::INFINITY, usize::MAX), (f64::INFINITY, usize::MAX));
        for &(lb, s) in bounds.iter() {
            if lb > second.0 {
                break;
            }
            let k = self.segments[s as usize].0 as usize;
            if lb >= best[k] {
                continue;
            }
            let d = self.segment_distance(s as usize, y);
            if d < best[k] {
                best[k] = d;
                // Re-rank the two nearest objects with object k's new distance.
                if k == first.1 {
                    first.0 = d;
                } else if (d, k) < first {
                    second = first;
                    first = (d, k);
                } else if k == second.1 || (d, k) < second {
                    second = (d, k);
                }
            }
        }
        (first.1, first.0, second.0)
    }

    /// The distance from coordinates `y` to the nearest point of group `g`.
    fn group_distance(&self, g: usize, y: &[f32]) -> f64 {
        let (_, first, count) = self.groups[g];
        (first as usize..(first + count) as usize).map(|s| self.segment_distance(s, y)).fold(f64::INFINITY, f64::min)
    }

    /// The distance from coordinates `y` to the nearest point of segment `s`.
    #[inline]
    fn segment_distance(&self, s: usize, y: &[f32]) -> f64 {
        let l = self.components();
        let (k, start) = (self.segments[s].0 as usize, self.segments[s].1 as usize);
        let p = &self.points[k];
        let end = (start + SEGMENT).min(p.len() / l);
        nearest_sq(Level::detect(), y, &p[start * l..end * l], l).sqrt()
    }

    /// The distance from coordinates `y` to object `k`'s nearest manifold point (every point).
    fn distance_to(&self, k: usize, y: &[f32]) -> f64 {
        nearest_sq(Level::detect(), y, &self.points[k], self.components()).sqrt()
    }

    /// Numbers stored: the eigenimages, the mean, every manifold point.
    pub(super) fn numbers(&self) -> usize {
        self.proj.rows().len() + self.mean.len() + self.points.iter().map(Vec::len).sum::<usize>()
    }

    /// Manifold points over all objects, N_dense.
    pub(super) fn manifold_len(&self) -> usize {
        self.points.iter().map(Vec::len).sum::<usize>() / self.components()
    }

    /// The arrays, named `{prefix}basis`, `{prefix}mean` and `{prefix}manifold.K`.
    pub(super) fn tensors(&self, prefix: &str) -> Vec<Tensor> {
        let (l, m) = (self.components(), self.mean.len());
        let mut v = vec![
            Tensor::f32(&format!("{prefix}basis"), vec![l, m], self.proj.rows().to_vec()),
            Tensor::f32(&format!("{prefix}mean"), vec![m], self.mean.clone()),
        ];
        for (k, p) in self.points.iter().enumerate() {
            v.push(Tensor::f32(&format!("{prefix}manifold.{k}"), vec![p.len() / l, l], p.clone()));
        }
        v
    }

    /// Reads back [`Universal::tensors`] under `prefix` for `objects` objects of `m` features and
    /// `l` dimensions.
    pub(super) fn from_parts(t: &TensorSet, prefix: &str, objects: usize, m: usize, l: usize) -> Result<Self> {
        let basis = t.f32(&format!("{prefix}basis"), &[l, m])?;
        let mean = t.f32(&format!("{prefix}mean"), &[m])?;
        let mut points = Vec::with_capacity(objects);
        for k in 0..objects {
            let name = format!("{prefix}manifold.{k}");
            let rows = t.tensors.iter().find(|x| x.name == name).map(|x| x.shape.first().copied().unwrap_or(0)).unwrap_or(0);
            if rows == 0 {
                return Err(t.error(format!("no points in tensor '{name}'")));
            }
            points.push(t.f32(&name, &[rows, l])?);
        }
        if basis.iter().chain(&mean).chain(points.iter().flatten()).any(|v| !v.is_finite()) {
            return Err(t.error("the universal eigenspace holds non-finite values"));
        }
        Universal::new(basis, mean, points).map_err(|e| t.error(e.to_string()))
    }
}

/// The universal eigenspace as a recogniser (its inherent methods do the work: its own
/// eigenspaces, [`super::own`], use them too).
impl Recognize for Universal {
    fn distances(&self, queries: &[f32], out: &mut [f64]) {
        Universal::distances(self, queries, out)
    }

    /// The nearest two objects by [`Universal::nearest_two`]'s search, not every distance.
    fn recognize(&self, queries: &[f32], n: usize, thresholds: &[f64]) -> Result<Vec<Recognition>> {
        let mut near = vec![(0, 0.0, 0.0); n];
        self.nearest_two(queries, &mut near);
        if let Some(i) = near.iter().position(|n| !n.1.is_finite()) {
            return Err(crate::model::unscalable_query(i));
        }
        Ok(near.into_iter().map(|(k, d1, d2)| Recognition::from_nearest(k, d1, d2, thresholds)).collect())
    }

    fn stored_numbers(&self) -> usize {
        self.numbers()
    }

    fn storage_terms(&self) -> Vec<(&'static str, usize)> {
        vec![("N_dense", self.manifold_len()), ("L", self.components())]
    }

    fn arrays(&self) -> Vec<Tensor> {
        self.tensors("recognizer.")
    }
}

/// The least and largest norm of the rows of `l` coordinates in `rows`, each from coordinate
/// `from` on.
fn norm_range(rows: &[f32], l: usize, from: usize) -> (f64, f64) {
    rows.chunks_exact(l).map(|p| crate::linalg::energy(&p[from..]).sqrt()).fold((f64::INFINITY, 0.0), |(lo, hi), r| (lo.min(r), hi.max(r)))
}

/// `v` rounded to f32.
pub(crate) fn to32(v: &[f64]) -> Vec<f32> {
    v.iter().map(|&x| x as f32).collect()
}

/// The sphere bounding `rows` (of `l` coordinates): the f32 centre of the rows (as queries use it)
/// and the largest distance of a row from it, widened by a relative 1e-5 for the rounding of
/// the distances it bounds.
fn sphere(rows: &[f32], l: usize) -> (Vec<f32>, f64) {
    let count = (rows.len() / l) as f64;
    let mut c64 = vec![0f64; l];
    for row in rows.chunks_exact(l) {
        c64.iter_mut().zip(row).for_each(|(a, &b)| *a += b as f64 / count);
    }
    let c: Vec<f32> = c64.iter().map(|&v| v as f32).collect();
    let r = rows.chunks_exact(l).map(|row| distance(row, &c)).fold(0.0, f64::max);
    (c, r * (1.0 + 1e-5) + 1e-6)
}

#[inline(always)]
fn nearest_sq_body(y: &[f32], rows: &[f32], l: usize) -> f64 {
    rows.chunks_exact(l).map(|row| squared_distance(y, row)).fold(f64::INFINITY, f64::min)
}

#[inline(always)]
fn sq_distances_body(y: &[f32], rows: &[f32], l: usize, out: &mut [f64]) {
    out.iter_mut().zip(rows.chunks_exact(l)).for_each(|(o, row)| *o = squared_distance(y, row));
}

dispatch! {
    /// The squared distances from `y` to the rows of `l` coordinates in `rows`, into `out` (one
    /// per row), built for the CPU's level: the search's bounds (group and segment centres).
    fn sq_distances(y: &[f32], rows: &[f32], l: usize, out: &mut [f64]) = sq_distances_body;
}

dispatch! {
    /// The least squared distance from `y` to the rows of `l` coordinates in `rows`
    /// ([`squared_distance`], infinite for none), built for the CPU's level: the searches' inner
    /// loop, which the baseline build ran in 4-lane SSE2. Its root is the least [`distance`]
    /// (the root is monotone and correctly rounded), so the same bits as taking the roots first.
    fn nearest_sq(y: &[f32], rows: &[f32], l: usize) -> f64 = nearest_sq_body;
}

/// The Euclidean distance between two rows of f32 coordinates ([`squared_distance`]'s root).
/// Every distance the search compares is this function's, so its rounding (about 1e-7
/// relative) never changes which point is nearest between two ways of searching.
#[inline]
fn distance(a: &[f32], b: &[f32]) -> f64 {
    squared_distance(a, b).sqrt()
}

/// For each of `n` points (rows of `l` coordinates in `coords`), its distance to the
/// [`NEIGHBOUR`]-th nearest other point (the nearest when there are fewer others),
/// sqrt(r_i^2 + |c_i - c_j|^2) with `residuals` r_i^2 (0 without): a training view held out of a
/// manifold that is its object's views themselves. Empty for a single point (nothing to hold it
/// out from).
pub(crate) fn nearest_other(coords: &[f64], l: usize, residuals: Option<&[f64]>) -> Vec<f64> {
    let n = coords.len() / l.max(1);
    if n < 2 {
        return Vec::new();
    }
    let k = NEIGHBOUR.min(n - 1);
    (0..n)
        .map(|i| {
            let ci = &coords[i * l..(i + 1) * l];
            let mut d: Vec<f64> =
                (0..n).filter(|&j| j != i).map(|j| ci.iter().zip(&coords[j * l..(j + 1) * l]).map(|(a, b)| (a - b) * (a - b)).sum::<f64>()).collect();
            d.select_nth_unstable_by(k - 1, f64::total_cmp);
            (residuals.map_or(0.0, |r| r[i].max(0.0)) + d[k - 1]).sqrt()
        })
        .collect()
}

/// Each training view's distance to its object's manifold interpolated from the other knots (the
/// same splines), at the view's own pose, over both folds of every axis with enough knots; empty
/// when none has. At its pose, not to the nearest point anywhere: a view whose twin (the other
/// side of a symmetric object) stays in the fold would otherwise measure nothing.
fn held_out_distances(train: &Dataset, grid: &Grid, coords: &[f64], l: usize) -> Result<Vec<f64>> {
    let space = train.space();
    let mut out = Vec::new();
    let mut f = vec![0.0; l];
    for keep in crate::manifold::folds::both_folds(train, grid) {
        let kept: Vec<usize> = (0..train.len()).filter(|&i| keep[i]).collect();
        let poses: Vec<f64> = kept.iter().flat_map(|&i| train.pose(i).iter().copied()).collect();
        let names: Vec<String> = kept.iter().map(|&i| train.manifest().images()[i].clone()).collect();
        let sub = Grid::new(space, &poses, &names, train.manifest().root())?;
        let knots: Vec<f64> = sub.sample_at.iter().flat_map(|&k| coords[kept[k] * l..(kept[k] + 1) * l].iter().copied()).collect();
        let surface = Surface::new(space, &sub.axes, &knots, l, Interpolant::Spline)?;
        for i in (0..train.len()).filter(|&i| !keep[i]) {
            let mut t = train.pose(i).to_vec();
            surface.clamp(&mut t);
            surface.eval(&t, &mut f, None);
            out.push(coords[i * l..(i + 1) * l].iter().zip(&f).map(|(a, b)| (a - b) * (a - b)).sum::<f64>().sqrt());
        }
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Every level's build of the searches' inner loops gives the portable body's bits, for row
    /// lengths with and without a remainder of 8 lanes, and the root of the least is the least
    /// of the roots.
    #[test]
    fn every_level_finds_the_same_least_distance() {
        for l in [1, 7, 8, 13, 20, 33] {
            let rows: Vec<f32> = (0..SEGMENT * l).map(|i| ((i * 2654435761usize) % 1000) as f32 / 997.0 - 0.4).collect();
            let y: Vec<f32> = (0..l).map(|i| (i as f32 * 0.37).sin()).collect();
            let want = nearest_sq_body(&y, &rows, l);
            let roots = rows.chunks_exact(l).map(|r| distance(&y, r)).fold(f64::INFINITY, f64::min);
            assert_eq!(want.sqrt().to_bits(), roots.to_bits(), "l {l}");
            let each: Vec<u64> = rows.chunks_exact(l).map(|r| squared_distance(&y, r).to_bits()).collect();
            for level in Level::supported() {
                assert_eq!(nearest_sq(level, &y, &rows, l).to_bits(), want.to_bits(), "{level:?}, l {l}");
                let mut out = vec![0.0; SEGMENT];
                sq_distances(level, &y, &rows, l, &mut out);
                assert_eq!(out.iter().map(|v| v.to_bits()).collect::<Vec<_>>(), each, "{level:?}, l {l}");
            }
        }
        assert_eq!(nearest_sq(Level::detect(), &[1.0], &[], 1), f64::INFINITY);
    }
}
