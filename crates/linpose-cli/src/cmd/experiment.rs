//! `linpose experiment`: the paper's study, run and reported (the main job).

use super::tuning::{
    SceneViewGrid, ThreeParamsGrid, COARSE_STEP, JITTER_EXPOSURE, JITTER_SCALE, JITTER_SHIFT_PER_WIDTH, SCENE_VIEWS, SCENE_VIEWS_FULL, SCENE_VIEWS_QUICK,
    SIZE_STEPS, THREE_PARAMS, THREE_PARAMS_FULL,
};
use crate::common::{load_dataset, progress};
use crate::report::{self, StudyInfo};
use crate::study::recognition::{self, RecognitionStudy};
use crate::study::scenes::{self, Backdrop, Condition, ScenesRow, ScenesStudy, StageCost};
use crate::study::table1::{self, SizePoint};
use crate::study::three_params::{self, ThreeParamsStudy};
use crate::study::tuning::{SCENE_SHARES, SCENE_SIDE_SHARES};
use crate::study::{normalization, run_object, ObjectResult, Run, StudyParams};
use anyhow::Context;
use linpose::image_io::{ColorMode, ImageSpec};
use linpose::render::background::Background;
use linpose::render::scene::Scene;
use linpose::render::synth::{self, PoseGrid};
use linpose::render::{objects, Grid, Jitter, RenderParams};
use linpose::{Dataset, Manifest, PoseModel, TrainSelection};
use std::path::{Path, PathBuf};
use std::time::Instant;

/// Arguments of `linpose experiment`.
#[derive(clap::Args, Debug)]
pub(crate) struct ExperimentArgs {
    /// Run the study on your own data set instead of the built-in objects (repeatable): a
    /// folder with poses.csv, or a COIL folder with --object.
    #[arg(long, value_name = "DIR")]
    pub data: Vec<PathBuf>,
    /// COIL object number for the --data folders in the COIL layout.
    #[arg(long, value_name = "O")]
    pub object: Option<u32>,
    /// Built-in objects of the main study (comma-separated).
    #[arg(long, value_delimiter = ',', default_value = "duck,pot,cap")]
    pub objects: Vec<String>,
    /// Built-in objects of the conclusion's open cases (comma-separated; empty for none).
    #[arg(long, value_delimiter = ',', default_value = "twin,column")]
    pub open_cases: Vec<String>,
    /// A smaller grid and images for a quick look (and the tests).
    #[arg(long, conflicts_with = "full")]
    pub quick: bool,
    /// The long version, on the built-in objects: the size sweep over 6,9,12,18,27 degrees, the
    /// normalisation study on every unseen view jittered, each object left out of recognition
    /// measured on every view, and the three-parameter section on azimuth 0:354:6 x elevation
    /// 32:77:9 x roll -30:30:10 at 160x120 (by default: steps 6,9,18,27, the views of a 12-degree
    /// grid for the two, and azimuth 0:348:12 x elevation 32:68:9 x roll -30:30:15 at 80x60).
    #[arg(long)]
    pub full: bool,
    /// Main training step in degrees (default: 9, the paper's; 18 with --quick).
    #[arg(long, value_name = "S")]
    pub train_step: Option<f64>,
    /// Training steps of the training-set-size sweep (default: 6,9,18,27; 6,9,12,18,27 with
    /// --full; 18,27,36 with --quick).
    #[arg(long, value_name = "S,...", value_delimiter = ',')]
    pub size_steps: Option<Vec<f64>>,
    /// Noise levels of the queries, fractions of full brightness.
    #[arg(long, value_name = "A,...", value_delimiter = ',', default_value = "0,0.05,0.1")]
    pub noise: Vec<f64>,
    /// Seed of the query noise.
    #[arg(long, default_value_t = 0)]
    pub seed: u64,
    /// Report folder (replaced whole when the study has finished).
    #[arg(long, value_name = "DIR", default_value = "report")]
    pub out: PathBuf,
    /// Write 0 for every time measured (fit, estimation, per query, total), so that the same
    /// study gives byte-identical reports from run to run and across thread counts.
    #[arg(long)]
    pub no_timings: bool,
}

/// Replaces `out` by the finished folder `tmp` (the old report is removed only once the new one
/// is complete).
fn replace_dir(tmp: &Path, out: &Path) -> anyhow::Result<()> {
    if out.exists() {
        if !out.is_dir() {
            anyhow::bail!("{}: the report output exists and is not a folder", out.display());
        }
        let old = out.with_file_name(format!(".{}.old-{}", out.file_name().and_then(|n| n.to_str()).unwrap_or("report"), std::process::id()));
        std::fs::rename(out, &old).with_context(|| format!("{}: cannot move the old report aside", out.display()))?;
        std::fs::rename(tmp, out).with_context(|| format!("{}: cannot move the new report into place", out.display()))?;
        std::fs::remove_dir_all(&old).with_context(|| format!("{}: cannot remove the old report", old.display()))?;
    } else {
        std::fs::rename(tmp, out).with_context(|| format!("{}: cannot move the report into place", out.display()))?;
    }
    Ok(())
}

/// Runs `linpose experiment`.
pub(crate) fn run(a: &ExperimentArgs) -> anyhow::Result<()> {
    let t0 = Instant::now();
    if a.out.exists() && !a.out.is_dir() {
        anyhow::bail!("{}: the report output exists and is not a folder", a.out.display());
    }
    for &n in &a.noise {
        if !(n.is_finite() && (0.0..=1.0).contains(&n)) {
            anyhow::bail!("--noise {n} is outside [0, 1]: noise is a fraction of full brightness (0.05 = +-5%)");
        }
    }
    // Checked before any object is rendered or loaded.
    for (flag, steps) in [("--train-step", a.train_step.as_slice()), ("--size-steps", a.size_steps.as_deref().unwrap_or_default())] {
        if let Some(s) = steps.iter().find(|s| !(s.is_finite() && **s > 0.0)) {
            anyhow::bail!("{flag} {s} is not a positive number of degrees");
        }
    }
    let mut params = StudyParams {
        methods: StudyParams::default().methods,
        train_step: a.train_step.unwrap_or(if a.quick { 18.0 } else { 9.0 }),
        noise: a.noise.clone(),
        size_steps: a.size_steps.clone().unwrap_or_else(|| match (a.quick, a.full) {
            (true, _) => vec![18.0, 27.0, 36.0],
            (false, true) => vec![6.0, 9.0, 12.0, 18.0, 27.0],
            (false, false) => SIZE_STEPS.to_vec(),
        }),
        seed: a.seed,
    };
    if !params.noise.contains(&0.0) {
        params.noise.insert(0, 0.0);
    }
    let (az, el, size) = if a.quick {
        (Grid::parse("azimuth", "0:351:9")?, Grid::parse("elevation", "32:77:9")?, (80, 60))
    } else {
        (Grid::paper_azimuth(), Grid::paper_elevation(), (160, 120))
    };
    let render_params = RenderParams::default().width(size.0).height(size.1);
    let grid = PoseGrid::new(el.clone(), az.clone())?;
    // The built-in objects on the paper's grid, not --full: the slow measures on a coarser grid.
    let coarse = !a.quick && !a.full && a.data.is_empty();
    let (jitter_az, jitter_el) = if coarse {
        (Grid::parse("azimuth", &format!("0:327:{COARSE_STEP}"))?, Grid::parse("elevation", &format!("32:77:{COARSE_STEP}"))?)
    } else {
        (az.clone(), el.clone())
    };
    let jitter_grid = PoseGrid::new(jitter_el.clone(), jitter_az.clone())?;
    let left_out_step = coarse.then_some(COARSE_STEP);
    // The objects: user data sets, or the built-in ones rendered on the grid.
    enum Source {
        Builtin(String),
        Folder(PathBuf),
    }
    let sources: Vec<(String, Source)> = if a.data.is_empty() {
        a.objects.iter().chain(a.open_cases.iter()).filter(|s| !s.is_empty()).map(|s| (s.clone(), Source::Builtin(s.clone()))).collect()
    } else {
        a.data
            .iter()
            .map(|d| {
                let base = d.file_name().map(|n| n.to_string_lossy().into_owned()).unwrap_or_else(|| d.display().to_string());
                let name = match a.object {
                    Some(o) => format!("{base}-obj{o}"),
                    None => base,
                };
                (name, Source::Folder(d.clone()))
            })
            .collect()
    };
    // Check every built-in name before any work.
    for (_, s) in &sources {
        if let Source::Builtin(n) = s {
            objects::builtin(n)?;
        }
    }
    let open_cases: Vec<String> = if a.data.is_empty() { a.open_cases.iter().filter(|s| !s.is_empty()).cloned().collect() } else { vec![] };
    let parent = a.out.parent().filter(|p| !p.as_os_str().is_empty()).unwrap_or(Path::new("."));
    std::fs::create_dir_all(parent).with_context(|| format!("{}: cannot create the report's parent folder", parent.display()))?;
    let tmp = parent.join(format!(".{}.tmp-{}", a.out.file_name().and_then(|n| n.to_str()).unwrap_or("report"), std::process::id()));
    let _ = std::fs::remove_dir_all(&tmp);
    std::fs::create_dir_all(tmp.join("figures"))
        .and_then(|_| std::fs::create_dir_all(tmp.join("models")))
        .with_context(|| format!("{}: cannot create the report folder", tmp.display()))?;
    // The Table 1 figure's points of one pose parameter, from the first object.
    let mut ring_points: Vec<SizePoint> = Vec::new();
    // The scenes section, on the built-in objects of the main study.
    let scene_views = match (a.quick, a.full) {
        (true, _) => SCENE_VIEWS_QUICK,
        (false, true) => SCENE_VIEWS_FULL,
        (false, false) => SCENE_VIEWS,
    };
    let scene_setup = SceneSetup {
        grid: scene_grid(&scene_views)?,
        views: format!("azimuth {} x elevation {}", scene_views.azimuth, scene_views.elevation),
        render: render_params.clone(),
        conditions: scenes::conditions(&SCENE_SHARES, if a.full { &SCENE_SHARES } else { &SCENE_SIDE_SHARES }),
        seed: params.seed,
    };
    let (mut scene_rows, mut scene_stages, mut scene_s): (Vec<ScenesRow>, Vec<StageCost>, f64) = (vec![], vec![], 0.0);
    let result = (|| -> anyhow::Result<Studied> {
        let mut results = Vec::new();
        let mut kept = Vec::new();
        let mut data_s = 0.0;
        for (name, src) in &sources {
            let td = Instant::now();
            let data = match src {
                Source::Builtin(n) => {
                    let bar = progress(grid.len() as u64, &format!("rendering {n}"));
                    let d = synth::dataset(&objects::builtin(n)?, &grid, &render_params, Path::new(n), &|k| bar.inc(k))?;
                    bar.finish_and_clear();
                    d
                }
                Source::Folder(d) => load_dataset(Manifest::open(d, a.object)?, ColorMode::Gray)?,
            };
            // The same views as a camera in a cell would take them, for the normalisation's study.
            let jittered = match src {
                Source::Builtin(n) => {
                    let bar = progress(jitter_grid.len() as u64, &format!("rendering {n}, jittered"));
                    let shift = JITTER_SHIFT_PER_WIDTH * size.0 as f64;
                    let jgrid = jitter_grid.clone().with_jitter(Jitter { shift, scale: JITTER_SCALE, exposure: JITTER_EXPOSURE, seed: params.seed })?;
                    let d = synth::dataset(&objects::builtin(n)?, &jgrid, &render_params, Path::new(n), &|k| bar.inc(k))?;
                    bar.finish_and_clear();
                    Some(d)
                }
                Source::Folder(_) => None,
            };
            data_s += td.elapsed().as_secs_f64();
            let stages = (params.methods.len() * (params.noise.len() + 2) + params.methods.len() * params.size_steps.len()) as u64;
            let bar = progress(stages, name);
            let tick = |stage: &str| {
                bar.set_message(stage.to_string());
                bar.inc(1);
            };
            let mut r = run_object(name, &data, &params, &tick).with_context(|| format!("the study on {name}"))?;
            // The plain models' unseen mean on the registered views is the clean run's.
            let clean: Vec<f64> = r
                .models
                .iter()
                .map(|m| r.runs.iter().find(|x| x.method == m.meta().method && x.noise == 0.0).map(unseen_mean))
                .collect::<Option<_>>()
                .context("a clean run per method")?;
            r.normalization = normalization::run(&data, jittered.as_ref(), &r.models, Some(&clean), &params, &|s| tick(&format!("{name}: {s}")))
                .with_context(|| format!("the normalisation study on {name}"))?;
            bar.finish_and_clear();
            for m in &r.models {
                m.save(&tmp.join("models").join(format!("{name}-{}.safetensors", m.meta().method)))?;
            }
            if results.is_empty() {
                ring_points = ring_sizes(name, &data, &params)?;
            }
            let mask = data.manifest().training_mask(&TrainSelection::Step(params.train_step))?;
            if let (Source::Builtin(n), false) = (src, open_cases.contains(name)) {
                let t = Instant::now();
                let (rows, stage) = scenes_of(n, &data.subset(&mask)?, &r.models, &scene_setup).with_context(|| format!("the scenes study on {name}"))?;
                scene_s += t.elapsed().as_secs_f64();
                scene_rows.extend(rows);
                scene_stages.push(stage);
            }
            // Every view kept (8-bit where exact) for the recognition study across the objects.
            kept.push((data.subset(&mask)?, Views::keep(data)));
            results.push(r);
        }
        Ok((results, data_s, kept))
    })();
    let (mut results, mut data_s, kept) = match result {
        Ok(r) => r,
        Err(e) => {
            let _ = std::fs::remove_dir_all(&tmp);
            return Err(e);
        }
    };
    let recognition = match recognition_study(&results, kept, left_out_step) {
        Ok(r) => r,
        Err(e) => {
            let _ = std::fs::remove_dir_all(&tmp);
            return Err(e);
        }
    };
    // Three pose parameters, on the first built-in object.
    let three = match sources.first() {
        Some((_, Source::Builtin(n))) => match three_params_study(n, if a.full { &THREE_PARAMS_FULL } else { &THREE_PARAMS }, &params) {
            Ok((study, points, s)) => {
                data_s += s;
                Some((study, points))
            }
            Err(e) => {
                let _ = std::fs::remove_dir_all(&tmp);
                return Err(e.context(format!("the three-parameter study on {n}")));
            }
        },
        _ => None,
    };
    // The Table 1 figure: one parameter (the first object's ring), two (its size sweep), three.
    let mut table1_sizes = ring_points;
    table1_sizes.extend(results.first().map(table1::from_sweep).unwrap_or_default());
    let (mut three_params, three_points) = three.unzip();
    table1_sizes.extend(three_points.unwrap_or_default());
    let mut scenes_study = (!scene_rows.is_empty()).then(|| ScenesStudy {
        views: scene_setup.views.clone(),
        seed: scene_setup.seed,
        conditions: scene_setup.conditions.clone(),
        rows: scene_rows,
        stages: scene_stages,
        total_s: scene_s,
    });
    let recognition = recognition.map(|mut s| {
        if a.no_timings {
            s.rows.iter_mut().for_each(|r| (r.fit_s, r.per_query_us) = (0.0, 0.0));
        }
        s
    });
    if a.no_timings {
        data_s = 0.0;
        table1_sizes.iter_mut().for_each(|p| p.cost.per_query_us = 0.0);
        if let Some(s) = &mut scenes_study {
            s.rows.iter_mut().for_each(|r| (r.plain.per_query_us, r.robust.per_query_us) = (0.0, 0.0));
            s.stages.iter_mut().for_each(|t| t.fit_s = 0.0);
            s.total_s = 0.0;
        }
        if let Some(t) = &mut three_params {
            t.rows.iter_mut().for_each(|r| (r.fit_s, r.cost.per_query_us) = (0.0, 0.0));
            t.total_s = 0.0;
        }
        for r in &mut results {
            r.runs.iter_mut().for_each(|x| (x.fit_s, x.predict_s, x.per_query_us) = (0.0, 0.0, 0.0));
            r.table1.iter_mut().for_each(|t| t.per_query_us = 0.0);
            r.sweep.iter_mut().for_each(|p| p.cost.per_query_us = 0.0);
        }
    }
    let info = StudyInfo {
        source: if a.data.is_empty() {
            format!("linpose's built-in turntable objects ({}), rendered", sources.iter().map(|s| s.0.as_str()).collect::<Vec<_>>().join(", "))
        } else {
            "the user's data sets".into()
        },
        grid: if a.data.is_empty() {
            format!("azimuth {} x elevation {} = {} images of {}x{} per object", az, el, az.len() * el.len(), size.0, size.1)
        } else {
            a.data.iter().map(|d| d.display().to_string()).collect::<Vec<_>>().join(", ")
        },
        methods: params.methods.iter().map(|m| m.name().to_string()).collect(),
        train_step: params.train_step,
        noise: params.noise.clone(),
        size_steps: params.size_steps.clone(),
        jitter_grid: coarse.then(|| format!("azimuth {jitter_az} x elevation {jitter_el}")),
        left_out_step,
        seed: params.seed,
        open_cases,
        data_s,
        total_s: if a.no_timings { 0.0 } else { t0.elapsed().as_secs_f64() },
        recognition,
        three_params,
        scenes: scenes_study,
        table1_sizes,
    };
    let written = (|| -> anyhow::Result<()> {
        let doc = report::build(&info, &results).map_err(|e| anyhow::anyhow!("drawing the figures: {e}"))?;
        for (file, bytes) in doc.figure_files() {
            linpose::atomic::write_atomic(&tmp.join("figures").join(file), &bytes)?;
        }
        linpose::atomic::write_atomic(&tmp.join("report.md"), doc.markdown().as_bytes())?;
        linpose::atomic::write_atomic(&tmp.join("report.html"), doc.html().as_bytes())?;
        crate::common::write_json(&tmp.join("results.json"), &serde_json::json!({ "study": info, "objects": results }))?;
        replace_dir(&tmp, &a.out)?;
        linpose::atomic::remove_stale_temps(&a.out);
        Ok(())
    })();
    if let Err(e) = written {
        let _ = std::fs::remove_dir_all(&tmp);
        return Err(e);
    }
    summary(&info, &results, &a.out);
    Ok(())
}

/// The Table 1 figure's points of one pose parameter: every method fitted on the ring of `data`
/// ([`table1::ring`]) at each training step of the size sweep, timed on the whole ring. None
/// when `data` has no such ring.
fn ring_sizes(name: &str, data: &Dataset, params: &StudyParams) -> anyhow::Result<Vec<SizePoint>> {
    let Some(ring) = table1::ring(data)? else { return Ok(vec![]) };
    let trainings: Vec<Vec<bool>> =
        params.size_steps.iter().map(|&s| ring.manifest().training_mask(&TrainSelection::Step(s))).collect::<linpose::Result<_>>()?;
    let bar = progress((trainings.len() * params.methods.len()) as u64, &format!("{name}, one parameter"));
    let points = table1::sizes(&table1::Sizes { object: name, data: &ring, trainings: &trainings, methods: &params.methods, timed: &ring }, &|s| {
        bar.set_message(s.to_string());
        bar.inc(1);
    })
    .with_context(|| format!("the one-parameter fits on {name}"))?;
    bar.finish_and_clear();
    Ok(points)
}

/// The three-parameter section on the built-in object `name` rendered on `g`: the study (its
/// `total_s` the section's wall time, rendering included), the Table 1 figure's points of three
/// parameters, and the seconds spent rendering.
fn three_params_study(name: &str, g: &ThreeParamsGrid, params: &StudyParams) -> anyhow::Result<(ThreeParamsStudy, Vec<SizePoint>, f64)> {
    let (az, el, roll) = (Grid::parse("azimuth", g.azimuth)?, Grid::parse("elevation", g.elevation)?, Grid::parse("roll", g.roll)?);
    let grid = PoseGrid::new(el.clone(), az.clone())?.with_roll(roll.clone())?;
    let render = RenderParams::default().width(g.size.0).height(g.size.1);
    let t = Instant::now();
    let bar = progress(grid.len() as u64, &format!("rendering {name}, three parameters"));
    let data = synth::dataset(&objects::builtin(name)?, &grid, &render, Path::new(name), &|k| bar.inc(k))?;
    bar.finish_and_clear();
    let data_s = t.elapsed().as_secs_f64();
    let desc = format!("azimuth {az} x elevation {el} x roll {roll} = {} images of {}x{}", grid.len(), g.size.0, g.size.1);
    let bar = progress((params.methods.len() * (2 + crate::study::tuning::THIN.len())) as u64, &format!("{name}, three parameters"));
    let (study, points) = three_params::run(name, &data, &desc, params, &|s| {
        bar.set_message(s.to_string());
        bar.inc(1);
    })?;
    bar.finish_and_clear();
    Ok((ThreeParamsStudy { total_s: t.elapsed().as_secs_f64(), ..study }, points, data_s))
}

/// What the scenes section renders and runs on each object.
struct SceneSetup {
    /// The views' poses (each condition's scene put on them).
    grid: PoseGrid,
    /// The views in words.
    views: String,
    /// The main study's render parameters (its image size, the studio backdrop).
    render: RenderParams,
    /// The conditions.
    conditions: Vec<Condition>,
    /// The scenes' seed.
    seed: u64,
}

/// The pose grid of `g`.
fn scene_grid(g: &SceneViewGrid) -> anyhow::Result<PoseGrid> {
    Ok(PoseGrid::new(Grid::parse("elevation", g.elevation)?, Grid::parse("azimuth", g.azimuth)?)?)
}

/// The scenes section on the built-in object `name`: `models` (fitted on `train`) plain and
/// robust on its views rendered into every condition's scenes.
fn scenes_of(name: &str, train: &Dataset, models: &[linpose::AnyModel], s: &SceneSetup) -> anyhow::Result<(Vec<ScenesRow>, StageCost)> {
    let mesh = objects::builtin(name)?;
    let spec = ImageSpec { width: s.render.get_width(), height: s.render.get_height(), color: ColorMode::Gray };
    let views = |c: Condition| -> linpose::Result<scenes::SceneViews> {
        let background = match c.backdrop {
            Backdrop::Studio => Background::Level(s.render.get_background()),
            Backdrop::Texture => Background::Texture,
            Backdrop::Noise => Background::Noise,
        };
        let grid = s.grid.clone().with_scene(Scene::new(background, c.occlude, s.seed)?);
        let v = synth::render_scenes(&mesh, &grid, &s.render, &|_| {})?;
        let hidden = if v.records.is_empty() { 0.0 } else { v.records.iter().map(|r| r.hidden).sum::<f64>() / v.records.len() as f64 };
        Ok(scenes::SceneViews { data: Dataset::from_pixels(grid.manifest(Path::new(name))?, spec, v.pixels)?, hidden })
    };
    let bar = progress((1 + s.conditions.len()) as u64, &format!("{name}, scenes"));
    let out = scenes::run(&scenes::ObjectScenes { object: name, train, plain: models, conditions: &s.conditions, views: &views }, s.seed, &|m| {
        bar.set_message(m.to_string());
        bar.inc(1);
    })?;
    bar.finish_and_clear();
    Ok(out)
}

/// The per-object studies, the seconds spent making or reading the data, and each object's
/// training views and every view (for the recognition study).
type Studied = (Vec<ObjectResult>, f64, Vec<(Dataset, Views)>);

/// An object's every view, kept for the recognition study: as 8-bit pixels when every feature
/// is one (a quarter of the memory), else as they are.
enum Views {
    U8(Manifest, linpose::image_io::ImageSpec, Vec<u8>),
    F32(Dataset),
}

impl Views {
    fn keep(data: Dataset) -> Views {
        let exact = data.features().iter().all(|&v| (v * 255.0).round() * (1.0 / 255.0) == v);
        if exact {
            let px = data.features().iter().map(|&v| (v * 255.0).round() as u8).collect();
            Views::U8(data.manifest().clone(), data.spec(), px)
        } else {
            Views::F32(data)
        }
    }

    fn dataset(&self) -> linpose::Result<Dataset> {
        match self {
            Views::U8(m, spec, px) => Dataset::from_features(m.clone(), *spec, px.iter().map(|&v| v as f32 * (1.0 / 255.0)).collect()),
            Views::F32(d) => Ok(d.clone()),
        }
    }
}

/// The recognition study across the study's objects, when there are at least two of one image
/// size and pose parameters (otherwise none).
fn recognition_study(results: &[ObjectResult], kept: Vec<(Dataset, Views)>, left_out_step: Option<f64>) -> anyhow::Result<Option<RecognitionStudy>> {
    if kept.len() < 2 {
        return Ok(None);
    }
    let (train, views): (Vec<Dataset>, Vec<Views>) = kept.into_iter().unzip();
    if train.iter().any(|d| d.spec() != train[0].spec() || d.space() != train[0].space()) {
        eprintln!("linpose: the objects differ in image size or pose parameters: no recognition study across them");
        return Ok(None);
    }
    let names: Vec<String> = results.iter().map(|r| r.name.clone()).collect();
    let set = linpose::ObjectSet::new(names, train)?;
    let methods = results[0].models.len();
    let models: Vec<Vec<linpose::AnyModel>> = (0..methods).map(|m| results.iter().map(|r| r.models[m].clone()).collect()).collect();
    // Each model's clean errors on its object's views (the clean run's).
    let errors = models
        .iter()
        .map(|per_object| {
            results
                .iter()
                .zip(per_object)
                .map(|(r, m)| r.runs.iter().find(|x| x.method == m.meta().method && x.noise == 0.0).map(|x| x.errors.clone()))
                .collect::<Option<Vec<Vec<f64>>>>()
        })
        .collect::<Option<Vec<_>>>()
        .context("a clean run per method and object")?;
    let poses = recognition::PoseRuns { models, errors };
    let bar = progress((2 * (1 + set.len())) as u64, "recognition");
    let study = recognition::run(&set, &|k| views[k].dataset(), &poses, left_out_step, &|s| {
        bar.set_message(s.to_string());
        bar.inc(1);
    })
    .context("the recognition study")?;
    bar.finish_and_clear();
    Ok(Some(study))
}

/// A run's unseen mean error (over all views when none was unseen).
fn unseen_mean(r: &Run) -> f64 {
    r.unseen.map_or(r.all.mean_deg, |u| u.mean_deg)
}

fn summary(info: &StudyInfo, results: &[ObjectResult], out: &Path) {
    println!("linpose experiment: {} objects, methods {}, {:.1} s", results.len(), info.methods.join(", "), info.total_s);
    let noisy: Vec<f64> = info.noise.iter().copied().filter(|&n| n > 0.0).collect();
    print!("{:<10} {:<12} {:>6} {:>12}", "object", "method", "N", "unseen mean");
    for n in &noisy {
        print!(" {:>12}", format!("+-{}% noise", (n * 100.0).round()));
    }
    println!(" {:>12}", "model bytes");
    for r in results {
        for run in r.runs.iter().filter(|x| x.noise == 0.0) {
            print!("{:<10} {:<12} {:>6} {:>12.2}", r.name, run.method, run.n_train, run.unseen.map_or(run.all.mean_deg, |u| u.mean_deg));
            for n in &noisy {
                let v = r.runs.iter().find(|x| x.method == run.method && x.noise == *n).map_or(f64::NAN, |x| x.unseen.map_or(x.all.mean_deg, |u| u.mean_deg));
                print!(" {:>12.2}", v);
            }
            println!(" {:>12}", run.model_bytes);
        }
    }
    if let Some(s) = &info.recognition {
        for r in &s.rows {
            let left = r.left_out_rejected.map_or(String::new(), |t| {
                format!(", left out: {:.1}% of its views unknown, others' unseen {:.1}%", 100.0 * t, 100.0 * r.left_out_false.unwrap_or(f64::NAN))
            });
            println!(
                "recognition ({} objects, {}): unseen {:.1}% recognised, {:.1}% reported unknown{left}",
                s.objects.len(),
                r.recognizer,
                100.0 * r.recognized_unseen,
                100.0 * r.false_rejections
            );
        }
    }
    if let Some(t) = &info.three_params {
        println!("three parameters ({}: {}; {} trained, {} unseen inside the training range; {:.1} s):", t.object, t.grid, t.n_train, t.n_unseen, t.total_s);
        println!("{:<12} {:>12} {:>8} {:>12} {:>12} {:>16}", "method", "model bytes", "fit s", "us per query", "unseen mean", "gross (flagged)");
        for r in &t.rows {
            println!(
                "{:<12} {:>12} {:>8.2} {:>12.1} {:>12.2} {:>16}",
                r.method,
                r.cost.model_bytes,
                r.fit_s,
                r.cost.per_query_us,
                r.unseen.mean_deg,
                format!("{} ({})", r.gross, r.gross_flagged)
            );
        }
    }
    if let Some(text) = info.scenes.as_ref().and_then(report::scenes_finding) {
        println!("{} ({:.1} s)", text.replace("**", ""), info.scenes.as_ref().map_or(0.0, |s| s.total_s));
    }
    println!("errors: unseen-view mean, degrees. Report: {}", out.join("report.html").display());
}
