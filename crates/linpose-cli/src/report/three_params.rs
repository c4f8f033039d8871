//! The report's three-parameter section: every method on azimuth x elevation x camera roll, its
//! storage with the paper's Table 1 terms, training time, time per query, unseen error and gross
//! errors with the confidence's flags, and what the linear model's small storage costs in
//! accuracy, all from the measured numbers.

use super::doc::Block;
use super::f;
use crate::study::three_params::{ThreeParamsRow, ThreeParamsStudy};
use crate::study::GROSS_ERROR_DEG;
use linpose::model::Origin;

/// `n` bytes in words: "4,415,320 bytes (4.42 MB)".
pub(super) fn bytes(n: usize) -> String {
    let digits = n.to_string();
    let mut grouped = String::new();
    for (i, c) in digits.chars().enumerate() {
        if i > 0 && (digits.len() - i).is_multiple_of(3) {
            grouped.push(',');
        }
        grouped.push(c);
    }
    let v = n as f64;
    let short = match v {
        _ if v < 1e3 => return format!("{grouped} bytes"),
        _ if v < 1e6 => format!("{:.1} kB", v / 1e3),
        _ => format!("{:.2} MB", v / 1e6),
    };
    format!("{grouped} bytes ({short})")
}

/// A parameter's trained values: all of them when few, else "a, b, ..., z".
fn values(v: &[f64]) -> String {
    let s: Vec<String> = v.iter().map(|x| format!("{x}")).collect();
    if s.len() <= 5 {
        s.join(", ")
    } else {
        format!("{}, {}, ..., {}", s[0], s[1], s[s.len() - 1])
    }
}

/// The row of the method of `origin`.
fn by_origin(t: &ThreeParamsStudy, origin: Origin) -> Option<&ThreeParamsRow> {
    t.rows.iter().find(|r| linpose::Method::from_name(&r.method).is_ok_and(|m| m.origin == origin))
}

/// What the paper's method's storage saves against its baseline's and what it costs in
/// accuracy, and how the methods beyond the paper compare; None without both.
fn storage_against_accuracy(t: &ThreeParamsStudy) -> Option<String> {
    let (lin, eig) = (by_origin(t, Origin::Paper)?, by_origin(t, Origin::Baseline)?);
    let (x, y) = (lin.cost.model_bytes, eig.cost.model_bytes);
    let (a, e) = (lin.unseen.mean_deg, eig.unseen.mean_deg);
    let storage = if x <= y { format!("{:.1} times fewer", y as f64 / x.max(1) as f64) } else { format!("{:.1} times more", x as f64 / y.max(1) as f64) };
    let accuracy =
        if a >= e { format!("{:.1} times the {}'s", a / e.max(1e-12), eig.method) } else { format!("{:.2} of the {}'s", a / e.max(1e-12), eig.method) };
    let mut text = format!(
        "the {} model stores {} against {} for the {}, {storage}, and its unseen error is {} degrees against {} ({accuracy})",
        lin.method,
        bytes(x),
        bytes(y),
        eig.method,
        f(a, 2),
        f(e, 2)
    );
    for r in t.rows.iter().filter(|r| linpose::Method::from_name(&r.method).is_ok_and(|m| m.origin == Origin::Beyond)) {
        text.push_str(&format!(
            "; the {} method, beyond the paper, stores {}, {:.1} times the {}'s, for {} degrees",
            r.method,
            bytes(r.cost.model_bytes),
            r.cost.model_bytes as f64 / x.max(1) as f64,
            lin.method,
            f(r.unseen.mean_deg, 2)
        ));
    }
    Some(text)
}

/// The gross errors of every method and how many the confidence flags.
fn gross(t: &ThreeParamsStudy) -> String {
    let parts: Vec<String> = t
        .rows
        .iter()
        .map(|r| match r.gross {
            0 => format!("{} none", r.method),
            g => format!("{} {g} ({} flagged by the confidence)", r.method, r.gross_flagged),
        })
        .collect();
    format!("Unseen views off by more than {GROSS_ERROR_DEG} degrees, of {}: {}.", t.n_unseen, parts.join(", "))
}

/// The section's finding (None without the paper's method and its baseline).
pub(super) fn three_params_finding(t: &ThreeParamsStudy) -> Option<String> {
    let text = storage_against_accuracy(t)?;
    Some(format!(
        "**Three pose parameters.** On {} at {} ({} training views; {} unseen inside the training range), {text}. {}",
        t.object,
        t.params.join(" x "),
        t.n_train,
        t.n_unseen,
        gross(t)
    ))
}

/// The section: what was measured, a table, and the storage against the accuracy.
pub(super) fn three_params_section(b: &mut Vec<Block>, t: Option<&ThreeParamsStudy>) {
    let Some(t) = t else { return };
    b.push(Block::Heading(1, "Three pose parameters: azimuth, elevation and camera roll".into()));
    let lattice: Vec<String> = t.params.iter().zip(&t.trained).map(|(p, v)| format!("{p} {}", values(v))).collect();
    b.push(Block::Para(format!(
        "The object {}, rendered at {} (the camera rolled about its optical axis). Every method is trained on the every-other-value lattice ({}: {} views) and measured on the {} other views inside the training range (none beyond the last trained value of a linear parameter). With more than two parameters the eigenspace and the refined method keep the manifold as its knots, the training views' coordinates, and search it continuously, so their N in the paper's N L + M L is the training views. Error: the angle of the rotation from the true camera pose to the estimated one (and each parameter's own mean error). Time per query: the wall time of estimating the measured views, batched, divided by their number, the least of a few runs, on 2 cores; fit: the wall time of training. The section took {:.1} s, rendering and the Table 1 figure's fits of three parameters included.",
        t.object,
        t.grid,
        lattice.join("; "),
        t.n_train,
        t.n_unseen,
        t.total_s
    )));
    let mut header: Vec<String> =
        ["method", "model bytes", "Table 1 terms", "fit (s)", "us per query", "unseen mean", "median", "p90", "max"].map(String::from).to_vec();
    header.extend(t.params.iter().map(|p| format!("{p} mean")));
    header.push(format!("over {GROSS_ERROR_DEG} (flagged)"));
    let rows = t
        .rows
        .iter()
        .map(|r| {
            let mut row = vec![
                r.method.clone(),
                r.cost.model_bytes.to_string(),
                format!("{}: {}", r.formula, r.cost.terms.iter().map(|(k, v)| format!("{k} = {v}")).collect::<Vec<_>>().join(", ")),
                f(r.fit_s, 2),
                f(r.cost.per_query_us, 1),
                f(r.unseen.mean_deg, 2),
                f(r.unseen.median_deg, 2),
                f(r.unseen.p90_deg, 2),
                f(r.unseen.max_deg, 1),
            ];
            row.extend(r.param_mean_deg.iter().map(|e| f(*e, 2)));
            row.push(format!("{} ({})", r.gross, r.gross_flagged));
            row
        })
        .collect();
    b.push(Block::Table(header, rows));
    let mut text = String::from("Errors in degrees over the unseen views inside the training range. ");
    if let Some(s) = storage_against_accuracy(t) {
        let mut c = s.chars();
        text.push_str(&format!("{}{s_rest}. ", c.next().map(|c| c.to_uppercase().to_string()).unwrap_or_default(), s_rest = c.as_str()));
    }
    text.push_str(&gross(t));
    b.push(Block::Para(text));
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bytes_are_grouped_and_shortened() {
        assert_eq!(bytes(999), "999 bytes");
        assert_eq!(bytes(76_832), "76,832 bytes (76.8 kB)");
        assert_eq!(bytes(4_415_320), "4,415,320 bytes (4.42 MB)");
    }

    #[test]
    fn long_value_lists_are_shortened() {
        assert_eq!(values(&[32.0, 50.0, 68.0]), "32, 50, 68");
        assert_eq!(values(&[0.0, 24.0, 48.0, 72.0, 96.0, 120.0]), "0, 24, ..., 120");
    }
}
