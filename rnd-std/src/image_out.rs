//! Output images of `go`: NRRD (3-D float, sizes C × W × H: the channel axis first, then
//! the image's columns and rows from the top) or 8-bit PNG (grey for one channel, RGB for
//! three or more; values mapped linearly from a range onto 0..255).

use std::path::Path;

use crate::nrrd::{self, Data, Nrrd, WriteOptions};
use crate::output::Output;
use crate::{Error, ErrorKind, Result};

/// An image of `channels` floats per pixel, `size[0]` × `size[1]` pixels, top row first.
#[derive(Debug, Clone, PartialEq)]
pub struct Image {
    /// Samples, channel fastest.
    pub data: Vec<f32>,
    /// Channels per pixel.
    pub channels: usize,
    /// Width, height.
    pub size: [usize; 2],
}

impl Image {
    /// Checks that the samples fill the image exactly: `channels` (at least one) floats
    /// for each of its pixels.
    ///
    /// # Errors
    /// [`ErrorKind::Output`] when they do not.
    pub fn check(&self) -> Result<()> {
        let [w, h] = self.size;
        let need = w.checked_mul(h).and_then(|n| n.checked_mul(self.channels));
        if self.channels == 0 || need != Some(self.data.len()) {
            return Err(Error::msg(format!(
                "an image of {w} x {h} pixels of {} channels cannot be made of {} samples",
                self.channels,
                self.data.len()
            ))
            .with_kind(ErrorKind::Output));
        }
        Ok(())
    }
}

/// Whether `path` asks for PNG output.
pub fn is_png(path: &Path) -> bool {
    path.extension()
        .is_some_and(|e| e.eq_ignore_ascii_case("png"))
}

/// `floor(256·(v − min)/(max − min))` clamped to 0..=255 (Teem's quantization).
pub fn quantize(v: f64, min: f64, max: f64) -> u8 {
    if !v.is_finite() || max <= min {
        return 0;
    }
    let i = ((v - min) / (max - min) * 256.0).floor();
    i.clamp(0.0, 255.0) as u8
}

/// Encodes the image as 8-bit PNG bytes: 1 channel → grey over [min, max] (`range` or the
/// image's finite range); 3 channels → RGB over one common range; 4 channels → RGBA
/// composited over black (rgb·a), as `overrgb -b 0 0 0`. Other channel counts use the
/// first channel.
///
/// # Errors
/// As [`Image::check`] and [`encode_png`].
pub fn png_bytes(img: &Image, range: Option<(f64, f64)>) -> Result<Vec<u8>> {
    let (buf, color) = png_pixels(img, range)?;
    encode_png(&buf, img.size[0], img.size[1], color)
}

/// The 8-bit pixels [`png_bytes`] encodes (the same quantization), with their layout.
///
/// # Errors
/// As [`Image::check`].
pub fn png_pixels(img: &Image, range: Option<(f64, f64)>) -> Result<(Vec<u8>, PngColor)> {
    img.check()?;
    let c = img.channels;
    let (buf, color): (Vec<u8>, PngColor) = match c {
        4 => {
            let mut b = Vec::with_capacity(img.data.len() / 4 * 3);
            for p in img.data.chunks_exact(4) {
                for k in 0..3 {
                    let v = (p[k] * p[3]) as f64;
                    b.push(quantize(v, 0.0, 1.0));
                }
            }
            (b, PngColor::Rgb)
        }
        3 => {
            let (lo, hi) = range.unwrap_or_else(|| finite_range(img.data.iter().copied()));
            (
                img.data
                    .iter()
                    .map(|&v| quantize(v as f64, lo, hi))
                    .collect(),
                PngColor::Rgb,
            )
        }
        _ => {
            let first = img.data.iter().step_by(c).copied();
            let (lo, hi) = range.unwrap_or_else(|| finite_range(first.clone()));
            (
                first.map(|v| quantize(v as f64, lo, hi)).collect(),
                PngColor::Grey,
            )
        }
    };
    Ok((buf, color))
}

/// Encodes frames of 8-bit pixels (each `w` × `h` of `color`, top row first) as an
/// animated PNG shown at `fps` frames per second, looping forever. Viewers without APNG
/// support show the first frame.
///
/// # Errors
/// No frames, a size a PNG cannot have, frames of the wrong length, a frame rate outside
/// 1..=1000, or an encoder failure; without the `png` cargo feature.
pub fn encode_apng(
    frames: &[Vec<u8>],
    w: usize,
    h: usize,
    color: PngColor,
    fps: u16,
) -> Result<Vec<u8>> {
    let per = png_len(w, h, color)?;
    if frames.is_empty() || frames.iter().any(|f| f.len() != per) {
        return Err(Error::msg(format!(
            "an animated PNG needs frames of {per} bytes ({w} x {h} pixels)"
        ))
        .with_kind(ErrorKind::Output));
    }
    if !(1..=1000).contains(&fps) {
        return Err(Error::msg(format!("frame rate {fps} is not in 1..=1000")));
    }
    let n = u32::try_from(frames.len()).map_err(|_| Error::msg("too many frames"))?;
    #[cfg(feature = "png")]
    {
        let fail = |e: png::EncodingError| Error::msg(format!("APNG encoding failed: {e}"));
        let mut out = Vec::new();
        let mut enc = png::Encoder::new(&mut out, w as u32, h as u32);
        enc.set_color(match color {
            PngColor::Grey => png::ColorType::Grayscale,
            PngColor::Rgb => png::ColorType::Rgb,
        });
        enc.set_depth(png::BitDepth::Eight);
        enc.set_animated(n, 0).map_err(fail)?;
        enc.set_frame_delay(1, fps).map_err(fail)?;
        let mut wr = enc.write_header().map_err(fail)?;
        for f in frames {
            wr.write_image_data(f).map_err(fail)?;
        }
        wr.finish().map_err(fail)?;
        Ok(out)
    }
    #[cfg(not(feature = "png"))]
    {
        let _ = n;
        Err(
            Error::msg("PNG output needs rnd-std's cargo feature \"png\", which this build lacks")
                .with_kind(crate::ErrorKind::Output),
        )
    }
}

/// The pixel layout of 8-bit PNG data.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PngColor {
    /// One grey byte per pixel.
    Grey,
    /// Red, green and blue bytes per pixel.
    Rgb,
}

/// The bytes of `w` × `h` 8-bit pixels of `color`.
///
/// # Errors
/// [`ErrorKind::Output`] for a size a PNG cannot have (a side of 0 or beyond 2^32 - 1).
fn png_len(w: usize, h: usize, color: PngColor) -> Result<usize> {
    let side = |n: usize| n > 0 && u32::try_from(n).is_ok();
    let bytes = w
        .checked_mul(h)
        .and_then(|n| n.checked_mul(if color == PngColor::Rgb { 3 } else { 1 }));
    match bytes {
        Some(n) if side(w) && side(h) => Ok(n),
        _ => {
            Err(Error::msg(format!("a PNG cannot be {w} x {h} pixels"))
                .with_kind(ErrorKind::Output))
        }
    }
}

/// Encodes 8-bit pixels (`w` × `h`, top row first) as PNG bytes.
///
/// # Errors
/// [`ErrorKind::Output`] for a size a PNG cannot have or a buffer of the wrong length;
/// an encoder failure; without the `png` cargo feature.
pub fn encode_png(buf: &[u8], w: usize, h: usize, color: PngColor) -> Result<Vec<u8>> {
    let need = png_len(w, h, color)?;
    if buf.len() != need {
        return Err(Error::msg(format!(
            "{} bytes of pixels for a {w} x {h} PNG that takes {need}",
            buf.len()
        ))
        .with_kind(ErrorKind::Output));
    }
    #[cfg(feature = "png")]
    {
        let color = match color {
            PngColor::Grey => image::ExtendedColorType::L8,
            PngColor::Rgb => image::ExtendedColorType::Rgb8,
        };
        let mut out = Vec::new();
        let enc = image::codecs::png::PngEncoder::new(&mut out);
        image::ImageEncoder::write_image(enc, buf, w as u32, h as u32, color)
            .map_err(|e| Error::msg(format!("PNG encoding failed: {e}")))?;
        Ok(out)
    }
    #[cfg(not(feature = "png"))]
    {
        let _ = (buf, w, h, color);
        Err(
            Error::msg("PNG output needs rnd-std's cargo feature \"png\", which this build lacks")
                .with_kind(crate::ErrorKind::Output),
        )
    }
}

/// Writes 8-bit RGB pixels (`w` × `h`, top row first) as a PNG file, atomically.
///
/// # Errors
/// As [`crate::output::Output::create`] and [`write_png_rgb_to`].
pub fn write_png_rgb(path: &Path, buf: &[u8], w: usize, h: usize) -> Result<()> {
    write_png_rgb_to(Output::create::<&Path>(path, &[])?, buf, w, h)
}

/// [`write_png_rgb`] into an output prepared beforehand.
///
/// # Errors
/// PNG encoding and write failures.
pub fn write_png_rgb_to(out: Output, buf: &[u8], w: usize, h: usize) -> Result<()> {
    commit_bytes(out, &encode_png(buf, w, h, PngColor::Rgb)?)
}

/// Writes `bytes` to `out` and puts it in place.
///
/// # Errors
/// As [`Output::commit`].
pub fn commit_bytes(out: Output, bytes: &[u8]) -> Result<()> {
    out.commit(|f| {
        f.write_all(bytes)
            .map_err(|e| Error::msg(format!("write failed: {e}")))
    })
}

fn finite_range(it: impl Iterator<Item = f32>) -> (f64, f64) {
    let (mut lo, mut hi) = (f64::INFINITY, f64::NEG_INFINITY);
    for v in it {
        if v.is_finite() {
            lo = lo.min(v as f64);
            hi = hi.max(v as f64);
        }
    }
    if lo > hi {
        (0.0, 1.0)
    } else {
        (lo, hi)
    }
}

/// Writes (and consumes) `img` to `path`: PNG when the name ends in `.png`, else NRRD (raw float,
/// sizes C W H, `content` as given). `-` writes NRRD to stdout.
///
/// ```
/// use rnd_std::image_out::{write_image, Image};
///
/// let dir = std::env::temp_dir().join(format!("rnd-std-img-doc-{}", std::process::id()));
/// std::fs::create_dir_all(&dir).unwrap();
/// // A 2 x 1 grey ramp: PNG over the range [0, 1], and the floats as NRRD.
/// let img = Image { data: vec![0.0, 1.0], channels: 1, size: [2, 1] };
/// write_image(img.clone(), &dir.join("ramp.png"), "ramp", Some((0.0, 1.0))).unwrap();
/// write_image(img, &dir.join("ramp.nrrd"), "ramp", None).unwrap();
/// let n = rnd_std::nrrd::read(&dir.join("ramp.nrrd")).unwrap();
/// assert_eq!(n.sizes(), &[1, 2, 1]);
/// # std::fs::remove_dir_all(&dir).unwrap();
/// ```
///
/// # Errors
/// As [`Output::create`] and [`write_image_to`].
pub fn write_image(
    img: Image,
    path: &Path,
    content: &str,
    range: Option<(f64, f64)>,
) -> Result<()> {
    write_image_to(img, Output::create::<&Path>(path, &[])?, content, range)
}

/// [`write_image`] into an output prepared beforehand (PNG when its name ends in
/// `.png`).
///
/// # Errors
/// As [`Image::check`]; PNG encoding and write failures.
pub fn write_image_to(
    img: Image,
    out: Output,
    content: &str,
    range: Option<(f64, f64)>,
) -> Result<()> {
    img.check()?;
    if is_png(out.path()) {
        return commit_bytes(out, &png_bytes(&img, range)?);
    }
    let mut n = Nrrd::new(
        vec![img.channels, img.size[0], img.size[1]],
        Data::F32(img.data),
    )?;
    n.header.content = Some(content.to_string());
    out.commit(|w| nrrd::write_to(&n, WriteOptions::default(), w))
}
