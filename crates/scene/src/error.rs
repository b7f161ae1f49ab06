//! Loader errors: every variant names the file (and line, where there is one).

use std::path::PathBuf;

#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    #[error("{path}: {cause}")]
    Io {
        path: PathBuf,
        cause: std::io::Error,
    },
    #[error("{path}:{line}: {msg}")]
    Parse {
        path: PathBuf,
        line: usize,
        msg: String,
    },
    #[error("{path}: {msg}")]
    Invalid { path: PathBuf, msg: String },
    #[error("{path}: the scene has no triangles{detail}")]
    Empty { path: PathBuf, detail: String },
    #[error("unknown scene '{name}': not a file and not a built-in scene ({builtins})")]
    UnknownScene { name: String, builtins: String },
}

impl SceneError {
    pub(crate) fn invalid(path: &std::path::Path, msg: impl Into<String>) -> Self {
        SceneError::Invalid {
            path: path.to_path_buf(),
            msg: msg.into(),
        }
    }
}
