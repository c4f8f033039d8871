//! Many objects at scale: 100 procedural objects (`render::random`, seeds 200..300) on a turntable
//! every 10 degrees at 128 x 128 (36 training views each, 3600 images). Prints each recogniser's
//! fit time (whole `ObjectModel::fit` with eigenspace pose models, and the recogniser alone, once
//! each: a fit takes seconds) and its storage in Table 1's terms; criterion measures one query
//! (f32): its distances to every object, its recognition (the universal eigenspace's search
//! pruned by bounding spheres, then the second stage in the object's own eigenspace), the same
//! with the second stage off, and recognition then pose.
//!
//! cargo bench -p linpose --bench recognize
use criterion::{criterion_group, criterion_main, Criterion};
use linpose::recognize::{ObjectModel, RecognizerParams, Unknown, RECOGNIZERS};
use linpose::render::synth::{dataset, PoseGrid};
use linpose::render::{objects, Grid, RenderParams};
use linpose::{Dataset, EigenspaceParams, MethodSpec, ObjectSet};
use std::hint::black_box;
use std::time::Instant;

const OBJECTS: u64 = 100;

fn zoo() -> ObjectSet {
    let grid = PoseGrid::new(Grid::parse("elevation", "30").unwrap(), Grid::parse("azimuth", "0:350:10").unwrap()).unwrap();
    let params = RenderParams::default().width(128).height(128);
    let names: Vec<String> = (200..200 + OBJECTS).map(|s| format!("s{s}")).collect();
    let data: Vec<Dataset> =
        (200..200 + OBJECTS).map(|s| dataset(&objects::random(s).unwrap(), &grid, &params, std::path::Path::new("zoo"), &|_| {}).unwrap()).collect();
    ObjectSet::new(names, data).unwrap()
}

fn bench(c: &mut Criterion) {
    let set = zoo();
    let pose: MethodSpec = EigenspaceParams::default().into();
    let m = set.spec().features();
    let query = set.object(57).row(13).to_vec();
    for &kind in RECOGNIZERS {
        let params = RecognizerParams::new(kind);
        let t = Instant::now();
        let model = ObjectModel::fit(&set, &params, &pose).unwrap();
        let whole = t.elapsed().as_secs_f64();
        let s = model.recognizer_storage();
        let terms: Vec<String> = s.terms.iter().map(|(k, v)| format!("{k} = {v}")).collect();
        println!(
            "{}: {} objects x 36 views of {m} pixels: fit {whole:.2} s with eigenspace pose models; recogniser {} = {} numbers ({}), {} bytes; whole model {} bytes",
            kind.name,
            OBJECTS,
            kind.storage,
            s.numbers,
            terms.join(", "),
            model.recognizer_bytes(),
            model.model_bytes()
        );
        let mut g = c.benchmark_group(format!("{} recogniser, 100 objects", kind.name));
        g.sample_size(50);
        g.bench_function("one query: distances to every object", |b| b.iter(|| model.distances(black_box(&query)).unwrap()));
        g.bench_function("one query: recognition", |b| b.iter(|| model.recognize(black_box(&query)).unwrap()));
        // A fixed distance turns the second stage (the object's own eigenspace) off: the first
        // stage's cost alone, for comparison.
        let first = model.clone().with_unknown(Unknown::Threshold(f64::MAX)).unwrap();
        g.bench_function("one query: recognition, first stage alone", |b| b.iter(|| first.recognize(black_box(&query)).unwrap()));
        g.bench_function("one query: recognition then pose", |b| b.iter(|| model.estimate(black_box(&query), 1).unwrap()));
        g.finish();
    }
}

criterion_group!(benches, bench);
criterion_main!(benches);
