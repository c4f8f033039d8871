//! Partial statistics files: safetensors like model files (`format = linpose`, the model files'
//! format version), with `kind = partial` and the JSON header under `linpose.partial`: what two
//! partials must share to merge (method, settings, image size, pose parameters, training-set
//! fingerprint, split) and which images or pixels this one holds. The arrays:
//! - shards of images: `xtx_lower` (X^T X's lower triangle packed row by row, f64),
//!   `xtp` (M x K, f64), `ptp` (K, f64);
//! - shards of pixels: `gram_lower` (X X^T's lower triangle packed row by row, f64) and
//!   `pixels.S` (N x w, f32) for each run of pixels from S;
//! - both: `poses` (N x parameters, f64, degrees).
//!
//! Written without a copy of the arrays (header, then each array in chunks) and atomically.

use super::{Header, Partial, Split, Stats};
use crate::atomic::write_atomic_with;
use crate::model::{Settings, TensorData};
use crate::model_file::{read_parts_except, write_parts_to, DataRef, TensorRef};
use crate::normal_equations::NormalEquations;
use crate::{Error, Result};
use serde::{Deserialize, Serialize};
use std::collections::BTreeMap;
use std::path::Path;

pub(crate) use crate::model_file::PARTIAL_KIND;

/// What `linpose.partial` holds.
#[derive(Serialize, Deserialize)]
struct FileHeader {
    header: Header,
    /// Images or pixels held, as [start, end) pairs.
    covered: Vec<[usize; 2]>,
    /// Images summed (shards of images).
    n_summed: usize,
    /// Whether every image summed was 8-bit and summed in integers.
    integer_8bit: bool,
}

impl Partial {
    /// Writes the statistics to `path` atomically; returns the bytes written.
    pub fn save(&self, path: &Path) -> Result<u64> {
        let mut written = 0u64;
        write_atomic_with(path, |w| {
            let mut counting = Counting { inner: w, bytes: 0 };
            self.write_to(&mut counting)?;
            written = counting.bytes;
            Ok(())
        })?;
        Ok(written)
    }

    /// The statistics as the bytes of a file.
    pub fn to_bytes(&self) -> Result<Vec<u8>> {
        let mut out = Vec::with_capacity(self.bytes() + 4096);
        self.write_to(&mut out).map_err(|e| Error::Numerical(format!("serialising partial statistics: {e}")))?;
        Ok(out)
    }

    /// The length of [`Partial::to_bytes`]'s bytes (for a caller that allocates them itself).
    pub fn file_len(&self) -> usize {
        let mut sink = std::io::sink();
        let mut counting = Counting { inner: &mut sink, bytes: 0 };
        self.write_to(&mut counting).expect("writing to a sink cannot fail");
        counting.bytes as usize
    }

    /// Writes [`Partial::to_bytes`]'s bytes into `buf`, which must be [`Partial::file_len`] long.
    pub fn write_into(&self, buf: &mut [u8]) -> Result<()> {
        let len = buf.len();
        let mut rest = &mut buf[..];
        self.write_to(&mut rest).map_err(|e| Error::Numerical(format!("serialising partial statistics into {len} bytes: {e}")))?;
        if !rest.is_empty() {
            return Err(Error::Numerical(format!("partial statistics of {} bytes written into {len}", len - rest.len())));
        }
        Ok(())
    }

    fn write_to(&self, w: &mut dyn std::io::Write) -> std::io::Result<()> {
        fn t<'a>(name: &str, shape: Vec<usize>, data: DataRef<'a>) -> TensorRef<'a> {
            TensorRef { name: name.to_string(), shape, data }
        }
        let h = &self.header;
        let (n, k, np) = (h.n, h.space.encoded_len(), h.space.len());
        let file = FileHeader {
            header: h.clone(),
            covered: self.covered.iter().map(|r| [r.start, r.end]).collect(),
            n_summed: match &self.stats {
                Stats::Images(ne) => ne.n(),
                Stats::Pixels { .. } => 0,
            },
            integer_8bit: matches!(&self.stats, Stats::Images(ne) if ne.integer_8bit()),
        };
        let mut meta = BTreeMap::new();
        meta.insert("kind", PARTIAL_KIND.to_string());
        meta.insert("method", h.method.clone());
        meta.insert("linpose.partial", serde_json::to_string(&file).expect("the header serialises"));
        let write_xtx;
        let mut tensors = vec![t("poses", vec![n, np], DataRef::F64(&self.poses))];
        match &self.stats {
            Stats::Images(ne) => {
                let m = ne.m();
                let (xtp, ptp) = ne.xtp_ptp();
                write_xtx = |w: &mut dyn std::io::Write| ne.write_xtx(w);
                let len = m * (m + 1) / 2;
                tensors.push(t("xtx_lower", vec![len], DataRef::F64With(len, &write_xtx)));
                tensors.push(t("xtp", vec![m, k], DataRef::F64(xtp)));
                tensors.push(t("ptp", vec![k], DataRef::F64(ptp)));
            }
            Stats::Pixels { gram, blocks } => {
                tensors.push(t("gram_lower", vec![gram.len()], DataRef::F64(gram)));
                for (start, cols) in blocks {
                    tensors.push(t(&format!("pixels.{start}"), vec![n, cols.len() / n.max(1)], DataRef::F32(cols)));
                }
            }
        }
        write_parts_to(meta, tensors, w)
    }

    /// Reads partial statistics written by [`Partial::save`].
    pub fn load(path: &Path) -> Result<Partial> {
        let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
        Partial::from_bytes(path, &bytes)
    }

    /// Partial statistics from a file's bytes (`path` names them in errors). X^T X is read from
    /// the bytes where it lies (no copy beside the statistics).
    pub fn from_bytes(path: &Path, bytes: &[u8]) -> Result<Partial> {
        let err = |m: String| Error::ModelFile { path: path.to_path_buf(), message: m };
        let (meta, set, borrowed) = read_parts_except(path, bytes, &["xtx_lower"])?;
        if meta.get("kind").map(String::as_str) != Some(PARTIAL_KIND) {
            return Err(err("not a file of partial training statistics (train --shard I/N --partial writes them); a model file?".into()));
        }
        let json = meta.get("linpose.partial").ok_or_else(|| err("no linpose.partial header".into()))?;
        let file: FileHeader = serde_json::from_str(json).map_err(|e| err(format!("damaged header: {e}")))?;
        let h = file.header;
        let settings = h.settings.iter().fold(Settings::new(), |s, (k, v)| s.set(k.clone(), v.clone()));
        let (method, partial) = match crate::methods::find(&h.method).and_then(|m| Some((m, m.partial?))) {
            Some(found) => found,
            None => return Err(err(format!("statistics of an unknown method '{}'", h.method))),
        };
        let fit = partial(&settings)?;
        let (n, m, k, np) = (h.n, h.spec.features(), h.space.encoded_len(), h.space.len());
        if h.spec.width == 0 || h.spec.height == 0 || h.spec.width as u64 * h.spec.height as u64 > crate::image_io::MAX_PIXELS || n == 0 {
            return Err(err(format!("damaged header: {} images of {}x{}", n, h.spec.width, h.spec.height)));
        }
        let mut tensors = set.tensors;
        let mut take = |name: &str, shape: &[usize]| -> Result<TensorData> {
            let i = tensors.iter().position(|t| t.name == name).ok_or_else(|| err(format!("no tensor '{name}'")))?;
            let t = tensors.swap_remove(i);
            if t.shape != shape {
                return Err(err(format!("tensor '{name}' has shape {:?}, but the header implies {:?}", t.shape, shape)));
            }
            Ok(t.data)
        };
        let f64s = |d: TensorData, name: &str| match d {
            TensorData::F64(v) => Ok(v),
            TensorData::F32(_) => Err(err(format!("tensor '{name}' must have dtype F64"))),
        };
        let poses = f64s(take("poses", &[n, np])?, "poses")?;
        let units = match h.split {
            Split::Images => n,
            Split::Pixels => m,
        };
        let mut covered = Vec::new();
        for &[a, b] in &file.covered {
            if !(a < b && b <= units) || covered.last().is_some_and(|r: &std::ops::Range<usize>| r.end >= a) {
                return Err(err(format!("damaged header: the {} held, {:?}, are not sorted disjoint runs within 0..{units}", h.split.unit(), file.covered)));
            }
            covered.push(a..b);
        }
        let stats = match h.split {
            Split::Images => {
                let xtp = f64s(take("xtp", &[m, k])?, "xtp")?;
                let ptp = f64s(take("ptp", &[k])?, "ptp")?;
                let xtx = match borrowed.first() {
                    Some((_, v)) if v.dtype() == safetensors::Dtype::F64 && v.shape() == [m * (m + 1) / 2] => v.data(),
                    Some((_, v)) => {
                        return Err(err(format!("tensor 'xtx_lower' must be F64 of shape [{}], not {:?} {:?}", m * (m + 1) / 2, v.dtype(), v.shape())))
                    }
                    None => return Err(err("no tensor 'xtx_lower'".into())),
                };
                Stats::Images(Box::new(NormalEquations::from_parts(m, k, file.n_summed, xtx, xtp, ptp, file.integer_8bit)))
            }
            Split::Pixels => {
                if h.names.len() != n {
                    return Err(err(format!("damaged header: {} image names for {n} images", h.names.len())));
                }
                let gram = f64s(take("gram_lower", &[n * (n + 1) / 2])?, "gram_lower")?;
                let mut blocks = Vec::new();
                for t in std::mem::take(&mut tensors) {
                    let Some(start) = t.name.strip_prefix("pixels.").and_then(|s| s.parse::<usize>().ok()) else {
                        tensors.push(t);
                        continue;
                    };
                    match (t.shape.as_slice(), t.data) {
                        (&[rows, w], TensorData::F32(v)) if rows == n && w > 0 => blocks.push((start, v)),
                        _ => return Err(err(format!("tensor '{}' must be F32 of shape [{n}, pixels]", t.name))),
                    }
                }
                // The runs of pixels held must be exactly the header's.
                blocks.sort_by_key(|b| b.0);
                let mut runs: Vec<std::ops::Range<usize>> = Vec::new();
                for (start, v) in &blocks {
                    let r = *start..start + v.len() / n;
                    match runs.last_mut() {
                        Some(last) if last.end == r.start => last.end = r.end,
                        _ => runs.push(r),
                    }
                }
                if runs != covered {
                    return Err(err(format!("damaged file: its pixel arrays hold {runs:?}, its header says {covered:?}")));
                }
                Stats::Pixels { gram, blocks }
            }
        };
        if let Some(t) = tensors.first() {
            return Err(err(format!("an unexpected tensor '{}' (for the runs held, {:?})", t.name, file.covered)));
        }
        Ok(Partial { header: h, method, fit, poses, covered, stats, source: path.display().to_string() })
    }
}

/// A writer that counts the bytes through it.
struct Counting<'a> {
    inner: &'a mut dyn std::io::Write,
    bytes: u64,
}

impl std::io::Write for Counting<'_> {
    fn write(&mut self, buf: &[u8]) -> std::io::Result<usize> {
        let n = self.inner.write(buf)?;
        self.bytes += n as u64;
        Ok(n)
    }
    fn flush(&mut self) -> std::io::Result<()> {
        self.inner.flush()
    }
}
