//! The z-buffered triangle rasteriser and the per-sample shading.
//!
//! Rendering is deferred: a first pass finds, for every sample, the nearest triangle and the
//! sample's barycentric coordinates in it; a second pass shades only the visible samples. A pixel
//! is the mean of its `ss x ss` samples (supersampling against jagged silhouettes).
//!
//! Every per-sample computation uses only + - * / and sqrt on f64, which IEEE 754 rounds exactly,
//! in a fixed order: the image is the same, bit for bit, on every machine.

use super::mesh::{dot, normalise};

/// What shading needs of a vertex: world normal, albedo and which side of it the camera is on.
#[derive(Debug, Clone, Copy, Default)]
pub(crate) struct Projected {
    pub normal: [f64; 3],
    pub albedo: f64,
    /// Dot product of the normal with the direction to the camera.
    pub facing: f64,
}

/// Per-sample shading constants, all in world coordinates.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Shading {
    /// Unit direction towards the light.
    pub light: [f64; 3],
    /// Unit half vector between the light and the camera direction.
    pub half: [f64; 3],
    pub ambient: f64,
    pub diffuse: f64,
    pub specular: f64,
    pub shininess: u32,
    /// The brightness of a sample no surface covers.
    pub background: f64,
}

const EMPTY: u32 = u32::MAX;

/// Where [`Samples::resolve`] puts an image: its pixels, what stands behind the object (8-bit,
/// one per pixel; the shading's uniform level when none) and, when wanted, how many of each
/// pixel's samples the object covers.
pub(crate) struct Target<'a> {
    pub out: &'a mut [u8],
    pub backdrop: Option<&'a [u8]>,
    pub coverage: Option<&'a mut [u8]>,
}

/// Reusable sample buffers of one image.
#[derive(Debug, Default)]
pub(crate) struct Samples {
    width: usize,
    height: usize,
    depth: Vec<f64>,
    tri: Vec<u32>,
    b1: Vec<f64>,
    b2: Vec<f64>,
}

impl Samples {
    /// Clears the buffers for a `width x height` sample grid.
    pub(super) fn reset(&mut self, width: usize, height: usize) {
        let n = width * height;
        self.width = width;
        self.height = height;
        self.depth.clear();
        self.depth.resize(n, f64::NEG_INFINITY);
        self.tri.clear();
        self.tri.resize(n, EMPTY);
        self.b1.resize(n, 0.0);
        self.b2.resize(n, 0.0);
    }

    /// Draws the triangles, keeping the nearest at each sample. `xyd` holds each vertex's
    /// sample-grid position and depth (larger is nearer). Samples lie at the centres of the
    /// grid's cells, (i + 0.5, j + 0.5); a sample on an edge belongs to the first triangle drawn
    /// there (triangles are drawn in order, so ties are settled the same way every time).
    pub(super) fn draw(&mut self, xyd: &[[f64; 3]], triangles: &[[u32; 3]]) {
        let (w, h) = (self.width as i64, self.height as i64);
        for (t, tri) in triangles.iter().enumerate() {
            let [p0, p1, p2] = tri.map(|i| xyd[i as usize]);
            // Sample columns i with xmin <= i + 0.5 <= xmax, clipped to the grid.
            let i0 = ceil(p0[0].min(p1[0]).min(p2[0]) - 0.5).max(0);
            let i1 = floor(p0[0].max(p1[0]).max(p2[0]) - 0.5).min(w - 1);
            let j0 = ceil(p0[1].min(p1[1]).min(p2[1]) - 0.5).max(0);
            let j1 = floor(p0[1].max(p1[1]).max(p2[1]) - 0.5).min(h - 1);
            if i0 > i1 || j0 > j1 {
                continue;
            }
            let area = (p1[0] - p0[0]) * (p2[1] - p0[1]) - (p2[0] - p0[0]) * (p1[1] - p0[1]);
            if area == 0.0 || !area.is_finite() {
                continue;
            }
            let sign = if area > 0.0 { 1.0 } else { -1.0 };
            let inv = 1.0 / area;
            let (d0, d10, d20) = (p0[2], p1[2] - p0[2], p2[2] - p0[2]);
            // Edge functions, twice the signed areas of the sub-triangles opposite each vertex:
            // e = a * (py - y) - b * (px - x), with the py term computed once per row.
            let (a0, b0) = (p2[0] - p1[0], p2[1] - p1[1]);
            let (a1, b1) = (p0[0] - p2[0], p0[1] - p2[1]);
            let (a2, b2) = (p1[0] - p0[0], p1[1] - p0[1]);
            for j in j0 as usize..=j1 as usize {
                let py = j as f64 + 0.5;
                let (r0, r1, r2) = (a0 * (py - p1[1]), a1 * (py - p2[1]), a2 * (py - p0[1]));
                let row = j * self.width;
                for i in i0 as usize..=i1 as usize {
                    let px = i as f64 + 0.5;
                    let e0 = r0 - b0 * (px - p1[0]);
                    let e1 = r1 - b1 * (px - p2[0]);
                    let e2 = r2 - b2 * (px - p0[0]);
                    if e0 * sign < 0.0 || e1 * sign < 0.0 || e2 * sign < 0.0 {
                        continue;
                    }
                    let (w1, w2) = (e1 * inv, e2 * inv);
                    let depth = d0 + w1 * d10 + w2 * d20;
                    let k = row + i;
                    if depth > self.depth[k] {
                        self.depth[k] = depth;
                        self.tri[k] = t as u32;
                        self.b1[k] = w1;
                        self.b2[k] = w2;
                    }
                }
            }
        }
    }

    /// Shades the visible samples and averages each `ss x ss` block into one 8-bit pixel of
    /// `target.out` (row-major, `width / ss` by `height / ss`); a sample no surface covers is
    /// the backdrop's pixel when there is one, else the shading's background level.
    pub(super) fn resolve(&self, verts: &[Projected], triangles: &[[u32; 3]], shading: &Shading, ss: usize, target: Target<'_>) {
        let (pw, ph) = (self.width / ss, self.height / ss);
        let Target { out, backdrop, mut coverage } = target;
        debug_assert_eq!(out.len(), pw * ph);
        let norm = (ss * ss) as f64;
        for py in 0..ph {
            for px in 0..pw {
                let background = backdrop.map_or(shading.background, |b| b[py * pw + px] as f64 / 255.0);
                let mut sum = 0.0;
                let mut covered = 0u8;
                for sy in 0..ss {
                    let row = (py * ss + sy) * self.width + px * ss;
                    for sx in 0..ss {
                        let k = row + sx;
                        let t = self.tri[k];
                        sum += match t {
                            EMPTY => background,
                            t => {
                                covered += 1;
                                shade(verts, triangles[t as usize], self.b1[k], self.b2[k], shading)
                            }
                        };
                    }
                }
                out[py * pw + px] = quantise(sum / norm);
                if let Some(c) = coverage.as_deref_mut() {
                    c[py * pw + px] = covered;
                }
            }
        }
    }
}

/// Brightness in [0, 1] of the surface point with barycentric coordinates (1 - b1 - b2, b1, b2).
fn shade(verts: &[Projected], tri: [u32; 3], b1: f64, b2: f64, s: &Shading) -> f64 {
    let [v0, v1, v2] = tri.map(|i| &verts[i as usize]);
    let b0 = 1.0 - b1 - b2;
    let lerp = |a: f64, b: f64, c: f64| b0 * a + b1 * b + b2 * c;
    let albedo = lerp(v0.albedo, v1.albedo, v2.albedo);
    let mut n = normalise([
        lerp(v0.normal[0], v1.normal[0], v2.normal[0]),
        lerp(v0.normal[1], v1.normal[1], v2.normal[1]),
        lerp(v0.normal[2], v1.normal[2], v2.normal[2]),
    ]);
    // Two-sided lighting: seen from behind (an open mesh's inside, a cap's brim from below) a
    // surface is lit as if its normal pointed at the camera.
    if lerp(v0.facing, v1.facing, v2.facing) < 0.0 {
        n = [-n[0], -n[1], -n[2]];
    }
    let mut value = albedo * (s.ambient + s.diffuse * dot(n, s.light).max(0.0));
    if s.specular > 0.0 {
        value += s.specular * powi(dot(n, s.half).max(0.0), s.shininess);
    }
    value
}

/// `x^k` by repeated squaring: a fixed sequence of multiplications (std's powi may differ
/// between platforms).
fn powi(mut x: f64, mut k: u32) -> f64 {
    let mut r = 1.0;
    while k > 0 {
        if k & 1 == 1 {
            r *= x;
        }
        x *= x;
        k >>= 1;
    }
    r
}

/// Largest integer <= x, saturating (NaN gives 0); exact, without the libm call that `f64::floor`
/// becomes on baseline x86-64.
fn floor(x: f64) -> i64 {
    let t = x as i64;
    if (t as f64) > x {
        t - 1
    } else {
        t
    }
}

/// Smallest integer >= x, saturating (NaN gives 0).
fn ceil(x: f64) -> i64 {
    let t = x as i64;
    if (t as f64) < x {
        t + 1
    } else {
        t
    }
}

/// [0, 1] to 0..=255, rounding half up.
fn quantise(v: f64) -> u8 {
    floor(v * 255.0 + 0.5).clamp(0, 255) as u8
}

#[cfg(test)]
mod tests {
    use super::*;

    const V: Projected = Projected { normal: [0.0, 0.0, 1.0], albedo: 1.0, facing: 1.0 };
    const FLAT: Shading = Shading { light: [0.0, 0.0, 1.0], half: [0.0, 0.0, 1.0], ambient: 0.0, diffuse: 1.0, specular: 0.0, shininess: 1, background: 0.0 };

    #[test]
    fn a_square_of_two_triangles_covers_its_samples_once() {
        let xyd = [[1.0, 1.0, 0.0], [5.0, 1.0, 0.0], [5.0, 5.0, 0.0], [1.0, 5.0, 0.0]];
        let tris = [[0, 1, 2], [0, 2, 3]];
        let mut s = Samples::default();
        s.reset(8, 8);
        s.draw(&xyd, &tris);
        let mut out = vec![0u8; 64];
        s.resolve(&[V; 4], &tris, &FLAT, 1, Target { out: &mut out, backdrop: None, coverage: None });
        let lit: Vec<usize> = (0..64).filter(|&k| out[k] == 255).collect();
        assert_eq!(lit.len(), 16, "{out:?}");
        assert!(lit.iter().all(|&k| (1..5).contains(&(k % 8)) && (1..5).contains(&(k / 8))));
        assert_eq!(out.iter().filter(|&&v| v != 0 && v != 255).count(), 0);
    }

    #[test]
    fn the_nearer_triangle_wins_whatever_the_order() {
        let xyd = [[0.0, 0.0, 1.0], [4.0, 0.0, 1.0], [0.0, 4.0, 1.0], [0.0, 0.0, -1.0], [4.0, 0.0, -1.0], [0.0, 4.0, -1.0]];
        let verts = [Projected { albedo: 0.5, ..V }, Projected { albedo: 0.5, ..V }, Projected { albedo: 0.5, ..V }, V, V, V];
        for tris in [[[0, 1, 2], [3, 4, 5]], [[3, 4, 5], [0, 1, 2]]] {
            let mut s = Samples::default();
            s.reset(4, 4);
            s.draw(&xyd, &tris);
            let mut out = vec![0u8; 16];
            s.resolve(&verts, &tris, &FLAT, 1, Target { out: &mut out, backdrop: None, coverage: None });
            assert_eq!(out[0], 128);
        }
    }

    #[test]
    fn integer_floor_and_ceil_match_std() {
        for x in [-2.5, -2.0, -0.3, -0.0, 0.0, 0.3, 1.0, 1.5, 1e15 + 0.5, -1e15 - 0.5] {
            assert_eq!(floor(x), x.floor() as i64, "{x}");
            assert_eq!(ceil(x), x.ceil() as i64, "{x}");
        }
    }

    #[test]
    fn powi_matches_repeated_multiplication() {
        assert_eq!(powi(0.9, 0), 1.0);
        assert_eq!(powi(0.5, 5), 0.03125);
        assert!((powi(0.9, 32) - 0.9f64.powf(32.0)).abs() < 1e-15);
    }
}
