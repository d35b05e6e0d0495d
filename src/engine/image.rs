//! 8-bit sRGB images, the linear → sRGB transfer function, and deterministic PNG encoding.
//!
//! In: pixels. Out: PNG bytes in memory (writing them to a file is the caller's business: the
//! engine does no I/O).
//!
//! **Invariant:** the same pixels always encode to the same PNG bytes: the encoder settings are
//! fixed here (RGB 8-bit, no ancillary chunks, `Balanced` deflate, adaptive row filters) and the
//! `png` crate's encoder is itself deterministic.

use std::sync::OnceLock;

/// Luminance weights of linear Rec. 709 (sRGB) red, green and blue.
pub const REC709: [f32; 3] = [0.2126, 0.7152, 0.0722];

/// An RGB image, 8 bits per channel, sRGB-encoded, rows top to bottom, no padding.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct RgbImage {
    pub width: u32,
    pub height: u32,
    /// `width * height * 3` bytes, `R G B` per pixel, row-major from the top-left corner.
    pub data: Vec<u8>,
}

/// Failure to encode a PNG.
#[derive(Debug, thiserror::Error)]
pub enum ImageError {
    #[error("PNG encoding failed: {0}")]
    Encode(#[from] png::EncodingError),
}

impl RgbImage {
    /// A black image.
    pub fn new(width: u32, height: u32) -> Self {
        RgbImage { width, height, data: vec![0; width as usize * height as usize * 3] }
    }

    /// The pixel at (`x`, `y`); panics when outside the image.
    pub fn pixel(&self, x: u32, y: u32) -> [u8; 3] {
        assert!(x < self.width && y < self.height, "pixel ({x}, {y}) outside {}×{}", self.width, self.height);
        let i = (y as usize * self.width as usize + x as usize) * 3;
        [self.data[i], self.data[i + 1], self.data[i + 2]]
    }

    /// Sets the pixel at (`x`, `y`); panics when outside the image.
    pub fn set_pixel(&mut self, x: u32, y: u32, rgb: [u8; 3]) {
        assert!(x < self.width && y < self.height, "pixel ({x}, {y}) outside {}×{}", self.width, self.height);
        let i = (y as usize * self.width as usize + x as usize) * 3;
        self.data[i..i + 3].copy_from_slice(&rgb);
    }

    /// Encodes as PNG with fixed settings: same pixels, same bytes.
    pub fn encode_png(&self) -> Vec<u8> {
        self.try_encode_png().expect("encoding a well-formed RGB image into memory cannot fail")
    }

    fn try_encode_png(&self) -> Result<Vec<u8>, ImageError> {
        assert_eq!(
            self.data.len(),
            self.width as usize * self.height as usize * 3,
            "RgbImage data length does not match {}×{}×3",
            self.width,
            self.height
        );
        let mut out = Vec::with_capacity(self.data.len() / 2 + 1024);
        {
            let mut encoder = png::Encoder::new(&mut out, self.width, self.height);
            encoder.set_color(png::ColorType::Rgb);
            encoder.set_depth(png::BitDepth::Eight);
            encoder.set_compression(png::Compression::Fast);
            encoder.set_filter(png::Filter::Adaptive);
            // The pixels are sRGB; say so (a fixed chunk, so still deterministic).
            encoder.set_source_srgb(png::SrgbRenderingIntent::Perceptual);
            let mut writer = encoder.write_header()?;
            writer.write_image_data(&self.data)?;
            writer.finish()?;
        }
        Ok(out)
    }
}

impl RgbImage {
    /// The same image in shades of grey: each pixel's luminance (Rec. 709 weights on linear
    /// light), encoded back to sRGB in all three channels.
    pub fn to_grayscale(&self) -> RgbImage {
        let [r, g, b] = REC709;
        let linear: [f32; 256] = std::array::from_fn(|v| srgb_to_linear(v as f32 / 255.0));
        let encode = Srgb8::new();
        let data = self
            .data
            .chunks_exact(3)
            .flat_map(|p| {
                let y = r * linear[p[0] as usize] + g * linear[p[1] as usize] + b * linear[p[2] as usize];
                [encode.encode(y); 3]
            })
            .collect();
        RgbImage { width: self.width, height: self.height, data }
    }

    /// Adds an alpha channel (`alpha` has one byte per pixel), dividing the colour of partly
    /// covered pixels by their coverage: the colours were blended with black there.
    pub fn with_alpha(&self, alpha: &[u8]) -> RgbaImage {
        assert_eq!(alpha.len() * 3, self.data.len(), "one alpha byte per pixel");
        let linear: [f32; 256] = std::array::from_fn(|v| srgb_to_linear(v as f32 / 255.0));
        let encode = Srgb8::new();
        let data = self
            .data
            .chunks_exact(3)
            .zip(alpha)
            .flat_map(|(p, &a)| match a {
                0 => [0, 0, 0, 0],
                255 => [p[0], p[1], p[2], 255],
                _ => {
                    let k = 255.0 / a as f32;
                    let c = |v: u8| encode.encode(linear[v as usize] * k);
                    [c(p[0]), c(p[1]), c(p[2]), a]
                }
            })
            .collect();
        RgbaImage { width: self.width, height: self.height, data }
    }
}

/// An RGBA image, 8 bits per channel, sRGB colour with straight (not premultiplied) alpha.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct RgbaImage {
    pub width: u32,
    pub height: u32,
    /// `width * height * 4` bytes, `R G B A` per pixel, row-major from the top-left corner.
    pub data: Vec<u8>,
}

impl RgbaImage {
    /// Encodes as PNG with the same fixed settings as [`RgbImage::encode_png`].
    pub fn encode_png(&self) -> Vec<u8> {
        let mut out = Vec::with_capacity(self.data.len() / 2 + 1024);
        let mut encoder = png::Encoder::new(&mut out, self.width, self.height);
        encoder.set_color(png::ColorType::Rgba);
        encoder.set_depth(png::BitDepth::Eight);
        encoder.set_compression(png::Compression::Fast);
        encoder.set_filter(png::Filter::Adaptive);
        encoder.set_source_srgb(png::SrgbRenderingIntent::Perceptual);
        let written = encoder.write_header().and_then(|mut w| w.write_image_data(&self.data).and_then(|()| w.finish()));
        written.expect("encoding a well-formed RGBA image into memory cannot fail");
        out
    }
}

/// A rendered frame: colour, or colour with alpha (transparent backdrop).
#[derive(Clone, Debug, PartialEq, Eq)]
pub enum Frame {
    Rgb(RgbImage),
    Rgba(RgbaImage),
}

impl Frame {
    pub fn encode_png(&self) -> Vec<u8> {
        match self {
            Frame::Rgb(image) => image.encode_png(),
            Frame::Rgba(image) => image.encode_png(),
        }
    }

    /// The colour image (for RGBA, composited over black).
    pub fn into_rgb(self) -> RgbImage {
        match self {
            Frame::Rgb(image) => image,
            Frame::Rgba(image) => {
                let data = image.data.chunks_exact(4).flat_map(|p| {
                    let a = p[3] as f32 / 255.0;
                    let linear = |v: u8| srgb_to_linear(v as f32 / 255.0) * a;
                    [linear_to_srgb8(linear(p[0])), linear_to_srgb8(linear(p[1])), linear_to_srgb8(linear(p[2]))]
                });
                RgbImage { width: image.width, height: image.height, data: data.collect() }
            }
        }
    }
}

/// The sRGB transfer function (IEC 61966-2-1), linear `[0, 1]` → encoded `[0, 1]`; clamps.
pub fn linear_to_srgb(linear: f32) -> f32 {
    let c = f64::from(linear);
    if c.is_nan() || c <= 0.0 {
        return 0.0;
    }
    if c >= 1.0 {
        return 1.0;
    }
    (if c <= 0.003_130_8 { 12.92 * c } else { 1.055 * c.powf(1.0 / 2.4) - 0.055 }) as f32
}

/// The inverse of [`linear_to_srgb`]: encoded `[0, 1]` → linear; clamps.
pub fn srgb_to_linear(encoded: f32) -> f32 {
    let s = f64::from(encoded);
    if s.is_nan() || s <= 0.0 {
        return 0.0;
    }
    if s >= 1.0 {
        return 1.0;
    }
    (if s <= 0.040_45 { s / 12.92 } else { ((s + 0.055) / 1.055).powf(2.4) }) as f32
}

/// Linear `[0, 1]` → 8-bit sRGB, i.e. `round(255 · linear_to_srgb(linear))`, NaN → 0.
///
/// Evaluated without `powf` per call: the 255 linear values at which the rounded output steps
/// up are computed once (in `f64`, nudged to the exact `f32` boundary); a 4096-bucket table
/// gives the output at the start of each bucket, and at most a step or two over the
/// thresholds finishes the job. Exact with respect to the formula, fast and deterministic.
pub fn linear_to_srgb8(linear: f32) -> u8 {
    Srgb8::new().encode(linear)
}

/// [`linear_to_srgb8`] with its tables fetched once, for loops over many pixels.
#[derive(Clone, Copy)]
pub struct Srgb8(&'static Srgb8Tables);

impl Srgb8 {
    pub fn new() -> Self {
        Srgb8(srgb8_tables())
    }

    /// Same as [`linear_to_srgb8`].
    #[inline]
    pub fn encode(self, linear: f32) -> u8 {
        // NaN and negatives → 0; the multiplication by a power of two is exact, so the bucket
        // starts at or below `x`, and a bucket never spans more than one step.
        let x = if linear > 0.0 { linear.min(1.0) } else { 0.0 };
        // SAFETY: `x` is in [0, 1] (NaN went to 0 above), so the product is a finite value in
        // [0, SRGB_BUCKETS] and truncates to a valid `u32` (the saturating `as` costs more here).
        let bucket = unsafe { (x * SRGB_BUCKETS as f32).to_int_unchecked::<u32>() } as usize;
        self.0.bucket_start[bucket] + u8::from(x >= self.0.bucket_next[bucket])
    }
}

impl Default for Srgb8 {
    fn default() -> Self {
        Srgb8::new()
    }
}

const SRGB_BUCKETS: usize = 4096;

struct Srgb8Tables {
    /// Output for the value `i / SRGB_BUCKETS`, i = 0..=SRGB_BUCKETS.
    bucket_start: [u8; SRGB_BUCKETS + 1],
    /// The threshold of the next output step after `bucket_start[i]` (+∞ after 255): a second
    /// table indexed like the first, so that both loads can run at once.
    bucket_next: [f32; SRGB_BUCKETS + 1],
}

fn srgb8_tables() -> &'static Srgb8Tables {
    static TABLES: OnceLock<Srgb8Tables> = OnceLock::new();
    TABLES.get_or_init(|| {
        let steps = srgb8_thresholds();
        let mut thresholds = [f32::INFINITY; 256];
        thresholds[..255].copy_from_slice(&steps);
        let bucket_start: [u8; SRGB_BUCKETS + 1] = std::array::from_fn(|i| {
            let x = i as f32 / SRGB_BUCKETS as f32;
            steps.partition_point(|&t| t <= x) as u8
        });
        // `encode` takes at most one step inside a bucket: the steepest slope of the curve,
        // 12.92 · 255 / 4096 ≈ 0.8 output levels per bucket, guarantees it.
        for (i, &start) in bucket_start[..SRGB_BUCKETS].iter().enumerate() {
            let next_step = thresholds.get(start as usize + 1).copied().unwrap_or(f32::INFINITY);
            let bucket_end = (i + 1) as f32 / SRGB_BUCKETS as f32;
            assert!(next_step >= bucket_end, "sRGB bucket {i} spans more than one output step");
        }
        let bucket_next = bucket_start.map(|start| thresholds[start as usize]);
        Srgb8Tables { bucket_start, bucket_next }
    })
}

/// `t[k]` = smallest f32 `x` with `255 · linear_to_srgb(x) ≥ k + 0.5`, for k = 0..255.
fn srgb8_thresholds() -> [f32; 255] {
    let mut table = [0f32; 255];
    for (k, slot) in table.iter_mut().enumerate() {
        let target = (k as f64 + 0.5) / 255.0;
        let mut x = srgb_to_linear(target as f32);
        // Nudge to the exact f32 boundary of the forward formula.
        let encodes_above = |x: f32| f64::from(linear_to_srgb(x)) >= target;
        while !encodes_above(x) {
            x = f32::from_bits(x.to_bits() + 1);
        }
        while x > 0.0 && encodes_above(f32::from_bits(x.to_bits() - 1)) {
            x = f32::from_bits(x.to_bits() - 1);
        }
        *slot = x;
    }
    table
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn srgb8_matches_the_formula() {
        for i in 0..=200_000u32 {
            let x = i as f32 / 200_000.0;
            let expected = (f64::from(linear_to_srgb(x)) * 255.0 + 0.5).floor() as u8;
            assert_eq!(linear_to_srgb8(x), expected, "x = {x}");
        }
        // Also across the whole f32 range below 1, by bit pattern (denser near 0).
        for bits in (0..1.0f32.to_bits()).step_by(997) {
            let x = f32::from_bits(bits);
            let expected = (f64::from(linear_to_srgb(x)) * 255.0 + 0.5).floor() as u8;
            assert_eq!(linear_to_srgb8(x), expected, "x = {x}");
        }
        for k in 0..255 {
            let t = srgb8_thresholds()[k];
            assert_eq!(linear_to_srgb8(t), k as u8 + 1);
            assert_eq!(linear_to_srgb8(f32::from_bits(t.to_bits() - 1)), k as u8);
        }
        assert_eq!(linear_to_srgb8(-1.0), 0);
        assert_eq!(linear_to_srgb8(f32::NAN), 0);
        assert_eq!(linear_to_srgb8(2.0), 255);
        assert_eq!(linear_to_srgb8(0.5), 188);
        assert_eq!(linear_to_srgb8(0.214_041_14), 128);
    }

    #[test]
    fn srgb_round_trip() {
        for i in 0..=100 {
            let s = i as f32 / 100.0;
            assert!((linear_to_srgb(srgb_to_linear(s)) - s).abs() < 1e-5);
        }
    }

    #[test]
    fn png_is_deterministic_and_decodes_back() {
        let mut img = RgbImage::new(7, 5);
        for y in 0..5 {
            for x in 0..7 {
                img.set_pixel(x, y, [(x * 30) as u8, (y * 50) as u8, 7]);
            }
        }
        let a = img.encode_png();
        let b = img.clone().encode_png();
        assert_eq!(a, b);
        let decoder = png::Decoder::new(std::io::Cursor::new(a));
        let mut reader = decoder.read_info().unwrap();
        let mut buf = vec![0; reader.output_buffer_size().unwrap()];
        let info = reader.next_frame(&mut buf).unwrap();
        assert_eq!((info.width, info.height), (7, 5));
        assert_eq!(&buf[..info.buffer_size()], &img.data[..]);
    }

    #[test]
    fn grayscale_has_equal_channels_and_keeps_grey() {
        let mut img = RgbImage::new(3, 1);
        img.set_pixel(0, 0, [200, 40, 10]);
        img.set_pixel(1, 0, [77, 77, 77]);
        img.set_pixel(2, 0, [0, 255, 0]);
        let grey = img.to_grayscale();
        assert!(grey.data.chunks(3).all(|p| p[0] == p[1] && p[1] == p[2]));
        assert_eq!(grey.pixel(1, 0), [77, 77, 77]);
        assert!(grey.pixel(2, 0)[0] > grey.pixel(0, 0)[0], "green is brighter than red");
    }

    #[test]
    fn alpha_unblends_edges_and_zeroes_the_backdrop() {
        let mut img = RgbImage::new(3, 1);
        img.set_pixel(0, 0, [5, 5, 5]);
        img.set_pixel(1, 0, [linear_to_srgb8(0.25), 0, 0]);
        img.set_pixel(2, 0, [10, 20, 30]);
        let rgba = img.with_alpha(&[0, 128, 255]);
        assert_eq!(&rgba.data[0..4], &[0, 0, 0, 0]);
        assert_eq!(rgba.data[7], 128);
        assert!((rgba.data[4] as i32 - linear_to_srgb8(0.5) as i32).abs() <= 2, "{}", rgba.data[4]);
        assert_eq!(&rgba.data[8..12], &[10, 20, 30, 255]);
        let png = rgba.encode_png();
        let mut reader = png::Decoder::new(std::io::Cursor::new(png)).read_info().unwrap();
        assert_eq!(reader.info().color_type, png::ColorType::Rgba);
        let mut buf = vec![0; reader.output_buffer_size().unwrap()];
        reader.next_frame(&mut buf).unwrap();
        assert_eq!(buf, rgba.data);
    }
}
