//! Writes a stand-in for the rendered paper grid: 1760 smooth synthetic 160 x 120 gray images,
//! elevation 32..77 step 3 by azimuth 0..327 step 3, with `poses.csv` (`image,elevation,azimuth`),
//! for timing and comparing methods before the renderer exists.
//!
//!     cargo run --release -p linpose --example synth_sphere -- OUT_DIR
//!
//! Each image is a fixed cloud of 60 soft blobs on a lumpy object (seeded), turned by the azimuth
//! about the vertical axis and seen from the elevation under orthographic projection: every pixel
//! is a smooth function of both angles.

use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::io::Write;
use std::path::PathBuf;

const W: u32 = 160;
const H: u32 = 120;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let out = PathBuf::from(std::env::args().nth(1).ok_or("usage: synth_sphere OUT_DIR")?);
    std::fs::create_dir_all(&out)?;
    let mut rng = ChaCha8Rng::seed_from_u64(2000);
    // Blobs: position on a lumpy ellipsoid, brightness, size.
    let blobs: Vec<([f64; 3], f64, f64)> = (0..60)
        .map(|_| {
            let (t, z): (f64, f64) = (rng.random_range(0.0..std::f64::consts::TAU), rng.random_range(-1.0..1.0));
            let r = (1.0 - z * z).sqrt() * rng.random_range(0.7..1.0);
            ([r * t.cos() * 1.2, r * t.sin() * 0.8, z * 0.9], rng.random_range(0.1..0.35), rng.random_range(0.05..0.15))
        })
        .collect();
    let mut csv = std::fs::File::create(out.join("poses.csv"))?;
    writeln!(csv, "image,elevation,azimuth")?;
    for el in (32..=77).step_by(3) {
        for az in (0..=327).step_by(3) {
            let (a, e) = ((az as f64).to_radians(), (el as f64).to_radians());
            // Turn by the azimuth, then view from the elevation: screen axes u (right), v (up).
            let proj: Vec<(f64, f64, f64, f64)> = blobs
                .iter()
                .map(|&([x, y, z], b, s)| {
                    let (xr, yr) = (x * a.cos() - y * a.sin(), x * a.sin() + y * a.cos());
                    let (u, v) = (yr, z * e.cos() - xr * e.sin());
                    (u, v, b, s)
                })
                .collect();
            let mut img = image::GrayImage::new(W, H);
            for (px, py, p) in img.enumerate_pixels_mut() {
                let u = (px as f64 - W as f64 / 2.0) / (H as f64 / 2.5);
                let v = -(py as f64 - H as f64 / 2.0) / (H as f64 / 2.5);
                let mut val = 0.08;
                for &(bu, bv, b, s) in &proj {
                    val += b * (-((u - bu).powi(2) + (v - bv).powi(2)) / (2.0 * s * s)).exp();
                }
                p.0[0] = (255.0 * val.min(1.0)).round() as u8;
            }
            let name = format!("e{el:02}_a{az:03}.png");
            img.save(out.join(&name))?;
            writeln!(csv, "{name},{el},{az}")?;
        }
    }
    println!("wrote 1760 images to {}", out.display());
    Ok(())
}
