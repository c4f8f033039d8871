//! `linpose scene`: put every view of a data set into a scene - its object found against the
//! studio backdrop, the backdrop replaced by clutter, noise or photographs, occluders in front -
//! and write the new data set with the same poses and a scene.csv.

use crate::common::progress;
use linpose::render::background::BackgroundSpec;
use linpose::render::scene::{SceneSpec, DEFAULT_SEED};
use linpose::scene::write_scenes;
use linpose::Source;
use std::io::Write;
use std::path::PathBuf;

/// Arguments of `linpose scene`.
#[derive(clap::Args, Debug)]
pub(crate) struct SceneArgs {
    /// The data set: a folder with poses.csv, a COIL folder (with --object for one object),
    /// or a data set of several objects.
    #[arg(long, value_name = "DIR")]
    pub data: PathBuf,
    /// Read a COIL folder's object O only.
    #[arg(long, value_name = "O")]
    pub object: Option<u32>,
    /// Output folder for the new data set; it must not exist yet or be empty.
    #[arg(long, value_name = "DIR")]
    pub out: PathBuf,
    /// What replaces the studio backdrop: `texture` (procedural clutter, the default), `noise`
    /// (independent pixel noise), a folder of photographs (a random crop of a random one per
    /// view), or a level from 0 (black) to 1 (white).
    #[arg(long, value_name = "texture|noise|DIR|LEVEL", default_value = "texture")]
    pub background: String,
    /// Hide about this share of each view's object (in [0, 1)) behind one or two occluders.
    #[arg(long, value_name = "F", default_value_t = 0.0)]
    pub occlude: f64,
    /// Put each view's object (with its occluders) somewhere in a larger image of WxH pixels
    /// instead, scaled by a random factor within --scale; scene.csv records the box.
    #[arg(long, value_name = "WxH")]
    pub canvas: Option<String>,
    /// The range of the scale factor of the views on the canvas (log-uniform).
    #[arg(long, value_name = "LO:HI", default_value = "0.8:1.2", requires = "canvas")]
    pub scale: String,
    /// Seed of the scenes' draws: the same seed, the same scenes.
    #[arg(long, value_name = "S", default_value_t = DEFAULT_SEED)]
    pub seed: u64,
}

/// Runs `linpose scene`.
pub(crate) fn run(args: &SceneArgs) -> anyhow::Result<()> {
    let canvas = match &args.canvas {
        Some(size) => Some(canvas(size, &args.scale)?),
        None => None,
    };
    let spec = SceneSpec { background: BackgroundSpec::parse(&args.background)?, occlude: args.occlude, seed: args.seed, canvas };
    // A share outside [0, 1) is refused before any image is read.
    linpose::render::scene::Scene::new(linpose::render::background::Background::Level(0.0), spec.occlude, spec.seed)?;
    let source = Source::open(&args.data, args.object)?;
    let total = match &source {
        Source::One(m) => m.len(),
        Source::Many(c) => c.total_images(),
    };
    let bar = progress(total as u64, "putting views into scenes");
    let summary = write_scenes(&source, &spec, &args.out, &|k| bar.inc(k))?;
    bar.finish_and_clear();
    let mut stdout = std::io::stdout().lock();
    let objects = if summary.objects > 1 { format!(" of {} objects", summary.objects) } else { String::new() };
    writeln!(stdout, "wrote {} views{objects} in scenes ({}) with poses.csv and scene.csv to {}", summary.views, args.background, args.out.display())?;
    if spec.occlude > 0.0 {
        let [mean, lo, hi] = summary.hidden;
        writeln!(stdout, "hidden share of the object: mean {mean:.3}, from {lo:.3} to {hi:.3} (asked {})", spec.occlude)?;
    }
    Ok(())
}

/// The canvas of `--canvas WxH --scale LO:HI`.
fn canvas(size: &str, scale: &str) -> anyhow::Result<linpose::render::place::Canvas> {
    let (w, h) = size.split_once('x').ok_or_else(|| anyhow::anyhow!("--canvas {size}: expected WxH, e.g. 320x240"))?;
    let px = |v: &str| v.trim().parse::<u32>().map_err(|_| anyhow::anyhow!("--canvas {size}: '{v}' is not a whole number of pixels"));
    let (lo, hi) = scale.split_once(':').ok_or_else(|| anyhow::anyhow!("--scale {scale}: expected LO:HI, e.g. 0.8:1.2"))?;
    let f = |v: &str| v.trim().parse::<f64>().map_err(|_| anyhow::anyhow!("--scale {scale}: '{v}' is not a number"));
    Ok(linpose::render::place::Canvas::new(px(w)?, px(h)?, [f(lo)?, f(hi)?])?)
}
