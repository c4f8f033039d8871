//! The fitted model: what it holds, how it is built from its stored parts, and how it serves
//! [`PoseModel`].

use super::fit::search_scale;
use super::noisy::{NoiseScan, NoisyTree};
use super::params::RefinedSettings;
use super::search::{box_split, lattice, CoarseTree};
use crate::manifold::surface::Surface;
use super::tuning::{MAX_LATTICE, MAX_ROLL_SPLIT, TREE_STEP};
use super::METHOD;
use crate::binning::Binning;
use crate::kernels::{dot_q, Level};
use crate::manifold::projector::Projector;
use crate::model::{Method, ModelMeta, PoseModel, Storage, Tensor, TensorSet};
use crate::pose::wrap_positive;
use crate::second_look::{Queries, SecondLook};
use crate::Result;

/// A fitted refined eigenspace: L eigenimages, the mean image, the spline surface through the
/// training views' coordinates and the coarse start points, in f32.
#[derive(Debug, Clone)]
pub struct RefinedModel {
    pub(crate) meta: ModelMeta,
    pub(crate) settings: RefinedSettings,
    /// The mean image, then the L eigenimages (rows of M, scaled): one matrix, so that the
    /// rows a query's route takes are one range of it ([`Self::clean_rows`]: the mean's, for
    /// the residual, and the clean search's L_s; [`Self::noisy_rows`]: the noisy match's L;
    /// [`Self::extra_range`]: the L past L_s), each one pass. With their forms for 8-bit
    /// queries (derived, not stored in the file): for a model that bins, where [`dot_q::fast`],
    /// the clean and noisy rows for the 16-bit block sums ([`crate::kernels::dot_w`]); otherwise
    /// the clean and extra rows in 16-bit fixed point for the 8-bit products.
    pub(crate) proj: Projector,
    /// The training views' mean residual energy off the clean search's L_s coordinates (the
    /// stored `residual_energy`, off all L, plus the knots' mean square in coordinates L_s..L):
    /// the level of a clean query's residual that means no noise.
    pub(crate) clean_residual_energy: f64,
    /// M, the pixels of an image (binned).
    pub(crate) m: usize,
    /// The binning of the images the model takes ([`ModelMeta::spec`]) into those it works on.
    pub(crate) binning: Binning,
    pub(crate) mean_proj: Vec<f32>,
    /// ||mean||^2.
    pub(crate) mean_sq: f64,
    /// 1 / w_l: each coordinate's interpolation variance plus the floor (ones when unweighted).
    pub(crate) inv_weight: Vec<f64>,
    knots: Vec<f32>,
    /// The offset direction g at each knot (N x L) and its surface.
    background: Vec<f32>,
    pub(crate) bg_surface: Surface,
    pub(crate) axes: Vec<Vec<f64>>,
    pub(crate) surface: Surface,
    /// Coarse surface points, coordinate-major (L x n: coordinate l of every point, then l + 1),
    /// so the scan over them runs along the points in SIMD lanes; their poses (n x D).
    pub(crate) start_points: Vec<f32>,
    /// The bounding boxes of every [`crate::kernels::scan::BOX`] coarse points in their first
    /// [`box_split`] coordinates, which rule boxes out before their points are scored.
    pub(crate) start_boxes: Vec<f32>,
    /// The offset surface at the start poses (L x n, as `start_points`).
    pub(crate) bg_start: Vec<f32>,
    pub(crate) start_poses: Vec<f64>,
    /// Points along each axis of the coarse grid, and whether the axis is circular.
    pub(crate) start_shape: Vec<(usize, bool)>,
    /// The noisy match's coarse scan.
    pub(crate) noise_scan: NoiseScan,
    /// The exact lattice search of a clean query on a one-parameter manifold (reported on a
    /// lattice): it replaces the coarse scan and the local search there.
    pub(crate) lattice: Option<lattice::Lattice>,
    /// The clean query's search on a manifold of more parameters (reported on a lattice): it
    /// replaces the coarse scan and the local search there.
    pub(crate) tree: Option<CoarseTree>,
    /// The noisy query's search beside `tree` (on its poses): it replaces the noisy match's
    /// coarse scan and local search there.
    pub(crate) noisy_tree: Option<NoisyTree>,
    /// The second look (`second_look`).
    pub(crate) look: Option<SecondLook>,
}

impl RefinedModel {
    pub(crate) fn new(
        mut meta: ModelMeta,
        settings: RefinedSettings,
        basis: Vec<f32>,
        mean: Vec<f32>,
        knots: Vec<f32>,
        background: Vec<f32>,
        axes: Vec<Vec<f64>>,
    ) -> Result<Self> {
        let (l, m) = (settings.components, mean.len());
        let binning = Binning::new(meta.spec, settings.bin)?;
        assert_eq!(binning.spec().features(), m, "a mean image of the binned size");
        meta.settings = serde_json::to_value(&settings).expect("plain struct serialises");
        let k64: Vec<f64> = knots.iter().map(|&v| v as f64).collect();
        let surface = Surface::new(&meta.space, &axes, &k64, l, settings.interpolant)?;
        let d = axes.len();
        // A manifold kept as its knots starts its searches from the surface at
        // KNOT_START_PER_CELL points per knot interval, as the eigenspace's does; a lattice's
        // continuous fallback from per_cell points per knot interval.
        let continuous = !crate::manifold::dense_lattice(d);
        let per_cell = if continuous { crate::manifold::tuning::KNOT_START_PER_CELL } else { settings.params.per_cell };
        // Along a split roll the starts keep their spacing over the training rolls: the turned
        // views refine the surface between them, not where a search may start.
        let mut per_axis = vec![per_cell; d];
        if let (Some(s), Some(r)) = (settings.roll_split, meta.space.in_plane_roll()) {
            per_axis[r] = per_cell.div_ceil(s);
        }
        let start_poses = surface.grid_poses_by(&per_axis);
        let start_shape = surface.grid_shape_by(&per_axis);
        let b64: Vec<f64> = background.iter().map(|&v| v as f64).collect();
        let bg_surface = Surface::new(&meta.space, &axes, &b64, l, settings.interpolant)?;
        let n_start = start_poses.len() / d;
        let mut start_points = vec![0f32; n_start * l];
        let mut bg_start = vec![0f32; n_start * l];
        let mut f = vec![0.0; l];
        for (i, t) in start_poses.chunks_exact(d).enumerate() {
            surface.eval(t, &mut f, None);
            f.iter().enumerate().for_each(|(c, &v)| start_points[c * n_start + i] = v as f32);
            bg_surface.eval(t, &mut f, None);
            f.iter().enumerate().for_each(|(c, &v)| bg_start[c * n_start + i] = v as f32);
        }
        let mean_sq = mean.iter().map(|&v| v as f64 * v as f64).sum();
        let ls = settings.search();
        let sigma2 = (settings.interpolation_variance.len() == ls).then_some(&settings.interpolation_variance[..]);
        let inv_weight = search_scale(sigma2, ls, l).iter().map(|s| 1.0 / (s * s)).collect();
        let step = settings.params.resolution;
        // The lattice search costs in proportion to the lattice (the local search does not):
        // kept for lattices of at most MAX_LATTICE poses.
        let lattice = surface
            .line_parts()
            .filter(|&(at, period, ..)| step > 0.0 && period.unwrap_or(at[at.len() - 1] - at[0]) / step <= MAX_LATTICE as f64)
            .map(|(at, period, values, slopes, dim)| lattice::Lattice::new(at, period, values, slopes, dim, ls, step));
        let tree = if lattice.is_none() && !continuous { CoarseTree::new(&surface, &meta.space, &axes, ls, TREE_STEP * step) } else { None };
        // Only the clean coarse scan reads the boxes; the lattice and the tree replace it.
        let scanned = lattice.is_none() && tree.is_none();
        let start_boxes = if scanned { crate::kernels::scan::boxes(&start_points, n_start, box_split(l)) } else { Vec::new() };
        let n_rows = 1 + basis.len() / m;
        let mut proj = Projector::new(&[mean, basis].concat(), m);
        let mean_proj = proj.dots_f64(&(1..n_rows), &proj.rows()[..m]);
        // The rows of each route (as clean_rows, noisy_rows, extra_range): the mean's only when
        // the residual is used.
        let r = uses_residual(&settings) as usize;
        let (clean, noisy, extra) = (1 - r..1 + ls, 1..1 + l, 1 + ls..n_rows);
        if binning.bins() && dot_q::fast(Level::detect()) {
            proj = proj.with_words(&[clean.clone(), noisy], binning.max_sum());
        }
        if !proj.has_words() {
            proj = proj.with_u8(clean).with_u8(extra);
        }
        // Coordinates L_s.. are unscaled (search_scale), and the knots are the training views
        // (a full grid, one view a point): their mean square is the eigenvalue over N. With a
        // roll's turned views among them (`manifold::roll`), the mean over those too, which turn
        // the training views and so hold about as much there.
        let nk = knots.len() / l.max(1);
        let beyond: f64 = knots.chunks_exact(l.max(1)).map(|k| k[ls..].iter().map(|&v| v as f64 * v as f64).sum::<f64>()).sum::<f64>() / nk.max(1) as f64;
        let clean_residual_energy = settings.residual_energy + beyond;
        Ok(RefinedModel {
            meta,
            settings,
            proj,
            clean_residual_energy,
            m,
            binning,
            mean_proj,
            mean_sq,
            inv_weight,
            knots,
            background,
            bg_surface,
            axes,
            surface,
            start_boxes,
            start_points,
            bg_start,
            start_poses,
            start_shape,
            noise_scan: NoiseScan::default(),
            lattice,
            tree,
            noisy_tree: None,
            look: None,
        })
        .map(|mut m: RefinedModel| {
            // Only a model that detects noisy queries routes any to the noisy match (the
            // automatic choice sets it on its candidates itself, `set_noise_match`).
            if m.settings.noise_threshold > 0.0 {
                let (ln, weighted) = (m.settings.noise_components, m.settings.noise_weighted);
                m.set_noise_match(ln, weighted);
            }
            m
        })
    }

    /// The model with its second look, recorded in its settings.
    pub(crate) fn with_look(mut self, look: SecondLook) -> Result<Self> {
        self.settings.second_look = Some(look.settings().clone());
        self.meta.settings = serde_json::to_value(&self.settings).expect("plain struct serialises");
        self.look = Some(look);
        Ok(self)
    }

    /// The settings as given and as chosen.
    pub fn settings(&self) -> &RefinedSettings {
        &self.settings
    }

    /// Number of eigenimages L.
    pub fn components(&self) -> usize {
        self.settings.components
    }

    /// Number of knots: the training views on the grid, and with a camera roll the turned views
    /// between them ([`RefinedSettings::roll_split`]).
    pub fn knots_len(&self) -> usize {
        self.knots.len() / self.components()
    }

    /// Whether the manifold is kept as its knots and searched continuously from the training
    /// views ([`crate::manifold::dense_lattice`]): more than two pose parameters.
    pub(crate) fn continuous(&self) -> bool {
        !crate::manifold::dense_lattice(self.axes.len())
    }

    /// Number of coarse start points.
    pub fn start_len(&self) -> usize {
        self.start_poses.len() / self.axes.len()
    }

    /// Whether a clean query's search weights depend on its residual (the weighted metric:
    /// 1 / (sigma_l^2 + floor + nu)). The plain metric weighs every coordinate alike, so nu only
    /// scales the distance and its products with the mean are not needed.
    pub(crate) fn uses_residual(&self) -> bool {
        uses_residual(&self.settings)
    }

    /// The noisy match's coordinates past the clean search's L_s: what a query routed to it
    /// takes besides [`Self::clean_rows`] when it is routed after them (a model that does not
    /// bin).
    pub(crate) fn extra_rows(&self) -> usize {
        self.components() - self.settings.search()
    }

    /// The rows of `rows` ([mean, eigenimages]) a query the clean search serves takes: the
    /// mean's when used, then the first L_s eigenimages.
    pub(crate) fn clean_rows(&self) -> std::ops::Range<usize> {
        1 - self.uses_residual() as usize..1 + self.settings.search()
    }

    /// The rows a query routed to the noisy match before its products takes (a model that
    /// bins): every eigenimage, not the mean.
    pub(crate) fn noisy_rows(&self) -> std::ops::Range<usize> {
        1..1 + self.components()
    }

    /// The rows of [`Self::extra_rows`].
    pub(crate) fn extra_range(&self) -> std::ops::Range<usize> {
        1 + self.settings.search()..1 + self.components()
    }

    /// The pose `t` into `out`, circular values wrapped into [0, period).
    pub(crate) fn write_pose(&self, t: &[f64], out: &mut [f64]) {
        for ((o, &v), p) in out.iter_mut().zip(t).zip(self.meta.space.params()) {
            *o = match p.period {
                Some(per) => wrap_positive(v, per),
                None => v,
            };
        }
    }

    pub(crate) fn from_parts(meta: ModelMeta, t: &TensorSet) -> Result<Self> {
        let bad = |e: String| t.error(format!("damaged refined-eigenspace settings: {e}"));
        let settings: RefinedSettings = serde_json::from_value(meta.settings.clone()).map_err(|e| bad(e.to_string()))?;
        settings.params.validate().map_err(|e| bad(e.to_string()))?;
        let binning = Binning::new(meta.spec, settings.bin).map_err(|e| bad(e.to_string()))?;
        let (l, m, d) = (settings.components, binning.spec().features(), meta.space.len());
        if l == 0 || settings.knot_shape.len() != d || settings.knot_shape.iter().any(|&c| c == 0 || c > 1 << 16) {
            return Err(bad(format!("{l} components, knot shape {:?}", settings.knot_shape)));
        }
        if let Some(s) = settings.roll_split.filter(|&s| !(2..=MAX_ROLL_SPLIT).contains(&s) || meta.space.in_plane_roll().is_none()) {
            return Err(bad(format!("a roll split of {s} (2 to {MAX_ROLL_SPLIT}, with a camera roll beside elevation and azimuth)")));
        }
        if !(1..=l).contains(&settings.search_components) {
            return Err(bad(format!("a clean search on {} of {l} components", settings.search_components)));
        }
        let basis = t.f32("basis", &[l, m])?;
        let mean = t.f32("mean", &[m])?;
        let mut shape = settings.knot_shape.clone();
        shape.push(l);
        let knots = t.f32("knots", &shape)?;
        let background = t.f32("background", &shape)?;
        let mut axes = Vec::with_capacity(d);
        for (j, p) in meta.space.params().iter().enumerate() {
            let a = t.f64(&format!("knot_axis_{j}"), &[settings.knot_shape[j]])?;
            let span_ok = p.period.is_none_or(|per| a[a.len() - 1] - a[0] < per);
            if a.iter().any(|v| !v.is_finite()) || a.windows(2).any(|w| w[1] <= w[0]) || !span_ok {
                return Err(t.error(format!("knot positions of '{}' are not finite, increasing and within one period", p.name)));
            }
            axes.push(a);
        }
        if basis.iter().chain(&mean).chain(&knots).chain(&background).any(|v| !v.is_finite()) {
            return Err(t.error("the refined eigenspace holds non-finite values"));
        }
        let l_ok = settings.noise_components <= l && (settings.coord_variance.is_empty() || settings.coord_variance.len() == l);
        if !l_ok || settings.coord_variance.iter().any(|v| !(v.is_finite() && *v >= 0.0)) {
            return Err(bad(format!("noise match of {} components over {} variances", settings.noise_components, settings.coord_variance.len())));
        }
        let Some(look) = settings.second_look.clone() else {
            return Err(bad("no second look".into()));
        };
        let look = SecondLook::from_parts(look, meta.spec, &meta.space, t)?;
        RefinedModel::new(meta, settings, basis, mean, knots, background, axes).map_err(|e| t.error(e.to_string()))?.with_look(look)
    }
}

/// Whether a model with these settings uses the residual (the mean's products): see
/// [`RefinedModel::uses_residual`].
fn uses_residual(settings: &RefinedSettings) -> bool {
    !settings.interpolation_variance.is_empty()
}

impl PoseModel for RefinedModel {
    fn method(&self) -> &'static Method {
        &METHOD
    }

    fn storage(&self) -> Storage {
        self.table1_storage()
    }

    fn meta(&self) -> &ModelMeta {
        &self.meta
    }

    fn predict_into(&self, queries: &[f32], out: &mut [f64]) -> Result<()> {
        self.predict_with(queries, self.noise_want(), out)?;
        self.look_again(Queries::F32(queries), out, None);
        Ok(())
    }

    fn estimate(&self, queries: &[f32], top: usize) -> Result<Vec<crate::Estimate>> {
        let m = self.meta.spec.features();
        crate::model::check_queries(m, queries.len(), "query batch")?;
        let mut out = vec![0.0; queries.len() / m * self.meta.space.len()];
        self.predict_with(queries, self.noise_want(), &mut out)?;
        let est = self.look_again(Queries::F32(queries), &mut out, Some(top));
        crate::second_look::complete(est, out.len() / self.meta.space.len().max(1))
    }

    /// 8-bit queries: the projection in 16-bit fixed point where AVX-512 VNNI runs it, else in
    /// f32 lanes, then the search; the estimates of
    /// [`PoseModel::predict_into`] on the same images as features but for near ties.
    fn predict_u8_into(&self, queries: &[u8], out: &mut [f64]) -> Result<()> {
        self.predict_u8_with(queries, self.noise_want(), out)?;
        self.look_again(Queries::U8(queries), out, None);
        Ok(())
    }

    /// Everything held to serve queries: basis, mean and their projections, the surface's knot
    /// values and slopes (2^D N L), the coarse start points with their poses, the knot positions,
    /// the lattice search or the coarse tree with its poses.
    fn model_bytes(&self) -> usize {
        (self.proj.rows().len()
            + self.mean_proj.len()
            + self.surface.len()
            + self.bg_surface.len()
            + self.start_points.len()
            + self.start_boxes.len()
            + self.bg_start.len())
            * 4
            + self.noise_scan.len() * 8
            + self.lattice.as_ref().map_or(0, lattice::Lattice::bytes)
            + self.tree.as_ref().map_or(0, |c| c.tree.bytes() + c.poses.len() * 8)
            + self.noisy_tree.as_ref().map_or(0, NoisyTree::bytes)
            + (self.start_poses.len() + self.axes.iter().map(Vec::len).sum::<usize>()) * 8
            + self.look.as_ref().map_or(0, SecondLook::len) * 4
    }

    fn tensors(&self) -> Vec<Tensor> {
        let (l, m) = (self.components(), self.m);
        let mut shape = self.settings.knot_shape.clone();
        shape.push(l);
        let mut v = vec![
            Tensor::f32("basis", vec![l, m], self.proj.rows()[m..].to_vec()),
            Tensor::f32("mean", vec![m], self.proj.rows()[..m].to_vec()),
            Tensor::f32("knots", shape.clone(), self.knots.clone()),
            Tensor::f32("background", shape, self.background.clone()),
        ];
        for (j, a) in self.axes.iter().enumerate() {
            v.push(Tensor::f64(&format!("knot_axis_{j}"), vec![a.len()], a.clone()));
        }
        v.extend(self.look.iter().flat_map(SecondLook::tensors));
        v
    }
}

impl RefinedModel {
    /// The second look over a batch whose own estimates are `out` (see `second_look`).
    fn look_again(&self, queries: Queries<'_>, out: &mut [f64], top: Option<usize>) -> Vec<crate::Estimate> {
        match &self.look {
            Some(look) => look.apply(queries, self.meta.spec.features(), out, top, |q, start, o| self.refine_in_basin(q, start, o)),
            None => Vec::new(),
        }
    }
}
