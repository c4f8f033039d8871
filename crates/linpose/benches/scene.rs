//! Scenes: the robust stage's query costs. The duck on a turntable every 10 degrees at 128 x 128
//! (36 training views, refined, behind the robust stage); criterion measures one query of the
//! view between two training views on a textured background with 20% of the object hidden (the
//! robust fit, the repair and the method), the same view in the studio (the check, then the
//! method; and the check alone: `Robust::repair`, which a studio view passes), and the search for it in a 320 x 240 scene (at scale 1.13 at (97.6, 41.3)):
//! the box, then the robust fit and the repair of the view found (`SceneSearch::locate`), and
//! the estimate after it. Then many objects: 20 procedural objects (`render::random`, seeds
//! 200..220) trained the same way as one model (the default recogniser, refined pose models),
//! plain and behind the robust stage: one studio query between two training views, whose check
//! (the named object's stage) it passes, and a batch of 20 such views, one per object.
//!
//! cargo bench -p linpose --bench scene
use criterion::{criterion_group, criterion_main, Criterion};
use linpose::image_io::ImageSpec;
use linpose::recognize::{ObjectModel, RecognizerParams};
use linpose::render::background::Background;
use linpose::render::place::Canvas;
use linpose::render::scene::{Scene, SceneSpec};
use linpose::render::synth::{dataset, PoseGrid};
use linpose::render::{objects, random, Grid, Mesh, RenderParams};
use linpose::robust::Robust;
use linpose::{Dataset, Estimator, MethodSpec, ObjectSet, PoseModel, RefinedParams};
use std::hint::black_box;

fn render(azimuth: &str, scene: Option<Scene>) -> Dataset {
    render_mesh(&objects::builtin("duck").unwrap(), azimuth, scene)
}

fn render_mesh(mesh: &Mesh, azimuth: &str, scene: Option<Scene>) -> Dataset {
    let mut grid = PoseGrid::new(Grid::parse("elevation", "30").unwrap(), Grid::parse("azimuth", azimuth).unwrap()).unwrap();
    if let Some(s) = scene {
        grid = grid.with_scene(s);
    }
    let params = RenderParams::default().width(128).height(128);
    dataset(mesh, &grid, &params, std::path::Path::new("<render>"), &|_| {}).unwrap()
}

fn bench(c: &mut Criterion) {
    let train = render("0:350:10", None);
    let inner = linpose::AnyModel::new(RefinedParams::default().fit(&train).unwrap());
    let model = Robust::fit(&train, inner).unwrap();
    let studio = render("125", None);
    let hidden = render("125", Some(Scene::new(Background::Texture, 0.2, 3).unwrap()));
    // The studio view's object (the renderer's backdrop is 0) placed in a 320 x 240 scene.
    let spec = train.spec();
    let pixels: Vec<u8> = studio.row(0).iter().map(|&v| (v * 255.0).round() as u8).collect();
    let mask: Vec<bool> = pixels.iter().map(|&v| v > 0).collect();
    let canvas = Canvas::new(320, 240, [1.13, 1.13]).unwrap();
    let scene =
        SceneSpec { background: linpose::render::background::BackgroundSpec::Texture, occlude: 0.0, seed: 5, canvas: Some(canvas) }.open(128, 128).unwrap();
    let (big, record) = scene.place(0, "duck", spec, &mask, &pixels).unwrap();
    let big: Vec<f32> = big.iter().map(|&v| v as f32 / 255.0).collect();
    let big_spec = ImageSpec { width: 320, height: 240, ..spec };
    let search = model.scene_search().unwrap();
    let found = search.locate(&big, big_spec).unwrap();
    println!("scene: the frame at {:?}, found at {:?} (shown {:.2})", record.bbox.unwrap(), found[0].bbox, found[0].shown);
    let mut g = c.benchmark_group("robust stage, 128 x 128 views");
    g.sample_size(20);
    g.bench_function("one studio query (check, then the method)", |b| b.iter(|| model.estimate(black_box(studio.row(0)), 1).unwrap()));
    let robust = model.downcast_ref::<Robust>().expect("a robust model");
    assert!(robust.repair(studio.row(0)).is_none(), "the studio view passes the check");
    g.bench_function("the check alone, one studio view", |b| b.iter(|| robust.repair(black_box(studio.row(0)))));
    g.bench_function("one query, textured background, 20% hidden", |b| b.iter(|| model.estimate(black_box(hidden.row(0)), 1).unwrap()));
    g.bench_function("one 320 x 240 scene: search and repair", |b| b.iter(|| search.locate(black_box(&big), big_spec).unwrap()));
    g.bench_function("one 320 x 240 scene: search, repair and estimate", |b| {
        b.iter(|| {
            let f = search.locate(black_box(&big), big_spec).unwrap();
            search.estimate_located(&f, 1).unwrap()
        })
    });
    g.finish();
    many_objects(c);
}

/// Many objects' studio queries, plain and behind the robust stage.
fn many_objects(c: &mut Criterion) {
    let meshes: Vec<Mesh> = (200..220).map(|s| random::random(s).unwrap()).collect();
    let set = ObjectSet::new((200..220).map(|s| format!("s{s}")).collect(), meshes.iter().map(|m| render_mesh(m, "0:350:10", None)).collect()).unwrap();
    let pose: MethodSpec = RefinedParams::default().into();
    let plain = ObjectModel::fit(&set, &RecognizerParams::default(), &pose).unwrap();
    let robust = plain.clone().with_robust(&set).unwrap();
    let between: Vec<f32> = meshes.iter().enumerate().flat_map(|(k, m)| render_mesh(m, &format!("{}", 5 + 10 * (7 * k % 36)), None).row(0).to_vec()).collect();
    let one = &between[..set.spec().features()];
    let (p, r) = (plain.estimate(&between, 1).unwrap(), robust.estimate(&between, 1).unwrap());
    let same = p.iter().zip(&r).filter(|(a, b)| a.pose.as_ref().map(|e| &e.pose) == b.pose.as_ref().map(|e| &e.pose)).count();
    println!("many objects: {same} of {} studio views answered the same plain and behind the robust stage", p.len());
    let mut g = c.benchmark_group("20 objects, 128 x 128 views, refined");
    g.sample_size(20);
    g.bench_function("one studio query, plain", |b| b.iter(|| plain.estimate(black_box(one), 1).unwrap()));
    g.bench_function("one studio query, behind the robust stage", |b| b.iter(|| robust.estimate(black_box(one), 1).unwrap()));
    g.bench_function("20 studio queries, plain", |b| b.iter(|| plain.estimate(black_box(&between), 1).unwrap()));
    g.bench_function("20 studio queries, behind the robust stage", |b| b.iter(|| robust.estimate(black_box(&between), 1).unwrap()));
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
