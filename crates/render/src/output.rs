//! Output files: linear RGB → sRGB-encoded 8-bit PNG and animated GIF, and the atomic write
//! every output of rayspace goes through ([`write_atomic`]): a reader (or a crash, or a full
//! disk) sees the old file or the whole new one, never a truncated one.

use geom::Vec3;
use std::io::Write as _;
use std::path::{Path, PathBuf};

/// Why an output file was not written. Every variant names the file.
#[derive(Debug, thiserror::Error)]
pub enum OutputError {
    /// The path has no file name (`dir/`).
    #[error("{}: not a file name", .0.display())]
    NotAFileName(PathBuf),
    /// The file's directory does not exist.
    #[error("{}: directory {} does not exist", .path.display(), .dir.display())]
    NoDirectory {
        /// The file.
        path: PathBuf,
        /// Its directory.
        dir: PathBuf,
    },
    /// The path is a directory.
    #[error("{}: is a directory", .0.display())]
    IsDirectory(PathBuf),
    /// The path is a device, FIFO or socket.
    #[error("{}: not a regular file (a device, FIFO or socket is never written)", .0.display())]
    NotRegular(PathBuf),
    /// Writing failed (disk full, no permission); the old file is left as it was.
    #[error("{}: {error}", .path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The system's error.
        error: std::io::Error,
    },
    /// The image encoder failed.
    #[error("{}PNG/GIF encoding: {msg}", at(.path))]
    Encode {
        /// The file, when there is one.
        path: Option<PathBuf>,
        /// The encoder's message.
        msg: String,
    },
    /// The pixels are not `width × height` of them.
    #[error("{}an image of {width} × {height} pixels needs {need} bytes, not {got}", at(.path))]
    Size {
        /// The file, when there is one.
        path: Option<PathBuf>,
        /// Image width.
        width: u32,
        /// Image height.
        height: u32,
        /// Bytes such an image has.
        need: u64,
        /// Bytes given.
        got: u64,
    },
}

fn at(path: &Option<PathBuf>) -> String {
    path.as_ref()
        .map(|p| format!("{}: ", p.display()))
        .unwrap_or_default()
}

impl OutputError {
    /// The same error, naming `path` where it named no file.
    fn at(self, path: &Path) -> OutputError {
        match self {
            OutputError::Encode { path: None, msg } => OutputError::Encode {
                path: Some(path.to_path_buf()),
                msg,
            },
            OutputError::Size {
                path: None,
                width,
                height,
                need,
                got,
            } => OutputError::Size {
                path: Some(path.to_path_buf()),
                width,
                height,
                need,
                got,
            },
            e => e,
        }
    }
}

/// Check that `path` can be an output before any work is done: its directory exists, and
/// it is not a directory or a special file (device, FIFO, socket: only regular files are
/// replaced). The error names the path.
pub fn check_output(path: &Path) -> Result<(), OutputError> {
    if path.file_name().is_none() {
        return Err(OutputError::NotAFileName(path.to_path_buf()));
    }
    let dir = parent_dir(path);
    if !dir.is_dir() {
        return Err(OutputError::NoDirectory {
            path: path.to_path_buf(),
            dir,
        });
    }
    match std::fs::metadata(path) {
        Ok(m) if m.is_dir() => Err(OutputError::IsDirectory(path.to_path_buf())),
        Ok(m) if !m.is_file() => Err(OutputError::NotRegular(path.to_path_buf())),
        _ => Ok(()),
    }
}

/// [`check_output`], and a file can be made in the folder: a probe, created exclusively and
/// removed at once, so that a read-only or special file system (`/sys`, a full disk's
/// quota) is found before any work rather than when the output is written.
pub fn check_writable(path: &Path) -> Result<(), OutputError> {
    check_output(path)?;
    tempfile::Builder::new()
        .prefix(".rayspace-")
        .suffix(".probe")
        .tempfile_in(parent_dir(path))
        .map(drop)
        .map_err(|error| OutputError::Io {
            path: path.to_path_buf(),
            error,
        })
}

fn parent_dir(path: &Path) -> PathBuf {
    match path.parent() {
        Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
        _ => PathBuf::from("."),
    }
}

/// Write `bytes` to `path` atomically: a temporary file in the same directory, written,
/// flushed to the disk, then renamed over `path`. The temporary is created exclusively under
/// an unpredictable name (`O_CREAT | O_EXCL`, by `tempfile`), so a file or symbolic link
/// planted under a name that could be guessed redirects nothing, and a long output name
/// still fits (the temporary's name is short); it takes the permissions of the file it
/// replaces, or the ones a new file gets (0666 less the umask). A symbolic link at `path`
/// is replaced, never written through. On any failure (disk full, no permission, a file-size
/// limit) the temporary is removed, an existing `path` is left as it was, and the error
/// names the path. While it exists the temporary is held for [`remove_temporaries`].
pub fn write_atomic(path: &Path, bytes: &[u8]) -> Result<(), OutputError> {
    check_output(path)?;
    let io = |error| OutputError::Io {
        path: path.to_path_buf(),
        error,
    };
    if STOPPING.load(std::sync::atomic::Ordering::SeqCst) {
        return Err(io(std::io::Error::new(
            std::io::ErrorKind::Interrupted,
            "the command is being interrupted",
        )));
    }
    let tmp = tempfile::Builder::new()
        .prefix(".rayspace-")
        .suffix(".tmp")
        .tempfile_in(parent_dir(path))
        .map_err(io)?;
    let held = Held::new(tmp.path());
    let mode = match std::fs::symlink_metadata(path) {
        Ok(m) if m.is_file() => m.permissions(),
        _ => new_file_permissions(),
    };
    let result = (|| {
        let mut f = tmp.as_file();
        f.write_all(bytes)?;
        f.set_permissions(mode)?;
        f.sync_all()?;
        tmp.persist(path).map(|_| ()).map_err(|e| e.error)
    })();
    drop(held);
    result.map_err(io)
}

/// The permissions a newly created file gets: 0666 less the process's umask (read from
/// `/proc/self/status`; 022 where it cannot be).
fn new_file_permissions() -> std::fs::Permissions {
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt as _;
        let umask = std::fs::read_to_string("/proc/self/status")
            .ok()
            .and_then(|s| {
                let l = s.lines().find(|l| l.starts_with("Umask:"))?;
                u32::from_str_radix(l["Umask:".len()..].trim(), 8).ok()
            })
            .unwrap_or(0o022);
        std::fs::Permissions::from_mode(0o666 & !umask)
    }
    #[cfg(not(unix))]
    {
        std::fs::metadata(".")
            .map(|m| m.permissions())
            .unwrap_or_else(|_| unreachable!("the working directory has metadata"))
    }
}

/// Temporary files and folders that exist only while a command runs: removed by
/// [`remove_temporaries`] when the command is interrupted (the command line's signal
/// handler calls it), so that an interrupt leaves none behind.
static TEMPORARIES: std::sync::Mutex<Vec<PathBuf>> = std::sync::Mutex::new(Vec::new());

/// A temporary file or folder held for [`remove_temporaries`] while this lives.
pub struct Held(PathBuf);

impl Held {
    /// Hold `path`.
    pub fn new(path: &Path) -> Held {
        if let Ok(mut t) = TEMPORARIES.lock() {
            t.push(path.to_path_buf());
        }
        Held(path.to_path_buf())
    }
}

impl Drop for Held {
    fn drop(&mut self) {
        if let Ok(mut t) = TEMPORARIES.lock() {
            if let Some(i) = t.iter().rposition(|p| *p == self.0) {
                t.swap_remove(i);
            }
        }
    }
}

/// A temporary folder, made exclusively under an unpredictable name (`mkdtemp`, by
/// `tempfile`), held for [`remove_temporaries`] and removed with everything in it when
/// dropped.
pub struct TempFolder {
    dir: tempfile::TempDir,
    _held: Held,
}

impl TempFolder {
    /// A new folder in `parent` whose name starts with `prefix`.
    pub fn new_in(parent: &Path, prefix: &str) -> std::io::Result<TempFolder> {
        let dir = tempfile::Builder::new().prefix(prefix).tempdir_in(parent)?;
        let held = Held::new(dir.path());
        Ok(TempFolder { dir, _held: held })
    }

    /// Its path.
    pub fn path(&self) -> &Path {
        self.dir.path()
    }
}

/// Set once the command is being interrupted: no output is written any more, so that the
/// temporaries [`remove_temporaries`] removes are not made again behind it.
static STOPPING: std::sync::atomic::AtomicBool = std::sync::atomic::AtomicBool::new(false);

/// Whether the command is being interrupted ([`remove_temporaries`] has run): whoever
/// ends it (the signal's handler) says so and sets the exit status.
pub fn stopping() -> bool {
    STOPPING.load(std::sync::atomic::Ordering::SeqCst)
}

/// Remove every temporary file and folder held now (an interrupted command's), after which
/// no output is written; returns how many were removed. A folder that another thread is
/// still writing into is tried again for a while (its writes stop at their next file).
pub fn remove_temporaries() -> usize {
    STOPPING.store(true, std::sync::atomic::Ordering::SeqCst);
    let held = match TEMPORARIES.lock() {
        Ok(mut t) => std::mem::take(&mut *t),
        Err(_) => return 0,
    };
    let remove = |p: &Path| match std::fs::symlink_metadata(p) {
        Ok(m) if m.is_dir() => std::fs::remove_dir_all(p).is_ok(),
        Ok(_) => std::fs::remove_file(p).is_ok(),
        Err(_) => true,
    };
    held.iter()
        .filter(|p| {
            (0..50).any(|_| {
                let done = remove(p);
                if !done {
                    std::thread::sleep(std::time::Duration::from_millis(10));
                }
                done
            })
        })
        .count()
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
pub fn png_bytes(pixels: &[Vec3], width: u32, height: u32) -> Result<Vec<u8>, OutputError> {
    encode_png(&to_rgb8(pixels, width, height))
}

/// An 8-bit RGB image as PNG bytes: the one encoder (and its settings) behind every PNG
/// rayspace writes, so an image written by the bindings has the command line's bytes.
pub fn encode_png(img: &image::RgbImage) -> Result<Vec<u8>, OutputError> {
    let mut buf = Vec::new();
    img.write_to(&mut std::io::Cursor::new(&mut buf), image::ImageFormat::Png)
        .map_err(|e| OutputError::Encode {
            path: None,
            msg: e.to_string(),
        })?;
    Ok(buf)
}

/// Row-major 8-bit RGB bytes (`width × height × 3`) as PNG bytes ([`encode_png`]).
pub fn rgb8_png(rgb: &[u8], width: u32, height: u32) -> Result<Vec<u8>, OutputError> {
    let img = image::RgbImage::from_raw(width, height, rgb.to_vec()).ok_or(OutputError::Size {
        path: None,
        width,
        height,
        need: width as u64 * height as u64 * 3,
        got: rgb.len() as u64,
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
pub fn write_png(pixels: &[Vec3], width: u32, height: u32, path: &Path) -> Result<(), OutputError> {
    let bytes = png_bytes(pixels, width, height).map_err(|e| e.at(path))?;
    write_atomic(path, &bytes)
}

/// Write row-major sRGB bytes (`width × height × 3`) as a PNG, atomically; the error names
/// the file.
pub fn write_rgb8_png(rgb: &[u8], width: u32, height: u32, path: &Path) -> Result<(), OutputError> {
    let bytes = rgb8_png(rgb, width, height).map_err(|e| e.at(path))?;
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
) -> Result<(), OutputError> {
    use image::codecs::gif::{GifEncoder, Repeat};
    let err = |e: image::ImageError| OutputError::Encode {
        path: Some(path.to_path_buf()),
        msg: e.to_string(),
    };
    let mut buf = Vec::new();
    {
        let mut enc = GifEncoder::new_with_speed(&mut buf, 10);
        enc.set_repeat(Repeat::Infinite).map_err(err)?;
        for f in frames {
            let rgb =
                image::RgbImage::from_raw(width, height, f.clone()).ok_or(OutputError::Size {
                    path: Some(path.to_path_buf()),
                    width,
                    height,
                    need: width as u64 * height as u64 * 3,
                    got: f.len() as u64,
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
        #[cfg(unix)]
        {
            use std::os::unix::fs::PermissionsExt as _;
            // A replaced file keeps its permissions.
            std::fs::set_permissions(&p, std::fs::Permissions::from_mode(0o600)).unwrap();
            write_atomic(&p, b"private").unwrap();
            let mode = std::fs::metadata(&p).unwrap().permissions().mode();
            assert_eq!(mode & 0o777, 0o600);
            // A symbolic link planted at the output is replaced, its target untouched; a
            // 250-byte name fits.
            let target = d.join("target.txt");
            std::fs::write(&target, b"keep").unwrap();
            let link = d.join("link.png");
            std::os::unix::fs::symlink(&target, &link).unwrap();
            write_atomic(&link, b"img").unwrap();
            assert_eq!(std::fs::read(&target).unwrap(), b"keep");
            assert!(!std::fs::symlink_metadata(&link).unwrap().is_symlink());
            let long = d.join(format!("{}.png", "n".repeat(246)));
            write_atomic(&long, b"x").unwrap();
            std::fs::remove_file(&long).unwrap();
            std::fs::remove_file(&link).unwrap();
            std::fs::remove_file(&target).unwrap();
            write_atomic(&p, b"new contents").unwrap();
        }
        // Special files and directories are refused, naming the path.
        let e = write_atomic(Path::new("/dev/null"), b"x")
            .unwrap_err()
            .to_string();
        assert!(e.contains("/dev/null") && e.contains("regular file"), "{e}");
        assert!(write_atomic(&d, b"x")
            .unwrap_err()
            .to_string()
            .contains("directory"));
        let e = write_atomic(&d.join("no/such/dir/f.png"), b"x")
            .unwrap_err()
            .to_string();
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
