//! A three-parameter data set (elevation, azimuth, roll) of a built-in object, for measuring the
//! methods on a manifold of three pose parameters. A STAND-IN for a renderer that rolls the
//! camera: each view is the turntable renderer's image at (elevation, azimuth), rotated by the
//! roll about the frame's centre (bilinear, black where the rotated frame leaves the image), as
//! a camera rolled about its optical axis would see it under orthographic projection with the
//! light turning with the camera.
//!
//! Writes two data sets in the directory format: `OUT/train` with the every-other-value lattice
//! (the first, third, ... value of each parameter's grid) and `OUT/unseen` with every other view
//! whose elevation and roll lie within their training range (every azimuth: it is circular).
//!
//! cargo run --release -p linpose --example roll_set -- OBJECT OUT [AZIMUTH ELEVATION ROLL]
//! (default grids 0:354:6 32:77:9 -30:30:10, images 160 x 120)

use linpose::render::{objects, synth, Grid, RenderParams, Renderer};
use std::fmt::Write as _;
use std::path::Path;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let args: Vec<String> = std::env::args().skip(1).collect();
    if args.len() != 2 && args.len() != 5 {
        return Err("usage: roll_set OBJECT OUT [AZIMUTH ELEVATION ROLL]".into());
    }
    let spec = |i: usize, default: &str| args.get(i).cloned().unwrap_or_else(|| default.into());
    let azimuth = Grid::parse("azimuth", &spec(2, "0:354:6"))?.values();
    let elevation = Grid::parse("elevation", &spec(3, "32:77:9"))?.values();
    let roll = Grid::parse("roll", &spec(4, "-30:30:10"))?.values();
    let mesh = objects::builtin(&args[0])?;
    let params = RenderParams::default();
    let (w, h) = (params.get_width() as usize, params.get_height() as usize);
    let out = Path::new(&args[1]);
    // The training range of the linear parameters: their even-index values' span (the azimuth
    // is circular: every value lies within its range).
    let even = |v: &[f64]| v.iter().step_by(2).copied().collect::<Vec<f64>>();
    let (ee, re) = (even(&elevation), even(&roll));
    let within = |v: f64, e: &[f64]| v >= e[0] && v <= e[e.len() - 1];
    let mut renderer = Renderer::new(&params)?;
    let (mut view, mut rolled) = (vec![0u8; w * h], vec![0u8; w * h]);
    let mut csv = [String::from("image,elevation,azimuth,roll\n"), String::from("image,elevation,azimuth,roll\n")];
    for dir in ["train", "unseen"] {
        std::fs::create_dir_all(out.join(dir))?;
        std::fs::write(out.join(dir).join("dataset.toml"), "elevation = { linear = true }\nazimuth = { period = 360 }\nroll = { linear = true }\n")?;
    }
    let mut counts = [0usize; 2];
    for (i, &e) in elevation.iter().enumerate() {
        for (j, &a) in azimuth.iter().enumerate() {
            renderer.render_into(&mesh, a, e, &mut view)?;
            for (k, &r) in roll.iter().enumerate() {
                let set = if i % 2 == 0 && j % 2 == 0 && k % 2 == 0 {
                    0
                } else if within(e, &ee) && within(r, &re) {
                    1
                } else {
                    continue;
                };
                rotate(&view, w, h, r, &mut rolled);
                let name = format!("e{e:05.1}_a{a:05.1}_r{r:+05.1}.png");
                std::fs::write(out.join(["train", "unseen"][set]).join(&name), synth::encode_png(&rolled, w as u32, h as u32)?)?;
                writeln!(csv[set], "{name},{e},{a},{r}")?;
                counts[set] += 1;
            }
        }
    }
    for (set, dir) in ["train", "unseen"].iter().enumerate() {
        std::fs::write(out.join(dir).join("poses.csv"), &csv[set])?;
    }
    eprintln!("wrote {} training and {} unseen views of {} to {}", counts[0], counts[1], args[0], out.display());
    Ok(())
}

/// `src` (w x h, 8-bit) rotated by `deg` degrees counter-clockwise about the frame's centre into
/// `dst`, bilinear, black outside the source.
fn rotate(src: &[u8], w: usize, h: usize, deg: f64, dst: &mut [u8]) {
    let (s, c) = deg.to_radians().sin_cos();
    let (cx, cy) = ((w as f64 - 1.0) / 2.0, (h as f64 - 1.0) / 2.0);
    let at = |x: isize, y: isize| if x < 0 || y < 0 || x >= w as isize || y >= h as isize { 0.0 } else { src[y as usize * w + x as usize] as f64 };
    for y in 0..h {
        for x in 0..w {
            // The source point that lands on (x, y): the inverse rotation (y grows downwards).
            let (dx, dy) = (x as f64 - cx, y as f64 - cy);
            let (sx, sy) = (cx + c * dx - s * dy, cy + s * dx + c * dy);
            let (x0, y0) = (sx.floor(), sy.floor());
            let (fx, fy) = (sx - x0, sy - y0);
            let (x0, y0) = (x0 as isize, y0 as isize);
            let v = (1.0 - fy) * ((1.0 - fx) * at(x0, y0) + fx * at(x0 + 1, y0)) + fy * ((1.0 - fx) * at(x0, y0 + 1) + fx * at(x0 + 1, y0 + 1));
            dst[y * w + x] = v.round().clamp(0.0, 255.0) as u8;
        }
    }
}
