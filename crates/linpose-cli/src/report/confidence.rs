//! The report's confidence section: for every method run, how often its estimates were flagged
//! (confidence under the threshold) and how many of its gross errors were among them, as a
//! table, a finding and a figure of error against confidence.

use super::doc::{Block, FigureData};
use super::{f, pct, plots};
use crate::study::{ObjectResult, Run};
use linpose::confidence::{FLAG_BELOW, GROSS_DEG};
use linpose::eval::ConfidenceSummary;

/// The methods in the results, in the order they first appear.
fn methods_run<'a>(objects: impl Iterator<Item = &'a ObjectResult>) -> Vec<&'a str> {
    let mut out: Vec<&str> = Vec::new();
    for r in objects.flat_map(|o| o.runs.iter()) {
        if !out.contains(&r.method.as_str()) {
            out.push(&r.method);
        }
    }
    out
}

/// The noise levels of an object's runs, smallest first.
fn noises_run(o: &ObjectResult) -> Vec<f64> {
    let mut v: Vec<f64> = o.runs.iter().map(|r| r.noise).filter(|a| a.is_finite()).collect();
    v.sort_by(f64::total_cmp);
    v.dedup();
    v
}

/// The counts behind a confidence summary: views, flagged, gross errors, gross errors flagged.
fn confidence_counts(c: &ConfidenceSummary) -> (usize, usize, usize, usize) {
    (c.n, c.flagged, c.gross, c.gross_flagged)
}

/// A share as a percentage with one decimal ("-" when not a number).
fn percent(share: f64) -> String {
    if share.is_finite() {
        format!("{:.1}%", 100.0 * share)
    } else {
        "-".into()
    }
}

/// "k of n (x%)", or "none" when there is nothing to count.
fn caught(k: usize, n: usize) -> String {
    if n == 0 {
        "none".into()
    } else {
        format!("{} ({k} of {n})", percent(k as f64 / n as f64))
    }
}

/// The (confidence, error) points of a run over the views its confidence summary covers (the
/// unseen ones, or all when every view was a training view).
fn confidence_points(r: &Run) -> Vec<(f64, f64)> {
    let unseen_only = r.confidence.as_ref().is_none_or(|c| c.over == "unseen") && r.seen.iter().any(|&s| !s);
    r.confidences.iter().zip(&r.errors).zip(&r.seen).filter(|(_, &seen)| !(unseen_only && seen)).map(|((&c, &e), _)| (c, e)).collect()
}

/// The confidence's section: what it is, a table of how well it tells the gross errors of every
/// run with one, and the figure of error against confidence.
pub(super) fn confidence_section(b: &mut Vec<Block>, objects: &[ObjectResult]) -> Result<(), String> {
    let mut rows = Vec::new();
    for o in objects {
        for a in noises_run(o) {
            for r in o.runs.iter().filter(|r| r.noise == a) {
                let Some(c) = &r.confidence else { continue };
                let (n, flagged, gross, gross_flagged) = confidence_counts(c);
                rows.push(vec![
                    o.name.clone(),
                    pct(a),
                    r.method.clone(),
                    if c.over == "unseen" { n.to_string() } else { format!("{n} ({} views)", c.over) },
                    format!("{} ({gross})", percent(c.gross_share)),
                    format!("{} ({flagged})", percent(c.flagged_share)),
                    caught(gross_flagged, gross),
                    percent(c.in_top_share),
                ]);
            }
        }
    }
    if rows.is_empty() {
        return Ok(());
    }
    b.push(Block::Heading(1, "Confidence: does each estimate say when it is unsure?".into()));
    b.push(Block::Para(format!(
        "Every estimate comes with a confidence: its probability of being within {GROSS_DEG} degrees of the truth, as the model judges it from its training views; an estimate whose confidence is under {FLAG_BELOW} is flagged, not to be trusted without a look. A useful confidence flags most gross errors (over {GROSS_DEG} degrees) while flagging few views."
    )));
    b.push(Block::Table(
        ["object", "noise", "method", "unseen views", "gross errors (%)", "flagged (%)", "gross errors flagged (%)", "truth among top hypotheses (%)"]
            .map(String::from)
            .to_vec(),
        rows,
    ));
    b.push(Block::Para(format!(
        "Over the unseen views of each run (all views where every one was a training view), counts in brackets: gross errors are errors over {GROSS_DEG} degrees; flagged views have a confidence under {FLAG_BELOW}; \"gross errors flagged\" is the share of the gross errors that were flagged (none: no gross error to flag); the last column is the share of views whose true pose is within {GROSS_DEG} degrees of one of the top {} hypotheses the model returns, the estimate first (for a method that considers one pose only, the share of views without a gross error).",
        linpose::EvalOptions::new(0.0, 0).top
    )));
    let mut series: Vec<(String, Vec<(f64, f64)>)> = Vec::new();
    for m in methods_run(objects.iter()) {
        let pts: Vec<(f64, f64)> = objects
            .iter()
            .flat_map(|o| o.runs.iter().filter(|r| r.method == m && r.noise == 0.0 && r.confidence.is_some()))
            .flat_map(confidence_points)
            .collect();
        if pts.iter().any(|(c, e)| c.is_finite() && e.is_finite()) {
            series.push((m.to_string(), pts));
        }
    }
    if !series.is_empty() {
        let all = || series.iter().flat_map(|s| s.1.iter()).filter(|(c, e)| c.is_finite() && e.is_finite());
        let quadrant = |low: bool, gross: bool| all().filter(|(c, e)| (*c < FLAG_BELOW) == low && (*e > GROSS_DEG) == gross).count();
        let left_out = series.iter().flat_map(|s| s.1.iter()).count() - all().count();
        let names: Vec<&str> = objects.iter().filter(|o| o.runs.iter().any(|r| r.noise == 0.0 && r.confidence.is_some())).map(|o| o.name.as_str()).collect();
        b.push(Block::Figure {
            file: "confidence-vs-error.svg".into(),
            data: FigureData::Svg(plots::confidence_scatter("Unseen-view error against confidence, clean queries", &series, FLAG_BELOW, GROSS_DEG)?),
            caption: format!(
                "Error against confidence: every unseen view of {}, clean queries, one point per view and colour per method. Left of the vertical line (confidence under {FLAG_BELOW}) the estimate is flagged; above the horizontal one (over {GROSS_DEG} degrees) it is a gross error. All methods together: {} gross errors flagged (upper left), {} gross errors not flagged (upper right), {} good estimates flagged (lower left), {} good estimates not flagged (lower right){}. Errors of zero are drawn on the bottom edge.",
                names.join(", "),
                quadrant(true, true),
                quadrant(false, true),
                quadrant(true, false),
                quadrant(false, false),
                if left_out > 0 { format!("; {left_out} views without a confidence or an error are left out") } else { String::new() }
            ),
        });
    }
    Ok(())
}

/// The confidence's finding, headed `label`: per method, over the unseen views of `objects`,
/// clean and at the largest noise level, the share of views flagged and of gross errors caught
/// (None when no run has a confidence).
pub(super) fn confidence_finding(label: &str, objects: &[&ObjectResult]) -> Option<String> {
    let objects = || objects.iter().copied();
    let noisiest = objects().flat_map(|o| o.runs.iter().map(|r| r.noise)).filter(|a| a.is_finite()).fold(0.0, f64::max);
    let levels: Vec<f64> = if noisiest > 0.0 { vec![0.0, noisiest] } else { vec![0.0] };
    let mut parts = Vec::new();
    for m in methods_run(objects()) {
        let mut texts = Vec::new();
        for &a in &levels {
            let runs: Vec<&Run> = objects().flat_map(|o| o.runs.iter()).filter(|r| r.method == m && r.noise == a && r.confidence.is_some()).collect();
            let (mut n, mut flagged, mut gross, mut gross_flagged) = (0, 0, 0, 0);
            for c in runs.iter().filter_map(|r| r.confidence.as_ref()) {
                let k = confidence_counts(c);
                (n, flagged, gross, gross_flagged) = (n + k.0, flagged + k.1, gross + k.2, gross_flagged + k.3);
            }
            if n == 0 {
                continue;
            }
            let worst = runs.iter().flat_map(|r| confidence_points(r)).filter(|(c, e)| *c >= FLAG_BELOW && e.is_finite()).map(|p| p.1).fold(f64::NAN, f64::max);
            let catch = match gross {
                0 => "makes no gross error".to_string(),
                g => format!("catches {gross_flagged} of its {g} gross errors ({:.0}%)", 100.0 * gross_flagged as f64 / g as f64),
            };
            let worst = if worst.is_finite() { format!(", its worst unflagged error {} degrees", f(worst, 1)) } else { String::new() };
            let who = if a == 0.0 { m.to_string() } else { format!("with {} noise it", pct(a)) };
            texts.push(format!("{who} flags {} of {n} views and {catch}{worst}", percent(flagged as f64 / n as f64)));
        }
        if !texts.is_empty() {
            parts.push(texts.join("; "));
        }
    }
    if parts.is_empty() {
        return None;
    }
    Some(format!(
        "**{label}.** Flagging the estimates with a confidence under {FLAG_BELOW}, over the unseen views of {}, clean queries unless said: {}. A gross error is one over {GROSS_DEG} degrees.",
        objects().map(|o| o.name.as_str()).collect::<Vec<_>>().join(", "),
        parts.join(". ")
    ))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn confidence_cells_say_none_for_no_gross_error_and_dash_for_not_a_number() {
        assert_eq!(caught(0, 0), "none");
        assert_eq!(caught(2, 3), "66.7% (2 of 3)");
        assert_eq!(percent(f64::NAN), "-");
    }
}
