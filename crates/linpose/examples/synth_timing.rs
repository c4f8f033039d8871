//! Times rendering the paper's full grid (1760 poses) of duck, pot and cap and writing each data
//! set to disk as PNG images plus poses.csv.
//!
//! cargo run --release -p linpose --example synth_timing [-- SCRATCH_DIR]

use linpose::render::synth::{write_dataset, PoseGrid};
use linpose::render::{objects, RenderParams};
use std::time::Instant;

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let scratch = match std::env::args().nth(1) {
        Some(d) => std::path::PathBuf::from(d),
        None => std::env::temp_dir().join(format!("linpose-synth-timing-{}", std::process::id())),
    };
    let grid = PoseGrid::paper();
    let params = RenderParams::default();
    let total = Instant::now();
    let mut images = 0;
    for name in ["duck", "pot", "cap"] {
        let t = Instant::now();
        let mesh = objects::builtin(name)?;
        let out = scratch.join(name);
        images += write_dataset(&mesh, &grid, &params, &out, &|_| {})?;
        eprintln!("{name}: {} triangles, {} images in {:.2} s", mesh.triangles().len(), grid.len(), t.elapsed().as_secs_f64());
    }
    let secs = total.elapsed().as_secs_f64();
    eprintln!("total: {images} images rendered and written in {secs:.2} s ({:.0} images/s, {} threads)", images as f64 / secs, rayon::current_num_threads());
    std::fs::remove_dir_all(&scratch)?;
    Ok(())
}
