//! The bytes of a linpose safetensors file: the header (metadata sorted, so the same model always
//! gives the same bytes) and the tensors, written without a copy of their values. A pose model
//! writes itself through these ([`super::PoseModel::save`]); `crate::model_file` reads files back
//! and writes many-object models, and `crate::partial` writes partial statistics.

use super::{PoseModel, Tensor, TensorData};
use crate::atomic::write_atomic;
use crate::{Error, Result};
use safetensors::tensor::Dtype;
use std::collections::BTreeMap;
use std::path::Path;

/// The model file format version this linpose writes and reads. Files of another version are
/// refused with a message that says to retrain: the format has no compatibility layer.
pub const FORMAT_VERSION: u32 = 7;

/// The file's bytes: the `meta` entries with the format and its version, then the tensors.
pub(crate) fn write_parts(meta: BTreeMap<&str, String>, tensors: Vec<Tensor>) -> Result<Vec<u8>> {
    let refs: Vec<TensorRef<'_>> = tensors
        .iter()
        .map(|t| TensorRef {
            name: t.name.clone(),
            shape: t.shape.clone(),
            data: match &t.data {
                TensorData::F32(v) => DataRef::F32(v),
                TensorData::F64(v) => DataRef::F64(v),
            },
        })
        .collect();
    let mut out = Vec::new();
    write_parts_to(meta, refs, &mut out).map_err(|e| Error::Numerical(format!("serialising: {e}")))?;
    Ok(out)
}

/// A named array whose values are borrowed, for [`write_parts_to`].
pub(crate) struct TensorRef<'a> {
    pub name: String,
    pub shape: Vec<usize>,
    pub data: DataRef<'a>,
}

/// Borrowed values of a [`TensorRef`].
pub(crate) enum DataRef<'a> {
    F32(&'a [f32]),
    F64(&'a [f64]),
    /// This many f64 values, which the function writes (little-endian) when the file is written.
    F64With(usize, &'a dyn Fn(&mut dyn std::io::Write) -> std::io::Result<()>),
}

/// Writes [`write_parts`]'s bytes to `w` without a copy of the values: the header, then each
/// tensor's values in chunks (what a large file, such as partial statistics, needs).
pub(crate) fn write_parts_to(mut meta: BTreeMap<&str, String>, mut tensors: Vec<TensorRef<'_>>, w: &mut dyn std::io::Write) -> std::io::Result<()> {
    let dtype = |t: &TensorRef<'_>| match t.data {
        DataRef::F32(_) => Dtype::F32,
        DataRef::F64(_) | DataRef::F64With(..) => Dtype::F64,
    };
    tensors.sort_by(|a, b| dtype(b).cmp(&dtype(a)).then_with(|| a.name.cmp(&b.name)));
    meta.insert("format", "linpose".to_string());
    meta.insert("format_version", FORMAT_VERSION.to_string());
    let mut header = format!("{{\"__metadata__\":{}", json(&meta));
    let mut offset = 0;
    for t in &tensors {
        let bytes = match t.data {
            DataRef::F32(v) => v.len() * 4,
            DataRef::F64(v) => v.len() * 8,
            DataRef::F64With(n, _) => n * 8,
        };
        let n: usize = t.shape.iter().product();
        if n * dtype(t).bitsize() / 8 != bytes {
            return Err(std::io::Error::other(format!("tensor '{}' has shape {:?} but {bytes} bytes", t.name, t.shape)));
        }
        header.push_str(&format!(
            ",{}:{{\"dtype\":{},\"shape\":{},\"data_offsets\":[{offset},{}]}}",
            json(&t.name),
            json(&dtype(t)),
            json(&t.shape),
            offset + bytes
        ));
        offset += bytes;
    }
    header.push('}');
    // safetensors pads the header with spaces to a multiple of 8 bytes (alignment of the data).
    while header.len() % 8 != 0 {
        header.push(' ');
    }
    w.write_all(&(header.len() as u64).to_le_bytes())?;
    w.write_all(header.as_bytes())?;
    let mut buf = Vec::with_capacity(1 << 16);
    for t in &tensors {
        match t.data {
            DataRef::F32(v) => {
                for c in v.chunks(1 << 13) {
                    buf.clear();
                    buf.extend(c.iter().flat_map(|x| x.to_le_bytes()));
                    w.write_all(&buf)?;
                }
            }
            DataRef::F64(v) => {
                for c in v.chunks(1 << 13) {
                    buf.clear();
                    buf.extend(c.iter().flat_map(|x| x.to_le_bytes()));
                    w.write_all(&buf)?;
                }
            }
            DataRef::F64With(_, write) => write(w)?,
        }
    }
    Ok(())
}

/// A plain value as compact JSON.
fn json<T: serde::Serialize + ?Sized>(v: &T) -> String {
    serde_json::to_string(v).expect("plain values serialise")
}

/// A pose model's file bytes: its method and metadata (`linpose.meta`), then its arrays.
///
/// The header is written here rather than by `safetensors::serialize`, whose metadata map is a
/// `HashMap`: its order, and so the file's bytes, would change from run to run. Here the
/// metadata keys are sorted and the tensors laid out as safetensors does (by decreasing
/// alignment, then name), so the same model always gives the same bytes.
pub(super) fn model_bytes<M: PoseModel + ?Sized>(model: &M) -> Result<Vec<u8>> {
    model_bytes_with(model, &[])
}

/// [`model_bytes`] with more metadata entries (a stage's settings, [`crate::robust::Robust`]).
pub(crate) fn model_bytes_with<M: PoseModel + ?Sized>(model: &M, extra: &[(&'static str, String)]) -> Result<Vec<u8>> {
    let mut meta = BTreeMap::new();
    for (k, v) in extra {
        meta.insert(*k, v.clone());
    }
    meta.insert("method", model.meta().method.clone());
    meta.insert("linpose.meta", serde_json::to_string(model.meta()).expect("meta serialises"));
    write_parts(meta, model.tensors())
}

/// Writes `bytes` to `path` atomically (temporary name, then rename): their length.
pub(crate) fn save_bytes(bytes: &[u8], path: &Path) -> Result<u64> {
    write_atomic(path, bytes)?;
    Ok(bytes.len() as u64)
}
