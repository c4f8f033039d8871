//! Procedurally generated objects, a "zoo": [`random`] builds an object from a seed out of the
//! same primitives as the built-ins (ellipsoids, surfaces of revolution, swept tubes), with albedo
//! markings painted in object space (stripes, spots, bands, patches), so that its appearance
//! changes with both the azimuth and the elevation.
//!
//! Why: the built-in objects are the ones linpose's automatic choices (interpolants, steps,
//! thresholds) were developed on. A method's robustness is better measured over many objects it
//! was not tuned on; the zoo gives as many as wanted, each reproducible from its seed.
//!
//! The seed picks one of three classes ([`RandomClass`]), in about these shares:
//!
//! - **asymmetric** (40%): a body (an ellipsoid, squared off, tapered, bent or pear-shaped to a
//!   random degree) with one to three attached parts (bumps, horns, handles) and markings.
//! - **front-back** (30%): a body and paired parts whose shape and markings are unchanged by a half
//!   turn about the vertical axis, (x, y) -> (-x, -y), but for one small mark at the front (a spot
//!   or a knob), like the built-in `twin`. These probe front/back confusion: the images at azimuth
//!   a and a + 180 differ only by the mark.
//! - **revolution** (30%): a vase, bottle or spindle profile turned about the vertical axis, with
//!   horizontal bands and one small feature that breaks the rotational symmetry (a knob, a spot, a
//!   short handle or a label patch): away from the feature, the azimuth barely shows.
//!
//! Shape proportions, the number, place and size of parts and markings, and the albedo contrast
//! are drawn within ranges that render well. Like every mesh, the object is normalised to its
//! bounding sphere, so it fits the frame at every pose; objects face +x with z up.
//!
//! Generation is deterministic: the seed drives a ChaCha8 generator, and all arithmetic is
//! IEEE-exact or goes through the pure-Rust `libm`, so a seed gives the same mesh, bit for bit,
//! on every machine.
//!
//! ```
//! use linpose::render::{objects, render, RenderParams};
//!
//! let mesh = objects::random(7)?;
//! println!("{}: {}", objects::random_name(7), objects::random_kind(7).description);
//! assert_eq!(objects::random(7)?, mesh);
//! assert!(render(&mesh, 30.0, 45.0, &RenderParams::default())?.pixels().any(|p| p.0[0] > 0));
//! # Ok::<(), linpose::Error>(())
//! ```

use super::mesh::Mesh;
use super::objects::{dist, hypot, longitude, mix, smooth, sphere_dir, spot, Builder, P3};
use crate::Result;
use paint::{half_turn, normalise, Mark, Paint, Pattern};
use rand::{Rng, SeedableRng};
use rand_chacha::ChaCha8Rng;
use std::f64::consts::PI;
use std::fmt;

/// The class of a generated object (see the [module doc](self)).
#[derive(Debug, Clone, Copy, PartialEq, Eq, Hash)]
pub enum RandomClass {
    /// A body with one to three attached parts and markings, without symmetry.
    Asymmetric,
    /// Shape and markings unchanged by a half turn about the vertical axis, but for one small mark.
    FrontBack,
    /// A body of revolution with horizontal bands and one small feature breaking its symmetry.
    Revolution,
}

impl RandomClass {
    /// Every class.
    pub const ALL: [RandomClass; 3] = [RandomClass::Asymmetric, RandomClass::FrontBack, RandomClass::Revolution];

    /// Short name: `asymmetric`, `front-back` or `revolution`.
    pub fn name(self) -> &'static str {
        match self {
            RandomClass::Asymmetric => "asymmetric",
            RandomClass::FrontBack => "front-back",
            RandomClass::Revolution => "revolution",
        }
    }
}

impl fmt::Display for RandomClass {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// What a seed generates.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RandomKind {
    /// The seed.
    pub seed: u64,
    /// The object's class.
    pub class: RandomClass,
    /// One line describing its shape, parts and markings.
    pub description: String,
}

/// The object generated from `seed` (see the [module doc](self)).
pub fn random(seed: u64) -> Result<Mesh> {
    let mut b = Builder::default();
    generate(seed, &mut b);
    b.finish(&random_name(seed))
}

/// The class and description of the object [`random`] generates from `seed`.
pub fn random_kind(seed: u64) -> RandomKind {
    generate(seed, &mut Builder::default())
}

/// The name of the object generated from `seed`: `random-SEED`.
pub fn random_name(seed: u64) -> String {
    format!("random-{seed}")
}

fn generate(seed: u64, b: &mut Builder) -> RandomKind {
    let mut d = Draw(ChaCha8Rng::seed_from_u64(seed));
    let x = d.unit();
    let (class, description) = if x < 0.4 {
        (RandomClass::Asymmetric, asymmetric(&mut d, b))
    } else if x < 0.7 {
        (RandomClass::FrontBack, front_back(&mut d, b))
    } else {
        (RandomClass::Revolution, revolution(&mut d, b))
    };
    RandomKind { seed, class, description }
}

/// Random draws, all from the generator's 53-bit uniform doubles (portable and exact).
struct Draw(ChaCha8Rng);

impl Draw {
    fn unit(&mut self) -> f64 {
        self.0.random::<f64>()
    }

    fn range(&mut self, lo: f64, hi: f64) -> f64 {
        lo + (hi - lo) * self.unit()
    }

    /// 0..n, n >= 1.
    fn index(&mut self, n: usize) -> usize {
        ((self.unit() * n as f64) as usize).min(n - 1)
    }

    fn chance(&mut self, p: f64) -> bool {
        self.unit() < p
    }

    /// A uniform unit direction with z >= `zmin`.
    fn direction(&mut self, zmin: f64) -> P3 {
        let z = self.range(zmin, 1.0);
        let (s, c) = (libm::sin(2.0 * PI * self.unit()), libm::cos(2.0 * PI * self.unit()));
        let r = (1.0 - z * z).max(0.0).sqrt();
        [r * c, r * s, z]
    }

    /// An albedo that stands out from `base` by 0.25 to 0.55, darker where there is room.
    fn contrast(&mut self, base: f64) -> f64 {
        let c = self.range(0.25, 0.55);
        if base - c >= 0.1 && (base + c > 0.95 || self.chance(0.7)) {
            base - c
        } else {
            (base + c).min(0.97)
        }
    }
}

/// A deformed ellipsoid about the origin.
struct Body {
    axes: P3,
    /// Superellipsoid exponent: 1 an ellipsoid, smaller boxier.
    exp: f64,
    /// Scale of the lower half's height.
    flat: f64,
    /// Narrowing towards +x (asymmetric only).
    taper: f64,
    /// Lift of both x ends (asymmetric only).
    bend: f64,
    /// Widening towards the top (negative: the bottom).
    pear: f64,
}

impl Body {
    fn draw(d: &mut Draw, symmetric: bool) -> Body {
        let ax = d.range(0.45, 0.75);
        let ay = if symmetric { ax / d.range(1.4, 2.2) } else { d.range(0.22, 0.45) };
        let axes = [ax, ay, d.range(0.22, 0.45)];
        let (exp, flat) = (d.range(0.45, 1.0), d.range(0.6, 1.0));
        let (taper, bend) = if symmetric { (0.0, 0.0) } else { (d.range(-0.35, 0.35), if d.chance(0.5) { d.range(-0.1, 0.3) } else { 0.0 }) };
        Body { axes, exp, flat, taper, bend, pear: d.range(-0.25, 0.25) }
    }

    /// The surface point in the unit direction `d`.
    fn point(&self, d: P3) -> P3 {
        let e = |x: f64| if x < 0.0 { -libm::pow(-x, self.exp) } else { libm::pow(x, self.exp) };
        let [ax, ay, az] = self.axes;
        let (x, y, mut z) = (ax * e(d[0]), ay * e(d[1]), az * e(d[2]));
        if z < 0.0 {
            z *= self.flat;
        }
        let (t, w) = (x / ax, 1.0 + self.pear * z / az);
        let s = 1.0 - self.taper * t;
        [x * w, y * s * w, z * s + self.bend * t * t]
    }

    /// Mean semi-axis.
    fn size(&self) -> f64 {
        (self.axes[0] + self.axes[1] + self.axes[2]) / 3.0
    }

    fn describe(&self) -> String {
        let [ax, ay, az] = self.axes;
        let mut s = format!("{} body {ax:.2}x{ay:.2}x{az:.2}", if self.exp < 0.7 { "boxy" } else { "rounded" });
        if self.taper.abs() > 0.15 {
            s.push_str(", tapered");
        }
        if self.bend > 0.1 {
            s.push_str(", bent");
        }
        s
    }

    fn surface(&self, b: &mut Builder, paint: &Paint) {
        b.surface(120, 60, true, |u, v| {
            let p = self.point(sphere_dir(u, v));
            (p, paint.at(p))
        });
    }
}

/// Two to four groups of markings on `body` (all twinned when `symmetric`).
fn body_paint(d: &mut Draw, body: &Body, symmetric: bool) -> Paint {
    let base = d.range(0.45, 0.9);
    let sz = body.size();
    let mut marks = Vec::new();
    for _ in 0..2 + d.index(3) {
        let albedo = d.contrast(base);
        let mut push = |pattern, kind| marks.push(Mark { pattern, albedo, twin: symmetric, kind });
        match d.index(4) {
            0 => {
                for _ in 0..1 + d.index(4) {
                    let c = body.point(d.direction(-1.0));
                    push(Pattern::Spot { c, r: sz * d.range(0.12, 0.25) }, "spot");
                }
            }
            1 => {
                // Symmetric stripes run across the horizontal, as a cosine: unchanged by the turn.
                let dir = if symmetric { normalise([d.range(-1.0, 1.0), d.range(-1.0, 1.0), 0.0], [1.0, 0.0, 0.0]) } else { d.direction(-1.0) };
                let (freq, phase) = (d.range(12.0, 30.0), if symmetric { 0.5 * PI } else { d.range(0.0, 2.0 * PI) });
                push(Pattern::Stripes { k: dir.map(|x| freq * x), phase, duty: d.range(-0.4, 0.4) }, "stripes");
            }
            2 => {
                let axis = d.direction(-1.0);
                push(Pattern::Band { axis, at: d.range(-0.6, 0.6) * sz, half: sz * d.range(0.06, 0.15) }, "band");
            }
            _ => {
                let c = body.point(d.direction(-1.0));
                push(Pattern::Spot { c, r: sz * d.range(0.4, 0.7) }, "patch");
            }
        }
    }
    Paint { base, marks }
}

/// Paint of an ellipsoid part over its unit directions: a base, maybe an eye spot and a ring.
fn part_paint(d: &mut Draw, body_base: f64) -> impl Fn(P3) -> f64 {
    let base = d.contrast(body_base);
    let eye = d.chance(0.6).then(|| (d.direction(-0.5), d.range(0.25, 0.45), d.contrast(base)));
    let ring = d.chance(0.4).then(|| (d.range(-0.5, 0.5), d.contrast(base)));
    move |u: P3| {
        let mut a = base;
        if let Some((h, alb)) = ring {
            a = mix(a, alb, spot((u[2] - h).abs(), 0.12, 0.05));
        }
        if let Some((c, r, alb)) = eye {
            a = mix(a, alb, spot(dist(u, c), r, 0.06));
        }
        a
    }
}

/// Paint of a tube along its length t: a base with rings or a tip of another albedo.
fn tube_paint(d: &mut Draw, body_base: f64) -> impl Fn(f64) -> f64 {
    let base = d.contrast(body_base);
    let alb = d.contrast(base);
    let rings = d.chance(0.5);
    let (start, step) = (d.range(0.25, 0.4), d.range(0.15, 0.25));
    move |t: f64| {
        if rings {
            let mut w: f64 = 0.0;
            let mut c = start;
            while c < 0.95 {
                w = w.max(spot((t - c).abs(), 0.035, 0.02));
                c += step;
            }
            mix(base, alb, w)
        } else {
            mix(base, alb, smooth(0.75, 0.9, t))
        }
    }
}

/// A half-loop handle at the `side` (+1 or -1) x end of `body`, at height `zoff`, in the xz-plane.
fn end_handle(body: &Body, side: f64, zoff: f64, half_height: f64, reach: f64) -> impl Fn(f64) -> P3 {
    let s = body.point(normalise([side, 0.0, zoff], [side, 0.0, 0.0]));
    let cx = 0.75 * s[0];
    let hx = 0.25 * s[0].abs() + reach;
    move |t: f64| {
        let th = PI * (t - 0.5);
        [cx + side * hx * libm::cos(th), 0.0, s[2] + half_height * libm::sin(th)]
    }
}

fn asymmetric(d: &mut Draw, b: &mut Builder) -> String {
    let body = Body::draw(d, false);
    let paint = body_paint(d, &body, false);
    body.surface(b, &paint);
    let sz = body.size();
    let mut parts = Vec::new();
    for _ in 0..1 + d.index(3) {
        let kind = d.unit();
        if kind < 0.45 {
            let s = body.point(d.direction(-0.3));
            let r = [0; 3].map(|_| sz * d.range(0.25, 0.55));
            let rmin = r[0].min(r[1]).min(r[2]);
            let out = normalise(s, [0.0, 0.0, 1.0]);
            let c = [0, 1, 2].map(|k| s[k] + 0.5 * rmin * out[k]);
            let paint = part_paint(d, paint.base);
            b.ellipsoid(c, r, 20, |u, _| paint(u));
            parts.push("bump");
        } else if kind < 0.8 {
            // A horn: a curved, narrowing tube leaving the body outwards in an xz-plane.
            let a = d.range(-0.25 * PI, 1.25 * PI);
            let s = body.point(normalise([libm::cos(a), d.range(-0.4, 0.4), libm::sin(a)], [0.0, 0.0, 1.0]));
            let out = normalise([s[0], 0.0, s[2]], [0.0, 0.0, 1.0]);
            let (len, turn) = (sz * d.range(0.6, 1.1), d.range(-1.0, 1.0));
            let end = [out[0] * libm::cos(turn) - out[2] * libm::sin(turn), 0.0, out[2] * libm::cos(turn) + out[0] * libm::sin(turn)];
            let r0 = sz * d.range(0.12, 0.22);
            let r1 = r0 * d.range(0.3, 1.0);
            let p0 = [s[0] - 0.5 * r0 * out[0], s[1], s[2] - 0.5 * r0 * out[2]];
            let p1 = [s[0] + 0.55 * len * out[0], s[1], s[2] + 0.55 * len * out[2]];
            let p2 = [p1[0] + 0.5 * len * end[0], s[1], p1[2] + 0.5 * len * end[2]];
            let bez = move |t: f64| {
                let (a, m, c) = ((1.0 - t) * (1.0 - t), 2.0 * t * (1.0 - t), t * t);
                [0, 1, 2].map(|k| a * p0[k] + m * p1[k] + c * p2[k])
            };
            let paint = tube_paint(d, paint.base);
            b.tube(20, 24, bez, |t| mix(r0, r1, t), |_, t| paint(t));
            parts.push("horn");
        } else {
            let side = if d.chance(0.5) { 1.0 } else { -1.0 };
            let (zoff, hz, reach) = (d.range(-0.15, 0.25), body.axes[2] * d.range(0.3, 0.45), sz * d.range(0.2, 0.4));
            let path = end_handle(&body, side, zoff, hz, reach);
            let (rr, paint) = (hz * d.range(0.15, 0.25), tube_paint(d, paint.base));
            b.tube(14, 24, path, |_| rr, |_, t| paint(t));
            parts.push(if side > 0.0 { "front handle" } else { "back handle" });
        }
    }
    format!("asymmetric: {}; {}; parts: {}", body.describe(), paint.describe(), parts.join(", "))
}

fn front_back(d: &mut Draw, b: &mut Builder) -> String {
    let body = Body::draw(d, true);
    let mut paint = body_paint(d, &body, true);
    let sz = body.size();
    let [ax, _, az] = body.axes;
    // Where the parts meet the body, which the mark must keep clear of.
    let mut taken: Vec<P3> = Vec::new();
    let parts = match d.index(4) {
        0 => "no parts",
        1 => {
            let s = body.point(d.direction(-0.2));
            let out = normalise(s, [0.0, 0.0, 1.0]);
            let r = [0; 3].map(|_| sz * d.range(0.2, 0.4));
            let c = [0, 1, 2].map(|k| s[k] + 0.4 * r[0].min(r[1]).min(r[2]) * out[k]);
            let pp = part_paint(d, paint.base);
            taken.extend([c, half_turn(c)]);
            b.ellipsoid(c, r, 18, |u, _| pp(u));
            b.ellipsoid(half_turn(c), r, 18, |u, _| pp(half_turn(u)));
            "a pair of bumps"
        }
        2 => {
            // An arch over the top from end to end: its path is its own half-turn image.
            let (hx, z0) = (ax * d.range(0.35, 0.6), 0.3 * az);
            let hz = (az - z0) * d.range(1.3, 1.8);
            let (rr, tp) = (sz * d.range(0.06, 0.1), tube_paint(d, paint.base));
            let path = move |t: f64| [hx * libm::cos(PI * (1.0 - t)), 0.0, z0 + hz * libm::sin(PI * t)];
            taken.extend([path(0.0), path(1.0)]);
            // Paint symmetric in t, as the turn maps t to 1 - t.
            b.tube(14, 32, path, |_| rr, |_, t| tp(1.0 - 2.0 * (t - 0.5).abs()));
            "an arch"
        }
        _ => {
            let (zoff, hz, reach) = (d.range(-0.15, 0.25), az * d.range(0.3, 0.45), sz * d.range(0.2, 0.4));
            let (rr, tp) = (hz * d.range(0.15, 0.25), tube_paint(d, paint.base));
            for side in [1.0, -1.0] {
                let path = end_handle(&body, side, zoff, hz, reach);
                taken.extend([path(0.0), path(0.5), path(1.0)]);
                b.tube(14, 24, path, |_| rr, |_, t| tp(t));
            }
            "a pair of end handles"
        }
    };
    // The one mark that tells front from back, on the front half.
    // The best placed of a few candidates: the farthest from the parts.
    let clearance = |c: P3| taken.iter().map(|&t| dist(c, t)).fold(f64::INFINITY, f64::min);
    let candidates: Vec<P3> = (0..6).map(|_| body.point(normalise([1.0, d.range(-0.5, 0.5), d.range(-0.3, 0.6)], [1.0, 0.0, 0.0]))).collect();
    let c = candidates.into_iter().fold(None, |best: Option<P3>, c| match best {
        Some(b) if clearance(b) >= clearance(c) => Some(b),
        _ => Some(c),
    });
    let c = c.unwrap_or([body.axes[0], 0.0, 0.0]);
    let albedo = if paint.at(c) > 0.5 { 0.05 } else { 0.97 };
    let mark = if d.chance(0.7) {
        paint.marks.push(Mark { pattern: Pattern::Spot { c, r: ax * d.range(0.08, 0.12) }, albedo, twin: false, kind: "mark" });
        "a spot"
    } else {
        let k = sz * d.range(0.08, 0.12);
        let out = normalise(c, [1.0, 0.0, 0.0]);
        b.ellipsoid([0, 1, 2].map(|i| c[i] + 0.5 * k * out[i]), [k; 3], 10, |_, _| albedo);
        "a knob"
    };
    body.surface(b, &paint);
    format!("front-back: {}; {}; {parts}; front mark: {mark}", body.describe(), paint.describe())
}

fn revolution(d: &mut Draw, b: &mut Builder) -> String {
    let h = d.range(0.9, 1.6);
    let rb = d.range(0.3, 0.45);
    let (family, knots) = match d.index(3) {
        0 => (
            "vase",
            vec![(0.0, rb), (d.range(0.25, 0.45), rb * d.range(1.2, 1.6)), (d.range(0.65, 0.8), rb * d.range(0.5, 0.8)), (1.0, rb * d.range(0.7, 1.1))],
        ),
        1 => {
            let neck = rb * d.range(0.3, 0.5);
            ("bottle", vec![(0.0, rb), (d.range(0.4, 0.6), rb * d.range(0.95, 1.1)), (d.range(0.7, 0.8), neck), (1.0, neck * d.range(1.0, 1.25))])
        }
        _ => ("spindle", vec![(0.0, rb * d.range(0.2, 0.45)), (d.range(0.35, 0.65), rb * d.range(1.1, 1.4)), (1.0, rb * d.range(0.2, 0.45))]),
    };
    // Radius at height fraction t: cosine easing between knots (no overshoot).
    let radius = move |t: f64| {
        let t = t.clamp(0.0, 1.0);
        let i = knots.iter().rposition(|k| k.0 <= t).unwrap_or(0).min(knots.len() - 2);
        let ((t0, r0), (t1, r1)) = (knots[i], knots[i + 1]);
        mix(r0, r1, 0.5 - 0.5 * libm::cos(PI * (t - t0) / (t1 - t0)))
    };
    let base = d.range(0.45, 0.9);
    let bands: Vec<(f64, f64, f64)> = (0..2 + d.index(4)).map(|_| (h * d.range(0.05, 0.95), h * d.range(0.015, 0.06), d.contrast(base))).collect();
    let band_paint = |z: f64| bands.iter().fold(base, |a, &(zc, half, alb)| mix(a, alb, spot((z - zc).abs(), half, 0.4 * half)));
    // The feature: at longitude phi0 (degrees), height z0.
    let (phi0, z0) = (d.range(-180.0, 180.0), h * d.range(0.3, 0.7));
    let r0 = radius(z0 / h);
    let alb = d.contrast(band_paint(z0));
    let feature = d.index(4);
    let (fw, fh) = (rb * d.range(0.25, 0.5), h * d.range(0.06, 0.12));
    let side_paint = |phi: f64, z: f64| {
        let a = band_paint(z);
        let dphi = (phi - phi0 + 180.0).rem_euclid(360.0) - 180.0;
        let arc = dphi.to_radians() * r0;
        match feature {
            1 => mix(a, alb, spot(hypot(arc, z - z0), fw, 0.3 * fw)),
            3 => mix(a, alb, spot(arc.abs(), 1.5 * fw, 0.02) * spot((z - z0).abs(), fh, 0.02)),
            _ => a,
        }
    };
    b.surface(128, 64, true, |u, v| {
        let dir = sphere_dir(u, 0.5);
        let (z, r) = (h * v, radius(v));
        ([r * dir[0], r * dir[1], z], side_paint(longitude(dir[0], dir[1]), z))
    });
    let (bottom, top, cap) = (radius(0.0), radius(1.0), d.contrast(base));
    b.surface(64, 4, true, |u, v| {
        let dir = sphere_dir(u, 0.5);
        ([bottom * (1.0 - v) * dir[0], bottom * (1.0 - v) * dir[1], 0.0], base)
    });
    b.surface(64, 4, true, |u, v| {
        let dir = sphere_dir(u, 0.5);
        ([top * v * dir[0], top * v * dir[1], h], cap)
    });
    let what = match feature {
        0 => {
            let k = rb * d.range(0.15, 0.25);
            let (s, c) = (libm::sin(phi0.to_radians()), libm::cos(phi0.to_radians()));
            b.ellipsoid([(r0 + 0.4 * k) * c, (r0 + 0.4 * k) * s, z0], [k; 3], 12, |_, _| alb);
            format!("a knob at {phi0:.0} deg")
        }
        1 => format!("a spot at {phi0:.0} deg"),
        2 => {
            let side = if phi0.abs() < 90.0 { 1.0 } else { -1.0 };
            let hz = h * d.range(0.12, 0.2);
            let cx = 0.92 * radius((z0 - hz) / h).min(r0).min(radius((z0 + hz) / h));
            let hx = rb * d.range(0.35, 0.6) + r0 - cx;
            let rr = hz * d.range(0.15, 0.25);
            let path = move |t: f64| {
                let th = PI * (t - 0.5);
                [side * (cx + hx * libm::cos(th)), 0.0, z0 + hz * libm::sin(th)]
            };
            b.tube(14, 20, path, |_| rr, |_, _| alb);
            format!("a short handle at {} deg", if side > 0.0 { 0 } else { 180 })
        }
        _ => format!("a label at {phi0:.0} deg"),
    };
    format!("revolution: {family} {:.2} high, {} bands; feature: {what}", h, bands.len())
}

mod paint;
#[cfg(test)]
mod tests;
