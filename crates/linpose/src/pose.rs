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

    /// Whether this is the paper's two-angle case: exactly `elevation` and a circular `azimuth`.
    fn sphere_indices(&self) -> Option<(usize, usize)> {
        if self.len() != 2 {
            return None;
        }
        let ie = self.index_of("elevation")?;
        let ia = self.index_of("azimuth")?;
        (self.params[ia].period == Some(360.0) && self.params[ie].period.is_none()).then_some((ie, ia))
    }

    /// The pose error (docs/method.md), in degrees: for (elevation, azimuth) the angle between the two
    /// viewing directions on the sphere; otherwise the largest difference over parameters, wrapped
    /// for circular ones (so a lone circular parameter gives its wrapped difference).
    pub fn error_deg(&self, truth: &[f64], est: &[f64]) -> f64 {
        if let Some((ie, ia)) = self.sphere_indices() {
            return sphere_angle_deg(truth[ie], truth[ia], est[ie], est[ia]);
        }
        self.params
            .iter()
            .zip(truth.iter().zip(est))
            .map(|(p, (&a, &b))| match p.period {
                Some(t) => wrapped_diff(a, b, t),
                None => (a - b).abs(),
            })
            .fold(0.0, f64::max)
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
