use super::*;
use crate::image_io::ColorMode;
use crate::methods::find;
use crate::{Param, PoseSpace};

fn job(n: usize, m: usize, method: &str, settings: &[(&str, &str)]) -> Job {
    let s = settings.iter().fold(Settings::new(), |s, &(k, v)| s.set(k, v));
    Job::new(n, m, 3, find(method).unwrap(), &s).unwrap().threads(2)
}

const MIB: u64 = 1 << 20;

/// The linear model's in-memory estimate is the formula: 4 N M + 24 N^2 + 2 KiB N + the
/// weights + the overhead.
#[test]
fn linear_estimate_is_the_formula() {
    let (n, m) = (1000u64, 500u64);
    let e = estimate::in_memory(&job(n as usize, m as usize, "linear", &[]));
    // G is 8 MB: under glibc's mmap threshold, one more is counted for the heap.
    let want = 4 * n * m
        + 24 * n * n
        + 2048 * n
        + 8 * n * n
        + 24 * 3 * m
        + tuning::OVERHEAD_BYTES
        + n * tuning::IMAGE_ENTRY_BYTES
        + 2 * m * tuning::THREAD_FEATURE_BYTES;
    assert_eq!(e.bytes, want);
    assert_eq!(e.what, "N x N Gram of 1000 images");
    // Leave-one-out and a noise level (twice the rows) need more; the streamed path for N > M
    // needs M^2-order memory whatever N.
    assert!(estimate::in_memory(&job(1000, 500, "linear", &[("ridge", "auto")])).bytes > e.bytes);
    assert!(estimate::in_memory(&job(1000, 500, "linear", &[("noise-level", "0.1")])).bytes > 3 * e.bytes);
    let s = estimate::streamed(&job(1000, 500, "linear", &[("ridge", "1e-3")]));
    assert!(s.what.contains("X^T X of 500 features") || s.bytes < e.bytes, "{s:?}");
    // Beside the manifest's entry per image.
    assert_eq!(
        estimate::streamed(&job(200_000, 500, "linear", &[])).bytes - estimate::streamed(&job(100_000, 500, "linear", &[])).bytes,
        100_000 * tuning::IMAGE_ENTRY_BYTES
    );
}

/// Small sizes with a small budget: in memory when it fits, streamed when only that fits, and
/// the line says which and why.
#[test]
fn the_plan_takes_the_path_that_fits() {
    // Fewer images than features: in memory when it fits.
    let few = plan(&job(100, 192, "linear", &[]), &Limit::Budget(1 << 30), None).unwrap();
    assert_eq!(few.path, Path::InMemory);
    assert!(
        few.describe().starts_with("memory: in memory needs ") && few.describe().ends_with("within the budget of 1.0 GiB: in memory"),
        "{}",
        few.describe()
    );
    // More images than features: least squares through X^T X even where the Gram matrix fits.
    let j = job(4000, 192, "linear", &[("ridge", "1e-3")]);
    let roomy = plan(&j, &Limit::Budget(1 << 30), None).unwrap();
    assert_eq!(roomy.path, Path::Streamed);
    assert!(roomy.describe().contains("more images than features") && roomy.describe().ends_with(": streaming"), "{}", roomy.describe());
    // 24 N^2 = 366 MiB in memory; X^T X of 192 features is a few MiB.
    let tight = plan(&j, &Limit::Budget(64 * MIB), None).unwrap();
    assert_eq!(tight.path, Path::Streamed);
    let line = tight.describe();
    assert!(line.contains("in memory needs 3") && line.contains("(N x N Gram of 4000 images), more than the budget of 64.0 MiB; streamed needs "), "{line}");
    assert!(line.ends_with(": streaming") && tight.chosen().bytes <= 64 * MIB, "{line}");
    // Asked for, streaming is checked too.
    let forced = plan(&j, &Limit::Budget(1 << 30), Some(Path::Streamed)).unwrap();
    assert_eq!(forced.path, Path::Streamed);
    assert!(forced.describe().contains("streamed needs") && forced.describe().contains("(as asked)"), "{}", forced.describe());
    // Unknown memory: unchecked, and said so.
    let unknown = plan(&job(100, 192, "linear", &[]), &Limit::Unknown, None).unwrap();
    assert_eq!(unknown.path, Path::InMemory);
    assert!(unknown.describe().contains("not checked"));
    // Available memory is used up to the usable fraction.
    let avail = Limit::Available(Available { bytes: 100 * MIB, cgroup: false });
    assert_eq!(avail.usable(), Some((100.0 * MIB as f64 * tuning::USABLE_FRACTION) as u64));
    assert!(plan(&j, &avail, None).unwrap().describe().contains("90% of the 100.0 MiB available"));
}

/// No path fits: the error names what each needs, the limit, and what would help, with numbers
/// that do fit.
#[test]
fn an_impossible_budget_is_an_error_naming_the_numbers() {
    let j = job(4000, 192, "linear", &[("ridge", "1e-3")]);
    let e = plan(&j, &Limit::Budget(4 * MIB), None).unwrap_err();
    let text = e.to_string();
    for part in [
        "not enough memory to train: in memory needs ",
        "(N x N Gram of 4000 images) and streamed needs ",
        "(X^T X of 192 features), both more than the budget of 4.0 MiB",
        "a budget of ",
    ] {
        assert!(text.contains(part), "{part}: {text}");
    }
    let Error::NotEnoughMemory { remedies, .. } = e else { panic!("{e:?}") };
    let more = remedies.iter().find_map(|r| match r {
        Remedy::MoreMemory { bytes, budget: true } => Some(*bytes),
        _ => None,
    });
    assert!(more.is_some_and(|b| b > 4 * MIB && plan(&j, &Limit::Budget(b), None).is_ok()), "{remedies:?}");
    // The eigenspace with fewer images than features streams by loading the set (the same
    // need): fewer images, or smaller ones, would fit (12 N M = 220 MiB; its N x N terms 34 MiB).
    let eig = job(1000, 19_200, "eigenspace", &[]);
    let budget = Limit::Budget(200 * MIB);
    let e = plan(&eig, &budget, None).unwrap_err();
    assert!(e.to_string().contains("in memory needs 2") && e.to_string().contains("and streamed needs 2"), "{e}");
    let Error::NotEnoughMemory { remedies, .. } = e else { panic!() };
    let Some(&Remedy::FewerImages { at_most, shards }) = remedies.iter().find(|r| matches!(r, Remedy::FewerImages { .. })) else { panic!("{remedies:?}") };
    assert!(at_most < 1000 && shards == 1000usize.div_ceil(at_most));
    assert!(plan(&eig.with_n(at_most), &budget, None).is_ok() && plan(&eig.with_n(at_most + 1), &budget, None).is_err());
    let Some(&Remedy::SmallerImages { at_most }) = remedies.iter().find(|r| matches!(r, Remedy::SmallerImages { .. })) else { panic!("{remedies:?}") };
    assert!(at_most < 19_200 && plan(&Job { m: at_most, ..eig.clone() }, &budget, None).is_ok());
    // The N x N terms alone over the budget: smaller images help only once they have fewer
    // features than there are images (the eigenspace then streams through the M x M scatter).
    let Err(Error::NotEnoughMemory { remedies, .. }) = plan(&job(4000, 19_200, "eigenspace", &[]), &budget, None) else { panic!() };
    let Some(&Remedy::SmallerImages { at_most }) = remedies.iter().find(|r| matches!(r, Remedy::SmallerImages { .. })) else { panic!("{remedies:?}") };
    assert!(at_most < 4000, "{remedies:?}");
}

/// `ridge auto` needs the set in memory: asked to stream, the settings' error; not fitting in
/// memory, the remedy of a fixed ridge, with what streaming then needs.
#[test]
fn a_rule_that_needs_the_set_in_memory_is_named() {
    let j = job(20_000, 192, "linear", &[("ridge", "auto")]);
    let e = plan(&j, &Limit::Budget(1 << 30), Some(Path::Streamed)).unwrap_err();
    assert!(matches!(&e, Error::Setting { name, value, .. } if name == "ridge" && value == "auto"), "{e:?}");
    let e = plan(&j, &Limit::Budget(1 << 30), None).unwrap_err();
    assert!(e.to_string().contains("not streamed: ridge auto"), "{e}");
    let Error::NotEnoughMemory { remedies, .. } = e else { panic!() };
    assert!(remedies.iter().any(|r| matches!(r, Remedy::Stream { change: StreamChange::FixedRidge, bytes } if *bytes < 1 << 30)), "{remedies:?}");
    let c = job(20_000, 192, "linear", &[("center", "true")]);
    assert!(matches!(plan(&c, &Limit::Budget(1 << 30), Some(Path::Streamed)), Err(Error::InvalidParameter { name: "center", .. })));
    // A fixed noise level fits expected noisy views beside the clean ones: in memory only.
    let e = plan(&job(20_000, 192, "linear", &[("noise-level", "0.05")]), &Limit::Budget(1 << 30), None).unwrap_err();
    assert!(e.to_string().contains("not streamed: the noise-level rule"), "{e}");
}

/// Normalisation and many objects are in memory only.
#[test]
fn normalisation_and_many_objects_are_planned_in_memory() {
    let j = job(4000, 192, "linear", &[("ridge", "1e-3")]).normalized(true);
    assert!(plan(&j, &Limit::Budget(64 * MIB), None).unwrap_err().to_string().contains("not streamed: the normalisation"));
    let space = PoseSpace::new(vec![Param::circular("azimuth", 360.0)]).unwrap();
    let manifest = |n: usize| Manifest::new(".", space.clone(), (0..n).map(|i| format!("{i}.png")).collect(), (0..n).map(|i| i as f64).collect()).unwrap();
    let spec = ImageSpec { width: 16, height: 12, color: ColorMode::Gray };
    let objects = Job::for_objects(&[manifest(300), manifest(200)], spec, find("linear").unwrap(), &Settings::new(), &RecognizerParams::default()).unwrap();
    assert_eq!(objects.n(), 500);
    let p = plan(&objects, &Limit::Budget(1 << 30), None).unwrap();
    assert_eq!((p.path, p.streamed.is_none()), (Path::InMemory, true));
    assert!(p.in_memory.bytes > estimate::in_memory(&job(500, 192, "linear", &[])).bytes);
    assert!(plan(&objects, &Limit::Budget(MIB), None).unwrap_err().to_string().contains("not streamed: a data set of many objects"));
}

/// The eigenspace's lattice is the resampled manifold's: a turntable every 0.5 degrees.
#[test]
fn the_lattice_is_the_resampled_manifold() {
    let space = PoseSpace::new(vec![Param::linear("elevation"), Param::circular("azimuth", 360.0)]).unwrap();
    let poses: Vec<f64> = (0..4).flat_map(|e| (0..36).flat_map(move |a| [30.0 + 10.0 * e as f64, 10.0 * a as f64])).collect();
    let m = Manifest::new(".", space, (0..144).map(|i| format!("{i}.png")).collect(), poses).unwrap();
    assert_eq!(lattice_points(&m, 0.5), 61 * 720);
    let spec = ImageSpec { width: 8, height: 8, color: ColorMode::Gray };
    assert_eq!(Job::for_manifest(&m, spec, find("eigenspace").unwrap(), &Settings::new()).unwrap().lattice, 61 * 720);
    assert_eq!(Job::for_manifest(&m, spec, find("linear").unwrap(), &Settings::new()).unwrap().lattice, 0);
}

/// With more than two pose parameters the manifold is kept as its knots: 2^3 points per training
/// view for the methods, 4^3 for the recognisers' resampling, whatever the pose ranges.
#[test]
fn three_parameters_count_points_per_training_view() {
    let space = PoseSpace::new(vec![Param::linear("elevation"), Param::circular("azimuth", 360.0), Param::linear("roll")]).unwrap();
    let poses: Vec<f64> =
        (0..3).flat_map(|e| (0..30).flat_map(move |a| (0..4).flat_map(move |r| [32.0 + 18.0 * e as f64, 12.0 * a as f64, -30.0 + 20.0 * r as f64]))).collect();
    let m = Manifest::new(".", space, (0..360).map(|i| format!("{i}.png")).collect(), poses).unwrap();
    assert_eq!(lattice_points(&m, 0.5), 8 * 360);
    let spec = ImageSpec { width: 8, height: 8, color: ColorMode::Gray };
    for method in ["eigenspace", "refined"] {
        assert_eq!(Job::for_manifest(&m, spec, find(method).unwrap(), &Settings::new()).unwrap().lattice, 8 * 360);
    }
    let objects = Job::for_objects(&[m.clone(), m], spec, find("eigenspace").unwrap(), &Settings::new(), &RecognizerParams::default()).unwrap();
    assert_eq!(objects.lattice, 64 * 360);
}

/// The case that started it (issue 36): 100,800 images of 160 x 120 with a fixed ridge on a
/// machine of 24 GB, about 23 GiB available: streamed, in under 2 GiB.
#[test]
fn a_hundred_thousand_images_stream_in_under_2_gib() {
    let j = job(100_800, 160 * 120, "linear", &[("ridge", "1e-3")]);
    let p = plan(&j, &Limit::Available(Available { bytes: 23 << 30, cgroup: false }), None).unwrap();
    eprintln!("{}", p.describe());
    assert_eq!(p.path, Path::Streamed);
    assert!(p.in_memory.bytes > 200 << 30 && p.chosen().bytes < 2 << 30, "{}", p.describe());
}

/// A million views of 32 x 24 and three pose parameters: the eigenspace in memory needs tens of
/// GiB (the images, and the second look's 768 coordinates per view with their surface), its
/// streamed fit (the 768 x 768 scatter, then the N L coordinates and the knots' surface) a few
/// (measured: 2.7 GiB peak), so a budget of 4 GiB streams; the streamed need grows with N L, not
/// N M.
#[test]
fn a_million_views_of_the_eigenspace_stream() {
    let (n, m) = (1_010_160, 768);
    let million = Job { params: 3, k: 5, ..job(n, m, "eigenspace", &[]) }.lattice(8 * n);
    let p = plan(&million, &Limit::Budget(4 << 30), None).unwrap();
    assert_eq!(p.path, Path::Streamed, "{}", p.describe());
    assert!(p.in_memory.bytes > 20 << 30 && p.in_memory.what.contains("second look"), "{:?}", p.in_memory);
    let s = p.streamed.as_ref().unwrap();
    assert!(s.bytes < 7 << 29 && s.what.contains("M x M scatter of 768 features"), "{s:?}");
    assert!(p.describe().contains("; streamed needs ") && p.describe().ends_with(": streaming"), "{}", p.describe());
    // Twice the views, about twice the knots' part; four times the pixels, not four times the need.
    let twice = estimate::streamed(&million.with_n(2 * n).lattice(16 * n)).bytes;
    assert!(twice > s.bytes && twice < 2 * s.bytes + (64 << 20), "{twice} {}", s.bytes);
    let wider = estimate::streamed(&Job { m: 4 * m, ..million.clone() }).bytes;
    assert!(wider < 2 * s.bytes, "{wider} {}", s.bytes);
    // Fewer images than features: the streamed fit loads the set, and needs what in memory needs.
    let few = job(500, 768, "eigenspace", &[]);
    assert_eq!(estimate::streamed(&few), estimate::in_memory(&few));
}
