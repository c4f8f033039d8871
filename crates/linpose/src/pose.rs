//! Pose parameters: names, periods, the (cos, sin) encoding of circular parameters (paper Eq. 5)
//! and the pose error measure (docs/method.md).

use crate::{Error, Result};
use serde::{Deserialize, Serialize};

/// Most pose parameters a data set or model may have.
pub(crate) const MAX_PARAMS: usize = 8;

/// One pose parameter, in degrees.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct Param {
    /// Its name (`azimuth`, `elevation`, ...).
    pub name: String,
    /// Its period in degrees when it is circular (360 for a turntable angle), `None` when linear.
    pub period: Option<f64>,
}

impl Param {
    /// A linear parameter.
    pub fn linear(name: impl Into<String>) -> Self {
        Param { name: name.into(), period: None }
    }

    /// A circular parameter with the given period in degrees.
    pub fn circular(name: impl Into<String>, period: f64) -> Self {
        Param { name: name.into(), period: Some(period) }
    }

    /// The default for a parameter that no `dataset.toml` describes: `azimuth` is circular with
    /// period 360, everything else linear.
    pub fn with_default_period(name: impl Into<String>) -> Self {
        let name = name.into();
        if name == "azimuth" {
            Param::circular(name, 360.0)
        } else {
            Param::linear(name)
        }
    }
}

/// The ordered list of pose parameters of a data set or a model.
#[derive(Debug, Clone, PartialEq, Serialize, Deserialize)]
pub struct PoseSpace {
    params: Vec<Param>,
}

impl PoseSpace {
    /// A pose space; names must be distinct and periods positive and finite.
    pub fn new(params: Vec<Param>) -> Result<Self> {
        if params.is_empty() {
            return Err(Error::invalid("pose parameters", "[]", "at least one parameter is needed"));
        }
        if params.len() > MAX_PARAMS {
            return Err(Error::invalid("pose parameters", params.len(), format!("at most {MAX_PARAMS} are supported")));
        }
        for (i, p) in params.iter().enumerate() {
            if p.name.is_empty() {
                return Err(Error::invalid("pose parameter name", "\"\"", "names must not be empty"));
            }
            if params[..i].iter().any(|q| q.name == p.name) {
                return Err(Error::invalid("pose parameter name", &p.name, "appears twice"));
            }
            if let Some(t) = p.period {
                if !(t.is_finite() && t > 0.0) {
                    return Err(Error::invalid("period", t, format!("period of '{}' must be a positive number of degrees", p.name)));
                }
            }
        }
        Ok(PoseSpace { params })
    }

    /// The parameters in order.
    pub fn params(&self) -> &[Param] {
        &self.params
    }

    /// Number of parameters (values per pose).
    pub fn len(&self) -> usize {
        self.params.len()
    }

    /// Always false: a pose space has at least one parameter.
    pub fn is_empty(&self) -> bool {
        self.params.is_empty()
    }

    /// Index of the parameter called `name`.
    pub fn index_of(&self, name: &str) -> Option<usize> {
        self.params.iter().position(|p| p.name == name)
    }

    /// Number of encoded values K: one per linear parameter, two (cos, sin) per circular one.
    pub fn encoded_len(&self) -> usize {
        self.params.iter().map(|p| if p.period.is_some() { 2 } else { 1 }).sum()
    }

    /// Encodes a pose (degrees) into `out` (length [`encoded_len`](Self::encoded_len)), Eq. 5:
    /// a circular parameter e of period T becomes (cos 2 pi e / T, sin 2 pi e / T).
    pub fn encode(&self, pose: &[f64], out: &mut [f64]) {
        debug_assert_eq!(pose.len(), self.len());
        let mut k = 0;
        for (p, &v) in self.params.iter().zip(pose) {
            match p.period {
                Some(t) => {
                    let r = v * std::f64::consts::TAU / t;
                    out[k] = r.cos();
                    out[k + 1] = r.sin();
                    k += 2;
                }
                None => {
                    out[k] = v;
                    k += 1;
                }
            }
        }
    }

    /// The first encoded column of each circular parameter's (cos, sin) pair, in
    /// [`encode`](Self::encode)'s layout.
    pub(crate) fn pair_columns(&self) -> Vec<usize> {
        let mut k = 0;
        let mut out = Vec::new();
        for p in &self.params {
            if p.period.is_some() {
                out.push(k);
                k += 2;
            } else {
                k += 1;
            }
        }
        out
    }

    /// Decodes an encoded estimate into a pose (degrees) by atan2; the (cos, sin) pair need not
    /// have unit length. Circular values land in [0, period).
    pub fn decode(&self, enc: &[f64], out: &mut [f64]) {
        let mut k = 0;
        for (p, o) in self.params.iter().zip(out.iter_mut()) {
            match p.period {
                Some(t) => {
                    let r = enc[k + 1].atan2(enc[k]);
                    *o = wrap_positive(r * t / std::f64::consts::TAU, t);
                    k += 2;
                }
                None => {
                    *o = enc[k];
                    k += 1;
                }
            }
        }
    }

    /// The parameters that place the camera around the object, by name: a linear `elevation`, an
    /// `azimuth` of period 360 and, when present, a `roll` (linear, or of period 360).
    fn geometry(&self) -> Geometry {
        let (Some(ie), Some(ia)) = (self.index_of("elevation"), self.index_of("azimuth")) else { return Geometry::None };
        if self.params[ia].period != Some(360.0) || self.params[ie].period.is_some() {
            return Geometry::None;
        }
        match self.index_of("roll") {
            Some(ir) if matches!(self.params[ir].period, None | Some(360.0)) => Geometry::Rotation(ie, ia, ir),
            Some(_) => Geometry::None,
            None => Geometry::Sphere(ie, ia),
        }
    }

    /// The index of the parameter that turns the image in its plane: a `roll` beside
    /// `elevation` and `azimuth` (the camera turned about its optical axis, which the error
    /// measures as a rotation), else None.
    pub(crate) fn in_plane_roll(&self) -> Option<usize> {
        match self.geometry() {
            Geometry::Rotation(_, _, ir) => Some(ir),
            _ => None,
        }
    }

    /// The pose error (docs/method.md), in degrees:
    /// - with `elevation`, `azimuth` and `roll`: the angle of the rotation that takes the camera's
    ///   true orientation to its estimated one (the geodesic distance on SO(3));
    /// - with `elevation` and `azimuth` (the paper's case): the angle between the two viewing
    ///   directions on the sphere;
    /// - otherwise the largest difference over parameters, wrapped for circular ones (so a lone
    ///   circular parameter gives its wrapped difference).
    ///
    /// In the first two cases the other parameters (a light's azimuth, say) are not part of it:
    /// each has its own difference ([`PoseSpace::param_errors_deg`]).
    pub fn error_deg(&self, truth: &[f64], est: &[f64]) -> f64 {
        match self.geometry() {
            Geometry::Rotation(ie, ia, ir) => rotation_angle_deg([truth[ie], truth[ia], truth[ir]], [est[ie], est[ia], est[ir]]),
            Geometry::Sphere(ie, ia) => sphere_angle_deg(truth[ie], truth[ia], est[ie], est[ia]),
            Geometry::None => self.param_errors(truth, est).fold(0.0, f64::max),
        }
    }

    /// Each parameter's own error in degrees, in order: the absolute difference, wrapped into
    /// [0, T / 2] for a circular parameter of period T.
    pub fn param_errors_deg(&self, truth: &[f64], est: &[f64]) -> Vec<f64> {
        self.param_errors(truth, est).collect()
    }

    /// [`PoseSpace::param_errors_deg`] as an iterator.
    pub(crate) fn param_errors<'a>(&'a self, truth: &'a [f64], est: &'a [f64]) -> impl Iterator<Item = f64> + 'a {
        self.params.iter().zip(truth.iter().zip(est)).map(|(p, (&a, &b))| match p.period {
            Some(t) => wrapped_diff(a, b, t),
            None => (a - b).abs(),
        })
    }

    /// Whether two poses coincide (circular parameters compared modulo their period), within
    /// `tol` degrees.
    pub fn same_pose(&self, a: &[f64], b: &[f64], tol: f64) -> bool {
        self.params.iter().zip(a.iter().zip(b)).all(|(p, (&x, &y))| match p.period {
            Some(t) => wrapped_diff(x, y, t) <= tol,
            None => (x - y).abs() <= tol,
        })
    }
}

/// `v` reduced into [0, period).
pub(crate) fn wrap_positive(v: f64, period: f64) -> f64 {
    let r = v.rem_euclid(period);
    // rem_euclid can return `period` itself for tiny negative inputs through rounding.
    if r >= period {
        0.0
    } else {
        r
    }
}

/// The shortest distance between `a` and `b` on a circle of circumference `period`, in [0, period/2].
pub(crate) fn wrapped_diff(a: f64, b: f64, period: f64) -> f64 {
    let d = (a - b).rem_euclid(period);
    d.min(period - d)
}

/// Angle in degrees between the viewing directions u = (cos a cos e, cos a sin e, sin a) of two
/// (elevation a, azimuth e) pairs.
pub(crate) fn sphere_angle_deg(elev1: f64, azim1: f64, elev2: f64, azim2: f64) -> f64 {
    let u = |a: f64, e: f64| {
        let (a, e) = (a.to_radians(), e.to_radians());
        [a.cos() * e.cos(), a.cos() * e.sin(), a.sin()]
    };
    let (p, q) = (u(elev1, azim1), u(elev2, azim2));
    // atan2(|p x q|, p.q) is accurate for tiny angles, where acos loses half the digits.
    let cross = [p[1] * q[2] - p[2] * q[1], p[2] * q[0] - p[0] * q[2], p[0] * q[1] - p[1] * q[0]];
    let s = (cross[0] * cross[0] + cross[1] * cross[1] + cross[2] * cross[2]).sqrt();
    let c = p[0] * q[0] + p[1] * q[1] + p[2] * q[2];
    s.atan2(c).to_degrees()
}

/// Which of a pose space's parameters place the camera ([`PoseSpace::error_deg`]): indices of
/// elevation, azimuth and roll.
enum Geometry {
    Rotation(usize, usize, usize),
    Sphere(usize, usize),
    None,
}

/// The camera's orientation in the object's frame (rows: the image's right, the image's up, the
/// direction towards the camera) at (elevation, azimuth, roll), as the renderer (`crate::render`)
/// places it: the turntable turns the object by Rz(-azimuth), the camera at the elevation sees
/// right = y, up = (-sin a, 0, cos a), towards it (cos a, 0, sin a), and the roll turns the
/// camera about its optical axis (a positive roll turns the image counter-clockwise).
fn camera_rotation(elevation: f64, azimuth: f64, roll: f64) -> [[f64; 3]; 3] {
    let (se, ce) = elevation.to_radians().sin_cos();
    let (sa, ca) = azimuth.to_radians().sin_cos();
    let (sr, cr) = roll.to_radians().sin_cos();
    // Turntable, object to world: rows (ca, sa, 0), (-sa, ca, 0), (0, 0, 1).
    let turn = [[ca, sa, 0.0], [-sa, ca, 0.0], [0.0, 0.0, 1.0]];
    let view = [[0.0, 1.0, 0.0], [-se, 0.0, ce], [ce, 0.0, se]];
    // A positive roll turns the image counter-clockwise (the camera's axes clockwise).
    let roll = [[cr, -sr, 0.0], [sr, cr, 0.0], [0.0, 0.0, 1.0]];
    mat_mul(&roll, &mat_mul(&view, &turn))
}

fn mat_mul(a: &[[f64; 3]; 3], b: &[[f64; 3]; 3]) -> [[f64; 3]; 3] {
    let mut out = [[0.0; 3]; 3];
    for (i, row) in out.iter_mut().enumerate() {
        for (j, v) in row.iter_mut().enumerate() {
            *v = (0..3).map(|k| a[i][k] * b[k][j]).sum();
        }
    }
    out
}

/// The angle in degrees of the rotation between the camera orientations of two (elevation,
/// azimuth, roll) poses: for D = R1 R2^T, atan2(|axis part|, (trace(D) - 1) / 2), where the axis
/// part is half the skew-symmetric part's vector (sin of the angle times the axis), accurate for
/// small angles where acos((trace - 1) / 2) loses half the digits.
pub(crate) fn rotation_angle_deg(a: [f64; 3], b: [f64; 3]) -> f64 {
    let (r1, r2) = (camera_rotation(a[0], a[1], a[2]), camera_rotation(b[0], b[1], b[2]));
    let d = |i: usize, j: usize| (0..3).map(|k| r1[i][k] * r2[j][k]).sum::<f64>();
    let v = [d(2, 1) - d(1, 2), d(0, 2) - d(2, 0), d(1, 0) - d(0, 1)];
    let s = 0.5 * (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
    let c = 0.5 * (d(0, 0) + d(1, 1) + d(2, 2) - 1.0);
    s.atan2(c).to_degrees()
}

/// Summary statistics of a set of errors (degrees).
#[derive(Debug, Clone, Copy, PartialEq, Serialize, Deserialize)]
pub struct ErrorSummary {
    /// Number of samples.
    pub n: usize,
    /// Mean error.
    pub mean_deg: f64,
    /// Median error.
    pub median_deg: f64,
    /// 90th percentile (linear interpolation, as numpy's default).
    pub p90_deg: f64,
    /// Largest error.
    pub max_deg: f64,
}

impl ErrorSummary {
    /// Summarises `errors`; `None` when there are none.
    pub fn of(errors: &[f64]) -> Option<Self> {
        if errors.is_empty() {
            return None;
        }
        let mut s = errors.to_vec();
        s.sort_by(f64::total_cmp);
        let n = s.len();
        Some(ErrorSummary {
            n,
            mean_deg: s.iter().sum::<f64>() / n as f64,
            median_deg: percentile_sorted(&s, 50.0),
            p90_deg: percentile_sorted(&s, 90.0),
            max_deg: s[n - 1],
        })
    }
}

/// Percentile `q` (0..=100) of sorted data with linear interpolation (numpy's default method).
pub(crate) fn percentile_sorted(sorted: &[f64], q: f64) -> f64 {
    let n = sorted.len();
    if n == 1 {
        return sorted[0];
    }
    let pos = q / 100.0 * (n - 1) as f64;
    let lo = pos.floor() as usize;
    let hi = (lo + 1).min(n - 1);
    let f = pos - lo as f64;
    sorted[lo] + (sorted[hi] - sorted[lo]) * f
}

#[cfg(test)]
mod tests {
    use super::*;
    use approx::assert_abs_diff_eq;
    use proptest::prelude::*;

    fn paper_space() -> PoseSpace {
        PoseSpace::new(vec![Param::linear("elevation"), Param::circular("azimuth", 360.0)]).unwrap()
    }

    #[test]
    fn percentiles_match_numpy() {
        // numpy.percentile([1,2,3,4,10], [50, 90]) = [3.0, 7.6]
        let s = [1.0, 2.0, 3.0, 4.0, 10.0];
        assert_eq!(percentile_sorted(&s, 50.0), 3.0);
        assert!((percentile_sorted(&s, 90.0) - 7.6).abs() < 1e-12);
    }

    #[test]
    fn sphere_angle_on_known_cases() {
        assert!((sphere_angle_deg(0.0, 0.0, 0.0, 90.0) - 90.0).abs() < 1e-12);
        assert!((sphere_angle_deg(0.0, 10.0, 90.0, 200.0) - 90.0).abs() < 1e-12);
        // At the pole azimuth does not matter.
        assert!(sphere_angle_deg(90.0, 0.0, 90.0, 123.0) < 1e-6);
        assert!((sphere_angle_deg(0.0, 359.0, 0.0, 1.0) - 2.0).abs() < 1e-9);
    }

    fn rotation_space(extra: &[Param]) -> PoseSpace {
        let mut p = vec![Param::linear("elevation"), Param::circular("azimuth", 360.0), Param::linear("roll")];
        p.extend(extra.iter().cloned());
        PoseSpace::new(p).unwrap()
    }

    #[test]
    fn rotation_error_identities() {
        let s = rotation_space(&[]);
        // A pure roll of 10 degrees is 10 degrees, at any elevation and azimuth.
        for (e, a) in [(0.0, 0.0), (32.0, 354.0), (77.0, 123.0), (-45.0, 10.0)] {
            assert_abs_diff_eq!(s.error_deg(&[e, a, -30.0], &[e, a, -20.0]), 10.0, epsilon = 1e-9);
            // A turntable turn of 10 degrees is 10 degrees at any elevation and roll (the
            // viewing directions' angle shrinks with cos(elevation); the rotation's does not).
            for r in [-30.0, 0.0, 20.0] {
                assert_abs_diff_eq!(s.error_deg(&[e, a, r], &[e, a + 10.0, r]), 10.0, epsilon = 1e-9);
                assert_abs_diff_eq!(s.error_deg(&[e, a, r], &[e, a + 350.0, r]), 10.0, epsilon = 1e-9);
            }
            // An elevation change at roll 0 is the viewing directions' angle.
            assert_abs_diff_eq!(s.error_deg(&[e, a, 0.0], &[e + 9.0, a, 0.0]), 9.0, epsilon = 1e-9);
        }
        // Small angles keep their digits; a pose is 0 from itself.
        assert_abs_diff_eq!(s.error_deg(&[40.0, 50.0, 5.0], &[40.0, 50.0, 5.0 + 1e-7]), 1e-7, epsilon = 1e-13);
        assert_eq!(s.error_deg(&[40.0, 50.0, 5.0], &[40.0, 50.0, 5.0]), 0.0);
        // Half a turn of the turntable is 180 degrees.
        assert_abs_diff_eq!(s.error_deg(&[40.0, 0.0, 0.0], &[40.0, 180.0, 0.0]), 180.0, epsilon = 1e-9);
        // Seen from straight above, a turntable turn (the image clockwise) and a roll (the image
        // counter-clockwise) turn the image about the same axis: 10 degrees more of each is the
        // same view (tests/render.rs checks this on rendered images).
        assert_abs_diff_eq!(s.error_deg(&[90.0, 10.0, 0.0], &[90.0, 20.0, 10.0]), 0.0, epsilon = 1e-9);
        assert_abs_diff_eq!(s.error_deg(&[90.0, 10.0, 0.0], &[90.0, 20.0, -10.0]), 20.0, epsilon = 1e-9);
    }

    #[test]
    fn light_is_apart_from_the_rotation_error() {
        let s = rotation_space(&[Param::circular("light", 360.0)]);
        let (t, e) = ([40.0, 50.0, 0.0, 350.0], [40.0, 50.0, 10.0, 20.0]);
        assert_abs_diff_eq!(s.error_deg(&t, &e), 10.0, epsilon = 1e-9);
        assert_eq!(s.param_errors_deg(&t, &e), vec![0.0, 0.0, 10.0, 30.0]);
        // The paper's two angles with a light: the viewing directions' angle, the light apart.
        let s = PoseSpace::new(vec![Param::linear("elevation"), Param::circular("azimuth", 360.0), Param::circular("light", 360.0)]).unwrap();
        assert_abs_diff_eq!(s.error_deg(&[0.0, 0.0, 0.0], &[0.0, 10.0, 90.0]), 10.0, epsilon = 1e-9);
    }

    #[test]
    fn lone_circular_error_wraps() {
        let s = PoseSpace::new(vec![Param::circular("azimuth", 360.0)]).unwrap();
        assert!((s.error_deg(&[355.0], &[5.0]) - 10.0).abs() < 1e-12);
        assert!((s.error_deg(&[0.0], &[180.0]) - 180.0).abs() < 1e-12);
    }

    #[test]
    fn invalid_spaces_are_refused() {
        assert!(PoseSpace::new(vec![]).is_err());
        assert!(PoseSpace::new(vec![Param::linear("a"), Param::linear("a")]).is_err());
        assert!(PoseSpace::new(vec![Param::circular("a", 0.0)]).is_err());
        assert!(PoseSpace::new(vec![Param::circular("a", f64::NAN)]).is_err());
    }

    proptest! {
        #[test]
        fn encode_decode_round_trip(e in -1000.0f64..1000.0, a in -90.0f64..90.0, scale in 0.1f64..10.0) {
            let s = paper_space();
            let mut enc = [0.0; 3];
            s.encode(&[a, e], &mut enc);
            // The decoded pair need not have unit length: scaling (cos, sin) changes nothing.
            enc[1] *= scale;
            enc[2] *= scale;
            let mut dec = [0.0; 2];
            s.decode(&enc, &mut dec);
            prop_assert!((dec[0] - a).abs() < 1e-9);
            prop_assert!((0.0..360.0).contains(&dec[1]));
            prop_assert!(wrapped_diff(dec[1], e, 360.0) < 1e-9);
        }

        #[test]
        fn rotation_error_is_symmetric_and_a_metric(e1 in -90.0f64..90.0, a1 in 0.0f64..360.0, r1 in -60.0f64..60.0, e2 in -90.0f64..90.0, a2 in 0.0f64..360.0, r2 in -60.0f64..60.0, e3 in -90.0f64..90.0, a3 in 0.0f64..360.0, r3 in -60.0f64..60.0) {
            let s = rotation_space(&[]);
            let (p, q, w) = ([e1, a1, r1], [e2, a2, r2], [e3, a3, r3]);
            let d = s.error_deg(&p, &q);
            prop_assert!((d - s.error_deg(&q, &p)).abs() < 1e-9);
            prop_assert!((0.0..=180.0 + 1e-9).contains(&d));
            prop_assert!(d <= s.error_deg(&p, &w) + s.error_deg(&w, &q) + 1e-9);
            // Never more than the sum of the parameters' own differences.
            prop_assert!(d <= s.param_errors_deg(&p, &q).iter().sum::<f64>() + 1e-9);
        }

        #[test]
        fn circular_error_is_period_invariant(a in -720.0f64..720.0, b in -720.0f64..720.0, k in -3i32..3) {
            let s = PoseSpace::new(vec![Param::circular("azimuth", 360.0)]).unwrap();
            let e1 = s.error_deg(&[a], &[b]);
            let e2 = s.error_deg(&[a + 360.0 * k as f64], &[b]);
            prop_assert!((e1 - e2).abs() < 1e-9);
            prop_assert!((0.0..=180.0).contains(&e1));
            prop_assert!((e1 - s.error_deg(&[b], &[a])).abs() < 1e-9);
        }

        #[test]
        fn sphere_error_is_a_metric_angle(a1 in -89.0f64..89.0, e1 in 0.0f64..360.0, a2 in -89.0f64..89.0, e2 in 0.0f64..360.0) {
            let s = paper_space();
            let d = s.error_deg(&[a1, e1], &[a2, e2]);
            prop_assert!((0.0..=180.0 + 1e-9).contains(&d));
            prop_assert!((d - s.error_deg(&[a2, e2 + 360.0], &[a1, e1])).abs() < 1e-7);
            prop_assert!(s.error_deg(&[a1, e1], &[a1, e1 - 360.0]) < 1e-6);
            // Never larger than the sum of the elevation and azimuth changes.
            prop_assert!(d <= (a1 - a2).abs() + wrapped_diff(e1, e2, 360.0) + 1e-7);
        }

        #[test]
        fn wrap_positive_stays_in_range(v in -1e6f64..1e6, t in 1.0f64..720.0) {
            let w = wrap_positive(v, t);
            prop_assert!(w >= 0.0 && w < t);
        }
    }
}
