//! Planning a training run's memory before it allocates any: what each way of fitting (each
//! *path*) needs, from the sizes alone, against what the machine has, and which path to take.
//!
//! Why: a training set too large for memory otherwise runs until the kernel's OOM killer ends
//! it (100,800 images of 160 x 120 with the linear model: the N x N Gram matrix alone is 76 GiB),
//! with no message and no model, although the streamed path would have fitted it in under
//! 2 GiB. [`plan`] decides before any pixel is read (the first image's header gives its size):
//! the in-memory path when it fits (but for the linear model with more images than features the
//! streamed least-squares path whenever it can take the job: less memory and time, the same model with a
//! ridge, the only fit with ridge 0), else the streamed one when the method and its settings
//! stream and it fits, else an [`Error::NotEnoughMemory`] naming the numbers and what would help
//! ([`Remedy`]). [`Plan::describe`] says which and why in one line.
//!
//! # The paths
//!
//! - [`Path::InMemory`]: every image decoded into one f32 array (N x M), then the method's fit.
//! - [`Path::Streamed`]: the method's streamed fit ([`Method::fit_streamed`], a method that has
//!   one), with settings it streams with: one object, no normalisation, and none of the
//!   method's settings that need the set in memory (the linear model's streamed fit takes a
//!   fixed ridge, uncentred: for N <= M it loads the set and fits through the N x N Gram matrix,
//!   for N > M it accumulates X^T X, M x M, block by block, whatever N; the eigenspace's, for
//!   N > M, the M x M covariance in one pass and the N L coordinates in a second, without the
//!   second look). Only the linear model takes it where the in-memory path fits too
//!   (`Footprint::stream_first`, `crate::model::footprint`).
//!
//! # The estimates (bytes; N images, M features)
//!
//! Read from what the code allocates, the coefficients that the code alone does not settle
//! measured (each module's tuning file says which, and how). Every estimate adds
//! `tuning::OVERHEAD_BYTES` for the process, `tuning::IMAGE_ENTRY_BYTES` per image (the
//! manifest) and `tuning::THREAD_FEATURE_BYTES` per thread and feature, and every N x N system one more N x N matrix when that is under glibc's largest
//! mmap threshold (`crate::huge::HEAP_MATRIX_BYTES`: freed, it may stay on the heap).
//!
//! - Images: 4 N M (f32), twice with normalisation (the normalised copy), three times when the
//!   normalisation is chosen on held-out views (each fold's views, normalised).
//! - The method's fit beside them, in memory and streamed: what the method says of its fit, from
//!   N, M, the encoded pose values, the settings and the pose lattice it resamples or searches
//!   (with more than two pose parameters, kept as its knots: 2^D points per training view;
//!   `crate::model::footprint`; each method's `footprint.rs` gives its formulas: the linear
//!   model's 24 N^2 + 2 KiB N in memory, and streamed with N > M about 4 M^2, so 100,800 images
//!   of 160 x 120 need 1.8 GiB streamed against 234.5 GiB in memory).
//! - Many objects (in memory only): the objects' images, a concatenated copy (4 N M), the
//!   recogniser's fit, which the recogniser says itself ([`crate::recognize::Recognizer`]:
//!   the universal eigenspace's PCA, the linear recogniser's system), and, as many at once as
//!   there are threads, the largest object's pose model fit.
//!
//! # Measured
//!
//! Peak resident memory of the release binary (`/usr/bin/time -v`, "Maximum resident set
//! size"; 2 cores, glibc) against the estimate (`train --json`'s `memory.estimate_bytes`), on
//! turntables rendered by `linpose synth --object duck`: `d480` 160 x 120, azimuth every 3
//! degrees, elevation 30 to 60 every 10; `d1440` the same every degree; `t2880`, `t5760`,
//! `t11160` 16 x 12, azimuth every 2, 1, 1 degrees, elevation every 2, 2, 1; `s5760` 64 x 48
//! and `s11160` 80 x 60 likewise; `d19440` 160 x 120, every degree, elevation 30 to 83;
//! `m1010160` 32 x 24, azimuth, elevation 32 to 77 and roll -30 to 30 every degree; `objs`
//! duck, pot and cap at 80 x 60 as `d1440`. The refined method's peak varies between runs of
//! the same fit by up to 20% (its held-out fits run side by side): 322 to 389 MiB on `t2880`.
//!
//! | settings | set | N | M | path | measured MiB | estimate MiB | over |
//! |---|---|---|---|---|---|---|---|
//! | (linear, ridge 0) | d480 | 480 | 19200 | in memory | 50.8 | 57.0 | +12% |
//! | (linear, ridge 0) | d1440 | 1440 | 19200 | in memory | 163.4 | 185.5 | +13% |
//! | --ridge 1e-3 | t2880 | 2880 | 192 | in memory | 203.9 | 209.6 | +3% |
//! | --ridge 1e-3 | t5760 | 5760 | 192 | in memory | 779.5 | 786.9 | +1% |
//! | --ridge 1e-3 | t11160 | 11160 | 192 | in memory | 2883.6 | 2892.6 | +0% |
//! | --ridge auto | d1440 | 1440 | 19200 | in memory | 197.3 | 213.2 | +8% |
//! | --ridge auto | t2880 | 2880 | 192 | in memory | 287.3 | 320.3 | +11% |
//! | --ridge auto | t5760 | 5760 | 192 | in memory | 1054.2 | 1229.8 | +17% |
//! | --noise-level 0.05 | d1440 | 1440 | 19200 | in memory | 518.3 | 525.8 | +1% |
//! | --noise-level 0.05 | t5760 | 5760 | 192 | in memory | 3073.2 | 3084.7 | +0% |
//! | --noise-level auto | d1440 | 1440 | 19200 | in memory | 235.2 | 240.7 | +2% |
//! | --center | d1440 | 1440 | 19200 | in memory | 163.8 | 185.5 | +13% |
//! | --normalize | d1440 | 1440 | 19200 | in memory | 268.9 | 290.9 | +8% |
//! | --stream --ridge 1e-3 | s5760 | 5760 | 3072 | streamed | 100.8 | 110.8 | +10% |
//! | --stream --ridge 1e-3 | s11160 | 11160 | 4800 | streamed | 185.8 | 198.0 | +7% |
//! | --ridge 1e-3 --memory-budget 4G | d19440 | 19440 | 19200 | streamed | 1769.6 | 1810.5 | +2% |
//! | --method eigenspace | d480 | 480 | 19200 | in memory | 125.2 | 134.5 | +7% |
//! | --method eigenspace | d1440 | 1440 | 19200 | in memory | 408.4 | 424.7 | +4% |
//! | --method eigenspace | t2880 | 2880 | 192 | in memory | 70.4 | 73.6 | +5% |
//! | --method eigenspace | t5760 | 5760 | 192 | in memory | 110.0 | 112.2 | +2% |
//! | (linear, ridge 0: streamed) | m1010160 | 1010160 | 768 | streamed | 284 | 307 | +8% |
//! | --method eigenspace (streamed) | m1010160 | 1010160 | 768 | streamed | 2785 | 2990 | +7% |
//! | --method eigenspace --normalize | d1440 | 1440 | 19200 | in memory | 514.2 | 530.1 | +3% |
//! | --method refined | d480 | 480 | 19200 | in memory | 228.9 | 270.3 | +18% |
//! | --method refined | d1440 | 1440 | 19200 | in memory | 545.0 | 677.3 | +24% |
//! | --method refined --bin 1 | d1440 | 1440 | 19200 | in memory | 604.0 | 644.3 | +7% |
//! | --method refined --bin 4 | d1440 | 1440 | 19200 | in memory | 411.9 | 465.5 | +13% |
//! | --method refined | t2880 | 2880 | 192 | in memory | 387.8 | 429.4 | +11% |
//! | (universal recogniser, linear) | objs | 4320 | 4800 | in memory | 1021.0 | 1172.3 | +15% |
//! | --recognizer linear | objs | 4320 | 4800 | in memory | 757.5 | 881.2 | +16% |
//!
//! # Available memory
//!
//! `available`: the smallest of `/proc/meminfo`'s `MemAvailable` and the control groups'
//! limits less their usage; a plan uses `tuning::USABLE_FRACTION` of it. A budget
//! ([`Limit::Budget`], `--memory-budget`) replaces it. Where nothing can be read
//! ([`Limit::Unknown`]), the in-memory path is taken unchecked, as before planning existed.

mod estimate;
mod remedy;
mod system;
pub(crate) mod tuning;

pub use crate::error::format_bytes;
pub use crate::error::{Remedy, StreamChange};
pub use estimate::Estimate;
pub(crate) use system::available;
pub use system::{parse_size, Available};

use crate::image_io::ImageSpec;
use crate::manifest::Manifest;
use crate::manifold::grid as manifold;
use crate::model::footprint::{Footprint, Sizes, StreamBlock};
use crate::model::{Method, Settings};
use crate::recognize::RecognizerParams;
use crate::{Error, Result};
use std::sync::Arc;
use tuning::USABLE_FRACTION;

/// A way of fitting a training set.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Path {
    /// Every image decoded into memory, then the method's fit.
    InMemory,
    /// The images read from disk in blocks ([`crate::Method::fit_streamed`]).
    Streamed,
}

impl Path {
    /// "in memory" or "streamed".
    pub fn name(self) -> &'static str {
        match self {
            Path::InMemory => "in memory",
            Path::Streamed => "streamed",
        }
    }
}

/// Many objects: how many, the largest one's training images, the recogniser.
#[derive(Debug, Clone, Copy)]
struct Objects {
    count: usize,
    largest: usize,
    recognizer: RecognizerParams,
}

/// What is to be trained, as far as memory goes: the sizes, the method and its settings.
#[derive(Debug, Clone)]
pub struct Job {
    n: usize,
    m: usize,
    k: usize,
    /// Pose parameters D.
    params: usize,
    channels: usize,
    method: &'static Method,
    /// The method's fit with its settings, as far as memory goes.
    fit: Arc<dyn Footprint>,
    normalize: bool,
    choose_stage: bool,
    /// Points of the pose lattice the method resamples or searches (0 for a method without one).
    lattice: usize,
    objects: Option<Objects>,
    threads: usize,
}

impl Job {
    /// `n` training images of `m` features (one value per pixel; see [`Job::channels`]) and `k`
    /// encoded pose values, fitted by `method` with `settings` (refused as the method refuses
    /// them). No pose lattice ([`Job::lattice`]), the rayon pool's threads, and the fewest pose
    /// parameters that encode to `k` values (every one circular, two values each;
    /// [`Job::for_manifest`] reads them from the data set).
    pub fn new(n: usize, m: usize, k: usize, method: &'static Method, settings: &Settings) -> Result<Self> {
        Ok(Job {
            n,
            m,
            k,
            params: k.div_ceil(2),
            channels: 1,
            method,
            fit: (method.footprint)(settings)?,
            normalize: false,
            choose_stage: false,
            lattice: 0,
            objects: None,
            threads: rayon::current_num_threads(),
        })
    }

    /// The images of `manifest`, of size `spec` ([`Manifest::first_image_spec`]): N, M, K and,
    /// from its poses, the pose lattice the method resamples or reports on, if it has one.
    pub fn for_manifest(manifest: &Manifest, spec: ImageSpec, method: &'static Method, settings: &Settings) -> Result<Self> {
        let mut job = Job::new(manifest.len(), spec.features(), manifest.space().encoded_len(), method, settings)?.channels(spec.color.channels());
        job.params = manifest.space().len();
        let step = job.fit.lattice_step();
        Ok(job.lattice(step.map_or(0, |s| lattice_points(manifest, s))))
    }

    /// A data set of many objects, one manifest each, fitted in memory: `method` for each
    /// object's poses, `recognizer` for which object.
    pub fn for_objects(manifests: &[Manifest], spec: ImageSpec, method: &'static Method, settings: &Settings, recognizer: &RecognizerParams) -> Result<Self> {
        let first = manifests.first().ok_or_else(|| Error::invalid("objects", 0, "a data set of many objects has at least one"))?;
        let mut job = Job::for_manifest(first, spec, method, settings)?;
        job.n = manifests.iter().map(Manifest::len).sum();
        job.lattice = job.lattice.max(recogniser_points(first, recognizer.manifold_step));
        job.objects = Some(Objects { count: manifests.len(), largest: manifests.iter().map(Manifest::len).max().unwrap_or(0), recognizer: *recognizer });
        Ok(job)
    }

    /// Values per pixel (3 for RGB features), which `noise-level auto` reads a plane of.
    pub fn channels(mut self, channels: usize) -> Self {
        self.channels = channels.max(1);
        self
    }

    /// Whether the images are normalised first ([`crate::normalize`]): in memory only, a copy.
    pub fn normalized(mut self, yes: bool) -> Self {
        self.normalize = yes;
        self
    }

    /// Whether the normalisation is chosen on held-out training views first
    /// ([`crate::MethodSpec::fit_with_stage`]): a normalised copy of each fold's views besides the images'.
    pub fn choosing_stage(mut self, yes: bool) -> Self {
        self.choose_stage = yes;
        self.normalize |= yes;
        self
    }

    /// Points of the pose lattice the method resamples or reports on.
    pub fn lattice(mut self, points: usize) -> Self {
        self.lattice = points;
        self
    }

    /// Threads fitting at once (each decodes an image; many objects' pose models are fitted
    /// this many at a time).
    pub fn threads(mut self, threads: usize) -> Self {
        self.threads = threads.max(1);
        self
    }

    /// Training images N (all objects').
    pub fn n(&self) -> usize {
        self.n
    }

    /// Features per image M.
    pub fn m(&self) -> usize {
        self.m
    }

    /// The sizes the method's fit depends on.
    fn sizes(&self) -> Sizes {
        Sizes { n: self.n, m: self.m, k: self.k, channels: self.channels, lattice: self.lattice, params: self.params }
    }

    /// The same job with `n` images (objects scaled alike).
    fn with_n(&self, n: usize) -> Job {
        let mut j = self.clone();
        if let Some(o) = &mut j.objects {
            o.largest = (o.largest as u128 * n as u128).div_ceil(self.n.max(1) as u128) as usize;
        }
        j.n = n;
        j
    }

    /// Why the streamed path cannot take this job, if it cannot.
    fn stream_blocker(&self) -> Option<Blocker> {
        if !self.method.streams() {
            return Some(Blocker::Method);
        }
        if self.objects.is_some() {
            return Some(Blocker::Objects);
        }
        if self.normalize {
            return Some(Blocker::Normalize);
        }
        self.fit.stream_block().map(Blocker::Setting)
    }

    /// The job as the streamed path could take it, with `blocker` removed (no normalisation, the
    /// method's setting changed); None when nothing the user can change would let it stream.
    fn unblocked(&self, blocker: &Blocker) -> Option<Job> {
        let mut j = self.clone();
        match blocker {
            Blocker::Normalize => j.normalize = false,
            Blocker::Setting(b) => j.fit = b.unblocked.clone(),
            Blocker::Method | Blocker::Objects => return None,
        }
        match j.stream_blocker() {
            None => Some(j),
            Some(b) => j.unblocked(&b),
        }
    }
}

/// Points of the lattice every `step` degrees over the range of each pose parameter of
/// `manifest` (its period when circular), as the eigenspace resamples its manifold; capped at
/// the most points a manifold may have. A manifold of more parameters kept as its knots
/// ([`crate::manifold::dense_lattice`]) counts 2^D points per training view instead: the
/// surface's values and slopes at each knot, which its structures hold in place of a lattice's
/// points.
fn lattice_points(manifest: &Manifest, step: f64) -> usize {
    let space = manifest.space();
    let d = space.len();
    if !crate::manifold::dense_lattice(d) {
        return knot_points(manifest, 1usize << d.min(16));
    }
    let mut points = 1.0;
    for (j, p) in space.params().iter().enumerate() {
        let (lo, hi) = manifest.poses().iter().skip(j).step_by(d.max(1)).fold((f64::INFINITY, f64::NEG_INFINITY), |(a, b), &v| (a.min(v), b.max(v)));
        if lo.is_finite() && step > 0.0 {
            points *= manifold::sample_count(&[lo, hi], p.period, step).max(1.0);
        }
    }
    points.min(manifold::MAX_POINTS as f64) as usize
}

/// Points of each object's manifold in a recogniser: [`lattice_points`] for a lattice, else the
/// [`crate::manifold::tuning::KNOT_RESAMPLE`]^D points per training view it is resampled at
/// (`Manifold::build_for`).
fn recogniser_points(manifest: &Manifest, step: f64) -> usize {
    let d = manifest.space().len();
    if crate::manifold::dense_lattice(d) {
        return lattice_points(manifest, step);
    }
    knot_points(manifest, crate::manifold::tuning::KNOT_RESAMPLE.saturating_pow(d as u32))
}

/// `per` points per training view of `manifest`, capped as [`lattice_points`] is.
fn knot_points(manifest: &Manifest, per: usize) -> usize {
    manifest.len().saturating_mul(per).min(manifold::MAX_POINTS)
}

/// Why the streamed path cannot take a job.
#[derive(Debug)]
enum Blocker {
    /// The method does not stream.
    Method,
    Objects,
    Normalize,
    /// One of the method's settings.
    Setting(StreamBlock),
}

impl Blocker {
    /// In words, after "not streamed: ".
    fn reason(&self, job: &Job) -> String {
        match self {
            Blocker::Method => format!("the {} method fits in memory only", job.method.name),
            Blocker::Objects => "a data set of many objects is fitted in memory".into(),
            Blocker::Normalize => "the normalisation is fitted in memory".into(),
            Blocker::Setting(b) => b.reason.into(),
        }
    }

    /// The error of a streamed fit asked for that cannot be.
    fn error(self, job: &Job) -> Error {
        match self {
            Blocker::Setting(b) => b.error,
            b => Error::invalid("streaming", job.method.name, b.reason(job)),
        }
    }
}

/// The memory a plan is held to.
#[derive(Debug, Clone, Copy, PartialEq)]
pub enum Limit {
    /// A budget in bytes, given by the user: used whole.
    Budget(u64),
    /// What the machine has available: `USABLE_FRACTION` of it is used.
    Available(Available),
    /// Nothing could be read (not Linux): no path is refused.
    Unknown,
}

impl Limit {
    /// The machine's available memory, or [`Limit::Unknown`].
    pub fn detect() -> Limit {
        available().map_or(Limit::Unknown, Limit::Available)
    }

    /// Bytes a plan may use; None when unknown.
    pub fn usable(&self) -> Option<u64> {
        match self {
            Limit::Budget(b) => Some(*b),
            Limit::Available(a) => Some((a.bytes as f64 * USABLE_FRACTION) as u64),
            Limit::Unknown => None,
        }
    }

    /// After "within" or "more than": "the budget of 1.0 GiB", "the 20.6 GiB usable (90% of
    /// the 22.9 GiB available)".
    fn describe(&self) -> String {
        match self {
            Limit::Budget(b) => format!("the budget of {}", format_bytes(*b)),
            Limit::Available(a) => format!(
                "the {} usable ({:.0}% of the {} available{})",
                format_bytes(self.usable().unwrap_or(0)),
                100.0 * USABLE_FRACTION,
                format_bytes(a.bytes),
                if a.cgroup { " under the cgroup's limit" } else { "" }
            ),
            Limit::Unknown => "an unknown amount of memory".into(),
        }
    }
}

/// The path taken, what each path needs, and the memory it was held to.
#[derive(Debug, Clone)]
pub struct Plan {
    /// The path taken.
    pub path: Path,
    /// What the in-memory path needs.
    pub in_memory: Estimate,
    /// What the streamed path needs (None when the method or its settings cannot stream).
    pub streamed: Option<Estimate>,
    /// The memory the plan was held to.
    pub limit: Limit,
    /// Whether the path was asked for rather than chosen.
    pub forced: bool,
}

impl Plan {
    /// The chosen path's estimate.
    pub fn chosen(&self) -> &Estimate {
        match (self.path, &self.streamed) {
            (Path::Streamed, Some(s)) => s,
            _ => &self.in_memory,
        }
    }

    /// One line: which path, what it needs and why it was taken, e.g. `memory: in memory needs
    /// 81.2 GiB (N x N Gram of 100800 images), more than the 20.6 GiB usable (90% of the 22.9
    /// GiB available); streamed needs 1.9 GiB (X^T X of 19200 features): streaming`.
    pub fn describe(&self) -> String {
        let needs = |name: &str, e: &Estimate| format!("{name} needs {} ({})", format_bytes(e.bytes), e.what);
        let limit = self.limit.describe();
        let end = match self.path {
            Path::InMemory => "in memory",
            Path::Streamed => "streaming",
        };
        if let Limit::Unknown = self.limit {
            return format!("memory: {}; the available memory could not be read, so it is not checked: {end}", needs(self.path.name(), self.chosen()));
        }
        let in_memory_fits = self.limit.usable().is_none_or(|u| self.in_memory.bytes <= u);
        match (self.path, self.forced, &self.streamed) {
            (Path::Streamed, false, Some(s)) if in_memory_fits => format!(
                "memory: {}, within {limit}; more images than features, so least squares through X^T X rather than the N x N Gram matrix ({}): {end}",
                needs("streamed", s),
                needs("in memory", &self.in_memory)
            ),
            (Path::Streamed, false, Some(s)) => {
                format!("memory: {}, more than {limit}; {}: {end}", needs("in memory", &self.in_memory), needs("streamed", s))
            }
            (path, true, _) => format!("memory: {} (as asked), within {limit}: {end}", needs(path.name(), self.chosen())),
            (path, false, _) => format!("memory: {}, within {limit}: {end}", needs(path.name(), self.chosen())),
        }
    }
}

/// Plans `job` against `limit`: `force` takes that path (still checked), else the in-memory
/// path when it fits, else the streamed one when it can take the job and fits. Where no path
/// fits, [`Error::NotEnoughMemory`] with what each needs and the [`Remedy`]s; a streamed fit
/// asked for that cannot take the job's settings is the settings' error.
pub fn plan(job: &Job, limit: &Limit, force: Option<Path>) -> Result<Plan> {
    let in_memory = estimate::in_memory(job);
    let blocker = job.stream_blocker();
    let streamed = blocker.is_none().then(|| estimate::streamed(job));
    let usable = limit.usable();
    let fits = |e: &Estimate| usable.is_none_or(|u| e.bytes <= u);
    let path = match force {
        Some(Path::Streamed) => match blocker {
            Some(b) => return Err(b.error(job)),
            None => Path::Streamed,
        },
        Some(Path::InMemory) => Path::InMemory,
        None if !fits(&in_memory) && streamed.as_ref().is_some_and(fits) => Path::Streamed,
        // A method whose streamed fit is the better one where it can take the job (the linear
        // model with more images than features: least squares through X^T X takes less memory
        // and time than the N x N Gram matrix, gives the same model with a ridge, and is the
        // only fit with ridge 0).
        None if job.fit.stream_first(&job.sizes()) && streamed.as_ref().is_some_and(fits) => Path::Streamed,
        None => Path::InMemory,
    };
    let plan = Plan { path, in_memory, streamed, limit: *limit, forced: force.is_some() };
    if fits(plan.chosen()) {
        return Ok(plan);
    }
    Err(remedy::not_enough(job, &plan, blocker))
}

#[cfg(test)]
mod tests;
