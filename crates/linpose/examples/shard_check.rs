//! Checks on a COIL folder that statistics merged from shards give the single-process fit: for
//! every object, the linear model's weights and the eigenspace's PCA (mean, eigenimages,
//! coordinates, eigenvalues) from 3 shards of pixels read from disk, against the in-memory fit,
//! to 1e-9 relative (COIL's 72 views of 128 x 128 are fewer images than pixels, so shards of
//! pixels; shards of images are checked on rendered sets by the library's tests). Exits non-zero
//! on a failure.
//!
//! `cargo run --release -p linpose --example shard_check -- COIL_DIR`

use linpose::image_io::ColorMode;
use linpose::methods::eigenspace::pca::{self, Dimension};
use linpose::partial::Partial;
use linpose::{Dataset, Estimator, LinearModel, LinearParams, Manifest, Settings};
use std::path::Path;

fn rel(want: &[f64], got: &[f64]) -> f64 {
    let num: f64 = want.iter().zip(got).map(|(a, b)| (a - b) * (a - b)).sum();
    let den: f64 = want.iter().map(|a| a * a).sum();
    (num / den).sqrt()
}

fn merged(method: &str, settings: &Settings, manifest: &Manifest, shards: usize) -> linpose::Result<Partial> {
    let method = linpose::methods::find(method).expect("a method");
    let proto = Partial::for_images(method, settings, manifest, ColorMode::Gray)?;
    let mut total: Option<Partial> = None;
    for i in 0..shards {
        let mut p = proto.empty();
        p.read_shard(manifest, ColorMode::Gray, i, shards, &|_| {})?;
        let p = Partial::from_bytes(Path::new("shard"), &p.to_bytes()?)?;
        match &mut total {
            None => total = Some(p),
            Some(t) => t.merge(p)?,
        }
    }
    Ok(total.expect("shards"))
}

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let dir = std::env::args().nth(1).ok_or("usage: shard_check COIL_DIR")?;
    let dir = Path::new(&dir);
    let mut worst = [0f64; 2];
    for object in 1..=20 {
        let manifest = Manifest::coil(dir, object)?;
        let data = Dataset::load(manifest.clone(), ColorMode::Gray, &|_| {})?;
        let want = LinearParams::default().fit(&data)?;
        let got = merged("linear", &Settings::new(), &manifest, 3)?.finish()?;
        let got = got.downcast_ref::<LinearModel>().ok_or("a linear model")?;
        let r_lin = rel(want.weights(), got.weights());
        let p = merged("eigenspace", &Settings::new(), &manifest, 3)?;
        let a = pca::fit(&data, Dimension::Fixed(20))?;
        let b = pca::fit_with_gram(&data, Dimension::Fixed(20), p.gram().ok_or("a Gram matrix")?)?;
        let l = a.dim();
        let r_pca = [rel(&a.mean, &b.mean), rel(&a.basis, &b.basis), rel(&a.coords, &b.coords), rel(&a.eigenvalues[..l], &b.eigenvalues[..l])]
            .into_iter()
            .fold(0.0, f64::max);
        println!("object {object:2}: linear weights {r_lin:.1e}, eigenspace PCA {r_pca:.1e} (relative, 3 shards of pixels)");
        worst = [worst[0].max(r_lin), worst[1].max(r_pca)];
    }
    println!("largest: linear {:.1e}, eigenspace PCA {:.1e}", worst[0], worst[1]);
    if !(worst[0] < 1e-9 && worst[1] < 1e-9) {
        return Err("merged statistics differ from the single-process fit by more than 1e-9".into());
    }
    println!("shard check: passed");
    Ok(())
}
