//! Geometric identities of the renderer.
//!
//! Identities that involve only exact operations are checked bit for bit: azimuth 0 and 360
//! (the angle is reduced in degrees before any trigonometry), turning by 90 degrees versus
//! swapping the coordinates, scaling by a power of two. Identities that go through rounding - a
//! general angle's sine, a scale of 3.7, a polygon standing in for a circle - are checked with a
//! tolerance on how many pixels may differ and by how much: a vertex moved by an ulp can move a
//! silhouette sample across an edge, which changes that pixel by at most a quarter of its range
//! (one of 2 x 2 samples) and touches only pixels on edges. At most 4 of the 4800 pixels may
//! differ by more than one gray level; when these tests were written none did (the largest
//! difference seen was 1 level).

use super::*;

fn duck() -> Mesh {
    objects::builtin("duck").unwrap()
}

fn small() -> RenderParams {
    RenderParams::default().width(80).height(60)
}

/// (pixels that differ by more than `level`, largest difference).
fn diff(a: &GrayImage, b: &GrayImage, level: u8) -> (usize, u8) {
    let d = a.as_raw().iter().zip(b.as_raw()).map(|(&x, &y)| x.abs_diff(y));
    d.fold((0, 0), |(n, m), v| (n + (v > level) as usize, m.max(v)))
}

/// A surface of revolution about z with `nu` segments around and constant albedo.
fn vase(nu: usize) -> Mesh {
    let nv = 24;
    let mut positions = Vec::new();
    for j in 0..=nv {
        let t = j as f64 / nv as f64;
        let (r, z) = (0.3 + 0.2 * libm::sin(3.0 * t) + 0.1 * t, t * 1.5);
        for i in 0..nu {
            let (s, c) = sin_cos_deg(360.0 * i as f64 / nu as f64);
            positions.push([r * c, r * s, z]);
        }
    }
    let mut triangles = Vec::new();
    for j in 0..nv as u32 {
        for i in 0..nu as u32 {
            let at = |i: u32, j: u32| j * nu as u32 + i % nu as u32;
            triangles.push([at(i, j), at(i + 1, j), at(i + 1, j + 1)]);
            triangles.push([at(i, j), at(i + 1, j + 1), at(i, j + 1)]);
        }
    }
    let n = positions.len();
    Mesh::new(positions, triangles, vec![0.7; n]).unwrap()
}

#[test]
fn azimuth_0_and_360_give_the_same_image() {
    let m = duck();
    for e in [32.0, 77.0] {
        assert_eq!(render(&m, 0.0, e, &small()).unwrap(), render(&m, 360.0, e, &small()).unwrap());
        assert_eq!(render(&m, 93.0, e, &small()).unwrap(), render(&m, -267.0, e, &small()).unwrap());
    }
}

#[test]
fn rendering_twice_gives_the_same_bytes() {
    let m = duck();
    let a = render(&m, 123.0, 41.0, &RenderParams::default()).unwrap();
    let mut r = Renderer::new(&RenderParams::default()).unwrap();
    let mut buf = vec![0u8; 160 * 120];
    // A renderer reused after another image must not keep anything of it.
    r.render_into(&objects::builtin("pot").unwrap(), 10.0, 70.0, &mut buf).unwrap();
    r.render_into(&m, 123.0, 41.0, &mut buf).unwrap();
    assert_eq!(a.as_raw(), &buf);
}

#[test]
fn a_surface_of_revolution_looks_the_same_at_every_azimuth() {
    // 256 segments: the polygon departs from its circle by r (1 - cos(pi / 256)) < 1e-4 radii,
    // well under a sample, but vertices do sit at different places for different azimuths (the
    // polygon has only 256-fold symmetry), so silhouette samples may flip. Azimuths that are
    // multiples of 360/256 degrees are exact symmetries up to rounding of sin and cos.
    let m = vase(256);
    for e in [32.0, 60.0] {
        let base = render(&m, 0.0, e, &small()).unwrap();
        for a in [17.0, 45.0, 90.0, 133.7, 211.0, 300.0] {
            let (n, max) = diff(&base, &render(&m, a, e, &small()).unwrap(), 1);
            assert!(n <= 4 && max <= 64, "azimuth {a}, elevation {e}: {n} pixels differ, by up to {max}");
        }
        assert_eq!(base, render(&m, 90.0 * 3.0, e, &small()).unwrap(), "a quarter turn maps the mesh onto itself exactly");
    }
}

#[test]
fn turning_the_object_equals_rendering_it_pre_rotated() {
    let m = duck();
    // The turntable applies Rz(-e); for e = 90 that is (x, y) -> (y, -x), exactly.
    let quarter = m.map_positions(|p| [p[1], -p[0], p[2]]).unwrap();
    for e in [32.0, 65.0] {
        assert_eq!(render(&m, 90.0, e, &small()).unwrap(), render(&quarter, 0.0, e, &small()).unwrap());
    }
    for a in [37.0, 151.5, 290.0] {
        let (s, c) = sin_cos_deg(a);
        let turned = m.map_positions(|p| [c * p[0] + s * p[1], c * p[1] - s * p[0], p[2]]).unwrap();
        let (n, max) = diff(&render(&m, a, 50.0, &small()).unwrap(), &render(&turned, 0.0, 50.0, &small()).unwrap(), 2);
        assert!(n <= 4 && max <= 64, "azimuth {a}: {n} pixels differ, by up to {max}");
    }
}

#[test]
fn a_scaled_and_shifted_copy_renders_the_same() {
    let m = duck();
    let p = small();
    let four = m.map_positions(|v| v.map(|x| 4.0 * x)).unwrap();
    assert_eq!(render(&m, 33.0, 44.0, &p).unwrap(), render(&four, 33.0, 44.0, &p).unwrap());
    let other = m.map_positions(|v| [3.7 * v[0] + 1.5, 3.7 * v[1] - 2.0, 3.7 * v[2] + 7.0]).unwrap();
    let (n, max) = diff(&render(&m, 33.0, 44.0, &p).unwrap(), &render(&other, 33.0, 44.0, &p).unwrap(), 2);
    assert!(n <= 4 && max <= 64, "{n} pixels differ, by up to {max}");
}

#[test]
fn perspective_frames_the_object_like_orthographic() {
    let m = objects::builtin("column").unwrap();
    let ortho = render(&m, 20.0, 32.0, &small()).unwrap();
    let persp = render(&m, 20.0, 32.0, &small().camera(Camera::perspective())).unwrap();
    assert_ne!(ortho, persp);
    let count = |g: &GrayImage| g.as_raw().iter().filter(|&&v| v > 0).count() as f64;
    // Same bounding-sphere framing: the object covers about the same area.
    assert!((count(&persp) / count(&ortho) - 1.0).abs() < 0.15, "{} vs {}", count(&persp), count(&ortho));
    // A vertical edge converges in perspective: the column's top is wider than its bottom in
    // orthographic, not by much; just check the perspective image is in frame and not empty.
    assert!(count(&persp) > 100.0);
}

#[test]
fn specular_highlights_brighten_and_stay_deterministic() {
    let m = objects::builtin("pot").unwrap();
    let p = small().light(Light::default().specular(0.6));
    let shiny = render(&m, 10.0, 40.0, &p).unwrap();
    let matte = render(&m, 10.0, 40.0, &small()).unwrap();
    assert!(shiny.as_raw().iter().zip(matte.as_raw()).all(|(s, m)| s >= m));
    assert!(shiny.as_raw().iter().max() > matte.as_raw().iter().max());
    assert_eq!(shiny, render(&m, 10.0, 40.0, &p).unwrap());
}

#[test]
fn bad_parameters_name_themselves() {
    let m = duck();
    let err = |p: RenderParams| render(&m, 0.0, 45.0, &p).unwrap_err().to_string();
    assert!(err(small().width(0)).starts_with("invalid size = 0x60"), "{}", err(small().width(0)));
    assert!(err(small().supersample(5)).contains("supersample"));
    assert!(err(small().camera(Camera::default().fill(0.0))).contains("fill"));
    assert!(err(small().camera(Camera::default().projection(Projection::Perspective { distance: 1.0 }))).contains("distance"));
    assert!(err(small().light(Light::default().ambient(f64::NAN))).contains("ambient"));
    assert!(err(small().light(Light::default().shininess(0))).contains("shininess"));
    assert!(render(&m, 0.0, 91.0, &small()).unwrap_err().to_string().contains("elevation"));
    assert!(render(&m, f64::NAN, 45.0, &small()).unwrap_err().to_string().contains("azimuth"));
    let unknown = objects::builtin("teapot").unwrap_err().to_string();
    assert!(unknown.contains("duck, pot, cap, twin, column"), "{unknown}");
}

#[test]
fn sin_cos_deg_is_exact_at_right_angles() {
    assert_eq!(sin_cos_deg(0.0), (0.0, 1.0));
    assert_eq!(sin_cos_deg(360.0), (0.0, 1.0));
    assert_eq!(sin_cos_deg(90.0).0, 1.0);
    assert_eq!(sin_cos_deg(180.0).1, -1.0);
    assert_eq!(sin_cos_deg(-90.0).0, -1.0);
    for d in [1.0, 33.0, 89.9, 123.0, 250.0, 359.0, -40.0] {
        let (s, c) = sin_cos_deg(d);
        assert!((s - d.to_radians().sin()).abs() < 1e-15 && (c - d.to_radians().cos()).abs() < 1e-15, "{d}");
    }
}

#[test]
fn a_whole_pixel_offset_moves_the_image_exactly() {
    let mesh = duck();
    let base = small();
    let at = render(&mesh, 40.0, 45.0, &base).unwrap();
    let (w, h) = (at.width() as i64, at.height() as i64);
    for (dx, dy) in [(3i64, -2i64), (-5, 4), (0, 1)] {
        let moved = render(&mesh, 40.0, 45.0, &base.clone().camera(Camera::default().offset(dx as f64, dy as f64))).unwrap();
        for y in 0..h {
            for x in 0..w {
                let (sx, sy) = (x - dx, y - dy);
                let want = if (0..w).contains(&sx) && (0..h).contains(&sy) { at.get_pixel(sx as u32, sy as u32)[0] } else { 0 };
                assert_eq!(moved.get_pixel(x as u32, y as u32)[0], want, "offset ({dx}, {dy}) at ({x}, {y})");
            }
        }
    }
}

#[test]
fn exposure_scales_every_pixel_and_clips_at_white() {
    let mesh = duck();
    let at = render(&mesh, 10.0, 40.0, &small()).unwrap();
    for e in [0.5, 1.7] {
        let lit = render(&mesh, 10.0, 40.0, &small().exposure(e)).unwrap();
        for (a, b) in at.pixels().zip(lit.pixels()) {
            assert_eq!(b[0], (a[0] as f64 * e).round().min(255.0) as u8);
        }
    }
    assert!(small().exposure(0.0).validate().unwrap_err().to_string().contains("exposure"));
}

#[test]
fn jitter_is_drawn_per_view_from_its_seed_within_its_bounds() {
    let j = Jitter::parse("8, 0.1, 0.2", 7).unwrap();
    let views: Vec<ViewJitter> = (0..200).map(|i| j.view(i)).collect();
    assert_eq!(views[17], j.view(17), "a view's draw does not depend on the others");
    assert_ne!(views[17], Jitter { seed: 8, ..j }.view(17));
    for v in &views {
        assert!(v.dx.abs() <= 8.0 && v.dy.abs() <= 8.0 && (0.9..=1.1).contains(&v.scale) && (0.8..=1.2).contains(&v.exposure), "{v:?}");
    }
    // The draws spread over their ranges.
    assert!(views.iter().any(|v| v.dx > 6.0) && views.iter().any(|v| v.dx < -6.0));
    let none = Jitter { shift: 0.0, scale: 0.0, exposure: 0.0, seed: 1 }.view(3);
    assert_eq!(none, ViewJitter { dx: 0.0, dy: 0.0, scale: 1.0, exposure: 1.0 });
    assert_eq!(none.apply(&small()).unwrap(), small());
    // Bad amounts name themselves; a scale that would push the sphere out of the frame too.
    for (spec, word) in [("8,0.1", "SHIFT,SCALE,EXPOSURE"), ("-1,0,0", "shift"), ("1,1.5,0", "scale"), ("1,0,x", "three numbers")] {
        assert!(Jitter::parse(spec, 0).unwrap_err().to_string().contains(word), "{spec}");
    }
    let big = ViewJitter { dx: 0.0, dy: 0.0, scale: 1.2, exposure: 1.0 };
    assert!(big.apply(&small()).unwrap_err().to_string().contains("fill"));
    assert!(Jitter { scale: 0.2, ..j }.fits(&small()).unwrap_err().to_string().contains("fill"));
    assert!(j.fits(&small()).is_ok());
}

fn rolled(p: &RenderParams, deg: f64) -> RenderParams {
    p.clone().camera(p.get_camera().clone().roll(deg))
}

#[test]
fn roll_0_is_no_roll_and_a_whole_turn_of_roll_is_none_bit_for_bit() {
    let m = duck();
    for p in [small(), small().camera(Camera::perspective())] {
        let base = render(&m, 40.0, 50.0, &p).unwrap();
        assert_eq!(base, render(&m, 40.0, 50.0, &rolled(&p, 0.0)).unwrap());
        assert_eq!(base, render(&m, 40.0, 50.0, &rolled(&p, 360.0)).unwrap());
        assert_eq!(render(&m, 40.0, 50.0, &rolled(&p, 30.0)).unwrap(), render(&m, 40.0, 50.0, &rolled(&p, -330.0)).unwrap());
        assert_ne!(base, render(&m, 40.0, 50.0, &rolled(&p, 30.0)).unwrap());
    }
    assert!(rolled(&small(), f64::INFINITY).validate().unwrap_err().to_string().contains("roll"));
}

#[test]
fn a_quarter_roll_turns_a_square_image_a_quarter_turn_counter_clockwise() {
    use image::imageops::{rotate180, rotate270, rotate90};
    // A roll of 90 degrees maps the sample grid of a square image onto itself, so the rolled view
    // is the unrolled one turned, up to the rounding of where vertices land: samples on a
    // silhouette edge may flip (see the module doc for the tolerance; when this test was written
    // none did).
    let square = RenderParams::default().width(64).height(64);
    let pot = objects::builtin("pot").unwrap();
    for (m, a, e, p) in [(&duck(), 40.0, 50.0, square.clone()), (&pot, 200.0, 35.0, square.clone().camera(Camera::perspective()))] {
        let base = render(m, a, e, &p).unwrap();
        for (roll, turned) in [(90.0, rotate270(&base)), (180.0, rotate180(&base)), (-90.0, rotate90(&base))] {
            let (n, max) = diff(&render(m, a, e, &rolled(&p, roll)).unwrap(), &turned, 1);
            eprintln!("roll {roll}: {n} pixels differ from the turned image by more than 1 level (by up to {max})");
            assert!(n <= 4 && max <= 64, "roll {roll}: {n} pixels differ by more than 1 level, by up to {max}");
        }
        // The test tells the directions apart: clockwise is far off.
        let (n, _) = diff(&render(m, a, e, &rolled(&p, 90.0)).unwrap(), &rotate90(&base), 1);
        assert!(n > 200, "a clockwise quarter turn differs in only {n} pixels");
    }
}

#[test]
fn any_roll_keeps_the_object_in_the_frame() {
    // The bounding sphere is a disc about the image's centre, whatever the roll: the object
    // covers about the same area and never reaches the border, and the corners are background.
    let m = objects::builtin("column").unwrap();
    let p = small();
    let on = |g: &GrayImage| g.as_raw().iter().filter(|&&v| v > 0).count() as f64;
    let base = on(&render(&m, 20.0, 40.0, &p).unwrap());
    for roll in [30.0, 45.0, 90.0, 135.0, -60.0] {
        let g = render(&m, 20.0, 40.0, &rolled(&p, roll)).unwrap();
        let (w, h) = g.dimensions();
        let border = (0..w).any(|x| g.get_pixel(x, 0)[0] > 0 || g.get_pixel(x, h - 1)[0] > 0)
            || (0..h).any(|y| g.get_pixel(0, y)[0] > 0 || g.get_pixel(w - 1, y)[0] > 0);
        assert!(!border, "roll {roll}: the object touches the border");
        assert!((on(&g) / base - 1.0).abs() < 0.1, "roll {roll}: {} pixels against {base}", on(&g));
    }
}

#[test]
fn the_light_changes_the_shading_but_not_the_silhouette() {
    // The pot's darkest albedo (0.25) under the ambient light alone (0.3) keeps even a pixel a
    // quarter covered above 0, so the non-black pixels are the silhouette under every light.
    let m = objects::builtin("pot").unwrap();
    let mask = |g: &GrayImage| g.as_raw().iter().map(|&v| v > 0).collect::<Vec<bool>>();
    for (a, e) in [(30.0, 45.0), (250.0, 70.0)] {
        let base = render(&m, a, e, &small()).unwrap();
        let object = mask(&base).iter().filter(|&&b| b).count();
        assert_eq!(base, render(&m, a, e, &small().light(Light::default().azimuth_deg(35.0))).unwrap(), "35 is the default light");
        for l in [0.0, 90.0, 180.0, 270.0] {
            let lit = render(&m, a, e, &small().light(Light::default().azimuth_deg(l))).unwrap();
            assert_eq!(mask(&lit), mask(&base), "light at {l}: the silhouette changed");
            let (changed, _) = diff(&lit, &base, 8);
            assert!(changed * 5 > object, "light at {l}: only {changed} of {object} pixels change by more than 8 levels");
        }
    }
}
