//! The built-in objects, built from primitives (ellipsoids, surfaces of revolution, swept tubes)
//! with albedo markings painted in object space, so that their appearance changes with both the
//! azimuth and the elevation.
//!
//! `duck`, `pot` and `cap` stand in for the paper's three objects; `twin` and `column` are the two
//! cases its conclusion leaves open: an object whose front and back differ only by a small mark,
//! and one whose appearance changes much more with azimuth than with elevation. `mug` and `ring`
//! are what real turntable sets hold and a segmentation must not take for two objects: a handle
//! that parts from the body in the image, and an object of two bright parts around a hole,
//! separated by parts as dark as a black background. Every object faces +x (the camera at
//! azimuth 0) with z up.
//!
//! [`random`] generates any number of further objects from a seed (see [`super::random`]).

use super::mesh::{builtin_path, Mesh};
pub use super::random::{random, random_kind, random_name, RandomClass, RandomKind};
use crate::{Error, Result};
use std::f64::consts::PI;

/// The built-in objects: name and a one-line description.
pub const OBJECTS: &[(&str, &str)] = &[
    ("duck", "a duck with wing patches, a neck ring, a bill and eyes (the paper's DUCK)"),
    ("pot", "a teapot with spout, handle, lid, painted bands and a label (the paper's POT)"),
    ("cap", "a baseball cap: six-panel crown with seams, button, front logo, and a brim (the paper's CAP)"),
    ("twin", "a rounded block whose front and back look the same but for a small mark"),
    ("column", "a tall striped cylinder with dark ends: its appearance changes much more with azimuth than with elevation"),
    ("mug", "a mug with a logo and a handle whose ends are black, so that the handle parts from the body in the image"),
    ("ring", "an upright ring with two black sectors: two bright arcs around a hole, a part as dark as the background"),
];

/// The built-in object `name` (see [`OBJECTS`]).
pub fn builtin(name: &str) -> Result<Mesh> {
    let mut b = Builder::default();
    match name {
        "duck" => duck(&mut b),
        "pot" => pot(&mut b),
        "cap" => cap(&mut b),
        "twin" => twin(&mut b),
        "column" => column(&mut b),
        "mug" => mug(&mut b),
        "ring" => ring(&mut b),
        _ => {
            let names: Vec<&str> = OBJECTS.iter().map(|o| o.0).collect();
            return Err(Error::invalid("object", name, format!("unknown built-in object; known: {}", names.join(", "))));
        }
    }
    b.finish(name)
}

pub(super) type P3 = [f64; 3];

/// Collects surfaces into one mesh.
#[derive(Default)]
pub(super) struct Builder {
    positions: Vec<P3>,
    albedo: Vec<f64>,
    triangles: Vec<[u32; 3]>,
}

impl Builder {
    /// A parametric patch of `nu x nv` quads over (u, v) in [0, 1]^2; `f` gives each grid
    /// point's position and albedo. With `wrap_u` the column u = 1 is the column u = 0 (a closed
    /// surface around an axis), so normals are smooth across the seam.
    pub(super) fn surface(&mut self, nu: usize, nv: usize, wrap_u: bool, f: impl Fn(f64, f64) -> (P3, f64)) {
        let base = self.positions.len() as u32;
        let cols = if wrap_u { nu } else { nu + 1 };
        for j in 0..=nv {
            for i in 0..cols {
                let (p, a) = f(i as f64 / nu as f64, j as f64 / nv as f64);
                self.positions.push(p);
                self.albedo.push(a.clamp(0.0, 1.0));
            }
        }
        let at = |i: usize, j: usize| base + (j * cols + i % cols) as u32;
        for j in 0..nv {
            for i in 0..nu {
                let (a, b, c, d) = (at(i, j), at(i + 1, j), at(i + 1, j + 1), at(i, j + 1));
                self.triangles.push([a, b, c]);
                self.triangles.push([a, c, d]);
            }
        }
    }

    /// An ellipsoid at `c` with semi-axes `r`; `paint` gets the unit direction from the centre
    /// (before scaling by the axes) and the surface point.
    pub(super) fn ellipsoid(&mut self, c: P3, r: P3, n: usize, paint: impl Fn(P3, P3) -> f64) {
        self.surface(2 * n, n, true, |u, v| {
            let d = sphere_dir(u, v);
            let p = [c[0] + r[0] * d[0], c[1] + r[1] * d[1], c[2] + r[2] * d[2]];
            (p, paint(d, p))
        });
    }

    /// A tube of radius `radius(t)` along the curve `path(t)`, t in [0, 1], which lies in the
    /// xz-plane (the tube's cross-sections are spanned by y and the in-plane normal).
    pub(super) fn tube(&mut self, nu: usize, nv: usize, path: impl Fn(f64) -> P3, radius: impl Fn(f64) -> f64, paint: impl Fn(f64, f64) -> f64) {
        self.surface(nu, nv, true, |u, t| {
            let h = 1e-4;
            let (a, b) = (path((t - h).max(0.0)), path((t + h).min(1.0)));
            let (tx, tz) = (b[0] - a[0], b[2] - a[2]);
            let l = (tx * tx + tz * tz).sqrt();
            let nrm = [-tz / l, 0.0, tx / l];
            let (s, c) = (libm::sin(2.0 * PI * u), libm::cos(2.0 * PI * u));
            let (p, r) = (path(t), radius(t));
            ([p[0] + r * (c * nrm[0]), p[1] + r * s, p[2] + r * (c * nrm[2])], paint(u, t))
        });
    }

    pub(super) fn finish(self, name: &str) -> Result<Mesh> {
        Mesh::new(self.positions, self.triangles, self.albedo).map_err(|e| match e {
            Error::Mesh { message, .. } => Error::Mesh { path: builtin_path(name), message },
            e => e,
        })
    }
}

/// Unit direction at longitude 2 pi u and colatitude pi v (v = 0 the top).
pub(super) fn sphere_dir(u: f64, v: f64) -> P3 {
    let (st, ct) = (libm::sin(PI * v), libm::cos(PI * v));
    let (sp, cp) = (libm::sin(2.0 * PI * u), libm::cos(2.0 * PI * u));
    [st * cp, st * sp, ct]
}

/// 0 below `a`, 1 above `b`, a smooth cubic between.
pub(super) fn smooth(a: f64, b: f64, x: f64) -> f64 {
    let t = ((x - a) / (b - a)).clamp(0.0, 1.0);
    t * t * (3.0 - 2.0 * t)
}

/// 1 at the centre of a spot of radius `r` (distance `d`), fading to 0 over `soft`.
pub(super) fn spot(d: f64, r: f64, soft: f64) -> f64 {
    1.0 - smooth(r - soft, r + soft, d)
}

pub(super) fn dist(a: P3, b: P3) -> f64 {
    let d = [a[0] - b[0], a[1] - b[1], a[2] - b[2]];
    (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt()
}

/// sqrt(x^2 + y^2) with + * and sqrt only (std's hypot is the platform's libm).
pub(super) fn hypot(x: f64, y: f64) -> f64 {
    (x * x + y * y).sqrt()
}

pub(super) fn mix(a: f64, b: f64, t: f64) -> f64 {
    a + (b - a) * t
}

/// Longitude of (x, y) in degrees, in (-180, 180].
pub(super) fn longitude(x: f64, y: f64) -> f64 {
    libm::atan2(y, x) * 180.0 / PI
}

fn duck(b: &mut Builder) {
    // Body: an ellipsoid, flattened below, its tail pulled up and narrowed.
    b.surface(72, 36, true, |u, v| {
        let d = sphere_dir(u, v);
        let (mut x, mut y, mut z) = (0.62 * d[0], 0.36 * d[1], 0.3 * d[2]);
        if z < 0.0 {
            z *= 0.75;
        }
        let tail = smooth(-0.2, -0.62, x);
        z += 0.32 * tail * tail;
        y *= 1.0 - 0.45 * tail;
        x -= 0.08 * tail;
        // Flanks pale, a dark wing on each side with a bright bar, dark tail, brown chest.
        let wing = smooth(0.25, 0.4, d[1].abs()) * smooth(-0.75, -0.6, d[0]) * (1.0 - smooth(0.2, 0.4, d[0])) * smooth(-0.2, 0.0, d[2]);
        let bar = spot((d[0] + 0.35).abs(), 0.06, 0.03) * wing;
        let chest = smooth(0.55, 0.8, d[0]);
        let mut a = mix(0.8, 0.35, wing);
        a = mix(a, 0.95, bar);
        a = mix(a, 0.45, chest);
        a = mix(a, 0.2, smooth(-0.75, -0.9, d[0]));
        // Speckles along the flanks so the body's turning shows in its texture.
        a -= 0.12 * (libm::sin(14.0 * x) * libm::sin(11.0 * z + 3.0 * y)).max(0.0);
        ([x, y, z], a)
    });
    // Neck with a white ring, then the dark head.
    b.ellipsoid([0.36, 0.0, 0.28], [0.13, 0.12, 0.2], 18, |_, p| mix(0.3, 0.95, spot((p[2] - 0.2).abs(), 0.025, 0.015)));
    let eye = |side: f64| {
        let l = (0.45f64 * 0.45 + 0.75 * 0.75 + 0.35 * 0.35).sqrt();
        [0.45 / l, side * 0.75 / l, 0.35 / l]
    };
    b.ellipsoid([0.42, 0.0, 0.5], [0.19, 0.16, 0.16], 26, |d, _| {
        let e = dist(d, eye(1.0)).min(dist(d, eye(-1.0)));
        let a = mix(0.3, 0.95, spot(e, 0.2, 0.03));
        mix(a, 0.02, spot(e, 0.12, 0.03))
    });
    // Bill: a flattened ellipsoid, bright with a dark nail at its tip.
    b.ellipsoid([0.64, 0.0, 0.45], [0.16, 0.085, 0.04], 14, |d, _| mix(0.95, 0.3, smooth(0.8, 0.95, d[0])));
}

fn pot(b: &mut Builder) {
    const H: f64 = 0.8;
    let body_r = |z: f64| 0.4 + 0.25 * libm::sin(PI * libm::pow(z / H, 0.8));
    // Base disk.
    b.surface(72, 4, true, |u, v| {
        let d = sphere_dir(u, 0.5);
        let r = body_r(0.0) * v;
        ([r * d[0], r * d[1], 0.0], 0.5)
    });
    // Body: bands, a wave between them, a label on the +y side and dots on the -y side.
    b.surface(96, 40, true, |u, v| {
        let d = sphere_dir(u, 0.5);
        let z = H * v;
        let r = body_r(z);
        let phi = longitude(d[0], d[1]);
        let mut a = 0.85;
        for zc in [0.12, 0.68] {
            a = mix(a, 0.25, spot((z - zc).abs(), 0.03, 0.012));
        }
        let wave = 0.4 + 0.07 * libm::sin(3.0 * phi.to_radians());
        a = mix(a, 0.3, spot((z - wave).abs(), 0.02, 0.012) * (1.0 - spot((phi - 90.0).abs(), 40.0, 5.0)));
        let label = spot((phi - 90.0).abs(), 28.0, 4.0) * spot((z - 0.4).abs(), 0.13, 0.02);
        a = mix(a, 0.3, label);
        a = mix(a, 0.95, spot(hypot((phi - 90.0) / 200.0, z - 0.44), 0.05, 0.015) * label);
        for k in 0..4 {
            let (pc, zc) = (-150.0 + 40.0 * k as f64, 0.3 + 0.1 * (k % 2) as f64);
            a = mix(a, 0.35, spot(hypot((phi - pc) / 200.0, z - zc), 0.045, 0.015));
        }
        ([r * d[0], r * d[1], z], a)
    });
    // Lid: a dome with a dark rim, then the knob.
    b.surface(72, 10, true, |u, v| {
        let d = sphere_dir(u, 0.5);
        let r = body_r(H) * (1.0 - v) + 0.06 * v;
        let z = H + 0.17 * libm::sin(0.5 * PI * v);
        ([r * d[0], r * d[1], z], mix(0.3, 0.6, smooth(0.1, 0.25, v)))
    });
    b.ellipsoid([0.0, 0.0, H + 0.22], [0.08, 0.08, 0.07], 10, |_, _| 0.25);
    // Spout: a quadratic Bezier curve rising from the +x side, narrowing.
    let bez = |t: f64, p: [P3; 3]| -> P3 {
        let (a, bb, c) = ((1.0 - t) * (1.0 - t), 2.0 * t * (1.0 - t), t * t);
        [0, 1, 2].map(|k| a * p[0][k] + bb * p[1][k] + c * p[2][k])
    };
    let spout = [[0.5, 0.0, 0.25], [0.88, 0.0, 0.3], [0.98, 0.0, 0.72]];
    b.tube(24, 16, |t| bez(t, spout), |t| 0.11 - 0.06 * t, |_, t| mix(0.85, 0.25, smooth(0.85, 0.95, t)));
    // Handle: half a torus on the -x side.
    b.tube(
        16,
        24,
        |t| {
            let th = PI * (t - 0.5);
            [-0.55 - 0.24 * libm::cos(th), 0.0, 0.42 + 0.27 * libm::sin(th)]
        },
        |_| 0.045,
        |_, _| 0.45,
    );
}

fn cap(b: &mut Builder) {
    // Crown: the upper part of an ellipsoid, six panels with seams, a button, eyelets, a logo.
    b.surface(120, 30, true, |u, v| {
        let d = sphere_dir(u, 0.56 * v);
        let p = [0.5 * d[0], 0.46 * d[1], 0.42 * d[2]];
        let phi = longitude(d[0], d[1]);
        let polar = 0.56 * 180.0 * v;
        let seam = ((phi + 30.0).rem_euclid(60.0) - 30.0).abs();
        let mut a = mix(0.78, 0.35, spot(seam, 2.2, 1.5) * smooth(6.0, 10.0, polar));
        a = mix(a, 0.15, spot(polar, 7.0, 1.5));
        let eyelet = hypot((phi.rem_euclid(60.0) - 30.0) / 9.0, (polar - 32.0) / 9.0);
        a = mix(a, 0.2, spot(eyelet, 0.18, 0.08));
        // Logo on the front panel: a bright disk with a dark letter-like bar and stem.
        let (lx, ly) = (phi / 22.0, (polar - 62.0) / 16.0);
        let logo = spot(hypot(lx, ly), 0.9, 0.1);
        a = mix(a, 0.97, logo);
        let letter = (spot(lx.abs(), 0.12, 0.05) * spot(ly.abs(), 0.6, 0.08))
            .max(spot(ly.abs() - 0.0, 0.12, 0.05) * spot(lx.abs(), 0.5, 0.08) * smooth(-0.1, 0.0, -ly + 0.0));
        a = mix(a, 0.15, letter * logo);
        // A dark strap band low on the back.
        a = mix(a, 0.3, smooth(130.0, 140.0, phi.abs()) * smooth(80.0, 86.0, polar));
        (p, a)
    });
    // Brim: from the crown's front half-rim outwards, drooping at its edge and curved sideways.
    b.surface(48, 12, false, |u, v| {
        let phi = PI * (u - 0.5);
        let (s, c) = (libm::sin(phi), libm::cos(phi));
        let rim = [0.5 * libm::sin(0.56 * PI) * c, 0.46 * libm::sin(0.56 * PI) * s, 0.42 * libm::cos(0.56 * PI)];
        let len = 0.4 * libm::pow(c.max(0.0), 1.3);
        let z = rim[2] - 0.12 * v * v * c - 0.07 * s * s * v;
        let p = [rim[0] + len * v * c, rim[1] + len * v * s, z];
        (p, mix(0.28, 0.75, smooth(0.82, 0.92, v)))
    });
}

fn twin(b: &mut Builder) {
    // A rounded block (superellipsoid); markings unchanged by a half turn, (x, y) -> (-x, -y),
    // but for a small dark dot at the front (+x) end.
    b.surface(72, 36, true, |u, v| {
        let d = sphere_dir(u, v);
        let sq = |x: f64| x.signum() * x.abs().sqrt();
        let (x, y, z) = (0.6 * sq(d[0]), 0.3 * sq(d[1]), 0.36 * sq(d[2]));
        let mut a = 0.75;
        a = mix(a, 0.3, spot((x.abs() - 0.32).abs(), 0.035, 0.015));
        for s in [1.0, -1.0] {
            a = mix(a, 0.25, spot(dist([x, y, z], [0.15 * s, 0.3 * s, 0.05]), 0.1, 0.02));
            a = mix(a, 0.45, spot(dist([x, y, z], [0.45 * s, -0.2 * s, 0.36]), 0.08, 0.02));
        }
        a = mix(a, 0.55, spot(y.abs(), 0.05, 0.02) * smooth(0.2, 0.3, z));
        a = mix(a, 0.05, spot(dist([x, y, z], [0.6, 0.0, 0.05]), 0.05, 0.015));
        ([x, y, z], a)
    });
}

fn column(b: &mut Builder) {
    const R: f64 = 0.34;
    // Side: sharp stripes of varying width over a slow variation, all constant along the column,
    // so a turn sweeps edges across the whole side while a change of elevation only moves the
    // ends. The ends are dark so that their changing shape shows little.
    let side = |phi: f64| {
        let t = phi.to_radians();
        let slow = 0.5 + 0.15 * libm::cos(t) + 0.1 * libm::sin(2.0 * t + 0.5);
        let wave = libm::sin(12.0 * t + 1.5 * libm::sin(t));
        mix(slow - 0.3, slow + 0.35, smooth(-0.25, 0.25, wave))
    };
    b.surface(360, 1, true, |u, v| {
        let d = sphere_dir(u, 0.5);
        ([R * d[0], R * d[1], 1.0 - 2.0 * v], side(longitude(d[0], d[1])))
    });
    for (z, v0) in [(1.0, 0.0), (-1.0, 1.0)] {
        b.surface(90, 3, true, |u, v| {
            let d = sphere_dir(u, 0.5);
            let r = R * (v0 + (1.0 - 2.0 * v0) * v);
            ([r * d[0], r * d[1], z], 0.1)
        });
    }
}

fn mug(b: &mut Builder) {
    const R: f64 = 0.32;
    const H: f64 = 0.75;
    // Base disk, then the wall: pale, with a dark band near the rim and a logo on the +y side
    // (a dark disk with a bright bar) so that the turn shows away from the handle too.
    b.surface(72, 4, true, |u, v| {
        let d = sphere_dir(u, 0.5);
        ([R * v * d[0], R * v * d[1], 0.0], 0.6)
    });
    b.surface(96, 30, true, |u, v| {
        let d = sphere_dir(u, 0.5);
        let z = H * v;
        let phi = longitude(d[0], d[1]);
        let mut a = mix(0.85, 0.3, spot((z - 0.64).abs(), 0.025, 0.01));
        let logo = spot(hypot((phi - 70.0) / 180.0, z - 0.36), 0.11, 0.015);
        a = mix(a, 0.25, logo);
        a = mix(a, 0.95, logo * spot((z - 0.36).abs(), 0.025, 0.01));
        a = mix(a, 0.4, spot(hypot((phi + 100.0) / 180.0, z - 0.25), 0.05, 0.015));
        ([R * d[0], R * d[1], z], a)
    });
    // Coffee: a dark disk just below the rim.
    b.surface(72, 4, true, |u, v| {
        let d = sphere_dir(u, 0.5);
        ([R * v * d[0], R * v * d[1], H - 0.06], 0.12)
    });
    // Handle: a C on the -x side whose ends, where it meets the wall, are black.
    b.tube(
        16,
        32,
        |t| {
            let th = PI * (t - 0.5);
            [-R + 0.02 - 0.24 * libm::cos(th), 0.0, 0.4 + 0.24 * libm::sin(th)]
        },
        |_| 0.05,
        |_, t| 0.8 * smooth(0.12, 0.2, t) * smooth(0.12, 0.2, 1.0 - t),
    );
}

fn ring(b: &mut Builder) {
    // A torus standing in the xz-plane, its hole facing the y axis. Two black sectors of
    // different widths cut it into two bright arcs; a dark dot on one arc's +y face and a band
    // on the other tell its sides and ends apart.
    const MAJOR: f64 = 0.6;
    b.tube(
        24,
        144,
        |t| {
            let th = 2.0 * PI * t;
            [MAJOR * libm::cos(th), 0.0, MAJOR * libm::sin(th)]
        },
        |_| 0.13,
        |u, t| {
            let deg = 360.0 * t;
            let black = spot((deg - 100.0).abs(), 9.0, 2.0).max(spot((deg - 250.0).abs(), 15.0, 2.0));
            let mut a = mix(0.8, 0.0, black);
            // u = 1/4 is the tube's +y side.
            a = mix(a, 0.3, spot(hypot((deg - 20.0) / 40.0, u - 0.25), 0.12, 0.03));
            a = mix(a, 0.45, spot((deg - 175.0).abs(), 4.0, 1.5));
            a
        },
    );
}
