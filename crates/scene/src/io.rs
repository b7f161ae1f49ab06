//! Reading the files a scene names, defensively: regular files only (a device, FIFO or
//! socket is refused: `mtllib /dev/zero` or an AFF `i 0 /dev/zero` must not be read until
//! memory runs out), at most [`MAX_FILE_BYTES`] (checked while reading, since `/proc` files
//! report a size of 0), with errors that name the file.

use crate::error::SceneError;
use std::io::Read as _;
use std::path::Path;

/// The largest file a loader reads (the largest shared scene file is under 200 MiB).
pub const MAX_FILE_BYTES: u64 = 2 << 30;

/// Check that `path` is a regular file of at most [`MAX_FILE_BYTES`].
pub fn check_regular(path: &Path) -> Result<(), SceneError> {
    let m = std::fs::metadata(path).map_err(|e| SceneError::Io {
        path: path.to_path_buf(),
        cause: e,
    })?;
    if !m.is_file() {
        return Err(SceneError::invalid(
            path,
            "not a regular file (devices, FIFOs and directories are not read)",
        ));
    }
    if m.len() > MAX_FILE_BYTES {
        return Err(SceneError::invalid(
            path,
            format!(
                "{} bytes is more than the {MAX_FILE_BYTES}-byte limit",
                m.len()
            ),
        ));
    }
    Ok(())
}

/// The bytes of the regular file `path` (see [`check_regular`]).
pub fn read_file(path: &Path) -> Result<Vec<u8>, SceneError> {
    check_regular(path)?;
    let io = |e| SceneError::Io {
        path: path.to_path_buf(),
        cause: e,
    };
    let mut bytes = Vec::new();
    std::fs::File::open(path)
        .map_err(io)?
        .take(MAX_FILE_BYTES + 1)
        .read_to_end(&mut bytes)
        .map_err(io)?;
    if bytes.len() as u64 > MAX_FILE_BYTES {
        return Err(SceneError::invalid(
            path,
            format!("more than the {MAX_FILE_BYTES}-byte limit"),
        ));
    }
    Ok(bytes)
}

/// The UTF-8 text of the regular file `path`, without a leading byte-order mark (editors
/// on Windows write one; it is not part of the first line).
pub fn read_text(path: &Path) -> Result<String, SceneError> {
    let bytes = read_file(path)?;
    let mut s = String::from_utf8(bytes).map_err(|e| SceneError::Io {
        path: path.to_path_buf(),
        cause: std::io::Error::new(std::io::ErrorKind::InvalidData, e),
    })?;
    if s.starts_with('\u{feff}') {
        s.drain(..'\u{feff}'.len_utf8());
    }
    Ok(s)
}
