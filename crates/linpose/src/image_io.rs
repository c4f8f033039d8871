//! Reading images into feature vectors.
//!
//! A gray image gives one feature per pixel, its brightness in [0, 1] (8-bit values / 255,
//! 16-bit values / 65535). RGB becomes gray with Rec. 601 luma computed exactly as PIL's
//! `convert("L")` does (so linpose and a numpy/PIL implementation see the same numbers), or keeps its three
//! channels as features with [`ColorMode::Rgb`]. Alpha is ignored; palette images are expanded.
//!
//! The formats read are PNG, PNM (PGM/PPM), JPEG and TIFF, told apart by the file's first
//! bytes (never by its name):
//!
//! - PNG: 1- to 16-bit gray, gray+alpha, palette, RGB and RGBA. PNM: 8- and 16-bit gray (PGM)
//!   and RGB (PPM).
//! - JPEG (baseline and progressive, 8-bit): gray and colour (YCbCr or RGB). A CMYK JPEG (four
//!   components) and a 12-bit one are refused, as is a file that ends before its end-of-image
//!   marker (a truncated file, which the decoder would otherwise fill in without a word). The
//!   EXIF orientation is not applied: pixels are read as stored.
//! - TIFF (uncompressed or compressed; the first image of the file): 1-, 8- and 16-bit gray,
//!   gray+alpha, RGB and RGBA. Floating-point samples, CMYK, palette and YCbCr TIFFs are refused.
//!
//! Every check of the header - format, size against `MAX_PIXELS` (2^26 pixels), colour type - comes before
//! any pixel is allocated.

#[cfg(test)]
mod format_tests;
mod jpeg;

use crate::{Error, Result};
use image::{DynamicImage, ExtendedColorType, ImageDecoder, ImageError, ImageFormat, ImageReader};
use serde::{Deserialize, Serialize};
use std::io::Cursor;
use std::path::Path;

/// Largest image accepted, in pixels (refused before its pixels are allocated).
pub(crate) const MAX_PIXELS: u64 = 1 << 26;

/// How colour images become features.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Serialize, Deserialize)]
#[serde(rename_all = "lowercase")]
pub enum ColorMode {
    /// One feature per pixel: brightness (Rec. 601 luma for colour images).
    #[default]
    Gray,
    /// Three features per pixel: red, green, blue (gray images repeat their value).
    Rgb,
}

impl ColorMode {
    /// Features per pixel.
    pub fn channels(self) -> usize {
        match self {
            ColorMode::Gray => 1,
            ColorMode::Rgb => 3,
        }
    }
}

/// The size and colour handling of the images a model was trained on.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub struct ImageSpec {
    /// Width in pixels.
    pub width: u32,
    /// Height in pixels.
    pub height: u32,
    /// Colour handling.
    pub color: ColorMode,
}

impl ImageSpec {
    /// Number of features M of one image.
    pub fn features(&self) -> usize {
        self.width as usize * self.height as usize * self.color.channels()
    }
}

/// A query image decoded for a model: its 8-bit gray values when it has them (the models' fast
/// 8-bit path, [`crate::PoseModel::predict_u8_into`]), else its features.
#[derive(Debug, Clone, PartialEq)]
pub enum QueryImage {
    /// 8-bit gray values (feature = value / 255), row-major.
    Gray8(Vec<u8>),
    /// Features (gray values in [0, 1], or three channels per pixel).
    Features(Vec<f32>),
}

impl QueryImage {
    /// Its features, converting 8-bit values exactly as the data set reader does.
    pub fn into_features(self) -> Vec<f32> {
        match self {
            QueryImage::Gray8(v) => v.iter().map(|&k| k as f32 * crate::kernels::levels::S8).collect(),
            QueryImage::Features(f) => f,
        }
    }
}

/// Reads the image file at `path` as a query for a model trained on images of `spec`: an image
/// of another size is an [`Error::ImageSizeMismatch`] naming `context` (e.g. the model file).
pub fn read_query(path: &Path, spec: ImageSpec, context: &str) -> Result<QueryImage> {
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    let (w, h) = dimensions(path, &bytes)?;
    if (w, h) != (spec.width, spec.height) {
        return Err(Error::ImageSizeMismatch {
            path: path.to_path_buf(),
            expected_w: spec.width,
            expected_h: spec.height,
            got_w: w,
            got_h: h,
            context: context.to_string(),
        });
    }
    let img = decode(path, &bytes)?;
    let mut v8 = Vec::with_capacity(spec.features());
    if push_u8_gray(&img, spec.color, &mut v8) {
        return Ok(QueryImage::Gray8(v8));
    }
    let mut f = Vec::with_capacity(spec.features());
    push_features(&img, spec.color, &mut f);
    Ok(QueryImage::Features(f))
}

/// Reads the image file at `path` whatever its size (a scene larger than the training views):
/// its spec in `color` and its features.
pub fn read_any_size(path: &Path, color: ColorMode) -> Result<(ImageSpec, Vec<f32>)> {
    let (width, height, q) = read_image(path, color)?;
    Ok((ImageSpec { width, height, color }, q.into_features()))
}

/// Reads the image file at `path`, whatever its size: its width, height and values as
/// [`read_query`] gives them (8-bit gray values when it has them, else features).
pub(crate) fn read_image(path: &Path, color: ColorMode) -> Result<(u32, u32, QueryImage)> {
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    let (w, h) = dimensions(path, &bytes)?;
    let img = decode(path, &bytes)?;
    let mut v8 = Vec::with_capacity(w as usize * h as usize);
    if push_u8_gray(&img, color, &mut v8) {
        return Ok((w, h, QueryImage::Gray8(v8)));
    }
    let mut f = Vec::with_capacity(w as usize * h as usize * color.channels());
    push_features(&img, color, &mut f);
    Ok((w, h, QueryImage::Features(f)))
}

/// Reads the image file at `path` as 8-bit pixels in its own colour: one channel for a gray
/// image, three interleaved (R, G, B) for a colour one; 16-bit values rounded to 8 bits, alpha
/// dropped. The returned spec's colour mode says which.
#[cfg(feature = "render")] // used by the renderer and the scenes only
pub(crate) fn read_u8(path: &Path) -> Result<(ImageSpec, Vec<u8>)> {
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    let img = decode(path, &bytes)?;
    let (width, height) = (img.width(), img.height());
    Ok(match img {
        DynamicImage::ImageLuma8(g) => (ImageSpec { width, height, color: ColorMode::Gray }, g.into_raw()),
        img if !img.color().has_color() => (ImageSpec { width, height, color: ColorMode::Gray }, img.to_luma8().into_raw()),
        DynamicImage::ImageRgb8(c) => (ImageSpec { width, height, color: ColorMode::Rgb }, c.into_raw()),
        img => (ImageSpec { width, height, color: ColorMode::Rgb }, img.to_rgb8().into_raw()),
    })
}

/// The feature of an 8-bit value `v`: v / 255 as an f32, the same bits the image reader makes
/// of an 8-bit pixel (so features made from pixels in memory match those read from files).
#[inline]
pub fn feature_of_u8(v: u8) -> f32 {
    crate::kernels::levels::feature_of_u8(v)
}

/// The feature of a 16-bit value `v`: v / 65535 as an f32, as the image reader makes it.
#[inline]
pub fn feature_of_u16(v: u16) -> f32 {
    v as f32 * S16
}

/// 1 / 65535: the feature scale of 16-bit values.
const S16: f32 = 1.0 / 65535.0;

/// PIL's integer Rec. 601 luma: L = (19595 R + 38470 G + 7471 B + 2^15) >> 16.
#[inline]
pub(crate) fn luma601(r: u8, g: u8, b: u8) -> u8 {
    ((r as u32 * 19595 + g as u32 * 38470 + b as u32 * 7471 + 0x8000) >> 16) as u8
}

/// Decodes the image file at `path`, returning its size and appending its features to `out`.
/// With `expect`, an image of another size is an [`Error::ImageSizeMismatch`] naming `context`.
pub(crate) fn read_features(path: &Path, color: ColorMode, expect: Option<(u32, u32)>, context: &str, out: &mut Vec<f32>) -> Result<(u32, u32)> {
    let bytes = std::fs::read(path).map_err(|e| Error::io(path, e))?;
    decode_features(path, &bytes, color, expect, context, out)
}

/// As [`read_features`], from bytes already in memory (`path` only names them in errors).
pub(crate) fn decode_features(
    path: &Path,
    bytes: &[u8],
    color: ColorMode,
    expect: Option<(u32, u32)>,
    context: &str,
    out: &mut Vec<f32>,
) -> Result<(u32, u32)> {
    // The declared size is checked against the expected one before any pixel is allocated.
    let (w, h) = dimensions(path, bytes)?;
    if let Some((ew, eh)) = expect {
        if (w, h) != (ew, eh) {
            return Err(Error::ImageSizeMismatch {
                path: path.to_path_buf(),
                expected_w: ew,
                expected_h: eh,
                got_w: w,
                got_h: h,
                context: context.to_string(),
            });
        }
    }
    let img = decode(path, bytes)?;
    push_features(&img, color, out);
    Ok((w, h))
}

/// File name extensions (lower case) of the images linpose reads: what `linpose predict` takes
/// from a folder. The format itself is told by the file's first bytes, not by its name.
pub(crate) const IMAGE_EXTENSIONS: &[&str] = &["png", "pgm", "ppm", "pnm", "jpg", "jpeg", "tif", "tiff"];

/// Whether `path` ends in one of the extensions linpose reads (png, pgm, ppm, pnm, jpg, jpeg, tif, tiff), in any case.
pub fn has_image_extension(path: &Path) -> bool {
    path.extension().and_then(|e| e.to_str()).is_some_and(|e| IMAGE_EXTENSIONS.iter().any(|x| e.eq_ignore_ascii_case(x)))
}

/// The formats read, for messages.
const READS: &str = "PNG, PNM (PGM/PPM), JPEG and TIFF images";

/// Why a JPEG without an end-of-image marker after its scan is refused.
const TRUNCATED_JPEG: &str = "the JPEG data ends before its end-of-image marker: the file is truncated or damaged";

/// The format linpose reads that `f` is, by name; `None` for the others.
fn format_name(f: ImageFormat) -> Option<&'static str> {
    match f {
        ImageFormat::Png => Some("PNG"),
        ImageFormat::Pnm => Some("PNM"),
        ImageFormat::Jpeg => Some("JPEG"),
        ImageFormat::Tiff => Some("TIFF"),
        _ => None,
    }
}

/// An [`Error::ImageDecode`] for an image whose bytes are `format`; when the file's name says
/// another format (a JPEG named `.png`), the reason begins by saying so.
fn refuse(path: &Path, format: ImageFormat, reason: String) -> Error {
    let named = path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase);
    let reason = match named.as_deref().and_then(ImageFormat::from_extension) {
        Some(n) if n != format && has_image_extension(path) => {
            format!("{} data in a .{} file: {reason}", format_name(format).unwrap_or("other"), named.unwrap_or_default())
        }
        _ => reason,
    };
    Error::ImageDecode { path: path.to_path_buf(), reason }
}

/// What the decoder of `format` said, made an [`Error::ImageDecode`] that says what is wrong.
fn decode_error(path: &Path, format: ImageFormat, e: ImageError) -> Error {
    let kind = format_name(format).unwrap_or("image");
    let said = e.to_string();
    let said = said.trim_end();
    let reason = match &e {
        ImageError::IoError(io) if io.kind() == std::io::ErrorKind::UnexpectedEof => {
            format!("the {kind} data ends early: the file is truncated or damaged ({said})")
        }
        ImageError::Unsupported(_) if format == ImageFormat::Tiff => {
            format!("a TIFF of a kind linpose does not read ({said}); it reads 1-, 8- and 16-bit gray, gray+alpha, RGB and RGBA TIFFs")
        }
        _ => said.to_string(),
    };
    refuse(path, format, reason)
}

/// The width and height an image file declares, read from its header; refuses a file that is
/// not a PNG, PNM, JPEG or TIFF image, a size of no pixels or over 2^26, and the kinds
/// of image the [module](self) lists as refused - all before any pixel is allocated.
pub(crate) fn dimensions(path: &Path, bytes: &[u8]) -> Result<(u32, u32)> {
    if bytes.is_empty() {
        return Err(Error::ImageDecode { path: path.to_path_buf(), reason: "the file is empty".into() });
    }
    let reader = ImageReader::new(Cursor::new(bytes)).with_guessed_format().map_err(|e| Error::io(path, e))?;
    let format = match reader.format() {
        None => return Err(Error::ImageDecode { path: path.to_path_buf(), reason: "not a PNG, PNM (PGM/PPM), JPEG or TIFF image".into() }),
        // A GIF or WebP behind a .png name: say what it is.
        Some(f) if format_name(f).is_none() => {
            let kind = format!("{f:?}").to_ascii_uppercase();
            return Err(Error::ImageDecode { path: path.to_path_buf(), reason: format!("a {kind} image; linpose reads {READS}") });
        }
        Some(f) => f,
    };
    let markers = (format == ImageFormat::Jpeg).then(|| jpeg::markers(bytes));
    if let Some(jpeg::Frame { precision, components }) = markers.and_then(|m| m.frame) {
        match components {
            1 | 3 => {}
            4 => {
                return Err(refuse(
                    path,
                    format,
                    "a CMYK JPEG (four colour components); linpose reads gray and colour (YCbCr or RGB) JPEGs: convert it to RGB".into(),
                ))
            }
            n => return Err(refuse(path, format, format!("a JPEG of {n} colour components; linpose reads gray (1) and colour (3) JPEGs"))),
        }
        if precision != 8 {
            return Err(refuse(path, format, format!("a {precision}-bit JPEG; linpose reads 8-bit JPEGs")));
        }
    }
    let decoder = reader.into_decoder().map_err(|e| match markers {
        // A JPEG cut short in its headers: say so, whatever the decoder missed.
        Some(m) if !m.ends => refuse(path, format, format!("{TRUNCATED_JPEG} ({})", e.to_string().trim_end())),
        _ => decode_error(path, format, e),
    })?;
    let (w, h) = decoder.dimensions();
    if w == 0 || h == 0 {
        return Err(Error::ImageDecode { path: path.to_path_buf(), reason: format!("the image has no pixels ({w}x{h})") });
    }
    if w as u64 * h as u64 > MAX_PIXELS {
        return Err(Error::ImageTooLarge { path: path.to_path_buf(), width: w, height: h, limit: MAX_PIXELS });
    }
    let kind = format_name(format).unwrap_or("image");
    if matches!(decoder.original_color_type(), ExtendedColorType::Cmyk8 | ExtendedColorType::Cmyk16) {
        return Err(refuse(path, format, format!("a CMYK {kind}; linpose reads gray and RGB images: convert it to RGB")));
    }
    if matches!(decoder.color_type(), image::ColorType::Rgb32F | image::ColorType::Rgba32F) {
        return Err(refuse(path, format, format!("a {kind} of floating-point samples; linpose reads 8- and 16-bit integer samples: convert it to 16-bit")));
    }
    if markers.is_some_and(|m| !m.ends) {
        return Err(refuse(path, format, TRUNCATED_JPEG.into()));
    }
    Ok((w, h))
}

/// Decodes an image, refusing absurd sizes and the kinds [`dimensions`] refuses before
/// allocating their pixels.
pub(crate) fn decode(path: &Path, bytes: &[u8]) -> Result<DynamicImage> {
    let (w, h) = dimensions(path, bytes)?;
    let mut reader = ImageReader::new(Cursor::new(bytes)).with_guessed_format().map_err(|e| Error::io(path, e))?;
    let format = reader.format().expect("dimensions() told the format");
    let mut limits = image::Limits::default();
    limits.max_image_width = Some(w);
    limits.max_image_height = Some(h);
    limits.max_alloc = Some(MAX_PIXELS * 8 + (1 << 20));
    reader.limits(limits);
    reader.decode().map_err(|e| decode_error(path, format, e))
}

/// Appends the features of a decoded image.
pub(crate) fn push_features(img: &DynamicImage, color: ColorMode, out: &mut Vec<f32>) {
    // The integer Gram kernels read features back as levels by this same constant.
    use crate::kernels::levels::S8;
    match (img, color) {
        (DynamicImage::ImageLuma8(g), ColorMode::Gray) => out.extend(g.as_raw().iter().map(|&v| v as f32 * S8)),
        (DynamicImage::ImageLumaA8(g), ColorMode::Gray) => out.extend(g.as_raw().chunks_exact(2).map(|p| p[0] as f32 * S8)),
        (DynamicImage::ImageRgb8(c), ColorMode::Gray) => out.extend(c.as_raw().chunks_exact(3).map(|p| luma601(p[0], p[1], p[2]) as f32 * S8)),
        (DynamicImage::ImageRgba8(c), ColorMode::Gray) => out.extend(c.as_raw().chunks_exact(4).map(|p| luma601(p[0], p[1], p[2]) as f32 * S8)),
        (DynamicImage::ImageLuma16(g), ColorMode::Gray) => out.extend(g.as_raw().iter().map(|&v| v as f32 * S16)),
        (DynamicImage::ImageLumaA16(g), ColorMode::Gray) => out.extend(g.as_raw().chunks_exact(2).map(|p| p[0] as f32 * S16)),
        (_, ColorMode::Gray) => {
            // 16-bit or float colour: Rec. 601 weights in floating point.
            let c = img.to_rgb32f();
            out.extend(c.as_raw().chunks_exact(3).map(|p| 0.299 * p[0] + 0.587 * p[1] + 0.114 * p[2]))
        }
        (DynamicImage::ImageRgb8(c), ColorMode::Rgb) => out.extend(c.as_raw().iter().map(|&v| v as f32 * S8)),
        (_, ColorMode::Rgb) => {
            let c = img.to_rgb32f();
            out.extend_from_slice(c.as_raw())
        }
    }
}

/// Appends an 8-bit image's gray features as their raw values (feature = value / 255) and
/// returns true; returns false, appending nothing, for an image that is not 8-bit or a colour
/// mode that is not gray. The values are exactly those [`push_features`] divides by 255.
pub(crate) fn push_u8_gray(img: &DynamicImage, color: ColorMode, out: &mut Vec<u8>) -> bool {
    if color != ColorMode::Gray {
        return false;
    }
    match img {
        DynamicImage::ImageLuma8(g) => out.extend_from_slice(g.as_raw()),
        DynamicImage::ImageLumaA8(g) => out.extend(g.as_raw().chunks_exact(2).map(|p| p[0])),
        DynamicImage::ImageRgb8(c) => out.extend(c.as_raw().chunks_exact(3).map(|p| luma601(p[0], p[1], p[2]))),
        DynamicImage::ImageRgba8(c) => out.extend(c.as_raw().chunks_exact(4).map(|p| luma601(p[0], p[1], p[2]))),
        _ => return false,
    }
    true
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn luma_is_pils_rec601() {
        // PIL: Image.new("RGB", (1, 1), c).convert("L").getpixel((0, 0))
        for (c, want) in [((255, 255, 255), 255), ((0, 0, 0), 0), ((255, 0, 0), 76), ((0, 255, 0), 150), ((0, 0, 255), 29), ((10, 200, 30), 124)] {
            assert_eq!(luma601(c.0, c.1, c.2), want, "{c:?}");
        }
    }

    #[test]
    fn features_per_colour_mode() {
        let img = DynamicImage::ImageRgb8(image::RgbImage::from_pixel(2, 1, image::Rgb([255, 0, 0])));
        let mut g = Vec::new();
        push_features(&img, ColorMode::Gray, &mut g);
        assert_eq!(g, vec![76.0 / 255.0; 2]);
        let mut c = Vec::new();
        push_features(&img, ColorMode::Rgb, &mut c);
        assert_eq!(c, vec![1.0, 0.0, 0.0, 1.0, 0.0, 0.0]);
        let g16 = DynamicImage::ImageLuma16(image::ImageBuffer::from_pixel(1, 1, image::Luma([65535u16])));
        let mut v = Vec::new();
        push_features(&g16, ColorMode::Gray, &mut v);
        assert_eq!(v, vec![1.0]);
    }
}
