//! A data set's rows as the kernels read them: f32 features or 8-bit values.

/// A data set's rows as held (row-major, M values a row): f32 features, or the 8-bit values
/// whose features are v / 255 of each (`image_io::feature_of_u8`).
#[derive(Debug, Clone, Copy)]
pub enum Rows<'a> {
    /// Features.
    F32(&'a [f32]),
    /// 8-bit values.
    U8(&'a [u8]),
}

impl Rows<'_> {
    /// Number of values.
    pub fn len(&self) -> usize {
        match self {
            Rows::F32(x) => x.len(),
            Rows::U8(x) => x.len(),
        }
    }

    /// Whether there are no values.
    pub fn is_empty(&self) -> bool {
        self.len() == 0
    }
}
