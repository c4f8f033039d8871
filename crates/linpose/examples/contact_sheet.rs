//! Renders every built-in object at four poses into one contact sheet (a row per object, in the
//! order of `linpose::render::objects::OBJECTS`), to look at the objects.
//!
//! cargo run --release -p linpose --example contact_sheet [-- OUT.png]   (default docs/contact-sheet.png)

use linpose::render::{objects, synth, RenderParams, Renderer};

/// (elevation, azimuth) of each column.
const POSES: [(f64, f64); 4] = [(32.0, 0.0), (32.0, 90.0), (50.0, 210.0), (77.0, 300.0)];

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let out = std::env::args().nth(1).unwrap_or_else(|| "docs/contact-sheet.png".into());
    let params = RenderParams::default();
    let (w, h) = (params.get_width() as usize, params.get_height() as usize);
    let (cols, rows) = (POSES.len(), objects::OBJECTS.len());
    let sheet_w = cols * w + (cols - 1);
    let mut sheet = vec![64u8; sheet_w * (rows * h + rows - 1)];
    let mut renderer = Renderer::new(&params)?;
    let mut pixels = vec![0u8; w * h];
    for (r, (name, _)) in objects::OBJECTS.iter().enumerate() {
        let mesh = objects::builtin(name)?;
        for (c, &(e, a)) in POSES.iter().enumerate() {
            renderer.render_into(&mesh, a, e, &mut pixels)?;
            for y in 0..h {
                let at = (r * (h + 1) + y) * sheet_w + c * (w + 1);
                sheet[at..at + w].copy_from_slice(&pixels[y * w..(y + 1) * w]);
            }
        }
    }
    let png = synth::encode_png(&sheet, sheet_w as u32, (sheet.len() / sheet_w) as u32)?;
    std::fs::write(&out, png)?;
    eprintln!("wrote {out}");
    Ok(())
}
