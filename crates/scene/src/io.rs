//! Reading the files a scene names, defensively: regular files only (a device, FIFO or
//! socket is refused: `mtllib /dev/zero` or an AFF `i 0 /dev/zero` must not be read until
//! memory runs out), at most [`MAX_FILE_BYTES`] (checked while reading, since `/proc` files
//! report a size of 0), with errors that name the file; and confining the files a scene
//! *references* (OBJ `mtllib`, glTF buffer URIs, TOML mesh files, AFF includes) to the
//! scene's own directory and the shared scenes directory ([`Sandbox`]), so that a scene
//! downloaded from elsewhere cannot make rayspace open `/etc/passwd` or `../../secret`.

use crate::error::SceneError;
use std::io::Read as _;
use std::path::{Path, PathBuf};

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
    text_of(path, read_file(path)?)
}

/// `bytes` of `path` as UTF-8 text without a leading byte-order mark.
fn text_of(path: &Path, bytes: Vec<u8>) -> Result<String, SceneError> {
    let mut s = String::from_utf8(bytes).map_err(|e| SceneError::Io {
        path: path.to_path_buf(),
        cause: std::io::Error::new(std::io::ErrorKind::InvalidData, e),
    })?;
    if s.starts_with('\u{feff}') {
        s.drain(..'\u{feff}'.len_utf8());
    }
    Ok(s)
}

/// Where the files a scene references may live: under the top-level scene file's directory
/// or the shared scenes directory ([`crate::scenes_dir`]), after `..` and symbolic links are
/// resolved, unless the user allowed reading outside (`allow_outside_paths`).
///
/// It also carries the load's triangle budget ([`Sandbox::with_max_triangles`]): loaders call
/// [`Sandbox::admit_triangles`] as their triangles accumulate, so that a small file that
/// expands into a huge scene (thousands of tessellated AFF spheres, a glTF mesh instanced by
/// thousands of nodes) stops with one error before its memory is allocated.
#[derive(Clone, Debug)]
pub struct Sandbox {
    roots: Vec<PathBuf>,
    allow_outside: bool,
    max_triangles: u64,
    /// What the triangle budget counts per triangle (for its message).
    bytes_per_triangle: u64,
    /// The most bytes of one file the load may hold in memory ([`Sandbox::read_file`]).
    max_file_bytes: u64,
    /// Every file admitted so far, shared by the clones of one load: what the load read
    /// besides its top-level file ([`Sandbox::files`]).
    admitted: std::sync::Arc<std::sync::Mutex<Vec<PathBuf>>>,
}

impl Sandbox {
    /// The sandbox of the scene file `top` (the file the user named is trusted; what it
    /// references is not).
    pub fn for_scene(top: &Path, allow_outside: bool) -> Sandbox {
        let dir = match top.parent() {
            Some(d) if !d.as_os_str().is_empty() => d.to_path_buf(),
            _ => PathBuf::from("."),
        };
        let roots = [Some(dir), crate::scenes_dir()]
            .into_iter()
            .flatten()
            .filter_map(|d| std::fs::canonicalize(d).ok())
            .collect();
        Sandbox {
            roots,
            allow_outside,
            max_triangles: u64::MAX,
            bytes_per_triangle: crate::BYTES_PER_TRIANGLE,
            max_file_bytes: MAX_FILE_BYTES,
            admitted: Default::default(),
        }
    }

    /// The files referenced by the scene that this load admitted (read or about to be), in
    /// the order it admitted them: with the top-level file, everything a command reads of
    /// the scene, which none of its outputs may be.
    pub fn files(&self) -> Vec<PathBuf> {
        self.admitted.lock().map(|v| v.clone()).unwrap_or_default()
    }

    /// The same sandbox holding at most `n` bytes of one file in memory (at most
    /// [`MAX_FILE_BYTES`]): the memory limit's share for reading.
    pub fn with_max_file_bytes(mut self, n: u64) -> Sandbox {
        self.max_file_bytes = n.min(MAX_FILE_BYTES);
        self
    }

    /// The bytes of the regular file `path` ([`read_file`]), refused before it is read
    /// when it is larger than this load may hold in memory.
    pub fn read_file(&self, path: &Path) -> Result<Vec<u8>, SceneError> {
        let len = std::fs::metadata(path).map(|m| m.len()).unwrap_or(0);
        if len > self.max_file_bytes {
            return Err(SceneError::invalid(
                path,
                format!(
                    "{len} bytes is more than the {} the memory limit (`max_memory`) lets one file take",
                    self.max_file_bytes
                ),
            ));
        }
        read_file(path)
    }

    /// [`Sandbox::read_file`] as UTF-8 text, as [`read_text`] reads it.
    pub fn read_text(&self, path: &Path) -> Result<String, SceneError> {
        let bytes = self.read_file(path)?;
        text_of(path, bytes)
    }

    /// The same sandbox with a budget of `n` triangles for the whole load, each counted as
    /// `bytes` (for the message).
    pub fn with_max_triangles(mut self, n: u64, bytes: u64) -> Sandbox {
        self.max_triangles = n;
        self.bytes_per_triangle = bytes;
        self
    }

    /// Refuse a load that has reached `total` triangles, more than its budget, at `path`
    /// (and `line`, where the loader knows it).
    pub fn admit_triangles(
        &self,
        path: &Path,
        line: Option<usize>,
        total: u64,
    ) -> Result<(), SceneError> {
        if total <= self.max_triangles {
            return Ok(());
        }
        let msg = format!(
            "the scene grows past {} triangles, its load budget (about {} bytes each with \
             the work done over it; the budget comes from `max_memory`)",
            self.max_triangles, self.bytes_per_triangle
        );
        Err(match line {
            Some(line) => SceneError::Parse {
                path: path.to_path_buf(),
                line,
                msg,
            },
            None => SceneError::invalid(path, msg),
        })
    }

    /// The file `name`, as written in `referrer` (relative to its directory, or absolute),
    /// if it may be read: it must exist and resolve under one of the roots. The error
    /// names the referrer and the reference but never reads the target.
    pub fn resolve(&self, referrer: &Path, what: &str, name: &str) -> Result<PathBuf, SceneError> {
        let joined = referrer.parent().unwrap_or(Path::new(".")).join(name);
        self.admit(referrer, what, name, joined)
    }

    /// [`Sandbox::resolve`] for a reference `name` that the caller already turned into the
    /// path `joined` (e.g. a TOML `scenes:REL`, relative to the scenes directory). Returns
    /// `joined` itself, so that names and messages keep the path as written.
    pub fn admit(
        &self,
        referrer: &Path,
        what: &str,
        name: &str,
        joined: PathBuf,
    ) -> Result<PathBuf, SceneError> {
        if let Ok(mut v) = self.admitted.lock() {
            v.push(joined.clone());
        }
        if self.allow_outside {
            return Ok(joined);
        }
        let real = std::fs::canonicalize(&joined)
            .map_err(|e| SceneError::invalid(referrer, format!("{what} '{name}': {e}")))?;
        if self.roots.iter().any(|r| real.starts_with(r)) {
            Ok(joined)
        } else {
            Err(SceneError::Outside {
                path: referrer.to_path_buf(),
                msg: format!(
                    "{what} '{name}' resolves outside the scene's directory{} \
                     (`allow_outside_paths` reads it)",
                    if self.roots.len() > 1 {
                        " and the scenes directory"
                    } else {
                        ""
                    }
                ),
            })
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn references_outside_the_scene_directory_are_refused_unless_allowed() {
        let d = std::env::temp_dir().join(format!("rayspace-sandbox-{}", std::process::id()));
        let inner = d.join("scene");
        std::fs::create_dir_all(inner.join("sub")).unwrap();
        std::fs::write(inner.join("sub/a.mtl"), "").unwrap();
        std::fs::write(d.join("secret.txt"), "x").unwrap();
        let top = inner.join("s.obj");
        let sb = Sandbox::for_scene(&top, false);
        assert!(sb.resolve(&top, "mtllib", "sub/a.mtl").is_ok());
        assert!(sb.resolve(&top, "mtllib", "sub/../sub/a.mtl").is_ok());
        for bad in ["../secret.txt", "sub/../../secret.txt", "/etc/passwd"] {
            let e = sb.resolve(&top, "mtllib", bad).unwrap_err().to_string();
            assert!(
                e.contains("outside the scene's directory") && e.contains("`allow_outside_paths`"),
                "{bad}: {e}"
            );
        }
        #[cfg(unix)]
        {
            // A link inside that points outside is outside.
            let _ = std::fs::remove_file(inner.join("link.txt"));
            std::os::unix::fs::symlink(d.join("secret.txt"), inner.join("link.txt")).unwrap();
            assert!(sb.resolve(&top, "mtllib", "link.txt").is_err());
        }
        let open = Sandbox::for_scene(&top, true);
        assert!(open.resolve(&top, "mtllib", "../secret.txt").is_ok());
        std::fs::remove_dir_all(&d).unwrap();
    }
}
