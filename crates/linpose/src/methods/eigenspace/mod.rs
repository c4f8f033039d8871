//! Murase & Nayar's parametric eigenspace (IJCV 14:5-24, 1995), the method Okatani & Deguchi
//! measure themselves against, written to match a numpy/SciPy implementation of it step by step
//! (the same splines as SciPy's `CubicSpline`, the same resampling positions as numpy's `arange`):
//!
//! 1. each training image scaled to unit energy (||x|| = 1) and the mean image subtracted;
//! 2. the eigenspace: the top L eigenimages, from the N x N Gram matrix (`pca.rs`), L fixed
//!    (default 20, capped at N - 1) or the fewest holding an energy fraction;
//! 3. the appearance manifold: the training images' coordinates on the training grid, joined by
//!    cubic splines along each pose axis (periodic along a circular one) and resampled every
//!    `manifold_step` degrees (`manifold.rs`, `spline.rs`);
//! 4. a query is scaled to unit energy, projected (L dot products of length M) and given the pose
//!    of the nearest manifold point (`search.rs`, a k-d tree or brute force).
//!
//! With more than two pose parameters (`manifold::dense_lattice`) the manifold is not
//! resampled: it is kept as its knots, the training views' coordinates, and searched
//! continuously from the nearest of them (`knots.rs`), so that the model and its training time
//! grow with the training views rather than with a lattice of (range / step)^K points.
//!
//! Beyond Murase & Nayar, linpose then takes the second look (`second_look`): where every
//! principal component of the training views (binned) puts the query nearer another basin of the
//! pose space (a nearly symmetric object's other side), the estimate is the nearest manifold point
//! in that basin; the same look gives the ranked hypotheses and the confidence.
//!
//! Trained in f64, served in f32: the basis (L x M), the mean image (M) and the manifold points
//! (N_dense x L) are stored as f32, and a query's projection is an f32 product. The f32 rounding
//! of a projection, about sqrt(M) * eps_f32 relative (1e-5 for M = 19,200), is far below the
//! distance between manifold points 0.5 degrees apart, so f32 serving returns the same manifold
//! point as f64 would except on exact near-ties; so do 8-bit queries through the 16-bit
//! fixed-point weights of the crate's 8-bit product kernels, whose error is of the same order. Tests that
//! compare them therefore check poses, and identities on the f64 fit (back-projection, knots) use
//! tolerances of a few eps times the size of the sums involved.
//!
//! ```
//! use linpose::{Dataset, EigenspaceParams, Estimator, Param, PoseModel, PoseSpace};
//! use linpose::image_io::{ColorMode, ImageSpec};
//!
//! // A turntable seen every 10 degrees: 36 "images" of 64 pixels, a bright lobe turning round.
//! let space = PoseSpace::new(vec![Param::circular("azimuth", 360.0)])?;
//! let poses: Vec<f64> = (0..36).map(|k| 10.0 * k as f64).collect();
//! let image = |a: f64| (0..64).map(move |p| {
//!     let u = p as f64 / 64.0 * std::f64::consts::TAU;
//!     (0.2 + (3.0 * ((u - a.to_radians()).cos() - 1.0)).exp()) as f32
//! });
//! let pixels = poses.iter().flat_map(|&a| image(a)).collect();
//! let data = Dataset::new(ImageSpec { width: 64, height: 1, color: ColorMode::Gray }, pixels, space, poses)?;
//!
//! let model = EigenspaceParams::default().components(8).manifold_step(0.5).fit(&data)?;
//! let view: Vec<f32> = image(123.0).collect(); // between two training views
//! let pose = model.predict(&view)?;
//! assert!((pose[0] - 123.0).abs() <= 1.0);
//! # Ok::<(), linpose::Error>(())
//! ```

mod footprint;
mod partial;
mod knots;
mod stream;
pub(crate) mod search;
mod tuning;

use crate::dataset::Dataset;
use crate::kernels::{dot_q, dot_u8, Level};
use crate::manifold::Interpolant;
use crate::model::{batch_len, AnyModel, Estimator, Method, MethodOption, ModelMeta, Origin, PoseModel, Settings, Storage, Stream, Tensor, TensorSet};
use crate::model::split;
use crate::second_look::{Queries, SecondLook, SecondLookSettings};
use crate::{Error, Result};
use crate::manifold::grid::{pose_of, Grid, Manifold};
use crate::manifold::projector::{u8_tasks, unit_coords, Projector, BATCH_FROM, U8_BATCH};
use crate::manifold::{chunk_rows, pca};
pub use crate::manifold::pca::Dimension;
use rayon::prelude::*;
use knots::KnotSearch;
use search::NearestIndex;
pub use search::SearchKind;
use serde::{Deserialize, Serialize};

/// The parametric eigenspace in the method registry.
pub(crate) static METHOD: Method = Method {
    name: "eigenspace",
    summary: "Murase & Nayar's parametric eigenspace: PCA, the spline appearance manifold resampled densely, the nearest manifold point",
    origin: Origin::Baseline,
    storage: "NL + ML + (K + 1) M / b^2 + N_t K",
    options: &[
        MethodOption { name: "components", value: "L", help: "number of eigenimages L (default 20, capped at N - 1)" },
        MethodOption { name: "energy", value: "T", help: "instead of components, keep the fewest eigenimages holding this fraction of the energy (e.g. 0.95)" },
        MethodOption { name: "manifold-step", value: "D", help: "resample the appearance manifold every D degrees along each pose axis (default 0.5)" },
    ],
    params: |s| Ok(EigenspaceParams::from_settings(s)?.into()),
    load: |meta, t| Ok(AnyModel::new(EigenspaceModel::from_parts(meta, t)?)),
    footprint: |s| Ok(std::sync::Arc::new(EigenspaceParams::from_settings(s)?)),
    // Two passes over the images with more images than features (`stream.rs`).
    stream: Some(Stream { fit: stream::fit_streamed, passes: |n, m| if n > m { 2 } else { 1 } }),
    partial: Some(|s| Ok(std::sync::Arc::new(EigenspaceParams::from_settings(s)?))),
};

/// Parameters of the parametric eigenspace. The default: 20 components (Murase & Nayar used 8 to
/// 20), a manifold resampled every 0.5 degrees, the search picked by size.
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct EigenspaceParams {
    dimension: Dimension,
    manifold_step: f64,
    search: SearchKind,
}

impl Default for EigenspaceParams {
    fn default() -> Self {
        EigenspaceParams { dimension: Dimension::Fixed(20), manifold_step: 0.5, search: SearchKind::Auto }
    }
}

impl EigenspaceParams {
    /// Keep `l` eigenimages (capped at N - 1 and the usable rank). Replaces an energy threshold.
    pub fn components(mut self, l: usize) -> Self {
        self.dimension = Dimension::Fixed(l);
        self
    }

    /// Keep the fewest eigenimages whose eigenvalues hold at least `fraction` (in (0, 1]) of the
    /// training set's energy about its mean. Replaces a fixed number.
    pub fn energy(mut self, fraction: f64) -> Self {
        self.dimension = Dimension::Energy(fraction);
        self
    }

    /// Resample the manifold every `degrees` along each pose axis.
    pub fn manifold_step(mut self, degrees: f64) -> Self {
        self.manifold_step = degrees;
        self
    }

    /// How the nearest manifold point is found.
    pub fn search(mut self, kind: SearchKind) -> Self {
        self.search = kind;
        self
    }

    /// How the eigenspace dimension is chosen.
    pub fn dimension(&self) -> Dimension {
        self.dimension
    }

    /// The manifold's resampling step (degrees).
    pub fn step(&self) -> f64 {
        self.manifold_step
    }

    /// The nearest-point search asked for.
    pub fn search_kind(&self) -> SearchKind {
        self.search
    }

    /// The parameters from settings by name ([`METHOD`]'s options).
    pub(crate) fn from_settings(settings: &Settings) -> Result<Self> {
        let r = settings.reader(&METHOD)?;
        r.exclusive("energy", "components")?;
        let mut p = EigenspaceParams::default();
        if let Some(l) = r.parse("components", "a whole number")? {
            p = p.components(l);
        }
        if let Some(t) = r.parse("energy", "a fraction in (0, 1]")? {
            p = p.energy(t);
        }
        if let Some(d) = r.parse("manifold-step", "a number of degrees")? {
            p = p.manifold_step(d);
        }
        Ok(p)
    }

    fn validate(&self) -> Result<()> {
        match self.dimension {
            Dimension::Fixed(0) => return Err(Error::invalid("components", 0, "at least one eigenimage is needed")),
            Dimension::Energy(t) if !(t > 0.0 && t <= 1.0) => {
                return Err(Error::invalid("energy", t, "must be a fraction in (0, 1], e.g. 0.95"));
            }
            _ => {}
        }
        if !(self.manifold_step.is_finite() && self.manifold_step > 0.0) {
            return Err(Error::invalid("manifold step", self.manifold_step, "must be a positive number of degrees"));
        }
        Ok(())
    }
}

/// What a fitted model records in [`ModelMeta::settings`]: the parameters as given and what they
/// resolved to.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct EigenspaceSettings {
    /// The parameters as given.
    pub params: EigenspaceParams,
    /// Eigenimages kept, L.
    pub components: usize,
    /// Fraction of the training energy (about the mean) they hold.
    pub energy_kept: f64,
    /// Manifold samples along each pose parameter (the knots, when [`Self::continuous`]).
    pub manifold_shape: Vec<usize>,
    /// Whether the manifold is kept as its knots (the training views on their grid) and
    /// searched continuously instead of resampled every `manifold_step` degrees: for more than
    /// two pose parameters. Poses are still reported on the `manifold_step` lattice.
    #[serde(default, skip_serializing_if = "std::ops::Not::not")]
    pub continuous: bool,
    /// The search in use.
    pub search: SearchKind,
    /// The second look that decides between the estimate and its rivals and scores them
    /// (`second_look`); absent in models fitted inside another method's choices and in a fit
    /// streamed from disk with more images than features (`stream.rs`).
    pub second_look: Option<SecondLookSettings>,
}

impl Estimator for EigenspaceParams {
    type Model = EigenspaceModel;

    fn method(&self) -> &'static Method {
        &METHOD
    }

    fn fit(&self, train: &Dataset) -> Result<EigenspaceModel> {
        self.fit_with_gram(train, None)
    }
}

impl EigenspaceParams {
    /// [`Estimator::fit`] with the training images' Gram matrix X X^T given
    /// ([`pca::fit_with_gram`]); computed from the images when None.
    pub(crate) fn fit_with_gram(&self, train: &Dataset, gram: Option<faer::Mat<f64>>) -> Result<EigenspaceModel> {
        self.validate()?;
        // The grid first: a training set that cannot make a manifold fails before any arithmetic.
        let grid = self.grid(train.manifest())?;
        let pca = match gram {
            Some(g) => pca::fit_with_gram(train, self.dimension, g)?,
            None => pca::fit(train, self.dimension)?,
        };
        let look = SecondLook::fit(train, &grid, Interpolant::Spline)?;
        self.model(train.manifest(), train.spec(), &grid, &pca, Some(look))
    }

    /// The training grid of `manifest`'s poses, with the dense manifold's size checked where it
    /// is resampled.
    fn grid(&self, manifest: &crate::Manifest) -> Result<Grid> {
        let space = manifest.space();
        let grid = Grid::new(space, manifest.poses(), manifest.images(), manifest.root())?;
        for (p, a) in space.params().iter().zip(&grid.axes) {
            crate::manifold::spline::check_knots("training values", a.len())
                .map_err(|e| Error::Dataset { path: manifest.root().to_path_buf(), message: format!("pose parameter '{}': {e}", p.name) })?;
        }
        if crate::manifold::dense_lattice(space.len()) {
            let counts: Vec<f64> = space.params().iter().zip(&grid.axes).map(|(p, g)| crate::manifold::grid::sample_count(g, p.period, self.manifold_step)).collect();
            crate::manifold::grid::check_size(&counts, 1, self.manifold_step)?;
        }
        Ok(grid)
    }

    /// The model of the eigenspace `pca` of `manifest`'s images (of `spec`) on their `grid`,
    /// with the second look `look` (None for a fit streamed from disk, see `stream.rs`).
    fn model(&self, manifest: &crate::Manifest, spec: crate::image_io::ImageSpec, grid: &Grid, pca: &pca::Pca, look: Option<SecondLook>) -> Result<EigenspaceModel> {
        let space = manifest.space();
        let continuous = !crate::manifold::dense_lattice(space.len());
        let l = pca.dim();
        let to32 = |v: &[f64]| v.iter().map(|&x| x as f32).collect::<Vec<f32>>();
        // The dense manifold's points and sample positions, or the knots and their positions.
        let (points, axes) = if continuous {
            (grid.sample_at.iter().flat_map(|&i| to32(&pca.coords[i * l..(i + 1) * l])).collect(), grid.axes.clone())
        } else {
            let dense = Manifold::build(space, grid, &pca.coords, l, self.manifold_step)?;
            (to32(&dense.points), dense.axes)
        };
        let settings = EigenspaceSettings {
            params: *self,
            components: l,
            energy_kept: pca.energy_kept(),
            manifold_shape: axes.iter().map(Vec::len).collect(),
            continuous,
            search: self.search,
            second_look: look.as_ref().map(|k| k.settings().clone()),
        };
        let meta = ModelMeta {
            method: METHOD.name.into(),
            spec,
            space: space.clone(),
            train_poses: manifest.poses().to_vec(),
            settings: serde_json::Value::Null,
            normalize: None,
            stage_choice: None,
        };
        EigenspaceModel::new(meta, settings, to32(&pca.basis), to32(&pca.mean), points, axes, look)
    }
}

/// A fitted parametric eigenspace: L eigenimages, the mean image and the dense manifold, in f32.
#[derive(Debug, Clone)]
pub struct EigenspaceModel {
    meta: ModelMeta,
    settings: EigenspaceSettings,
    /// The basis (L x M, row-major; 64-byte aligned, so the 8-bit products read it in place),
    /// with its 16-bit fixed-point form for 8-bit queries where [`dot_q::fast`] (derived, not
    /// stored in the file).
    proj: Projector,
    /// M.
    mean: Vec<f32>,
    /// u_l . mean, subtracted from each projection (summed in f64 from the f32 values, so a model
    /// read back from a file computes the same numbers).
    mean_proj: Vec<f32>,
    /// N_dense x L, row-major (the knots, N x L, when continuous).
    points: Vec<f32>,
    /// Sample positions per pose parameter (the knots' when continuous).
    axes: Vec<Vec<f64>>,
    search: Search,
    /// The second look (`second_look`).
    look: Option<SecondLook>,
}

/// How a query's manifold point is found: the nearest point of the dense lattice, or the
/// continuous search on the knots.
#[derive(Debug, Clone)]
enum Search {
    Lattice(NearestIndex),
    Knots(Box<KnotSearch>),
}

impl EigenspaceModel {
    fn new(mut meta: ModelMeta, mut settings: EigenspaceSettings, basis: Vec<f32>, mean: Vec<f32>, points: Vec<f32>, axes: Vec<Vec<f64>>, look: Option<SecondLook>) -> Result<Self> {
        let (l, m) = (settings.components, mean.len());
        let search = if settings.continuous {
            if settings.params.search == SearchKind::KdTree && l > search::MAX_TREE_DIM {
                // The dense lattice's refusal (NearestIndex::new), for the same request.
                NearestIndex::new(&points, l, SearchKind::KdTree)?;
            }
            let k = KnotSearch::new(&meta.space, &axes, &points, l, settings.params.step(), settings.params.search != SearchKind::Brute)?;
            settings.search = if k.has_tree() { SearchKind::KdTree } else { SearchKind::Brute };
            Search::Knots(Box::new(k))
        } else {
            let index = NearestIndex::new(&points, l, settings.params.search)?;
            settings.search = index.kind();
            Search::Lattice(index)
        };
        meta.settings = serde_json::to_value(&settings).expect("plain struct serialises");
        let rows = 0..basis.len() / m;
        let proj = Projector::new(&basis, m).with_u8(rows.clone());
        let mean_proj = proj.dots_f64(&rows, &mean);
        Ok(EigenspaceModel { meta, settings, proj, mean, mean_proj, points, axes, search, look })
    }

    /// The settings as given and as resolved.
    pub fn settings(&self) -> &EigenspaceSettings {
        &self.settings
    }

    /// Number of eigenimages L.
    pub fn components(&self) -> usize {
        self.settings.components
    }

    /// The eigenimages, one row of M values each (L x M).
    pub fn basis(&self) -> &[f32] {
        self.proj.rows()
    }

    /// The basis's rows in [`Self::proj`]: all of them.
    fn eigen(&self) -> std::ops::Range<usize> {
        0..self.components()
    }

    /// The mean unit-energy training image.
    pub fn mean(&self) -> &[f32] {
        &self.mean
    }

    /// The dense manifold's points (N_dense x L, row-major over the pose grid, last parameter
    /// fastest); the knots when the manifold is kept as its knots
    /// ([`EigenspaceSettings::continuous`]).
    pub fn manifold_points(&self) -> &[f32] {
        &self.points
    }

    /// Number of manifold points N_dense (of knots, when continuous).
    pub fn manifold_len(&self) -> usize {
        self.points.len() / self.components()
    }

    /// The pose of manifold point `k` (circular values in [0, period)).
    pub fn manifold_pose(&self, k: usize) -> Vec<f64> {
        let mut p = vec![0.0; self.meta.space.len()];
        pose_of(&self.axes, &self.meta.space, k, &mut p);
        p
    }

    /// Eigenspace coordinates of `queries` (rows of M features) into `out` (rows of L): each
    /// query scaled to unit energy, the mean subtracted, projected on the basis, in f32. A query
    /// of zero or non-finite energy gives NaN coordinates.
    pub fn project_into(&self, queries: &[f32], out: &mut [f32]) -> Result<()> {
        let (l, m) = (self.components(), self.mean.len());
        let n = batch_len(m, queries.len(), out.len(), l)?;
        let rows = chunk_rows(n);
        queries.par_chunks(rows * m).zip(out.par_chunks_mut(rows * l)).for_each(|(q, y)| self.project_chunk(q, y));
        Ok(())
    }

    /// As [`EigenspaceModel::project_into`] for 8-bit images given as raw pixel values: with
    /// AVX-512 VNNI the L products are summed exactly in integers against the basis in 16-bit
    /// fixed point (each weight within half a step of 1 / 32,639 of
    /// its row's largest), elsewhere in f32 lanes (the integer
    /// sums without VNNI measured 3.5x slower on AVX2); the two agree within that quantisation.
    /// The energy is summed exactly (the 1 / 255 of the features cancels in the unit-energy
    /// scaling).
    pub fn project_u8_into(&self, queries: &[u8], out: &mut [f32]) -> Result<()> {
        let (l, m) = (self.components(), self.mean.len());
        let n = batch_len(m, queries.len(), out.len(), l)?;
        let level = Level::detect();
        if n >= BATCH_FROM {
            let (rows, parallel) = u8_tasks(n, m, self.proj.u8_block(level, &self.eigen()));
            let task = |scratch: &mut dot_q::Scratch, (q, y): (&[u8], &mut [f32])| self.project_u8_batch(level, q, y, scratch);
            split::for_each_task(queries, rows * m, out, rows * l, parallel, dot_q::Scratch::default, task);
        } else {
            queries.chunks_exact(m).zip(out.chunks_exact_mut(l)).for_each(|(x, y)| self.project_one_u8(level, x, y));
        }
        Ok(())
    }

    /// At most [`U8_BATCH`] 8-bit queries: the products by the batch kernel
    /// ([`Projector::u8_batch`], the same bits as its kernel one image at a time), then each row
    /// scaled as in `project_one_u8`.
    fn project_u8_batch(&self, level: Level, queries: &[u8], out: &mut [f32], scratch: &mut dot_q::Scratch) {
        let m = self.mean.len();
        let mut energy = [0u64; U8_BATCH];
        let energy = &mut energy[..queries.len() / m];
        self.proj.u8_batch(level, &self.eigen(), queries, out, energy, scratch);
        for (y, &ss) in out.chunks_exact_mut(self.components()).zip(energy.iter()) {
            self.scale(ss, y);
        }
    }

    #[inline]
    fn project_one_u8(&self, level: Level, x: &[u8], y: &mut [f32]) {
        self.proj.u8_one(level, &self.eigen(), x, y);
        self.scale_u8(x, y);
    }

    /// Raw products `y` of an 8-bit query to unit-energy, mean-subtracted coordinates (NaN for
    /// an all-black image).
    #[inline]
    fn scale_u8(&self, x: &[u8], y: &mut [f32]) {
        self.scale(dot_u8::sum_squares(x), y)
    }

    /// As `scale_u8`, given the query's sum of squared pixel values.
    #[inline]
    fn scale(&self, ss: u64, y: &mut [f32]) {
        if unit_coords(ss as f64, &self.mean_proj, y).is_none() {
            y.fill(f32::NAN);
        }
    }

    /// Projects a few queries: Y = Q U^T as one sequential f32 product (rayon splits the batch
    /// into such chunks, see [`chunk_rows`]), then
    /// each row scaled by 1 / ||x|| and shifted by u_l . mean.
    fn project_chunk(&self, queries: &[f32], out: &mut [f32]) {
        let (l, m) = (self.components(), self.mean.len());
        self.proj.f32_products(&self.eigen(), queries, out);
        for (x, y) in queries.chunks_exact(m).zip(out.chunks_exact_mut(l)) {
            if unit_coords(crate::linalg::energy(x), &self.mean_proj, y).is_none() {
                y.fill(f32::NAN);
            }
        }
    }

    /// One 8-bit query with more than 64 coordinates (heap scratch).
    fn predict_one_u8_dyn(&self, level: Level, x: &[u8], o: &mut [f64]) {
        let mut y = vec![0f32; self.components()];
        self.project_one_u8(level, x, &mut y);
        if y[0].is_nan() {
            o.fill(f64::NAN);
        } else {
            self.pose_of_coords(&y, o);
        }
    }

    /// The pose of a query's coordinates `y` into `o`: the nearest manifold point's, or the
    /// continuous search's on the knots.
    #[inline]
    fn pose_of_coords(&self, y: &[f32], o: &mut [f64]) {
        match &self.search {
            Search::Lattice(index) => pose_of(&self.axes, &self.meta.space, index.nearest(y), o),
            Search::Knots(k) => k.pose_of(&self.meta.space, y, o),
        }
    }

    pub(crate) fn from_parts(meta: ModelMeta, t: &TensorSet) -> Result<Self> {
        let settings: EigenspaceSettings = serde_json::from_value(meta.settings.clone()).map_err(|e| t.error(format!("damaged eigenspace settings: {e}")))?;
        settings.params.validate().map_err(|e| t.error(format!("damaged eigenspace settings: {e}")))?;
        let (l, m, d) = (settings.components, meta.spec.features(), meta.space.len());
        // A model streamed from disk has no second look (`stream.rs`).
        let look = settings.second_look.clone().map(|s| SecondLook::from_parts(s, meta.spec, &meta.space, t)).transpose()?;
        if l == 0 || settings.manifold_shape.len() != d || settings.manifold_shape.contains(&0) {
            return Err(t.error(format!("damaged eigenspace settings: {l} components, manifold shape {:?}", settings.manifold_shape)));
        }
        if settings.continuous == crate::manifold::dense_lattice(d) {
            return Err(t.error(format!("damaged eigenspace settings: a manifold of {d} pose parameters {} as its knots", if settings.continuous { "kept" } else { "not kept" })));
        }
        let counts: Vec<f64> = settings.manifold_shape.iter().map(|&c| c as f64).collect();
        crate::manifold::grid::check_size(&counts, l, settings.params.step()).map_err(|e| t.error(format!("damaged eigenspace settings: {e}")))?;
        let n_dense: usize = settings.manifold_shape.iter().product();
        let basis = t.f32("basis", &[l, m])?;
        let mean = t.f32("mean", &[m])?;
        let mut shape = settings.manifold_shape.clone();
        shape.push(l);
        let (points_name, axis_name) = if settings.continuous { ("knots", "knot_axis") } else { ("manifold", "manifold_axis") };
        let points = t.f32(points_name, &shape)?;
        let mut axes = Vec::with_capacity(d);
        for (j, p) in meta.space.params().iter().enumerate() {
            let a = t.f64(&format!("{axis_name}_{j}"), &[settings.manifold_shape[j]])?;
            let span_ok = !settings.continuous || p.period.is_none_or(|per| a[a.len() - 1] - a[0] < per);
            if a.iter().any(|v| !v.is_finite()) || a.windows(2).any(|w| w[1] <= w[0]) || !span_ok {
                return Err(t.error(format!("manifold positions of '{}' are not finite and increasing", p.name)));
            }
            axes.push(a);
        }
        if basis.iter().chain(&mean).chain(&points).any(|v| !v.is_finite()) {
            return Err(t.error("the eigenspace holds non-finite values"));
        }
        debug_assert_eq!(points.len(), n_dense * l);
        EigenspaceModel::new(meta, settings, basis, mean, points, axes, look).map_err(|e| t.error(e.to_string()))
    }
}

impl PoseModel for EigenspaceModel {
    fn method(&self) -> &'static Method {
        &METHOD
    }

    fn meta(&self) -> &ModelMeta {
        &self.meta
    }

    fn predict_into(&self, queries: &[f32], out: &mut [f64]) -> Result<()> {
        self.predict_own(queries, out)?;
        self.look_again(Queries::F32(queries), out, None);
        Ok(())
    }

    fn estimate(&self, queries: &[f32], top: usize) -> Result<Vec<crate::Estimate>> {
        crate::model::check_queries(self.mean.len(), queries.len(), "query batch")?;
        let mut out = vec![0.0; queries.len() / self.mean.len() * self.meta.space.len()];
        self.predict_own(queries, &mut out)?;
        if self.look.is_none() {
            // Without the second look (a fit streamed from disk) nothing scores the estimate:
            // its confidence is unknown (NaN, so flagged at any threshold).
            return Ok(out.chunks_exact(self.meta.space.len()).map(|o| crate::Estimate::single(o.to_vec(), f64::NAN)).collect());
        }
        let est = self.look_again(Queries::F32(queries), &mut out, Some(top));
        crate::second_look::complete(est, out.len() / self.meta.space.len().max(1))
    }

    /// 8-bit queries: [`EigenspaceModel::project_u8_into`]'s projection, then the search.
    fn predict_u8_into(&self, queries: &[u8], out: &mut [f64]) -> Result<()> {
        self.predict_own_u8(queries, out)?;
        self.look_again(Queries::U8(queries), out, None);
        Ok(())
    }

    /// Every stored number: (manifold points + basis + mean) x 4 bytes, the second look's
    /// numbers x 4 bytes, plus the manifold's sample positions (8 bytes each), which turn a
    /// point's index into its pose; for a manifold kept as its knots, also what is derived from
    /// them when loaded (the surface's values and slopes, the starts' index).
    fn model_bytes(&self) -> usize {
        let derived = match &self.search {
            Search::Lattice(_) => 0,
            Search::Knots(k) => k.bytes(),
        };
        (self.points.len() + self.basis().len() + self.mean.len() + self.look.as_ref().map_or(0, SecondLook::len)) * 4 + self.axes.iter().map(Vec::len).sum::<usize>() * 8 + derived
    }

    fn storage(&self) -> Storage {
        let (n, l, m) = (self.manifold_len(), self.components(), self.meta.spec.features());
        let (k, b) = self.look.as_ref().map_or((0, 1), |s| (s.settings().components, s.settings().bin));
        let n_train = self.meta.train_poses.len() / self.meta.space.len().max(1);
        Storage::new(&[("N", n), ("L", l), ("M", m), ("K", k), ("b", b), ("N_t", n_train)], n * l + m * l + crate::second_look::numbers(n_train, k, m, b))
    }

    fn tensors(&self) -> Vec<Tensor> {
        let (l, m) = (self.components(), self.mean.len());
        let mut shape = self.settings.manifold_shape.clone();
        shape.push(l);
        let (points_name, axis_name) = if self.settings.continuous { ("knots", "knot_axis") } else { ("manifold", "manifold_axis") };
        let mut v = vec![
            Tensor::f32("basis", vec![l, m], self.basis().to_vec()),
            Tensor::f32("mean", vec![m], self.mean.clone()),
            Tensor::f32(points_name, shape, self.points.clone()),
        ];
        for (j, a) in self.axes.iter().enumerate() {
            v.push(Tensor::f64(&format!("{axis_name}_{j}"), vec![a.len()], a.clone()));
        }
        v.extend(self.look.iter().flat_map(SecondLook::tensors));
        v
    }
}

impl EigenspaceModel {
    /// The second look over a batch whose own estimates are `out` (see `second_look`).
    fn look_again(&self, queries: Queries<'_>, out: &mut [f64], top: Option<usize>) -> Vec<crate::Estimate> {
        match &self.look {
            Some(look) => look.apply(queries, self.mean.len(), out, top, |q, start, o| self.refine_in_basin(q, start, o)),
            None => Vec::new(),
        }
    }

    /// The nearest manifold point to query `x` within the basin of `start`: from the manifold
    /// point nearest `start` in pose, to the closest of its neighbours one point along an axis
    /// while one is closer (on the knots, Levenberg-Marquardt from `start`); its pose into `out`.
    fn refine_in_basin(&self, x: &[f32], start: &[f64], out: &mut [f64]) {
        let l = self.components();
        let mut y = vec![0f32; l];
        self.project_chunk(x, &mut y);
        if y[0].is_nan() {
            return;
        }
        if let Search::Knots(k) = &self.search {
            return k.pose_from(&self.meta.space, &y, start, out);
        }
        let shape: Vec<(usize, bool)> = self.axes.iter().zip(self.meta.space.params()).map(|(a, p)| (a.len(), p.period.is_some())).collect();
        let stride = crate::confidence::row_major_strides(&shape);
        let mut k = 0;
        for (((a, p), &st), &v) in self.axes.iter().zip(self.meta.space.params()).zip(&stride).zip(start) {
            let gap = |x: f64| p.period.map_or((x - v).abs(), |per| { let e = crate::pose::wrap_positive(x - v, per); e.min(per - e) });
            let i = (0..a.len()).min_by(|&i, &j| gap(a[i]).total_cmp(&gap(a[j]))).unwrap_or(0);
            k += i * st;
        }
        let point = |k: usize| self.points[k * l..(k + 1) * l].iter().zip(&y).map(|(&a, &b)| (a - b) as f64 * (a - b) as f64).sum::<f64>();
        let mut dk = point(k);
        loop {
            let mut best = (k, dk);
            for k2 in crate::confidence::grid_neighbours(&shape, &stride, k) {
                let d2 = point(k2);
                if d2 < best.1 {
                    best = (k2, d2);
                }
            }
            if best.0 == k {
                break;
            }
            (k, dk) = best;
        }
        pose_of(&self.axes, &self.meta.space, k, out);
    }

    /// The method's own estimates (the nearest manifold point), before the second look.
    fn predict_own(&self, queries: &[f32], out: &mut [f64]) -> Result<()> {
        let (l, m, p) = (self.components(), self.mean.len(), self.meta.space.len());
        let n = batch_len(m, queries.len(), out.len(), p)?;
        // Project and search chunk by chunk, in parallel; a query that cannot be normalised
        // leaves NaN poses, found afterwards so the error names the first such query.
        let rows = chunk_rows(n);
        queries.par_chunks(rows * m).zip(out.par_chunks_mut(rows * p)).for_each(|(q, o)| {
            let mut y = vec![0f32; q.len() / m * l];
            self.project_chunk(q, &mut y);
            for (c, o) in y.chunks_exact(l).zip(o.chunks_exact_mut(p)) {
                if c[0].is_nan() {
                    o.fill(f64::NAN);
                } else {
                    self.pose_of_coords(c, o);
                }
            }
        });
        if let Some(i) = out.chunks_exact(p).position(|o| o[0].is_nan()) {
            return Err(crate::model::unscalable_query(i));
        }
        Ok(())
    }

    /// 8-bit queries: the method's own estimates, before the second look.
    fn predict_own_u8(&self, queries: &[u8], out: &mut [f64]) -> Result<()> {
        let (l, m, p) = (self.components(), self.mean.len(), self.meta.space.len());
        let n = batch_len(m, queries.len(), out.len(), p)?;
        let level = Level::detect();
        let search = |y: &[f32], o: &mut [f64]| {
            if y[0].is_nan() {
                o.fill(f64::NAN);
            } else {
                self.pose_of_coords(y, o);
            }
        };
        if n >= BATCH_FROM {
            let (rows, parallel) = u8_tasks(n, m, self.proj.u8_block(level, &self.eigen()));
            let init = || (dot_q::Scratch::default(), vec![0f32; rows * l]);
            let task = |(scratch, y): &mut (dot_q::Scratch, Vec<f32>), (q, o): (&[u8], &mut [f64])| {
                let y = &mut y[..q.len() / m * l];
                self.project_u8_batch(level, q, y, scratch);
                y.chunks_exact(l).zip(o.chunks_exact_mut(p)).for_each(|(y, o)| search(y, o));
            };
            split::for_each_task(queries, rows * m, out, rows * p, parallel, init, task);
        } else {
            queries.chunks_exact(m).zip(out.chunks_exact_mut(p)).for_each(|(x, o)| {
                let mut y = [0f32; 64];
                let y = if l <= 64 { &mut y[..l] } else { return self.predict_one_u8_dyn(level, x, o) };
                self.project_one_u8(level, x, y);
                search(y, o)
            });
        }
        if let Some(i) = out.chunks_exact(p).position(|o| o[0].is_nan()) {
            return Err(Error::invalid("query", format!("row {i} of the batch"), "the image is all black (zero energy), so it cannot be scaled to unit energy"));
        }
        Ok(())
    }

}

#[cfg(test)]
pub(crate) mod tests;
