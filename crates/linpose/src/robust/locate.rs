//! The object anywhere in a larger image (a scene): the box, at a position and a scale within
//! [`tuning::SCALE_LO`] to [`tuning::SCALE_HI`] of the training views' size, whose pixels the
//! stage's hypotheses explain best; then the box resampled to the training views' size is the
//! query.
//!
//! A window of the scene at scale s is read as the stage reads a view binned by b: cells of
//! b s x b s scene pixels, each the mean of the scene under it (from the scene's integral image,
//! exact at any real position and size), so one scene serves every position and scale without
//! resampling it. A window is scored by the stage's hypotheses (the training views' binned
//! images, each in the gain that fits the window best): the best hypothesis's score, the share
//! of its silhouette the window explains less the cells just outside it that go on like the
//! object ([`silhouette_score`]). Background and occluders explain nothing, and the object ends
//! where the hypothesis's silhouette does, so the score peaks where the object is, at its size.
//!
//! 1. **Coarse.** Every scale of a geometric ladder (steps of [`tuning::SCALE_RATIO`]) and every
//!    position on a grid of one coarse cell, scored on cells of 2b s pixels (the hypotheses'
//!    binned images binned by 2 more; [`tuning::COARSE_HYPOTHESES`] of them): about 2,600
//!    windows of a quarter of the stage's pixels for a 320 x 240 scene and 128 x 128 views.
//! 2. **Fine.** The best [`tuning::CANDIDATES`] windows (each at least a quarter of a window from
//!    the others, or more than two steps of the scale ladder from them), then
//!    [`tuning::LOOSE_CANDIDATES`] more, the best by their score within the hypotheses'
//!    envelopes ([`envelope`]: what a hypothesis reads up to half a cell off its place; a
//!    textured object's coarse score falls off within a few pixels, less than the coarse step,
//!    so the grid can miss its peak), and the four windows a coarse step from each of the first
//!    (the fine score's peak is a few pixels wide, and the coarse one's may lie a step off it),
//!    are refined on the stage's own cells by a pattern search over the position and the
//!    scale, the steps halved until they are under [`tuning::MIN_SHIFT`] pixels, scored by the hypotheses that explain the window
//!    best and the poses halfway to their neighbours in the eigenspace (a query between two
//!    training views is placed best by a pose between them).
//! 3. **Arbitrate** (with the dense first pass of `scan.rs`). The best refined window and those
//!    centred within [`tuning::APART`] of a window of it but more than
//!    [`tuning::APART_SCALE_STEPS`] steps of the ladder from its scale (the part and the whole
//!    of one object, as the candidates are told apart) are read by the lattice; the one it
//!    explains most of in scene pixels wins: its best hypothesis's score (explained less missed
//!    bins, weighed by their neighbourhoods) times the window's scale squared. The refine scores
//!    a window by the share of a silhouette it explains, so a part of the object matched by a
//!    view at a smaller scale (a cup's bowl, by a view whose handle hides) can win it; the
//!    whole explains more of the scene. Windows of nearly one scale are left to the refine: the
//!    tight first pass is too sensitive to a window's sub-pixel place to rank those. On COIL-20
//!    in 320 x 240 scenes (`bench/locate.py`, 0 / 20 / 40% hidden) it took the boxes within
//!    3 px from 96.4 / 87.2 / 47.8% to 96.8 / 87.6 / 49.6% and the pose from 1.44 / 9.58 /
//!    47.3 to 1.22 / 9.20 / 45.8 degrees (the cup, object 18, at 0% hidden: 10.4 to 5.97). It
//!    was built looking at objects 2, 3, 4, 9, 11, 18 and 19 at 0 and 20% hidden; the eleven
//!    others went from 0.72 / 3.60 / 37.9 to 0.72 / 3.37 / 36.5 degrees. Comparing every
//!    refined window near the best, whatever its scale, took the cup to 2.78 but read a wider
//!    window of object 19 as the car end-on, and on the duck's 64 x 48 views a window at nearly
//!    the true scale a quarter turn off. It costs a first pass per window read (one to three):
//!    a 320 x 240 scene took 39.6 ms against 37.7.
//! 4. **Polish.** [`tuning::POLISH`] times: the robust fit of the window (`search.rs`), then the
//!    pattern search again, at half the steps, with the fit's reconstruction alone as the
//!    hypothesis: its coefficients are free, so it follows the query's pose between the
//!    training views, and its silhouette places the box.

use super::check::Basis;
use super::search::gain;
use super::{tuning, Stage};
use crate::binning::Binning;
use crate::image_io::{ColorMode, ImageSpec};
use crate::model::Kept;
use crate::model::Located;
use crate::{Error, Result};
use rayon::prelude::*;

/// A scene's integral image: the sum of its pixels over [0, x) x [0, y) at any real point.
pub(super) struct Integral {
    pub(super) w: usize,
    pub(super) h: usize,
    sums: Vec<f64>,
}

impl Integral {
    pub(super) fn new(img: &[f32], w: usize, h: usize) -> Self {
        let mut sums = vec![0f64; (w + 1) * (h + 1)];
        for y in 0..h {
            let mut row = 0f64;
            for x in 0..w {
                row += img[y * w + x] as f64;
                sums[(y + 1) * (w + 1) + x + 1] = sums[y * (w + 1) + x + 1] + row;
            }
        }
        Integral { w, h, sums }
    }

    /// Whether the box of width `w` and height `h` at (x, y) lies in the image.
    pub(super) fn holds(&self, x: f64, y: f64, w: f64, h: f64) -> bool {
        x >= 0.0 && y >= 0.0 && x + w <= self.w as f64 + 1e-9 && y + h <= self.h as f64 + 1e-9
    }

    /// The sum over [0, x) x [0, y): bilinear between the pixel corners, which is exact for an
    /// image constant on each pixel.
    fn at(&self, x: f64, y: f64) -> f64 {
        let (x, y) = (x.clamp(0.0, self.w as f64), y.clamp(0.0, self.h as f64));
        let (i, j) = ((x as usize).min(self.w - 1), (y as usize).min(self.h - 1));
        let (fx, fy) = (x - i as f64, y - j as f64);
        let s = |i: usize, j: usize| self.sums[j * (self.w + 1) + i];
        let top = s(i, j) + fx * (s(i + 1, j) - s(i, j));
        let bottom = s(i, j + 1) + fx * (s(i + 1, j + 1) - s(i, j + 1));
        top + fy * (bottom - top)
    }

    /// The means of `gw` x `gh` cells of `c` x `c` pixels from (x0, y0), row by row, into `out`;
    /// `corners` is scratch.
    pub(super) fn cells(&self, (x0, y0): (f64, f64), c: f64, (gw, gh): (usize, usize), out: &mut [f32], corners: &mut Vec<f64>) {
        corners.clear();
        for j in 0..=gh {
            let y = y0 + j as f64 * c;
            corners.extend((0..=gw).map(|i| self.at(x0 + i as f64 * c, y)));
        }
        let inv = 1.0 / (c * c);
        let g = |i: usize, j: usize| corners[j * (gw + 1) + i];
        for j in 0..gh {
            for i in 0..gw {
                out[j * gw + i] = ((g(i + 1, j + 1) - g(i, j + 1) - g(i + 1, j) + g(i, j)) * inv) as f32;
            }
        }
    }
}

/// The hypotheses at one resolution: cells of `cell` x `cell` view pixels, `gw` x `gh` of them.
struct Level {
    cell: usize,
    grid: (usize, usize),
    preds: Vec<f32>,
    peaks: Vec<f32>,
    support: Vec<u32>,
    /// Each hypothesis's silhouette and its rim.
    shapes: Vec<Shape>,
    /// Per hypothesis and cell, how far the hypothesis interpolated bilinearly up to half a cell
    /// either way strays from the cell ([`envelope`]): the coarse level's; empty on the others.
    envelope: Vec<f32>,
}

impl Level {
    /// The level of the hypotheses `preds` (`grid` cells each, on the `support`), on cells of
    /// `cell` x `cell` view pixels.
    fn new(cell: usize, grid: (usize, usize), preds: Vec<f32>, support: Vec<u32>) -> Level {
        let m = grid.0 * grid.1;
        let peaks: Vec<f32> = preds.chunks_exact(m).map(|p| p.iter().fold(0f32, |a, &v| a.max(v))).collect();
        let shapes = preds.chunks_exact(m).zip(&peaks).map(|(p, &peak)| Shape::new(p, peak, &support, grid)).collect();
        Level { cell, grid, preds, peaks, support, shapes, envelope: Vec::new() }
    }

    /// The stage's own cells.
    fn fine(stage: &Stage) -> Level {
        let s = stage.binning.spec();
        Level::new(stage.binning.factor(), (s.width as usize, s.height as usize), stage.preds.clone(), stage.support.clone())
    }

    /// Its hypotheses `keep`, each with the poses halfway to its [`tuning::NEIGHBOURS`] nearest
    /// hypotheses in the eigenspace (`coords`, H x K: the hypotheses' coefficients): the mean of
    /// the two binned images, which are linear in the coefficients. The training views lie a
    /// step apart on the object's manifold in the eigenspace, and a query between two of them
    /// is placed best by a point between them: the nearer view alone fits it best a few pixels
    /// off wherever the pose moves the object in the frame (the parametric eigenspace's
    /// interpolation, for the search).
    fn around(&self, keep: &[usize], coords: &[f32]) -> Level {
        let m = self.grid.0 * self.grid.1;
        let k = coords.len() / self.peaks.len();
        let coord = |h: usize| &coords[h * k..(h + 1) * k];
        let pred = |h: usize| &self.preds[h * m..(h + 1) * m];
        let mut pairs: Vec<(usize, usize)> = keep.iter().map(|&h| (h, h)).collect();
        for &h in keep {
            let mut near: Vec<(f32, usize)> =
                (0..self.peaks.len()).filter(|&n| n != h).map(|n| (coord(n).iter().zip(coord(h)).map(|(a, b)| (a - b) * (a - b)).sum::<f32>(), n)).collect();
            near.sort_by(|a, b| a.0.total_cmp(&b.0).then(a.1.cmp(&b.1)));
            pairs.extend(near.iter().take(tuning::NEIGHBOURS).map(|&(_, n)| (h, n)));
        }
        let preds: Vec<f32> = pairs.iter().flat_map(|&(h, n)| pred(h).iter().zip(pred(n)).map(|(&u, &v)| 0.5 * (u + v))).collect();
        Level::new(self.cell, self.grid, preds, self.support.clone())
    }

    /// The single hypothesis whose cells are `pred`, on this level's cells.
    fn single(&self, pred: Vec<f32>) -> Level {
        Level::new(self.cell, self.grid, pred, self.support.clone())
    }

    /// `fine`'s cells binned by 2 (a pixel of the support where any of its four is), with at
    /// most `most` of its hypotheses, taken evenly, and their envelopes.
    fn coarse(fine: &Level, most: usize) -> Result<Level> {
        let (fw, fh) = fine.grid;
        let grid = ImageSpec { width: fw as u32, height: fh as u32, color: ColorMode::Gray };
        let binning = Binning::new(grid, 2)?;
        let (gw, gh) = (fw / 2, fh / 2);
        let step = fine.peaks.len().div_ceil(most.max(1)).max(1);
        let preds = binning.apply_all(&fine.preds.chunks_exact(fw * fh).step_by(step).flatten().copied().collect::<Vec<_>>());
        let mut on = vec![false; gw * gh];
        for &k in &fine.support {
            let (i, j) = (k as usize % fw / 2, k as usize / fw / 2);
            if i < gw && j < gh {
                on[j * gw + i] = true;
            }
        }
        let support = (0..(gw * gh) as u32).filter(|&k| on[k as usize]).collect();
        let mut level = Level::new(2 * fine.cell, (gw, gh), preds, support);
        level.envelope = level.preds.chunks_exact(gw * gh).flat_map(|p| envelope(p, (gw, gh))).collect();
        Ok(level)
    }

    /// Each hypothesis's score on the window whose cells are `xb` ([`silhouette_score`]), with
    /// its score within its envelope on a level that has them (else the same).
    fn scores<'a>(&'a self, xb: &'a [f32], ratios: &'a mut Vec<f32>) -> impl Iterator<Item = [f32; 2]> + 'a {
        let m = xb.len();
        self.preds.chunks_exact(m).zip(&self.peaks).zip(&self.shapes).enumerate().map(move |(h, ((p, &peak), shape))| {
            let envelope = self.envelope.get(h * m..(h + 1) * m);
            silhouette_score(p, peak, &self.support, shape, envelope, xb, ratios)
        })
    }

    /// The best hypothesis's score on the window whose cells are `xb`, and the best within the
    /// hypotheses' envelopes.
    fn score(&self, xb: &[f32], ratios: &mut Vec<f32>) -> [f32; 2] {
        self.scores(xb, ratios).fold([f32::NEG_INFINITY; 2], |a, b| [a[0].max(b[0]), a[1].max(b[1])])
    }
}

/// A window: its top-left corner and scale, with its score (and on the coarse level, its score
/// within the hypotheses' envelopes).
#[derive(Debug, Clone, Copy, PartialEq)]
struct Window {
    x: f64,
    y: f64,
    s: f64,
    score: f32,
    loose: f32,
}

impl Window {
    /// How far its centre lies from `o`'s, for training views of `view` (width, height).
    fn offset(&self, o: &Window, view: (f64, f64)) -> f64 {
        let dx = self.x + 0.5 * view.0 * self.s - o.x - 0.5 * view.0 * o.s;
        let dy = self.y + 0.5 * view.1 * self.s - o.y - 0.5 * view.1 * o.s;
        dx.hypot(dy)
    }

    /// Whether it ranks before `o` by `key`: the higher first, then the smaller scale, the
    /// higher, the more to the left.
    fn rank(&self, o: &Window, key: fn(&Window) -> f32) -> std::cmp::Ordering {
        key(o).total_cmp(&key(self)).then(self.s.total_cmp(&o.s)).then(self.y.total_cmp(&o.y)).then(self.x.total_cmp(&o.x))
    }
}

/// Scratch of one scoring thread.
#[derive(Default)]
struct Scratch {
    xb: Vec<f32>,
    corners: Vec<f64>,
    ratios: Vec<f32>,
}

/// The search over one scene (see the module doc).
struct Search<'a> {
    scene: &'a Integral,
    /// The training views' width and height.
    view: (f64, f64),
}

impl Search<'_> {
    /// Whether a window of scale `s` at (x, y) lies in the scene.
    fn fits(&self, x: f64, y: f64, s: f64) -> bool {
        self.scene.holds(x, y, self.view.0 * s, self.view.1 * s)
    }

    /// The score of the window at (x, y) and scale `s` on `level`, and within the envelopes.
    fn score(&self, level: &Level, x: f64, y: f64, s: f64, t: &mut Scratch) -> [f32; 2] {
        let (gw, gh) = level.grid;
        t.xb.resize(gw * gh, 0.0);
        self.scene.cells((x, y), level.cell as f64 * s, level.grid, &mut t.xb, &mut t.corners);
        level.score(&t.xb, &mut t.ratios)
    }

    /// Every window of the scales `scales` on a grid of half a coarse cell, scored on `level`.
    fn coarse(&self, level: &Level, scales: &[f64]) -> Vec<Window> {
        let rows: Vec<(f64, f64)> = scales
            .iter()
            .flat_map(|&s| {
                let stride = tuning::STRIDE * level.cell as f64 * s;
                let ny = ((self.scene.h as f64 - self.view.1 * s) / stride).floor().max(0.0) as usize + 1;
                (0..ny).map(move |j| (s, j as f64 * stride))
            })
            .collect();
        rows.par_iter()
            .map_init(Scratch::default, |t, &(s, y)| {
                let stride = tuning::STRIDE * level.cell as f64 * s;
                let nx = ((self.scene.w as f64 - self.view.0 * s) / stride).floor().max(0.0) as usize + 1;
                (0..nx)
                    .map(|i| i as f64 * stride)
                    .filter(|&x| self.fits(x, y, s))
                    .map(|x| {
                        let [score, loose] = self.score(level, x, y, s, t);
                        Window { x, y, s, score, loose }
                    })
                    .collect::<Vec<_>>()
            })
            .flatten()
            .collect()
    }

    /// The window `w` refined on the stage's cells (`fine`, whose hypotheses' coefficients are
    /// `coords`): the hypotheses that explain it best and the poses between them and their
    /// neighbours ([`Level::around`]), then a pattern search ([`Self::pattern`]).
    fn refine(&self, fine: &Level, coords: &[f32], w: Window, shift: f64, ratio: f64, t: &mut Scratch) -> Window {
        let (gw, gh) = fine.grid;
        t.xb.resize(gw * gh, 0.0);
        self.scene.cells((w.x, w.y), fine.cell as f64 * w.s, fine.grid, &mut t.xb, &mut t.corners);
        let mut ranked: Vec<(f32, usize)> = fine.scores(&t.xb, &mut t.ratios).enumerate().map(|(h, v)| (v[0], h)).collect();
        ranked.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
        let keep: Vec<usize> = ranked.iter().take(tuning::FINE_HYPOTHESES).map(|r| r.1).collect();
        self.pattern(&fine.around(&keep, coords), w, shift, ratio, t)
    }

    /// The window `w` moved on `level` by a pattern search over position and scale (the scale
    /// changed about the window's centre), from steps of `shift` pixels and `ratio`, halved
    /// until under [`tuning::MIN_SHIFT`] pixels.
    fn pattern(&self, level: &Level, mut w: Window, shift: f64, ratio: f64, t: &mut Scratch) -> Window {
        w.score = self.score(level, w.x, w.y, w.s, t)[0];
        let (mut dx, mut ds) = (shift, ratio);
        let mut evaluations = 0;
        while dx >= tuning::MIN_SHIFT && evaluations < tuning::MAX_EVALUATIONS {
            let mut moved = false;
            for (mx, my, ms) in [(1.0, 0.0, 0.0), (-1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, -1.0, 0.0), (0.0, 0.0, 1.0), (0.0, 0.0, -1.0)] {
                let s = w.s * (1.0 + ms * ds);
                let (x, y) = (w.x + mx * dx - 0.5 * self.view.0 * (s - w.s), w.y + my * dx - 0.5 * self.view.1 * (s - w.s));
                if !(tuning::SCALE_LO..=tuning::SCALE_HI).contains(&s) || !self.fits(x, y, s) {
                    continue;
                }
                evaluations += 1;
                let score = self.score(level, x, y, s, t)[0];
                if score > w.score {
                    w = Window { x, y, s, score, loose: score };
                    moved = true;
                }
            }
            if !moved {
                dx *= 0.5;
                ds *= 0.5;
            }
        }
        w
    }
}

/// The scales of the coarse search that fit a `scene` of views `view` (width, height): from
/// [`tuning::SCALE_LO`] up by [`tuning::SCALE_RATIO`], and [`tuning::SCALE_HI`].
fn scales(view: (f64, f64), scene: (f64, f64)) -> Vec<f64> {
    let most = tuning::SCALE_HI.min(scene.0 / view.0).min(scene.1 / view.1);
    let mut out = Vec::new();
    let mut s = tuning::SCALE_LO;
    while s < most {
        out.push(s);
        s *= tuning::SCALE_RATIO;
    }
    if most >= tuning::SCALE_LO {
        out.push(most);
    }
    out
}

impl Stage {
    /// The integral image of `scene` (gray features of `spec`), which must be larger than the
    /// training views at the smallest scale searched.
    pub(super) fn scene(&self, scene: &[f32], spec: ImageSpec) -> Result<Integral> {
        let full = self.binning.full();
        let (w, h) = (full.width as usize, full.height as usize);
        let (sw, sh) = (spec.width as usize, spec.height as usize);
        if spec.color != ColorMode::Gray || scene.len() != sw * sh {
            return Err(Error::invalid("scene", format!("{sw}x{sh} {:?}, {} values", spec.color, scene.len()), "a gray image of its size"));
        }
        let view = (w as f64, h as f64);
        let ladder = scales(view, (sw as f64, sh as f64));
        if ladder.is_empty() {
            return Err(Error::invalid(
                "scene",
                format!("{sw}x{sh}"),
                format!("at least the training views' {w}x{h} times {} (the smallest scale searched)", tuning::SCALE_LO),
            ));
        }
        if scene.iter().any(|v| !v.is_finite()) {
            return Err(Error::invalid("scene", "a value that is not finite", "finite pixel values"));
        }
        Ok(Integral::new(scene, sw, sh))
    }

    /// The object in `scene` (from [`Stage::scene`]): its box, and the box resampled to the
    /// training views' size (not yet repaired).
    pub(super) fn locate(&self, scene: &Integral) -> Result<Located> {
        let full = self.binning.full();
        let view = (full.width as f64, full.height as f64);
        let ladder = scales(view, (scene.w as f64, scene.h as f64));
        let search = Search { scene, view };
        let fine = Level::fine(self);
        let coarse = Level::coarse(&fine, tuning::COARSE_HYPOTHESES)?;
        let found = search.coarse(&coarse, &ladder);
        // The best windows by their score, then the best by their score within the envelopes
        // (a window up to half a cell off the object), each apart from those before it: its
        // centre a quarter of a window away, or its scale more than two steps of the ladder
        // (at one place, a part of the object matched by a view at a smaller scale, say a
        // cup's bowl by a view whose handle hides, and the whole object are two candidates).
        let add = |starts: &mut Vec<Window>, key: fn(&Window) -> f32, more: usize| {
            let most = starts.len() + more;
            let mut ranked: Vec<&Window> = found.iter().collect();
            ranked.sort_by(|a, b| a.rank(b, key));
            for &c in ranked {
                if starts.len() >= most {
                    break;
                }
                let apart = |o: &Window| c.offset(o, view) > tuning::APART * view.0.min(view.1) * c.s || scales_apart(&c, o);
                if starts.iter().all(apart) {
                    starts.push(c);
                }
            }
        };
        let mut starts: Vec<Window> = Vec::new();
        add(&mut starts, |w| w.score, tuning::CANDIDATES);
        let first = starts.len();
        add(&mut starts, |w| w.loose, tuning::LOOSE_CANDIDATES);
        let shift = 0.5 * tuning::STRIDE * coarse.cell as f64;
        let ratio = 0.5 * (tuning::SCALE_RATIO - 1.0);
        // Each of the first candidates and the four windows a coarse step from it: the fine
        // score's peak is a few pixels wide, and the coarse one's may lie a step or more off it.
        // The loose candidates alone: their score already reads up to half a step off.
        let step = tuning::STRIDE * coarse.cell as f64;
        let tries: Vec<Window> = starts
            .iter()
            .enumerate()
            .flat_map(|(k, &c)| {
                let around: &[(f64, f64)] = if k < first { &[(0.0, 0.0), (1.0, 0.0), (-1.0, 0.0), (0.0, 1.0), (0.0, -1.0)] } else { &[(0.0, 0.0)] };
                around.iter().map(move |&(dx, dy)| Window { x: c.x + dx * step * c.s, y: c.y + dy * step * c.s, ..c })
            })
            .filter(|w| search.fits(w.x, w.y, w.s))
            .collect();
        let mut refined: Vec<Window> =
            tries.par_iter().map_init(Scratch::default, |t, &c| search.refine(&fine, &self.hyps, c, shift * c.s, ratio, t)).collect();
        refined.sort_by(|a, b| a.rank(b, |w| w.score));
        let mut best = *refined.first().expect("at least one window fits");
        if self.lattice.is_some() {
            best = self.arbitrate(&search, &fine, &refined, best);
        }
        // 4. The box placed by the robust fit's own reconstruction, which is not bound to a
        //    training view's pose.
        let mut t = Scratch::default();
        let mut recon = vec![0f64; fine.grid.0 * fine.grid.1];
        for _ in 0..tuning::POLISH {
            t.xb.resize(recon.len(), 0.0);
            search.scene.cells((best.x, best.y), fine.cell as f64 * best.s, fine.grid, &mut t.xb, &mut t.corners);
            let fit = self.fit_binned(&t.xb);
            Basis::reconstruct(&self.binned, &fit.coef, &mut recon);
            let level = fine.single(recon.iter().map(|&v| v as f32).collect());
            best = search.pattern(&level, best, 0.5 * shift * best.s, 0.5 * ratio, &mut t);
        }
        Ok(self.cut(scene, [best.x, best.y, view.0 * best.s, view.1 * best.s]))
    }

    /// Of `best` (the best refined window) and the windows of `refined` centred within
    /// [`tuning::APART`] of a window of it and more than [`tuning::APART_SCALE_STEPS`] ladder
    /// steps from its scale, the one whose view the dense first pass (`scan.rs`) explains most
    /// of, in scene pixels: its best lattice hypothesis's score times the window's scale squared
    /// (see the module doc). Windows within a fine cell and half a ladder step of one already
    /// read are read once.
    fn arbitrate(&self, search: &Search, fine: &Level, refined: &[Window], best: Window) -> Window {
        let view = search.view;
        let mut read: Vec<Window> = Vec::new();
        let (mut xb, mut corners) = (vec![0f32; fine.grid.0 * fine.grid.1], Vec::new());
        let (mut chosen, mut top) = (best, f64::NEG_INFINITY);
        for &c in refined {
            if c.offset(&best, view) > tuning::APART * view.0.min(view.1) * best.s.min(c.s) || !(scales_apart(&c, &best) || c == best) {
                continue;
            }
            let same = |o: &Window| c.offset(o, view) <= fine.cell as f64 * c.s && (c.s / o.s).ln().abs() <= 0.5 * tuning::SCALE_RATIO.ln();
            if read.iter().any(same) {
                continue;
            }
            read.push(c);
            search.scene.cells((c.x, c.y), fine.cell as f64 * c.s, fine.grid, &mut xb, &mut corners);
            let explained = self.coarse(&xb).top().map_or(f64::NEG_INFINITY, |v| f64::from(v) * c.s * c.s);
            if explained > top {
                (chosen, top) = (c, explained);
            }
        }
        chosen
    }

    /// The box `bbox` (left, top, width, height) of `scene`, resampled to the training views'
    /// size (not yet repaired).
    pub(super) fn cut(&self, scene: &Integral, bbox: [f64; 4]) -> Located {
        let full = self.binning.full();
        let (w, h) = (full.width as usize, full.height as usize);
        let scale = bbox[2] / w as f64;
        let mut view = vec![0f32; w * h];
        scene.cells((bbox[0], bbox[1]), scale, (w, h), &mut view, &mut Vec::new());
        Located { bbox, scale, view, shown: 1.0, repaired: false, kept: Kept::default() }
    }
}

/// Whether windows `a` and `b` are more than [`tuning::APART_SCALE_STEPS`] steps of the
/// scale ladder apart: the part and the whole of one object, at one place.
fn scales_apart(a: &Window, b: &Window) -> bool {
    (a.s / b.s).ln().abs() > tuning::APART_SCALE_STEPS * tuning::SCALE_RATIO.ln() + 1e-9
}

/// Per cell of the hypothesis `pred` (`gw` x `gh` cells), how far its value interpolated
/// bilinearly up to half a cell either way strays from the cell's own: the largest difference
/// at the midpoints of its sides and its corners (the means of two and of four cells), where a
/// bilinear surface takes its extremes over the square. A window up to half a coarse step off
/// the object reads each cell within it, for cells that vary no faster than bilinearly.
fn envelope(pred: &[f32], (gw, gh): (usize, usize)) -> Vec<f32> {
    let at = |a: usize, b: usize| pred[b.min(gh - 1) * gw + a.min(gw - 1)];
    (0..gw * gh)
        .map(|k| {
            let (i, j) = (k % gw, k / gw);
            let (l, u) = (i.saturating_sub(1), j.saturating_sub(1));
            let mut e = 0f32;
            for xs in [[i, i], [l, i], [i, i + 1]] {
                for ys in [[j, j], [u, j], [j, j + 1]] {
                    let v = 0.25 * (at(xs[0], ys[0]) + at(xs[1], ys[0]) + at(xs[0], ys[1]) + at(xs[1], ys[1]));
                    e = e.max((v - pred[k]).abs());
                }
            }
            e
        })
        .collect()
}

/// A hypothesis's silhouette (its cells of the support above [`tuning::SILHOUETTE`] of its
/// peak) and its rim (the cells outside the silhouette next to it, each with a neighbour inside).
struct Shape {
    inside: Vec<u32>,
    rim: Vec<(u32, u32)>,
}

impl Shape {
    fn new(pred: &[f32], peak: f32, support: &[u32], (gw, gh): (usize, usize)) -> Shape {
        let silhouette = tuning::SILHOUETTE * peak;
        let on = |i: usize, j: usize| pred[j * gw + i] > silhouette;
        let inside = support.iter().copied().filter(|&k| pred[k as usize] > silhouette).collect();
        let mut rim = Vec::new();
        for j in 0..gh {
            for i in (0..gw).filter(|&i| !on(i, j)) {
                let next = [(i.wrapping_sub(1), j), (i + 1, j), (i, j.wrapping_sub(1)), (i, j + 1)];
                if let Some(&(a, b)) = next.iter().find(|&&(a, b)| a < gw && b < gh && on(a, b)) {
                    rim.push(((j * gw + i) as u32, (b * gw + a) as u32));
                }
            }
        }
        Shape { inside, rim }
    }
}

/// The score of the hypothesis whose cells are `pred` (brightest `peak`, silhouette and rim
/// `shape`) on the window whose cells are `xb`, in the hypothesis's best gain, with theta as the
/// robust fit scores hypotheses ([`tuning::COARSE`] of the mean bright cell):
///
/// - each cell of the silhouette the window explains counts 1 - (r / theta)^2, each it does not
///   -1;
/// - each cell of the rim that the window explains as the silhouette's cell next to it counts
///   -(1 - (r / theta)^2): the object ends where the hypothesis ends, and a window whose scene
///   goes on like the object past the silhouette's edge is inside something larger (a part of
///   the object, a stretch of flat clutter), not on the object;
/// - the sum over the silhouette's cells: the share of the silhouette explained, so that a view
///   whose object fills more of its frame (and so more cells) does not outscore one that fills
///   less by explaining a part of the object at a smaller scale (a cup's bowl alone, from a view
///   where its handle hides, fits the bowl of a view whose handle shows).
///
/// Cells the hypothesis leaves dark count nothing otherwise: the training views' backdrop is
/// not the scene's, and dark clutter explaining it would outscore the object. None (minus
/// infinity) for a hypothesis the window cannot scale or with no silhouette.
///
/// With the hypothesis's `envelope` ([`envelope`]), also the score with each silhouette cell's
/// residual taken beyond the envelope's band around the hypothesis (the score of the best
/// window up to half a cell away, nearly); without, the score twice.
fn silhouette_score(pred: &[f32], peak: f32, support: &[u32], shape: &Shape, envelope: Option<&[f32]>, xb: &[f32], ratios: &mut Vec<f32>) -> [f32; 2] {
    if shape.inside.is_empty() {
        return [f32::NEG_INFINITY; 2];
    }
    let Some((gain, scale, _)) = gain(pred, peak, support, xb, ratios) else { return [f32::NEG_INFINITY; 2] };
    let theta = tuning::COARSE * scale;
    let count = |r: f32| if r < 1.0 { 1.0 - r * r } else { -1.0 };
    let (mut score, mut loose) = (0f32, 0f32);
    match envelope {
        Some(e) => {
            // The plain score divides as the levels without envelopes do (the same bits).
            let inv = 1.0 / theta;
            for &i in &shape.inside {
                let d = (xb[i as usize] - gain * pred[i as usize]).abs();
                score += count(d / theta);
                loose += count((d - gain * e[i as usize]).max(0.0) * inv);
            }
        }
        None => {
            for &i in &shape.inside {
                score += count((xb[i as usize] - gain * pred[i as usize]).abs() / theta);
            }
            loose = score;
        }
    }
    for &(out, next) in &shape.rim {
        let r = (xb[out as usize] - gain * pred[next as usize]).abs() / theta;
        if r < 1.0 {
            score -= 1.0 - r * r;
            loose -= 1.0 - r * r;
        }
    }
    let n = shape.inside.len() as f32;
    [score / n, loose / n]
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A 16 x 16 hypothesis: a shaded square on cells 4..12, dark elsewhere.
    fn square() -> (Vec<f32>, Vec<u32>) {
        let pred = (0..256).map(|k| if (4..12).contains(&(k % 16)) && (4..12).contains(&(k / 16)) { 0.5 + 0.05 * (k % 16) as f32 } else { 0.0 }).collect();
        (pred, (0..256).collect())
    }

    #[test]
    fn the_score_is_the_share_of_the_silhouette_explained_less_a_rim_that_goes_on_like_the_object() {
        let (pred, support) = square();
        let shape = Shape::new(&pred, 1.05, &support, (16, 16));
        assert_eq!(shape.inside.len(), 64);
        assert_eq!(shape.rim.len(), 32);
        let mut ratios = Vec::new();
        // The object (twice as bright) on a backdrop that explains nothing of it.
        let on_object: Vec<f32> = pred.iter().map(|&p| if p > 0.0 { 2.0 * p } else { 0.0 }).collect();
        let object = silhouette_score(&pred, 1.05, &support, &shape, None, &on_object, &mut ratios)[0];
        assert!((object - 1.0).abs() < 1e-6, "{object}");
        // The same, inside something larger: past the square's edge the scene goes on as its
        // edge cells are (a window on a part of a larger object, or on flat clutter).
        let mut inside_more = on_object.clone();
        for &(out, next) in &shape.rim {
            inside_more[out as usize] = on_object[next as usize];
        }
        let part = silhouette_score(&pred, 1.05, &support, &shape, None, &inside_more, &mut ratios)[0];
        assert!((part - 0.5).abs() < 1e-6, "{part}: 32 rim cells of 64 count against");
        // A quarter of the silhouette hidden (the gain still the object's): 48 cells count 1, 16
        // count -1.
        let mut hidden = on_object.clone();
        for &k in shape.inside.iter().take(16) {
            hidden[k as usize] = 10.0;
        }
        let quarter = silhouette_score(&pred, 1.05, &support, &shape, None, &hidden, &mut ratios)[0];
        assert!((quarter - 0.5).abs() < 1e-6, "{quarter}");
        // A hypothesis with no silhouette scores nothing.
        let dark = vec![0f32; 256];
        let none = Shape::new(&dark, 0.0, &support, (16, 16));
        assert_eq!(silhouette_score(&dark, 0.0, &support, &none, None, &on_object, &mut ratios), [f32::NEG_INFINITY; 2]);
    }

    #[test]
    fn a_window_half_a_cell_off_the_object_reads_within_the_envelope() {
        // A hypothesis of smooth shading on a 16 x 16 grid, and the window half a cell off it
        // both ways: each of its cells the mean of four of the hypothesis's (bilinear at the
        // corner), which scores low on the point values and whole within the envelope.
        let (pred, support) = square();
        let (gw, gh) = (16, 16);
        let env = envelope(&pred, (gw, gh));
        let at = |a: usize, b: usize| pred[b.min(gh - 1) * gw + a.min(gw - 1)];
        let off: Vec<f32> =
            (0..gw * gh).map(|k| 0.25 * (at(k % gw, k / gw) + at(k % gw + 1, k / gw) + at(k % gw, k / gw + 1) + at(k % gw + 1, k / gw + 1))).collect();
        for (k, (&v, &e)) in off.iter().zip(&env).enumerate() {
            assert!((v - pred[k]).abs() <= e, "cell {k}: {v} more than {e} from {}", pred[k]);
        }
        let shape = Shape::new(&pred, 1.05, &support, (gw, gh));
        let mut ratios = Vec::new();
        let [score, loose] = silhouette_score(&pred, 1.05, &support, &shape, Some(&env), &off, &mut ratios);
        assert!(loose > score, "{loose} against {score}");
        // On the object itself both read the same.
        let [a, b] = silhouette_score(&pred, 1.05, &support, &shape, Some(&env), &pred, &mut ratios);
        assert_eq!(a, b);
    }
}
