use super::*;
use crate::image_io::ColorMode;
use crate::pose::{Param, PoseSpace};

const W: usize = 40;
const H: usize = 30;

/// An elliptic object of semi-axes `a` x `b` with a texture, centred at (`cx`, `cy`), on a
/// background of `level`.
fn object(cx: f64, cy: f64, a: f64, b: f64, level: f32) -> Vec<f32> {
    let mut img = vec![level; W * H];
    for y in 0..H {
        for x in 0..W {
            let (u, v) = ((x as f64 - cx) / a, (y as f64 - cy) / b);
            let r = 1.0 - u * u - v * v;
            if r > 0.0 {
                img[y * W + x] = level + (r.sqrt() * (0.4 + 0.2 * (3.0 * u + v).sin())) as f32;
            }
        }
    }
    img
}

fn stage(edges: bool, background: Background, brightness: bool) -> Normalizer {
    Normalizer {
        width: W as u32,
        height: H as u32,
        channels: 1,
        background,
        threshold: tuning::HALF_LEVEL,
        edges,
        framed: edges,
        noise: 0.5,
        noisy_radius: Vec::new(),
        radius: Some(6.0),
        brightness: brightness.then_some(2.0),
    }
}

fn apply(s: &Normalizer, img: &[f32]) -> Result<Vec<f32>, Rejection> {
    let mut out = vec![0.0; img.len()];
    s.apply(img, &mut out).map(|_| out)
}

#[test]
fn a_move_by_whole_pixels_gives_the_same_image_bit_for_bit() {
    for (background, level) in [(Background::Dark, 0.0), (Background::Border, 0.55)] {
        let s = stage(false, background, true);
        let base = apply(&s, &object(17.3, 13.6, 8.0, 5.0, level)).unwrap();
        for (dx, dy) in [(3, -2), (-6, 4), (1, 1)] {
            let moved = apply(&s, &object(17.3 + dx as f64, 13.6 + dy as f64, 8.0, 5.0, level)).unwrap();
            assert!(base.iter().zip(&moved).all(|(a, b)| a.to_bits() == b.to_bits()), "{background:?} moved by ({dx}, {dy})");
        }
        // The object is centred: its centroid is the frame's centre to a small fraction of a pixel.
        let p = s.locate(&base.iter().map(|v| v + level).collect::<Vec<_>>()).unwrap();
        let (cx, cy) = (p.origin.0 as f64 + p.cx, p.origin.1 as f64 + p.cy);
        assert!((cx - (W as f64 - 1.0) / 2.0).abs() < 0.05 && (cy - (H as f64 - 1.0) / 2.0).abs() < 0.05, "centroid {cx}, {cy}");
        // The radius to 2%: the cubic's overshoot at the ellipse's steep rim weighs in the moments.
        assert!((p.radius - 6.0).abs() < 0.12, "radius {}", p.radius);
    }
}

#[test]
fn a_larger_or_brighter_object_comes_out_alike() {
    let s = stage(false, Background::Dark, true);
    let base = apply(&s, &object(20.0, 15.0, 8.0, 5.0, 0.0)).unwrap();
    let larger = apply(&s, &object(19.0, 14.5, 8.8, 5.5, 0.0)).unwrap();
    let brighter: Vec<f32> = object(20.0, 15.0, 8.0, 5.0, 0.0).iter().map(|v| v * 1.2).collect();
    let brighter = apply(&s, &brighter).unwrap();
    let energy: f32 = base.iter().map(|v| v * v).sum();
    let diff = |o: &[f32]| base.iter().zip(o).map(|(a, b)| (a - b) * (a - b)).sum::<f32>() / energy;
    // A 10% larger object scaled back differs by the resampling's error only (the ellipse's
    // texture is not scaled with it, so not exactly).
    assert!(diff(&larger) < 0.02, "larger: relative squared difference {}", diff(&larger));
    assert!(diff(&brighter) < 1e-10, "brighter: relative squared difference {}", diff(&brighter));
}

#[test]
fn images_it_cannot_normalise_are_refused_with_the_reason() {
    let s = stage(false, Background::Dark, false);
    assert!(matches!(apply(&s, &vec![0.0; W * H]), Err(Rejection::Empty { .. })));
    let cut = apply(&s, &object(3.0, 15.0, 8.0, 5.0, 0.0));
    assert_eq!(cut, Err(Rejection::TouchesEdge { sides: [true, false, false, false] }));
    assert!(cut.unwrap_err().to_string().contains("touches the frame edge (left)"));
    // A speck far from the object is not part of it.
    let mut speck = object(20.0, 15.0, 5.0, 3.0, 0.0);
    speck[W + 1] = 0.3;
    assert_eq!(s.placement(&speck).unwrap(), s.placement(&object(20.0, 15.0, 5.0, 3.0, 0.0)).unwrap());
    let mut nan = object(20.0, 15.0, 8.0, 5.0, 0.0);
    nan[5] = f32::NAN;
    assert_eq!(apply(&s, &nan), Err(Rejection::NotFinite));
    // Where the training views touch the edge, a query may.
    assert!(apply(&stage(true, Background::Dark, false), &object(3.0, 15.0, 8.0, 5.0, 0.0)).is_ok());
}

#[test]
fn an_image_placed_where_it_was_is_unchanged_and_placed_elsewhere_moves_there() {
    for (background, level) in [(Background::Dark, 0.0), (Background::Border, 0.55)] {
        let s = stage(false, background, false);
        let img = object(17.3, 13.6, 8.0, 5.0, level);
        let at = s.placement(&img).unwrap();
        let mut out = vec![0.0; img.len()];
        s.place(&img, at, &mut out).unwrap();
        // Where it was, at its own size: the image minus its background, to rounding.
        let worst = img.iter().zip(&out).map(|(a, b)| (a - level - b).abs()).fold(0.0f32, f32::max);
        assert!(worst < 1e-5, "{background:?}: largest change {worst}");
        // Elsewhere and larger: found there (the radius to 2%, as apply's).
        let to = [21.4, 14.2, 1.1 * at[2]];
        s.place(&img, to, &mut out).unwrap();
        let back: Vec<f32> = out.iter().map(|v| v + level).collect();
        let found = s.placement(&back).unwrap();
        assert!((found[0] - to[0]).abs() < 0.05 && (found[1] - to[1]).abs() < 0.05, "{background:?}: centroid {found:?}, asked {to:?}");
        assert!((found[2] / to[2] - 1.0).abs() < 0.02, "{background:?}: radius {}, asked {}", found[2], to[2]);
        // And at the frame's centre with the stage's radius, exactly what apply gives.
        let centre = [(W as f64 - 1.0) / 2.0, (H as f64 - 1.0) / 2.0, 6.0];
        s.place(&img, centre, &mut out).unwrap();
        assert_eq!(apply(&s, &img).unwrap(), out);
        for bad in [[f64::NAN, 10.0, 5.0], [10.0, 10.0, 0.0], [10.0, f64::INFINITY, 5.0]] {
            let refused = s.place(&img, bad, &mut out).unwrap_err();
            assert!(matches!(refused, Rejection::Placement { .. }) && refused.to_string().contains("a finite position and a positive radius"), "{refused}");
        }
    }
}

fn dataset(images: Vec<Vec<f32>>) -> Dataset {
    let space = PoseSpace::new(vec![Param::circular("azimuth", 360.0)]).unwrap();
    let spec = ImageSpec { width: W as u32, height: H as u32, color: ColorMode::Gray };
    let poses = (0..images.len()).map(|i| 10.0 * i as f64).collect();
    Dataset::new(spec, images.concat(), space, poses).unwrap()
}

#[test]
fn fitting_reads_the_background_threshold_and_size_from_the_training_images() {
    let train = dataset((0..5).map(|i| object(20.0, 15.0, 7.0 + i as f64 * 0.5, 5.0, 0.0)).collect());
    let s = Normalizer::fit(&train, NormalizeParams { geometry: true, brightness: true }).unwrap();
    assert_eq!((s.background, s.threshold, s.edges), (Background::Dark, tuning::HALF_LEVEL, false));
    let radius = s.radius.unwrap();
    let p =
        find::locate(train.row(2), W, H, 1, find::Rules { background: Background::Dark, threshold: s.threshold, framed: false, edges: false }, None).unwrap();
    assert_eq!(radius, p.radius, "the median view's radius");
    // A bright background is measured per image.
    let bright = dataset((0..3).map(|_| object(20.0, 15.0, 8.0, 5.0, 0.5)).collect());
    assert_eq!(Normalizer::fit(&bright, NormalizeParams::geometry()).unwrap().background, Background::Border);
    // Views framed to the edge (most of them) make the edge the data's convention...
    let framed = dataset((0..3).map(|_| object(20.0, 15.0, 20.5, 9.0, 0.0)).collect());
    assert!(Normalizer::fit(&framed, NormalizeParams::geometry()).unwrap().edges);
    // ...one view cut by the edge among views inside it is kept, and queries may touch it too,
    // but the border stays background (its noise measured on each query).
    let mut images: Vec<Vec<f32>> = (0..4).map(|_| object(20.0, 15.0, 8.0, 5.0, 0.0)).collect();
    images[2] = object(2.0, 15.0, 8.0, 5.0, 0.0);
    let s = Normalizer::fit(&dataset(images), NormalizeParams::geometry()).unwrap();
    assert!(s.edges && !s.framed);
    assert!(Normalizer::fit(&train, NormalizeParams::default()).is_err());
}

#[test]
fn colour_images_move_exactly_too_and_a_wrong_size_is_refused() {
    let s = Normalizer { channels: 3, ..stage(false, Background::Border, true) };
    let rgb = |cx: f64| -> Vec<f32> { object(cx, 13.6, 8.0, 5.0, 0.3).iter().flat_map(|&v| [v, 0.5 * v, 0.9 - 0.5 * v]).collect() };
    let (a, b) = (rgb(17.3), rgb(20.3));
    let (mut oa, mut ob) = (vec![0.0; a.len()], vec![0.0; b.len()]);
    s.apply(&a, &mut oa).unwrap();
    s.apply(&b, &mut ob).unwrap();
    assert!(oa.iter().zip(&ob).all(|(x, y)| x.to_bits() == y.to_bits()));
    assert_eq!(s.check(&a[3..]), Err(Rejection::Size { expected: W * H * 3, got: W * H * 3 - 3 }));
    assert_eq!(s.apply(&a, &mut oa[3..]), Err(Rejection::Size { expected: W * H * 3, got: W * H * 3 - 3 }));
}

/// `img` with `part` added where it is brighter.
fn with(mut img: Vec<f32>, part: &[f32]) -> Vec<f32> {
    img.iter_mut().zip(part).for_each(|(a, &b)| *a = a.max(b));
    img
}

#[test]
fn an_object_in_parts_is_one_object_and_a_second_object_apart_is_named() {
    let s = stage(false, Background::Dark, false);
    // A body and a handle beside it with a gap between: one object of two parts, measured whole.
    let body = object(17.0, 15.0, 7.0, 6.0, 0.0);
    let mug = with(body.clone(), &object(27.5, 15.0, 2.0, 4.0, 0.0));
    assert_eq!(s.parts(&mug), Ok(2));
    assert_eq!(s.parts(&body), Ok(1));
    let (whole, alone) = (s.placement(&mug).unwrap(), s.placement(&body).unwrap());
    assert!(whole[0] > alone[0] + 0.5, "the handle moves the centre: {whole:?} against {alone:?}");
    assert!(apply(&s, &mug).is_ok());
    // A second object far from the first (farther than the first's size) is left out of a
    // query without a word...
    let wide = Normalizer { width: 3 * W as u32, ..stage(false, Background::Dark, false) };
    let far = |second: bool| {
        let mut img = vec![0.0f32; 3 * W * H];
        for (k, v) in object(12.0, 15.0, 7.0, 6.0, 0.0).into_iter().enumerate() {
            img[(k / W) * 3 * W + k % W] = v;
        }
        if second {
            for (k, v) in object(20.0, 15.0, 6.0, 5.0, 0.0).into_iter().enumerate() {
                img[(k / W) * 3 * W + 2 * W + k % W] = v;
            }
        }
        img
    };
    assert_eq!(wide.placement(&far(true)).unwrap(), wide.placement(&far(false)).unwrap());
    // ...and stops training, naming the view and saying what it found.
    let space = PoseSpace::new(vec![Param::circular("azimuth", 360.0)]).unwrap();
    let spec = ImageSpec { width: 3 * W as u32, height: H as u32, color: ColorMode::Gray };
    let data = Dataset::new(spec, [far(false), far(true)].concat(), space, vec![0.0, 10.0]).unwrap();
    let err = Normalizer::fit(&data, NormalizeParams::geometry()).unwrap_err().to_string();
    assert!(err.contains("sample 1") && err.contains("two objects: a second one") && err.contains("crop"), "{err}");
}

#[test]
fn a_gray_background_and_parts_as_dark_as_it_is_or_darker() {
    // On a gray backdrop, an object with a band as gray as the backdrop (cutting it in two) and
    // parts darker than it: found whole, and the stage measures the level on each image.
    let level = 0.45;
    let mut img = object(20.0, 15.0, 9.0, 6.0, level);
    for y in 0..H {
        for x in 0..W {
            if (x as i64 - 20).abs() <= 1 {
                img[y * W + x] = level;
            }
            if (x, y) == (15, 15) || (x, y) == (25, 13) {
                img[y * W + x] = 0.05;
            }
        }
    }
    let train = dataset(vec![img.clone(); 3]);
    let s = Normalizer::fit(&train, NormalizeParams::all()).unwrap();
    assert_eq!(s.background, Background::Border);
    assert_eq!(s.parts(&img), Ok(2));
    // Brighter lighting moves the backdrop's level and the object's with it: the same image.
    let brighter: Vec<f32> = img.iter().map(|v| v + 0.1).collect();
    let (a, b) = (apply(&s, &img).unwrap(), apply(&s, &brighter).unwrap());
    assert!(a.iter().zip(&b).all(|(x, y)| (x - y).abs() < 1e-5));
}
