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

pub fn to_rgb8(pixels: &[Vec3], width: u32, height: u32) -> image::RgbImage {
    let mut img = image::RgbImage::new(width, height);
    for (i, p) in img.pixels_mut().enumerate() {
        let c = pixels[i];
        *p = image::Rgb([srgb_encode(c.x), srgb_encode(c.y), srgb_encode(c.z)]);
    }
    img
}

pub fn write_png(pixels: &[Vec3], width: u32, height: u32, path: &Path) -> Result<(), String> {
    to_rgb8(pixels, width, height)
        .save_with_format(path, image::ImageFormat::Png)
        .map_err(|e| format!("{}: {e}", path.display()))
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
