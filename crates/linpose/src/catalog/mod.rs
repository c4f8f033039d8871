//! Data sets of several objects: which objects a data folder holds, their images and poses
//! ([`Catalog`], before any pixel is read) and their decoded images ([`ObjectSet`]).
//!
//! A [`Manifest`] and a [`Dataset`] hold one object. Telling *which* object an image shows, as
//! well as its pose, needs the views of many objects side by side, each object's kept apart and
//! all of them comparable: one image size and one set of pose parameters. A catalog is read
//! from a folder in any of three layouts:
//! - **a folder of object folders**: `DIR/<name>/poses.csv` (each one object's data set folder,
//!   with its own optional `dataset.toml`); the folder's name is the object's;
//! - **one poses.csv with an `object` column**: `DIR/poses.csv` with header
//!   `image,object,<param>,...` (the `object` column anywhere after `image`), the images relative
//!   to DIR, `DIR/dataset.toml` describing the pose parameters;
//! - **a COIL folder**: `objO__K.png` files, every object number O one object, named `objO`.
//!
//! [`Source::open`] reads a folder of either kind, one object or several.

use crate::dataset::Dataset;
use crate::image_io::{self, ColorMode, ImageSpec};
use crate::manifest::{self, list_names, Manifest, PosesTable, TrainSelection, OBJECT_COLUMN};
use crate::pose::PoseSpace;
use crate::{Error, Result};
use std::collections::{BTreeSet, HashMap, HashSet};
use std::path::{Component, Path, PathBuf};

#[cfg(test)]
mod tests;

/// Most object names quoted in one error message.
const NAMES_IN_ERRORS: usize = 20;

/// The images of several objects, each a [`Manifest`], with the objects' names. Every object has
/// at least one image and all have the same [`PoseSpace`].
#[derive(Debug, Clone)]
pub struct Catalog {
    root: PathBuf,
    names: Vec<String>,
    manifests: Vec<Manifest>,
}

impl Catalog {
    /// A catalog from parts: `root` is the folder the objects were read from (training lists
    /// name images relative to it), `names[k]` the name of the object whose images `manifests[k]`
    /// lists. Refused: no object, a name count other than the manifest count, an empty or
    /// repeated name, an object whose pose parameters (names, order, periods) differ from the
    /// first object's.
    pub fn new(root: impl Into<PathBuf>, names: Vec<String>, manifests: Vec<Manifest>) -> Result<Self> {
        let root = root.into();
        check_names(&names, manifests.len()).map_err(|message| Error::Dataset { path: root.clone(), message })?;
        for (name, m) in names.iter().zip(&manifests).skip(1) {
            check_space(name, m.space(), &names[0], manifests[0].space()).map_err(|message| Error::Dataset { path: m.root().to_path_buf(), message })?;
        }
        Ok(Catalog { root, names, manifests })
    }

    /// Opens a folder of several objects, in any of three layouts:
    /// - a folder of object folders: DIR has no `poses.csv`, and each of its subfolders that
    ///   holds a `poses.csv` is one object, read by [`Manifest::read_dir_format`] (so its own
    ///   `dataset.toml` applies) and named after the subfolder; objects are sorted by name, and
    ///   another subfolder without a `poses.csv` (an empty object folder) is an error naming it
    ///   (hidden ones, with a leading dot, are ignored);
    /// - `DIR/poses.csv` with an `object` column (anywhere after `image`): the rows of each
    ///   object, objects in order of first appearance; image paths are relative to DIR and
    ///   `DIR/dataset.toml` describes the pose parameters;
    /// - a COIL folder (`objO__K.png` files, no `poses.csv`): each object number found, in
    ///   numeric order, read by [`Manifest::coil`] and named `objO`.
    ///
    /// A `poses.csv` without an `object` column is one object's data set, refused here
    /// ([`Source::open`] reads either).
    pub fn open(dir: &Path) -> Result<Self> {
        check_folder(dir)?;
        if dir.join("poses.csv").is_file() {
            let (csv, table) = manifest::read_poses_table(dir)?;
            if table.objects.is_none() {
                return Err(Error::Dataset {
                    path: csv,
                    message: format!(
                        "no '{OBJECT_COLUMN}' column: this folder holds one object's data set (read it with Manifest::open or \
                         Source::open); a poses.csv of several objects names each image's object in a column '{OBJECT_COLUMN}'"
                    ),
                });
            }
            return Self::from_table(dir, &csv, table);
        }
        let coil = coil_objects(dir)?;
        if !coil.is_empty() {
            return Self::from_coil(dir, &coil);
        }
        let folders = object_folders(dir)?;
        if !folders.is_empty() {
            return Self::from_folders(dir, folders);
        }
        Err(Error::Dataset {
            path: dir.to_path_buf(),
            message: "not a data set of several objects: no poses.csv, no COIL images (objO__K.png) and no subfolder with a \
                      poses.csv in this folder"
                .into(),
        })
    }

    /// Layout (b): `table` read from `csv` in `dir`, with its object column.
    fn from_table(dir: &Path, csv: &Path, table: PosesTable) -> Result<Self> {
        let space = manifest::read_pose_space(dir, csv, &table.names)?;
        let objects = table.objects.as_deref().unwrap_or_default();
        let p = table.names.len();
        let mut index: HashMap<&str, usize> = HashMap::new();
        let mut groups: Vec<(String, Vec<String>, Vec<f64>)> = Vec::new();
        for (i, (img, obj)) in table.images.iter().zip(objects).enumerate() {
            let k = *index.entry(obj.as_str()).or_insert_with(|| {
                groups.push((obj.clone(), Vec::new(), Vec::new()));
                groups.len() - 1
            });
            groups[k].1.push(img.clone());
            groups[k].2.extend_from_slice(&table.poses[i * p..(i + 1) * p]);
        }
        let mut names = Vec::with_capacity(groups.len());
        let mut manifests = Vec::with_capacity(groups.len());
        for (name, images, poses) in groups {
            manifests.push(Manifest::new(dir, space.clone(), images, poses)?);
            names.push(name);
        }
        Self::new(dir, names, manifests)
    }

    /// Layout (c): the COIL objects `objects` of `dir`.
    fn from_coil(dir: &Path, objects: &[u32]) -> Result<Self> {
        let manifests = objects.iter().map(|&o| Manifest::coil(dir, o)).collect::<Result<Vec<_>>>()?;
        Self::new(dir, objects.iter().map(|o| format!("obj{o}")).collect(), manifests)
    }

    /// Layout (a): the object folders `folders` (names) of `dir`.
    fn from_folders(dir: &Path, folders: Vec<String>) -> Result<Self> {
        let manifests = folders.iter().map(|f| Manifest::read_dir_format(&dir.join(f))).collect::<Result<Vec<_>>>()?;
        Self::new(dir, folders, manifests)
    }

    /// The folder the catalog was read from; training lists name images relative to it.
    pub fn root(&self) -> &Path {
        &self.root
    }

    /// The objects' names, in catalog order.
    pub fn names(&self) -> &[String] {
        &self.names
    }

    /// The objects' manifests, in catalog order.
    pub fn manifests(&self) -> &[Manifest] {
        &self.manifests
    }

    /// Number of objects.
    pub fn len(&self) -> usize {
        self.names.len()
    }

    /// Whether there are no objects (never true for a catalog that was built).
    pub fn is_empty(&self) -> bool {
        self.names.is_empty()
    }

    /// The pose parameters, the same for every object.
    pub fn space(&self) -> &PoseSpace {
        self.manifests[0].space()
    }

    /// Number of images of all objects together.
    pub fn total_images(&self) -> usize {
        self.manifests.iter().map(Manifest::len).sum()
    }

    /// The catalog of the objects named in `names` only, in the catalog's order. An unknown
    /// name is an error listing the known ones.
    pub fn select(&self, names: &[String]) -> Result<Self> {
        let keep = select_indices(&self.names, names).map_err(|message| Error::Dataset { path: self.root.clone(), message })?;
        Ok(Catalog {
            root: self.root.clone(),
            names: keep.iter().map(|&k| self.names[k].clone()).collect(),
            manifests: keep.iter().map(|&k| self.manifests[k].clone()).collect(),
        })
    }

    /// Each object's training mask under `sel`: [`Manifest::training_mask`]'s rule for
    /// [`TrainSelection::Step`] and [`TrainSelection::All`], applied to each object on its own.
    /// [`TrainSelection::Names`] lists image paths relative to the catalog's
    /// [`root`](Self::root): `objfolder/img.png` in a folder of object folders, the path as in
    /// poses.csv or the file name otherwise; a listed path found in no object is an error. An
    /// object whose selection picks no view is an error naming the object.
    pub fn training_masks(&self, sel: &TrainSelection) -> Result<Vec<Vec<bool>>> {
        let masks: Vec<Vec<bool>> = match sel {
            TrainSelection::Names(list) => {
                let listed: HashSet<&str> = list.iter().map(String::as_str).collect();
                let mut found: HashSet<String> = HashSet::new();
                let masks = (0..self.len())
                    .map(|k| {
                        let m = &self.manifests[k];
                        (0..m.len())
                            .map(|i| {
                                let name = self.image_name(k, i);
                                let hit = listed.contains(name.as_str());
                                if hit {
                                    found.insert(name);
                                }
                                hit
                            })
                            .collect()
                    })
                    .collect();
                if let Some(missing) = list.iter().find(|n| !found.contains(n.as_str())) {
                    return Err(Error::Dataset {
                        path: self.root.clone(),
                        message: format!(
                            "training list names '{missing}', which is in no object of the data set (paths are relative to the \
                             data folder, such as '{}')",
                            self.image_name(0, 0)
                        ),
                    });
                }
                masks
            }
            _ => self.manifests.iter().map(|m| m.selection_mask(sel)).collect::<Result<_>>()?,
        };
        for (k, mask) in masks.iter().enumerate() {
            if !mask.iter().any(|&b| b) {
                return Err(Error::Dataset {
                    path: self.manifests[k].root().to_path_buf(),
                    message: format!("object '{}' has no training views under {sel}", self.names[k]),
                });
            }
        }
        Ok(masks)
    }

    /// Image `i` of object `k` as a path relative to the catalog's root (`/`-separated); the
    /// full path when the object's folder is not inside the root.
    fn image_name(&self, k: usize, i: usize) -> String {
        let m = &self.manifests[k];
        let img = &m.images()[i];
        match m.root().strip_prefix(&self.root) {
            Ok(rel) => {
                let mut parts: Vec<&str> = rel.components().filter_map(|c| if let Component::Normal(s) = c { s.to_str() } else { None }).collect();
                parts.push(img);
                parts.join("/")
            }
            Err(_) => m.image_path(i).to_string_lossy().into_owned(),
        }
    }

    /// The catalog restricted to the views where `masks` (one per object, one value per view)
    /// are true ([`Manifest::subset`]); an object left with no view is an error naming it.
    pub fn subset(&self, masks: &[Vec<bool>]) -> Result<Self> {
        let lens: Vec<usize> = self.manifests.iter().map(Manifest::len).collect();
        check_masks(&self.names, &lens, masks)
            .map_err(|(k, message)| Error::Dataset { path: k.map_or_else(|| self.root.clone(), |k| self.manifests[k].root().to_path_buf()), message })?;
        let manifests = self.manifests.iter().zip(masks).map(|(m, mask)| m.subset(mask)).collect::<Result<Vec<_>>>()?;
        Ok(Catalog { root: self.root.clone(), names: self.names.clone(), manifests })
    }

    /// Decodes every object's images ([`Dataset::load`], one object after the other, each in
    /// parallel) into an [`ObjectSet`]; `progress` is called with the number of images decoded
    /// since its last call. Every object's images must have one size: the first image of each
    /// object is checked against the first object's before any pixel is decoded.
    pub fn load(&self, color: ColorMode, progress: &(dyn Fn(u64) + Sync)) -> Result<ObjectSet> {
        let mut first: Option<(u32, u32)> = None;
        for (k, m) in self.manifests.iter().enumerate() {
            let path = m.image_path(0);
            let bytes = std::fs::read(&path).map_err(|e| Error::io(&path, e))?;
            let (w, h) = image_io::dimensions(&path, &bytes)?;
            match first {
                None => first = Some((w, h)),
                Some((w0, h0)) if (w, h) != (w0, h0) => {
                    return Err(Error::Dataset {
                        path,
                        message: format!(
                            "object '{}' has images of {w}x{h} but object '{}' has {w0}x{h0} ({}): every object's images must have one size",
                            self.names[k],
                            self.names[0],
                            self.image_name(0, 0)
                        ),
                    });
                }
                Some(_) => {}
            }
        }
        let objects = self.manifests.iter().map(|m| Dataset::load(m.clone(), color, progress)).collect::<Result<Vec<_>>>()?;
        ObjectSet::new(self.names.clone(), objects)
    }
}

/// Several objects' data sets in memory: one [`Dataset`] per object, all of one [`ImageSpec`]
/// and one [`PoseSpace`], with the objects' names.
#[derive(Debug, Clone)]
pub struct ObjectSet {
    names: Vec<String>,
    objects: Vec<Dataset>,
}

impl ObjectSet {
    /// The objects `objects` named `names`. Refused: no object, a name count other than the data
    /// set count, an empty or repeated name, an empty data set, an object whose image size,
    /// colour handling or pose parameters differ from the first object's.
    pub fn new(names: Vec<String>, objects: Vec<Dataset>) -> Result<Self> {
        let at = |k: usize| objects.get(k).map_or_else(|| PathBuf::from("in-memory data set"), where_of);
        check_names(&names, objects.len()).map_err(|message| Error::Dataset { path: at(0), message })?;
        for (k, (name, d)) in names.iter().zip(&objects).enumerate() {
            if d.is_empty() {
                return Err(Error::Dataset { path: at(k), message: format!("object '{name}' has no images") });
            }
            if k == 0 {
                continue;
            }
            let (s, s0) = (d.spec(), objects[0].spec());
            if (s.width, s.height) != (s0.width, s0.height) {
                return Err(Error::Dataset {
                    path: at(k),
                    message: format!(
                        "object '{name}' has images of {}x{} but object '{}' has {}x{}: every object's images must have one size",
                        s.width, s.height, names[0], s0.width, s0.height
                    ),
                });
            }
            if s.color != s0.color {
                return Err(Error::Dataset {
                    path: at(k),
                    message: format!(
                        "object '{name}' has {} features but object '{}' has {}: every object's images must be read in one colour mode",
                        color_name(s.color),
                        names[0],
                        color_name(s0.color)
                    ),
                });
            }
            check_space(name, d.space(), &names[0], objects[0].space()).map_err(|message| Error::Dataset { path: at(k), message })?;
        }
        Ok(ObjectSet { names, objects })
    }

    /// The objects' names, in order.
    pub fn names(&self) -> &[String] {
        &self.names
    }

    /// The objects' data sets, in order.
    pub fn objects(&self) -> &[Dataset] {
        &self.objects
    }

    /// Object `k`'s data set; panics when `k` is not below [`len`](Self::len).
    pub fn object(&self, k: usize) -> &Dataset {
        &self.objects[k]
    }

    /// Number of objects.
    pub fn len(&self) -> usize {
        self.objects.len()
    }

    /// Whether there are no objects (never true for a set that was built).
    pub fn is_empty(&self) -> bool {
        self.objects.is_empty()
    }

    /// Image size and colour handling, the same for every object.
    pub fn spec(&self) -> ImageSpec {
        self.objects[0].spec()
    }

    /// The pose parameters, the same for every object.
    pub fn space(&self) -> &PoseSpace {
        self.objects[0].space()
    }

    /// Total number of images.
    pub fn total_len(&self) -> usize {
        self.objects.iter().map(Dataset::len).sum()
    }

    /// Each object restricted to the images where its mask is true ([`Dataset::subset`]; one
    /// mask per object, one value per image); an object left with no image is an error naming
    /// it.
    pub fn subset(&self, masks: &[Vec<bool>]) -> Result<Self> {
        let lens: Vec<usize> = self.objects.iter().map(Dataset::len).collect();
        check_masks(&self.names, &lens, masks).map_err(|(k, message)| Error::Dataset { path: where_of(&self.objects[k.unwrap_or(0)]), message })?;
        let objects = self.objects.iter().zip(masks).map(|(d, mask)| d.subset(mask)).collect::<Result<Vec<_>>>()?;
        Ok(ObjectSet { names: self.names.clone(), objects })
    }

    /// The set of the objects named in `names` only, in the set's order. An unknown name is an
    /// error listing the known ones.
    pub fn select(&self, names: &[String]) -> Result<Self> {
        let keep = select_indices(&self.names, names).map_err(|message| Error::Dataset { path: where_of(&self.objects[0]), message })?;
        Ok(ObjectSet { names: keep.iter().map(|&k| self.names[k].clone()).collect(), objects: keep.iter().map(|&k| self.objects[k].clone()).collect() })
    }
}

/// What a data folder holds: one object's data set or several objects'.
#[derive(Debug, Clone)]
pub enum Source {
    /// One object's images and poses.
    One(Manifest),
    /// Several objects' images and poses.
    Many(Catalog),
}

impl Source {
    /// Opens a data folder of one object or several. With `object`, the folder is a COIL folder
    /// and that object is read ([`Manifest::coil`]). Otherwise: `DIR/poses.csv` without an
    /// `object` column is one object; with one it is several (even when it names a single
    /// object); without a `poses.csv`, `objO__K.png` files make a COIL folder of several objects,
    /// and else subfolders holding a `poses.csv` are the objects ([`Catalog::open`]).
    pub fn open(dir: &Path, object: Option<u32>) -> Result<Self> {
        check_folder(dir)?;
        if let Some(o) = object {
            return Ok(Source::One(Manifest::coil(dir, o)?));
        }
        if dir.join("poses.csv").is_file() {
            let (csv, table) = manifest::read_poses_table(dir)?;
            if table.objects.is_some() {
                return Ok(Source::Many(Catalog::from_table(dir, &csv, table)?));
            }
            let space = manifest::read_pose_space(dir, &csv, &table.names)?;
            return Ok(Source::One(Manifest::new(dir, space, table.images, table.poses)?));
        }
        let coil = coil_objects(dir)?;
        if !coil.is_empty() {
            return Ok(Source::Many(Catalog::from_coil(dir, &coil)?));
        }
        let folders = object_folders(dir)?;
        if !folders.is_empty() {
            return Ok(Source::Many(Catalog::from_folders(dir, folders)?));
        }
        Err(Error::Dataset {
            path: dir.to_path_buf(),
            message: "no poses.csv in this folder; for a COIL folder (objO__K.png files) give --object O; a data set of \
                      several objects is a poses.csv with an 'object' column, a COIL folder of several objects, or a folder \
                      of object folders each with its own poses.csv"
                .into(),
        })
    }
}

/// Refuses a path that is not a folder, as [`Manifest::open`] does.
fn check_folder(dir: &Path) -> Result<()> {
    if !dir.is_dir() {
        return Err(Error::Dataset { path: dir.to_path_buf(), message: if dir.exists() { "not a folder".into() } else { "no such folder".into() } });
    }
    Ok(())
}

/// The object numbers of the COIL files (`objO__K.png`) in `dir`, ascending. Numbers written
/// with a leading zero are not COIL's and are ignored, as [`Manifest::coil`] would not find them.
fn coil_objects(dir: &Path) -> Result<Vec<u32>> {
    let digits = |s: &str| !s.is_empty() && s.bytes().all(|b| b.is_ascii_digit());
    let mut objects = BTreeSet::new();
    for entry in std::fs::read_dir(dir).map_err(|e| Error::io(dir, e))? {
        let entry = entry.map_err(|e| Error::io(dir, e))?;
        let name = entry.file_name();
        let Some(name) = name.to_str() else { continue };
        let Some((o, k)) = name.strip_prefix("obj").and_then(|r| r.strip_suffix(".png")).and_then(|r| r.split_once("__")) else { continue };
        if !digits(o) || !digits(k) || (o.len() > 1 && o.starts_with('0')) || k.parse::<u32>().is_err() {
            continue;
        }
        if let Ok(o) = o.parse::<u32>() {
            objects.insert(o);
        }
    }
    Ok(objects.into_iter().collect())
}

/// The subfolders of `dir` that hold a `poses.csv`, sorted by name; a name that is not UTF-8
/// is an error.
///
/// Once some subfolder holds a `poses.csv`, every other subfolder (but hidden ones, named with a
/// leading dot) must too: an object folder left empty or without its `poses.csv` is an error
/// naming it, never an object silently left out.
fn object_folders(dir: &Path) -> Result<Vec<String>> {
    let mut folders = Vec::new();
    let mut without = Vec::new();
    for entry in std::fs::read_dir(dir).map_err(|e| Error::io(dir, e))? {
        let entry = entry.map_err(|e| Error::io(dir, e))?;
        let path = entry.path();
        if !path.is_dir() || entry.file_name().to_string_lossy().starts_with('.') {
            continue;
        }
        if !path.join("poses.csv").is_file() {
            without.push(path);
            continue;
        }
        let Some(name) = entry.file_name().to_str().map(String::from) else {
            return Err(Error::Dataset { path, message: "the object folder's name is not valid UTF-8, so it cannot name the object".into() });
        };
        folders.push(name);
    }
    if let (false, Some(path)) = (folders.is_empty(), without.iter().min()) {
        let empty = std::fs::read_dir(path).map(|mut d| d.next().is_none()).unwrap_or(false);
        return Err(Error::Dataset {
            path: path.clone(),
            message: format!(
                "{} of this many-object data set, which has no poses.csv while {} other object folder{} {}: give it its \
                 images and poses.csv, or move it out of the data set",
                if empty { "an empty folder" } else { "a folder" },
                folders.len(),
                if folders.len() == 1 { "" } else { "s" },
                if folders.len() == 1 { "has one" } else { "have one" }
            ),
        });
    }
    folders.sort();
    Ok(folders)
}

/// `gray` or `rgb`.
fn color_name(c: ColorMode) -> &'static str {
    match c {
        ColorMode::Gray => "gray",
        ColorMode::Rgb => "rgb",
    }
}

/// Where an object's data come from, for errors: its folder, or the in-memory set.
fn where_of(d: &Dataset) -> PathBuf {
    let root = d.manifest().root();
    if root.as_os_str().is_empty() {
        PathBuf::from("in-memory data set")
    } else {
        root.to_path_buf()
    }
}

/// At least one object, one name per object, names non-empty and distinct.
fn check_names(names: &[String], objects: usize) -> std::result::Result<(), String> {
    if names.len() != objects {
        return Err(format!("{} object names for {objects} objects", names.len()));
    }
    if names.is_empty() {
        return Err("no object: a data set of several objects needs at least one".into());
    }
    if let Some(k) = names.iter().position(String::is_empty) {
        return Err(format!("object {k} has an empty name"));
    }
    let mut seen = HashSet::new();
    if let Some(n) = names.iter().find(|n| !seen.insert(n.as_str())) {
        return Err(format!("object name '{n}' appears twice"));
    }
    Ok(())
}

/// Object `name`'s pose parameters must be `first`'s (object `first_name`'s).
fn check_space(name: &str, space: &PoseSpace, first_name: &str, first: &PoseSpace) -> std::result::Result<(), String> {
    if space == first {
        return Ok(());
    }
    Err(format!(
        "object '{name}' has pose parameters ({}) but object '{first_name}' has ({}): every object must have the same pose parameters",
        describe_space(space),
        describe_space(first)
    ))
}

/// `elevation (linear), azimuth (period 360)`.
fn describe_space(space: &PoseSpace) -> String {
    let parts: Vec<String> = space
        .params()
        .iter()
        .map(|p| match p.period {
            Some(t) => format!("{} (period {t})", p.name),
            None => format!("{} (linear)", p.name),
        })
        .collect();
    parts.join(", ")
}

/// The positions in `have` of the names in `want`, in `have`'s order; an unknown name or an
/// empty `want` is an error.
fn select_indices(have: &[String], want: &[String]) -> std::result::Result<Vec<usize>, String> {
    if want.is_empty() {
        return Err(format!("no object selected (the data set has {})", list_names(have, NAMES_IN_ERRORS)));
    }
    if let Some(unknown) = want.iter().find(|w| !have.contains(w)) {
        return Err(format!("no object named '{unknown}' (the data set has {})", list_names(have, NAMES_IN_ERRORS)));
    }
    let want: HashSet<&str> = want.iter().map(String::as_str).collect();
    Ok((0..have.len()).filter(|&k| want.contains(have[k].as_str())).collect())
}

/// One mask per object with one value per view, and at least one true value in each; the error
/// names the object at fault when there is one.
fn check_masks(names: &[String], lens: &[usize], masks: &[Vec<bool>]) -> std::result::Result<(), (Option<usize>, String)> {
    if masks.len() != names.len() {
        return Err((None, format!("{} masks for {} objects: one mask per object is needed", masks.len(), names.len())));
    }
    for (k, (mask, &n)) in masks.iter().zip(lens).enumerate() {
        if mask.len() != n {
            return Err((Some(k), format!("the mask of object '{}' has {} values but the object has {n} views", names[k], mask.len())));
        }
        if !mask.iter().any(|&b| b) {
            return Err((Some(k), format!("the mask of object '{}' keeps none of its views", names[k])));
        }
    }
    Ok(())
}
