//! Pose grids: `START:STOP:STEP` in degrees, as the turntable and the arm step through them.
//!
//! Values are computed in exact decimal arithmetic: with d the most decimals written in START or
//! STEP, every value is the integer start*10^d + i*step*10^d divided by 10^d, i.e. the double
//! nearest the decimal value. `0:1:0.1` gives 0.3, not 0.30000000000000004, and each value
//! printed with `{}` reads back as the same double.

use crate::{Error, Result};
use std::fmt;

/// Most points one grid axis may have.
pub const MAX_POINTS: usize = 1_000_000;
/// Most decimals a grid value may have.
pub const MAX_DECIMALS: u32 = 6;
/// Largest absolute value in a grid, degrees.
pub const MAX_ABS: f64 = 1e6;

/// An arithmetic sequence of angles: START, START + STEP, ..., up to STOP inclusive.
#[derive(Debug, Clone, PartialEq)]
pub struct Grid {
    start: i64,
    step: i64,
    count: usize,
    decimals: u32,
}

impl Grid {
    /// The paper's azimuths: 0, 3, ..., 327 (110 values).
    pub fn paper_azimuth() -> Self {
        Grid { start: 0, step: 3, count: 110, decimals: 0 }
    }

    /// The paper's elevations: 32, 35, ..., 77 (16 values).
    pub fn paper_elevation() -> Self {
        Grid { start: 32, step: 3, count: 16, decimals: 0 }
    }

    /// Parses `START:STOP:STEP` (or a single value) for the parameter `name` (used in errors).
    pub fn parse(name: &'static str, spec: &str) -> Result<Self> {
        let parts: Vec<&str> = spec.split(':').map(str::trim).collect();
        let bad = |reason: String| Error::invalid(name, spec, reason);
        let (start, stop, step) = match parts.as_slice() {
            [v] => (*v, *v, "1"),
            [a, b, c] => (*a, *b, *c),
            _ => return Err(bad("expected START:STOP:STEP in degrees, e.g. 0:327:3, or a single value".into())),
        };
        let (start, d0) = decimal(start).map_err(|r| bad(format!("START {r}")))?;
        let (stop, d1) = decimal(stop).map_err(|r| bad(format!("STOP {r}")))?;
        let (step, d2) = decimal(step).map_err(|r| bad(format!("STEP {r}")))?;
        if step <= 0.0 {
            return Err(bad(format!("STEP must be positive, got {step}")));
        }
        if stop < start {
            return Err(bad(format!("STOP ({stop}) is less than START ({start})")));
        }
        let decimals = d0.max(d1).max(d2);
        let scale = 10f64.powi(decimals as i32);
        let (s, e, t) = ((start * scale).round() as i64, (stop * scale).round() as i64, (step * scale).round() as i64);
        let count = ((e - s) / t) as u64 + 1;
        if count > MAX_POINTS as u64 {
            return Err(bad(format!("{count} points; at most {MAX_POINTS} are allowed")));
        }
        Ok(Grid { start: s, step: t, count: count as usize, decimals })
    }

    /// Number of values.
    pub fn len(&self) -> usize {
        self.count
    }

    /// Whether the grid has no value (never, for a parsed grid).
    pub fn is_empty(&self) -> bool {
        self.count == 0
    }

    /// Decimals of the grid's values (0 for whole degrees).
    pub fn decimals(&self) -> u32 {
        self.decimals
    }

    /// The `i`-th value, degrees.
    pub fn value(&self, i: usize) -> f64 {
        let scale = 10f64.powi(self.decimals as i32);
        (self.start + i as i64 * self.step) as f64 / scale
    }

    /// All values, degrees.
    pub fn values(&self) -> Vec<f64> {
        (0..self.count).map(|i| self.value(i)).collect()
    }

    /// Whether the grid goes round a whole turn: one more step after its last value would reach
    /// 360 degrees past its first (`0:354:6`, `0:350:10`; not `-30:30:10`, nor a single value).
    pub(crate) fn covers_turn(&self) -> bool {
        self.count as i128 * self.step as i128 >= 360 * 10i128.pow(self.decimals)
    }
}

impl fmt::Display for Grid {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let last = self.value(self.count.saturating_sub(1));
        let scale = 10f64.powi(self.decimals as i32);
        write!(f, "{}:{}:{}", self.value(0), last, self.step as f64 / scale)
    }
}

/// A plain decimal number and its count of decimals.
fn decimal(s: &str) -> std::result::Result<(f64, u32), String> {
    let digits = s.strip_prefix(['-', '+']).unwrap_or(s);
    let (int, frac) = digits.split_once('.').unwrap_or((digits, ""));
    let plain = !(int.is_empty() && frac.is_empty()) && int.bytes().all(|b| b.is_ascii_digit()) && frac.bytes().all(|b| b.is_ascii_digit());
    if !plain {
        return Err(format!("'{s}' is not a number of degrees in plain decimal notation (e.g. 32 or 2.5)"));
    }
    let v: f64 = s.parse().map_err(|_| format!("'{s}' is not a number"))?;
    if frac.len() as u32 > MAX_DECIMALS {
        return Err(format!("'{s}' has more than {MAX_DECIMALS} decimals"));
    }
    if !(v.abs() <= MAX_ABS) {
        return Err(format!("'{s}' is beyond +-{MAX_ABS} degrees"));
    }
    Ok((v, frac.len() as u32))
}

#[cfg(test)]
mod tests {
    use super::*;

    fn err(spec: &str) -> String {
        Grid::parse("azimuth", spec).unwrap_err().to_string()
    }

    #[test]
    fn the_papers_grids_make_1760_poses() {
        let (a, e) = (Grid::parse("azimuth", "0:327:3").unwrap(), Grid::parse("elevation", "32:77:3").unwrap());
        assert_eq!((a.len(), e.len()), (110, 16));
        assert_eq!(a, Grid::paper_azimuth());
        assert_eq!(e, Grid::paper_elevation());
        assert_eq!(a.values()[109], 327.0);
        assert_eq!(e.values(), (0..16).map(|i| 32.0 + 3.0 * i as f64).collect::<Vec<_>>());
        assert_eq!(a.to_string(), "0:327:3");
    }

    #[test]
    fn fractional_steps_are_exact_decimals() {
        let g = Grid::parse("azimuth", "0:1:0.1").unwrap();
        assert_eq!(g.len(), 11);
        assert_eq!(g.value(3), 0.3);
        for v in g.values() {
            assert_eq!(v.to_string().parse::<f64>().unwrap(), v);
        }
        let g = Grid::parse("elevation", "-10.5:10:2.25").unwrap();
        assert_eq!((g.len(), g.value(1), g.decimals()), (10, -8.25, 2));
        assert_eq!(Grid::parse("elevation", "45").unwrap().values(), vec![45.0]);
        // STOP need not be on the grid: the last value is the last one not past it.
        assert_eq!(Grid::parse("azimuth", "0:10:3").unwrap().values(), vec![0.0, 3.0, 6.0, 9.0]);
    }

    #[test]
    fn a_grid_covers_a_turn_when_one_more_step_closes_it() {
        let covers = |spec: &str| Grid::parse("roll", spec).unwrap().covers_turn();
        for spec in ["0:354:6", "0:350:10", "0:359:1", "0:359.9:0.1", "-180:179.5:0.5", "0:720:10"] {
            assert!(covers(spec), "{spec}");
        }
        for spec in ["-30:30:10", "0:349:10", "0:359.8:0.1", "90", "0:180:10"] {
            assert!(!covers(spec), "{spec}");
        }
    }

    #[test]
    fn bad_specs_name_the_problem() {
        assert!(err("0:10:0").contains("STEP must be positive"), "{}", err("0:10:0"));
        assert!(err("0:10:-1").contains("STEP must be positive"));
        assert!(err("10:0:1").contains("less than START"));
        assert!(err("nan:10:1").contains("plain decimal"));
        assert!(err("0:inf:1").contains("plain decimal"));
        assert!(err("0:1e3:1").contains("plain decimal"));
        assert!(err("0:10").contains("START:STOP:STEP"));
        assert!(err("0:100000:0.01").contains("at most"));
        assert!(err("0:1:0.0000001").contains("decimals"));
        assert!(err("0:1e300:1").contains("plain decimal"));
        assert!(err("0:9999999:1").contains("beyond"));
        assert!(err("").contains("plain decimal"));
        assert!(err("x:1:1").starts_with("invalid azimuth = x:1:1"), "{}", err("x:1:1"));
    }
}
