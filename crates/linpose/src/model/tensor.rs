//! The named arrays a model is stored as ([`Tensor`]) and, read back from a model file, looked
//! up by name with their shape and type checked ([`TensorSet`]).

use crate::{Error, Result};

/// Element type of a stored array.
#[derive(Debug, Clone, PartialEq)]
pub enum TensorData {
    /// 32-bit floats.
    F32(Vec<f32>),
    /// 64-bit floats.
    F64(Vec<f64>),
}

/// A named array as stored in a model file.
#[derive(Debug, Clone, PartialEq)]
pub struct Tensor {
    /// Its name in the file.
    pub name: String,
    /// Its shape.
    pub shape: Vec<usize>,
    /// Its values, row-major.
    pub data: TensorData,
}

impl Tensor {
    /// An f32 array.
    pub fn f32(name: &str, shape: Vec<usize>, data: Vec<f32>) -> Self {
        debug_assert_eq!(shape.iter().product::<usize>(), data.len());
        Tensor { name: name.into(), shape, data: TensorData::F32(data) }
    }

    /// An f64 array.
    pub fn f64(name: &str, shape: Vec<usize>, data: Vec<f64>) -> Self {
        debug_assert_eq!(shape.iter().product::<usize>(), data.len());
        Tensor { name: name.into(), shape, data: TensorData::F64(data) }
    }
}

/// The arrays read back from a model file, looked up by name with their shape checked; errors
/// name the file.
#[derive(Debug)]
pub struct TensorSet {
    pub(crate) path: std::path::PathBuf,
    pub(crate) tensors: Vec<Tensor>,
}

impl TensorSet {
    fn get(&self, name: &str, shape: &[usize]) -> Result<&Tensor> {
        let t = self.tensors.iter().find(|t| t.name == name).ok_or_else(|| self.error(format!("the model file has no tensor '{name}'")))?;
        if t.shape != shape {
            return Err(self.error(format!("tensor '{name}' has shape {:?}, but the metadata implies {:?}", t.shape, shape)));
        }
        Ok(t)
    }

    /// The f32 tensor `name`, which must have `shape`.
    pub fn f32(&self, name: &str, shape: &[usize]) -> Result<Vec<f32>> {
        match &self.get(name, shape)?.data {
            TensorData::F32(v) => Ok(v.clone()),
            TensorData::F64(_) => Err(self.wrong_type(name, "F32")),
        }
    }

    /// The f64 tensor `name`, which must have `shape`.
    pub fn f64(&self, name: &str, shape: &[usize]) -> Result<Vec<f64>> {
        match &self.get(name, shape)?.data {
            TensorData::F64(v) => Ok(v.clone()),
            TensorData::F32(_) => Err(self.wrong_type(name, "F64")),
        }
    }

    /// An error about this file.
    pub fn error(&self, message: impl Into<String>) -> Error {
        Error::ModelFile { path: self.path.clone(), message: message.into() }
    }

    fn wrong_type(&self, name: &str, want: &str) -> Error {
        self.error(format!("tensor '{name}' must have dtype {want}"))
    }
}
