//! Image output: linear RGB → sRGB-encoded 8-bit PNG.

use geom::Vec3;
use std::path::Path;

/// The sRGB transfer function (IEC 61966-2-1) of a linear value clamped to [0, 1].
#[inline]
pub fn srgb_encode(c: f32) -> u8 {
    let c = if c.is_nan() { 0.0 } else { c.clamp(0.0, 1.0) };
    let s = if c <= 0.003_130_8 {
        12.92 * c
    } else {
        1.055 * c.powf(1.0 / 2.4) - 0.055
    };
    (s * 255.0 + 0.5) as u8
}

/// The pixels (linear RGB, row-major) as an 8-bit sRGB image.
pub fn to_rgb8(pixels: &[Vec3], width: u32, height: u32) -> image::RgbImage {
    let mut img = image::RgbImage::new(width, height);
    for (i, p) in img.pixels_mut().enumerate() {
        let c = pixels[i];
        *p = image::Rgb([srgb_encode(c.x), srgb_encode(c.y), srgb_encode(c.z)]);
    }
    img
}

/// Write the pixels as an sRGB PNG; the error names the file.
pub fn write_png(pixels: &[Vec3], width: u32, height: u32, path: &Path) -> Result<(), String> {
    to_rgb8(pixels, width, height)
        .save_with_format(path, image::ImageFormat::Png)
        .map_err(|e| format!("{}: {e}", path.display()))
}

/// An animated GIF of `frames` (each `width × height` linear RGB), looping, `delay_ms` per
/// frame. Colours are quantised per frame (NeuQuant, speed 10).
pub fn write_gif(
    frames: &[Vec<Vec3>],
    width: u32,
    height: u32,
    delay_ms: u32,
    path: &Path,
) -> Result<(), String> {
    use image::codecs::gif::{GifEncoder, Repeat};
    let err = |e: image::ImageError| format!("{}: {e}", path.display());
    let file = std::fs::File::create(path).map_err(|e| format!("{}: {e}", path.display()))?;
    let mut enc = GifEncoder::new_with_speed(std::io::BufWriter::new(file), 10);
    enc.set_repeat(Repeat::Infinite).map_err(err)?;
    for f in frames {
        let rgba = image::DynamicImage::ImageRgb8(to_rgb8(f, width, height)).to_rgba8();
        let frame = image::Frame::from_parts(
            rgba,
            0,
            0,
            image::Delay::from_numer_denom_ms(delay_ms.max(10), 1),
        );
        enc.encode_frame(frame).map_err(err)?;
    }
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn srgb_endpoints() {
        assert_eq!(srgb_encode(0.0), 0);
        assert_eq!(srgb_encode(1.0), 255);
        assert_eq!(srgb_encode(7.0), 255);
        assert_eq!(srgb_encode(f32::NAN), 0);
        assert_eq!(srgb_encode(0.2), 124);
    }
}
