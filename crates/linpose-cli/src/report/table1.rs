//! The report's Table 1 figure: each method's storage (and time per query) against its training
//! views N on log-log axes, with one, two and three pose parameters, beside the paper's formulas
//! (M K for the linear model, N L + M L for the eigenspace) evaluated with each model's own
//! terms; and what it shows, in numbers: how storage grows with N and how many times the
//! eigenspace's the linear model's is.

use super::doc::{Block, FigureData};
use super::plots::{self, LogPanel, LogRow, LogSeries};
use super::three_params::bytes;
use super::{f, StudyInfo};
use crate::study::table1::SizePoint;
use linpose::model::Origin;

/// The methods of `points`, in order of first appearance.
fn methods(points: &[SizePoint]) -> Vec<&str> {
    let mut v: Vec<&str> = Vec::new();
    for p in points {
        if !v.contains(&p.method.as_str()) {
            v.push(&p.method);
        }
    }
    v
}

/// The pose-parameter counts of `points`, smallest first.
fn dims(points: &[SizePoint]) -> Vec<usize> {
    let mut d: Vec<usize> = points.iter().map(|p| p.params).collect();
    d.sort_unstable();
    d.dedup();
    d
}

/// The method of `origin` among `points`.
fn of_origin(points: &[SizePoint], origin: Origin) -> Option<&str> {
    methods(points).into_iter().find(|m| linpose::Method::from_name(m).is_ok_and(|x| x.origin == origin))
}

/// The least-squares slope of ln y on ln x (None with fewer than two distinct x).
fn loglog_slope(pts: &[(f64, f64)]) -> Option<f64> {
    let v: Vec<(f64, f64)> = pts.iter().filter(|(x, y)| *x > 0.0 && *y > 0.0).map(|(x, y)| (x.ln(), y.ln())).collect();
    let n = v.len() as f64;
    let (mx, my) = (v.iter().map(|p| p.0).sum::<f64>() / n, v.iter().map(|p| p.1).sum::<f64>() / n);
    let sxx: f64 = v.iter().map(|p| (p.0 - mx).powi(2)).sum();
    (v.len() >= 2 && sxx > 1e-12).then(|| v.iter().map(|p| (p.0 - mx) * (p.1 - my)).sum::<f64>() / sxx)
}

/// The points of method `m` with `d` parameters, fewest training views first.
fn series<'a>(points: &'a [SizePoint], d: usize, m: &str) -> Vec<&'a SizePoint> {
    let mut v: Vec<&SizePoint> = points.iter().filter(|p| p.params == d && p.method == m).collect();
    v.sort_by_key(|p| p.n_train);
    v
}

/// "one pose parameter", "two pose parameters", ...
fn params_words(d: usize) -> String {
    let n = ["one", "two", "three", "four"].get(d.wrapping_sub(1)).map_or(d.to_string(), |s| s.to_string());
    format!("{n} pose parameter{}", if d == 1 { "" } else { "s" })
}

/// What the eigenspace's N is across its points of `d` parameters: the training views (its knots)
/// or its dense lattice's points whatever the training set.
fn baseline_n(points: &[&SizePoint]) -> Option<String> {
    let n: Vec<usize> = points.iter().filter_map(|p| p.cost.terms.iter().find(|t| t.0 == "N").map(|t| t.1)).collect();
    if n.is_empty() || n.len() != points.len() {
        return None;
    }
    if points.iter().zip(&n).all(|(p, &k)| k == p.n_train) {
        Some("N is the training views".into())
    } else if n.iter().all(|&k| k == n[0]) {
        Some(format!("N is its lattice's {} points whatever the training set", n[0]))
    } else {
        Some(format!("N runs from {} to {}", n.iter().min()?, n.iter().max()?))
    }
}

/// Per parameter count: how storage grows with N and the eigenspace's storage against the linear
/// model's at the most training views both were fitted on.
fn growth(points: &[SizePoint]) -> Vec<String> {
    let (paper, base) = (of_origin(points, Origin::Paper), of_origin(points, Origin::Baseline));
    dims(points)
        .into_iter()
        .map(|d| {
            let slopes: Vec<String> = methods(points)
                .into_iter()
                .filter_map(|m| {
                    let s = series(points, d, m);
                    loglog_slope(&s.iter().map(|p| (p.n_train as f64, p.cost.model_bytes as f64)).collect::<Vec<_>>())
                        .map(|k| format!("{m} N^{}", f(if k.abs() < 0.005 { 0.0 } else { k }, 2)))
                })
                .collect();
            let (lo, hi) = points.iter().filter(|p| p.params == d).fold((usize::MAX, 0), |(a, b), p| (a.min(p.n_train), b.max(p.n_train)));
            let mut text = format!("{} (N {lo} to {hi}): storage grows as {}", params_words(d), slopes.join(", "));
            if let (Some(pm), Some(bm)) = (paper, base) {
                let (ps, bs) = (series(points, d, pm), series(points, d, bm));
                if let Some(bp) = bs.iter().rev().find(|b| ps.iter().any(|p| p.n_train == b.n_train)) {
                    let pp = ps.iter().find(|p| p.n_train == bp.n_train).expect("found above");
                    text.push_str(&format!(
                        "; at N = {}, the {bm} stores {} and the {pm} model {}, {:.1} times fewer",
                        bp.n_train,
                        bytes(bp.cost.model_bytes),
                        bytes(pp.cost.model_bytes),
                        bp.cost.model_bytes as f64 / pp.cost.model_bytes.max(1) as f64
                    ));
                }
                if let Some(n) = baseline_n(&bs) {
                    text.push_str(&format!(" (the {bm}'s {n})"));
                }
            }
            text
        })
        .collect()
}

/// The finding: the eigenspace's storage against the linear model's across the figure (None
/// without both).
pub(super) fn table1_finding(points: &[SizePoint]) -> Option<String> {
    let (pm, bm) = (of_origin(points, Origin::Paper)?, of_origin(points, Origin::Baseline)?);
    let mut ratios = Vec::new();
    for d in dims(points) {
        for b in series(points, d, bm) {
            if let Some(p) = series(points, d, pm).into_iter().find(|p| p.n_train == b.n_train) {
                ratios.push((d, b.cost.model_bytes as f64 / p.cost.model_bytes.max(1) as f64));
            }
        }
    }
    if ratios.is_empty() {
        return None;
    }
    let per: Vec<String> = dims(points)
        .into_iter()
        .filter_map(|d| {
            let r: Vec<f64> = ratios.iter().filter(|x| x.0 == d).map(|x| x.1).collect();
            let (lo, hi) = r.iter().fold((f64::INFINITY, 0.0f64), |(a, b), &x| (a.min(x), b.max(x)));
            (!r.is_empty()).then(|| format!("{} {}x to {}x", params_words(d), f(lo, 1), f(hi, 1)))
        })
        .collect();
    let fewer = ratios.iter().all(|r| r.1 > 1.0);
    Some(format!(
        "**Table 1 against N.** {} The {bm} stores this many times the {pm} model's bytes on the same training views: {}.",
        if fewer {
            format!("The {pm} model stores fewer bytes than the {bm} at every training-set size measured, with one, two and three pose parameters.")
        } else {
            format!("The {pm} model does not store fewer bytes than the {bm} at every training-set size measured.")
        },
        per.join("; ")
    ))
}

/// `v` microseconds in words on an axis.
fn us(v: f64) -> String {
    if v >= 1000.0 {
        format!("{} ms", f(v / 1000.0, if v >= 1e4 { 0 } else { 1 }))
    } else {
        format!("{} us", f(v, if v >= 10.0 { 0 } else { 1 }))
    }
}

/// `v` bytes in words on an axis.
fn axis_bytes(v: f64) -> String {
    match v {
        _ if v >= 1e6 => format!("{} MB", f(v / 1e6, if v >= 1e7 { 0 } else { 1 })),
        _ if v >= 1e3 => format!("{} kB", f(v / 1e3, if v >= 1e4 { 0 } else { 1 })),
        _ => format!("{} B", f(v, 0)),
    }
}

/// The subsection: the figure and what it shows (nothing without points).
pub(super) fn table1_figure(b: &mut Vec<Block>, info: &StudyInfo) -> Result<(), String> {
    let points = &info.table1_sizes;
    if points.is_empty() {
        return Ok(());
    }
    let ms = methods(points);
    let color = |m: &str| info.methods.iter().position(|x| x == m).unwrap_or(ms.iter().position(|x| *x == m).unwrap_or(0));
    let timed = points.iter().any(|p| p.cost.per_query_us > 0.0);
    let panel = |d: usize, time: bool| {
        let mut s = Vec::new();
        for &m in &ms {
            let pts = series(points, d, m);
            let y = |p: &SizePoint| if time { p.cost.per_query_us } else { p.cost.model_bytes as f64 };
            s.push(LogSeries {
                name: format!("{m} (measured)"),
                points: pts.iter().map(|p| (p.n_train as f64, y(p))).collect(),
                color: color(m),
                dashed: false,
            });
            if !time && pts.iter().all(|p| p.paper_numbers().is_some()) && !pts.is_empty() {
                let formula = linpose::Method::from_name(m).map_or("", |x| if x.origin == Origin::Paper { "M K" } else { "N L + M L" });
                s.push(LogSeries {
                    name: format!("{m}: the paper's {formula}"),
                    points: pts.iter().filter_map(|p| p.paper_numbers().map(|n| (p.n_train as f64, 4.0 * n as f64))).collect(),
                    color: color(m),
                    dashed: true,
                });
            }
        }
        let k = series(points, d, ms[0]).first().and_then(|p| p.cost.terms.iter().find(|t| t.0 == "K").map(|t| t.1));
        let title = match (k, of_origin(points, Origin::Paper) == Some(ms[0])) {
            (Some(k), true) => format!("{} (K = {k})", params_words(d)),
            _ => params_words(d),
        };
        LogPanel { title, series: s }
    };
    let ds = dims(points);
    let mut rows = vec![LogRow { y_desc: "model bytes".into(), unit: axis_bytes, panels: ds.iter().map(|&d| panel(d, false)).collect() }];
    if timed {
        rows.push(LogRow { y_desc: "time per query".into(), unit: us, panels: ds.iter().map(|&d| panel(d, true)).collect() });
    }
    b.push(Block::Heading(2, "Table 1 against the number of training views".into()));
    let objects: Vec<String> = ds
        .iter()
        .map(|&d| {
            let o = points.iter().find(|p| p.params == d).map_or("", |p| p.object.as_str());
            let how = match d {
                1 => "the lowest elevation's ring of views, azimuth alone, at each step of the size sweep",
                2 => "the size sweep's training sets",
                _ => "sub-lattices of the three-parameter section's training lattice, its azimuth thinned",
            };
            format!("{} on {o} ({how})", params_words(d))
        })
        .collect();
    b.push(Block::Para(format!(
        "Every method fitted on nested training sets: {}. Storage is the bytes each model serves queries from (points) beside the paper's formulas evaluated with the model's own terms at 4 bytes a number (dashed): M K for the linear model, N L + M L for the eigenspace, whose N is the manifold's points: its dense lattice's with one and two parameters, the training views (the knots) with three. The measured bytes exceed the formula by what the paper's count leaves out (the second look's numbers; with three parameters the surface's slopes and the search's start points). {} By parameter count, {}.",
        objects.join("; "),
        if timed { "Time per query: the wall time of estimating the object's views, batched, divided by their number, on 2 cores (two parameters: every view, once; one: every view of the ring, and three: the unseen views inside the training range, the least of a few runs)." } else { "Times were not recorded (`--no-timings`)." },
        growth(points).join("; ")
    )));
    b.push(Block::Figure {
        file: "table1-storage-vs-training-views.svg".into(),
        data: FigureData::Svg(plots::loglog_grid("training views N", &rows)?),
        caption: format!(
            "Table 1 against N: model bytes{} against the training views, log-log, one panel per number of pose parameters; points measured, dashed lines the paper's formulas with each model's own terms.",
            if timed { " (top) and time per query (bottom)" } else { "" }
        ),
    });
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_slope_of_a_power_law_is_its_exponent() {
        let pts: Vec<(f64, f64)> = [10.0, 20.0, 40.0].iter().map(|&x: &f64| (x, 3.0 * x.powf(1.5))).collect();
        assert!((loglog_slope(&pts).unwrap() - 1.5).abs() < 1e-9);
        assert_eq!(loglog_slope(&[(10.0, 1.0)]), None);
        assert_eq!(loglog_slope(&[(10.0, 1.0), (10.0, 2.0)]), None);
    }
}
