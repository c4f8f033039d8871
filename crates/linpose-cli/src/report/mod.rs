//! The experiment's report: Markdown and a self-contained HTML page built from one document, the
//! figures, and `results.json` with every number behind them.

mod confidence;
pub(crate) mod doc;
mod normalization;
pub(crate) mod plots;
mod recognition;
mod scenes;
mod table1;
mod three_params;

use confidence::{confidence_finding, confidence_section};
use normalization::{normalization_finding, normalization_section};
use recognition::{recognition_finding, recognition_section};
pub(crate) use scenes::scenes_finding;
use scenes::scenes_section;
use table1::{table1_figure, table1_finding};
use three_params::{three_params_finding, three_params_section};

use crate::study::{ObjectResult, Run, GROSS_ERROR_DEG};
use doc::{Block, Doc, FigureData};
use linpose::model::Origin;
use linpose::{Method, PoseModel};
use serde::Serialize;

/// What the study was, for the report's opening and the JSON.
#[derive(Debug, Clone, Serialize)]
pub(crate) struct StudyInfo {
    /// Where the data came from (rendered built-in objects, or user folders).
    pub source: String,
    /// The grid or data description.
    pub grid: String,
    /// Method names compared.
    pub methods: Vec<String>,
    /// Main training step.
    pub train_step: f64,
    /// Noise levels.
    pub noise: Vec<f64>,
    /// Sweep steps.
    pub size_steps: Vec<f64>,
    /// Noise seed.
    pub seed: u64,
    /// The coarser grid of the normalisation's jittered views, when not the data's own (the
    /// default study; none with `--full`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub jitter_grid: Option<String>,
    /// The step of the coarser grid the left-out objects are measured on in the recognition
    /// study, when not every view (the default study; none with `--full`).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub left_out_step: Option<f64>,
    /// Objects that are the conclusion's open cases (reported in their own section).
    pub open_cases: Vec<String>,
    /// Seconds spent rendering or loading data.
    pub data_s: f64,
    /// Seconds for the whole study.
    pub total_s: f64,
    /// Recognition on all the objects at once, when there were several of one image size.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub recognition: Option<crate::study::recognition::RecognitionStudy>,
    /// The three-parameter section, on the first built-in object (none on the user's data).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub three_params: Option<crate::study::three_params::ThreeParamsStudy>,
    /// The scenes section, on the built-in objects of the main study (none on the user's data).
    #[serde(skip_serializing_if = "Option::is_none")]
    pub scenes: Option<crate::study::scenes::ScenesStudy>,
    /// The Table 1 figure's points: every method fitted on nested training sets of one, two and
    /// three pose parameters.
    pub table1_sizes: Vec<crate::study::table1::SizePoint>,
}

pub(super) fn f(v: f64, d: usize) -> String {
    if v.is_finite() {
        format!("{v:.d$}")
    } else {
        "-".into()
    }
}

fn unseen_mean(r: &Run) -> f64 {
    r.unseen.map_or(r.all.mean_deg, |u| u.mean_deg)
}

fn run<'a>(o: &'a ObjectResult, method: &str, noise: f64) -> Option<&'a Run> {
    o.runs.iter().find(|r| r.method == method && (r.noise - noise).abs() < 1e-12)
}

fn mean_over<'a>(objs: impl Iterator<Item = &'a ObjectResult>, method: &str, noise: f64) -> f64 {
    let v: Vec<f64> = objs.filter_map(|o| run(o, method, noise)).map(unseen_mean).collect();
    v.iter().sum::<f64>() / v.len().max(1) as f64
}

pub(super) fn pct(noise: f64) -> String {
    if noise == 0.0 {
        "clean".into()
    } else {
        format!("+-{}%", (noise * 100.0).round())
    }
}

/// Builds the report document. `models[i]` are the models of `objects[i]` (for Fig. 2).
pub(crate) fn build(info: &StudyInfo, objects: &[ObjectResult]) -> Result<Doc, String> {
    let mut b = Vec::new();
    let main: Vec<&ObjectResult> = objects.iter().filter(|o| !info.open_cases.contains(&o.name)).collect();
    let open: Vec<&ObjectResult> = objects.iter().filter(|o| info.open_cases.contains(&o.name)).collect();
    let n_train = main.first().or(open.first()).and_then(|o| o.runs.first()).map_or(0, |r| r.n_train);
    b.push(Block::Para(format!(
        "Okatani & Deguchi's linear model (MVA 2000) against Murase & Nayar's parametric eigenspace, the study of the paper's sections 3 and 4 reproduced on {}. Data: {}. Training set: every {} degrees on each axis ({} views per object); every view is estimated, and errors are reported over the unseen views (not in the training set) unless said otherwise. Queries: clean and with uniform pixel noise of {} of full brightness (seed {}). Error: the angle between the true and the estimated viewing directions (degrees). Methods: {}. The study took {:.1} s ({:.1} s making the data).",
        info.source,
        info.grid,
        info.train_step,
        n_train,
        info.noise.iter().filter(|&&a| a > 0.0).map(|&a| pct(a)).collect::<Vec<_>>().join(" and "),
        info.seed,
        info.methods.join(", "),
        info.total_s,
        info.data_s
    )));

    b.push(Block::Heading(1, "What it found".into()));
    b.push(Block::List(findings(info, &main, &open)));

    // Accuracy table.
    b.push(Block::Heading(1, "Accuracy (Fig. 3 and 4 in numbers)".into()));
    let mut header = vec!["object".to_string(), "method".into(), "N".into()];
    header.extend(["unseen mean", "median", "p90", "max"].map(String::from));
    for &a in info.noise.iter().filter(|&&a| a > 0.0) {
        header.push(format!("{} mean", pct(a)));
    }
    let mut rows = Vec::new();
    for o in objects {
        for m in &info.methods {
            let Some(r) = run(o, m, 0.0) else { continue };
            let u = r.unseen.unwrap_or(r.all);
            let mut row = vec![o.name.clone(), m.clone(), r.n_train.to_string(), f(u.mean_deg, 2), f(u.median_deg, 2), f(u.p90_deg, 2), f(u.max_deg, 1)];
            for &a in info.noise.iter().filter(|&&a| a > 0.0) {
                row.push(run(o, m, a).map_or("-".into(), |r| f(unseen_mean(r), 2)));
            }
            rows.push(row);
        }
    }
    b.push(Block::Table(header, rows));
    b.push(Block::Para("Errors in degrees over the unseen views; N is the number of training views.".into()));

    // Table 1.
    if let Some(o) = main.first().or(open.first()) {
        b.push(Block::Heading(1, format!("Table 1, measured on {}", o.name)));
        let rows = o
            .table1
            .iter()
            .map(|t| {
                vec![
                    t.method.clone(),
                    t.formula.clone(),
                    t.terms.iter().map(|(k, v)| format!("{k} = {v}")).collect::<Vec<_>>().join(", "),
                    t.formula_numbers.to_string(),
                    t.model_bytes.to_string(),
                    f(t.per_query_us, 1),
                ]
            })
            .collect();
        b.push(Block::Table(
            ["method", "paper's formula", "actual terms", "numbers stored (formula)", "model bytes (measured)", "us per query (measured)"]
                .map(String::from)
                .to_vec(),
            rows,
        ));
        b.push(Block::Para("The paper's Table 1 gives storage and cost NL + ML for the eigenspace method (N manifold points of L dimensions, M pixels) and MK for the linear model (K encoded parameters). Bytes count the numbers each model stores to serve a query, as float32; time is the wall time of estimating every view of the object divided by their number, batched, on 2 cores.".into()));
    }
    table1_figure(&mut b, info)?;
    three_params_section(&mut b, info.three_params.as_ref());

    // Overtraining.
    b.push(Block::Heading(1, "Training-set size and the overtraining question (section 4)".into()));
    let steps = &info.size_steps;
    let mut header = vec!["object".to_string(), "method".into()];
    header.extend(steps.iter().map(|s| format!("step {s} deg")));
    let mut rows = Vec::new();
    for o in objects {
        let point = |m: &str, s: f64| o.sweep.iter().find(|p| p.method == m && (p.step - s).abs() < 1e-9);
        for m in &info.methods {
            let mut row = vec![o.name.clone(), format!("{m}: unseen mean")];
            row.extend(steps.iter().map(|&s| point(m, s).map_or("-".into(), |p| format!("{} (N={})", f(p.unseen_mean_deg, 2), p.n_train))));
            rows.push(row);
            if steps.iter().any(|&s| point(m, s).is_some_and(|p| p.loo_mean_deg.is_some())) {
                let mut row = vec![o.name.clone(), format!("{m}: leave-one-out mean")];
                row.extend(steps.iter().map(|&s| point(m, s).and_then(|p| p.loo_mean_deg).map_or("-".into(), |v| f(v, 2))));
                rows.push(row);
            }
        }
    }
    b.push(Block::Table(header, rows));
    b.push(Block::Para("Unseen mean error (degrees) for each training step, with the number of training views N; for the linear model also its exact leave-one-out error, computed in closed form from the training set alone (each training view estimated by the model fitted without it).".into()));
    let series: Vec<(String, Vec<(f64, f64)>)> = main
        .iter()
        .flat_map(|o| {
            info.methods
                .iter()
                .map(move |m| (format!("{} {m}", o.name), o.sweep.iter().filter(|p| &p.method == m).map(|p| (p.n_train as f64, p.unseen_mean_deg)).collect()))
        })
        .filter(|(_, v): &(String, Vec<(f64, f64)>)| !v.is_empty())
        .collect();
    if !series.is_empty() {
        b.push(Block::Figure {
            file: "error-vs-training-size.svg".into(),
            data: FigureData::Svg(plots::lines("Unseen mean error against training-set size", "training views N", "unseen mean error (degrees, log scale)", &series, true)?),
            caption: "Error against training-set size: the unseen mean error of each method and object as the training step shrinks from the largest to the smallest in the table above (more views to the right). The leave-one-out rows of the table give the linear model's own closed-form estimate, from the training set alone.".into(),
        });
    }

    // Open cases.
    if !open.is_empty() {
        b.push(Block::Heading(1, "The conclusion's two open cases".into()));
        let pnames: Vec<String> = open[0].params.clone();
        let mut rows = Vec::new();
        for o in &open {
            for m in &info.methods {
                if let Some(r) = run(o, m, 0.0) {
                    let mut row = vec![o.name.clone(), m.clone(), f(unseen_mean(r), 2)];
                    row.extend(r.param_mean_abs_err_deg.iter().map(|e| f(*e, 2)));
                    row.push(format!("{:.1}%", 100.0 * r.gross_frac));
                    rows.push(row);
                }
            }
        }
        let mut header = ["object", "method", "unseen mean"].map(String::from).to_vec();
        header.extend(pnames.iter().map(|p| format!("{p} mean abs. error")));
        header.push(format!("views off by > {GROSS_ERROR_DEG} deg"));
        b.push(Block::Table(header, rows));
        b.push(Block::Para("twin: front and back look alike but for a small mark, so an estimate can land on the wrong side (an azimuth error near 180 degrees). column: its appearance changes strongly with azimuth but weakly with elevation, so the elevation signal is small beside the azimuth one.".into()));
    }

    confidence_section(&mut b, objects)?;
    normalization_section(&mut b, objects, info.jitter_grid.as_deref());
    recognition_section(&mut b, info.recognition.as_ref(), info.left_out_step);
    scenes_section(&mut b, info.scenes.as_ref())?;

    // Figures.
    b.push(Block::Heading(1, "Figures".into()));
    figures(&mut b, info, objects)?;
    Ok(Doc { title: "linpose: the paper's experiments, reproduced".into(), blocks: b })
}

/// The methods of the study as the registry describes them (a name it does not know is skipped).
fn described(info: &StudyInfo) -> Vec<&'static Method> {
    info.methods.iter().filter_map(|m| linpose::Method::from_name(m).ok()).collect()
}

/// "a (x), b (y), ..." for the methods with a value, smallest first.
fn ranked(values: &[(&str, f64)], show: impl Fn(f64) -> String) -> String {
    let mut v: Vec<&(&str, f64)> = values.iter().filter(|(_, x)| x.is_finite()).collect();
    v.sort_by(|a, b| a.1.total_cmp(&b.1));
    v.iter().map(|(m, x)| format!("{m} {}", show(*x))).collect::<Vec<_>>().join(", ")
}

fn findings(info: &StudyInfo, main: &[&ObjectResult], open: &[&ObjectResult]) -> Vec<String> {
    let mut out = Vec::new();
    let names: Vec<&str> = main.iter().map(|o| o.name.as_str()).collect();
    let methods = described(info);
    let by_origin = |origin: Origin| methods.iter().find(|m| m.origin == origin).map(|m| m.name);
    if !main.is_empty() && !methods.is_empty() {
        let errors: Vec<(&str, f64)> = methods.iter().map(|m| (m.name, mean_over(main.iter().copied(), m.name, 0.0))).collect();
        let mut text =
            format!("**Accuracy.** Unseen mean error averaged over {}, most accurate first: {} degrees.", names.join(", "), ranked(&errors, |e| f(e, 2)));
        let err = |name: &str| errors.iter().find(|(m, _)| *m == name).map_or(f64::NAN, |e| e.1);
        if let (Some(paper), Some(base)) = (by_origin(Origin::Paper), by_origin(Origin::Baseline)) {
            let (l, e) = (err(paper), err(base));
            text.push_str(&format!(
                " The paper's verdict {}: {paper}'s error is {:.1}x {base}'s.",
                if l > e { "holds, its baseline is the more accurate" } else { "does not hold here, its own method is at least as accurate as its baseline" },
                l / e.max(1e-12)
            ));
        }
        for beyond in methods.iter().filter(|m| m.origin == Origin::Beyond) {
            let others: Vec<String> =
                methods.iter().filter(|m| m.name != beyond.name).map(|m| format!("{:.2}x {}'s", err(beyond.name) / err(m.name).max(1e-12), m.name)).collect();
            text.push_str(&format!(" {}, beyond the paper: {} error.", beyond.name, others.join(", ")));
        }
        out.push(text);
        if let Some(o) = main.first() {
            let t = |m: &str| o.table1.iter().find(|t| t.method == m);
            let rows: Vec<&crate::study::Table1Row> = methods.iter().filter_map(|m| t(m.name)).collect();
            if !rows.is_empty() {
                let bytes: Vec<(&str, f64)> = rows.iter().map(|r| (r.method.as_str(), r.model_bytes as f64)).collect();
                let (small, large) = (rows.iter().min_by_key(|r| r.model_bytes).expect("a row"), rows.iter().max_by_key(|r| r.model_bytes).expect("a row"));
                out.push(format!(
                    "**Storage.** On {}, smallest first: {} bytes; {} stores {:.1}x fewer than {}.",
                    o.name,
                    ranked(&bytes, |b| format!("{b:.0}")),
                    small.method,
                    large.model_bytes as f64 / small.model_bytes.max(1) as f64,
                    large.method
                ));
                let us: Vec<(&str, f64)> = rows.iter().map(|r| (r.method.as_str(), r.per_query_us)).collect();
                out.push(format!("**Cost.** A query costs, cheapest first: {} us, measured on all {} views.", ranked(&us, |u| f(u, 1)), o.n_samples));
            }
        }
    }
    if let Some(&amax) = info.noise.iter().rfind(|&&a| a > 0.0) {
        for m in &methods {
            let (c, n) = (mean_over(main.iter().copied(), m.name, 0.0), mean_over(main.iter().copied(), m.name, amax));
            let paper = match m.origin {
                Origin::Paper if n / c.max(1e-12) < 1.5 => ", so noise does not severely affect it, as the paper's Fig. 4 says",
                Origin::Paper => ", more than the paper's Fig. 4 suggests",
                _ => "",
            };
            out.push(format!(
                "**Noise ({}).** With {} pixel noise its unseen mean error goes from {} to {} degrees ({:.1}x){paper}.",
                m.name,
                pct(amax),
                f(c, 2),
                f(n, 2),
                n / c.max(1e-12)
            ));
        }
    }
    let swept: Vec<&str> = methods.iter().map(|m| m.name).filter(|m| main.iter().any(|o| o.sweep.iter().any(|p| p.method == *m))).collect();
    if !swept.is_empty() {
        let decreasing = |m: &str| {
            main.iter().all(|o| {
                let mut v: Vec<(usize, f64)> = o.sweep.iter().filter(|p| p.method == m).map(|p| (p.n_train, p.unseen_mean_deg)).collect();
                v.sort_by_key(|x| x.0);
                v.windows(2).all(|w| w[1].1 <= w[0].1 * 1.05)
            })
        };
        let ends: Vec<String> = swept
            .iter()
            .map(|m| {
                let (small, large) = sweep_ends(main, m);
                format!("{m} from {} to {}", f(small, 2), f(large, 2))
            })
            .collect();
        let (steady, not): (Vec<&str>, Vec<&str>) = swept.iter().partition(|m| decreasing(m));
        let mut text = format!(
            "**Overtraining.** Unseen mean error with the fewest training views against the most (mean over objects, degrees): {}. {}",
            ends.join("; "),
            match (steady.is_empty(), not.is_empty()) {
                (false, true) => "No overtraining appears: the error falls with more data for every method.".to_string(),
                (false, false) => format!("It falls steadily with more data for {}, not for {}.", steady.join(", "), not.join(", ")),
                _ => "The error does not fall steadily with more data.".to_string(),
            }
        );
        for m in &swept {
            let ratios: Vec<f64> = main
                .iter()
                .flat_map(|o| o.sweep.iter().filter(|p| p.method == *m))
                .filter_map(|p| p.loo_mean_deg.filter(|l| l.is_finite() && p.unseen_mean_deg > 0.0).map(|l| l / p.unseen_mean_deg))
                .collect();
            if ratios.is_empty() {
                continue;
            }
            let (rmin, rmax) = ratios.iter().fold((f64::INFINITY, 0.0f64), |(a, b), &r| (a.min(r), b.max(r)));
            text.push_str(&format!(
                " The {m} method's closed-form leave-one-out error, from the training set alone, is {rmin:.2} to {rmax:.2} times its true unseen error across objects and steps: each left-out view sits a whole training step from its nearest remaining neighbour, twice as far as an unseen view, so it answers a harder question than the one measured: it ranks training sets rather than predicting their error."
            ));
        }
        out.push(text);
    }
    for (label, objs) in [("Confidence", main), ("Confidence on the open cases", open)] {
        if let Some(text) = confidence_finding(label, objs) {
            out.push(text);
        }
    }
    let everything: Vec<&ObjectResult> = main.iter().chain(open).copied().collect();
    if let Some(text) = recognition_finding(info.recognition.as_ref()) {
        out.push(text);
    }
    if let Some(text) = normalization_finding(&everything) {
        out.push(text);
    }
    if let Some(text) = info.scenes.as_ref().and_then(scenes_finding) {
        out.push(text);
    }
    if let Some(text) = info.three_params.as_ref().and_then(three_params_finding) {
        out.push(text);
    }
    if let Some(text) = table1_finding(&info.table1_sizes) {
        out.push(text);
    }
    for o in open {
        let parts: Vec<String> = info
            .methods
            .iter()
            .filter_map(|m| run(o, m, 0.0).map(|r| (m, r)))
            .map(|(m, r)| {
                let pe: Vec<String> = o.params.iter().zip(&r.param_mean_abs_err_deg).map(|(p, e)| format!("{p} {}", f(*e, 1))).collect();
                format!(
                    "{m} {} degrees ({}; {:.0}% of views off by more than {GROSS_ERROR_DEG} degrees)",
                    f(unseen_mean(r), 2),
                    pe.join(", "),
                    100.0 * r.gross_frac
                )
            })
            .collect();
        out.push(format!("**Open case {}.** Unseen mean error: {}.", o.name, parts.join("; ")));
    }
    out
}

fn sweep_ends(main: &[&ObjectResult], m: &str) -> (f64, f64) {
    let mut small = Vec::new();
    let mut large = Vec::new();
    for o in main {
        let v: Vec<_> = o.sweep.iter().filter(|p| p.method == m).collect();
        if let (Some(a), Some(b)) = (v.iter().min_by_key(|p| p.n_train), v.iter().max_by_key(|p| p.n_train)) {
            small.push(a.unseen_mean_deg);
            large.push(b.unseen_mean_deg);
        }
    }
    let mean = |v: &[f64]| v.iter().sum::<f64>() / v.len().max(1) as f64;
    (mean(&small), mean(&large))
}

fn error_map(o: &ObjectResult, r: &Run, title: &str, vmax: f64) -> Result<FigureData, String> {
    match &o.grid {
        Some(g) => {
            let mut values = vec![f64::NAN; g.rows.1.len() * g.cols.1.len()];
            for (i, &(row, col)) in g.cell.iter().enumerate() {
                values[row * g.cols.1.len() + col] = r.errors[i];
            }
            Ok(FigureData::Svg(plots::heatmap(
                title,
                plots::GridAxis { desc: &format!("{} (degrees)", g.cols.0), values: &g.cols.1 },
                plots::GridAxis { desc: &format!("{} (degrees)", g.rows.0), values: &g.rows.1 },
                &values,
                plots::ColorScale { vmax, unit: "pose error (degrees)" },
            )?))
        }
        None => {
            let k = o.params.len();
            let pts: Vec<(f64, f64)> = (0..o.n_samples).map(|i| (o.poses[i * k + k - 1], r.errors[i])).collect();
            Ok(FigureData::Svg(plots::lines(title, &format!("{} (degrees)", o.params[k - 1]), "pose error (degrees)", &[(r.method.clone(), pts)], false)?))
        }
    }
}

fn figures(b: &mut Vec<Block>, info: &StudyInfo, objects: &[ObjectResult]) -> Result<(), String> {
    // Fig. 2: the coefficient vectors of the first object's first model linear in the pixels.
    if let Some((o, model, w)) = objects.iter().find_map(|o| o.models.iter().find_map(|m| m.coefficients().map(|w| (o, m, w)))) {
        let spec = model.meta().spec;
        if spec.color == linpose::image_io::ColorMode::Gray {
            let m = spec.features();
            let imgs: Vec<&[f64]> = w.chunks_exact(m).collect();
            let names = encoded_names(model.meta());
            b.push(Block::Figure {
                file: format!("fig2-coefficients-{}.png", o.name),
                data: FigureData::Png(plots::coefficient_png(&imgs, spec.width, spec.height, 2)?),
                caption: format!(
                    "Fig. 2: the coefficient vectors w_j of the {} model of {} shown as {}x{} images, left to right: {}. Blue negative, white zero, red positive, each image on its own scale (largest |w| = {}).",
                    model.meta().method,
                    o.name,
                    spec.width,
                    spec.height,
                    names.join(", "),
                    imgs.iter().map(|w| format!("{:.2e}", w.iter().fold(0.0f64, |a, &v| a.max(v.abs())))).collect::<Vec<_>>().join(", ")
                ),
            });
        }
    }
    // Fig. 3: error maps per object and method, one colour scale per object.
    for o in objects {
        let runs: Vec<&Run> = info.methods.iter().filter_map(|m| run(o, m, 0.0)).collect();
        let vmax = runs.iter().map(|r| r.all.p90_deg).fold(0.0, f64::max) * 1.5;
        for r in runs {
            b.push(Block::Figure {
                file: format!("fig3-{}-{}.svg", o.name, r.method),
                data: error_map(o, r, &format!("{} - {}: pose error, clean queries", o.name, r.method), vmax)?,
                caption: format!(
                    "Fig. 3 ({}, {}): pose error of every view over the (azimuth, elevation) grid, training views included (they sit every {} degrees). Unseen mean {} degrees. Colour scale shared by the methods on this object, clipped at {} degrees.",
                    o.name,
                    r.method,
                    info.train_step,
                    f(unseen_mean(r), 2),
                    f(vmax, 1)
                ),
            });
        }
    }
    // Fig. 4: the first object under noise.
    if let Some(o) = objects.first() {
        for &a in info.noise.iter().filter(|&&a| a > 0.0) {
            let runs: Vec<&Run> = info.methods.iter().filter_map(|m| run(o, m, a)).collect();
            let vmax = runs.iter().map(|r| r.all.p90_deg).fold(0.0, f64::max) * 1.5;
            for r in runs {
                b.push(Block::Figure {
                    file: format!("fig4-{}-{}-noise{}.svg", o.name, r.method, (a * 100.0).round()),
                    data: error_map(o, r, &format!("{} - {}: pose error, {} noise", o.name, r.method, pct(a)), vmax)?,
                    caption: format!(
                        "Fig. 4 ({}, {}, {} uniform pixel noise on the queries; the model trained on clean images): unseen mean {} degrees.",
                        o.name,
                        r.method,
                        pct(a),
                        f(unseen_mean(r), 2)
                    ),
                });
            }
        }
    }
    // CDFs per method over all objects, clean, unseen views.
    let series: Vec<(String, Vec<f64>)> = info
        .methods
        .iter()
        .map(|m| {
            let e: Vec<f64> = objects
                .iter()
                .filter(|o| !info.open_cases.contains(&o.name))
                .filter_map(|o| run(o, m, 0.0))
                .flat_map(|r| r.errors.iter().zip(&r.seen).filter(|(_, &s)| !s).map(|(&e, _)| e))
                .collect();
            (m.clone(), e)
        })
        .filter(|(_, e)| !e.is_empty())
        .collect();
    if !series.is_empty() {
        let mut all: Vec<f64> = series.iter().flat_map(|s| s.1.iter().copied()).collect();
        all.sort_by(f64::total_cmp);
        let xmax = all[(all.len() as f64 * 0.98) as usize % all.len()].max(1.0) * 1.2;
        b.push(Block::Figure {
            file: "error-cdf.svg".into(),
            data: FigureData::Svg(plots::cdf("Distribution of unseen-view errors", "pose error (degrees)", &series, xmax)?),
            caption: "Error distributions: the fraction of unseen views estimated within a given error, per method, pooled over the objects (open cases excluded), clean queries.".into(),
        });
    }
    Ok(())
}

/// Names of the encoded parameters: `elevation`, `cos azimuth`, `sin azimuth`, ...
fn encoded_names(meta: &linpose::ModelMeta) -> Vec<String> {
    meta.space
        .params()
        .iter()
        .flat_map(|p| if p.period.is_some() { vec![format!("cos {}", p.name), format!("sin {}", p.name)] } else { vec![p.name.clone()] })
        .collect()
}
