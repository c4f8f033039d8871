//! Model files: safetensors, so numpy's and PyTorch's safetensors loaders read the arrays as they
//! are. The arrays are tensors; everything else is JSON in the header's metadata under
//! `linpose.meta`, with `format = linpose` and `format_version`. Writes are atomic.
//!
//! For the linear model, `weights` is K x M (float32) and `bias` has K values (float64): the
//! encoded estimate of a feature row x is `weights @ x + bias`.
//!
//! ```
//! use linpose::image_io::{ColorMode, ImageSpec};
//! use linpose::{AnyModel, Dataset, EigenspaceParams, Estimator, Param, PoseModel, PoseSpace};
//!
//! // Eight 4x4 views of a turntable.
//! let space = PoseSpace::new(vec![Param::circular("azimuth", 360.0)])?;
//! let spec = ImageSpec { width: 4, height: 4, color: ColorMode::Gray };
//! let poses: Vec<f64> = (0..8).map(|i| 45.0 * i as f64).collect();
//! let pixels: Vec<f32> = poses.iter().flat_map(|a| (0..16).map(move |p| (0.5 + 0.4 * (a.to_radians() + p as f64).sin()) as f32)).collect();
//! let data = Dataset::new(spec, pixels, space, poses)?;
//! let model = EigenspaceParams::default().components(3).fit(&data)?;
//!
//! let path = std::env::temp_dir().join(format!("linpose-doc-{}.safetensors", std::process::id()));
//! model.save(&path)?;
//! let back = AnyModel::load(&path)?; // any method's model
//! std::fs::remove_file(&path).ok();
//! assert_eq!(back.meta().method, "eigenspace");
//! assert_eq!(back.predict(data.row(2))?, model.predict(data.row(2))?);
//! # Ok::<(), linpose::Error>(())
//! ```

use crate::model::file::{save_bytes, write_parts};
use crate::model::{AnyModel, ModelMeta, PoseModel, Tensor, TensorData, TensorSet};
use crate::recognize::{ObjectModel, ObjectSettings};
use crate::{Error, Result};
use safetensors::tensor::Dtype;
use safetensors::SafeTensors;
use std::collections::BTreeMap;
use std::path::Path;

pub use crate::model::file::FORMAT_VERSION;
pub(crate) use crate::model::file::{write_parts_to, DataRef, TensorRef};

impl ObjectModel {
    /// The model's file bytes (safetensors): the recogniser's arrays (`recognizer.*`), each
    /// object's pose model's arrays under `object.K.`, and in the metadata `kind = objects` with
    /// `linpose.objects`: the names, the recogniser's settings and each pose model's metadata.
    pub fn to_bytes(&self) -> Result<Vec<u8>> {
        objects_to_bytes(self)
    }

    /// Writes the model file atomically (temporary name, then rename): its size in bytes.
    pub fn save(&self, path: &Path) -> Result<u64> {
        save_bytes(&self.to_bytes()?, path)
    }

    /// Reads a many-object model file written by [`ObjectModel::save`].
    pub fn load(path: &Path) -> Result<ObjectModel> {
        let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
        objects_from_bytes(path, &bytes)
    }

    /// Parses many-object model file bytes (`path` names them in errors).
    pub fn from_bytes(path: &Path, bytes: &[u8]) -> Result<ObjectModel> {
        objects_from_bytes(path, bytes)
    }
}

impl AnyModel {
    /// Reads a pose model file written by [`PoseModel::save`]: any method's model.
    pub fn load(path: &Path) -> Result<AnyModel> {
        let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
        from_bytes(path, &bytes)
    }

    /// Parses pose model file bytes (`path` names them in errors).
    pub fn from_bytes(path: &Path, bytes: &[u8]) -> Result<AnyModel> {
        from_bytes(path, bytes)
    }
}

fn objects_to_bytes(model: &ObjectModel) -> Result<Vec<u8>> {
    let header = ObjectsHeader {
        names: model.names().to_vec(),
        settings: model.settings().clone(),
        models: model.pose_models().iter().map(|p| p.meta().clone()).collect(),
        views: model.space().is_none().then(|| model.spec()),
        normalize: model.stage().cloned(),
        labels: model.labels().cloned(),
        robust: Some(model.robust_settings()).filter(|r| !r.is_empty()),
    };
    let mut tensors = model.recognizer_tensors();
    tensors.extend(model.robust_tensors());
    for (k, p) in model.pose_models().iter().enumerate() {
        tensors.extend(p.tensors().into_iter().map(|t| Tensor { name: format!("object.{k}.{}", t.name), ..t }));
    }
    let mut meta = BTreeMap::new();
    meta.insert("kind", OBJECTS_KIND.to_string());
    meta.insert("method", model.method_name().unwrap_or(NO_POSES).to_string());
    meta.insert("linpose.objects", serde_json::to_string(&header).expect("header serialises"));
    write_parts(meta, tensors)
}

/// The `kind` metadata of a many-object model file (a file without it holds one pose model).
const OBJECTS_KIND: &str = "objects";

/// The `kind` metadata of a file of partial training statistics (`crate::partial`), which
/// [`AnyModel::load`] refuses with a message that says how to make a model of it.
pub(crate) const PARTIAL_KIND: &str = "partial";

/// The `method` of a many-object model fitted without poses (no pose models), in its file's
/// metadata and in what the command line reports.
pub const NO_POSES: &str = "none";

/// What a many-object model file's `linpose.objects` holds besides its arrays.
#[derive(serde::Serialize, serde::Deserialize)]
struct ObjectsHeader {
    names: Vec<String>,
    settings: ObjectSettings,
    models: Vec<ModelMeta>,
    /// The image size of a model fitted without poses, which has no pose models to tell it
    /// (absent otherwise).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    views: Option<crate::image_io::ImageSpec>,
    /// The normalisation stage every query goes through first (absent: none).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    normalize: Option<crate::normalize::Normalizer>,
    /// The caller's labels for the objects (absent: their names; a linpose that predates them
    /// reads the file and ignores them).
    #[serde(default, skip_serializing_if = "Option::is_none")]
    labels: Option<crate::recognize::Labels>,
    /// Each object's robust stage's settings (absent: no robust stage); their arrays are
    /// `robust.K.rows` and `robust.K.hypotheses`.
    #[serde(default, skip_serializing_if = "Option::is_none")]
    robust: Option<Vec<crate::robust::RobustSettings>>,
}

fn from_bytes(path: &Path, bytes: &[u8]) -> Result<AnyModel> {
    let (file_meta, tensors) = read_parts(path, bytes)?;
    let meta = &file_meta;
    let err = |m: String| Error::ModelFile { path: path.to_path_buf(), message: m };
    if meta.get("kind").map(String::as_str) == Some(PARTIAL_KIND) {
        return Err(err(
            "this is a file of partial training statistics (train --shard), not a model: merge the shards' files into a model with `linpose merge`".into(),
        ));
    }
    if meta.get("kind").map(String::as_str) == Some(OBJECTS_KIND) {
        return Err(err(
            "this model file holds several objects (a recogniser and each object's pose model), not one object's pose model: `linpose predict` and `eval` read it, in Python `linpose.load` (an ObjectRecognizer), in Rust ObjectModel::load"
                .into(),
        ));
    }
    let json = meta.get("linpose.meta").ok_or_else(|| err("model file has no linpose.meta".into()))?;
    let meta: ModelMeta = serde_json::from_str(json).map_err(|e| err(format!("damaged metadata: {e}")))?;
    let model = pose_model(meta, &tensors)?;
    match file_meta.get(crate::robust::META_KEY) {
        None => Ok(model),
        Some(json) => {
            let settings = serde_json::from_str(json).map_err(|e| err(format!("damaged robust stage settings: {e}")))?;
            crate::robust::Robust::from_parts(model, settings, &tensors)
        }
    }
}

/// A pose model from its metadata and arrays: the method's own model, put back behind its
/// normalisation stage when it has one.
fn pose_model(mut meta: ModelMeta, tensors: &TensorSet) -> Result<AnyModel> {
    let err = |m: String| Error::ModelFile { path: tensors.path.clone(), message: m };
    validate_meta(&meta).map_err(err)?;
    let stage = meta.normalize.take();
    let method = crate::methods::find(&meta.method)
        .ok_or_else(|| tensors.error(format!("unknown method '{}' (this linpose knows: {})", meta.method, crate::methods::names())))?;
    let model = method.load(meta, tensors)?;
    Ok(match stage {
        Some(stage) => AnyModel::new(crate::model::Normalized::new(stage, model)),
        None => model,
    })
}

fn objects_from_bytes(path: &Path, bytes: &[u8]) -> Result<ObjectModel> {
    let (meta, tensors) = read_parts(path, bytes)?;
    let err = |m: String| Error::ModelFile { path: path.to_path_buf(), message: m };
    if meta.get("kind").map(String::as_str) != Some(OBJECTS_KIND) {
        return Err(err("this model file holds one object's pose model, not several objects' (read it with AnyModel::load)".into()));
    }
    let json = meta.get("linpose.objects").ok_or_else(|| err("model file has no linpose.objects".into()))?;
    let header: ObjectsHeader = serde_json::from_str(json).map_err(|e| err(format!("damaged metadata: {e}")))?;
    if header.models.len() != header.names.len() && !header.settings.views_only {
        return Err(err(format!("damaged metadata: {} names for {} pose models", header.names.len(), header.models.len())));
    }
    let (mut own, mut rest): (Vec<Tensor>, Vec<Tensor>) = tensors.tensors.into_iter().partition(|t| t.name.starts_with("recognizer."));
    let mut poses = Vec::with_capacity(header.models.len());
    for (k, meta) in header.models.into_iter().enumerate() {
        let prefix = format!("object.{k}.");
        let (mine, others): (Vec<Tensor>, Vec<Tensor>) = rest.into_iter().partition(|t| t.name.starts_with(&prefix));
        rest = others;
        let set = TensorSet { path: path.to_path_buf(), tensors: mine.into_iter().map(|t| Tensor { name: t.name[prefix.len()..].to_string(), ..t }).collect() };
        poses.push(pose_model(meta, &set)?);
    }
    own.extend(rest);
    let t = TensorSet { path: path.to_path_buf(), tensors: own };
    let model = ObjectModel::from_parts(header.names, header.settings, &t, poses, header.views, header.normalize, header.labels)?;
    match header.robust {
        None => Ok(model),
        Some(settings) => model.with_robust_parts(&settings, &t),
    }
}

/// Whether the model file at `path` holds several objects ([`ObjectModel::load`]) rather than one
/// pose model ([`AnyModel::load`]); reads only its header.
pub fn holds_objects(path: &Path) -> Result<bool> {
    use std::io::Read;
    let mut f = std::fs::File::open(path).map_err(|e| Error::io(path, e))?;
    let mut len = [0u8; 8];
    let err = |m: &str| Error::ModelFile { path: path.to_path_buf(), message: m.to_string() };
    f.read_exact(&mut len).map_err(|_| err("not a linpose model file (shorter than a safetensors header)"))?;
    let n = u64::from_le_bytes(len);
    if n > 100 << 20 {
        return Err(err("not a linpose model file (a safetensors header over 100 MB)"));
    }
    let mut header = vec![0u8; n as usize];
    f.read_exact(&mut header).map_err(|_| err("not a linpose model file (its header is cut short)"))?;
    let v: serde_json::Value = serde_json::from_slice(&header).map_err(|_| err("not a linpose model file (its header is not JSON)"))?;
    Ok(v.get("__metadata__").and_then(|m| m.get("kind")).and_then(|k| k.as_str()) == Some(OBJECTS_KIND))
}

/// Whether model file bytes hold several objects ([`ObjectModel::from_bytes`]) rather than one pose
/// model ([`AnyModel::from_bytes`]); false for bytes that are no safetensors file (reading them says why).
pub fn bytes_hold_objects(bytes: &[u8]) -> bool {
    SafeTensors::read_metadata(bytes).ok().and_then(|(_, h)| h.metadata().as_ref().and_then(|m| m.get("kind").cloned())).as_deref() == Some(OBJECTS_KIND)
}

/// A safetensors file's metadata.
pub(crate) type Metadata = std::collections::HashMap<String, String>;

/// Tensors left in a file's bytes, by name ([`read_parts_except`]).
pub(crate) type Borrowed<'b> = Vec<(String, safetensors::tensor::TensorView<'b>)>;

/// The metadata and the arrays of a linpose safetensors file, its format version checked.
pub(crate) fn read_parts(path: &Path, bytes: &[u8]) -> Result<(Metadata, TensorSet)> {
    read_parts_except(path, bytes, &[]).map(|(meta, set, _)| (meta, set))
}

/// [`read_parts`] with the tensors named in `borrow` left in the file's bytes: returned as their
/// safetensors views (shape and dtype checked by the caller), not copied into the set.
pub(crate) fn read_parts_except<'b>(path: &Path, bytes: &'b [u8], borrow: &[&str]) -> Result<(Metadata, TensorSet, Borrowed<'b>)> {
    let err = |m: String| Error::ModelFile { path: path.to_path_buf(), message: m };
    let st = SafeTensors::deserialize(bytes).map_err(|e| err(format!("not a linpose model file (not a complete safetensors file: {e})")))?;
    let (_, header) = SafeTensors::read_metadata(bytes).map_err(|e| err(e.to_string()))?;
    let meta = header.metadata().as_ref().ok_or_else(|| err("not a linpose model file (safetensors without linpose metadata)".into()))?;
    if meta.get("format").map(String::as_str) != Some("linpose") {
        return Err(err("not a linpose model file (a safetensors file of another program)".into()));
    }
    let version = meta.get("format_version").ok_or_else(|| err("model file has no format_version".into()))?;
    if version != &FORMAT_VERSION.to_string() {
        let whose = match version.parse::<u32>() {
            Ok(v) if v < FORMAT_VERSION => "an earlier linpose",
            Ok(_) => "a newer linpose",
            Err(_) => "an unknown program",
        };
        return Err(err(format!(
            "model file format version {version} (written by {whose}), but this linpose reads version {FORMAT_VERSION}; retrain the model with this linpose"
        )));
    }
    let mut tensors = Vec::new();
    let mut borrowed = Vec::new();
    for (name, view) in st.tensors() {
        if borrow.contains(&name.as_str()) {
            borrowed.push((name, view));
            continue;
        }
        let data = match view.dtype() {
            Dtype::F32 => TensorData::F32(view.data().chunks_exact(4).map(|c| f32::from_le_bytes(c.try_into().expect("4 bytes"))).collect()),
            Dtype::F64 => TensorData::F64(view.data().chunks_exact(8).map(|c| f64::from_le_bytes(c.try_into().expect("8 bytes"))).collect()),
            d => return Err(err(format!("tensor '{name}' has dtype {d:?}; linpose writes only F32 and F64"))),
        };
        tensors.push(Tensor { name, shape: view.shape().to_vec(), data });
    }
    Ok((meta.clone(), TensorSet { path: path.to_path_buf(), tensors }, borrowed))
}

fn validate_meta(meta: &ModelMeta) -> std::result::Result<(), String> {
    crate::pose::PoseSpace::new(meta.space.params().to_vec()).map_err(|e| format!("damaged metadata: {e}"))?;
    let s = meta.spec;
    if s.width == 0 || s.height == 0 || s.width as u64 * s.height as u64 > crate::image_io::MAX_PIXELS {
        return Err(format!("damaged metadata: image size {}x{}", s.width, s.height));
    }
    if let Some(n) = &meta.normalize {
        n.check_spec(&s).map_err(|e| format!("damaged metadata: {e}"))?;
    }
    if meta.train_poses.is_empty() || !meta.train_poses.len().is_multiple_of(meta.space.len()) {
        return Err(format!("damaged metadata: {} training pose values for {} parameters", meta.train_poses.len(), meta.space.len()));
    }
    Ok(())
}
