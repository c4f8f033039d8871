//! The built-in objects on the paper's grid, data sets written to disk (and read back, as
//! features and as 8-bit pixels), and meshes from OBJ files.
//!
//! The grid checks render every 7th azimuth and every 3rd elevation of the paper's grid (16 x 6
//! poses) to keep debug test time small; `LINPOSE_FULL_GRID=1` renders all 1760 poses.

use linpose::image_io::ColorMode;
use linpose::render::synth::{dataset, write_dataset, PoseGrid};
use linpose::render::{objects, render, Grid, Mesh, RenderParams};
use linpose::{Dataset, Manifest, Param, PoseSpace};
use std::collections::HashSet;
use std::path::Path;

fn grid() -> PoseGrid {
    if std::env::var_os("LINPOSE_FULL_GRID").is_some() {
        PoseGrid::paper()
    } else {
        PoseGrid::new(Grid::parse("elevation", "32:77:9").unwrap(), Grid::parse("azimuth", "0:327:21").unwrap()).unwrap()
    }
}

/// Mean absolute difference between two images' features, in gray levels.
fn mad(a: &[f32], b: &[f32]) -> f64 {
    a.iter().zip(b).map(|(x, y)| (x - y).abs() as f64).sum::<f64>() * 255.0 / a.len() as f64
}

#[test]
fn every_built_in_object_fills_the_frame_sensibly_at_every_pose() {
    let params = RenderParams::default();
    let (w, h) = (160usize, 120usize);
    let grid = grid();
    for (name, _) in objects::OBJECTS {
        let data = dataset(&objects::builtin(name).unwrap(), &grid, &params, Path::new(name), &|_| {}).unwrap();
        let mut distinct = HashSet::new();
        let (mut lo_frac, mut hi_frac, mut lo_ext, mut hi_ext) = (1.0f64, 0.0f64, 1.0f64, 0.0f64);
        for i in 0..data.len() {
            let row = data.row(i);
            let on = |x: usize, y: usize| row[y * w + x] > 0.0;
            let border = (0..w).any(|x| on(x, 0) || on(x, h - 1)) || (0..h).any(|y| on(0, y) || on(w - 1, y));
            assert!(!border, "{name}: pose {:?} touches the border", data.pose(i));
            let frac = row.iter().filter(|&&v| v > 0.0).count() as f64 / (w * h) as f64;
            let (xs, ys): (Vec<usize>, Vec<usize>) = (0..w * h).filter(|&k| row[k] > 0.0).map(|k| (k % w, k / w)).unzip();
            let extent = (xs.iter().max().unwrap() - xs.iter().min().unwrap()).max(ys.iter().max().unwrap() - ys.iter().min().unwrap()) + 1;
            let ext = extent as f64 / h as f64;
            (lo_frac, hi_frac, lo_ext, hi_ext) = (lo_frac.min(frac), hi_frac.max(frac), lo_ext.min(ext), hi_ext.max(ext));
            distinct.insert(row.iter().map(|v| (v * 255.0).round() as u8).collect::<Vec<u8>>());
        }
        eprintln!("{name}: object covers {lo_frac:.3}..{hi_frac:.3} of the image; largest extent {lo_ext:.2}..{hi_ext:.2} of its height");
        assert_eq!(distinct.len(), data.len(), "{name}: two poses give the same image");
        assert!(lo_frac > 0.04 && hi_frac < 0.5, "{name}: covers {lo_frac}..{hi_frac} of the image");
        assert!(lo_ext >= 0.4 && hi_ext <= 0.86, "{name}: extent {lo_ext}..{hi_ext} of the image height");
    }
}

#[test]
fn twin_front_and_back_differ_only_by_a_small_mark() {
    let params = RenderParams::default();
    let grid = PoseGrid::new(Grid::parse("elevation", "32:77:15").unwrap(), Grid::parse("azimuth", "0:315:45").unwrap()).unwrap();
    let twin = dataset(&objects::builtin("twin").unwrap(), &grid, &params, Path::new("twin"), &|_| {}).unwrap();
    // Azimuth a and a + 180 (4 grid steps apart) against a and a + 90 (2 steps).
    for e in 0..4 {
        for a in 0..4 {
            let i = e * 8 + a;
            let (half, quarter) = (mad(twin.row(i), twin.row(i + 4)), mad(twin.row(i), twin.row(i + 2)));
            assert!(half > 0.0 && half < 0.1 * quarter, "pose {:?}: half turn {half:.2}, quarter turn {quarter:.2}", twin.pose(i));
        }
    }
}

#[test]
fn column_changes_much_more_with_azimuth_than_with_elevation() {
    let params = RenderParams::default();
    let sub = |e: &str, a: &str| PoseGrid::new(Grid::parse("elevation", e).unwrap(), Grid::parse("azimuth", a).unwrap()).unwrap();
    // Neighbouring poses 3 degrees apart along each axis, around the grid's middle.
    let data = dataset(&objects::builtin("column").unwrap(), &sub("47:53:3", "90:186:3"), &params, Path::new("column"), &|_| {}).unwrap();
    let (mut d_az, mut d_el) = (0.0, 0.0);
    for a in 0..32 {
        d_az += mad(data.row(33 + a), data.row(33 + a + 1));
        d_el += mad(data.row(33 + a), data.row(a)) + mad(data.row(33 + a), data.row(66 + a));
    }
    let ratio = (d_az / 32.0) / (d_el / 64.0);
    eprintln!("column: a 3-degree step changes the image {ratio:.1} times more in azimuth than in elevation");
    assert!(ratio > 2.0, "ratio {ratio}");
}

#[test]
fn a_written_data_set_reads_back_as_the_rendered_one() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("pot");
    let grid = PoseGrid::new(Grid::parse("elevation", "32:38.5:3.25").unwrap(), Grid::parse("azimuth", "350:370:5").unwrap()).unwrap();
    let mesh = objects::builtin("pot").unwrap();
    let params = RenderParams::default().width(64).height(48);
    let calls = std::sync::atomic::AtomicU64::new(0);
    let n = write_dataset(&mesh, &grid, &params, &out, &|k| {
        calls.fetch_add(k, std::sync::atomic::Ordering::Relaxed);
    })
    .unwrap();
    assert_eq!((n, calls.into_inner()), (15, 15));
    let csv = std::fs::read_to_string(out.join("poses.csv")).unwrap();
    assert!(csv.starts_with("image,elevation,azimuth\ne032.00_a350.0.png,32,350\n"), "{csv}");
    assert!(csv.contains("e038.50_a370.0.png,38.5,370\n"), "{csv}");
    let manifest = Manifest::open(&out, None).unwrap();
    let read = Dataset::load(manifest, ColorMode::Gray, &|_| {}).unwrap();
    let made = dataset(&mesh, &grid, &params, &out, &|_| {}).unwrap();
    assert_eq!(read.poses(), made.poses());
    assert_eq!(read.features(), made.features());
    assert_eq!(read.space().params()[1].period, Some(360.0));
    // Its 8-bit pixels, read into a caller's buffer, are the features' levels; a buffer
    // of the wrong size is refused.
    let manifest = Manifest::open(&out, None).unwrap();
    let (spec, row0) = linpose::dataset::first_gray8(&manifest).unwrap().expect("8-bit images");
    let mut into = vec![0u8; read.features().len()];
    assert!(linpose::dataset::load_gray8_into(&manifest, spec, &row0, &mut into, &|_| {}).unwrap());
    assert!(into.iter().zip(read.features()).all(|(&p, &f)| (p as f32 / 255.0 - f).abs() < 1e-6));
    assert_eq!(&into[..row0.len()], &row0[..]);
    let e = linpose::dataset::load_gray8_into(&manifest, spec, &row0, &mut into[1..], &|_| {}).unwrap_err().to_string();
    assert!(e.contains("15 images of 3072 values"), "{e}");
    // Nothing but the data set is left beside it.
    let names: Vec<_> = std::fs::read_dir(dir.path()).unwrap().map(|e| e.unwrap().file_name()).collect();
    assert_eq!(names, vec![std::ffi::OsString::from("pot")]);

    // A non-empty folder or a file is refused and left as it was.
    let err = write_dataset(&mesh, &grid, &params, &out, &|_| {}).unwrap_err().to_string();
    assert!(err.contains("not empty"), "{err}");
    let file = out.join("poses.csv");
    assert!(write_dataset(&mesh, &grid, &params, &file, &|_| {}).unwrap_err().to_string().contains("not a folder"));
    assert_eq!(std::fs::read_to_string(&file).unwrap(), csv);
    // An empty folder is filled.
    let empty = dir.path().join("empty");
    std::fs::create_dir(&empty).unwrap();
    write_dataset(&mesh, &grid, &params, &empty, &|_| {}).unwrap();
    assert!(empty.join("poses.csv").is_file());
}

#[test]
fn a_failed_write_leaves_nothing_behind() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("duck");
    let grid = PoseGrid::new(Grid::parse("elevation", "30").unwrap(), Grid::parse("azimuth", "0:10:5").unwrap()).unwrap();
    let bad = RenderParams::default().supersample(9);
    let err = write_dataset(&objects::builtin("duck").unwrap(), &grid, &bad, &out, &|_| {}).unwrap_err();
    assert!(err.to_string().contains("supersample"), "{err}");
    // An elevation out of range fails while rendering, after the temporary folder exists.
    let steep = PoseGrid::new(Grid::parse("elevation", "80:100:10").unwrap(), Grid::parse("azimuth", "0").unwrap()).unwrap();
    let err = write_dataset(&objects::builtin("duck").unwrap(), &steep, &RenderParams::default(), &out, &|_| {}).unwrap_err();
    assert!(err.to_string().contains("elevation"), "{err}");
    assert_eq!(std::fs::read_dir(dir.path()).unwrap().count(), 0);
}

#[test]
fn obj_files_render_and_bad_ones_are_named() {
    let dir = tempfile::tempdir().unwrap();
    // A tetrahedron, Y up, with a vertex colour on each vertex.
    let good = dir.path().join("tet.obj");
    std::fs::write(
        &good,
        "# tetrahedron\nmtllib missing.mtl\nv 0 0 0 1 1 1\nv 1 0 0 0.5 0.5 0.5\nv 0 0 1 1 0 0\nv 0 1 0 0 1 0\nf 1 3 2\nf 1 2 4\nf 1 4 3\nf 2 3 4\n",
    )
    .unwrap();
    let mesh = Mesh::from_obj(&good).unwrap();
    assert_eq!((mesh.positions().len(), mesh.triangles().len()), (4, 4));
    assert_eq!(mesh.positions()[3], [0.0, 0.0, 1.0], "OBJ y is the turntable axis");
    let img = render(&mesh, 30.0, 40.0, &RenderParams::default()).unwrap();
    assert!(img.as_raw().iter().any(|&v| v > 0));

    let cases = [
        ("missing.obj", None, "No such file"),
        ("empty.obj", Some(""), "empty"),
        ("nofaces.obj", Some("v 0 0 0\nv 1 0 0\nv 0 1 0\n"), "no faces"),
        ("range.obj", Some("v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n"), "refers to vertex 9"),
        ("garbage.obj", Some("v zero one two\nf 1 2 3\n"), "not a valid Wavefront OBJ"),
    ];
    for (name, text, expect) in cases {
        let path = dir.path().join(name);
        if let Some(t) = text {
            std::fs::write(&path, t).unwrap();
        }
        let err = Mesh::from_obj(&path).unwrap_err().to_string();
        assert!(err.contains(name) && err.contains(expect), "{name}: {err}");
    }
}

#[test]
fn roll_and_light_are_pose_columns_and_each_view_renders_with_its_own() {
    let dir = tempfile::tempdir().unwrap();
    let out = dir.path().join("duck");
    let (el, az) = (Grid::parse("elevation", "40").unwrap(), Grid::parse("azimuth", "0:10:10").unwrap());
    let grid = PoseGrid::new(el.clone(), az.clone())
        .unwrap()
        .with_roll(Grid::parse("roll", "-30:30:30").unwrap())
        .unwrap()
        .with_light(Grid::parse("light", "0:270:90").unwrap())
        .unwrap();
    assert_eq!((grid.len(), grid.names()), (24, vec!["elevation", "azimuth", "roll", "light"]));
    let mesh = objects::builtin("duck").unwrap();
    let params = RenderParams::default().width(32).height(24);
    assert_eq!(write_dataset(&mesh, &grid, &params, &out, &|_| {}).unwrap(), 24);
    // Columns in their fixed order, the last varying fastest; names carry every value.
    let csv = std::fs::read_to_string(out.join("poses.csv")).unwrap();
    let rows: Vec<&str> = csv.lines().collect();
    assert_eq!(rows.len(), 1 + 24);
    assert_eq!(rows[0], "image,elevation,azimuth,roll,light");
    assert_eq!(rows[1], "e040.0_a000.0_r-30.0_l000.0.png,40,0,-30,0");
    assert_eq!(rows[2], "e040.0_a000.0_r-30.0_l090.0.png,40,0,-30,90");
    assert_eq!(rows[5], "e040.0_a000.0_r000.0_l000.0.png,40,0,0,0");
    assert_eq!(rows[24], "e040.0_a010.0_r030.0_l270.0.png,40,10,30,270");
    // A light grid round the whole turn is circular, a partial roll linear.
    let toml = std::fs::read_to_string(out.join("dataset.toml")).unwrap();
    assert_eq!(toml, "azimuth = { period = 360 }\nelevation = { linear = true }\nroll = { linear = true }\nlight = { period = 360 }\n");
    let read = Dataset::load(Manifest::open(&out, None).unwrap(), ColorMode::Gray, &|_| {}).unwrap();
    let periods: Vec<Option<f64>> = read.space().params().iter().map(|p| p.period).collect();
    assert_eq!(periods, vec![None, Some(360.0), None, Some(360.0)]);
    // Every image is the renderer's at its roll and light.
    for i in 0..grid.len() {
        let [e, a, r, l]: [f64; 4] = read.pose(i).try_into().unwrap();
        let p = params.clone().camera(params.get_camera().clone().roll(r)).light(params.get_light().clone().azimuth_deg(l));
        let got: Vec<u8> = read.row(i).iter().map(|&v| (v * 255.0).round() as u8).collect();
        assert_eq!(&got, render(&mesh, a, e, &p).unwrap().as_raw(), "view {i} at {:?}", read.pose(i));
    }
    // A grid without roll or light writes the two columns and files it always did.
    let plain = PoseGrid::new(el.clone(), az.clone()).unwrap();
    assert!(plain.poses_csv().starts_with("image,elevation,azimuth\ne040.0_a000.0.png,40,0\n"));
    assert_eq!(plain.dataset_toml(), linpose::render::synth::DATASET_TOML);
    let full_roll = PoseGrid::new(el.clone(), az.clone()).unwrap().with_roll(Grid::parse("roll", "0:350:10").unwrap()).unwrap();
    assert!(full_roll.dataset_toml().ends_with("roll = { period = 360 }\n"));
    // The count of views is the product of the grids, refused past the limit with every size named.
    let big = Grid::parse("azimuth", "0:999999:1").unwrap();
    let err = PoseGrid::new(Grid::parse("elevation", "0:10:1").unwrap(), big.clone()).unwrap_err().to_string();
    assert!(err.contains("11 elevations x 1000000 azimuths") && err.contains("11000000 images"), "{err}");
    let ten = PoseGrid::new(el, big.clone()).unwrap().with_roll(Grid::parse("roll", "0:9:1").unwrap()).unwrap();
    assert_eq!(ten.len(), 10_000_000);
    let err = ten.with_light(big).unwrap_err().to_string();
    assert!(err.contains("1 elevations x 1000000 azimuths x 10 rolls x 1000000 lights") && err.contains("at most 10000000"), "{err}");
}

/// The pose error's rotation (`PoseSpace::error_deg` with elevation, azimuth and roll) turns the
/// camera the way the renderer does: seen from straight above, a turntable turn of 10 degrees and
/// a roll of 10 degrees cancel, so the two views show the same silhouette (the light, fixed in
/// the world, shades them differently), and the error calls them 0 apart; the roll the other way
/// is 20 degrees off and shows another silhouette.
#[test]
fn rotation_error_follows_the_renderers_roll() {
    let space = PoseSpace::new(vec![Param::linear("elevation"), Param::circular("azimuth", 360.0), Param::linear("roll")]).unwrap();
    let mesh = objects::builtin("duck").unwrap();
    let params = RenderParams::default().width(64).height(64);
    let mask = |a: f64, r: f64| -> Vec<bool> {
        let p = params.clone().camera(params.get_camera().clone().roll(r));
        render(&mesh, a, 90.0, &p).unwrap().pixels().map(|p| p.0[0] > 0).collect()
    };
    let differ = |x: &[bool], y: &[bool]| x.iter().zip(y).filter(|(a, b)| a != b).count();
    let base = mask(10.0, 0.0);
    let (same, other) = (mask(20.0, 10.0), mask(20.0, -10.0));
    assert!(space.error_deg(&[90.0, 10.0, 0.0], &[90.0, 20.0, 10.0]) < 1e-9);
    assert!((space.error_deg(&[90.0, 10.0, 0.0], &[90.0, 20.0, -10.0]) - 20.0).abs() < 1e-9);
    let area = base.iter().filter(|&&b| b).count();
    assert!(differ(&base, &same) <= area / 50, "{} of {area} pixels differ", differ(&base, &same));
    assert!(differ(&base, &other) > area / 10, "{} of {area} pixels differ", differ(&base, &other));
}
