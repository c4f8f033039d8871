//! Scenes: rendered views over a background and behind occluders (`render::scene`), and the
//! views of a data set put into scenes (`scene`). Every data set here is rendered by the test.

use linpose::image_io::{ColorMode, ImageSpec};
use linpose::render::background::{Background, BackgroundDraw, BackgroundSpec};
use linpose::render::scene::{read_scene_csv, Scene, SceneSpec};
use linpose::render::synth::{render_scenes, render_u8, write_dataset, PoseGrid, SceneViews};
use linpose::render::{objects, Grid, Mesh, RenderParams};
use linpose::scene::{find_object, write_scenes};
use linpose::{Dataset, Manifest, Source};
use std::path::Path;

fn grid(azimuth: &str, elevation: &str) -> PoseGrid {
    PoseGrid::new(Grid::parse("elevation", elevation).unwrap(), Grid::parse("azimuth", azimuth).unwrap()).unwrap()
}

fn params(w: u32, h: u32) -> RenderParams {
    RenderParams::default().width(w).height(h)
}

fn scene(background: Background, occlude: f64, seed: u64) -> Scene {
    Scene::new(background, occlude, seed).unwrap()
}

fn render(mesh: &Mesh, grid: PoseGrid, params: &RenderParams, scene: Scene) -> SceneViews {
    render_scenes(mesh, &grid.with_scene(scene), params, &|_| {}).unwrap()
}

#[test]
fn the_occluders_hide_the_share_asked_for() {
    let p = params(96, 72);
    for name in ["duck", "pot", "mug"] {
        let mesh = objects::builtin(name).unwrap();
        for share in [0.1, 0.2, 0.5] {
            let v = render(&mesh, grid("0:330:30", "40"), &p, scene(Background::Texture, share, 1));
            assert_eq!(v.records.len(), 12);
            for r in &v.records {
                assert!((r.hidden - share).abs() < 0.03, "{name} {}: asked {share}, hid {}", r.image, r.hidden);
                assert!((1..=2).contains(&r.occluders.len()));
                assert!(r.object_pixels > 500, "{name}: {}", r.object_pixels);
            }
            let mean = v.records.iter().map(|r| r.hidden).sum::<f64>() / 12.0;
            assert!((mean - share).abs() < 0.01, "{name}: mean {mean} for {share}");
        }
    }
}

#[test]
fn the_object_keeps_its_pixels_where_nothing_hides_it() {
    let mesh = objects::builtin("duck").unwrap();
    let (w, h) = (96usize, 72usize);
    let g = || grid("0:300:60", "40:70:30");
    // A pixel the object covers whole is the same on black and on white.
    let black = render_u8(&mesh, &g(), &params(96, 72), &|_| {}).unwrap();
    let white = render_u8(&mesh, &g(), &params(96, 72).background(1.0), &|_| {}).unwrap();
    for occlude in [0.0, 0.3] {
        let v = render(&mesh, g(), &params(96, 72), scene(Background::Texture, occlude, 5));
        let mut kept = 0;
        for (i, r) in v.records.iter().enumerate() {
            let m = w * h;
            for k in 0..m {
                let (x, y) = (k % w, k / w);
                let hidden = r.occluders.iter().any(|o| o.covers(x, y));
                let whole = black[i * m + k] == white[i * m + k];
                if whole && !hidden {
                    assert_eq!(v.pixels[i * m + k], black[i * m + k], "view {i} pixel ({x}, {y})");
                    kept += 1;
                }
            }
            assert!(r.object_pixels > 0 && v.masks[i * m..(i + 1) * m].iter().filter(|&&b| b).count() == r.object_pixels);
        }
        assert!(kept > 6 * 1000, "{kept}");
        // The background is not the studio's: most pixels outside the object changed.
        let outside = (0..black.len()).filter(|&k| !v.masks[k]).count();
        let changed = (0..black.len()).filter(|&k| !v.masks[k] && v.pixels[k] != black[k]).count();
        assert!(changed as f64 > 0.9 * outside as f64, "{changed} of {outside}");
    }
}

#[test]
fn a_seed_gives_one_scene_per_view() {
    let mesh = objects::builtin("cap").unwrap();
    let p = params(64, 48);
    let a = render(&mesh, grid("0:90:30", "40"), &p, scene(Background::Texture, 0.2, 3));
    let b = render(&mesh, grid("0:90:30", "40"), &p, scene(Background::Texture, 0.2, 3));
    let c = render(&mesh, grid("0:90:30", "40"), &p, scene(Background::Texture, 0.2, 4));
    assert_eq!(a.pixels, b.pixels);
    assert_eq!(a.records, b.records);
    assert_ne!(a.pixels, c.pixels);
    // Each view its own background: no two views share their first row.
    let rows: std::collections::HashSet<&[u8]> = a.pixels.chunks(64 * 48).map(|v| &v[..64]).collect();
    assert_eq!(rows.len(), 4);
    // Noise: every pixel outside the object its own draw.
    let n = render(&mesh, grid("0", "40"), &p, scene(Background::Noise, 0.0, 0));
    assert_eq!(n.records[0].background, BackgroundDraw::Noise);
    let levels: std::collections::HashSet<u8> = n.pixels.iter().zip(&n.masks).filter(|(_, &m)| !m).map(|(&v, _)| v).collect();
    assert!(levels.len() > 250, "{}", levels.len());
}

#[test]
fn a_level_is_the_renderer_s_own_background() {
    let mesh = objects::builtin("duck").unwrap();
    let g = || grid("0:90:45", "40");
    let plain = render_u8(&mesh, &g(), &params(48, 36).background(0.5), &|_| {}).unwrap();
    let v = render(&mesh, g(), &params(48, 36), scene(Background::Level(0.5), 0.0, 0));
    assert_eq!(v.pixels, plain);
    assert!(v.records.is_empty(), "a level alone needs no scene.csv");
}

/// The intersection over union of two masks.
fn iou(a: &[bool], b: &[bool]) -> f64 {
    let both = a.iter().zip(b).filter(|(&x, &y)| x && y).count();
    let either = a.iter().zip(b).filter(|(&x, &y)| x || y).count();
    both as f64 / either as f64
}

#[test]
fn the_studio_object_is_found_as_the_renderer_drew_it() {
    let (w, h) = (96u32, 72u32);
    let spec = ImageSpec { width: w, height: h, color: ColorMode::Gray };
    // Objects without parts at the backdrop's level on their outline (the column's black
    // stripes, the mug's black handle ends, the ring's black sectors are taken for backdrop).
    for (name, level) in [("duck", 0.0), ("duck", 0.5), ("pot", 0.0), ("cap", 0.3), ("twin", 0.0), ("twin", 0.5)] {
        let mesh = objects::builtin(name).unwrap();
        let p = params(w, h).background(level);
        // A scene of the studio's own level: the renderer's masks, the studio views.
        let v = render(&mesh, grid("0:330:30", "32:77:45"), &p, scene(Background::Level(level), 0.0, 0));
        let m = (w * h) as usize;
        let mut worst = 1.0f64;
        for (i, (view, truth)) in v.pixels.chunks(m).zip(v.masks.chunks(m)).enumerate() {
            let found = find_object(Path::new(&format!("{name} {i}")), spec, view).unwrap();
            worst = worst.min(iou(&found.mask, truth));
        }
        assert!(worst >= 0.95, "{name} on {level}: IoU down to {worst:.3}");
    }
}

#[test]
fn a_rendered_set_put_into_scenes_reads_as_the_original() {
    let dir = tempfile::tempdir().unwrap();
    let studio = dir.path().join("studio");
    let g = grid("0:350:10", "40");
    write_dataset(&objects::builtin("pot").unwrap(), &g, &params(64, 48), &studio, &|_| {}).unwrap();
    let spec = SceneSpec { background: BackgroundSpec::Texture, occlude: 0.2, seed: 9, canvas: None };
    let out = dir.path().join("scene");
    let source = Source::open(&studio, None).unwrap();
    let summary = write_scenes(&source, &spec, &out, &|_| {}).unwrap();
    assert_eq!((summary.objects, summary.views), (1, 36));
    assert!((summary.hidden[0] - 0.2).abs() < 0.01 && summary.hidden[1] > 0.15 && summary.hidden[2] < 0.25, "{:?}", summary.hidden);
    let a = Manifest::open(&studio, None).unwrap();
    let b = Manifest::open(&out, None).unwrap();
    assert_eq!(a.images(), b.images());
    assert_eq!(a.poses(), b.poses());
    assert_eq!(a.space(), b.space());
    let data = Dataset::load(b, ColorMode::Gray, &|_| {}).unwrap();
    assert_eq!(data.len(), 36);
    let records = read_scene_csv(&out.join("scene.csv")).unwrap();
    assert_eq!(records.len(), 36);
    assert_eq!(records[0].image, a.images()[0]);
    assert!(records.iter().all(|r| r.background == BackgroundDraw::Texture && r.seed == 9 && r.occlude == 0.2));
    // The same scene again: the same bytes.
    let again = dir.path().join("again");
    write_scenes(&source, &spec, &again, &|_| {}).unwrap();
    for name in a.images() {
        assert_eq!(std::fs::read(out.join(name)).unwrap(), std::fs::read(again.join(name)).unwrap(), "{name}");
    }
    // Refused, naming the folder: an output folder that is not empty.
    let e = write_scenes(&source, &spec, &out, &|_| {}).unwrap_err().to_string();
    assert!(e.contains("not empty"), "{e}");
}

#[test]
fn a_view_without_an_object_is_named() {
    let dir = tempfile::tempdir().unwrap();
    let studio = dir.path().join("studio");
    write_dataset(&objects::builtin("duck").unwrap(), &grid("0:90:30", "40"), &params(32, 24), &studio, &|_| {}).unwrap();
    // One view's object painted out.
    image::GrayImage::new(32, 24).save(studio.join("e040.0_a060.0.png")).unwrap();
    let spec = SceneSpec { background: BackgroundSpec::Noise, occlude: 0.0, seed: 0, canvas: None };
    let out = dir.path().join("scene");
    let e = write_scenes(&Source::open(&studio, None).unwrap(), &spec, &out, &|_| {}).unwrap_err().to_string();
    assert!(e.contains("e040.0_a060.0.png") && e.contains("no separable object"), "{e}");
    assert!(!out.exists(), "nothing half-written is left");
}

#[test]
fn photographs_are_cropped_into_the_background() {
    let dir = tempfile::tempdir().unwrap();
    let photos = dir.path().join("photos");
    std::fs::create_dir(&photos).unwrap();
    let stripes = image::RgbImage::from_fn(200, 150, |x, y| image::Rgb([(x * 5 % 256) as u8, (y * 3 % 256) as u8, 90]));
    stripes.save(photos.join("stripes.png")).unwrap();
    let background = BackgroundSpec::parse(photos.to_str().unwrap()).unwrap().open(64, 48).unwrap();
    let v = render(&objects::builtin("duck").unwrap(), grid("0:90:90", "40"), &params(64, 48), scene(background, 0.0, 2));
    for r in &v.records {
        let BackgroundDraw::Photo(crop) = &r.background else { panic!("{:?}", r.background) };
        assert_eq!(crop.name, "stripes.png");
        let [x0, y0, x1, y1] = crop.rect;
        assert!(x0 >= 0.0 && y0 >= 0.0 && x1 <= 200.0 && y1 <= 150.0 && x1 - x0 >= 64.0 - 1e-9, "{:?}", crop.rect);
    }
    assert!(v.pixels.iter().zip(&v.masks).filter(|(&p, &m)| !m && p > 0).count() > 1000);
    // An empty folder, named.
    let empty = dir.path().join("empty");
    std::fs::create_dir(&empty).unwrap();
    let e = BackgroundSpec::parse(empty.to_str().unwrap()).unwrap().open(64, 48).unwrap_err().to_string();
    assert!(e.contains("empty") && e.contains("no photographs"), "{e}");
}

#[test]
fn occlusion_outside_0_1_is_refused_by_value() {
    for bad in [1.0, -0.2, 2.0] {
        let e = SceneSpec { background: BackgroundSpec::Texture, occlude: bad, seed: 0, canvas: None }.open(32, 24).unwrap_err().to_string();
        assert!(e.contains("occlude") && e.contains(&bad.to_string()), "{e}");
    }
}
