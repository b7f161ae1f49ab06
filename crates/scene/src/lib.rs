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

pub use error::SceneError;
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

impl std::str::FromStr for MeshSplit {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        match s {
            "groups" => Ok(MeshSplit::Groups),
            "materials" => Ok(MeshSplit::Materials),
            "single" => Ok(MeshSplit::Single),
            _ => Err(format!(
                "unknown mesh split '{s}' (expected groups, materials or single)"
            )),
        }
    }
}

/// Options that apply to whatever loader handles a scene.
#[derive(Clone, Copy, Debug, Default)]
pub struct LoadOptions {
    /// How OBJ files are cut into meshes.
    pub split: MeshSplit,
    /// Read files the scene references even where they resolve outside the scene's
    /// directory and the scenes directory (see [`io::Sandbox`]).
    pub allow_outside_paths: bool,
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
    let sb = io::Sandbox::for_scene(path, opts.allow_outside_paths);
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
    Ok(scene)
}
