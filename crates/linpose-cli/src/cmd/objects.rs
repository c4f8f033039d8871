//! `train`, `eval` and `predict` on data sets of many objects: which object, then its pose, and
//! "none of these" ([`linpose::recognize`]).

use crate::args::method::as_flag;
use crate::args::EvalArgs;
use crate::args::PredictArgs;
use crate::args::TrainArgs;
use crate::common::{progress, write_json};
use crate::queries::{eight_bit_as_features, read_one};
use anyhow::Context;
use linpose::normalize::{NormalizeParams, StageChoice, StageRule};
use linpose::recognize::{ObjectModel, Recognizer, RecognizerParams, Unknown};
use linpose::{Catalog, ErrorSummary, ObjectSet, PoseModel, Source};
use serde::Serialize;
use std::collections::BTreeMap;
use std::io::Write;
use std::path::Path;
use std::time::Instant;

/// The options of `train` that only a many-object data set takes, with the flag that gave each.
pub(crate) fn recognizer_params(a: &TrainArgs) -> anyhow::Result<RecognizerParams> {
    let mut p = RecognizerParams::default().unknown(parse_unknown(a.unknown.as_deref().unwrap_or("calibrated"))?);
    if let Some(name) = &a.recognizer {
        p.kind = Recognizer::from_name(name).map_err(|e| anyhow::anyhow!("--recognizer: {e}"))?;
    }
    if let Some(l) = a.recognizer_components {
        p = p.components(l);
    }
    Ok(p)
}

/// `--unknown calibrated|off|D`.
pub(crate) fn parse_unknown(s: &str) -> anyhow::Result<Unknown> {
    match s {
        "calibrated" => Ok(Unknown::Calibrated),
        "off" => Ok(Unknown::Off),
        t => match t.parse::<f64>() {
            Ok(v) if v.is_finite() && v > 0.0 => Ok(Unknown::Threshold(v)),
            _ => anyhow::bail!("--unknown {t}: give calibrated, off, or a positive distance"),
        },
    }
}

/// Reads a many-object data set's objects (no pixels yet), dropping those `leave_out` names.
fn catalog(dir: &Path, leave_out: &[String]) -> anyhow::Result<Catalog> {
    let c = Catalog::open(dir)?;
    if leave_out.is_empty() {
        return Ok(c);
    }
    if let Some(n) = leave_out.iter().find(|n| !c.names().contains(n)) {
        anyhow::bail!("--leave-out {n}: no such object in {} (it has {})", dir.display(), c.names().join(", "));
    }
    let keep: Vec<String> = c.names().iter().filter(|n| !leave_out.contains(n)).cloned().collect();
    if keep.is_empty() {
        anyhow::bail!("--leave-out leaves no object to train on");
    }
    Ok(c.select(&keep)?)
}

/// [`load`], with the images that cannot be read at size `spec` (unreadable, damaged, another
/// size) left out and each named with why; every image is checked only when the whole catalog
/// does not load. An object none of whose images can be read is an error naming it.
fn load_readable(c: &Catalog, spec: linpose::image_io::ImageSpec) -> anyhow::Result<(ObjectSet, Vec<Refused>)> {
    let e = match load(c, spec.color) {
        Ok(set) => return Ok((set, Vec::new())),
        Err(e) => e,
    };
    let mut refused = Vec::new();
    let mut manifests = Vec::with_capacity(c.len());
    for (name, m) in c.names().iter().zip(c.manifests()) {
        let why = crate::queries::unreadable(m, spec);
        let mask: Vec<bool> = why.iter().map(Option::is_none).collect();
        if !mask.iter().any(|&k| k) {
            anyhow::bail!("{}: none of object '{name}''s {} images can be read, the first: {}", m.root().display(), m.len(), why[0].as_deref().unwrap_or(""));
        }
        refused.extend(why.into_iter().enumerate().filter_map(|(i, w)| w.map(|reason| Refused { object: name.clone(), image: m.images()[i].clone(), reason })));
        manifests.push(m.subset(&mask)?);
    }
    if refused.is_empty() {
        return Err(e);
    }
    let readable = Catalog::new(c.root(), c.names().to_vec(), manifests)?;
    Ok((load(&readable, spec.color)?, refused))
}

/// Decodes a catalog's images with a progress bar.
fn load(c: &Catalog, color: linpose::image_io::ColorMode) -> anyhow::Result<ObjectSet> {
    let bar = progress(c.total_images() as u64, "decoding images");
    let set = c.load(color, &|n| bar.inc(n))?;
    bar.finish_and_clear();
    Ok(set)
}

#[derive(Serialize)]
struct TrainSummary<'a> {
    recognizer: &'static str,
    method: &'a str,
    data: String,
    objects: &'a [String],
    n_train: usize,
    n_features: usize,
    load_s: f64,
    fit_s: f64,
    model_bytes: usize,
    recognizer_bytes: usize,
    file_bytes: u64,
    settings: &'a linpose::recognize::ObjectSettings,
    /// The normalisation stage, in words (absent: none).
    #[serde(skip_serializing_if = "Option::is_none")]
    normalize: Option<String>,
    memory: crate::plan::MemorySummary,
}

/// `train` on a many-object data set.
pub(crate) fn train(
    a: &TrainArgs,
    params: &RecognizerParams,
    method: &'static linpose::Method,
    spec: &linpose::MethodSpec,
    rule: StageRule,
) -> anyhow::Result<()> {
    let out = a.out.as_deref().context("--out MODEL is required")?;
    let t0 = Instant::now();
    let c = catalog(&a.data.data, &a.leave_out)?;
    let c = c.subset(&c.training_masks(&a.selection()?)?)?;
    // In memory only: checked before any image is decoded.
    let mut fell_back = false;
    let (plan, rule) = match rule {
        // A stage is chosen only where its held-out folds fit in memory too.
        StageRule::Auto => match crate::plan::plan_objects(a, &c, method, params, rule) {
            Ok(plan) => (plan, rule),
            Err(_) => {
                fell_back = true;
                (crate::plan::plan_objects(a, &c, method, params, StageRule::Fixed(NormalizeParams::OFF))?, StageRule::Fixed(NormalizeParams::OFF))
            }
        },
        StageRule::Fixed(_) => (crate::plan::plan_objects(a, &c, method, params, rule)?, rule),
    };
    crate::plan::say(&plan);
    let train = load(&c, a.color.into())?;
    let load_s = t0.elapsed().as_secs_f64();
    let t1 = Instant::now();
    let bar = progress(train.len() as u64 + 1, "fitting");
    let mut model = ObjectModel::fit_staged(&train, params, spec, rule, &|k| bar.inc(k)).map_err(as_flag)?;
    if fell_back {
        model = model.with_stage_choice(StageChoice::off("the training set is too large to choose its normalisation in memory"));
    }
    if a.robust {
        model = model.with_robust(&train).map_err(as_flag)?;
    }
    bar.finish_and_clear();
    let fit_s = t1.elapsed().as_secs_f64();
    let file_bytes = model.save(out).context("writing the model")?;
    let summary = TrainSummary {
        recognizer: model.kind().name,
        method: model.method_name().unwrap_or(linpose::model_file::NO_POSES),
        data: a.data.data.display().to_string(),
        objects: model.names(),
        n_train: train.total_len(),
        n_features: model.spec().features(),
        load_s,
        fit_s,
        model_bytes: model.model_bytes(),
        recognizer_bytes: model.recognizer_bytes(),
        file_bytes,
        settings: model.settings(),
        normalize: model.stage().map(|s| s.describe()),
        memory: crate::plan::MemorySummary::of(&plan),
    };
    eprintln!(
        "trained the {} recogniser and {} pose models on {} objects ({} images of {}x{}) in {fit_s:.3} s (decoding {load_s:.3} s); model {} bytes ({} the recogniser) -> {}",
        summary.recognizer,
        summary.method,
        model.names().len(),
        summary.n_train,
        model.spec().width,
        model.spec().height,
        summary.model_bytes,
        summary.recognizer_bytes,
        out.display()
    );
    if let Some(c) = &model.settings().stage_choice {
        eprintln!("  {}", c.describe());
    }
    if let Some(n) = &summary.normalize {
        eprintln!("  {n}");
    }
    if let Some(j) = &a.json {
        write_json(j, &summary)?;
    }
    Ok(())
}

/// One evaluated image.
#[derive(Serialize)]
struct Sample {
    /// Its object (the data set's name for it).
    object: String,
    image: String,
    /// Whether the object is one the model knows.
    known: bool,
    /// Whether the view is one of the model's training views.
    seen: bool,
    /// The object recognised; null when reported unknown.
    recognized: Option<String>,
    /// The nearest object even when reported unknown.
    nearest: String,
    distance: f64,
    /// The distance to the nearest object in its own eigenspace (the second stage); null when
    /// not measured.
    own_distance: Option<f64>,
    /// Another object whose own manifold lies nearer the view than the nearest object's does
    /// (then unknown); null when none.
    own_nearer: Option<String>,
    confidence: f64,
    /// The pose estimated by the recognised object's model (degrees); null when unknown.
    pose: Option<Vec<f64>>,
    /// Its error against the true pose (degrees); null when unknown.
    error_deg: Option<f64>,
}

#[derive(Serialize)]
struct Rates {
    /// Views of known objects recognised as their object, over all their views.
    all: f64,
    /// The same over their unseen views (null when none).
    unseen: Option<f64>,
    n_all: usize,
    n_unseen: usize,
}

#[derive(Serialize)]
struct Rejection {
    /// Views of objects the model does not know, and the share of them reported unknown
    /// (null when the data set has none).
    unknown_views: usize,
    true_rejections: Option<f64>,
    /// Unseen views of known objects, and the share of them reported unknown.
    known_unseen_views: usize,
    false_rejections: Option<f64>,
}

/// An image the model's normalisation stage refused: counted apart, in no figure.
#[derive(Serialize)]
struct Refused {
    object: String,
    image: String,
    reason: String,
}

#[derive(Serialize)]
struct Report {
    recognizer: &'static str,
    method: String,
    objects: Vec<String>,
    n_eval: usize,
    /// Images the model's normalisation refused (not among the samples).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    rejected: Vec<Refused>,
    recognition: Rates,
    unknown: Rejection,
    /// Rows: the data set's objects; columns: the model's objects then "unknown".
    confusion: BTreeMap<String, BTreeMap<String, usize>>,
    /// Pose error of known objects' views recognised as their own object (degrees).
    pose: PoseErrors,
    predict_s: f64,
    model_bytes: usize,
    recognizer_bytes: usize,
    samples: Vec<Sample>,
}

#[derive(Serialize)]
struct PoseErrors {
    all: Option<ErrorSummary>,
    unseen: Option<ErrorSummary>,
}

/// The column of the confusion table for a query reported unknown.
const UNKNOWN: &str = "unknown";

/// `eval` with a many-object model.
pub(crate) fn eval(a: &EvalArgs) -> anyhow::Result<()> {
    let model = linpose::recognize::ObjectModel::load(&a.model)?;
    let model = match &a.unknown {
        Some(u) => model.with_unknown(parse_unknown(u)?)?,
        None => model,
    };
    if a.noise != 0.0 {
        anyhow::bail!("--noise with a many-object model: not supported yet (evaluate clean images)");
    }
    let c = match Source::open(&a.data.data, a.data.object)? {
        Source::Many(c) => c,
        Source::One(_) => anyhow::bail!(
            "{}: the model knows {} objects ({}), but this data set holds one; give a many-object data set (a folder of object folders, a poses.csv with an object column, or a COIL folder without --object)",
            a.data.data.display(),
            model.names().len(),
            model.names().join(", ")
        ),
    };
    // Images that cannot be read at the model's size are counted apart with why, as the model's
    // refusals are; every object's other views are evaluated.
    let (data, unreadable) = load_readable(&c, model.spec())?;
    if data.spec() != model.spec() || model.space().is_some_and(|s| s != data.space()) {
        anyhow::bail!(
            "{}: images of {}x{} with parameters {}, but the model was trained on {}x{} with {}",
            a.data.data.display(),
            data.spec().width,
            data.spec().height,
            params(data.space()),
            model.spec().width,
            model.spec().height,
            model.space().map_or_else(|| "no poses".to_string(), params)
        );
    }
    if model.space().is_none() {
        eprintln!("the model was fitted without poses: it gives no pose, and it cannot tell its training views, so every known view counts as unseen");
    }
    let names = model.names();
    let mut samples = Vec::with_capacity(data.total_len());
    let mut rejected = unreadable;
    let mut predict_s = 0.0;
    let space = model.space();
    for (name, d) in data.names().iter().zip(data.objects()) {
        let truth = names.iter().position(|n| n == name);
        let t = Instant::now();
        // Behind a normalisation stage, the images it refuses are set apart, in no figure; so
        // are those the model refuses (an all-black image), each found alone.
        let m = d.n_features();
        let est = crate::queries::each_row(d.len(), |r| model.estimate_each(&d.features()[r.start * m..r.end * m], 1));
        predict_s += t.elapsed().as_secs_f64();
        for (i, e) in est.into_iter().enumerate() {
            let e = match e {
                Ok(Ok(e)) => e,
                Ok(Err(r)) => {
                    rejected.push(Refused { object: name.clone(), image: d.manifest().images()[i].clone(), reason: crate::queries::cannot_normalise(&r) });
                    continue;
                }
                Err(why) => {
                    rejected.push(Refused { object: name.clone(), image: d.manifest().images()[i].clone(), reason: why });
                    continue;
                }
            };
            let r = &e.recognition;
            let seen = truth.and_then(|k| model.pose_model(k)).is_some_and(|m| m.meta().is_seen(d.pose(i)));
            let pose = e.pose.map(|p| p.pose);
            let error_deg = pose.as_ref().zip(space).map(|(p, space)| space.error_deg(d.pose(i), p));
            samples.push(Sample {
                object: name.clone(),
                image: d.manifest().images()[i].clone(),
                known: truth.is_some(),
                seen,
                recognized: r.object.map(|k| names[k].clone()),
                nearest: names[r.nearest].clone(),
                distance: r.distance,
                own_distance: r.own_distance,
                own_nearer: r.own_nearer.map(|k| names[k].clone()),
                confidence: r.confidence,
                pose,
                error_deg,
            });
        }
    }
    let right = |s: &Sample| s.recognized.as_deref() == Some(s.object.as_str());
    let known: Vec<&Sample> = samples.iter().filter(|s| s.known).collect();
    let known_unseen: Vec<&Sample> = known.iter().copied().filter(|s| !s.seen).collect();
    let unknown: Vec<&Sample> = samples.iter().filter(|s| !s.known).collect();
    let share = |num: usize, den: usize| (den > 0).then(|| num as f64 / den as f64);
    let recognition = Rates {
        all: share(known.iter().filter(|s| right(s)).count(), known.len()).unwrap_or(0.0),
        unseen: share(known_unseen.iter().filter(|s| right(s)).count(), known_unseen.len()),
        n_all: known.len(),
        n_unseen: known_unseen.len(),
    };
    let rejection = Rejection {
        unknown_views: unknown.len(),
        true_rejections: share(unknown.iter().filter(|s| s.recognized.is_none()).count(), unknown.len()),
        known_unseen_views: known_unseen.len(),
        false_rejections: share(known_unseen.iter().filter(|s| s.recognized.is_none()).count(), known_unseen.len()),
    };
    let mut confusion: BTreeMap<String, BTreeMap<String, usize>> = BTreeMap::new();
    for s in &samples {
        *confusion.entry(s.object.clone()).or_default().entry(s.recognized.clone().unwrap_or_else(|| UNKNOWN.into())).or_default() += 1;
    }
    let errors = |v: &[&Sample]| ErrorSummary::of(&v.iter().filter(|s| right(s)).filter_map(|s| s.error_deg).collect::<Vec<f64>>());
    let pose = PoseErrors { all: errors(&known), unseen: errors(&known_unseen) };
    let report = Report {
        recognizer: model.kind().name,
        method: model.method_name().unwrap_or(linpose::model_file::NO_POSES).to_string(),
        objects: names.to_vec(),
        n_eval: samples.len(),
        rejected,
        recognition,
        unknown: rejection,
        confusion,
        pose,
        predict_s,
        model_bytes: model.model_bytes(),
        recognizer_bytes: model.recognizer_bytes(),
        samples,
    };
    print_report(&report);
    if let Some(j) = &a.json {
        write_json(j, &report)?;
    }
    crate::queries::refusals(report.rejected.len(), report.rejected.len() + report.n_eval)
}

fn print_report(r: &Report) {
    let pct = |x: Option<f64>| x.map_or("-".to_string(), |v| format!("{:.2}%", 100.0 * v));
    let posed = r.method != linpose::model_file::NO_POSES;
    let method = if posed { r.method.as_str() } else { "no" };
    println!("{} recogniser, {method} pose models of {} objects; {} images evaluated", r.recognizer, r.objects.len(), r.n_eval);
    crate::queries::print_refused(r.rejected.len(), r.rejected.iter().map(|x| format!("{} ({}): {}", x.image, x.object, x.reason)));
    println!(
        "recognised: {} of the known objects' {} views, {} of their {} unseen views",
        pct(Some(r.recognition.all)),
        r.recognition.n_all,
        pct(r.recognition.unseen),
        r.recognition.n_unseen
    );
    println!(
        "reported unknown: {} of {} views of objects the model does not know, {} of {} unseen views of known objects",
        pct(r.unknown.true_rejections),
        r.unknown.unknown_views,
        pct(r.unknown.false_rejections),
        r.unknown.known_unseen_views
    );
    let confused: Vec<String> = r
        .confusion
        .iter()
        .flat_map(|(truth, row)| row.iter().filter(move |(got, _)| *got != truth).map(move |(got, n)| format!("{truth} as {got}: {n}")))
        .collect();
    if confused.is_empty() {
        println!("confusions: none");
    } else {
        println!("confusions: {}", confused.join(", "));
    }
    if posed {
        println!("pose error of views recognised as their object (degrees):");
        println!("{:<8} {:>6} {:>10} {:>10} {:>10} {:>10}", "", "n", "mean", "median", "p90", "max");
        for (name, s) in [("all", &r.pose.all), ("unseen", &r.pose.unseen)] {
            if let Some(s) = s {
                println!("{name:<8} {:>6} {:>10.4} {:>10.4} {:>10.4} {:>10.4}", s.n, s.mean_deg, s.median_deg, s.p90_deg, s.max_deg);
            }
        }
    }
    println!("model {} bytes ({} the recogniser); estimation {:.4} s", r.model_bytes, r.recognizer_bytes, r.predict_s);
}

#[derive(Serialize)]
struct Estimate<'a> {
    image: &'a str,
    object: Option<&'a str>,
    nearest: &'a str,
    distance: f64,
    own_distance: Option<f64>,
    own_nearer: Option<&'a str>,
    confidence: f64,
    pose: Option<BTreeMap<&'a str, f64>>,
    #[serde(skip_serializing_if = "Option::is_none")]
    hypotheses: Option<Vec<ObjectHypothesisRow<'a>>>,
}

/// One (object, pose) hypothesis of `predict --top` with a many-object model.
#[derive(Serialize)]
struct ObjectHypothesisRow<'a> {
    object: &'a str,
    distance: f64,
    pose: BTreeMap<&'a str, f64>,
    score: f64,
}

/// `predict` with a many-object model: each image's object, its confidence and its pose, or
/// "unknown".
pub(crate) fn predict(a: &PredictArgs, files: &[std::path::PathBuf]) -> anyhow::Result<()> {
    let model = linpose::recognize::ObjectModel::load(&a.model)?;
    if a.top.is_some() && model.space().is_none() {
        anyhow::bail!("--top: {} was trained without poses; it tells objects apart, with no (object, pose) hypotheses to rank", a.model.display());
    }
    let (spec, space) = (model.spec(), model.space());
    let m = spec.features();
    let context = format!("the size of the model's training images ({})", a.model.display());
    let bar = progress(files.len() as u64, "estimating");
    let mut out = crate::queries::Output::open(a.out.as_deref())?;
    let mut refused = 0usize;
    for chunk in files.chunks(crate::queries::BATCH) {
        // Decoded in parallel as `predict` decodes one object's queries, then all as features;
        // an image that cannot be read, or that the model refuses, has no estimate and leaves
        // the others theirs.
        let n = chunk.len();
        let (mut feats, mut pix) = (vec![0f32; n * m], vec![0u8; n * m]);
        let read: Vec<linpose::Result<bool>> = {
            use rayon::prelude::*;
            feats.par_chunks_mut(m).zip(pix.par_chunks_mut(m)).zip(chunk.par_iter()).map(|((f, p), path)| read_one(path, spec, &context, f, p)).collect()
        };
        let mut reasons: Vec<Option<String>> =
            read.iter().zip(chunk).map(|(r, path)| r.as_ref().err().map(|e| crate::queries::read_refusal(path, e))).collect();
        let rows: Vec<usize> = (0..n).filter(|&i| reasons[i].is_none()).collect();
        crate::queries::compact(&mut feats, m, &rows);
        crate::queries::compact(&mut pix, m, &rows);
        let (feats, pix) = (&mut feats[..rows.len() * m], &pix[..rows.len() * m]);
        eight_bit_as_features(feats, pix, m);
        let feats = &*feats;
        // Behind a normalisation stage, the images it refuses get why in their place.
        let outcomes = crate::queries::each_row(rows.len(), |r| model.estimate_each(&feats[r.start * m..r.end * m], 1));
        let mut est: Vec<Option<linpose::recognize::ObjectEstimate>> = (0..n).map(|_| None).collect();
        for (&i, o) in rows.iter().zip(outcomes) {
            match o {
                Ok(Ok(e)) => est[i] = Some(e),
                Ok(Err(r)) => reasons[i] = Some(crate::queries::cannot_normalise(&r)),
                Err(why) => reasons[i] = Some(why),
            }
        }
        // With --top, the (object, pose) hypotheses of each image that has an estimate.
        let mut ranked: Vec<Vec<linpose::recognize::ObjectHypothesis>> = vec![Vec::new(); n];
        if let Some(top) = a.top {
            let kept: Vec<usize> = (0..n).filter(|&i| est[i].is_some()).collect();
            let rows_of: Vec<f32> = kept.iter().flat_map(|&i| feats[rows.iter().position(|&r| r == i).unwrap_or(0) * m..][..m].iter().copied()).collect();
            let found = crate::queries::each_row(kept.len(), |r| model.hypotheses(&rows_of[r.start * m..r.end * m], top as usize));
            for (&i, h) in kept.iter().zip(found) {
                match h {
                    Ok(h) => ranked[i] = h,
                    Err(why) => {
                        est[i] = None;
                        reasons[i] = Some(why);
                    }
                }
            }
        }
        for (i, path) in chunk.iter().enumerate() {
            let Some(e) = &est[i] else {
                let why = reasons[i].as_deref().unwrap_or("no estimate");
                if a.strict {
                    out.flush()?;
                    anyhow::bail!("{}: {why}", path.display());
                }
                crate::queries::report_refused(&bar, path, why);
                if a.json {
                    serde_json::to_writer(&mut out, &serde_json::json!({ "image": path.display().to_string(), "refused": why }))?;
                    writeln!(out)?;
                }
                refused += 1;
                continue;
            };
            let name = path.display().to_string();
            let r = &e.recognition;
            let object = r.object.map(|k| model.names()[k].as_str());
            if a.json {
                let pose = e.pose.as_ref().zip(space).map(|(p, space)| space.params().iter().map(|q| q.name.as_str()).zip(p.pose.iter().copied()).collect());
                let row = Estimate {
                    image: &name,
                    object,
                    nearest: &model.names()[r.nearest],
                    distance: r.distance,
                    own_distance: r.own_distance,
                    own_nearer: r.own_nearer.map(|k| model.names()[k].as_str()),
                    confidence: r.confidence,
                    pose,
                    hypotheses: a.top.map(|_| {
                        ranked[i]
                            .iter()
                            .map(|h| ObjectHypothesisRow {
                                object: &model.names()[h.object],
                                distance: h.distance,
                                pose: space
                                    .map(|space| space.params().iter().map(|q| q.name.as_str()).zip(h.pose.pose.iter().copied()).collect())
                                    .unwrap_or_default(),
                                score: h.pose.score,
                            })
                            .collect()
                    }),
                };
                serde_json::to_writer(&mut out, &row)?;
                writeln!(out)?;
            } else {
                match object {
                    Some(o) => write!(out, "{name}\tobject={o}\tconfidence={:.3}", r.confidence)?,
                    None => {
                        write!(out, "{name}\tobject=unknown\tnearest={}\tdistance={:.4}\tthreshold={:.4}", model.names()[r.nearest], r.distance, r.threshold)?;
                        // Within the recogniser's threshold: the object's own eigenspace rejected
                        // it, or another object's own manifold lies nearer.
                        if let Some(d) = r.own_distance {
                            write!(out, "\town_distance={d:.4}\town_threshold={:.4}", r.own_threshold)?
                        }
                        if let Some(k) = r.own_nearer {
                            write!(out, "\town_nearer={}", model.names()[k])?
                        }
                    }
                }
                if let (Some(p), Some(space)) = (&e.pose, space) {
                    for (q, v) in space.params().iter().zip(&p.pose) {
                        write!(out, "\t{}={v:.4}", q.name)?;
                    }
                }
                if let Some(space) = space.filter(|_| a.top.is_some()) {
                    for (k, h) in ranked[i].iter().enumerate() {
                        write!(out, "\t#{}: object={}", k + 1, model.names()[h.object])?;
                        for (q, v) in space.params().iter().zip(&h.pose.pose) {
                            write!(out, " {}={v:.4}", q.name)?;
                        }
                        write!(out, " score={:.3}", h.pose.score)?;
                    }
                }
                writeln!(out)?;
            }
        }
        bar.inc(chunk.len() as u64);
    }
    bar.finish_and_clear();
    out.finish()?;
    crate::queries::refusals(refused, files.len())
}

/// A pose space's parameter names, for a message.
fn params(space: &linpose::PoseSpace) -> String {
    space.params().iter().map(|p| p.name.as_str()).collect::<Vec<_>>().join(", ")
}
