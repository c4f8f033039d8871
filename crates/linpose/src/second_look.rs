//! The second look: a manifold method's candidate poses compared again in the full span of the
//! training views, which decides between them and scores them ([`crate::confidence`]).
//!
//! An eigenspace keeps the L eigenimages of most energy (20 for Murase & Nayar). What tells a
//! nearly symmetric object's front from its back (a small mark, a knob, a feature on one side) has
//! little energy, so it lies mostly in the components past L: in the L-dimensional eigenspace the
//! front and the back views are almost the same point, and the nearest manifold point is a coin
//! toss between them. The second look keeps every principal component of the training views,
//! N - 1 of them, at a coarse binning ([`SECOND_LOOK_BIN`], which keeps a mark's energy while the
//! products cost about as much as the eigenspace's own), and a surface through the training
//! views' coordinates there (the same interpolant as the method's manifold). For a query it
//!
//! 1. projects the binned, unit-energy query on all N - 1 components;
//! 2. finds the *basins* of its distance to that surface: the method's estimate, climbed to the
//!    nearest local least of the distance on a lattice of [`STEP_DEG`], and the local minima of
//!    the distance over a grid of [`PER_CELL`] points per knot interval, kept while at least
//!    [`GROSS_DEG`] from the estimate and from each other; the nearest of them is climbed likewise
//!    (it and the estimate's decide the estimate and its confidence), the others keep their grid
//!    point's distance;
//! 3. takes the nearest basin (the method's own on a tie): when it is not the estimate's, the
//!    method searches again in that basin (its own metric, started at the basin's pose) and that
//!    is the estimate;
//! 4. scores the basins as [`crate::confidence`] says: exp(-d_k / 2 s^2), normalised, with
//!    s^2 = max(D_h, d_1) / K_eff. D_h is the distance a fresh view between training views is
//!    expected at: the held-out training views' mean squared distance (every other knot held out
//!    along each axis, then the others, the surface through the rest) times [`UNSEEN_SHARE`],
//!    since a held-out view lies twice as far from its neighbours as a fresh one does; K_eff is
//!    how many coordinates that distance spreads over ([`SecondLookSettings::effective_dims`]).
//!    One more alternative, that the query is none of the manifold's views, is scored alike at
//!    the held-out views' own distance D ([`SecondLookSettings::held_out`]): a query farther
//!    from the manifold than a view the manifold does not hold (an image not registered like
//!    the training views, another object) is not trusted, whatever its basins.
//!
//! With more than two pose parameters, where the method keeps its manifold as its knots
//! ([`crate::manifold::dense_lattice`]) and a climb on a lattice would take many steps of
//! 3^D - 1 poses each in K dimensions, the scan is over the knots themselves, and each climb is
//! Levenberg-Marquardt on the distance from the same start, its end rounded to the lattice of
//! [`STEP_DEG`]. Between knots, the surface in K = N - 1 dimensions interpolates the views' fine
//! detail poorly where the knots are far apart (on a rendered duck with knots 12 to 20 degrees
//! apart, a view's distance at its own pose came to twice its distance at a training view 20
//! degrees off), so a basin the look finds where the method's own search has none (the method,
//! started there, slides back to its estimate) does not move the estimate: it only lowers its
//! confidence. With fewer parameters the basin's pose then stands.
//!
//! `predict` and `estimate` take the same steps, so the estimate `predict` gives is the first
//! hypothesis `estimate` gives. The method's own search still places the pose within its
//! basin: the second look only says which basin.
//!
//! Storage, in the terms of the paper's Table 1: K (M / b^2) + N K + M / b^2 numbers for K = N - 1
//! components of images binned by b; per query K (M / b^2) products beside the method's own,
//! and the scan of the surface's grid.

use crate::binning::Binning;
use crate::confidence::{grid_minima, posterior, Estimate, Hypothesis, GROSS_DEG, MAX_HYPOTHESES};
use crate::dataset::Dataset;
use crate::image_io::ImageSpec;
use crate::kernels::scan::sq_dist;
use crate::kernels::Level;
use crate::manifold::folds::{both_folds, held_out_errors};
use crate::manifold::grid::Grid;
use crate::manifold::pca::{self, Dimension};
use crate::manifold::projector::Projector;
use crate::manifold::surface::{Interpolant, Surface};
use crate::model::{split, Tensor, TensorSet};
use crate::pose::{wrap_positive, PoseSpace};
pub(crate) use crate::tuning::second_look::SECOND_LOOK_BIN;
use crate::tuning::second_look::{PER_CELL, STEP_DEG, STEP_TOL_LOOK, UNSEEN_SHARE};
use crate::{Error, Result};
use rayon::prelude::*;
use serde::{Deserialize, Serialize};

/// What a model records of its second look (in its settings).
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct SecondLookSettings {
    /// The binning factor of its images.
    pub bin: usize,
    /// Its principal components, K (N - 1 unless the training views span fewer).
    pub components: usize,
    /// How its surface passes between the knots.
    pub interpolant: Interpolant,
    /// The knots' positions along each pose parameter.
    pub knot_axes: Vec<Vec<f64>>,
    /// The held-out training views' mean squared distance to the surface through the others (0
    /// when no axis has enough knots to hold any out): also the distance at which the
    /// alternative that the query is none of the manifold's views is scored.
    pub held_out: f64,
    /// D_h, the distance level of a fresh view: `held_out` times [`UNSEEN_SHARE`].
    pub floor: f64,
    /// How many of the K coordinates the held-out distance spreads over, (sum_c v_c)^2 /
    /// sum_c v_c^2 for v_c the held-out views' mean squared error in coordinate c: K when it
    /// spreads evenly, 1 when one coordinate holds it all. The squared distance of independent
    /// Gaussian errors of variances v_c has the mean and the variance of a sum of that many
    /// equal ones (Satterthwaite), so the scores take the variance per coordinate as
    /// D / `effective_dims`.
    pub effective_dims: f64,
}

/// A fitted second look (see the [module doc](self)).
#[derive(Debug, Clone)]
pub(crate) struct SecondLook {
    settings: SecondLookSettings,
    binning: Binning,
    space: PoseSpace,
    /// The mean binned unit-energy training image (M_b), and the basis's products with it (K).
    mean: Vec<f32>,
    mean_proj: Vec<f64>,
    /// K x M_b, row-major, with its f32 product kernel.
    basis: Vec<f32>,
    proj: Projector,
    /// The training views' coordinates on the knot grid (N x K, row-major, last parameter fastest).
    knots: Vec<f32>,
    surface: Surface,
    /// The scan grid: its shape, poses (row-major, D each) and surface points, coordinate-major
    /// (K rows of G values: the points in SIMD lanes, [`crate::kernels::scan::sq_dist`]).
    scan_shape: Vec<(usize, bool)>,
    scan_poses: Vec<f64>,
    scan_cols: Vec<f32>,
    /// Unit weights (K) for that kernel, and in f64 for Levenberg-Marquardt.
    ones: Vec<f32>,
    ones64: Vec<f64>,
}

/// Per-thread buffers of [`SecondLook::apply`].
#[derive(Default)]
struct Scratch {
    /// An 8-bit query as features (for the method's search in another basin).
    features: Vec<f32>,
    /// The query binned, and the binning's scratch (f32, or 8-bit block sums).
    binned: Vec<f32>,
    acc: Vec<f32>,
    sums: Vec<u16>,
    acc16: Vec<u16>,
    /// Its coordinates, and their raw products.
    z: Vec<f64>,
    y: Vec<f32>,
    /// Its coordinates in f32, and its squared distance to each scan point.
    z32: Vec<f32>,
    dist32: Vec<f32>,
    dist: Vec<f64>,
    /// Levenberg-Marquardt's scratch ((D + 2) K).
    buf: Vec<f64>,
}

/// One query as the method was given it.
#[derive(Clone, Copy)]
enum Query<'a> {
    F32(&'a [f32]),
    U8(&'a [u8]),
}

/// A batch of queries as the method was given them.
#[derive(Debug, Clone, Copy)]
pub(crate) enum Queries<'a> {
    /// Features in [0, 1].
    F32(&'a [f32]),
    /// Raw 8-bit pixel values (features times 255).
    U8(&'a [u8]),
}

impl SecondLook {
    /// The second look at the training views `train` (features as the method was given them),
    /// on their pose grid `grid`, with `interpolant` between the knots.
    pub(crate) fn fit(train: &Dataset, grid: &Grid, interpolant: Interpolant) -> Result<SecondLook> {
        let binning = Binning::coarsest(train.spec(), SECOND_LOOK_BIN, train.len());
        let binned =
            if binning.bins() { Some(Dataset::from_features(train.manifest().clone(), binning.spec(), binning.apply_all(train.features()))?) } else { None };
        let views = binned.as_ref().unwrap_or(train);
        let pca = pca::fit(views, Dimension::Fixed(views.len().saturating_sub(1).max(1)))?;
        let k = pca.dim();
        let knots: Vec<f32> = grid.sample_at.iter().flat_map(|&i| pca.coords[i * k..(i + 1) * k].iter().map(|&v| v as f32)).collect();
        // Every other knot along each axis held out, then the others.
        let per_coord = held_out_errors(views, &both_folds(views, grid), &pca.coords, k, interpolant)?;
        let held_out: f64 = per_coord.iter().sum();
        let squares: f64 = per_coord.iter().map(|v| v * v).sum();
        let effective_dims = if squares > 0.0 { held_out * held_out / squares } else { k as f64 };
        let settings = SecondLookSettings {
            bin: binning.factor(),
            components: k,
            interpolant,
            knot_axes: grid.axes.clone(),
            held_out,
            floor: held_out * UNSEEN_SHARE,
            effective_dims,
        };
        let to32 = |v: &[f64]| v.iter().map(|&x| x as f32).collect::<Vec<f32>>();
        SecondLook::new(settings, train.spec(), train.space().clone(), to32(&pca.mean), to32(&pca.basis), knots)
    }

    fn new(settings: SecondLookSettings, spec: ImageSpec, space: PoseSpace, mean: Vec<f32>, basis: Vec<f32>, knots: Vec<f32>) -> Result<SecondLook> {
        let binning = Binning::new(spec, settings.bin)?;
        let (k, mb) = (settings.components, binning.spec().features());
        debug_assert_eq!(basis.len(), k * mb);
        let k64: Vec<f64> = knots.iter().map(|&v| v as f64).collect();
        let surface = Surface::new(&space, &settings.knot_axes, &k64, k, settings.interpolant)?;
        let d = space.len();
        let per_cell = if crate::manifold::dense_lattice(d) { PER_CELL } else { 1 };
        let scan_shape = surface.grid_shape(per_cell);
        let scan_poses = surface.grid_poses(per_cell);
        let g = scan_poses.len() / d.max(1);
        let mut scan_cols = vec![0f32; g * k];
        let mut f = vec![0.0; k];
        for (j, t) in scan_poses.chunks_exact(d).enumerate() {
            surface.eval(t, &mut f, None);
            for (c, &v) in f.iter().enumerate() {
                scan_cols[c * g + j] = v as f32;
            }
        }
        let mean_proj = basis.chunks_exact(mb).map(|u| u.iter().zip(&mean).map(|(&a, &b)| a as f64 * b as f64).sum()).collect();
        let proj = Projector::new(&basis, mb);
        Ok(SecondLook {
            settings,
            binning,
            space,
            mean,
            mean_proj,
            basis,
            proj,
            knots,
            surface,
            scan_shape,
            scan_poses,
            scan_cols,
            ones: vec![1.0; k],
            ones64: vec![1.0; k],
        })
    }

    /// What the model records of it.
    pub(crate) fn settings(&self) -> &SecondLookSettings {
        &self.settings
    }

    /// Numbers stored: basis, mean and knots.
    pub(crate) fn len(&self) -> usize {
        self.basis.len() + self.mean.len() + self.knots.len()
    }

    /// Its tensors in a model file.
    pub(crate) fn tensors(&self) -> Vec<Tensor> {
        let (k, mb) = (self.settings.components, self.mean.len());
        let n = self.knots.len() / k.max(1);
        vec![
            Tensor::f32("second_look_basis", vec![k, mb], self.basis.clone()),
            Tensor::f32("second_look_mean", vec![mb], self.mean.clone()),
            Tensor::f32("second_look_knots", vec![n, k], self.knots.clone()),
        ]
    }

    /// Reads it back from a model file of images `spec` and poses `space`.
    pub(crate) fn from_parts(settings: SecondLookSettings, spec: ImageSpec, space: &PoseSpace, t: &TensorSet) -> Result<SecondLook> {
        let bad = |e: String| t.error(format!("damaged second-look settings: {e}"));
        let binning = Binning::new(spec, settings.bin).map_err(|e| bad(e.to_string()))?;
        let (k, mb, d) = (settings.components, binning.spec().features(), space.len());
        if k == 0 || settings.knot_axes.len() != d || settings.knot_axes.iter().any(|a| a.is_empty() || a.len() > 1 << 16) {
            return Err(bad(format!("{k} components, knot axes of {:?} points", settings.knot_axes.iter().map(Vec::len).collect::<Vec<_>>())));
        }
        if settings.knot_axes.iter().flatten().any(|v| !v.is_finite()) || settings.knot_axes.iter().any(|a| a.windows(2).any(|w| w[1] <= w[0])) {
            return Err(bad("knot positions are not finite and increasing".into()));
        }
        let finite = |v: f64| v.is_finite() && v >= 0.0;
        if !(finite(settings.held_out) && finite(settings.floor) && finite(settings.effective_dims) && settings.effective_dims <= k as f64 + 1e-9) {
            return Err(bad(format!(
                "held-out level {}, floor {}, {} effective of {k} components",
                settings.held_out, settings.floor, settings.effective_dims
            )));
        }
        let n: usize = settings.knot_axes.iter().map(Vec::len).product();
        let basis = t.f32("second_look_basis", &[k, mb])?;
        let mean = t.f32("second_look_mean", &[mb])?;
        let knots = t.f32("second_look_knots", &[n, k])?;
        if basis.iter().chain(&mean).chain(&knots).any(|v| !v.is_finite()) {
            return Err(t.error("the second look holds non-finite values"));
        }
        SecondLook::new(settings, spec, space.clone(), mean, basis, knots).map_err(|e| bad(e.to_string()))
    }

    /// A query's coordinates (features of the method's images, binned here), into `z` (K); false
    /// for a query of zero or non-finite energy.
    fn coords(&self, x: Query<'_>, s: &mut Scratch) -> bool {
        let Scratch { binned, acc, sums, acc16, z, y, .. } = s;
        let b: &[f32] = match x {
            Query::F32(x) if self.binning.bins() => {
                binned.resize(self.mean.len(), 0.0);
                self.binning.apply(x, binned, acc);
                binned
            }
            Query::F32(x) => x,
            // The block sums, exact in integers: a constant factor cancels in the unit energy.
            Query::U8(x) if self.binning.bins() => {
                sums.resize(self.mean.len(), 0);
                self.binning.sums_u8(x, sums, acc16);
                binned.clear();
                binned.extend(sums.iter().map(|&v| v as f32));
                binned
            }
            Query::U8(x) => {
                binned.clear();
                binned.extend(x.iter().map(|&v| v as f32));
                binned
            }
        };
        let energy: f64 = b.iter().map(|&v| v as f64 * v as f64).sum();
        if !(energy.is_finite() && energy > 0.0) {
            return false;
        }
        let inv = 1.0 / energy.sqrt();
        self.proj.f32_products(&(0..self.settings.components), b, y);
        for ((zk, &p), &c) in z.iter_mut().zip(y.iter()).zip(&self.mean_proj) {
            *zk = p as f64 * inv - c;
        }
        true
    }

    /// Climbs `t` (surface coordinates) to a local least of the distance from `z`; returns it.
    fn climb(&self, z: &[f64], t: &mut [f64], f: &mut [f64]) -> f64 {
        self.surface.clamp(t);
        self.surface.climb_by(t, STEP_DEG, |p| {
            self.surface.eval(p, f, None);
            f.iter().zip(z).map(|(&a, &b)| (a - b) * (a - b)).sum()
        })
    }

    /// The pose of surface coordinates `t` (circular values in [0, period)).
    fn pose_of(&self, t: &[f64]) -> Vec<f64> {
        t.iter().zip(self.space.params()).map(|(&v, p)| p.period.map_or(v, |per| wrap_positive(v, per))).collect()
    }

    /// The basins of the query `z` (see the module doc): the first is the estimate `pose`'s (its
    /// pose as given, its distance climbed), then the others, each at least [`GROSS_DEG`] from it
    /// and from each other, at their climbed poses; at most [`MAX_HYPOTHESES`] in all.
    fn basins(&self, s: &mut Scratch, pose: &[f64]) -> Vec<(Vec<f64>, f64)> {
        let (k, d) = (self.settings.components, self.space.len());
        let Scratch { z, z32, dist32, dist, .. } = s;
        let mut f = vec![0.0; k];
        let mut t = pose.to_vec();
        let own = self.climb(z, &mut t, &mut f);
        let mut out = vec![(pose.to_vec(), own)];
        z32.clear();
        z32.extend(z.iter().map(|&v| v as f32));
        dist32.resize(self.scan_poses.len() / d.max(1), 0.0);
        sq_dist(Level::detect(), &self.scan_cols, z32, &self.ones, dist32);
        dist.clear();
        dist.extend(dist32.iter().map(|&v| v as f64));
        let mut minima = grid_minima(&self.scan_shape, dist);
        minima.sort_by(|&a, &b| dist[a].total_cmp(&dist[b]));
        for j in minima {
            if out.len() == MAX_HYPOTHESES {
                break;
            }
            let start = &self.scan_poses[j * d..(j + 1) * d];
            let far = |p: &[f64]| out.iter().all(|o| self.space.error_deg(&o.0, p) >= GROSS_DEG);
            if !far(&self.pose_of(start)) {
                continue;
            }
            // The nearest rival is climbed to its basin's least, as the estimate's is: the two
            // decide the estimate and its confidence. The others keep their scan point (an upper
            // bound on their basin's distance), which costs no climb.
            if out.len() == 1 {
                let mut t = start.to_vec();
                let dj = self.climb(z, &mut t, &mut f);
                let p = self.pose_of(&t);
                if far(&p) {
                    out.push((p, dj));
                }
            } else {
                out.push((self.pose_of(start), dist[j]));
            }
        }
        out
    }

    /// [`Self::basins`] on a manifold kept as its knots (see the module doc): the same basins,
    /// the scan over the knots, each climb replaced by Levenberg-Marquardt on the distance to the
    /// surface from the same start ([`Surface::refine_to`]), its end rounded to the lattice.
    fn basins_continuous(&self, s: &mut Scratch, pose: &[f64]) -> Vec<(Vec<f64>, f64)> {
        let (k, d) = (self.settings.components, self.space.len());
        let Scratch { z, z32, dist32, dist, buf, .. } = s;
        z32.clear();
        z32.extend(z.iter().map(|&v| v as f32));
        dist32.resize(self.scan_poses.len() / d.max(1), 0.0);
        sq_dist(Level::detect(), &self.scan_cols, z32, &self.ones, dist32);
        dist.clear();
        dist.extend(dist32.iter().map(|&v| v as f64));
        buf.resize((d + 2) * k, 0.0);
        let (z32, ones) = (&*z32, &self.ones64);
        let mut descend = |t: &mut [f64]| {
            self.surface.clamp(t);
            let least = self.surface.refine_to(z32, ones, t, buf, STEP_TOL_LOOK);
            // Its pose on the lattice of STEP_DEG, where the climbs of fewer parameters end.
            self.surface.round_to_lattice(t, STEP_DEG);
            least
        };
        let mut t = pose.to_vec();
        let own = descend(&mut t);
        let mut out = vec![(pose.to_vec(), own)];
        let mut minima = grid_minima(&self.scan_shape, dist);
        minima.sort_by(|&a, &b| dist[a].total_cmp(&dist[b]));
        for j in minima {
            if out.len() == MAX_HYPOTHESES {
                break;
            }
            let start = &self.scan_poses[j * d..(j + 1) * d];
            let far = |p: &[f64], out: &[(Vec<f64>, f64)]| out.iter().all(|o| self.space.error_deg(&o.0, p) >= GROSS_DEG);
            if !far(&self.pose_of(start), &out) {
                continue;
            }
            if out.len() == 1 {
                let mut t = start.to_vec();
                let dj = descend(&mut t);
                let p = self.pose_of(&t);
                if far(&p, &out) {
                    out.push((p, dj));
                }
            } else {
                out.push((self.pose_of(start), dist[j]));
            }
        }
        out
    }

    /// The second look over a batch (`queries` of `m` features each) whose method's estimates
    /// are `poses` (D each; NaN for a query the method could not scale, left as it is): where
    /// another basin is nearer than the estimate's, `refine(query features, basin pose, out)`
    /// writes the method's pose in it. With `top`, each query's ranked hypotheses too (an empty
    /// list without).
    pub(crate) fn apply(
        &self,
        queries: Queries<'_>,
        m: usize,
        poses: &mut [f64],
        top: Option<usize>,
        refine: impl Fn(&[f32], &[f64], &mut [f64]) + Sync,
    ) -> Vec<Estimate> {
        let (k, d) = (self.settings.components, self.space.len());
        let continuous = !crate::manifold::dense_lattice(d);
        let one = |s: &mut Scratch, (i, pose): (usize, &mut [f64])| -> Option<Estimate> {
            let q = match queries {
                Queries::F32(all) => Query::F32(&all[i * m..(i + 1) * m]),
                Queries::U8(all) => Query::U8(&all[i * m..(i + 1) * m]),
            };
            if pose[0].is_nan() || !self.coords(q, s) {
                return None;
            }
            let mut basins = if continuous { self.basins_continuous(s, pose) } else { self.basins(s, pose) };
            let dist: Vec<f64> = basins.iter().map(|b| b.1).collect();
            let unexplained = (self.settings.held_out > 0.0).then_some(self.settings.held_out);
            let score = posterior(&dist, self.settings.floor, self.settings.effective_dims, unexplained);
            // The most probable basin; the method's own on a tie.
            let mut w = (1..basins.len()).fold(0, |w, j| if score[j] > score[w] { j } else { w });
            if w != 0 {
                // The method searches again in the nearer basin; where its own metric has
                // no least there (it slides back towards the first estimate), the basin's
                // pose stands.
                let mut p = basins[w].0.clone();
                let features: &[f32] = match q {
                    Query::F32(x) => x,
                    Query::U8(x) => {
                        s.features.clear();
                        s.features.extend(x.iter().map(|&v| v as f32 / 255.0));
                        &s.features
                    }
                };
                refine(features, &basins[w].0, &mut p);
                if self.space.error_deg(&p, &basins[w].0) < GROSS_DEG {
                    basins[w].0 = p;
                    pose.copy_from_slice(&basins[w].0);
                } else if continuous {
                    // On a manifold kept as its knots the look's surface interpolates the views'
                    // detail poorly between knots, and a basin its metric finds where the
                    // method's finds none is taken for that: the estimate stays, its score
                    // says how much the look doubts it.
                    w = 0;
                } else {
                    pose.copy_from_slice(&basins[w].0);
                }
            }
            let top = top?;
            let mut hyps: Vec<Hypothesis> = basins.into_iter().zip(score).map(|((pose, distance), score)| Hypothesis { pose, score, distance }).collect();
            let best = hyps.swap_remove(w);
            hyps.sort_by(|a, b| b.score.total_cmp(&a.score));
            hyps.insert(0, best);
            hyps.truncate(top.max(1));
            Some(Estimate { pose: hyps[0].pose.clone(), confidence: hyps[0].score, hypotheses: hyps })
        };
        let scratch = || Scratch { z: vec![0.0; k], y: vec![0.0; k], ..Scratch::default() };
        // A batch of fewer than split::LOOK_SPLIT_FROM queries runs on the calling thread.
        if split::look_splits(poses.len() / d.max(1), m) {
            poses.par_chunks_mut(d).enumerate().map_init(scratch, one).flatten().collect()
        } else {
            let mut s = scratch();
            poses.chunks_mut(d).enumerate().filter_map(|q| one(&mut s, q)).collect()
        }
    }
}

/// The numbers a second look stores for `n` training views of `m` features with `k` components
/// binned by `b`: K (M / b^2) + N K + M / b^2 (the module doc).
pub(crate) fn numbers(n: usize, k: usize, m: usize, b: usize) -> usize {
    let mb = m / (b * b).max(1);
    k * mb + n * k + mb
}

/// The estimates of [`SecondLook::apply`] for a batch of `n` queries, which every query must
/// have (the method refused any it could not scale before).
pub(crate) fn complete(est: Vec<Estimate>, n: usize) -> Result<Vec<Estimate>> {
    if est.len() == n {
        Ok(est)
    } else {
        Err(Error::invalid("query batch", n, "a query could not be scaled to unit energy for the second look"))
    }
}
