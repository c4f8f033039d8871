//! The tuning constants of the modules that are one file directly under `src/` (the confidence,
//! the second look, the huge-page buffers, the linear algebra helpers): one submodule each, and
//! for each constant what it trades and how its value was set. The modules that are folders keep
//! theirs in their own `tuning.rs`.
//!
//! Constants that define rather than trade (the gross-error definition
//! [`crate::confidence::GROSS_DEG`], glibc's mmap threshold `crate::huge::HEAP_MATRIX_BYTES`,
//! the huge page's size, SIMD lane counts) stay beside their code.

/// [`crate::confidence`]'s constants.
pub(crate) mod confidence {
    /// The confidence under which an estimate is flagged. What it trades: raising it flags more
    /// views, gross or not; lowering it lets more gross errors through unflagged. Chosen on
    /// development data only, the procedural zoo's seeds 0-19 and 20-99 on a turntable trained
    /// every 10 degrees (`bench/zoo.py`): the smallest of 0.5, 0.55, 0.6, 0.7, 0.8, 0.9 and 0.95
    /// that flags at least 90% of the unseen views' gross errors of both the eigenspace and the
    /// refined method on each set. Re-measured with the second look of ee18c9a: at 0.55 the
    /// eigenspace caught 89.8% of the gross errors of seeds 20-99 (7.6% of their unseen views
    /// flagged); at 0.6, 92.7% (refined 94.4%), flagging 8.9% of their views, and every one of
    /// seeds 0-19, flagging 4.3%. The rendered `twin` (the paper's grid every 9 degrees) is
    /// development data too, but no threshold under 1 flags 90% of its gross errors: over a tenth
    /// of them have confidence 1 (docs/confidence.md, "Where it fails"). The zoo's held-out seeds
    /// report it (BENCHMARKS.md).
    pub const FLAG_BELOW: f64 = 0.6;

    /// Most hypotheses a model considers for one query (the best first): the confidence is the
    /// estimate's share of the probability among these. More would cost a climb each (the refined
    /// method) and shift little probability: alternatives beyond the best few score near 0. Not
    /// tuned.
    pub(crate) const MAX_HYPOTHESES: usize = 8;
}

/// [`crate::second_look`]'s constants.
pub(crate) mod second_look {
    /// The binning factor of the second look's images (smaller where the binned images would have
    /// fewer pixels than there are training views, or fewer than 3 x 3). What it trades: a
    /// coarser binning stores and projects b^2 times fewer numbers but blurs a small mark into its
    /// surroundings. Measured on the procedural zoo's development seeds 0-19 (a turntable every 10
    /// degrees, 128 x 96), with all N - 1 components: gross errors (over 20 degrees) among the 720
    /// unseen views 13 unbinned, 11 binned by 2, 10 by 4, where the eigenspace's 20 components
    /// make 48. Re-measured at 75b89f7 with the factor switched, on seeds 20-99 (`bench/zoo.py`,
    /// 2,880 unseen views; gross errors of the eigenspace / the refined method): 222 / 215
    /// unbinned, 200 / 197 by 2, 177 / 177 by 4, and the best factor for each object would make
    /// 175 / 174, so a per-model choice has nothing to win there. A mark of a few pixels wants the
    /// finer look: on the rendered `twin` (the paper's grid every 9 degrees, 160 x 120) the gross
    /// errors among its 1538 unseen views are 30 / 26 unbinned, 52 / 70 by 2 and 63 / 69 by 4, and
    /// its unseen mean error 1.28 / 0.97 degrees unbinned against 2.69 / 2.78 by 4, but unbinned
    /// the look stores and projects 17 times the numbers (218 components of 19,200 pixels, against
    /// 204 of 1,200). Kept at 4 for every model: a choice per model would need a held-out measure
    /// that tells such an object apart, and the one tried for the look's interpolant, the held-out
    /// flip count, was too noisy (docs/confidence.md).
    pub(crate) const SECOND_LOOK_BIN: usize = 4;

    /// The share of the held-out training views' mean squared distance to the surface that a
    /// fresh view between training views is expected at (D_h in [`crate::second_look`]'s module
    /// doc). What it trades: a larger share widens the posterior, flagging more views (gross or
    /// not); a smaller one trusts small gaps between basins, letting more gross errors through
    /// unflagged. Chosen on development data only, the procedural zoo's seeds 0-19 (a turntable
    /// every 10 degrees, `bench/zoo.py`): the largest power of two that flags at most 5% of their
    /// 720 unseen views, with every one of the 10 gross errors flagged at each share tried
    /// (flagged: 11.5% at 1, 6.8% at 1/4, 5.1% at 1/8, 4.3% at 1/16). On the rendered `twin` (the
    /// paper's grid every 9 degrees), also development data, no share meets both (at 1/16: 15.9%
    /// flagged, 47.6% of its gross errors). A held-out view lies twice as far from its neighbours
    /// as a fresh one; its distance measured 7 to 109 times (median about 40) an unseen view's at
    /// its true pose on those seeds. Held-out seeds report it (BENCHMARKS.md).
    pub(crate) const UNSEEN_SHARE: f64 = 1.0 / 16.0;

    /// Scan points per knot interval along each axis, where the basins start: a basin narrower
    /// than half a knot interval can be missed; more points cost a longer scan. Not tuned. With
    /// more than two pose parameters the scan is the knots themselves (one point per knot: 2^D
    /// fewer), as the method's own starts are.
    pub(crate) const PER_CELL: usize = 2;

    /// The lattice (degrees) the basins are climbed on. Not tuned: the eigenspace's manifold step.
    pub(crate) const STEP_DEG: f64 = 0.5;

    /// The step (degrees) below which the second look's Levenberg-Marquardt in a basin ends (more
    /// than two pose parameters, where it replaces the climb on the lattice of [`STEP_DEG`]): that
    /// lattice's step, which the descent's end is rounded to anyway. A smaller step costs more
    /// iterations of 4^D K products each (K the look's components, up to N - 1). Measured on the
    /// duck at azimuth 0:354:6, elevation 32:77:9, roll -30:30:10 (160 x 120, trained on the
    /// every-other-value lattice, 360 views; `bench/three_params.py`): the refined method's
    /// query took 20% less time at 0.5 than at 0.1 degrees (medians of 3 alternated runs each,
    /// 2 loaded cores: 256-270 against 316-347 us), with the same unseen errors.
    pub(crate) const STEP_TOL_LOOK: f64 = STEP_DEG;
}

/// [`crate::huge`]'s constants.
pub(crate) mod huge {
    /// Buffers of at most this many bytes stay on ordinary pages; larger ones are asked on huge
    /// pages. It is glibc's largest mmap threshold (`crate::huge::HEAP_MATRIX_BYTES`, asserted
    /// equal there), so only buffers that are always fresh mappings are advised: a smaller one may
    /// be carved from the heap, already touched, where the alignment slack would be zeroed too and
    /// the advice would split pages when the heap shrinks. Measured (`bench/ab_timing.py`, three
    /// alternated runs): with the threshold at numpy's 4 MB, COIL-20 object 1's refined fit (4.7 MB
    /// copies) was 7-37% slower; above it, the rendered duck's eigenspace fit took 161.3 -> 133.6
    /// ms on an AVX2 machine (21 alternated turns of 0.2 s).
    pub(crate) const HUGE_MIN_BYTES: usize = 32 << 20;
}

/// [`crate::linalg`]'s constants.
pub(crate) mod linalg {
    /// Values per block of the energy ||x||^2 (32 a lane of its 64 f32 lanes), each block's lane
    /// sums added into f64: a longer block sums more in f32 before the f64 sum takes over (the
    /// energy is tested to lie within f32 rounding of the f64 sum), a shorter one adds the lanes
    /// into f64 more often. Chosen by hand with the 64 lanes (80adb95); not measured against
    /// other values.
    pub(crate) const ENERGY_BLOCK: usize = 2048;
}
