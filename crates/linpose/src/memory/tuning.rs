//! Every constant of the memory plan, in one place: for each, what it trades and how its value
//! was set.
//!
//! The coefficients of N^2 and N M are read from the code (what each path allocates, see
//! [`super`]) and checked against the peak resident memory of the release binary
//! (`/usr/bin/time -v`, "Maximum resident set size") on rendered data sets; where the code
//! alone does not settle a value (faer's eigendecomposition workspace, the refined method's
//! held-out fits), the value is the measured one rounded up, and says so. The measurements
//! (2 cores, glibc's allocator) are tabled in [`super`]'s documentation. An estimate is meant as
//! an upper bound a little above the peak: too low and a plan that "fits" is killed, too high
//! and a set that would fit is streamed or refused.

/// The process itself: the binary, its libraries, the allocator's arenas and the thread pool.
/// Measured: 8.5 MiB peak for 36 images of 16 x 12 (one and two threads alike); 12 MiB leaves
/// room for the manifest and the small arrays no formula counts.
pub(crate) const OVERHEAD_BYTES: u64 = 12 << 20;

/// Per thread and per feature of one image: each decoding thread holds an image as decoded
/// (up to 2 bytes a value for 16-bit images) and its row of f32 features. Read from the code
/// (2 + 4, rounded up to cover the decoder's own buffers); not measured apart (a few hundred
/// KiB per thread at 160 x 120).
pub(crate) const THREAD_FEATURE_BYTES: u64 = 16;

/// The share of the available memory a plan may use: the rest is left to the page cache, other
/// processes' growth while the fit runs, and the estimates' own error. A larger share trains
/// more sets in memory and risks the kernel's OOM killer more. Not tuned.
pub(crate) const USABLE_FRACTION: f64 = 0.9;

/// Bytes per N^2 of the linear model's in-memory fit: G (f64 N x N), G + lambda I (a copy) and
/// its Cholesky factor (another): 3 x 8, all alive while the factor is made. Read from the code;
/// measured 24.5 N^2 at N = 2,880 to 11,160 (16 x 12 images, where N^2 dominates).
pub(crate) const GRAM_SYSTEM_BYTES: f64 = 24.0;

/// Bytes per training row beside the N x N matrices: the factorisation's scratch and the
/// leave-one-out spread's solve with up to 256 unit columns (N x 256 f64, twice). Measured: the
/// linear fits at N = 5,760 and 11,160 sit 1.2 KiB per row above 24 N^2.
pub(crate) const ROW_BYTES: f64 = 2048.0;

/// glibc's largest mmap threshold (see [`crate::huge::HEAP_MATRIX_BYTES`]).
pub(crate) use crate::huge::HEAP_MATRIX_BYTES;

/// Bytes per N^2 of the linear model with `ridge auto` (leave-one-out): G, its
/// eigendecomposition (the eigenvectors and faer's workspace) and the eigenvectors squared.
/// Measured 33 N^2 (N = 5,760), 35 (2,880) and 41 (1,440, where [`HEAP_MATRIX_BYTES`]'s spare
/// matrix makes up the difference): 38, so that the larger sets, which matter, are not
/// overstated by more than about 20%.
pub(crate) const LOO_SYSTEM_BYTES: f64 = 38.0;

/// Bytes per N^2 of the eigenspace's PCA: the Gram matrix of the centred unit-energy images
/// and its eigendecomposition (the eigenvectors and faer's workspace). Measured 29 to 31 N^2
/// (N = 2,880 and 5,760, 16 x 12 images) and 42 at N = 1,440 (with [`HEAP_MATRIX_BYTES`]'s
/// spare matrix, 34); rounded up.
pub(crate) const EVD_SYSTEM_BYTES: f64 = 36.0;

/// Bytes per N^2 of the linear recogniser of many objects: G, its shifted copy and factor (as
/// [`GRAM_SYSTEM_BYTES`]) and the factor's inverse (another N x N), read from the code; measured
/// within 10% above on three objects of 1,440 images.
pub(crate) const LINEAR_RECOGNIZER_BYTES: f64 = 32.0;

/// Bytes per resampled manifold point and eigenimage (the eigenspace): the spline's f64 cube,
/// its resampled f64 points, their f32 copy and the search tree's. Read from the code (8 + 8 +
/// 4 + 4).
pub(crate) const MANIFOLD_VALUE_BYTES: f64 = 24.0;

/// Eigenimages the plan assumes for an eigenspace given an energy fraction instead of a number
/// (the number is known only once fitted). Murase & Nayar used 8 to 20; a set needing more makes
/// the estimate low by 24 bytes per point and eigenimage beyond it. Not tuned.
pub(crate) const ENERGY_COMPONENTS: usize = 40;

/// The refined method's working copies at the images' full size, in bytes per training image
/// and feature (besides the f32 images themselves): the held-out views as given for the noisy
/// match, their copies under two levels of simulated noise, the fold's own views. Measured
/// with [`REFINED_BINNED_BYTES`] on 1,440 images of 160 x 120 fitted with bin 1 (599 MiB) and
/// bin 4 (421 MiB): 5.15, rounded up.
pub(crate) const REFINED_FULL_BYTES: f64 = 5.5;

/// The refined method's working copies at the binned size, in bytes per training image and
/// binned feature: the held-out folds' views, their f64 transposed copy in each fold's PCA, the
/// final PCA's copy. Measured with [`REFINED_FULL_BYTES`] (see there): 7.45, rounded up.
pub(crate) const REFINED_BINNED_BYTES: f64 = 7.5;

/// Bytes per N^2 of the refined method: the final PCA's Gram matrix and eigendecomposition (as
/// [`EVD_SYSTEM_BYTES`]) and 4 more, because the peak of one and the same fit varies between
/// runs (its held-out fits run side by side, two at a time, and free at different moments):
/// 322 to 389 MiB over five runs on 2,880 images of 16 x 12, where 36 N^2 gave 398 MiB.
pub(crate) const REFINED_SYSTEM_BYTES: f64 = 40.0;

/// The refined method's structures per point of its reporting lattice (the surface's lattice
/// search, its coarse tree, the noisy match's tables, for each candidate fitted on held-out
/// views, two interpolants at a time). Measured: 84 MiB above the PCA on 2,880 images of
/// 16 x 12 over a lattice of 43,920 points (about 2 KiB a point).
pub(crate) const REFINED_LATTICE_BYTES: f64 = 2048.0;

/// The reporting lattice's step the plan assumes when a method reports continuous poses
/// (degrees): the refined method's default resolution.
pub(crate) const LATTICE_STEP: f64 = 0.5;
