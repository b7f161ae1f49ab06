//! The scene model and everything that produces one.
//!
//! A [`Scene`] is a list of [`Mesh`]es (named triangle meshes with their own transform: the
//! unit the ray-space hierarchies cull by bounding sphere), materials, point lights and a
//! pinhole camera. Scenes come from built-in generators ([`builtin`]), OBJ/MTL files
//! ([`obj`]), glTF 2.0 files ([`gltf_load`]) and TOML scene files ([`scenefile`]) that compose
//! them. Engines never see a `Scene`: they consume its flattened world-space [`Geometry`].

#![warn(missing_docs)]

pub mod aff;
pub mod anim;
pub mod builtin;
pub mod error;
pub mod geometry;
pub mod gltf_load;
pub mod io;
pub mod model;
pub mod obj;
pub mod scenefile;
pub mod shapes;

pub use error::{Invalid, SceneError};
pub use geometry::Geometry;
pub use model::{Camera, Light, LoadReport, Material, Mesh, Scene};

use std::path::{Path, PathBuf};

/// How an OBJ file is cut into meshes. Culling by mesh bounding sphere depends on it.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Default)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum MeshSplit {
    /// One mesh per `o`/`g` group (the default).
    #[default]
    Groups,
    /// One mesh per material.
    Materials,
    /// The whole file is one mesh.
    Single,
}

impl MeshSplit {
    /// Every value by its name (as options spell it).
    pub const NAMES: [(&'static str, MeshSplit); 3] = [
        ("groups", MeshSplit::Groups),
        ("materials", MeshSplit::Materials),
        ("single", MeshSplit::Single),
    ];
}

impl std::str::FromStr for MeshSplit {
    type Err = Invalid;
    fn from_str(s: &str) -> Result<Self, Invalid> {
        match s {
            "groups" => Ok(MeshSplit::Groups),
            "materials" => Ok(MeshSplit::Materials),
            "single" => Ok(MeshSplit::Single),
            _ => Err(Invalid(format!(
                "unknown mesh split '{s}' (expected groups, materials or single)"
            ))),
        }
    }
}

/// Options that apply to whatever loader handles a scene.
#[derive(Clone, Copy, Debug)]
pub struct LoadOptions {
    /// How OBJ files are cut into meshes.
    pub split: MeshSplit,
    /// Read files the scene references even where they resolve outside the scene's
    /// directory and the scenes directory (see [`io::Sandbox`]).
    pub allow_outside_paths: bool,
    /// Most triangles the loaded scene may have (checked while it is built; see
    /// [`io::Sandbox::admit_triangles`]). No limit by default; [`LoadOptions::for_memory`]
    /// derives one from a memory budget.
    pub max_triangles: u64,
}

impl Default for LoadOptions {
    fn default() -> Self {
        LoadOptions {
            split: MeshSplit::default(),
            allow_outside_paths: false,
            max_triangles: u64::MAX,
        }
    }
}

/// Bytes the scene model takes per triangle at most, as the loaders' budget counts them:
/// three unshared vertices with normals (72), the index triple (12), the material (4), and
/// the mesh's share of its bookkeeping (8).
pub const BYTES_PER_TRIANGLE: u64 = 96;

impl LoadOptions {
    /// The triangle budget that fits `bytes` of scene model.
    pub fn for_memory(self, bytes: u64) -> LoadOptions {
        LoadOptions {
            max_triangles: bytes / BYTES_PER_TRIANGLE,
            ..self
        }
    }
}

/// The directory holding the shared real scenes: `$RAYSPACE_SCENES`, else `../shared/scenes`
/// (relative to the current directory or to the workspace root) when it exists.
pub fn scenes_dir() -> Option<PathBuf> {
    if let Some(d) = std::env::var_os("RAYSPACE_SCENES") {
        let p = PathBuf::from(d);
        return p.is_dir().then_some(p);
    }
    let candidates = [
        PathBuf::from("../shared/scenes"),
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/scenes"),
    ];
    candidates.into_iter().find(|p| p.is_dir())
}

/// Load a scene by built-in name or file path (`.obj`, `.gltf`/`.glb`, `.toml`).
pub fn load(spec: &str, opts: &LoadOptions) -> Result<Scene, SceneError> {
    let path = Path::new(spec);
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase());
    let sb = io::Sandbox::for_scene(path, opts.allow_outside_paths)
        .with_max_triangles(opts.max_triangles);
    let scene = match ext.as_deref() {
        Some("obj") => obj::load_obj_scene_in(path, opts.split, &sb)?,
        Some("gltf") | Some("glb") => gltf_load::load_gltf_scene_in(path, &sb)?,
        Some("toml") => scenefile::load_scene_file_in(path, &sb)?,
        Some("aff") | Some("nff") => aff::load_aff_scene_in(path, &sb)?,
        _ => match builtin::by_name(spec) {
            Some(s) => s,
            None if path.exists() => {
                return Err(SceneError::Invalid {
                    path: path.to_path_buf(),
                    msg: "unsupported file type (expected .obj, .gltf, .glb, .toml or .aff)".into(),
                })
            }
            None => {
                return Err(SceneError::UnknownScene {
                    name: spec.to_string(),
                    builtins: builtin::NAMES.join(", "),
                })
            }
        },
    };
    scene.validate()?;
    // The file loaders check as they go; this covers the built-in scenes.
    sb.admit_triangles(path, None, scene.triangle_count() as u64)?;
    Ok(scene)
}
