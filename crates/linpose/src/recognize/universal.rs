//! Murase & Nayar's universal eigenspace: every object's training images, scaled to unit energy,
//! share one eigenspace (the crate's Gram-matrix PCA, `methods::eigenspace::pca`); each object's
//! training coordinates are joined by the same splines as the parametric eigenspace's manifold and
//! resampled densely; a query's distance to an object is its distance to the nearest point of
//! that object's manifold, in the eigenspace (its residual off the eigenspace is the same for
//! every object, so it would not change which object is nearest).
//!
//! The held-out distance of a training view is its distance to its object's manifold resampled
//! from the object's other knots (every other knot held out along each axis, then the others:
//! `refined::select::both_folds`), what calibrates the unknown-object threshold.

use super::RecognizerParams;
use crate::catalog::ObjectSet;
use crate::dataset::Dataset;
use crate::methods::eigenspace::chunk_rows;
use crate::methods::eigenspace::manifold::{Grid, Manifold};
use crate::methods::eigenspace::pca::{self, Dimension};
use crate::methods::eigenspace::projector::{unit_coords, Projector};
use crate::methods::eigenspace::search::{NearestIndex, SearchKind};
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
            held_out.push(held_out_distances(d, grid, coords, l, step)?);
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
        Ok(Universal { proj, mean, mean_proj, points, index })
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
                for ((o, idx), pts) in o.iter_mut().zip(&self.index).zip(&self.points) {
                    let p = &pts[idx.nearest(y) * l..][..l];
                    *o = y.iter().zip(p).map(|(&a, &b)| (a as f64 - b as f64).powi(2)).sum::<f64>().sqrt();
                }
            }
        });
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

/// Each training view's distance to the manifold resampled from its object's other knots (over
/// both folds of every axis with enough knots; empty when none has).
fn held_out_distances(train: &Dataset, grid: &Grid, coords: &[f64], l: usize, step: f64) -> Result<Vec<f64>> {
    let space = train.space();
    let mut out = Vec::new();
    for keep in crate::methods::refined::select::both_folds(train, grid) {
        let kept: Vec<usize> = (0..train.len()).filter(|&i| keep[i]).collect();
        let poses: Vec<f64> = kept.iter().flat_map(|&i| train.pose(i).iter().copied()).collect();
        let names: Vec<String> = kept.iter().map(|&i| train.manifest().images()[i].clone()).collect();
        let sub = Grid::new(space, &poses, &names, train.manifest().root())?;
        let knots: Vec<f64> = kept.iter().flat_map(|&i| coords[i * l..(i + 1) * l].iter().copied()).collect();
        let dense = Manifold::build(space, &sub, &knots, l, step)?;
        let held: Vec<usize> = (0..train.len()).filter(|&i| !keep[i]).collect();
        out.par_extend(held.par_iter().map(|&i| {
            let c = &coords[i * l..(i + 1) * l];
            dense.points.chunks_exact(l).map(|p| p.iter().zip(c).map(|(a, b)| (a - b) * (a - b)).sum::<f64>()).fold(f64::INFINITY, f64::min).sqrt()
        }));
    }
    Ok(out)
}
