//! Data set manifests: which images a data set has and their poses, before any pixel is read.
//!
//! Two layouts are understood:
//! - the directory format: `DIR/poses.csv` with header `image,<param>,...` (degrees), the images
//!   beside it (paths relative to DIR), and an optional `DIR/dataset.toml` giving each parameter's
//!   period (`azimuth = { period = 360 }`, or `name = { linear = true }`); without it a parameter
//!   named `azimuth` has period 360 and every other one is linear. A column named `object` (after
//!   `image`) says which object each image shows: a manifest holds one object, so such a file is
//!   read here only when it names a single object; the data set of several objects is a
//!   [`Catalog`](crate::Catalog);
//! - the COIL layout: a folder of `objO__K.png` files, read one object at a time. COIL-20 numbers
//!   its 72 views 0..71 (5 degrees apart); COIL-100 names them by degree (0..355). When any view
//!   number of the object exceeds 71 the numbers are degrees, otherwise views 5 degrees apart.

use crate::image_io::{ColorMode, ImageSpec};
use crate::pose::{Param, PoseSpace};
use crate::{Error, Result};
use std::collections::{HashMap, HashSet};
use std::path::{Component, Path, PathBuf};

/// Largest manifest accepted, in rows.
pub(crate) const MAX_ROWS: usize = 10_000_000;

/// The images of a data set and their poses.
#[derive(Debug, Clone)]
pub struct Manifest {
    root: PathBuf,
    space: PoseSpace,
    images: Vec<String>,
    poses: Vec<f64>,
}

impl Manifest {
    /// The size of the first image, read from its header (no pixel is decoded), with `color`:
    /// what the memory plan ([`crate::memory::Job::for_manifest`]) needs before the images are
    /// read.
    pub fn first_image_spec(&self, color: ColorMode) -> Result<ImageSpec> {
        let path = self.image_path(0);
        let bytes = std::fs::read(&path).map_err(|e| Error::io(&path, e))?;
        let (width, height) = crate::image_io::dimensions(&path, &bytes)?;
        Ok(ImageSpec { width, height, color })
    }

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

    /// Reads `DIR/poses.csv` and the optional `DIR/dataset.toml`. A poses.csv with an `object`
    /// column is read only when it names one object (the column is then dropped); one naming
    /// several is refused: it is a [`Catalog`](crate::Catalog) ([`Catalog::open`](crate::Catalog::open),
    /// [`Source::open`](crate::Source::open)).
    pub fn read_dir_format(dir: &Path) -> Result<Self> {
        let (csv_path, table) = read_poses_table(dir)?;
        one_object(&csv_path, &table)?;
        let space = read_pose_space(dir, &csv_path, &table.names)?;
        Self::new(dir, space, table.images, table.poses)
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
        let mask = self.selection_mask(sel)?;
        if !mask.iter().any(|&b| b) {
            return Err(Error::Dataset { path: self.root.clone(), message: format!("the training selection ({sel}) picks no sample") });
        }
        Ok(mask)
    }

    /// The samples `sel` picks, which may be none; a bad step or a listed image not in the
    /// manifest is an error.
    pub(crate) fn selection_mask(&self, sel: &TrainSelection) -> Result<Vec<bool>> {
        Ok(match sel {
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
        })
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

/// The header of the column that names each image's object.
pub(crate) const OBJECT_COLUMN: &str = "object";

/// A poses.csv as read: its pose parameters, images and poses, and each image's object when it
/// has an [`OBJECT_COLUMN`]. Public for the fuzz target only.
#[doc(hidden)]
#[derive(Debug, Clone, PartialEq)]
pub struct PosesTable {
    /// The pose parameters' names, in header order (without the object column).
    pub names: Vec<String>,
    /// The image paths, as written.
    pub images: Vec<String>,
    /// The poses, one row of `names.len()` values per image.
    pub poses: Vec<f64>,
    /// Each image's object (never empty) when the header has an object column.
    pub objects: Option<Vec<String>>,
}

impl PosesTable {
    /// The distinct objects, in order of first appearance (empty without an object column).
    pub fn object_names(&self) -> Vec<&str> {
        let mut seen = HashSet::new();
        self.objects.iter().flatten().map(String::as_str).filter(|o| seen.insert(*o)).collect()
    }
}

/// Parses the text of a poses.csv: the parameter names, the image paths, the poses (row-major).
/// An object column naming a single object is dropped; one naming several is an error.
/// Public for the fuzz target only.
#[doc(hidden)]
pub fn parse_poses_csv(path: &Path, text: &str) -> Result<(Vec<String>, Vec<String>, Vec<f64>)> {
    let table = parse_poses_table(path, text)?;
    one_object(path, &table)?;
    Ok((table.names, table.images, table.poses))
}

/// Parses the text of a poses.csv, keeping its object column when it has one.
/// Public for the fuzz target only.
#[doc(hidden)]
pub fn parse_poses_table(path: &Path, text: &str) -> Result<PosesTable> {
    let mut rdr = csv::ReaderBuilder::new().has_headers(false).flexible(true).trim(csv::Trim::All).from_reader(text.as_bytes());
    let mut records = rdr.records();
    let header = match records.next() {
        None => return Err(Error::parse(path, 1, "empty file: expected a header 'image,<param>,...'")),
        Some(r) => r.map_err(|e| Error::parse(path, 1, e.to_string()))?,
    };
    if header.get(0) != Some("image") {
        return Err(Error::parse(path, 1, format!("the header must start with 'image', found '{}'", header.get(0).unwrap_or(""))));
    }
    let columns: Vec<String> = header.iter().skip(1).map(String::from).collect();
    if let Some(n) = columns.iter().find(|n| n.is_empty()) {
        return Err(Error::parse(path, 1, format!("empty parameter name in the header ('{n}')")));
    }
    let mut seen_names = HashSet::new();
    for n in &columns {
        if !seen_names.insert(n) {
            let what = if n == OBJECT_COLUMN { "column" } else { "parameter" };
            return Err(Error::parse(path, 1, format!("{what} '{n}' appears twice in the header")));
        }
    }
    // Position of the object column among the columns after `image`.
    let object_col = columns.iter().position(|n| n == OBJECT_COLUMN);
    let names: Vec<String> = columns.iter().filter(|n| *n != OBJECT_COLUMN).cloned().collect();
    if names.is_empty() {
        let besides = if object_col.is_some() { format!(" (besides '{OBJECT_COLUMN}')") } else { String::new() };
        return Err(Error::parse(path, 1, format!("the header names no pose parameter after 'image'{besides}")));
    }
    let layout = match object_col {
        Some(_) => format!("image, {OBJECT_COLUMN} and {} parameters", names.len()),
        None => format!("image plus {} parameters", names.len()),
    };
    let mut images = Vec::new();
    let mut poses = Vec::new();
    let mut objects = Vec::new();
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
        if rec.len() != columns.len() + 1 {
            return Err(Error::parse(path, line, format!("{} fields, but the header has {} ({layout})", rec.len(), columns.len() + 1)));
        }
        let img = rec.get(0).unwrap_or("");
        if img.is_empty() {
            return Err(Error::parse(path, line, "empty image path"));
        }
        if let Some(prev) = seen.insert(img.to_string(), line) {
            return Err(Error::parse(path, line, format!("image '{img}' is listed twice (also on line {prev})")));
        }
        for (k, (name, v)) in columns.iter().zip(rec.iter().skip(1)).enumerate() {
            if Some(k) == object_col {
                if v.is_empty() {
                    return Err(Error::parse(path, line, format!("empty {OBJECT_COLUMN} name for '{img}'")));
                }
                objects.push(v.to_string());
                continue;
            }
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
    Ok(PosesTable { names, images, poses, objects: object_col.map(|_| objects) })
}

/// Refuses a table whose object column names several objects: a manifest is one object.
fn one_object(csv_path: &Path, table: &PosesTable) -> Result<()> {
    let objects = table.object_names();
    if objects.len() > 1 {
        return Err(Error::Dataset {
            path: csv_path.to_path_buf(),
            message: format!(
                "the '{OBJECT_COLUMN}' column names {} objects ({}): this folder holds several objects; \
                 read it as a catalog of objects (Catalog::open or Source::open), not as one object's data set",
                objects.len(),
                list_names(&objects, 10)
            ),
        });
    }
    Ok(())
}

/// `names` quoted and comma-separated, at most `max` of them (then how many more).
pub(crate) fn list_names<S: AsRef<str>>(names: &[S], max: usize) -> String {
    let mut s = names.iter().take(max).map(|n| format!("'{}'", n.as_ref())).collect::<Vec<_>>().join(", ");
    if names.len() > max {
        s.push_str(&format!(" and {} more", names.len() - max));
    }
    s
}

/// Reads `DIR/poses.csv` into a table (any object column kept); returns the file's path too.
pub(crate) fn read_poses_table(dir: &Path) -> Result<(PathBuf, PosesTable)> {
    let csv_path = dir.join("poses.csv");
    let text = std::fs::read(&csv_path).map_err(|e| Error::io(&csv_path, e))?;
    let text = String::from_utf8(text).map_err(|e| {
        let line = 1 + e.as_bytes()[..e.utf8_error().valid_up_to()].iter().filter(|&&b| b == b'\n').count();
        Error::parse(&csv_path, line, "not valid UTF-8")
    })?;
    let table = parse_poses_table(&csv_path, &text)?;
    for img in &table.images {
        check_relative(&csv_path, img)?;
    }
    Ok((csv_path, table))
}

/// The pose space of the parameters `names` of `DIR/poses.csv`, with the periods of the
/// optional `DIR/dataset.toml`.
pub(crate) fn read_pose_space(dir: &Path, csv_path: &Path, names: &[String]) -> Result<PoseSpace> {
    let toml_path = dir.join("dataset.toml");
    let periods = if toml_path.exists() {
        let t = std::fs::read_to_string(&toml_path).map_err(|e| Error::io(&toml_path, e))?;
        parse_dataset_toml(&toml_path, &t, names)?
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
    PoseSpace::new(params).map_err(|e| Error::parse(csv_path, 1, e.to_string()))
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

    fn err_of<T: std::fmt::Debug>(r: Result<T>) -> String {
        r.unwrap_err().to_string()
    }

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
    fn object_column() {
        let t = parse_poses_table(p(), "image,object,azimuth\na.png,cup,10\nb.png,7,20\n").unwrap();
        assert_eq!((t.names, t.poses, t.objects), (sv(&["azimuth"]), vec![10.0, 20.0], Some(sv(&["cup", "7"]))));
        assert_eq!(parse_poses_table(p(), "image,azimuth\na.png,1\n").unwrap().objects, None);
        let e = err_of(parse_poses_table(p(), "image,object\na.png,cup\n"));
        assert!(e.contains("no pose parameter") && e.contains("besides 'object'"), "{e}");
        let e = err_of(parse_poses_table(p(), "image,object,azimuth,object\na.png,cup,1,cup\n"));
        assert!(e.contains("column 'object' appears twice"), "{e}");
        let e = err_of(parse_poses_table(p(), "image,object,azimuth\na.png,cup\n"));
        assert!(e.contains(":2:") && e.contains("2 fields, but the header has 3 (image, object and 1 parameters)"), "{e}");
        // One object: a manifest (the column dropped); several: refused.
        let (n, i, v) = parse_poses_csv(p(), "image,object,azimuth\na.png,cup,10\nb.png,cup,20\n").unwrap();
        assert_eq!((n, i, v), (sv(&["azimuth"]), sv(&["a.png", "b.png"]), vec![10.0, 20.0]));
        let e = err_of(parse_poses_csv(p(), "image,object,azimuth\na.png,cup,10\nb.png,pot,20\n"));
        assert!(e.contains("names 2 objects ('cup', 'pot')") && e.contains("several objects"), "{e}");
    }

    fn sv(v: &[&str]) -> Vec<String> {
        v.iter().map(|s| s.to_string()).collect()
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
