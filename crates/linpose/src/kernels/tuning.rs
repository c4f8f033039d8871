//! The kernels' tuning constants: cache blocks, parallel splits and the fixed-point precision,
//! one submodule per kernel (their names repeat from kernel to kernel), each constant with what
//! it trades and how its value was set. Each moves the time; those that set the order of a
//! floating-point sum (the f64 Gram's panels and partials, the streamed panels) move the last
//! bits of a fit too, and [`dot_q::DIGITS`] the 8-bit products' quantisation.
//!
//! The timings were taken on the project's 2-core AVX-512 machine on the day of the commit
//! named; the best value may move with the machine. What the hardware or the maths fixes stays
//! beside the kernels: vector lanes, register blocks (as many accumulators as the registers
//! hold), the overflow bounds of the integer sums ([`super::syrk::KCP_MAX`]).

/// [`super::gram`]'s blocking (the f64 Gram matrix X X^T).
pub(crate) mod gram {
    /// Reduction steps per packed panel: a tile's 24 rows (24 KiB) stay in L1 while the columns
    /// stream past; a panel of 224 rows (230 KiB) and the partial Gram it updates (350 KiB) stay
    /// in L2, and for N = 2000 an item's rows (24 KiB) and columns (192 KiB) do. Chosen from the
    /// cache sizes with the tile loop that keeps a tile's rows in L1 (d7f20b9: gram_timing at
    /// N = 222, M = 19,200, 54% of the FMA peak); other values not timed.
    pub(crate) const KC: usize = 128;
    /// Rows of C per band (a multiple of 24, so that tiles start on the band's groups). Small
    /// items balance the threads at the end of each panel's fork-join, and the bands store less
    /// above the diagonal, so that for N = 2000 two partial Grams fit [`PARTIALS_BYTES`] (each
    /// thread then updates its own partial). Chosen by timing 24, 48, 96 and 192 rows at N = 222
    /// and 2000 (M = 19,200), alternated.
    pub(crate) const BAND: usize = 24;
    /// Most columns of C per work item: items of about equal cost keep the threads balanced.
    /// Chosen from the cache sizes (an item's columns, 192 KiB at N = 2000, stay in L2); not
    /// timed against other values.
    pub(crate) const COLS: usize = 192;
    /// Most partial Grams (runs of panels summed apart, in parallel, and added in order): few
    /// images leave too little of the triangle to share, so M is split too. 8 at N = 222, M =
    /// 19,200 (d7f20b9, which measured 54% of the FMA peak there); other counts not timed.
    pub(crate) const MAX_CHUNKS: usize = 8;
    /// Fewest panels per partial Gram: a partial costs an N x N addition and its memory, so a
    /// run of panels must be long enough to pay for it. Not tuned.
    pub(crate) const MIN_PANELS: usize = 4;
    /// Most memory the partial Grams beyond the first may take together: each is a copy of the
    /// triangle, so their count is capped by memory as well as by [`MAX_CHUNKS`]. Not tuned;
    /// [`BAND`] was chosen so that two partials of N = 2000 fit under it.
    pub(crate) const PARTIALS_BYTES: usize = 16 << 20;
}

/// [`super::gram8`]'s blocking (the 8-bit Gram matrix in integers).
pub(crate) mod gram8 {
    /// Most rows (padded) that take the shorter panels of 512 pixels (1024 above): shorter
    /// panels leave a small Gram more panels to share between the partials, longer ones give a
    /// large Gram fewer passes over its triangle. Chosen by timing 256, 512 and 1024 pixels at
    /// N = 222 and 2000 (M = 19,200), alternated.
    pub(crate) const SMALL: usize = 480;
    /// Most partial Grams: with two, each of two threads sums one with no fork-join per panel;
    /// chosen by timing one, two and four at N = 222, M = 19,200 on two cores (two were fastest).
    pub(crate) const MAX_CHUNKS8: usize = 2;
}

/// [`super::syrk`]'s blocking (the rank-k update, f64 and 8-bit).
pub(crate) mod syrk {
    /// Most rows of C per band (one rayon task): 192 rows x 256 steps of the band's micro-panels
    /// (384 KiB) stay in L2; at least 8 bands are made where C has the rows, so that two to
    /// eight threads balance. Chosen from the cache sizes; not timed against other values.
    pub(crate) const BAND: usize = 192;
    /// Step quads per cross panel used by streaming (1024 images, as [`KCP`]). Chosen with
    /// [`KCP`]; not timed against other values.
    #[cfg_attr(not(feature = "bench"), allow(unreachable_pub))] // public through crate::bench
    pub const KCQ: usize = 256;
    /// Step pairs per 8-bit panel used by streaming (1024 images, the streamed block that the
    /// reader thread decodes while the previous one is summed): a band's micro-panels (384 KiB)
    /// stay in L2, a column group's (16 KiB) in L1. Chosen from the cache sizes (aa5de73); not
    /// timed against other values.
    #[cfg_attr(not(feature = "bench"), allow(unreachable_pub))] // public through crate::bench
    pub const KCP: usize = 512;
    /// Reduction steps per packed f64 panel of the streaming X^T X: 256 ran faster than 128.
    #[cfg_attr(not(feature = "bench"), allow(unreachable_pub))] // public through crate::bench
    pub const KC: usize = 256;
}

/// [`super::dot_u8`]'s cache blocks (8-bit images times f32 weight rows).
pub(crate) mod dot_u8 {
    /// Images per cache block of `dots_batch`: the weights are read from the outer caches once
    /// per this many images (32 register blocks). Chosen with [`PIXEL_CHUNK`] (7ed96f6); not
    /// timed against other values.
    pub(crate) const BATCH_GROUP: usize = 32 * crate::kernels::dot_u8::BATCH_IMAGES;
    /// Pixels per cache block of `dots_batch`: a block of 20 weight rows (30 KiB) stays in the L1
    /// cache while the images' block passes over it. 512 (the most the u32 masks of nonzero steps
    /// allow) made no difference beyond the machine's load in three alternated rounds (3eec347).
    pub(crate) const PIXEL_CHUNK: usize = 384;
}

/// [`super::dot_q`]'s precision and cache blocks (8-bit images times fixed-point weight rows).
pub(crate) mod dot_q {
    /// Balanced base-256 digits per stored integer: 2 (16-bit fixed point). What it trades: each
    /// digit costs one `vpdpbusd` a step of 64 pixels, and each digit fewer quantises the weights
    /// 256 times more coarsely. Measured when it went from 3 (24-bit, as fine as the f32 basis)
    /// to 2 (9adf2e3, 2026-11-22): the eigenspace's dense 8-bit batch 4.5-5.5 -> 3.2-3.3 us a
    /// query, and estimates from 8-bit images differing from the f32 features' on 9 of 55,680
    /// rendered and COIL queries (near ties between two poses) against 2 with 3 digits. Works
    /// for 1 to 3.
    #[cfg_attr(not(feature = "bench"), allow(unreachable_pub))] // public through crate::bench
    pub const DIGITS: usize = 2;
    /// Steps (of 64 pixels) per cache block of `dots_batch`: the group's images' copies (16 KiB)
    /// stay in L1 while every row passes over them (at most 32: the u32 masks of nonzero steps).
    /// Chosen from the cache sizes (33f96bd); not timed against other values.
    pub(crate) const CHUNK: usize = 16;
    /// Register blocks per group of `dots_batch`: a row's digits, once in L1, serve this many.
    /// Chosen with [`CHUNK`] (33f96bd: groups of 2 x 8 images); not timed against other values.
    pub(crate) const GROUP: usize = 2;
}
