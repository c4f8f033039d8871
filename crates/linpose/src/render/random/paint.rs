//! Markings painted in object space: spots, stripes and bands of another albedo over a base,
//! each optionally paired with its image under the half turn about the vertical axis.

use super::super::objects::{dist, mix, smooth, spot, P3};

fn dot(a: P3, b: P3) -> f64 {
    a[0] * b[0] + a[1] * b[1] + a[2] * b[2]
}

pub(super) fn normalise(v: P3, fallback: P3) -> P3 {
    let l = dot(v, v).sqrt();
    if l > 1e-9 {
        v.map(|x| x / l)
    } else {
        fallback
    }
}

/// The half turn about the vertical axis.
pub(super) fn half_turn(p: P3) -> P3 {
    [-p[0], -p[1], p[2]]
}

/// A marking's footprint: its weight in [0, 1] at a point.
#[derive(Debug, Clone, Copy)]
pub(super) enum Pattern {
    Spot { c: P3, r: f64 },
    Stripes { k: P3, phase: f64, duty: f64 },
    Band { axis: P3, at: f64, half: f64 },
}

impl Pattern {
    fn weight(&self, p: P3) -> f64 {
        match *self {
            Pattern::Spot { c, r } => spot(dist(p, c), r, 0.3 * r),
            Pattern::Stripes { k, phase, duty } => smooth(duty - 0.2, duty + 0.2, libm::sin(dot(k, p) + phase)),
            Pattern::Band { axis, at, half } => spot((dot(axis, p) - at).abs(), half, 0.3 * half),
        }
    }
}

/// A marking: where (with its half-turn image too when `twin`) and its albedo.
pub(super) struct Mark {
    pub(super) pattern: Pattern,
    pub(super) albedo: f64,
    pub(super) twin: bool,
    pub(super) kind: &'static str,
}

/// A base albedo with markings painted over it in order.
pub(super) struct Paint {
    pub(super) base: f64,
    pub(super) marks: Vec<Mark>,
}

impl Paint {
    pub(super) fn at(&self, p: P3) -> f64 {
        let mut a = self.base;
        for m in &self.marks {
            let w = m.pattern.weight(p);
            // max(w(p), w(Rp)) is unchanged by p -> Rp: the marking is symmetric.
            let w = if m.twin { w.max(m.pattern.weight(half_turn(p))) } else { w };
            a = mix(a, m.albedo, w);
        }
        a
    }

    pub(super) fn describe(&self) -> String {
        let mut kinds: Vec<(&str, usize)> = Vec::new();
        for m in &self.marks {
            match kinds.iter_mut().find(|k| k.0 == m.kind) {
                Some(k) => k.1 += 1,
                None => kinds.push((m.kind, 1)),
            }
        }
        let words: Vec<String> = kinds.iter().map(|&(k, n)| if n == 1 { k.to_string() } else { format!("{n} {k}s") }).collect();
        words.join(", ")
    }
}
