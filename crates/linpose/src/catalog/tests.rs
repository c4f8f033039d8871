use super::*;
use crate::Param;
use std::fs;

/// Writes `text` to `dir/rel`, creating folders.
fn write(dir: &Path, rel: &str, text: &str) {
    let p = dir.join(rel);
    fs::create_dir_all(p.parent().unwrap()).unwrap();
    fs::write(p, text).unwrap();
}

/// Writes a `w`x`h` gray PNG of value `v` at `dir/rel`.
fn png(dir: &Path, rel: &str, w: u32, h: u32, v: u8) {
    let p = dir.join(rel);
    fs::create_dir_all(p.parent().unwrap()).unwrap();
    image::GrayImage::from_pixel(w, h, image::Luma([v])).save(p).unwrap();
}

fn strings(v: &[&str]) -> Vec<String> {
    v.iter().map(|s| s.to_string()).collect()
}

fn err<T: std::fmt::Debug>(r: Result<T>) -> String {
    r.unwrap_err().to_string()
}

fn azimuth() -> PoseSpace {
    PoseSpace::new(vec![Param::circular("azimuth", 360.0)]).unwrap()
}

fn manifest(root: &str, n: usize) -> Manifest {
    Manifest::new(root, azimuth(), (0..n).map(|i| format!("{i}.png")).collect(), (0..n).map(|i| 90.0 * i as f64).collect()).unwrap()
}

fn dataset(n: usize, w: u32, space: PoseSpace) -> Dataset {
    let spec = ImageSpec { width: w, height: w, color: ColorMode::Gray };
    let p = space.len();
    Dataset::new(spec, vec![0.5; n * spec.features()], space, (0..n * p).map(|i| i as f64).collect()).unwrap()
}

/// Layout (a): objects `b` (3 views, with a dataset.toml) and `a` (2 views), and a hidden folder
/// that is not an object.
fn folder_of_folders(dir: &Path) {
    write(dir, "b/poses.csv", "image,azimuth,tilt\n0.png,0,10\n1.png,120,10\n2.png,240,10\n");
    write(dir, "b/dataset.toml", "tilt = { period = 180 }\n");
    write(dir, "a/poses.csv", "image,azimuth,tilt\nx/0.png,0,0\nx/1.png,180,0\n");
    write(dir, "a/dataset.toml", "tilt = { period = 180 }\n");
    write(dir, ".notes/readme.txt", "not an object");
    write(dir, "README", "a file");
}

/// A folder beside the objects without a poses.csv, empty or not, is an error naming it: no
/// object is silently left out.
#[test]
fn a_folder_without_poses_beside_the_objects_is_named() {
    let t = tempfile::tempdir().unwrap();
    folder_of_folders(t.path());
    std::fs::create_dir(t.path().join("c")).unwrap();
    let e = err(Catalog::open(t.path()));
    assert!(e.contains("/c") && e.contains("an empty folder") && e.contains("2 other object folders have one"), "{e}");
    std::fs::remove_dir(t.path().join("c")).unwrap();
    write(t.path(), "notes/readme.txt", "not an object");
    let e = err(Catalog::open(t.path()));
    assert!(e.contains("/notes") && e.contains("no poses.csv"), "{e}");
    assert!(err(Source::open(t.path(), None)).contains("/notes"));
}

#[test]
fn opens_a_folder_of_object_folders() {
    let t = tempfile::tempdir().unwrap();
    folder_of_folders(t.path());
    let c = Catalog::open(t.path()).unwrap();
    assert_eq!(c.names(), ["a", "b"]);
    assert_eq!((c.len(), c.total_images(), c.is_empty()), (2, 5, false));
    assert_eq!(c.root(), t.path());
    assert_eq!(c.manifests()[0].root(), t.path().join("a"));
    assert_eq!(c.manifests()[0].images(), ["x/0.png", "x/1.png"]);
    assert_eq!(c.manifests()[1].poses(), [0.0, 10.0, 120.0, 10.0, 240.0, 10.0]);
    assert_eq!(c.space().params(), [Param::circular("azimuth", 360.0), Param::circular("tilt", 180.0)]);
    assert!(matches!(Source::open(t.path(), None).unwrap(), Source::Many(m) if m.names() == ["a", "b"]));
}

#[test]
fn objects_must_share_the_pose_parameters() {
    let t = tempfile::tempdir().unwrap();
    folder_of_folders(t.path());
    // b's tilt becomes linear: not the same parameters as a's.
    write(t.path(), "b/dataset.toml", "tilt = { linear = true }\n");
    let e = err(Catalog::open(t.path()));
    assert!(e.contains("object 'b' has pose parameters (azimuth (period 360), tilt (linear))"), "{e}");
    assert!(e.contains("object 'a' has (azimuth (period 360), tilt (period 180))"), "{e}");
    // Another order or another parameter is refused as well.
    write(t.path(), "b/poses.csv", "image,tilt,azimuth\n0.png,10,0\n");
    fs::remove_file(t.path().join("b/dataset.toml")).unwrap();
    fs::remove_file(t.path().join("a/dataset.toml")).unwrap();
    let e = err(Catalog::open(t.path()));
    assert!(e.contains("object 'b' has pose parameters (tilt (linear), azimuth (period 360))"), "{e}");
    let e = err(Catalog::new(
        "r",
        strings(&["a", "b"]),
        vec![manifest("r", 2), Manifest::new("r", PoseSpace::new(vec![Param::linear("azimuth")]).unwrap(), strings(&["p.png"]), vec![1.0]).unwrap()],
    ));
    assert!(e.contains("object 'b' has pose parameters (azimuth (linear)) but object 'a' has (azimuth (period 360))"), "{e}");
}

#[test]
fn a_folder_with_no_objects_is_refused() {
    let t = tempfile::tempdir().unwrap();
    write(t.path(), "notes/readme.txt", "x");
    let e = err(Catalog::open(t.path()));
    assert!(e.contains("not a data set of several objects") && e.contains("no subfolder with a poses.csv"), "{e}");
    let e = err(Source::open(t.path(), None));
    assert!(e.contains("no poses.csv in this folder") && e.contains("'object' column") && e.contains("folder of object folders"), "{e}");
    let e = err(Catalog::open(&t.path().join("missing")));
    assert!(e.contains("no such folder"), "{e}");
}

#[test]
fn opens_a_poses_csv_with_an_object_column() {
    let t = tempfile::tempdir().unwrap();
    write(t.path(), "poses.csv", "image,azimuth,object,tilt\ncup/0.png,0,cup,5\npot/0.png,0,pot,5\ncup/1.png,90,cup,5\n3.png,180,42,5\npot/1.png,90,pot,7\n");
    write(t.path(), "dataset.toml", "tilt = { period = 90 }\n");
    let c = Catalog::open(t.path()).unwrap();
    assert_eq!(c.names(), ["cup", "pot", "42"]);
    assert_eq!(c.manifests().iter().map(Manifest::len).collect::<Vec<_>>(), [2, 2, 1]);
    assert_eq!(c.manifests()[0].images(), ["cup/0.png", "cup/1.png"]);
    assert_eq!(c.manifests()[1].poses(), [0.0, 5.0, 90.0, 7.0]);
    assert_eq!(c.manifests()[2].root(), t.path());
    assert_eq!(c.space().params(), [Param::circular("azimuth", 360.0), Param::circular("tilt", 90.0)]);
    assert!(matches!(Source::open(t.path(), None).unwrap(), Source::Many(m) if m.names() == ["cup", "pot", "42"]));
    // dataset.toml describes pose parameters; the object column is none.
    write(t.path(), "dataset.toml", "object = { linear = true }\n");
    let e = err(Catalog::open(t.path()));
    assert!(e.contains("'object' is not a parameter"), "{e}");
}

#[test]
fn an_empty_object_value_names_its_line() {
    let t = tempfile::tempdir().unwrap();
    write(t.path(), "poses.csv", "image,object,azimuth\na.png,cup,0\nb.png, ,90\n");
    let e = err(Catalog::open(t.path()));
    assert!(e.contains("poses.csv:3:") && e.contains("empty object name for 'b.png'"), "{e}");
    let e = err(manifest::parse_poses_table(Path::new("poses.csv"), "image,object,azimuth\na.png,,0\n"));
    assert!(e.contains("poses.csv:2:") && e.contains("empty object name"), "{e}");
}

#[test]
fn manifest_open_refuses_several_objects_and_reads_one() {
    let t = tempfile::tempdir().unwrap();
    write(t.path(), "poses.csv", "image,object,azimuth\na.png,cup,0\nb.png,pot,90\n");
    let e = err(Manifest::open(t.path(), None));
    assert!(e.contains("poses.csv") && e.contains("this folder holds several objects") && e.contains("Catalog::open or Source::open"), "{e}");
    write(t.path(), "poses.csv", "image,azimuth,object\na.png,0,cup\nb.png,90,cup\n");
    let m = Manifest::open(t.path(), None).unwrap();
    assert_eq!((m.images(), m.poses(), m.space()), (&strings(&["a.png", "b.png"])[..], &[0.0, 90.0][..], &azimuth()));
    // Read as a catalog, the same file is one object.
    let c = Catalog::open(t.path()).unwrap();
    assert_eq!((c.names(), c.total_images()), (&strings(&["cup"])[..], 2));
    assert!(matches!(Source::open(t.path(), None).unwrap(), Source::Many(_)));
    // A folder of object folders whose object holds several objects is refused with that message.
    let u = tempfile::tempdir().unwrap();
    write(u.path(), "x/poses.csv", "image,object,azimuth\na.png,cup,0\nb.png,pot,90\n");
    let e = err(Catalog::open(u.path()));
    assert!(e.contains("several objects"), "{e}");
}

#[test]
fn single_object_folders() {
    let t = tempfile::tempdir().unwrap();
    write(t.path(), "poses.csv", "image,azimuth\na.png,0\nb.png,90\n");
    match Source::open(t.path(), None).unwrap() {
        Source::One(m) => assert_eq!((m.len(), m.root()), (2, t.path())),
        s => panic!("{s:?}"),
    }
    let e = err(Catalog::open(t.path()));
    assert!(e.contains("no 'object' column") && e.contains("one object"), "{e}");
    let e = err(Source::open(&t.path().join("poses.csv"), None));
    assert!(e.contains("not a folder"), "{e}");
}

#[test]
fn opens_a_coil_folder() {
    let t = tempfile::tempdir().unwrap();
    for f in ["obj2__0.png", "obj2__1.png", "obj10__0.png", "obj1__5.png", "obj1__100.png", "obj03__0.png", "objx__1.png", "obj4__.png", "obj5__1.jpg"] {
        write(t.path(), f, "");
    }
    let c = Catalog::open(t.path()).unwrap();
    assert_eq!(c.names(), ["obj1", "obj2", "obj10"]);
    assert_eq!(c.manifests()[0].poses(), [5.0, 100.0]); // numbered by degree: 100 > 71
    assert_eq!(c.manifests()[1].poses(), [0.0, 5.0]);
    assert_eq!(c.manifests()[2].images(), ["obj10__0.png"]);
    assert_eq!(c.space(), &azimuth());
    assert!(matches!(Source::open(t.path(), None).unwrap(), Source::Many(m) if m.len() == 3));
    match Source::open(t.path(), Some(2)).unwrap() {
        Source::One(m) => assert_eq!(m.images(), ["obj2__0.png", "obj2__1.png"]),
        s => panic!("{s:?}"),
    }
}

#[test]
fn catalog_new_checks_names() {
    let e = err(Catalog::new("r", strings(&["a", "a"]), vec![manifest("r", 1), manifest("r", 2)]));
    assert!(e.contains("object name 'a' appears twice"), "{e}");
    let e = err(Catalog::new("r", strings(&["a", ""]), vec![manifest("r", 1), manifest("r", 2)]));
    assert!(e.contains("object 1 has an empty name"), "{e}");
    let e = err(Catalog::new("r", vec![], vec![]));
    assert!(e.contains("no object"), "{e}");
    let e = err(Catalog::new("r", strings(&["a"]), vec![manifest("r", 1), manifest("r", 2)]));
    assert!(e.contains("1 object names for 2 objects"), "{e}");
    // Duplicate object names cannot come from one poses.csv (rows are grouped), but do from parts.
    let c = Catalog::new("r", strings(&["a", "b"]), vec![manifest("r", 1), manifest("r", 2)]).unwrap();
    assert_eq!(c.total_images(), 3);
}

#[test]
fn select_keeps_the_catalog_order() {
    let c = Catalog::new("r", strings(&["a", "b", "c"]), vec![manifest("r", 1), manifest("r", 2), manifest("r", 3)]).unwrap();
    let s = c.select(&strings(&["c", "a"])).unwrap();
    assert_eq!(s.names(), ["a", "c"]);
    assert_eq!(s.manifests()[1].len(), 3);
    let e = err(c.select(&strings(&["a", "z"])));
    assert!(e.contains("no object named 'z'") && e.contains("'a', 'b', 'c'"), "{e}");
    assert!(c.select(&[]).is_err());
}

#[test]
fn training_masks_per_object() {
    let t = tempfile::tempdir().unwrap();
    folder_of_folders(t.path());
    let c = Catalog::open(t.path()).unwrap();
    assert_eq!(c.training_masks(&TrainSelection::All).unwrap(), [vec![true; 2], vec![true; 3]]);
    // Each object's own smallest pose is the origin of its step.
    assert_eq!(c.training_masks(&TrainSelection::Step(180.0)).unwrap(), [vec![true, true], vec![true, false, false]]);
    // Names are relative to the catalog root: the object folder first.
    let sel = TrainSelection::Names(strings(&["a/x/1.png", "b/2.png"]));
    assert_eq!(c.training_masks(&sel).unwrap(), [vec![false, true], vec![false, false, true]]);
    let e = err(c.training_masks(&TrainSelection::Names(strings(&["a/x/1.png", "x/1.png"]))));
    assert!(e.contains("training list names 'x/1.png', which is in no object") && e.contains("'a/x/0.png'"), "{e}");
    let e = err(c.training_masks(&TrainSelection::Names(strings(&["a/x/1.png"]))));
    assert!(e.contains("object 'b' has no training views under a list of 1 images"), "{e}");
    assert!(err(c.training_masks(&TrainSelection::Step(0.0))).contains("train step"));
    // Two parameters: a step may pick none of an object's views.
    let u = tempfile::tempdir().unwrap();
    write(u.path(), "poses.csv", "image,object,azimuth,tilt\na0.png,a,0,0\na1.png,a,10,0\nb0.png,b,0,10\nb1.png,b,10,0\n");
    let c = Catalog::open(u.path()).unwrap();
    assert_eq!(c.training_masks(&TrainSelection::Step(10.0)).unwrap(), [vec![true, true], vec![true, true]]);
    let e = err(c.training_masks(&TrainSelection::Step(20.0)));
    assert!(e.contains("object 'b' has no training views under every 20 degrees"), "{e}");
    // In one poses.csv, names are the paths as written.
    let m = c.training_masks(&TrainSelection::Names(strings(&["a1.png", "b0.png"]))).unwrap();
    assert_eq!(m, [vec![false, true], vec![true, false]]);
}

#[test]
fn catalog_subset() {
    let c = Catalog::new("r", strings(&["a", "b"]), vec![manifest("r", 2), manifest("r", 3)]).unwrap();
    let s = c.subset(&[vec![true, false], vec![false, true, true]]).unwrap();
    assert_eq!(s.manifests()[1].images(), ["1.png", "2.png"]);
    assert_eq!((s.names(), s.total_images()), (c.names(), 3));
    let e = err(c.subset(&[vec![true, false], vec![false; 3]]));
    assert!(e.contains("object 'b' keeps none of its views"), "{e}");
    let e = err(c.subset(&[vec![true, false]]));
    assert!(e.contains("1 masks for 2 objects"), "{e}");
    let e = err(c.subset(&[vec![true], vec![true; 3]]));
    assert!(e.contains("object 'a' has 1 values but the object has 2 views"), "{e}");
}

#[test]
fn loads_every_object() {
    let t = tempfile::tempdir().unwrap();
    write(t.path(), "a/poses.csv", "image,azimuth\n0.png,0\n1.png,90\n");
    write(t.path(), "b/poses.csv", "image,azimuth\n0.png,0\n1.png,90\n2.png,180\n");
    for (k, f) in ["a/0.png", "a/1.png", "b/0.png", "b/1.png", "b/2.png"].iter().enumerate() {
        png(t.path(), f, 4, 4, 50 * k as u8);
    }
    let c = Catalog::open(t.path()).unwrap();
    let calls = std::sync::atomic::AtomicU64::new(0);
    let set = c.load(ColorMode::Gray, &|k| _ = calls.fetch_add(k, std::sync::atomic::Ordering::Relaxed)).unwrap();
    assert_eq!(calls.into_inner(), 5);
    assert_eq!((set.len(), set.total_len(), set.names(), set.is_empty()), (2, 5, c.names(), false));
    assert_eq!(set.spec(), ImageSpec { width: 4, height: 4, color: ColorMode::Gray });
    assert_eq!(set.space(), &azimuth());
    assert!((set.object(1).row(2)[0] - 200.0 / 255.0).abs() < 1e-6);
    assert_eq!(set.objects()[0].pose(1), [90.0]);
    let s = set.subset(&[vec![false, true], vec![true, false, true]]).unwrap();
    assert_eq!((s.object(0).len(), s.object(1).poses()), (1, &[0.0, 180.0][..]));
    let e = err(set.subset(&[vec![false, false], vec![true; 3]]));
    assert!(e.contains("object 'a' keeps none of its views"), "{e}");
    let b = set.select(&strings(&["b"])).unwrap();
    assert_eq!((b.names(), b.total_len()), (&strings(&["b"])[..], 3));
    assert!(err(set.select(&strings(&["c"]))).contains("no object named 'c'"));
    // An object of another image size is refused before any of its pixels is read.
    png(t.path(), "b/0.png", 8, 4, 0);
    let e = err(c.load(ColorMode::Gray, &|_| {}));
    assert!(e.contains("object 'b' has images of 8x4 but object 'a' has 4x4") && e.contains("every object's images must have one size"), "{e}");
    assert!(e.contains(&*t.path().join("b/0.png").to_string_lossy()), "{e}");
    // Within an object, Dataset::load finds it.
    png(t.path(), "b/0.png", 4, 4, 0);
    png(t.path(), "b/2.png", 8, 4, 0);
    let e = c.load(ColorMode::Gray, &|_| {}).unwrap_err();
    assert!(matches!(e, Error::ImageSizeMismatch { .. }), "{e}");
}

#[test]
fn object_set_checks() {
    let a = dataset(2, 4, azimuth());
    let s = ObjectSet::new(strings(&["a", "b"]), vec![a.clone(), dataset(3, 4, azimuth())]).unwrap();
    assert_eq!(s.total_len(), 5);
    let e = err(ObjectSet::new(strings(&["a", "b"]), vec![dataset(2, 64, azimuth()), dataset(2, 32, azimuth())]));
    assert!(e.contains("object 'b' has images of 32x32 but object 'a' has 64x64: every object's images must have one size"), "{e}");
    let two = PoseSpace::new(vec![Param::linear("elevation"), Param::circular("azimuth", 360.0)]).unwrap();
    let e = err(ObjectSet::new(strings(&["a", "b"]), vec![a.clone(), dataset(2, 4, two)]));
    assert!(e.contains("object 'b' has pose parameters (elevation (linear), azimuth (period 360)) but object 'a' has (azimuth (period 360))"), "{e}");
    let rgb = Dataset::new(ImageSpec { width: 4, height: 4, color: ColorMode::Rgb }, vec![0.0; 48], azimuth(), vec![0.0]).unwrap();
    let e = err(ObjectSet::new(strings(&["a", "b"]), vec![a.clone(), rgb]));
    assert!(e.contains("object 'b' has rgb features but object 'a' has gray"), "{e}");
    let e = err(ObjectSet::new(strings(&["a", "a"]), vec![a.clone(), a.clone()]));
    assert!(e.contains("object name 'a' appears twice"), "{e}");
    let e = err(ObjectSet::new(strings(&[""]), vec![a.clone()]));
    assert!(e.contains("empty name"), "{e}");
    let e = err(ObjectSet::new(vec![], vec![]));
    assert!(e.contains("no object"), "{e}");
    let e = err(ObjectSet::new(strings(&["a"]), vec![a.clone(), a]));
    assert!(e.contains("1 object names for 2 objects"), "{e}");
}
