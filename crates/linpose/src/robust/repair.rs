//! The repair of a query from its robust fit: which of the query's own pixels the method sees,
//! and the reconstruction everywhere else.
//!
//! A binned pixel the fit explains is the query's own when its four neighbours are explained
//! too (the bins at an occluder's or the background's edge mix both). A bin the fit does not
//! explain is replaced, except in a speck: a group of unexplained bins on the object (the
//! reconstruction's bright bins, 8-connected through the object alone) holding fewer than
//! [`tuning::SPECK`] of them. The eigenspace reconstructs an object's fine detail (print,
//! edges, a car's interior) only roughly, so a textured object leaves such specks unexplained
//! all over itself, at its outline too; replaced, they become the reconstruction's blur, which
//! the method reads as a neighbouring pose, or as the pose half a turn away when the object
//! looks alike from behind. The background is not on the object, and an occluder hides more of
//! it than a speck. Inside a bin not kept, a pixel is still kept when it is within the fit's
//! threshold of the reconstruction.

use super::check::Basis;
use super::{tuning, Fit, Stage};

impl Stage {
    /// The repaired query: `x`'s own pixels where `fit` keeps their bin (see the module doc) or
    /// the pixel itself is explained, the reconstruction elsewhere.
    pub(crate) fn repair(&self, x: &[f32], fit: &Fit) -> Vec<f32> {
        let s = self.binning.spec();
        let (wb, hb) = (s.width as usize, s.height as usize);
        let b = self.binning.factor();
        let w = self.binning.full().width as usize;
        let explained = self.with_specks(fit, wb, hb);
        let keep: Vec<bool> = (0..wb * hb)
            .map(|i| {
                let (xo, yo) = (i % wb, i / wb);
                let ok = |x: usize, y: usize| explained[y * wb + x];
                ok(xo, yo) && (xo == 0 || ok(xo - 1, yo)) && (xo + 1 == wb || ok(xo + 1, yo)) && (yo == 0 || ok(xo, yo - 1)) && (yo + 1 == hb || ok(xo, yo + 1))
            })
            .collect();
        let coef: Vec<f32> = fit.coef.iter().map(|&c| c as f32).collect();
        let mut out = x.to_vec();
        for (i, v) in out.iter_mut().enumerate() {
            let (xo, yo) = ((i % w) / b, (i / w) / b);
            if xo < wb && yo < hb && keep[yo * wb + xo] {
                continue;
            }
            let r: f32 = coef.iter().enumerate().map(|(j, &c)| c * self.rows[j * self.m + i]).sum();
            if !((*v - r).abs() < fit.theta) {
                *v = r;
            }
        }
        out
    }

    /// `fit`'s explained bins (a `wb` x `hb` grid) with its specks (see the module doc) counted
    /// as explained.
    fn with_specks(&self, fit: &Fit, wb: usize, hb: usize) -> Vec<bool> {
        let mut explained = fit.inlier.clone();
        if fit.theta <= 0.0 {
            return explained;
        }
        let mut recon = vec![0f64; wb * hb];
        self.binned.reconstruct(&fit.coef, &mut recon);
        // The fit's threshold is its last share of the mean bright pixel (`search.rs`).
        let scale = fit.theta / tuning::ANNEAL[tuning::ANNEAL.len() - 1];
        let bright: Vec<bool> = recon.iter().map(|&v| v > f64::from(tuning::BRIGHT * scale)).collect();
        let most = tuning::SPECK * bright.iter().filter(|&&v| v).count() as f64;
        let mut seen = vec![false; wb * hb];
        let mut group = Vec::new();
        for start in 0..wb * hb {
            if fit.inlier[start] || seen[start] {
                continue;
            }
            group.clear();
            group.push(start);
            seen[start] = true;
            let mut next = 0;
            while next < group.len() {
                let i = group[next];
                next += 1;
                let (x, y) = (i % wb, i / wb);
                for ny in y.saturating_sub(1)..(y + 2).min(hb) {
                    for nx in x.saturating_sub(1)..(x + 2).min(wb) {
                        let n = ny * wb + nx;
                        if !fit.inlier[n] && !seen[n] && bright[n] == bright[start] {
                            seen[n] = true;
                            group.push(n);
                        }
                    }
                }
            }
            if bright[start] && (group.len() as f64) < most {
                group.iter().for_each(|&i| explained[i] = true);
            }
        }
        explained
    }
}
