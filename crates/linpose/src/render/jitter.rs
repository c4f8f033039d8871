//! Views as a camera in a cell takes them: each view of a data set moved in the frame, seen from
//! nearer or farther, and exposed brighter or darker than the registered views a turntable gives,
//! by amounts drawn from a seed ([`Jitter`]). Training on registered views and querying jittered
//! ones measures what position, scale and brightness do to a method.
//!
//! View i draws from its own ChaCha8 stream of the seed, so the jitter of a view does not depend
//! on the order or the number of threads it is rendered in.

use super::RenderParams;
use crate::{Error, Result};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;

/// How much each view is jittered: uniform draws of a shift of up to `shift` pixels along each
/// image axis, a scale in [1 - `scale`, 1 + `scale`] (the object's size in the frame, as a
/// change of distance would make it) and an exposure in [1 - `exposure`, 1 + `exposure`], each
/// view's from its own stream of `seed`.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Jitter {
    /// Largest shift along each axis, pixels.
    pub shift: f64,
    /// Largest relative change of scale (0.1: 0.9 to 1.1).
    pub scale: f64,
    /// Largest relative change of exposure (0.2: 0.8 to 1.2).
    pub exposure: f64,
    /// The seed of the draws.
    pub seed: u64,
}

/// One view's jitter.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct ViewJitter {
    /// Shift right, pixels.
    pub dx: f64,
    /// Shift down, pixels.
    pub dy: f64,
    /// Scale factor of the object's image.
    pub scale: f64,
    /// Exposure factor.
    pub exposure: f64,
}

impl Jitter {
    /// Parses `SHIFT,SCALE,EXPOSURE` (e.g. `8,0.1,0.2`) with `seed`.
    pub fn parse(spec: &str, seed: u64) -> Result<Self> {
        let bad = |reason: &str| Error::invalid("jitter", spec, reason.to_string());
        let parts: Vec<f64> = spec
            .split(',')
            .map(|p| p.trim().parse::<f64>())
            .collect::<std::result::Result<_, _>>()
            .map_err(|_| bad("expected SHIFT,SCALE,EXPOSURE, three numbers, e.g. 8,0.1,0.2"))?;
        let [shift, scale, exposure] = parts[..] else { return Err(bad("expected SHIFT,SCALE,EXPOSURE, three numbers, e.g. 8,0.1,0.2")) };
        let j = Jitter { shift, scale, exposure, seed };
        j.validate()?;
        Ok(j)
    }

    /// Checks the amounts: a shift of at least 0 pixels, scale and exposure changes in [0, 1).
    pub fn validate(&self) -> Result<()> {
        if !(self.shift.is_finite() && self.shift >= 0.0) {
            return Err(Error::invalid("jitter shift", self.shift, "must be a number of pixels, 0 or more"));
        }
        for (name, v) in [("jitter scale", self.scale), ("jitter exposure", self.exposure)] {
            if !(v.is_finite() && (0.0..1.0).contains(&v)) {
                return Err(Error::invalid(name, v, "must be a fraction in [0, 1) (0.1: from 0.9 to 1.1 times)"));
            }
        }
        Ok(())
    }

    /// Checks that the largest scale keeps the object's bounding sphere within the frame of
    /// `params` (its camera's fill times 1 + `scale` at most 1), before any view is rendered.
    pub fn fits(&self, params: &RenderParams) -> Result<()> {
        let fill = params.get_camera().get_fill() * (1.0 + self.scale);
        if fill > 1.0 {
            return Err(Error::invalid(
                "jitter scale",
                self.scale,
                format!("makes the object's bounding sphere up to {fill:.3} of the frame (the camera's fill is {}); at most 1", params.get_camera().get_fill()),
            ));
        }
        Ok(())
    }

    /// The jitter of view `i`.
    pub fn view(&self, i: usize) -> ViewJitter {
        let mut rng = ChaCha8Rng::seed_from_u64(self.seed);
        rng.set_stream(i as u64);
        let mut draw = |a: f64| if a > 0.0 { rng.random_range(-a..=a) } else { 0.0 };
        ViewJitter { dx: draw(self.shift), dy: draw(self.shift), scale: 1.0 + draw(self.scale), exposure: 1.0 + draw(self.exposure) }
    }
}

/// Reads a `jitter.csv` as `synth --jitter` writes it: each image's name with its jitter. Errors
/// name the file and line.
pub fn read_csv(path: &std::path::Path) -> Result<Vec<(String, ViewJitter)>> {
    let text = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
    let mut lines = text.lines().enumerate();
    match lines.next() {
        Some((_, h)) if h.trim() == "image,dx,dy,scale,exposure" => {}
        _ => return Err(Error::parse(path, 1, "expected the header image,dx,dy,scale,exposure")),
    }
    let mut out = Vec::new();
    for (k, line) in lines.filter(|(_, l)| !l.trim().is_empty()) {
        let fields: Vec<&str> = line.split(',').collect();
        let bad = || Error::parse(path, k + 1, format!("expected an image and four numbers, got '{line}'"));
        let [image, rest @ ..] = &fields[..] else { return Err(bad()) };
        let v: Vec<f64> = rest.iter().map(|f| f.trim().parse::<f64>()).collect::<std::result::Result<_, _>>().map_err(|_| bad())?;
        let [dx, dy, scale, exposure] = v[..] else { return Err(bad()) };
        if !v.iter().all(|x| x.is_finite()) {
            return Err(bad());
        }
        out.push((image.trim().to_string(), ViewJitter { dx, dy, scale, exposure }));
    }
    Ok(out)
}

impl ViewJitter {
    /// `params` with this view's jitter: the camera's fill times the scale, its offset the shift,
    /// the exposure times this one's.
    pub fn apply(&self, params: &RenderParams) -> Result<RenderParams> {
        let camera = params.get_camera().clone();
        let fill = camera.get_fill() * self.scale;
        if fill > 1.0 {
            return Err(Error::invalid(
                "jitter scale",
                self.scale,
                format!("makes the object's bounding sphere {fill:.3} of the frame; lower the camera's fill or the scale jitter"),
            ));
        }
        let [ox, oy] = camera.get_offset();
        let out = params.clone().camera(camera.fill(fill).offset(ox + self.dx, oy + self.dy)).exposure(params.get_exposure() * self.exposure);
        out.validate()?;
        Ok(out)
    }
}
