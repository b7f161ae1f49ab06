//! Output files: linear RGB → sRGB-encoded 8-bit PNG and animated GIF, and the atomic write
//! every output of rayspace goes through ([`write_atomic`]): a reader (or a crash, or a full
//! disk) sees the old file or the whole new one, never a truncated one.

use geom::Vec3;
use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicU64, Ordering};

/// Check that `path` can be an output before any work is done: its directory exists, and
/// it is not a directory or a special file (device, FIFO, socket: only regular files are
/// replaced). The error names the path.
pub fn check_output(path: &Path) -> Result<(), String> {
    let name = path.display();
    if path.file_name().is_none() {
        return Err(format!("{name}: not a file name"));
    }
    let dir = parent_dir(path);
    if !dir.is_dir() {
        return Err(format!(
            "{name}: directory {} does not exist",
            dir.display()
        ));
    }
    match std::fs::metadata(path) {
        Ok(m) if m.is_dir() => Err(format!("{name}: is a directory")),
        Ok(m) if !m.is_file() => Err(format!(
            "{name}: not a regular file (a device, FIFO or socket is never written)"
        )),
        _ => Ok(()),
    }
}

fn parent_dir(path: &Path) -> PathBuf {
    match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    }
}

/// Write `bytes` to `path` atomically: a temporary file in the same directory, written,
/// flushed to the disk, then renamed over `path`. On any failure (disk full, no permission)
/// the temporary is removed, an existing `path` is left as it was, and the error names the
/// path.
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), String> {
    static SEQ: AtomicU64 = AtomicU64::new(0);
    check_output(path)?;
    let name = path.file_name().expect("checked").to_string_lossy();
    let tmp = parent_dir(path).join(format!(
        ".{name}.{}-{}.tmp",
        std::process::id(),
        SEQ.fetch_add(1, Ordering::Relaxed)
    ));
    let result = (|| {
        let mut f = std::fs::File::create(&tmp)?;
        f.write_all(bytes)?;
        f.sync_all()?;
        std::fs::rename(&tmp, path)
    })();
    result.map_err(|e| {
        let _ = std::fs::remove_file(&tmp);
        format!("{}: {e}", path.display())
    })
}

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

/// The pixels as the bytes of an sRGB PNG.
pub fn png_bytes(pixels: &[Vec3], width: u32, height: u32) -> Result<Vec<u8>, String> {
    encode_png(&to_rgb8(pixels, width, height))
}

/// An 8-bit RGB image as PNG bytes: the one encoder (and its settings) behind every PNG
/// rayspace writes, so an image written by the bindings has the command line's bytes.
pub fn encode_png(img: &image::RgbImage) -> Result<Vec<u8>, String> {
    let mut buf = Vec::new();
    img.write_to(&mut std::io::Cursor::new(&mut buf), image::ImageFormat::Png)
        .map_err(|e| format!("PNG encoding: {e}"))?;
    Ok(buf)
}

/// Row-major 8-bit RGB bytes (`width × height × 3`) as PNG bytes ([`encode_png`]).
pub fn rgb8_png(rgb: &[u8], width: u32, height: u32) -> Result<Vec<u8>, String> {
    let img = image::RgbImage::from_raw(width, height, rgb.to_vec()).ok_or_else(|| {
        format!(
            "an image of {width} × {height} pixels needs {} bytes, not {}",
            width as u64 * height as u64 * 3,
            rgb.len()
        )
    })?;
    encode_png(&img)
}

/// Per-pixel counts as an RGB8 heat map: black → red → yellow → white, linear in
/// count ÷ the largest count (the report's ray-kind maps, the viewer's tests per pixel).
pub fn heat_rgb8(counts: &[u32]) -> Vec<u8> {
    let max = counts.iter().copied().max().unwrap_or(0).max(1) as f32;
    counts
        .iter()
        .flat_map(|&c| {
            let x = c as f32 / max * 3.0;
            [
                x.min(1.0),
                (x - 1.0).clamp(0.0, 1.0),
                (x - 2.0).clamp(0.0, 1.0),
            ]
            .map(|v| (v * 255.0).round() as u8)
        })
        .collect()
}

/// Write the pixels as an sRGB PNG, atomically ([`write_atomic`]); the error names the file.
pub fn write_png(pixels: &[Vec3], width: u32, height: u32, path: &Path) -> Result<(), String> {
    let bytes = png_bytes(pixels, width, height).map_err(|e| format!("{}: {e}", path.display()))?;
    write_atomic(path, &bytes)
}

/// Write row-major sRGB bytes (`width × height × 3`) as a PNG, atomically; the error names
/// the file.
pub fn write_rgb8_png(rgb: &[u8], width: u32, height: u32, path: &Path) -> Result<(), String> {
    let bytes = rgb8_png(rgb, width, height).map_err(|e| format!("{}: {e}", path.display()))?;
    write_atomic(path, &bytes)
}

/// An animated GIF of `frames` (each `width × height` sRGB bytes, as [`to_rgb8`] makes
/// them), looping, `delay_ms` per frame, written atomically. Colours are quantised per frame
/// (NeuQuant, speed 10).
pub fn write_gif(
    frames: &[Vec<u8>],
    width: u32,
    height: u32,
    delay_ms: u32,
    path: &Path,
) -> Result<(), String> {
    use image::codecs::gif::{GifEncoder, Repeat};
    let err = |e: image::ImageError| format!("{}: {e}", path.display());
    let mut buf = Vec::new();
    {
        let mut enc = GifEncoder::new_with_speed(&mut buf, 10);
        enc.set_repeat(Repeat::Infinite).map_err(err)?;
        for f in frames {
            let rgb = image::RgbImage::from_raw(width, height, f.clone()).ok_or_else(|| {
                format!(
                    "{}: a frame is not {width} × {height} pixels",
                    path.display()
                )
            })?;
            let rgba = image::DynamicImage::ImageRgb8(rgb).to_rgba8();
            let frame = image::Frame::from_parts(
                rgba,
                0,
                0,
                image::Delay::from_numer_denom_ms(delay_ms.max(10), 1),
            );
            enc.encode_frame(frame).map_err(err)?;
        }
    }
    write_atomic(path, &buf)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn atomic_writes_replace_whole_files_and_refuse_special_files() {
        let d = std::env::temp_dir().join(format!("rayspace-atomic-{}", std::process::id()));
        std::fs::create_dir_all(&d).unwrap();
        let p = d.join("a.bin");
        write_atomic(&p, b"old").unwrap();
        write_atomic(&p, b"new contents").unwrap();
        assert_eq!(std::fs::read(&p).unwrap(), b"new contents");
        // No temporary is left behind.
        let left: Vec<_> = std::fs::read_dir(&d).unwrap().collect();
        assert_eq!(left.len(), 1);
        // Special files and directories are refused, naming the path.
        let e = write_atomic(Path::new("/dev/null"), b"x").unwrap_err();
        assert!(e.contains("/dev/null") && e.contains("regular file"), "{e}");
        assert!(write_atomic(&d, b"x").unwrap_err().contains("directory"));
        let e = write_atomic(&d.join("no/such/dir/f.png"), b"x").unwrap_err();
        assert!(e.contains("does not exist"), "{e}");
        // The refused writes left the earlier file as it was.
        assert_eq!(std::fs::read(&p).unwrap(), b"new contents");
    }

    #[test]
    fn srgb_endpoints() {
        assert_eq!(srgb_encode(0.0), 0);
        assert_eq!(srgb_encode(1.0), 255);
        assert_eq!(srgb_encode(7.0), 255);
        assert_eq!(srgb_encode(f32::NAN), 0);
        assert_eq!(srgb_encode(0.2), 124);
    }
}
