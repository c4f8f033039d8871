//! Murase & Nayar's universal eigenspace: every object's training images, scaled to unit energy,
//! share one eigenspace (the crate's Gram-matrix PCA, `methods::eigenspace::pca`); each object's
//! training coordinates are joined by the same splines as the parametric eigenspace's manifold and
//! resampled densely; a query's distance to an object is its distance to the nearest point of
//! that object's manifold, in the eigenspace (its residual off the eigenspace is the same for
//! every object, so it would not change which object is nearest).
//!
//! The held-out distance of a training view is its distance to its object's manifold interpolated
//! from the object's other knots, at its own pose (every other knot held out along each axis,
//! then the others: `refined::select::both_folds`), what calibrates the unknown-object threshold.

use super::RecognizerParams;
use crate::catalog::ObjectSet;
use crate::dataset::Dataset;
use crate::methods::eigenspace::chunk_rows;
use crate::methods::eigenspace::manifold::{Grid, Manifold};
use crate::methods::eigenspace::pca::{self, Dimension};
use crate::methods::eigenspace::projector::{unit_coords, Projector};
use crate::methods::eigenspace::search::{NearestIndex, SearchKind};
use crate::methods::refined::surface::Surface;
use crate::methods::refined::Interpolant;
use crate::model::{Tensor, TensorSet};
use crate::{Error, Result};
use rayon::prelude::*;

/// A fitted universal eigenspace with every object's manifold in it.
#[derive(Debug, Clone)]
pub(crate) struct Universal {
    /// The eigenimages (L x M).
    proj: Projector,
    /// The mean unit-energy training image (M).
    mean: Vec<f32>,
    /// Each eigenimage's product with the mean.
    mean_proj: Vec<f32>,
    /// Each object's manifold points (rows of L).
    points: Vec<Vec<f32>>,
    index: Vec<NearestIndex>,
    /// Each object's bounding sphere: the centre of its points (rows of L) and the largest
    /// distance of one from it, so a query's distance to the manifold is at least its distance to
    /// the centre less the radius, and most objects are never searched ([`Universal::nearest_two`]).
    centres: Vec<f32>,
    radii: Vec<f64>,
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
    pub fn fit(objects: &ObjectSet, all: &Dataset, params: &RecognizerParams) -> Result<UniversalFit> {
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
            let dense = Manifold::build(space, grid, coords, l, step)?;
            points.push(dense.points.iter().map(|&v| v as f32).collect::<Vec<f32>>());
            held_out.push(held_out_distances(d, grid, coords, l)?);
        }
        let to32 = |v: &[f64]| v.iter().map(|&x| x as f32).collect::<Vec<f32>>();
        let model = Universal::new(to32(&pca.basis), to32(&pca.mean), points)?;
        Ok(UniversalFit { model, energy_kept: pca.energy_kept(), held_out })
    }

    fn new(basis: Vec<f32>, mean: Vec<f32>, points: Vec<Vec<f32>>) -> Result<Self> {
        let m = mean.len();
        let l = basis.len() / m;
        let index = points.iter().map(|p| NearestIndex::new(p, l, SearchKind::Auto)).collect::<Result<_>>()?;
        let rows = 0..l;
        let proj = Projector::new(&basis, m);
        let mean_proj = proj.dots_f64(&rows, &mean);
        let mut centres = vec![0f32; points.len() * l];
        let mut radii = Vec::with_capacity(points.len());
        for (p, c) in points.iter().zip(centres.chunks_exact_mut(l)) {
            let n = (p.len() / l) as f64;
            let mut c64 = vec![0f64; l];
            for row in p.chunks_exact(l) {
                c64.iter_mut().zip(row).for_each(|(a, &b)| *a += b as f64 / n);
            }
            c.iter_mut().zip(&c64).for_each(|(a, &b)| *a = b as f32);
            // The radius from the f32 centre used at query time, widened by a relative 1e-5 for
            // the f32 rounding of the distances it bounds.
            let r = p.chunks_exact(l).map(|row| distance(row, c)).fold(0.0, f64::max);
            radii.push(r * (1.0 + 1e-5) + 1e-6);
        }
        Ok(Universal { proj, mean, mean_proj, points, index, centres, radii })
    }

    /// Dimensions L.
    pub fn components(&self) -> usize {
        self.mean_proj.len()
    }

    /// Each query's distance to each object's manifold into `out` (rows of K); a query that
    /// cannot be scaled to unit energy gets NaN.
    pub fn distances(&self, queries: &[f32], out: &mut [f64]) {
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
    /// distances. Objects are searched in the order of their bounding spheres' lower bounds and
    /// the search stops at the first bound beyond the second nearest distance found: the same
    /// answer as searching them all ([`Universal::distances`]).
    pub fn nearest_two(&self, queries: &[f32], out: &mut [(usize, f64, f64)]) {
        let (l, m) = (self.components(), self.mean.len());
        let n = queries.len() / m;
        let rows = chunk_rows(n);
        queries.par_chunks(rows * m).zip(out.par_chunks_mut(rows)).for_each(|(q, o)| {
            let mut y = vec![0f32; q.len() / m * l];
            self.proj.f32_products(&(0..l), q, &mut y);
            let mut bounds: Vec<(f64, usize)> = Vec::with_capacity(self.radii.len());
            for ((x, y), o) in q.chunks_exact(m).zip(y.chunks_exact_mut(l)).zip(o.iter_mut()) {
                if unit_coords(crate::linalg::energy(x), &self.mean_proj, y).is_none() {
                    *o = (0, f64::NAN, f64::NAN);
                    continue;
                }
                bounds.clear();
                bounds.extend(self.centres.chunks_exact(l).zip(&self.radii).enumerate().map(|(k, (c, r))| ((distance(y, c) - r).max(0.0), k)));
                bounds.sort_by(|a, b| a.0.total_cmp(&b.0));
                let (mut best, mut d1, mut d2) = (0, f64::INFINITY, f64::INFINITY);
                for &(lb, k) in bounds.iter() {
                    if lb > d2 {
                        break;
                    }
                    let d = self.distance_to(k, y);
                    if d < d1 || (d == d1 && k < best) {
                        (best, d1, d2) = (k, d, d1);
                    } else if d < d2 {
                        d2 = d;
                    }
                }
                *o = (best, d1, d2);
            }
        });
    }

    /// The distance from coordinates `y` to object `k`'s nearest manifold point.
    #[inline]
    fn distance_to(&self, k: usize, y: &[f32]) -> f64 {
        let l = self.components();
        distance(y, &self.points[k][self.index[k].nearest(y) * l..][..l])
    }

    /// Numbers stored: the eigenimages, the mean, every manifold point.
    pub fn numbers(&self) -> usize {
        self.proj.rows().len() + self.mean.len() + self.points.iter().map(Vec::len).sum::<usize>()
    }

    /// Manifold points over all objects, N_dense.
    pub fn manifold_len(&self) -> usize {
        self.points.iter().map(Vec::len).sum::<usize>() / self.components()
    }

    pub fn tensors(&self) -> Vec<Tensor> {
        let (l, m) = (self.components(), self.mean.len());
        let mut v = vec![Tensor::f32("recognizer.basis", vec![l, m], self.proj.rows().to_vec()), Tensor::f32("recognizer.mean", vec![m], self.mean.clone())];
        for (k, p) in self.points.iter().enumerate() {
            v.push(Tensor::f32(&format!("recognizer.manifold.{k}"), vec![p.len() / l, l], p.clone()));
        }
        v
    }

    /// Reads back [`Universal::tensors`] for `objects` objects of `m` features and `l`
    /// dimensions.
    pub fn from_parts(t: &TensorSet, objects: usize, m: usize, l: usize) -> Result<Self> {
        let basis = t.f32("recognizer.basis", &[l, m])?;
        let mean = t.f32("recognizer.mean", &[m])?;
        let mut points = Vec::with_capacity(objects);
        for k in 0..objects {
            let name = format!("recognizer.manifold.{k}");
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

/// The Euclidean distance between two rows of f32 coordinates, summed in f64.
#[inline]
fn distance(a: &[f32], b: &[f32]) -> f64 {
    a.iter().zip(b).map(|(&x, &y)| (x as f64 - y as f64).powi(2)).sum::<f64>().sqrt()
}

/// Each training view's distance to its object's manifold interpolated from the other knots (the
/// same splines), at the view's own pose, over both folds of every axis with enough knots; empty
/// when none has. At its pose, not to the nearest point anywhere: a view whose twin (the other
/// side of a symmetric object) stays in the fold would otherwise measure nothing.
fn held_out_distances(train: &Dataset, grid: &Grid, coords: &[f64], l: usize) -> Result<Vec<f64>> {
    let space = train.space();
    let mut out = Vec::new();
    let mut f = vec![0.0; l];
    for keep in crate::methods::refined::select::both_folds(train, grid) {
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
