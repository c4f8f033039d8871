//! A query's pose searched again in another basin: the refined model's part of the second look
//! (`second_look`), which says which basin of the pose space a query belongs to when it is
//! not the one the model's own search ended in. The search is the query's own route's (the clean
//! search's weighted distance, or the noisy match's affine residual), climbed on the reporting
//! lattice from the basin's pose; on a manifold kept as its knots (more than two pose
//! parameters, where a climb on the lattice would take many steps of 3^D - 1 poses each),
//! Levenberg-Marquardt from the basin's pose, snapped to the lattice.

use super::model::RefinedModel;
use super::noisy::affine_fit;
use super::query::Route;
use super::scratch::QueryScratch;
use super::tuning::HYPOTHESIS_STEP;

impl RefinedModel {
    /// The pose of query `x` (features of the images the model takes) in the basin of `start`,
    /// into `out` (left as it is for a query that cannot be projected).
    pub(crate) fn refine_in_basin(&self, x: &[f32], start: &[f64], out: &mut [f64]) {
        let mut s = QueryScratch::default();
        self.project_binned(x, self.noise_want(), &mut s);
        let l = self.components();
        let y = &s.y[..l];
        if y[0].is_nan() {
            return;
        }
        let (r, route, nu) = self.route_values(&s, 0);
        let step = if self.settings.params.resolution > 0.0 { self.settings.params.resolution } else { HYPOTHESIS_STEP };
        let mut t = start.to_vec();
        self.surface.clamp(&mut t);
        let mut f = vec![0.0; l];
        if self.continuous() {
            self.refine_continuous(y, self.route_of(r, route, nu), &mut t);
            return self.write_pose(&t, out);
        }
        match self.route_of(r, route, nu) {
            Route::Clean(nu) => {
                let ls = self.settings.search();
                let wt: Vec<f64> = self.inv_weight[..ls].iter().map(|&w| w / (w + nu)).collect();
                self.surface.climb_by(&mut t, step, |p| {
                    self.surface.eval(p, &mut f, None);
                    wt.iter().zip(y).zip(&f).map(|((&w, &v), &fv)| w * (v as f64 - fv) * (v as f64 - fv)).sum::<f64>()
                });
            }
            Route::Noisy(nu) => {
                let wt = self.noise_weights(nu);
                let ln = wt.len();
                let c: Vec<f64> = self.mean_proj[..ln].iter().map(|&v| v as f64).collect();
                let z: Vec<f64> = y[..ln].iter().zip(&c).map(|(&v, &cv)| v as f64 + cv).collect();
                let mut g = vec![0.0; l];
                self.surface.climb_by(&mut t, step, |p| {
                    self.surface.eval_pair(&self.bg_surface, p, &mut f, None, &mut g, None);
                    affine_fit(&z, &c, &wt, &f[..ln], &g[..ln]).0
                });
            }
        }
        self.write_pose(&t, out);
    }
}

impl RefinedModel {
    /// [`Self::refine_in_basin`]'s search on a manifold kept as its knots: `t` (in the domain)
    /// moved by Levenberg-Marquardt on the route's cost, then snapped to the reporting lattice
    /// (a model that reports continuous poses keeps the continuous end).
    fn refine_continuous(&self, y: &[f32], route: Route, t: &mut [f64]) {
        let (l, d, ls) = (self.components(), self.axes.len(), self.settings.search());
        let step = self.settings.params.resolution;
        match route {
            Route::Clean(nu) => {
                let wt: Vec<f64> = self.inv_weight.iter().enumerate().map(|(c, &w)| if c < ls { w / (w + nu) } else { 0.0 }).collect();
                let mut buf = vec![0.0; (d + 2) * l];
                self.surface.refine(y, &wt, t, &mut buf);
                if step > 0.0 {
                    self.surface.snap(y, &wt, t, step, &mut buf[..l]);
                }
            }
            Route::Noisy(nu) => {
                let wt = self.noise_weights(nu);
                let ln = wt.len();
                let c: Vec<f64> = self.mean_proj[..ln].iter().map(|&v| v as f64).collect();
                let z: Vec<f64> = y[..ln].iter().zip(&c).map(|(&v, &cv)| v as f64 + cv).collect();
                let mut buf = vec![0.0; (2 * d + 5) * l];
                self.surface.refine_affine(&self.bg_surface, &z, &c, &wt, t, &mut buf);
                if step > 0.0 {
                    let (f, rest) = buf.split_at_mut(ln);
                    let g = &mut rest[..ln];
                    self.surface.snap_by(t, step, |p| {
                        self.surface.eval_pair(&self.bg_surface, p, f, None, g, None);
                        affine_fit(&z, &c, &wt, f, g).0
                    });
                }
            }
        }
    }
}
