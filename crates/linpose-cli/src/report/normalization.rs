//! The report's normalisation section: every method with and without the normalisation stage, on
//! registered views and on views as a camera would take them, and the recommendation.

use super::doc::Block;
use super::f;
use crate::study::tuning::REGISTERED_COST;
use crate::study::ObjectResult;

/// The section: a table and, per method, whether to normalise.
/// `jitter_grid`: the coarser grid of the jittered views, when not every unseen view's.
pub(super) fn normalization_section(b: &mut Vec<Block>, objects: &[ObjectResult], jitter_grid: Option<&str>) {
    let rows: Vec<Vec<String>> = objects
        .iter()
        .flat_map(|o| o.normalization.iter().map(move |r| (o, r)))
        .map(|(o, r)| {
            let (jp, jn) = r.jittered.map_or(("-".into(), "-".into()), |[a, b]| (f(a, 2), f(b, 2)));
            vec![
                o.name.clone(),
                r.method.clone(),
                f(r.registered[0], 2),
                if r.registered[1].is_finite() { f(r.registered[1], 2) } else { "-".into() },
                jp,
                jn,
                if r.jittered.is_some() { format!("{} of {}", r.refused, r.n_jittered) } else { "-".into() },
                match (&r.unavailable, r.recommended) {
                    (Some(why), _) => format!("cannot: {why}"),
                    (None, true) => "yes".into(),
                    (None, false) => "for unregistered images only".into(),
                },
            ]
        })
        .collect();
    if rows.is_empty() {
        return;
    }
    b.push(Block::Heading(1, "Normalisation: images as a camera takes them".into()));
    let mut text = "Every method compares pixels, so it expects a query registered like the training views. The normalisation stage (`train --normalize`) finds the object in each image, centres it on its centroid, scales it to the training views' median size and brings it to their median brightness, for training and query images alike. Here each method is fitted on the registered training views with and without it, and measured on the registered unseen views and on the same views rendered as a camera in a cell would take them (moved by up to 8 pixels in a 160-pixel frame, 0.9 to 1.1 times the size, 0.8 to 1.2 times the exposure; rendered objects only). Images the stage cannot normalise (the object cut by the frame edge) are counted apart.".to_string();
    if let Some(g) = jitter_grid {
        text.push_str(&format!(
            " The jittered views are the unseen views of a coarser grid, {g}, a sample of the registered ones (`--full`: every unseen view)."
        ));
    }
    b.push(Block::Para(text));
    b.push(Block::Table(
        ["object", "method", "registered", "registered, normalised", "jittered", "jittered, normalised", "refused", "normalise?"].map(String::from).to_vec(),
        rows,
    ));
    b.push(Block::Para(format!(
        "Unseen mean error in degrees. The stage is recommended for a method when it costs at most {:.0}% of its accuracy on registered views; where it costs more, use it only for images that are not registered like the training views.",
        100.0 * REGISTERED_COST
    )));
}

/// The normalisation's finding: per method, what the stage does on registered and jittered views,
/// over the objects (None when the study did not run it).
pub(super) fn normalization_finding(objects: &[&ObjectResult]) -> Option<String> {
    let mut methods: Vec<&str> = Vec::new();
    for r in objects.iter().flat_map(|o| o.normalization.iter()) {
        if !methods.contains(&r.method.as_str()) {
            methods.push(&r.method);
        }
    }
    if methods.is_empty() {
        return None;
    }
    let parts: Vec<String> = methods
        .iter()
        .map(|m| {
            let rows: Vec<(&str, &crate::study::normalization::NormalizationRow)> = objects
                .iter()
                .flat_map(|o| o.normalization.iter().filter(|r| r.method == *m && r.unavailable.is_none()).map(move |r| (o.name.as_str(), r)))
                .collect();
            if rows.is_empty() {
                return format!("{m}: the stage refused a training view of every object");
            }
            let mean = |g: &dyn Fn(&crate::study::normalization::NormalizationRow) -> Option<f64>| {
                let v: Vec<f64> = rows.iter().filter_map(|(_, r)| g(r)).collect();
                (!v.is_empty()).then(|| v.iter().sum::<f64>() / v.len() as f64)
            };
            let jit = match (mean(&|r| r.jittered.map(|j| j[0])), mean(&|r| r.jittered.map(|j| j[1]))) {
                (Some(a), Some(b)) => format!("; on jittered views {} -> {} degrees", f(a, 2), f(b, 2)),
                _ => String::new(),
            };
            let not: Vec<&str> = rows.iter().filter(|(_, r)| !r.recommended).map(|(o, _)| *o).collect();
            let verdict = match not.len() {
                0 => "recommended on every object".to_string(),
                _ => format!("not recommended for registered images of {}", not.join(", ")),
            };
            format!(
                "{m}: registered {} -> {} degrees{jit}; {verdict}",
                f(mean(&|r| Some(r.registered[0])).unwrap_or(f64::NAN), 2),
                f(mean(&|r| Some(r.registered[1])).unwrap_or(f64::NAN), 2)
            )
        })
        .collect();
    Some(format!(
        "**Normalisation.** Mean unseen error over {} without and with the normalisation stage: {}.",
        objects.iter().filter(|o| !o.normalization.is_empty()).map(|o| o.name.as_str()).collect::<Vec<_>>().join(", "),
        parts.join(". ")
    ))
}
