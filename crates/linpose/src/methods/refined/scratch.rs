//! Per-thread and per-task buffers of a query batch, so that queries allocate nothing once warm.

use crate::kernels::{dot_q, dot_w};
use crate::pixel_noise::{RowsF32, RowsU8};

/// A clean query's search buffers (one per thread): the weights, in f64 and f32, the coarse
/// points' distances and the local search's scratch.
#[derive(Default)]
pub(crate) struct SearchScratch {
    pub(crate) wt: Vec<f64>,
    pub(crate) w32: Vec<f32>,
    pub(crate) dist: Vec<f32>,
    pub(crate) buf: Vec<f64>,
    pub(crate) lb: Vec<f32>,
    /// The noisy tree's points near a query ([`NoisyTree::starts`](super::noisy::NoisyTree::starts)).
    pub(crate) near: Vec<(f32, u32)>,
}

thread_local! {
    pub(crate) static SEARCH_SCRATCH: std::cell::RefCell<SearchScratch> = std::cell::RefCell::new(SearchScratch::default());
}

/// A query task's buffers: coordinates (rows of L), residuals and noise, the products (rows of
/// 1 + L: the mean's, then the eigenimages', see [`RefinedModel::finish_query`](super::RefinedModel::finish_query)), the 8-bit
/// queries' energies and the 8-bit products' buffers.
#[derive(Default)]
pub(crate) struct QueryScratch {
    pub(crate) y: Vec<f32>,
    pub(crate) resid: Vec<f64>,
    pub(crate) noise: Vec<f64>,
    pub(crate) raw: Vec<f32>,
    /// Whether each query goes to the noisy match, its pixel noise, and the buffers of a pass
    /// over some of a sub-chunk's queries: which (two lists), a copy of their images, their
    /// products and sums of squares.
    pub(crate) noisy: Vec<bool>,
    pub(crate) pv: Vec<f64>,
    pub(crate) xidx: Vec<usize>,
    pub(crate) xidx2: Vec<usize>,
    pub(crate) gather_f32: Vec<f32>,
    pub(crate) gather_u8: Vec<u8>,
    pub(crate) xout: Vec<f32>,
    pub(crate) xenergy: Vec<u64>,
    pub(crate) energy: Vec<u64>,
    pub(crate) products: dot_q::Scratch,
    pub(crate) rows_u8: Option<RowsU8>,
    pub(crate) rows_f32: Option<RowsF32>,
    /// Binned f32 queries and the binning's scratch, when the model bins; each query's energy
    /// (of the image projected), and when it bins, its route's value and pixel noise measured
    /// on the image as given, and that estimate's row buffers.
    pub(crate) binned: Vec<f32>,
    pub(crate) bin_acc: Vec<f32>,
    pub(crate) benergy: Vec<f64>,
    pub(crate) route: Vec<f64>,
    pub(crate) pv_full: Vec<f64>,
    pub(crate) rows_f32_full: Option<RowsF32>,
    pub(crate) rows_u8_full: Option<RowsU8>,
}

/// A thread's buffers for binned 8-bit queries ([`RefinedModel::project_u8_binned`](super::RefinedModel::project_u8_binned)): for the
/// 8-bit products, a task's block sums, their digit planes, the planes' products and sums of
/// squares; for the 16-bit ones, a sub-chunk's sums in lines and the kernel's step list; the
/// binning's scratch. Per thread, not per task, so that the buffers are not allocated for
/// every task.
#[derive(Default)]
pub(crate) struct BinScratch {
    pub(crate) planes: Vec<u8>,
    pub(crate) sums: Vec<u16>,
    pub(crate) acc: Vec<u16>,
    pub(crate) raw: Vec<f32>,
    pub(crate) energy: Vec<u64>,
    pub(crate) lines: Vec<dot_w::Line>,
    pub(crate) lines_x: Vec<dot_w::Line>,
    pub(crate) idx: Vec<u32>,
}

thread_local! {
    pub(crate) static BIN_SCRATCH: std::cell::RefCell<BinScratch> = std::cell::RefCell::new(BinScratch::default());
}

impl QueryScratch {
    /// Room for `n` queries of `l` coordinates (the products: 1 + l a query; the routes already
    /// in `noisy` are kept).
    pub(crate) fn resize(&mut self, n: usize, l: usize) {
        self.y.resize(n * l, 0.0);
        self.resid.resize(n, 0.0);
        self.noise.resize(n, 0.0);
        self.raw.resize(n * (1 + l), 0.0);
        self.noisy.resize(n, false);
        self.pv.resize(n, 0.0);
        self.energy.resize(n, 0);
        self.benergy.resize(n, 0.0);
    }
}
