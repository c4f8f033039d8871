//! Data set manifests: which images a data set has and their poses, before any pixel is read.
//!
//! Two layouts are understood:
//! - the directory format: `DIR/poses.csv` with header `image,<param>,...` (degrees), the images
//!   beside it (paths relative to DIR), and an optional `DIR/dataset.toml` giving each parameter's
//!   period (`azimuth = { period = 360 }`, or `name = { linear = true }`); without it a parameter
//!   named `azimuth` has period 360 and every other one is linear;
//! - the COIL layout: a folder of `objO__K.png` files, read one object at a time. COIL-20 numbers
//!   its 72 views 0..71 (5 degrees apart); COIL-100 names them by degree (0..355). When any view
//!   number of the object exceeds 71 the numbers are degrees, otherwise views 5 degrees apart.

use crate::pose::{Param, PoseSpace};
use crate::{Error, Result};
use std::collections::{HashMap, HashSet};
use std::path::{Component, Path, PathBuf};

/// Largest manifest accepted, in rows.
pub const MAX_ROWS: usize = 10_000_000;

/// The images of a data set and their poses.
#[derive(Debug, Clone)]
pub struct Manifest {
    root: PathBuf,
    space: PoseSpace,
    images: Vec<String>,
    poses: Vec<f64>,
}

impl Manifest {
    /// Builds a manifest from parts, checking that every pose is finite and has one value per
    /// parameter.
    pub fn new(root: impl Into<PathBuf>, space: PoseSpace, images: Vec<String>, poses: Vec<f64>) -> Result<Self> {
        let root = root.into();
        if images.is_empty() {
            return Err(Error::Dataset { path: root, message: "the data set is empty: no images".into() });
        }
        if poses.len() != images.len() * space.len() {
            return Err(Error::Dataset {
                path: root,
                message: format!("{} images but {} pose values for {} parameters", images.len(), poses.len(), space.len()),
            });
        }
        if let Some(i) = poses.iter().position(|v| !v.is_finite()) {
            return Err(Error::Dataset { path: root, message: format!("pose of {} is not finite: {}", images[i / space.len()], poses[i]) });
        }
        Ok(Manifest { root, space, images, poses })
    }

    /// Opens a data set folder: the directory format when `DIR/poses.csv` exists, otherwise the
    /// COIL layout for `object` (which must then be given).
    pub fn open(dir: &Path, object: Option<u32>) -> Result<Self> {
        if !dir.is_dir() {
            return Err(Error::Dataset { path: dir.to_path_buf(), message: if dir.exists() { "not a folder".into() } else { "no such folder".into() } });
        }
        let csv = dir.join("poses.csv");
        match object {
            Some(o) => Self::coil(dir, o),
            None if csv.is_file() => Self::read_dir_format(dir),
            None => Err(Error::Dataset {
                path: dir.to_path_buf(),
                message: "no poses.csv in this folder; for a COIL folder (objO__K.png files) give --object O".into(),
            }),
        }
    }

    /// Reads `DIR/poses.csv` and the optional `DIR/dataset.toml`.
    pub fn read_dir_format(dir: &Path) -> Result<Self> {
        let csv_path = dir.join("poses.csv");
        let text = std::fs::read(&csv_path).map_err(|e| Error::io(&csv_path, e))?;
        let text = String::from_utf8(text).map_err(|e| {
            let line = 1 + e.as_bytes()[..e.utf8_error().valid_up_to()].iter().filter(|&&b| b == b'\n').count();
            Error::parse(&csv_path, line, "not valid UTF-8")
        })?;
        let (names, images, poses) = parse_poses_csv(&csv_path, &text)?;
        let toml_path = dir.join("dataset.toml");
        let periods = if toml_path.exists() {
            let t = std::fs::read_to_string(&toml_path).map_err(|e| Error::io(&toml_path, e))?;
            parse_dataset_toml(&toml_path, &t, &names)?
        } else {
            HashMap::new()
        };
        let params = names
            .iter()
            .map(|n| match periods.get(n) {
                Some(&Some(t)) => Param::circular(n.clone(), t),
                Some(None) => Param::linear(n.clone()),
                None => Param::with_default_period(n.clone()),
            })
            .collect();
        let space = PoseSpace::new(params).map_err(|e| Error::parse(&csv_path, 1, e.to_string()))?;
        for img in &images {
            check_relative(&csv_path, img)?;
        }
        Self::new(dir, space, images, poses)
    }

    /// Reads one object of a COIL folder (`objO__K.png`); other files are ignored.
    pub fn coil(dir: &Path, object: u32) -> Result<Self> {
        let prefix = format!("obj{object}__");
        let rd = std::fs::read_dir(dir).map_err(|e| Error::io(dir, e))?;
        let mut views: Vec<(u32, String)> = Vec::new();
        for entry in rd {
            let entry = entry.map_err(|e| Error::io(dir, e))?;
            let name = entry.file_name();
            let Some(name) = name.to_str() else { continue };
            let Some(rest) = name.strip_prefix(&prefix) else { continue };
            let Some(num) = rest.strip_suffix(".png") else { continue };
            if num.is_empty() || !num.bytes().all(|b| b.is_ascii_digit()) {
                continue;
            }
            let Ok(k) = num.parse::<u32>() else { continue };
            views.push((k, name.to_string()));
        }
        if views.is_empty() {
            return Err(Error::Dataset { path: dir.to_path_buf(), message: format!("no COIL images of object {object} (files named {prefix}K.png)") });
        }
        views.sort();
        if let Some(w) = views.windows(2).find(|w| w[0].0 == w[1].0) {
            return Err(Error::Dataset { path: dir.to_path_buf(), message: format!("view {} of object {object} appears twice", w[0].0) });
        }
        let by_degree = views.iter().any(|(k, _)| *k > 71);
        if by_degree {
            if let Some((k, n)) = views.iter().find(|(k, _)| *k >= 360) {
                return Err(Error::Dataset { path: dir.join(n), message: format!("COIL view angle {k} is not below 360 degrees") });
            }
        }
        let poses = views.iter().map(|(k, _)| if by_degree { *k as f64 } else { 5.0 * *k as f64 }).collect();
        let images = views.into_iter().map(|(_, n)| n).collect();
        let space = PoseSpace::new(vec![Param::circular("azimuth", 360.0)])?;
        Self::new(dir, space, images, poses)
    }

    /// The folder image paths are relative to.
    pub fn root(&self) -> &Path {
        &self.root
    }

    /// The pose parameters.
    pub fn space(&self) -> &PoseSpace {
        &self.space
    }

    /// Number of samples.
    pub fn len(&self) -> usize {
        self.images.len()
    }

    /// Whether there are no samples (never true for a manifest that was built).
    pub fn is_empty(&self) -> bool {
        self.images.is_empty()
    }

    /// Image paths as written in the manifest, relative to [`root`](Self::root).
    pub fn images(&self) -> &[String] {
        &self.images
    }

    /// The full path of sample `i`'s image.
    pub fn image_path(&self, i: usize) -> PathBuf {
        self.root.join(&self.images[i])
    }

    /// All poses, one row of [`PoseSpace::len`] values per sample.
    pub fn poses(&self) -> &[f64] {
        &self.poses
    }

    /// The pose of sample `i`.
    pub fn pose(&self, i: usize) -> &[f64] {
        let p = self.space.len();
        &self.poses[i * p..(i + 1) * p]
    }

    /// Which samples are in the training set.
    pub fn training_mask(&self, sel: &TrainSelection) -> Result<Vec<bool>> {
        let mask: Vec<bool> = match sel {
            TrainSelection::All => vec![true; self.len()],
            TrainSelection::Step(s) => {
                if !(s.is_finite() && *s > 0.0) {
                    return Err(Error::invalid("train step", s, "must be a positive number of degrees"));
                }
                let p = self.space.len();
                let lo: Vec<f64> = (0..p).map(|j| (0..self.len()).map(|i| self.poses[i * p + j]).fold(f64::INFINITY, f64::min)).collect();
                (0..self.len()).map(|i| self.pose(i).iter().zip(&lo).all(|(&v, &l)| is_multiple(v - l, *s))).collect()
            }
            TrainSelection::Names(names) => {
                let have: HashSet<&str> = self.images.iter().map(|s| s.as_str()).collect();
                if let Some(missing) = names.iter().find(|n| !have.contains(n.as_str())) {
                    return Err(Error::Dataset { path: self.root.clone(), message: format!("training list names '{missing}', which is not in the data set") });
                }
                let set: HashSet<&str> = names.iter().map(|s| s.as_str()).collect();
                self.images.iter().map(|n| set.contains(n.as_str())).collect()
            }
        };
        if !mask.iter().any(|&b| b) {
            return Err(Error::Dataset { path: self.root.clone(), message: format!("the training selection ({sel}) picks no sample") });
        }
        Ok(mask)
    }

    /// The manifest restricted to the samples where `mask` is true.
    pub fn subset(&self, mask: &[bool]) -> Result<Self> {
        let mut images = Vec::new();
        let mut poses = Vec::new();
        for (i, _) in mask.iter().enumerate().filter(|(_, &m)| m) {
            images.push(self.images[i].clone());
            poses.extend_from_slice(self.pose(i));
        }
        Self::new(self.root.clone(), self.space.clone(), images, poses)
    }
}

/// Which samples of a data set form the training set.
#[derive(Debug, Clone, PartialEq)]
pub enum TrainSelection {
    /// Every sample.
    All,
    /// docs/method.md: a sample is in the training set when every parameter minus that parameter's
    /// smallest value in the data set is a multiple of the step (degrees).
    Step(f64),
    /// The samples whose image paths are listed.
    Names(Vec<String>),
}

impl std::fmt::Display for TrainSelection {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            TrainSelection::All => write!(f, "all samples"),
            TrainSelection::Step(s) => write!(f, "every {s} degrees"),
            TrainSelection::Names(n) => write!(f, "a list of {} images", n.len()),
        }
    }
}

impl TrainSelection {
    /// Reads a training list: one image path per line, blank lines and `#` comments ignored.
    pub fn read_list(path: &Path) -> Result<Self> {
        let t = std::fs::read_to_string(path).map_err(|e| Error::io(path, e))?;
        let names: Vec<String> = t.lines().map(str::trim).filter(|l| !l.is_empty() && !l.starts_with('#')).map(String::from).collect();
        if names.is_empty() {
            return Err(Error::parse(path, 0, "the training list names no image"));
        }
        Ok(TrainSelection::Names(names))
    }
}

/// Whether `v` (>= 0) is a multiple of `s` within a relative tolerance (numpy's isclose spirit).
fn is_multiple(v: f64, s: f64) -> bool {
    let r = v.rem_euclid(s);
    let tol = 1e-6 * s.max(1.0);
    r <= tol || s - r <= tol
}

fn check_relative(csv: &Path, img: &str) -> Result<()> {
    let p = Path::new(img);
    let escapes = p.is_absolute() || p.components().any(|c| matches!(c, Component::ParentDir | Component::RootDir | Component::Prefix(_)));
    if escapes {
        return Err(Error::Dataset {
            path: csv.to_path_buf(),
            message: format!("image path '{img}' leaves the data folder; paths must be relative and stay inside it"),
        });
    }
    Ok(())
}

/// Parses the text of a poses.csv: the parameter names, the image paths, the poses (row-major).
/// Public for the fuzz target only.
#[doc(hidden)]
pub fn parse_poses_csv(path: &Path, text: &str) -> Result<(Vec<String>, Vec<String>, Vec<f64>)> {
    let mut rdr = csv::ReaderBuilder::new().has_headers(false).flexible(true).trim(csv::Trim::All).from_reader(text.as_bytes());
    let mut records = rdr.records();
    let header = match records.next() {
        None => return Err(Error::parse(path, 1, "empty file: expected a header 'image,<param>,...'")),
        Some(r) => r.map_err(|e| Error::parse(path, 1, e.to_string()))?,
    };
    if header.get(0) != Some("image") {
        return Err(Error::parse(path, 1, format!("the header must start with 'image', found '{}'", header.get(0).unwrap_or(""))));
    }
    let names: Vec<String> = header.iter().skip(1).map(String::from).collect();
    if names.is_empty() {
        return Err(Error::parse(path, 1, "the header names no pose parameter after 'image'"));
    }
    if let Some(n) = names.iter().find(|n| n.is_empty()) {
        return Err(Error::parse(path, 1, format!("empty parameter name in the header ('{n}')")));
    }
    let mut seen_names = HashSet::new();
    for n in &names {
        if !seen_names.insert(n) {
            return Err(Error::parse(path, 1, format!("parameter '{n}' appears twice in the header")));
        }
    }
    let mut images = Vec::new();
    let mut poses = Vec::new();
    let mut seen: HashMap<String, usize> = HashMap::new();
    for rec in records {
        let rec = rec.map_err(|e| {
            let line = e.position().map(|p| p.line() as usize).unwrap_or(0);
            Error::parse(path, line, e.to_string())
        })?;
        let line = rec.position().map(|p| p.line() as usize).unwrap_or(0);
        if rec.len() == 1 && rec.get(0) == Some("") {
            continue; // blank line
        }
        if rec.len() != names.len() + 1 {
            return Err(Error::parse(
                path,
                line,
                format!("{} fields, but the header has {} (image plus {} parameters)", rec.len(), names.len() + 1, names.len()),
            ));
        }
        let img = rec.get(0).unwrap_or("");
        if img.is_empty() {
            return Err(Error::parse(path, line, "empty image path"));
        }
        if let Some(prev) = seen.insert(img.to_string(), line) {
            return Err(Error::parse(path, line, format!("image '{img}' is listed twice (also on line {prev})")));
        }
        for (name, v) in names.iter().zip(rec.iter().skip(1)) {
            if v.is_empty() {
                return Err(Error::parse(path, line, format!("missing value for '{name}' of '{img}'")));
            }
            let x: f64 = v.parse().map_err(|_| Error::parse(path, line, format!("'{name}' of '{img}' is not a number: '{v}'")))?;
            if !x.is_finite() {
                return Err(Error::parse(path, line, format!("'{name}' of '{img}' is not finite: '{v}'")));
            }
            poses.push(x);
        }
        images.push(img.to_string());
        if images.len() > MAX_ROWS {
            return Err(Error::parse(path, line, format!("more than {MAX_ROWS} rows")));
        }
    }
    if images.is_empty() {
        return Err(Error::Dataset { path: path.to_path_buf(), message: "the data set is empty: no rows after the header".into() });
    }
    Ok((names, images, poses))
}

/// Parses a dataset.toml: for each parameter named there, `Some(period)` or `None` (linear).
/// Public for the fuzz target only.
#[doc(hidden)]
pub fn parse_dataset_toml(path: &Path, text: &str, names: &[String]) -> Result<HashMap<String, Option<f64>>> {
    let table: toml::Table = text.parse().map_err(|e: toml::de::Error| {
        let line = e.span().map(|s| text[..s.start].matches('\n').count() + 1).unwrap_or(0);
        Error::parse(path, line, e.message().to_string())
    })?;
    let line_of = |key: &str| text.lines().position(|l| l.trim_start().starts_with(key)).map(|i| i + 1).unwrap_or(0);
    let mut out = HashMap::new();
    for (key, value) in &table {
        let line = line_of(key);
        if !names.iter().any(|n| n == key) {
            return Err(Error::parse(path, line, format!("'{key}' is not a parameter of poses.csv (it has: {})", names.join(", "))));
        }
        let Some(t) = value.as_table() else {
            return Err(Error::parse(path, line, format!("'{key}' must be a table such as {{ period = 360 }}")));
        };
        let mut period = None;
        let mut linear = false;
        for (k, v) in t {
            match k.as_str() {
                "period" => {
                    let p = v.as_float().or_else(|| v.as_integer().map(|i| i as f64));
                    match p {
                        Some(p) if p.is_finite() && p > 0.0 => period = Some(p),
                        _ => return Err(Error::parse(path, line, format!("period of '{key}' must be a positive number of degrees, found {v}"))),
                    }
                }
                "linear" => match v.as_bool() {
                    Some(b) => linear = b,
                    None => return Err(Error::parse(path, line, format!("'linear' of '{key}' must be true or false, found {v}"))),
                },
                other => return Err(Error::parse(path, line, format!("unknown key '{other}' for '{key}' (known: period, linear)"))),
            }
        }
        match (period, linear) {
            (Some(_), true) => return Err(Error::parse(path, line, format!("'{key}' cannot have a period and be linear"))),
            (Some(p), false) => out.insert(key.clone(), Some(p)),
            (None, true) => out.insert(key.clone(), None),
            (None, false) => return Err(Error::parse(path, line, format!("'{key}' needs period = <degrees> or linear = true"))),
        };
    }
    Ok(out)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn p() -> &'static Path {
        Path::new("poses.csv")
    }

    #[test]
    fn parses_a_manifest() {
        let (n, i, v) = parse_poses_csv(p(), "image,elevation,azimuth\na.png,32,0\nb.png,35,3.5\n").unwrap();
        assert_eq!(n, ["elevation", "azimuth"]);
        assert_eq!(i, ["a.png", "b.png"]);
        assert_eq!(v, [32.0, 0.0, 35.0, 3.5]);
    }

    #[test]
    fn manifest_errors_name_the_line() {
        let e = parse_poses_csv(p(), "image,azimuth\na.png,1\nb.png,x\n").unwrap_err().to_string();
        assert!(e.contains(":3:") && e.contains("not a number"), "{e}");
        let e = parse_poses_csv(p(), "image,azimuth\na.png,\n").unwrap_err().to_string();
        assert!(e.contains(":2:") && e.contains("missing value"), "{e}");
        let e = parse_poses_csv(p(), "image,azimuth\na.png,1\na.png,2\n").unwrap_err().to_string();
        assert!(e.contains("listed twice"), "{e}");
        let e = parse_poses_csv(p(), "file,azimuth\n").unwrap_err().to_string();
        assert!(e.contains("must start with 'image'"), "{e}");
        let e = parse_poses_csv(p(), "image,azimuth\n").unwrap_err().to_string();
        assert!(e.contains("empty"), "{e}");
        let e = parse_poses_csv(p(), "image,azimuth\na.png,nan\n").unwrap_err().to_string();
        assert!(e.contains("not finite"), "{e}");
        let e = parse_poses_csv(p(), "image,azimuth\na.png,1,2\n").unwrap_err().to_string();
        assert!(e.contains("3 fields"), "{e}");
    }

    #[test]
    fn dataset_toml_periods() {
        let names = vec!["azimuth".to_string(), "tilt".to_string()];
        let m = parse_dataset_toml(Path::new("d.toml"), "tilt = { period = 180 }\nazimuth = { linear = true }\n", &names).unwrap();
        assert_eq!(m["tilt"], Some(180.0));
        assert_eq!(m["azimuth"], None);
        for bad in ["tilt = { period = 0 }", "tilt = { period = -5 }", "tilt = { perod = 5 }", "roll = { period = 5 }", "tilt = 5", "tilt = {"] {
            assert!(parse_dataset_toml(Path::new("d.toml"), bad, &names).is_err(), "{bad}");
        }
    }

    #[test]
    fn train_step_selects_the_paper_subset() {
        let space = PoseSpace::new(vec![Param::linear("elevation"), Param::circular("azimuth", 360.0)]).unwrap();
        let mut images = Vec::new();
        let mut poses = Vec::new();
        for a in (32..=77).step_by(3) {
            for e in (0..=327).step_by(3) {
                images.push(format!("{a}_{e}.png"));
                poses.extend([a as f64, e as f64]);
            }
        }
        let m = Manifest::new("d", space, images, poses).unwrap();
        let mask = m.training_mask(&TrainSelection::Step(9.0)).unwrap();
        assert_eq!(m.len(), 1760);
        assert_eq!(mask.iter().filter(|&&b| b).count(), 222);
    }

    #[test]
    fn escaping_paths_are_refused() {
        assert!(check_relative(p(), "../x.png").is_err());
        assert!(check_relative(p(), "/etc/passwd").is_err());
        assert!(check_relative(p(), "sub/x.png").is_ok());
    }
}
