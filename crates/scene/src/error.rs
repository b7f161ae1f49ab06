//! Loader errors: every variant names the file (and line, where there is one).

use std::path::PathBuf;

/// Why a scene could not be loaded.
#[derive(Debug, thiserror::Error)]
pub enum SceneError {
    /// The file could not be read.
    #[error("{path}: {cause}")]
    Io {
        /// The file.
        path: PathBuf,
        /// The system's error.
        cause: std::io::Error,
    },
    /// A syntax error at a line.
    #[error("{path}:{line}: {msg}")]
    Parse {
        /// The file.
        path: PathBuf,
        /// The line (1-based).
        line: usize,
        /// What is wrong.
        msg: String,
    },
    /// Well-formed but unusable content (bad values, missing parts).
    #[error("{path}: {msg}")]
    Invalid {
        /// The file.
        path: PathBuf,
        /// What is wrong.
        msg: String,
    },
    /// A file the scene references resolves outside its directory and the scenes
    /// directory (see [`crate::io::Sandbox`]).
    #[error("{path}: {msg}")]
    Outside {
        /// The referring file.
        path: PathBuf,
        /// The reference and where it may be read from.
        msg: String,
    },
    /// Nothing to render.
    #[error("{path}: the scene has no triangles{detail}")]
    Empty {
        /// The file.
        path: PathBuf,
        /// Why, when known (e.g. every triangle degenerate).
        detail: String,
    },
    /// Arrays that make no scene ([`crate::arrays`]).
    #[error(transparent)]
    Arrays(#[from] ArrayError),
    /// Neither a file nor a built-in scene.
    #[error("unknown scene '{name}': not a file and not {known}{}", suggestion.map(|s| format!("; did you mean '{s}'?")).unwrap_or_default())]
    UnknownScene {
        /// The name given.
        name: String,
        /// The scene name nearest to it, where one is near (a typo).
        suggestion: Option<&'static str>,
        /// The names that are known: the built-in scenes ([`crate::builtin::NAMES`]), the
        /// generators' forms ([`crate::generate::NAMES`]) and the shared real scenes
        /// ([`crate::SHARED`]).
        known: String,
    },
    /// A generated scene's spec (`hairball:2M`) that names a generator but is malformed.
    #[error("scene '{spec}': {error}")]
    Generator {
        /// The spec given.
        spec: String,
        /// What is wrong with it.
        error: SpecError,
    },
    /// A shared real scene by name, with no scenes directory to find it in.
    #[error("scene '{name}' is {file} in the shared scenes, and there is no scenes directory: set RAYSPACE_SCENES or provide ../shared/scenes")]
    NoScenesDir {
        /// The name given.
        name: String,
        /// Its file under the scenes directory.
        file: String,
    },
}

impl SceneError {
    pub(crate) fn invalid(path: &std::path::Path, msg: impl Into<String>) -> Self {
        SceneError::Invalid {
            path: path.to_path_buf(),
            msg: msg.into(),
        }
    }
}

/// What is wrong with a value of a scene (a material, an animation, a shape), before the
/// loader attaches the file and line to it as a [`SceneError`].
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("{0}")]
pub struct Invalid(pub String);

impl From<String> for Invalid {
    fn from(s: String) -> Self {
        Invalid(s)
    }
}

impl From<&str> for Invalid {
    fn from(s: &str) -> Self {
        Invalid(s.to_string())
    }
}

/// Why a viewpoint (`EX,EY,EZ,TX,TY,TZ[,FOV]`) was refused.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum ViewpointError {
    /// Not 6 or 7 comma-separated finite numbers.
    #[error("'{0}': expected 6 or 7 finite numbers EX,EY,EZ,TX,TY,TZ[,FOV] (eye, target, vertical field of view in degrees)")]
    Form(String),
}

/// Why a generator spec (`hairball:2M`) is malformed.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
pub enum SpecError {
    /// Not `GENERATOR:SIZE[:SEED]`.
    #[error("expected {0}:SIZE[:SEED], e.g. {0}:2M or {0}:250k:7")]
    Form(&'static str),
    /// The size is not a count.
    #[error(
        "size '{size}' is not a count like 10000, 250k or 2M (expected {generator}:SIZE[:SEED])"
    )]
    Size {
        /// The generator.
        generator: &'static str,
        /// The size given.
        size: String,
    },
    /// The size is a count out of range.
    #[error("size {triangles} is outside {min}..={max} triangles")]
    Range {
        /// The count given.
        triangles: u64,
        /// The smallest count a generator makes.
        min: u64,
        /// The largest.
        max: u64,
    },
    /// The seed is not a whole number.
    #[error("seed '{seed}' is not a whole number (expected {generator}:SIZE[:SEED])")]
    Seed {
        /// The generator.
        generator: &'static str,
        /// The seed given.
        seed: String,
    },
}

/// Why arrays were refused (each names the row or mesh at fault).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum ArrayError {
    /// A scene needs at least one face.
    #[error("no faces: a scene needs at least one triangle")]
    NoFaces,
    /// A face names a vertex that is not there.
    #[error("face {row}: vertex index {index} is out of range ({vertices} vertices)")]
    Index {
        /// The face's row.
        row: usize,
        /// The index given.
        index: u32,
        /// The vertices there are.
        vertices: usize,
    },
    /// A vertex coordinate is NaN or infinite.
    #[error("vertex {row} is not finite: {value}")]
    NotFinite {
        /// The vertex's row.
        row: usize,
        /// Its value.
        value: geom::Vec3,
    },
    /// More faces than triangle ids hold (2^31), or more vertices than indices (2^32).
    #[error("{count} {what}: more than the {max} a scene holds")]
    TooMany {
        /// "faces" or "vertices".
        what: &'static str,
        /// How many were given.
        count: usize,
        /// The most there may be.
        max: usize,
    },
    /// No mesh of that index.
    #[error("mesh {mesh}: no such mesh (the scene has {meshes})")]
    NoMesh {
        /// The index given.
        mesh: usize,
        /// The scene's meshes.
        meshes: usize,
    },
    /// New positions for a mesh must be as many as its vertices (its faces stay).
    #[error("mesh {mesh}: {given} vertices given, the mesh has {has}")]
    VertexCount {
        /// The mesh.
        mesh: usize,
        /// Vertices given.
        given: usize,
        /// Vertices the mesh has.
        has: usize,
    },
    /// No material of that index.
    #[error("material {material}: no such material (the scene has {materials})")]
    NoMaterial {
        /// The index given.
        material: u32,
        /// The scene's materials.
        materials: usize,
    },
    /// A transform that is not finite or not invertible.
    #[error("mesh {mesh}: the transform is not finite or not invertible")]
    Transform {
        /// The mesh.
        mesh: usize,
    },
    /// The part of a mesh asked to change is moved by the scene's animation.
    #[error("mesh {mesh}: its {what} come from the scene's animation")]
    Animated {
        /// The mesh.
        mesh: usize,
        /// "vertices" or "transform".
        what: &'static str,
    },
}
