//! The report's recognition section: every recogniser on all the study's objects at once, the
//! unknown-object rejection with each object left out in turn, and the pose of the recognised
//! views.

use super::doc::Block;
use super::f;
use crate::study::recognition::RecognitionStudy;

fn pct(v: f64) -> String {
    if v.is_finite() {
        format!("{:.1}%", 100.0 * v)
    } else {
        "-".into()
    }
}

/// The section (nothing when the study did not run it).
/// `left_out_step`: the step of the coarser grid the left-out measure ran on, when not every view.
pub(super) fn recognition_section(b: &mut Vec<Block>, study: Option<&RecognitionStudy>, left_out_step: Option<f64>) {
    let Some(s) = study else { return };
    b.push(Block::Heading(1, "Many objects: which object, then its pose".into()));
    let mut text = format!(
        "All {} objects ({}) at once: a recogniser fitted on every object's training views names the object of each view, and the recognised object's own model gives the pose (Murase & Nayar's order; the paper's linear model takes over \"after object recognition is completed\"). `universal`: Murase & Nayar's universal eigenspace, the nearest object manifold; `linear`: the paper's minimum-norm linear model with one-hot object targets. A view is reported unknown when its distance to the nearest object exceeds the largest distance of that object's own held-out training views, in the recogniser's space and then in that object's own eigenspace; to measure that, each object is left out of training in turn and its views should be reported unknown while the others' unseen views should not.",
        s.objects.len(),
        s.objects.join(", ")
    );
    if let Some(step) = left_out_step {
        text.push_str(&format!(" The left-out measure runs on the views every {step} degrees on each axis, a sample of them (`--full`: every view)."));
    }
    b.push(Block::Para(text));
    let methods: Vec<&str> = s.rows.first().map(|r| r.pose_unseen.iter().map(|p| p.0.as_str()).collect()).unwrap_or_default();
    let mut header: Vec<String> = [
        "recogniser",
        "recognised (all)",
        "recognised (unseen)",
        "unseen reported unknown",
        "left out: reported unknown",
        "left out: others' unseen reported unknown",
    ]
    .map(String::from)
    .to_vec();
    header.extend(methods.iter().map(|m| format!("pose unseen, {m}")));
    header.extend(["fit (s)", "per query (us)", "storage", "bytes"].map(String::from));
    let rows = s
        .rows
        .iter()
        .map(|r| {
            let mut row = vec![
                r.recognizer.clone(),
                pct(r.recognized_all),
                pct(r.recognized_unseen),
                pct(r.false_rejections),
                r.left_out_rejected.map_or("-".into(), pct),
                r.left_out_false.map_or("-".into(), pct),
            ];
            row.extend(r.pose_unseen.iter().map(|p| f(p.1, 2)));
            row.extend([f(r.fit_s, 3), f(r.per_query_us, 1), r.storage.clone(), r.bytes.to_string()]);
            row
        })
        .collect();
    b.push(Block::Table(header, rows));
    b.push(Block::Para(
        "Pose errors: unseen mean in degrees over the views recognised as their own object. Per query: the recognition alone, batched. Storage: the recogniser's, in Table 1's terms (N_dense manifold points, L dimensions, M pixels, K objects).".into(),
    ));
}

/// The recognition finding (None when the study did not run it).
pub(super) fn recognition_finding(study: Option<&RecognitionStudy>) -> Option<String> {
    let s = study?;
    let parts: Vec<String> = s
        .rows
        .iter()
        .map(|r| {
            let left = match (r.left_out_rejected, r.left_out_false) {
                (Some(t), Some(fa)) => {
                    format!("; an object left out of training had {} of its views reported unknown, the others {} of their unseen views", pct(t), pct(fa))
                }
                _ => String::new(),
            };
            format!("{} recognises {} of the unseen views{left}", r.recognizer, pct(r.recognized_unseen))
        })
        .collect();
    Some(format!("**Many objects.** With all {} objects at once, {}.", s.objects.len(), parts.join("; ")))
}
