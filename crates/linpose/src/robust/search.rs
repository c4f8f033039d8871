//! The hypothesize-and-test search of the robust fit (see the module doc of `robust`): score the
//! hypotheses (the dense lattice of `scan.rs` where the stage has one, else the training views'
//! coefficients), each in the gain that fits the query best; refine the best (without a lattice,
//! the best few) by re-solving on their explained pixels with a tightening threshold; keep the
//! best. A hypothesis's score is a description length in pixels: the binned pixels it explains,
//! less its own object's pixels it leaves unexplained (on the lattice each pixel weighed by its
//! neighbourhood, `coherence.rs`; after the re-solves, each explained pixel counts
//! 1 - (r / theta)^2, so a closer fit scores higher). Without that penalty a wide silhouette
//! (a car seen from the side) "explains" background of the object's brightness and wins over the
//! right, narrower pose: on COIL-20 objects 1-6 in texture scenes (20% hidden, refined) the
//! penalty took objects 3 and 6, toy cars, from 37 and 46 degrees to 9.4 and 18. Everything runs
//! on the stage's support (the binned pixels where the model has energy): elsewhere no
//! coefficient changes the reconstruction.

use super::scan::Lattice;
use super::{coherence, tuning, Fit, Stage};

/// The best refined hypothesis so far.
struct Best {
    score: f64,
    coef: Vec<f64>,
    inlier: Vec<bool>,
    scale: f32,
    /// The object's bright binned pixels (the lattice view's, or the reconstruction's), and how
    /// many of them are explained.
    object: usize,
    seen: usize,
    /// The lattice hypothesis's pose (None without a lattice).
    pose: Option<Vec<f64>>,
}

/// The first pass of the robust fit of one query on one stage: every hypothesis scored in its
/// own gain.
pub(crate) struct Coarse {
    /// Per hypothesis scored, best first: (its score, the explained binned pixels less the
    /// missed as [`score`] weighs them; the hypothesis; its gain; its mean bright pixel in that
    /// gain).
    scored: Vec<(f32, usize, f32, f32)>,
    /// The largest share of a hypothesis's bright binned pixels that the query matches within
    /// the coarse threshold: how much of the stage's object the query shows at best, whatever
    /// else it shows. Many objects' stages compare by it (`crate::recognize`'s robust stage).
    pub(crate) share: f64,
    /// Whether the hypotheses are the stage's lattice (`scan.rs`).
    lattice: bool,
}

/// The hypotheses' binned images laid out for the first pass: each one's values on the stage's
/// support, one hypothesis after another, and its bright pixels (at least [`tuning::BRIGHT`] of
/// its brightest), so that the pass reads contiguous arrays and the median gain reads only the
/// bright pixels. Made with the stage.
#[derive(Debug, Clone)]
pub(crate) struct Table {
    /// H x S: hypothesis h's value at the support's j-th pixel.
    values: Vec<f32>,
    /// Per hypothesis, its bright pixels (positions in the support), one after another.
    bright: Vec<u32>,
    /// Where each hypothesis's bright pixels start in `bright` (H + 1 values).
    starts: Vec<usize>,
    /// Per hypothesis, the sum of its bright pixels (in the support's order).
    sums: Vec<f32>,
}

impl Coarse {
    /// The best hypothesis's score.
    pub(crate) fn top(&self) -> Option<f32> {
        self.scored.first().map(|v| v.0)
    }
}

impl Table {
    /// The table of the hypotheses' binned images `preds` (H x M_b) of brightest `peaks` on
    /// `support`.
    pub(crate) fn new(preds: &[f32], peaks: &[f32], support: &[u32]) -> Table {
        let mb = preds.len() / peaks.len().max(1);
        let (mut values, mut bright, mut starts, mut sums) = (Vec::with_capacity(peaks.len() * support.len()), Vec::new(), vec![0], Vec::new());
        for (pred, &peak) in preds.chunks_exact(mb.max(1)).zip(peaks) {
            let level = tuning::BRIGHT * peak;
            let mut sum = 0f32;
            for (j, &i) in support.iter().enumerate() {
                let p = pred[i as usize];
                values.push(p);
                if p > level {
                    bright.push(j as u32);
                    sum += p;
                }
            }
            starts.push(bright.len());
            sums.push(sum);
        }
        Table { values, bright, starts, sums }
    }

    /// H x S: each hypothesis's values on the support.
    #[cfg(test)]
    pub(crate) fn values(&self) -> &[f32] {
        &self.values
    }

    /// Hypothesis `h`'s bright pixels (positions in the support).
    pub(crate) fn bright(&self, h: usize) -> &[u32] {
        &self.bright[self.starts[h]..self.starts[h + 1]]
    }
}

/// Scores every hypothesis of `stage` on the binned query `xb` (the first pass of [`fit`]): the
/// dense lattice of views where the stage has one (`scan.rs`), else the training views'
/// coefficients.
pub(super) fn coarse(stage: &Stage, xb: &[f32]) -> Coarse {
    coarse_on(stage, xb, stage.lattice.as_ref())
}

/// [`coarse`] on the dense lattice `lattice` in place of the stage's own.
pub(super) fn coarse_on(stage: &Stage, xb: &[f32], lattice: Option<&Lattice>) -> Coarse {
    match lattice {
        Some(l) => {
            let (scored, share) = score(stage, xb, &l.table, &l.peaks, Some(tuning::SCAN));
            Coarse { scored, share, lattice: true }
        }
        None => {
            let (scored, share) = score(stage, xb, &stage.table, &stage.peaks, None);
            Coarse { scored, share, lattice: false }
        }
    }
}

/// Every hypothesis of `table` (brightest values `peaks`) scored on the binned query `xb`, best
/// first, each in the gain that fits the query best: the pixels it explains within
/// [`tuning::COARSE`] of its mean bright pixel less its bright pixels it leaves unexplained; or,
/// with `tight`, the same within `tight` of it, each pixel weighed by its neighbourhood
/// (`coherence.rs`). With the largest share of a hypothesis's bright pixels matched within
/// [`tuning::COARSE`] (`Coarse::share`).
fn score(stage: &Stage, xb: &[f32], table: &Table, peaks: &[f32], tight: Option<f32>) -> (Vec<(f32, usize, f32, f32)>, f64) {
    let s = stage.support.len();
    let width = stage.binning.spec().width as usize;
    let xs: Vec<f32> = stage.support.iter().map(|&i| xb[i as usize]).collect();
    let mut scored: Vec<(f32, usize, f32, f32)> = Vec::new();
    let mut share = 0f64;
    let (mut ratios, mut rows) = (Vec::new(), Vec::new());
    let (mut ok, mut near) = (vec![false; xb.len()], vec![0u8; xb.len()]);
    for (h, ps) in table.values.chunks_exact(s.max(1)).enumerate() {
        let bright = table.bright(h);
        ratios.clear();
        ratios.extend(bright.iter().map(|&j| xs[j as usize] / ps[j as usize]));
        let Some(gain) = median_gain(&mut ratios) else { continue };
        let count = bright.len();
        let scale = gain * table.sums[h] / count as f32;
        let level = tuning::BRIGHT * peaks[h];
        let theta = tuning::COARSE * scale;
        let (value, matched) = match tight {
            None => {
                let (mut explained, mut missed, mut matched) = (0u32, 0u32, 0u32);
                for (&x, &p) in xs.iter().zip(ps) {
                    let ok = (x - gain * p).abs() < theta;
                    let lit = p > level;
                    explained += ok as u32;
                    missed += (!ok && lit) as u32;
                    matched += (ok && lit) as u32;
                }
                (explained as f32 - missed as f32, matched)
            }
            Some(t) => {
                let tight = t * scale;
                // Beyond the support the hypothesis is dark.
                ok.iter_mut().zip(xb).for_each(|(o, &x)| *o = x.abs() < tight);
                let mut matched = 0u32;
                for ((&x, &p), &i) in xs.iter().zip(ps).zip(&stage.support) {
                    let r = (x - gain * p).abs();
                    ok[i as usize] = r < tight;
                    matched += (r < theta && p > level) as u32;
                }
                coherence::neighbourhood(&ok, width, &mut near, &mut rows);
                let explained: u32 = ok.iter().zip(&near).map(|(&o, &n)| o as u32 * n as u32).sum();
                let missed: u32 = ps.iter().zip(&stage.support).filter(|(&p, &i)| p > level && !ok[i as usize]).map(|(_, &i)| near[i as usize] as u32).sum();
                ((explained as f32 - missed as f32) / 9.0, matched)
            }
        };
        share = share.max(matched as f64 / count as f64);
        scored.push((value, h, gain, scale));
    }
    scored.sort_by(|a, b| b.0.total_cmp(&a.0).then(a.1.cmp(&b.1)));
    (scored, share)
}

/// The robust fit of the binned query `xb` on `stage`, its first pass `coarse` done. The best
/// few training views are refined and the best refined kept; the lattice's best (`scan.rs`)
/// is refined alone, the scan having scored the details the refine's reconstruction blurs.
pub(super) fn fit(stage: &Stage, xb: &[f32], coarse: &Coarse) -> Fit {
    fit_on(stage, xb, coarse, stage.lattice.as_ref())
}

/// [`fit`] from a first pass on `lattice` ([`coarse_on`]).
pub(super) fn fit_on(stage: &Stage, xb: &[f32], coarse: &Coarse, lattice: Option<&Lattice>) -> Fit {
    let anneal = &tuning::ANNEAL;
    let k = stage.settings.rows;
    let mb = xb.len();
    let lattice = lattice.filter(|_| coarse.lattice);
    // 2. Refine the best few; 3. keep the best scored.
    let mut best: Option<Best> = None;
    for &(_, h, gain, scale) in coarse.scored.iter().take(if lattice.is_some() { 1 } else { tuning::REFINED }) {
        let start = match lattice {
            Some(l) => l.coef(h),
            None => &stage.hyps[h * k..(h + 1) * k],
        };
        let mut coef: Vec<f64> = start.iter().map(|&v| (v * gain) as f64).collect();
        let mut inlier = vec![false; mb];
        let mut score = 0.0;
        for (it, &share) in anneal.iter().enumerate() {
            let (count, fit) = mark(stage, xb, &coef, share * scale, &mut inlier);
            score = fit;
            if it + 1 == anneal.len() || count < 2 * k {
                break;
            }
            match solve_on(stage, xb, &inlier) {
                Some(c) => coef = c,
                None => break,
            }
        }
        // How much of the object the query shows: of the lattice view's bright pixels (the
        // whole object at its pose), or else of the reconstruction's, which the re-solves
        // shape to the pixels seen.
        let (object, seen) = match lattice {
            Some(l) => l.seen(h, &stage.support, &inlier),
            None => object_seen(stage, &coef, &inlier, scale),
        };
        let score = score - (object - seen) as f64;
        if best.as_ref().is_none_or(|b| score > b.score) {
            let pose = lattice.map(|l| l.pose(h).to_vec());
            best = Some(Best { score, coef, inlier, scale, object, seen, pose });
        }
    }
    let Some(Best { coef, inlier, scale, object, seen, pose, .. }) = best else {
        // No hypothesis has a bright pixel the query can scale: the least-squares fit on all.
        let all = vec![true; mb];
        let coef = solve_on(stage, xb, &all).unwrap_or_else(|| vec![0.0; k]);
        return Fit { coef, inlier: all, shown: 0.0, theta: 0.0, pose: None };
    };
    let shown = if object == 0 { 0.0 } else { seen as f64 / object as f64 };
    Fit { coef, inlier, shown, theta: tuning::ANNEAL[tuning::ANNEAL.len() - 1] * scale, pose }
}

/// The gain in which the hypothesis whose binned image is `pred` (brightest `peak`) fits the
/// binned query `xb` best, the median ratio of query to hypothesis over the hypothesis's bright
/// pixels of the `support` ([`tuning::BRIGHT`] of its peak), and its mean bright pixel in that
/// gain, and the count of those pixels. None when it has no bright pixel, or the query is dark
/// there. `ratios` is scratch.
pub(super) fn gain(pred: &[f32], peak: f32, support: &[u32], xb: &[f32], ratios: &mut Vec<f32>) -> Option<(f32, f32, usize)> {
    let bright = tuning::BRIGHT * peak;
    ratios.clear();
    let (mut sum, mut count) = (0f32, 0usize);
    for &i in support {
        let p = pred[i as usize];
        if p > bright {
            ratios.push(xb[i as usize] / p);
            sum += p;
            count += 1;
        }
    }
    let gain = median_gain(ratios)?;
    Some((gain, gain * sum / count as f32, count))
}

/// The median of the ratios of query to hypothesis over a hypothesis's bright pixels (reordered
/// in place): the gain that fits the query best; None when there are none or it is not positive.
fn median_gain(ratios: &mut [f32]) -> Option<f32> {
    if ratios.is_empty() {
        return None;
    }
    let mid = ratios.len() / 2;
    let gain = *ratios.select_nth_unstable_by(mid, f32::total_cmp).1;
    (gain > 0.0).then_some(gain)
}

/// Marks the binned pixels the coefficients `coef` explain within `theta` (outside the support:
/// those the query leaves dark); returns the count on the support and their sum of
/// 1 - (r / theta)^2.
fn mark(stage: &Stage, xb: &[f32], coef: &[f64], theta: f32, inlier: &mut [bool]) -> (usize, f64) {
    inlier.iter_mut().zip(xb).for_each(|(v, &x)| *v = x.abs() < theta);
    let c: Vec<f32> = coef.iter().map(|&v| v as f32).collect();
    let (mut count, mut fit) = (0, 0f64);
    for &i in &stage.support {
        let i = i as usize;
        let r: f32 = stage.binned.pixel(i).iter().zip(&c).map(|(&u, &a)| u * a).sum();
        let e = (xb[i] - r).abs() / theta;
        let ok = e < 1.0;
        inlier[i] = ok;
        if ok {
            count += 1;
            fit += 1.0 - (e * e) as f64;
        }
    }
    (count, fit)
}

/// The least-squares coefficients on the support's `inlier` pixels (None when singular).
fn solve_on(stage: &Stage, xb: &[f32], inlier: &[bool]) -> Option<Vec<f64>> {
    let k = stage.settings.rows;
    let mut a = vec![0f64; k * k];
    let mut rhs = vec![0f64; k];
    let mut b64 = vec![0f64; k];
    for &i in &stage.support {
        let i = i as usize;
        if !inlier[i] {
            continue;
        }
        b64.iter_mut().zip(stage.binned.pixel(i)).for_each(|(d, &s)| *d = s as f64);
        let x = xb[i] as f64;
        for r in 0..k {
            let br = b64[r];
            rhs[r] += br * x;
            let row = &mut a[r * k..r * k + r + 1];
            row.iter_mut().zip(&b64[..=r]).for_each(|(v, &bc)| *v += br * bc);
        }
    }
    for r in 0..k {
        for c in 0..r {
            a[c * k + r] = a[r * k + c];
        }
    }
    cholesky_solve(&mut a, k, &mut rhs).then_some(rhs)
}

/// The reconstruction's bright binned pixels (at least [`tuning::BRIGHT`] of `scale`) and how
/// many of them `inlier` marks.
fn object_seen(stage: &Stage, coef: &[f64], inlier: &[bool], scale: f32) -> (usize, usize) {
    let c: Vec<f32> = coef.iter().map(|&v| v as f32).collect();
    let (mut object, mut seen) = (0usize, 0usize);
    for &i in &stage.support {
        let i = i as usize;
        let r: f32 = stage.binned.pixel(i).iter().zip(&c).map(|(&u, &a)| u * a).sum();
        if r > tuning::BRIGHT * scale {
            object += 1;
            seen += inlier[i] as usize;
        }
    }
    (object, seen)
}

/// Solves A x = b in place (A symmetric positive definite, k x k row-major, overwritten by its
/// Cholesky factor; b by x); false when A is not positive definite.
pub(super) fn cholesky_solve(a: &mut [f64], k: usize, b: &mut [f64]) -> bool {
    for j in 0..k {
        let mut d = a[j * k + j];
        for p in 0..j {
            d -= a[j * k + p] * a[j * k + p];
        }
        if !(d > 1e-300) {
            return false;
        }
        let d = d.sqrt();
        a[j * k + j] = d;
        for i in j + 1..k {
            let mut s = a[i * k + j];
            for p in 0..j {
                s -= a[i * k + p] * a[j * k + p];
            }
            a[i * k + j] = s / d;
        }
    }
    for i in 0..k {
        let mut s = b[i];
        for p in 0..i {
            s -= a[i * k + p] * b[p];
        }
        b[i] = s / a[i * k + i];
    }
    for i in (0..k).rev() {
        let mut s = b[i];
        for p in i + 1..k {
            s -= a[p * k + i] * b[p];
        }
        b[i] = s / a[i * k + i];
    }
    true
}

/// The inverse of the symmetric positive definite k x k `a` (row-major); None when singular.
pub(super) fn invert(a: &[f64], k: usize) -> Option<Vec<f64>> {
    let mut inv = vec![0f64; k * k];
    for c in 0..k {
        let mut f = a.to_vec();
        let mut e = vec![0f64; k];
        e[c] = 1.0;
        if !cholesky_solve(&mut f, k, &mut e) {
            return None;
        }
        for r in 0..k {
            inv[r * k + c] = e[r];
        }
    }
    Some(inv)
}
