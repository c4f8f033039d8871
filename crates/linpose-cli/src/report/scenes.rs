//! The report's scenes section: every method, plain and behind the robust stage, on unseen views
//! over the studio backdrop, clutter and pixel noise with a share of the object hidden; its
//! figure (error against the hidden share over clutter), what the stage costs, and the finding.

use super::doc::{Block, FigureData};
use super::three_params::bytes;
use super::{f, plots};
use crate::study::scenes::{Backdrop, Condition, SceneEval, ScenesRow, ScenesStudy};
use crate::study::GROSS_ERROR_DEG;

/// One method under one condition, pooled over the objects.
struct Pooled {
    /// Unseen views in all.
    n: usize,
    /// The mean share hidden as drawn (over the objects' views).
    hidden: f64,
    /// Plain, then robust.
    evals: [PooledEval; 2],
}

/// A model's figures pooled over the objects.
#[derive(Default)]
struct PooledEval {
    mean_deg: f64,
    gross: usize,
    flagged: usize,
    per_query_us: f64,
}

impl PooledEval {
    fn add(&mut self, e: &SceneEval, n: usize) {
        self.mean_deg += e.mean_deg * n as f64;
        self.per_query_us += e.per_query_us * n as f64;
        self.gross += e.gross;
        self.flagged += e.flagged;
    }
}

/// The methods of the study, in the rows' order.
fn methods(s: &ScenesStudy) -> Vec<&str> {
    let mut m: Vec<&str> = Vec::new();
    for r in &s.rows {
        if !m.contains(&r.method.as_str()) {
            m.push(&r.method);
        }
    }
    m
}

/// The objects of the study, in the rows' order.
fn objects(s: &ScenesStudy) -> Vec<&str> {
    let mut o: Vec<&str> = Vec::new();
    for r in &s.rows {
        if !o.contains(&r.object.as_str()) {
            o.push(&r.object);
        }
    }
    o
}

/// `method` under `c`, pooled over the objects (None when no row has it).
fn pooled(s: &ScenesStudy, method: &str, c: &Condition) -> Option<Pooled> {
    let rows: Vec<&ScenesRow> = s.rows.iter().filter(|r| r.method == method && r.condition == *c).collect();
    let n: usize = rows.iter().map(|r| r.n_unseen).sum();
    if rows.is_empty() || n == 0 {
        return None;
    }
    let mut p = Pooled { n, hidden: 0.0, evals: Default::default() };
    for r in rows {
        p.hidden += r.hidden * r.n_unseen as f64;
        p.evals[0].add(&r.plain, r.n_unseen);
        p.evals[1].add(&r.robust, r.n_unseen);
    }
    p.hidden /= n as f64;
    for e in &mut p.evals {
        e.mean_deg /= n as f64;
        e.per_query_us /= n as f64;
    }
    Some(p)
}

/// "20%".
fn share(v: f64) -> String {
    format!("{:.0}%", 100.0 * v)
}

/// The texture condition nearest 20% hidden, the one the finding quotes.
fn quoted(s: &ScenesStudy) -> Option<Condition> {
    s.conditions.iter().filter(|c| c.backdrop == Backdrop::Texture).min_by(|a, b| (a.occlude - 0.2).abs().total_cmp(&(b.occlude - 0.2).abs())).copied()
}

/// The section: the pooled table, the figure, the stages' costs.
pub(super) fn scenes_section(b: &mut Vec<Block>, s: Option<&ScenesStudy>) -> Result<(), String> {
    let Some(s) = s else { return Ok(()) };
    let methods = methods(s);
    let objects = objects(s);
    b.push(Block::Heading(1, "Scenes: clutter and occluders".into()));
    b.push(Block::Para(format!(
        "Every method compares the whole image, so a background that is not the training views' or something in front of the object moves every estimate. Here each method, fitted on the studio views of {} as above, is measured plain and behind the robust stage (`train --robust`, docs/scenes.md) on unseen views ({}) rendered into scenes as `linpose synth --background ... --occlude ...` renders them: on the studio backdrop, over procedural clutter (`texture`) and over pixel noise (`noise`), with a share of the object hidden behind one or two striped occluders (seed {}: each view keeps its background across the shares). The stage is fitted on the same training views, in front of the same plain model.",
        objects.join(", "),
        s.views,
        s.seed
    )));
    let mut rows = Vec::new();
    for c in &s.conditions {
        for m in &methods {
            let Some(p) = pooled(s, m, c) else { continue };
            let [plain, robust] = &p.evals;
            rows.push(vec![
                c.backdrop.name().to_string(),
                share(c.occlude),
                format!("{:.1}%", 100.0 * p.hidden),
                m.to_string(),
                f(plain.mean_deg, 2),
                f(robust.mean_deg, 2),
                format!("{} / {}", plain.gross, robust.gross),
                format!("{} / {}", share_of(plain.flagged, p.n), share_of(robust.flagged, p.n)),
                f(plain.per_query_us, 0),
                f(robust.per_query_us, 0),
            ]);
        }
    }
    let n = pooled_n(s);
    b.push(Block::Table(
        [
            "backdrop",
            "hidden",
            "hidden (drawn)",
            "method",
            "plain",
            "robust",
            "gross, plain / robust",
            "flagged, plain / robust",
            "us per query, plain",
            "us per query, robust",
        ]
        .map(String::from)
        .to_vec(),
        rows,
    ));
    b.push(Block::Para(format!(
        "Unseen mean error in degrees over the {n} views of {} objects pooled; gross: views off by more than {GROSS_ERROR_DEG} degrees; flagged: the share of the views whose confidence is under the flag threshold ({}); time per query: every view of a condition estimated in one batch, the confidence included, on the shared 2-core machine the study ran on. A studio view the stage's check finds explained goes to the method as it is; every other view is fitted robustly and repaired first.",
        objects.len(),
        linpose::confidence::FLAG_BELOW
    )));
    let series: Vec<(String, Vec<(f64, f64)>)> = methods
        .iter()
        .flat_map(|m| {
            [(0, "plain"), (1, "robust")].map(|(k, label)| {
                let pts = s
                    .conditions
                    .iter()
                    .filter(|c| c.backdrop == Backdrop::Texture)
                    .filter_map(|c| pooled(s, m, c).map(|p| (100.0 * c.occlude, p.evals[k].mean_deg)))
                    .collect::<Vec<_>>();
                (format!("{m}, {label}"), pts)
            })
        })
        .filter(|(_, v)| !v.is_empty())
        .collect();
    if !series.is_empty() {
        b.push(Block::Figure {
            file: "scenes-error-vs-hidden.svg".into(),
            data: FigureData::Svg(plots::lines("Unseen mean error over clutter against the share hidden", "share of the object hidden (%)", "unseen mean error (degrees, log scale)", &series, true)?),
            caption: format!(
                "Scenes: the unseen mean error of each method, plain and behind the robust stage, on views over procedural clutter with 0 to {} of the object hidden, pooled over {}.",
                share(s.conditions.iter().filter(|c| c.backdrop == Backdrop::Texture).map(|c| c.occlude).fold(0.0, f64::max)),
                objects.join(", ")
            ),
        });
    }
    let rows: Vec<Vec<String>> = s
        .stages
        .iter()
        .map(|t| vec![t.object.clone(), t.n_train.to_string(), format!("{}x{}", t.size.0, t.size.1), bytes(t.stage_bytes), f(t.fit_s, 2)])
        .collect();
    b.push(Block::Heading(2, "What the robust stage costs".into()));
    b.push(Block::Table(["object", "training views", "size", "stage bytes", "stage fit (s)"].map(String::from).to_vec(), rows));
    b.push(Block::Para(format!(
        "The stage keeps its own eigenspace of the training views (the mean image and its eigenimages, full size) and the training views' coefficients; it depends on the training views alone, so one stage is fitted per object and put in front of every method's model, and a robust model stores the stage's bytes besides the method's. Fitting it computes that eigenspace and, for the check's threshold, one without each of a few training views (wall time on the shared 2 cores). The section took {:.1} s, rendering included.",
        s.total_s
    )));
    Ok(())
}

/// "12.3%" of `k` in `n`.
fn share_of(k: usize, n: usize) -> String {
    format!("{:.1}%", 100.0 * k as f64 / n.max(1) as f64)
}

/// The views of one condition pooled over the objects.
fn pooled_n(s: &ScenesStudy) -> usize {
    let c = s.conditions.first();
    s.rows.iter().filter(|r| Some(&r.condition) == c && Some(r.method.as_str()) == methods(s).first().copied()).map(|r| r.n_unseen).sum()
}

/// The scenes' finding: per method, the error over clutter with a fifth hidden plain and
/// robust, and on studio views; None without a texture condition.
pub(crate) fn scenes_finding(s: &ScenesStudy) -> Option<String> {
    let c = quoted(s)?;
    let studio = s.conditions.iter().find(|c| c.backdrop == Backdrop::Studio && c.occlude == 0.0);
    let parts: Vec<String> = methods(s)
        .iter()
        .filter_map(|m| {
            let p = pooled(s, m, &c)?;
            let mut t = format!(
                "{m} {} -> {} degrees ({} -> {} gross errors of {}; {} us a query robust against {} plain)",
                f(p.evals[0].mean_deg, 1),
                f(p.evals[1].mean_deg, 2),
                p.evals[0].gross,
                p.evals[1].gross,
                p.n,
                f(p.evals[1].per_query_us, 0),
                f(p.evals[0].per_query_us, 0)
            );
            if let Some(q) = studio.and_then(|sc| pooled(s, m, sc)) {
                t.push_str(&format!(", studio views {} -> {}", f(q.evals[0].mean_deg, 2), f(q.evals[1].mean_deg, 2)));
            }
            Some(t)
        })
        .collect();
    if parts.is_empty() {
        return None;
    }
    Some(format!(
        "**Scenes.** Over clutter with {} of the object hidden, unseen mean error plain -> behind the robust stage, pooled over {}: {}.",
        share(c.occlude),
        objects(s).join(", "),
        parts.join("; ")
    ))
}
