//! The dense first pass of the robust fit: the training views interpolated on a fine lattice of
//! poses, each scored by the pixels it explains at the fit's tight threshold, every vote weighed
//! by its neighbourhood (`coherence.rs`).
//!
//! The stage's hypotheses are the training views' coefficients, whose reconstructions from
//! sixteen eigenimages blur an object's detail, and a query between two training views misses
//! either of them by as much as the detail that tells the two sides of a toy car apart: scored
//! at a loose threshold that misses nothing the pose moves, half a turn away scores as well as
//! the truth once much of the object is hidden. The views themselves, interpolated (the
//! reread's surface, `reread.rs`) every quarter of a training interval, keep that detail, so
//! they can be scored tightly, where the details decide. The best is the fit's start, and its
//! pose the fit's own (`verify.rs`).
//!
//! Measured on COIL-20 in texture scenes (`bench/scenes.py`, refined `--robust`, trained every
//! 10 degrees, the views between; 0 / 20 / 40% hidden): 0.92 / 1.16 / 4.96 degrees with the
//! training views' coefficients as the hypotheses, 0.92 / 1.08 / 2.67 with the lattice; 29
//! gross errors of 720 at 40% hidden against 12. It was built on objects 1, 3, 6, 9, 12, 16, 18
//! and 19 at 40% hidden (8.1 to 4.9 degrees there); the twelve others went from 2.86 to 1.18.
//! It costs per query one pass over the binned pixels and their neighbourhoods per view (144
//! views for a ring of 36): a repaired 128 x 128 query took 0.89 ms against 0.66
//! (`cargo bench -p linpose --bench scene`). It needs the training poses on a lattice, as the
//! reread does; without one, the stage's hypotheses are the training views' coefficients.

use super::check::Basis;
use super::reread::Reread;
use super::search::Table;
use super::{check::Binned, tuning};

/// The lattice's hypotheses (see the module doc).
#[derive(Debug, Clone)]
pub(crate) struct Lattice {
    /// H x P: the hypotheses' poses.
    pub(super) poses: Vec<f64>,
    /// P.
    pub(super) params: usize,
    /// H x K: each view's least-squares coefficients on the stage's binned rows.
    pub(super) coefs: Vec<f32>,
    /// Per hypothesis: its brightest binned value.
    pub(super) peaks: Vec<f32>,
    /// The views on the stage's support.
    pub(super) table: Table,
}

impl Lattice {
    /// The lattice of `reread`'s surface, its views' coefficients on `binned`, laid out on
    /// `support`; None when even one view per training pose exceeds [`tuning::LATTICE_MOST`].
    pub(crate) fn of(reread: &Reread, binned: &Binned, support: &[u32]) -> Option<Lattice> {
        let surface = &reread.surface;
        let params = surface.params();
        let per_cell = (1..=tuning::LATTICE_STEPS).rev().find(|&c| surface.grid_shape(c).iter().map(|&(n, _)| n).product::<usize>() <= tuning::LATTICE_MOST)?;
        let poses = surface.grid_poses(per_cell);
        let (k, mb) = binned.shape();
        let (mut views, mut coefs) = (Vec::with_capacity(poses.len() / params * mb), Vec::new());
        let (mut f, mut xb, mut p, mut c) = (vec![0f64; mb], vec![0f32; mb], vec![0f64; k], vec![0f64; k]);
        for pose in poses.chunks_exact(params) {
            surface.eval(pose, &mut f, None);
            xb.iter_mut().zip(&f).for_each(|(v, &u)| *v = u as f32);
            binned.coefficients(&xb, &mut p, &mut c);
            coefs.extend(c.iter().map(|&v| v as f32));
            views.extend_from_slice(&xb);
        }
        let peaks: Vec<f32> = views.chunks_exact(mb).map(|v| v.iter().fold(0f32, |a, &u| a.max(u))).collect();
        let table = Table::new(&views, &peaks, support);
        Some(Lattice { poses, params, coefs, peaks, table })
    }

    /// Hypothesis `h`'s pose.
    pub(super) fn pose(&self, h: usize) -> &[f64] {
        &self.poses[h * self.params..(h + 1) * self.params]
    }

    /// Hypothesis `h`'s coefficients.
    pub(super) fn coef(&self, h: usize) -> &[f32] {
        let k = self.coefs.len() / self.peaks.len();
        &self.coefs[h * k..(h + 1) * k]
    }

    /// Hypothesis `h`'s bright pixels on `support` (at least [`tuning::BRIGHT`] of its brightest)
    /// and how many of them `inlier` marks.
    pub(super) fn seen(&self, h: usize, support: &[u32], inlier: &[bool]) -> (usize, usize) {
        let bright = self.table.bright(h);
        (bright.len(), bright.iter().filter(|&&j| inlier[support[j as usize] as usize]).count())
    }
}
