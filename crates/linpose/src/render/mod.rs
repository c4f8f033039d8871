//! The turntable renderer: images of an object under known poses, as the paper's turntable and
//! robot arm took them, so linpose can make its own training data.
//!
//! The object stands on a turntable that turns it by the azimuth e about the vertical (z) axis; a
//! camera at elevation alpha above the turntable plane looks at its centre. In the object's own
//! frame the camera then lies in the direction u = (cos alpha cos e, cos alpha sin e, sin alpha)
//! of docs/method.md (the turntable turns clockwise seen from above). The camera may also be
//! rolled about its optical axis ([`Camera::roll`]), which turns the image and nothing else. The
//! light is fixed in the world: it does not turn with the object; its azimuth ([`Light::azimuth_deg`])
//! moves it around the turntable's vertical axis, which changes the shading and nothing else (a
//! data set can step through it, `synth --light`). Shading is Lambertian with an ambient term and an optional
//! Blinn-Phong highlight; the image is 8-bit gray on a uniform background (black by default), or
//! over a scene's background with occluders in front ([`scene`]). A camera offset moves
//! the object in the frame and an exposure scales its brightness; [`jitter`] draws both, with a
//! scale, per view, as a camera in a cell would see the views a turntable registers.
//!
//! ```
//! use linpose::render::{objects, render, RenderParams};
//!
//! let duck = objects::builtin("duck")?;
//! let image = render(&duck, 30.0, 45.0, &RenderParams::default())?;
//! assert_eq!(image.dimensions(), (160, 120));
//! assert!(image.pixels().any(|p| p.0[0] > 0));
//! # Ok::<(), linpose::Error>(())
//! ```
//!
//! Rendering is deterministic: the same mesh, pose and parameters give the same bytes on every
//! machine. Angles go through `sin_cos_deg` (exact at multiples of 90 degrees, so azimuth 0 and
//! 360 are the same pose bit for bit), trigonometry through the pure-Rust `libm`, and per-pixel
//! work uses only IEEE-exact operations.

pub mod background;
pub mod grid;
pub mod jitter;
pub mod mesh;
pub mod objects;
pub mod occlude;
mod params;
pub mod photos;
pub mod place;
pub mod random;
mod raster;
pub mod scene;
pub mod synth;
mod texture;
mod tuning;
mod view;

pub use grid::Grid;
pub use jitter::{Jitter, ViewJitter};
pub use mesh::Mesh;
pub use params::{Camera, Light, Projection, RenderParams};

use crate::{Error, Result};
use image::GrayImage;
use mesh::normalise;
use raster::{Projected, Samples, Shading, Target};

/// Renders `mesh` turned by `azimuth_deg` and seen from `elevation_deg` (in [-90, 90]).
pub fn render(mesh: &Mesh, azimuth_deg: f64, elevation_deg: f64, params: &RenderParams) -> Result<GrayImage> {
    let mut renderer = Renderer::new(params)?;
    let mut pixels = vec![0u8; params.get_width() as usize * params.get_height() as usize];
    renderer.render_into(mesh, azimuth_deg, elevation_deg, &mut pixels)?;
    Ok(GrayImage::from_raw(params.get_width(), params.get_height(), pixels).expect("buffer has width * height pixels"))
}

/// A renderer that keeps its buffers between images (one per thread when rendering many).
#[derive(Debug)]
pub struct Renderer {
    params: RenderParams,
    samples: Samples,
    xyd: Vec<[f64; 3]>,
    verts: Vec<Projected>,
}

impl Renderer {
    /// A renderer for `params`, which are checked here.
    pub fn new(params: &RenderParams) -> Result<Self> {
        params.validate()?;
        Ok(Renderer { params: params.clone(), samples: Samples::default(), xyd: Vec::new(), verts: Vec::new() })
    }

    /// Renders with `params` from now on (checked here), keeping the buffers.
    pub fn set_params(&mut self, params: &RenderParams) -> Result<()> {
        params.validate()?;
        self.params = params.clone();
        Ok(())
    }

    /// The parameters.
    pub fn params(&self) -> &RenderParams {
        &self.params
    }

    /// Renders into `out`, `width * height` gray pixels, row-major.
    pub fn render_into(&mut self, mesh: &Mesh, azimuth_deg: f64, elevation_deg: f64, out: &mut [u8]) -> Result<()> {
        self.render_target(mesh, [azimuth_deg, elevation_deg], Target { out, backdrop: None, coverage: None })
    }

    /// Renders into `out` over `backdrop` (when given; else the parameters' uniform background),
    /// both `width * height` gray pixels, row-major, and writes into `coverage` how many of each
    /// pixel's samples the object covers (0 to supersample squared). A pixel the object covers
    /// whole is the pixel [`Renderer::render_into`] gives; one it covers in part mixes the object
    /// with the backdrop's pixel in proportion, as a camera's pixel mixes an edge. The exposure
    /// scales the backdrop with the object.
    pub fn render_over(&mut self, mesh: &Mesh, pose: [f64; 2], backdrop: Option<&[u8]>, out: &mut [u8], coverage: &mut [u8]) -> Result<()> {
        let n = out.len();
        if backdrop.is_some_and(|b| b.len() != n) || coverage.len() != n {
            return Err(Error::invalid(
                "backdrop or coverage buffer",
                format!("{:?}, {}", backdrop.map(|b| b.len()), coverage.len()),
                format!("must hold {n} pixels, as the output"),
            ));
        }
        self.render_target(mesh, pose, Target { out, backdrop, coverage: Some(coverage) })
    }

    /// Renders the pose `[azimuth, elevation]` (degrees) into `target`.
    fn render_target(&mut self, mesh: &Mesh, pose: [f64; 2], target: Target<'_>) -> Result<()> {
        let [azimuth_deg, elevation_deg] = pose;
        if !azimuth_deg.is_finite() {
            return Err(Error::invalid("azimuth", azimuth_deg, "must be a finite number of degrees"));
        }
        if !(-90.0..=90.0).contains(&elevation_deg) {
            return Err(Error::invalid("elevation", elevation_deg, "must be in [-90, 90] degrees"));
        }
        let p = &self.params;
        let (w, h) = (p.get_width() as usize, p.get_height() as usize);
        if target.out.len() != w * h {
            return Err(Error::invalid("output buffer", target.out.len(), format!("must hold {w} x {h} pixels")));
        }
        let ss = p.get_supersample() as usize;
        let (sw, sh) = (w * ss, h * ss);

        let (se, ce) = sin_cos_deg(azimuth_deg);
        let (sa, ca) = sin_cos_deg(elevation_deg);
        let (sr, cr) = sin_cos_deg(p.get_camera().get_roll());
        // Camera frame in the world: towards the camera c; image up and image right, which
        // without roll are (-sin alpha, 0, cos alpha) and (0, 1, 0), turned by the roll about c
        // (up' = cos r up + sin r right, right' = cos r right - sin r up), so the image turns
        // counter-clockwise. At roll 0 (sin 0 = 0 and cos 0 = 1 exactly) they are the unrolled
        // vectors bit for bit.
        let c = [ca, 0.0, sa];
        let up = [-sa * cr, sr, ca * cr];
        let right = [sa * sr, cr, -ca * sr];
        // Object to world: the turntable's rotation Rz(-e).
        let turn = |v: [f64; 3]| [ce * v[0] + se * v[1], ce * v[1] - se * v[0], v[2]];
        // Sample units per unit of the normalised (unit-sphere) object.
        let scale = p.get_camera().get_fill() * (sw.min(sh) as f64) / 2.0;
        let [dx, dy] = p.get_camera().get_offset();
        let (cx, cy) = (sw as f64 / 2.0 + dx * ss as f64, sh as f64 / 2.0 + dy * ss as f64);
        let centre = mesh.centre();
        let radius = mesh.radius();
        let perspective = match p.get_camera().get_projection() {
            Projection::Orthographic => None,
            // The unit sphere seen from distance d subtends tan(theta) = 1 / sqrt(d^2 - 1): the
            // focal length that makes it span the same `scale` as the orthographic view.
            Projection::Perspective { distance } => Some((distance, scale * (distance * distance - 1.0).sqrt())),
        };

        self.xyd.clear();
        self.verts.clear();
        for ((&pos, &n), &albedo) in mesh.positions().iter().zip(mesh.normals()).zip(mesh.albedo()) {
            let q = [(pos[0] - centre[0]) / radius, (pos[1] - centre[1]) / radius, (pos[2] - centre[2]) / radius];
            let wp = turn(q);
            let normal = turn(n);
            let (xc, yc, zc) = (mesh::dot(wp, right), mesh::dot(wp, up), mesh::dot(wp, c));
            let (x, y, facing) = match perspective {
                None => (cx + scale * xc, cy - scale * yc, mesh::dot(normal, c)),
                Some((d, f)) => {
                    let k = f / (d - zc);
                    let to_cam = [d * c[0] - wp[0], d * c[1] - wp[1], d * c[2] - wp[2]];
                    (cx + k * xc, cy - k * yc, mesh::dot(normal, to_cam))
                }
            };
            self.xyd.push([x, y, zc]);
            self.verts.push(Projected { normal, albedo, facing });
        }

        let light = p.get_light();
        let (sle, cle) = sin_cos_deg(light.get_elevation_deg());
        let (sla, cla) = sin_cos_deg(light.get_azimuth_deg());
        let l = [cle * cla, cle * sla, sle];
        let shading = Shading {
            light: l,
            half: normalise([l[0] + c[0], l[1] + c[1], l[2] + c[2]]),
            ambient: light.get_ambient(),
            diffuse: light.get_diffuse(),
            specular: light.get_specular(),
            shininess: light.get_shininess(),
            background: p.get_background(),
        };
        self.samples.reset(sw, sh);
        self.samples.draw(&self.xyd, mesh.triangles());
        let Target { out, backdrop, coverage } = target;
        self.samples.resolve(&self.verts, mesh.triangles(), &shading, ss, Target { out: &mut *out, backdrop, coverage });
        let exposure = p.get_exposure();
        if exposure != 1.0 {
            out.iter_mut().for_each(|v| *v = (*v as f64 * exposure).round().min(255.0) as u8);
        }
        Ok(())
    }
}

/// (sin, cos) of an angle in degrees, reduced to [0, 90) in degrees first so that multiples of
/// 90 are exact (sin 180 = 0, cos 360 = 1) and the result depends only on the angle modulo 360.
pub(crate) fn sin_cos_deg(deg: f64) -> (f64, f64) {
    let r = deg.rem_euclid(360.0);
    let r = if r >= 360.0 { 0.0 } else { r };
    let q = (r / 90.0).floor().min(3.0);
    let x = (r - 90.0 * q) * (std::f64::consts::PI / 180.0);
    let (s, c) = (libm::sin(x), libm::cos(x));
    match q as u8 {
        0 => (s, c),
        1 => (c, -s),
        2 => (-s, -c),
        _ => (-c, s),
    }
}

#[cfg(test)]
mod tests;
