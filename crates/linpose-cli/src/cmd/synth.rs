//! `linpose synth`: render a built-in object, a generated one or an OBJ mesh on a turntable grid of poses and write
//! the data set (poses.csv, dataset.toml and PNG images).

use crate::common::progress;
use anyhow::{bail, Context};
use linpose::render::background::BackgroundSpec;
use linpose::render::scene::{SceneSpec, DEFAULT_SEED};
use linpose::render::synth::{write_dataset, PoseGrid};
use linpose::render::{objects, Camera, Grid, Jitter, Light, Mesh, RenderParams};
use std::io::Write;
use std::path::PathBuf;

/// Arguments of `linpose synth`.
#[derive(clap::Args, Debug)]
pub(crate) struct SynthArgs {
    /// Built-in object to render (see --list).
    #[arg(long, value_name = "NAME", conflicts_with_all = ["mesh", "random"], required_unless_present_any = ["mesh", "random", "list"])]
    pub object: Option<String>,
    /// Wavefront OBJ mesh to render (its Y axis stands on the turntable).
    #[arg(long, value_name = "FILE.obj", conflicts_with = "random")]
    pub mesh: Option<PathBuf>,
    /// A generated object instead: the one of this seed (the same seed, the same images).
    #[arg(long, value_name = "SEED")]
    pub random: Option<u64>,
    /// Output folder for the data set; it must not exist yet or be empty.
    #[arg(long, value_name = "DIR", required_unless_present = "list")]
    pub out: Option<PathBuf>,
    /// Azimuths (turntable angles), degrees.
    #[arg(long, value_name = "START:STOP:STEP", default_value = "0:327:3", allow_hyphen_values = true)]
    pub azimuth: String,
    /// Elevations of the camera above the turntable plane, degrees.
    #[arg(long, value_name = "START:STOP:STEP", default_value = "32:77:3", allow_hyphen_values = true)]
    pub elevation: String,
    /// Rolls of the camera about its optical axis, degrees (the image turned counter-clockwise):
    /// every pose at every roll, a `roll` column in poses.csv. None by default.
    #[arg(long, value_name = "START:STOP:STEP", allow_hyphen_values = true)]
    pub roll: Option<String>,
    /// Azimuths of the light around the turntable's vertical axis, degrees (the camera at 0; by
    /// default the light stays at 35): every pose under every light, a `light` column in
    /// poses.csv. The shading changes, the silhouette does not.
    #[arg(long, value_name = "START:STOP:STEP", allow_hyphen_values = true)]
    pub light: Option<String>,
    /// Image size, WIDTHxHEIGHT.
    #[arg(long, value_name = "WxH", default_value = "160x120")]
    pub size: String,
    /// Long-lens perspective instead of orthographic projection.
    #[arg(long)]
    pub perspective: bool,
    /// Weight of the specular highlight (0 for a matte object).
    #[arg(long, value_name = "S", default_value_t = 0.0)]
    pub specular: f64,
    /// The background: a level from 0 (black, the default) to 1 (white), a studio backdrop of
    /// gray paper or cloth, e.g. 0.5; or a scene's: `texture` (procedural clutter), `noise`
    /// (independent pixel noise) or a folder of photographs (a random crop of a random one),
    /// each view its own draw (recorded in scene.csv).
    #[arg(long, value_name = "LEVEL|texture|noise|DIR", default_value = "0")]
    pub background: String,
    /// Hide about this share of each view's object (in [0, 1)) behind one or two opaque,
    /// striped occluders, each view its own (recorded in scene.csv).
    #[arg(long, value_name = "F", default_value_t = 0.0)]
    pub occlude: f64,
    /// Seed of the scene's draws (background and occluders).
    #[arg(long, value_name = "S", default_value_t = DEFAULT_SEED)]
    pub seed: u64,
    /// Jitter every view as a camera in a cell would see it: a shift of up to SHIFT pixels along
    /// each image axis, a scale within 1 +- SCALE and an exposure within 1 +- EXPOSURE, uniform,
    /// each view its own draw (written to jitter.csv), e.g. 8,0.1,0.2.
    #[arg(long, value_name = "SHIFT,SCALE,EXPOSURE")]
    pub jitter: Option<String>,
    /// Seed of the jitter's draws.
    #[arg(long, value_name = "S", default_value_t = 0, requires = "jitter")]
    pub jitter_seed: u64,
    /// List the built-in objects and exit.
    #[arg(long)]
    pub list: bool,
}

/// Runs `linpose synth`.
pub(crate) fn run(args: &SynthArgs) -> anyhow::Result<()> {
    // A closed pipe (`linpose synth --list | head -1`) is an error that main treats as success,
    // where the print macro would panic.
    let mut stdout = std::io::stdout().lock();
    if args.list {
        let width = objects::OBJECTS.iter().map(|o| o.0.len()).max().unwrap_or(0);
        for (name, about) in objects::OBJECTS {
            writeln!(stdout, "{name:width$}  {about}")?;
        }
        writeln!(
            stdout,
            "\n--random SEED  a generated object instead: asymmetric, front-back symmetric but for a mark, or a body of revolution with one feature"
        )?;
        return Ok(());
    }
    let Some(out) = &args.out else { bail!("--out DIR is required") };
    let (mesh, name) = match (&args.object, &args.mesh, args.random) {
        (Some(name), None, None) => (objects::builtin(name)?, name.clone()),
        (None, Some(path), None) => (Mesh::from_obj(path)?, path.display().to_string()),
        (None, None, Some(seed)) => (objects::random(seed)?, objects::random_name(seed)),
        _ => bail!("give one of --object NAME, --random SEED or --mesh FILE.obj"),
    };
    if let Some(seed) = args.random {
        writeln!(stdout, "{name}: {}", objects::random_kind(seed).description)?;
    }
    let mut grid = PoseGrid::new(parse_grid("elevation", &args.elevation)?, parse_grid("azimuth", &args.azimuth)?)?;
    if let Some(spec) = &args.roll {
        grid = grid.with_roll(parse_grid("roll", spec)?)?;
    }
    if let Some(spec) = &args.light {
        grid = grid.with_light(parse_grid("light", spec)?)?;
    }
    if let Some(spec) = &args.jitter {
        grid = grid.with_jitter(Jitter::parse(spec, args.jitter_seed)?)?;
    }
    let (width, height) = parse_size(&args.size)?;
    let camera = if args.perspective { Camera::perspective() } else { Camera::default() };
    let background = BackgroundSpec::parse(&args.background)?;
    let level = match background {
        BackgroundSpec::Level(v) => v,
        _ => 0.0,
    };
    let params = RenderParams::default().width(width).height(height).camera(camera).light(Light::default().specular(args.specular)).background(level);
    params.validate()?;
    let scene = SceneSpec { background, occlude: args.occlude, seed: args.seed, canvas: None }.open(width, height)?;
    let scene_csv = !scene.is_plain();
    grid = grid.with_scene(scene);

    let bar = progress(grid.len() as u64, "rendering images");
    // The library's errors name the folder or file at fault.
    let n = write_dataset(&mesh, &grid, &params, out, &|k| bar.inc(k))?;
    bar.finish_and_clear();
    let jitter = if grid.jitter().is_some() { ", jitter.csv" } else { "" };
    let scene = if scene_csv { ", scene.csv" } else { "" };
    writeln!(stdout, "wrote {n} images of {name} at {width}x{height} and poses.csv{jitter}{scene} to {}", out.display())?;
    Ok(())
}

/// The grid of `--NAME SPEC`; an error names the flag and the value.
fn parse_grid(name: &'static str, spec: &str) -> anyhow::Result<Grid> {
    Grid::parse(name, spec).with_context(|| format!("--{name} {spec}"))
}

/// `160x120` to (160, 120).
fn parse_size(s: &str) -> anyhow::Result<(u32, u32)> {
    let parsed = s.split_once(['x', 'X']).and_then(|(w, h)| Some((w.trim().parse().ok()?, h.trim().parse().ok()?)));
    match parsed {
        Some((w, h)) if w > 0 && h > 0 => Ok((w, h)),
        _ => bail!("invalid --size {s:?}: expected WIDTHxHEIGHT in pixels, e.g. 160x120"),
    }
}

#[cfg(test)]
mod tests {
    use super::parse_size;

    #[test]
    fn sizes_parse_and_bad_ones_are_named() {
        assert_eq!(parse_size("160x120").unwrap(), (160, 120));
        assert_eq!(parse_size("64X48").unwrap(), (64, 48));
        for bad in ["160", "0x10", "ax3", "-1x5", ""] {
            assert!(parse_size(bad).unwrap_err().to_string().contains("--size"), "{bad}");
        }
    }
}
