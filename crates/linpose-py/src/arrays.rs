//! Images from numpy: a 2-D array of one image per row, or a 3-D one of (n, h, w) images read as
//! n rows of h w values (no reshape needed in Python, a fresh view object less per call), in
//! `uint8`, `uint16`, `float32` or `float64`. 8- and 16-bit values
//! become features as the image reader makes them (v / 255, v / 65535); floats are features as
//! they are. A C-contiguous `uint8` or `float32` array is read in place.

use numpy::{PyArrayDyn, PyArrayMethods, PyReadonlyArrayDyn, PyUntypedArrayMethods};
use pyo3::exceptions::{PyTypeError, PyValueError};
use pyo3::prelude::*;
use rayon::prelude::*;
use std::borrow::Cow;

/// Images as numpy gave them.
pub(crate) enum Pixels<'py> {
    U8(PyReadonlyArrayDyn<'py, u8>),
    U16(PyReadonlyArrayDyn<'py, u16>),
    F32(PyReadonlyArrayDyn<'py, f32>),
    F64(PyReadonlyArrayDyn<'py, f64>),
}

/// Reads `x` as images; `what` names it in errors.
pub(crate) fn pixels<'py>(x: &Bound<'py, PyAny>, what: &str) -> PyResult<Pixels<'py>> {
    let busy = |e: numpy::BorrowError| PyValueError::new_err(format!("{what}: {e}"));
    let kind =
        || PyTypeError::new_err(format!("{what} must be a 2-D or 3-D numpy array of uint8, uint16, float32 or float64 (one image per row, or (n, h, w))"));
    let p = if let Ok(a) = x.cast::<PyArrayDyn<u8>>() {
        Pixels::U8(a.try_readonly().map_err(busy)?)
    } else if let Ok(a) = x.cast::<PyArrayDyn<f32>>() {
        Pixels::F32(a.try_readonly().map_err(busy)?)
    } else if let Ok(a) = x.cast::<PyArrayDyn<f64>>() {
        Pixels::F64(a.try_readonly().map_err(busy)?)
    } else if let Ok(a) = x.cast::<PyArrayDyn<u16>>() {
        Pixels::U16(a.try_readonly().map_err(busy)?)
    } else {
        return Err(kind());
    };
    match p.dims().len() {
        2 | 3 => Ok(p),
        _ => Err(kind()),
    }
}

impl Pixels<'_> {
    fn dims(&self) -> &[usize] {
        match self {
            Pixels::U8(a) => a.shape(),
            Pixels::U16(a) => a.shape(),
            Pixels::F32(a) => a.shape(),
            Pixels::F64(a) => a.shape(),
        }
    }

    /// (rows, values per row): (n, h w) for (n, h, w) images.
    pub(crate) fn shape(&self) -> (usize, usize) {
        let s = self.dims();
        (s[0], s[1..].iter().product())
    }

    /// The 8-bit values in place, when they are C-contiguous `uint8`.
    pub(crate) fn u8_slice(&self) -> Option<&[u8]> {
        match self {
            Pixels::U8(a) => a.as_slice().ok(),
            _ => None,
        }
    }

    /// The features: borrowed from a C-contiguous `float32` array, else converted (8-bit and
    /// 16-bit values scaled as the image reader scales them). A value that is not finite is a
    /// `ValueError` naming its row.
    pub(crate) fn features(&self, what: &str) -> PyResult<Cow<'_, [f32]>> {
        let f: Cow<'_, [f32]> = match self {
            Pixels::F32(a) => match a.as_slice() {
                Ok(s) => Cow::Borrowed(s),
                Err(_) => Cow::Owned(a.as_array().iter().copied().collect()),
            },
            Pixels::F64(a) => Cow::Owned(a.as_array().iter().map(|&v| v as f32).collect()),
            Pixels::U8(a) => Cow::Owned(match a.as_slice() {
                Ok(s) => s.par_iter().map(|&v| linpose::image_io::feature_of_u8(v)).collect(),
                Err(_) => a.as_array().iter().map(|&v| linpose::image_io::feature_of_u8(v)).collect(),
            }),
            Pixels::U16(a) => Cow::Owned(a.as_array().iter().map(|&v| linpose::image_io::feature_of_u16(v)).collect()),
        };
        if matches!(self, Pixels::F32(_) | Pixels::F64(_)) {
            let m = self.shape().1.max(1);
            if let Some(i) = f.iter().position(|v| !v.is_finite()) {
                return Err(PyValueError::new_err(format!("{what}: image {} has a value that is not finite (NaN or infinity)", i / m)));
            }
        }
        Ok(f)
    }
}
