//! JPEG and TIFF, written by the `image` crate's own encoders, read through the same paths as
//! PNG: exact where the format is lossless, within a stated tolerance where it is not, refused
//! with a message naming the file where it is damaged or of a kind linpose does not read.

use super::*;
use image::codecs::jpeg::JpegEncoder;
use image::{GrayImage, ImageBuffer, Luma, Rgb, RgbImage, Rgba, RgbaImage};
use std::path::PathBuf;

const W: u32 = 16;
const H: u32 = 12;

fn encode(img: &DynamicImage, format: ImageFormat) -> Vec<u8> {
    let mut out = Cursor::new(Vec::new());
    img.write_to(&mut out, format).unwrap();
    out.into_inner()
}

fn jpeg(img: &DynamicImage, quality: u8) -> Vec<u8> {
    let mut out = Vec::new();
    JpegEncoder::new_with_quality(&mut out, quality).encode_image(img).unwrap();
    out
}

/// A smooth gradient with a bright blob: what a turntable view looks like, and gentle enough
/// for JPEG to keep close.
fn gray8() -> GrayImage {
    GrayImage::from_fn(W, H, |x, y| {
        let d2 = (x as f64 - 9.0).powi(2) + (y as f64 - 5.0).powi(2);
        Luma([(20.0 + 6.0 * x as f64 + 4.0 * y as f64 + 120.0 * (-d2 / 12.0).exp()).round() as u8])
    })
}

fn gray16() -> ImageBuffer<Luma<u16>, Vec<u16>> {
    // Every value distinct from its 8-bit rounding: a 16-bit path that kept only 8 bits shows.
    ImageBuffer::from_fn(W, H, |x, y| Luma([(x * 4001 + y * 257 + 3) as u16]))
}

fn rgb8() -> RgbImage {
    let g = gray8();
    RgbImage::from_fn(W, H, |x, y| {
        let v = g.get_pixel(x, y).0[0];
        Rgb([v, v / 2 + 60, 255 - v / 3])
    })
}

fn features(bytes: &[u8], color: ColorMode) -> Vec<f32> {
    let mut out = Vec::new();
    assert_eq!(decode_features(Path::new("x"), bytes, color, Some((W, H)), "test", &mut out).unwrap(), (W, H));
    out
}

/// `read_query` of `bytes` written to a file named `name`.
fn query(name: &str, bytes: &[u8], color: ColorMode) -> QueryImage {
    let t = tempfile::tempdir().unwrap();
    let p = t.path().join(name);
    std::fs::write(&p, bytes).unwrap();
    read_query(&p, ImageSpec { width: W, height: H, color }, "the test").unwrap()
}

fn err(path: &str, bytes: &[u8]) -> String {
    let e = decode(Path::new(path), bytes).map(|_| ()).unwrap_err();
    let s = e.to_string();
    assert!(s.contains(path), "error does not name {path}: {s}");
    s
}

#[test]
fn tiff_gray_8_and_16_bit_are_exactly_the_pngs() {
    let g8 = DynamicImage::ImageLuma8(gray8());
    let (tif, png) = (encode(&g8, ImageFormat::Tiff), encode(&g8, ImageFormat::Png));
    assert_eq!(&tif[..4], b"II*\0");
    for color in [ColorMode::Gray, ColorMode::Rgb] {
        assert_eq!(features(&tif, color), features(&png, color), "{color:?}");
    }
    // The 8-bit fast path: the very pixels.
    assert_eq!(query("a.tif", &tif, ColorMode::Gray), QueryImage::Gray8(gray8().into_raw()));
    assert_eq!(query("a.tif", &tif, ColorMode::Gray).into_features(), features(&png, ColorMode::Gray));

    let g16 = DynamicImage::ImageLuma16(gray16());
    let (tif, png) = (encode(&g16, ImageFormat::Tiff), encode(&g16, ImageFormat::Png));
    for color in [ColorMode::Gray, ColorMode::Rgb] {
        assert_eq!(features(&tif, color), features(&png, color), "{color:?}");
    }
    let want: Vec<f32> = gray16().into_raw().iter().map(|&v| v as f32 * (1.0 / 65535.0)).collect();
    assert_eq!(features(&tif, ColorMode::Gray), want);
    // Not 8-bit: no fast path, the 16-bit features.
    assert_eq!(query("a.tiff", &tif, ColorMode::Gray), QueryImage::Features(want));
}

#[test]
fn tiff_rgb_and_rgba_are_exactly_the_pngs() {
    let rgb = rgb8();
    let rgba = RgbaImage::from_fn(W, H, |x, y| {
        let p = rgb.get_pixel(x, y).0;
        Rgba([p[0], p[1], p[2], (x * 16) as u8])
    });
    let rgb16 = ImageBuffer::<Rgb<u16>, Vec<u16>>::from_fn(W, H, |x, y| Rgb([(x * 4001) as u16, (y * 5003) as u16, (x * y * 300 + 7) as u16]));
    let rgba16 = ImageBuffer::<Rgba<u16>, Vec<u16>>::from_fn(W, H, |x, y| Rgba([(x * 4001) as u16, (y * 5003) as u16, 9, (x * 999) as u16]));
    let images = [DynamicImage::ImageRgb8(rgb.clone()), DynamicImage::ImageRgba8(rgba), DynamicImage::ImageRgb16(rgb16), DynamicImage::ImageRgba16(rgba16)];
    for img in &images {
        let (tif, png) = (encode(img, ImageFormat::Tiff), encode(img, ImageFormat::Png));
        for color in [ColorMode::Gray, ColorMode::Rgb] {
            assert_eq!(features(&tif, color), features(&png, color), "{:?} {color:?}", img.color());
        }
    }
    // 8-bit colour made gray takes the 8-bit path with PIL's luma.
    let tif = encode(&images[0], ImageFormat::Tiff);
    let luma: Vec<u8> = rgb.pixels().map(|p| luma601(p.0[0], p.0[1], p.0[2])).collect();
    assert_eq!(query("c.tif", &tif, ColorMode::Gray), QueryImage::Gray8(luma));
}

/// Largest and mean absolute difference, in 8-bit levels, between features and 8-bit values.
fn level_error(got: &[f32], want: &[u8]) -> (f32, f32) {
    assert_eq!(got.len(), want.len());
    let d: Vec<f32> = got.iter().zip(want).map(|(&g, &w)| (g * 255.0 - w as f32).abs()).collect();
    (d.iter().cloned().fold(0.0, f32::max), d.iter().sum::<f32>() / d.len() as f32)
}

/// JPEG is lossy: at quality 95 every gray value of these smooth images comes back within 6
/// levels (of 255; 3 are seen) and their mean within 1.5 (0.7 seen); RGB channels, their chroma
/// subsampled, within twice that (7 and 1.3 seen).
const JPEG_MAX_LEVELS: f32 = 6.0;
const JPEG_MEAN_LEVELS: f32 = 1.5;

#[test]
fn jpeg_gray_and_rgb_come_back_within_the_tolerance() {
    let g = gray8();
    let bytes = jpeg(&DynamicImage::ImageLuma8(g.clone()), 95);
    assert_eq!(&bytes[..2], [0xFF, 0xD8]);
    // Gray JPEG: the 8-bit fast path.
    let QueryImage::Gray8(v) = query("g.jpg", &bytes, ColorMode::Gray) else { panic!("a gray JPEG is 8-bit gray") };
    let f: Vec<f32> = v.iter().map(|&k| k as f32 / 255.0).collect();
    let (max, mean) = level_error(&f, g.as_raw());
    assert!(max <= JPEG_MAX_LEVELS && mean <= JPEG_MEAN_LEVELS, "gray JPEG: max {max}, mean {mean} levels");
    assert_eq!(query("g.jpg", &bytes, ColorMode::Gray).into_features(), features(&bytes, ColorMode::Gray));

    // Colour JPEG: gray (PIL's luma of the decoded RGB, on the 8-bit path) and RGB features.
    let rgb = rgb8();
    let bytes = jpeg(&DynamicImage::ImageRgb8(rgb.clone()), 95);
    let luma: Vec<u8> = rgb.pixels().map(|p| luma601(p.0[0], p.0[1], p.0[2])).collect();
    let QueryImage::Gray8(v) = query("c.jpeg", &bytes, ColorMode::Gray) else { panic!("an RGB JPEG made gray is 8-bit gray") };
    let f: Vec<f32> = v.iter().map(|&k| k as f32 / 255.0).collect();
    let (max, mean) = level_error(&f, &luma);
    assert!(max <= JPEG_MAX_LEVELS && mean <= JPEG_MEAN_LEVELS, "RGB JPEG made gray: max {max}, mean {mean} levels");
    let (max, mean) = level_error(&features(&bytes, ColorMode::Rgb), rgb.as_raw());
    assert!(max <= 2.0 * JPEG_MAX_LEVELS && mean <= 2.0 * JPEG_MEAN_LEVELS, "RGB JPEG: max {max}, mean {mean} levels");
}

#[test]
fn every_truncation_of_a_jpeg_or_tiff_is_refused_naming_the_file() {
    let g = DynamicImage::ImageLuma8(gray8());
    let files = [
        ("view.jpg", jpeg(&g, 90)),
        ("view.jpg", jpeg(&DynamicImage::ImageRgb8(rgb8()), 90)),
        ("view.tif", encode(&g, ImageFormat::Tiff)),
        ("view.tif", encode(&DynamicImage::ImageLuma16(gray16()), ImageFormat::Tiff)),
    ];
    for (name, bytes) in &files {
        decode(Path::new(name), bytes).unwrap();
        for n in 0..bytes.len() {
            let e = err(name, &bytes[..n]);
            assert!(e.contains("cannot decode image"), "{name} cut at {n} of {}: {e}", bytes.len());
            // Past the magic bytes the message says what happened: from the decoder (TIFF), or
            // from the missing end-of-image marker (JPEG, which the decoder would fill in).
            assert!(n < 4 || e.contains("truncated"), "{name} cut at {n} of {}: {e}", bytes.len());
        }
        // Damaged bytes: an answer, never a panic.
        for k in 0..bytes.len() {
            let mut b = bytes.clone();
            b[k] ^= 0xA5;
            let _ = decode(Path::new(name), &b);
        }
    }
    for (name, bytes) in [&files[0], &files[2]] {
        let e = err(name, &bytes[..bytes.len() - 8]);
        assert!(e.contains(if name.ends_with("jpg") { "the JPEG data ends" } else { "the TIFF data ends" }), "{e}");
    }

    // Through the readers of data sets and queries, too.
    let t = tempfile::tempdir().unwrap();
    let p: PathBuf = t.path().join("cut.jpeg");
    std::fs::write(&p, &files[0].1[..files[0].1.len() - 3]).unwrap();
    let e = read_features(&p, ColorMode::Gray, None, "", &mut Vec::new()).unwrap_err().to_string();
    assert!(e.contains(&*p.to_string_lossy()) && e.contains("truncated"), "{e}");
    let e = read_query(&p, ImageSpec { width: W, height: H, color: ColorMode::Gray }, "m").unwrap_err().to_string();
    assert!(e.contains(&*p.to_string_lossy()) && e.contains("truncated"), "{e}");
}

/// The offset of a JPEG's frame header (the SOF0 segment's length field).
fn sof0(bytes: &[u8]) -> usize {
    bytes.windows(2).position(|w| w == [0xFF, 0xC0]).unwrap() + 2
}

#[test]
fn cmyk_and_12_bit_jpegs_are_refused_from_the_header() {
    // A frame header of four components (what Photoshop writes for CMYK), then the end.
    let mut cmyk = vec![0xFF, 0xD8, 0xFF, 0xC0, 0, 20, 8, 0, 12, 0, 16, 4];
    for c in 1..=4u8 {
        cmyk.extend([c, 0x11, 0]);
    }
    cmyk.extend([0xFF, 0xD9]);
    let e = err("print.jpg", &cmyk);
    assert!(e.contains("CMYK JPEG") && e.contains("convert it to RGB"), "{e}");
    // Behind another name, the message says what the bytes are.
    let e = err("print.png", &cmyk);
    assert!(e.contains("JPEG data in a .png file") && e.contains("CMYK"), "{e}");

    let mut deep = jpeg(&DynamicImage::ImageLuma8(gray8()), 90);
    let at = sof0(&deep);
    deep[at + 2] = 12;
    let e = err("deep.jpg", &deep);
    assert!(e.contains("12-bit JPEG"), "{e}");
}

#[test]
fn float_tiffs_are_refused() {
    let f = ImageBuffer::<Rgb<f32>, Vec<f32>>::from_fn(W, H, |x, _| Rgb([x as f32 / 16.0, 0.5, 0.25]));
    for img in [DynamicImage::ImageRgb32F(f.clone()), DynamicImage::ImageRgba32F(DynamicImage::ImageRgb32F(f).to_rgba32f())] {
        let e = err("hdr.tif", &encode(&img, ImageFormat::Tiff));
        assert!(e.contains("floating-point") && e.contains("16-bit"), "{e}");
    }
}

#[test]
fn absurd_sizes_are_refused_from_the_header() {
    // A JPEG declaring 65535 x 65535 pixels (17 GB of RGB): refused before decoding.
    let mut big = jpeg(&DynamicImage::ImageRgb8(rgb8()), 90);
    let at = sof0(&big);
    big[at + 3..at + 7].copy_from_slice(&[0xFF, 0xFF, 0xFF, 0xFF]);
    assert!(matches!(decode(Path::new("big.jpg"), &big), Err(Error::ImageTooLarge { width: 65535, height: 65535, .. })));

    // A TIFF whose ImageWidth and ImageLength tags say 100000 x 100000 (and RowsPerStrip, so
    // that its one strip still agrees).
    let mut big = encode(&DynamicImage::ImageLuma8(gray8()), ImageFormat::Tiff);
    let ifd = u32::from_le_bytes(big[4..8].try_into().unwrap()) as usize;
    let n = u16::from_le_bytes([big[ifd], big[ifd + 1]]) as usize;
    let mut patched = 0;
    for k in 0..n {
        let e = ifd + 2 + 12 * k;
        let tag = u16::from_le_bytes([big[e], big[e + 1]]);
        if matches!(tag, 256 | 257 | 278) {
            // Make the field a LONG holding 100000.
            big[e + 2..e + 4].copy_from_slice(&4u16.to_le_bytes());
            big[e + 8..e + 12].copy_from_slice(&100_000u32.to_le_bytes());
            patched += 1;
        }
    }
    assert_eq!(patched, 3);
    let r = dimensions(Path::new("big.tif"), &big);
    assert!(matches!(r, Err(Error::ImageTooLarge { width: 100_000, height: 100_000, .. })), "{r:?}");
}

#[test]
fn image_extensions() {
    for f in ["a.png", "a.PGM", "a.ppm", "a.pnm", "a.jpg", "a.JPEG", "a.tif", "a.Tiff"] {
        assert!(has_image_extension(Path::new(f)), "{f}");
    }
    for f in ["a.gif", "a.txt", "png", "a.jpg.bak", "a"] {
        assert!(!has_image_extension(Path::new(f)), "{f}");
    }
}
