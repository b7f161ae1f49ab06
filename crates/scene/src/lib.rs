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
pub mod arrays;
pub mod autocam;
pub mod builtin;
pub mod error;
pub mod generate;
pub mod geometry;
pub mod gltf_load;
pub mod io;
pub mod model;
pub mod obj;
pub mod objfast;
pub mod scenefile;
pub mod shapes;

pub use arrays::SceneBuilder;
pub use error::{ArrayError, Invalid, SceneError, SpecError, ViewpointError};
pub use geometry::Geometry;
pub use model::{Camera, Light, LoadReport, Material, Mesh, Scene, SceneId};

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
    /// Most bytes of one file the load may read into memory (at most
    /// [`io::MAX_FILE_BYTES`]; [`LoadOptions::for_process`] sets it from a memory budget).
    pub max_file_bytes: u64,
    /// What the budget counts per triangle, for messages ([`BYTES_PER_TRIANGLE`], or the
    /// whole process's share with [`LoadOptions::for_process`]).
    pub bytes_per_triangle: u64,
    /// The ambient fill ([`autocam::apply_fill`]): `None` gives it to scenes whose lights
    /// are automatic ([`LoadReport::automatic_lights`]) and to no other; `Some` forces it
    /// on or off.
    pub fill: Option<bool>,
    /// Exposure in stops ([`Scene::expose`]); 0 leaves the scene's light as it is.
    pub exposure: f32,
}

impl Default for LoadOptions {
    fn default() -> Self {
        LoadOptions {
            split: MeshSplit::default(),
            allow_outside_paths: false,
            max_triangles: u64::MAX,
            max_file_bytes: io::MAX_FILE_BYTES,
            bytes_per_triangle: BYTES_PER_TRIANGLE,
            fill: None,
            exposure: 0.0,
        }
    }
}

/// Bytes the scene model takes per triangle at most, as the loaders' budget counts them:
/// three unshared vertices with normals (72), the index triple (12), the material (4), and
/// the mesh's share of its bookkeeping (8).
pub const BYTES_PER_TRIANGLE: u64 = 96;

/// What a loaded scene holds in memory per triangle, with the flattened [`Geometry`] made
/// from it: above the measured 130–232 bytes (city and hairball scenes,
/// `bench/results/2026-12-07-2core/memory.txt`), for whole-process memory models.
pub const RESIDENT_BYTES_PER_TRIANGLE: u64 = 240;

impl LoadOptions {
    /// The triangle budget that fits `bytes` of scene model.
    pub fn for_memory(self, bytes: u64) -> LoadOptions {
        LoadOptions {
            max_triangles: bytes / BYTES_PER_TRIANGLE,
            ..self
        }
    }

    /// The triangle budget that fits `bytes` of a whole process whose every triangle costs
    /// [`RESIDENT_BYTES_PER_TRIANGLE`] for the scene and `extra` more (the engine built over
    /// it): a scene too large for the work stops while it loads, before its memory is
    /// allocated.
    pub fn for_process(self, bytes: u64, extra: u64) -> LoadOptions {
        LoadOptions {
            max_triangles: bytes / (RESIDENT_BYTES_PER_TRIANGLE + extra),
            max_file_bytes: bytes.min(io::MAX_FILE_BYTES),
            bytes_per_triangle: RESIDENT_BYTES_PER_TRIANGLE + extra,
            ..self
        }
    }
}

/// The directory holding the shared real scenes: `$RAYSPACE_SCENES`, else `../shared/scenes`
/// (relative to the current directory or to the workspace root) when it exists. The path is
/// made absolute, so that it still names the directory when handed to a process (or a
/// file) that runs elsewhere.
pub fn scenes_dir() -> Option<PathBuf> {
    let absolute = |p: PathBuf| std::fs::canonicalize(&p).unwrap_or(p);
    if let Some(d) = std::env::var_os("RAYSPACE_SCENES") {
        let p = PathBuf::from(d);
        return p.is_dir().then(|| absolute(p));
    }
    let candidates = [
        PathBuf::from("../shared/scenes"),
        Path::new(env!("CARGO_MANIFEST_DIR")).join("../../../shared/scenes"),
    ];
    candidates.into_iter().find(|p| p.is_dir()).map(absolute)
}

/// The shared real scenes by name: the papers' benchmark views (`bench/scenes/*.toml`,
/// built into the binary, their meshes read from the scenes directory) and BART's animated
/// scenes (their `.aff` files there).
pub const SHARED: [(&str, Shared); 4] = [
    (
        "sponza",
        Shared::SceneFile(
            "bench/scenes/sponza.toml",
            include_str!("../../../bench/scenes/sponza.toml"),
        ),
    ),
    (
        "conference",
        Shared::SceneFile(
            "bench/scenes/conference.toml",
            include_str!("../../../bench/scenes/conference.toml"),
        ),
    ),
    ("kitchen", Shared::File("bart-kitchen/aff/kitchen.aff")),
    ("museum", Shared::File("bart-museum/aff/museum5.aff")),
];

/// How a shared scene looks best when it is viewed rather than measured: (ambient fill,
/// exposure in stops) for `render` and `view` to take unless told otherwise. The benchmarks
/// and the report keep the thesis's lighting (eq. 3.19, no fill): these scenes' own lights
/// leave 31–57 % of a 256² view pure black, and Kitchen's 20 % clipped white; with these
/// looks none is over 10 % black or 5 % clipped (`tests/command/looks.rs` checks it).
pub fn named_look(name: &str) -> Option<(bool, f32)> {
    Some(match name {
        "sponza" | "museum" => (true, 0.0),
        "conference" | "kitchen" => (true, -0.5),
        _ => return None,
    })
}

/// Where a shared scene comes from.
#[derive(Clone, Copy, Debug)]
pub enum Shared {
    /// A TOML scene file built into the binary (its name in the repository, its text),
    /// whose meshes are `scenes:` paths.
    SceneFile(&'static str, &'static str),
    /// A file under the scenes directory.
    File(&'static str),
}

/// The names [`load`] accepts besides files: the built-ins, then the shared scenes.
pub fn scene_names() -> Vec<&'static str> {
    builtin::NAMES
        .iter()
        .copied()
        .chain(SHARED.iter().map(|s| s.0))
        .collect()
}

/// A shared scene by name ([`SHARED`]), loaded from the scenes directory.
fn load_shared(name: &str, what: Shared, opts: &LoadOptions) -> Result<Scene, SceneError> {
    let Some(dir) = scenes_dir() else {
        return Err(SceneError::NoScenesDir {
            name: name.into(),
            file: match what {
                Shared::SceneFile(..) => "a view of the shared scenes".to_string(),
                Shared::File(f) => f.to_string(),
            },
        });
    };
    match what {
        Shared::File(rel) => {
            let p = dir.join(rel);
            load(&p.to_string_lossy(), opts)
        }
        Shared::SceneFile(path, text) => {
            let path = Path::new(path);
            let sb = io::Sandbox::for_scene(path, opts.allow_outside_paths)
                .with_max_triangles(opts.max_triangles, opts.bytes_per_triangle)
                .with_max_file_bytes(opts.max_file_bytes);
            let mut scene = scenefile::load_scene_text_in(text, path, &sb)?;
            finish(&mut scene, path, &sb, opts)?;
            Ok(scene)
        }
    }
}

/// What every load ends with: the scene's invariants, the triangle budget (the file
/// loaders check as they go; this covers the built-in scenes) and the ambient fill.
fn finish(
    scene: &mut Scene,
    path: &Path,
    sb: &io::Sandbox,
    opts: &LoadOptions,
) -> Result<(), SceneError> {
    scene.validate()?;
    sb.admit_triangles(path, None, scene.triangle_count() as u64)?;
    if path.is_file() {
        scene.report.files.push(path.to_path_buf());
    }
    scene.report.files.extend(sb.files());
    if opts.fill.unwrap_or(scene.report.automatic_lights) {
        autocam::apply_fill(scene);
    }
    scene.expose(opts.exposure);
    Ok(())
}

/// The scene name nearest to `name` (built-in, shared or a generator), where it is at most
/// two edits away (a typo: `offce`, `sponsa`, `hairbal:2M`).
pub fn suggest(name: &str) -> Option<&'static str> {
    let (head, _) = name.split_once(':').unwrap_or((name, ""));
    let head = head.to_ascii_lowercase();
    builtin::NAMES
        .iter()
        .copied()
        .chain(SHARED.iter().map(|s| s.0))
        .chain(generate::NAMES.iter().copied())
        .map(|n| (edits(&head, n), n))
        .filter(|&(d, n)| d > 0 && d <= 2 && d < n.len())
        .min_by_key(|&(d, _)| d)
        .map(|(_, n)| n)
}

/// The edit distance between `a` and `b` (insertions, deletions, substitutions).
fn edits(a: &str, b: &str) -> usize {
    let b: Vec<char> = b.chars().collect();
    let mut row: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.chars().enumerate() {
        let mut prev = row[0];
        row[0] = i + 1;
        for j in 0..b.len() {
            let cur = row[j + 1];
            row[j + 1] = if ca == b[j] {
                prev
            } else {
                1 + prev.min(row[j]).min(cur)
            };
            prev = cur;
        }
    }
    row[b.len()]
}

/// Load a scene by built-in name or file path (`.obj`, `.gltf`/`.glb`, `.toml`).
pub fn load(spec: &str, opts: &LoadOptions) -> Result<Scene, SceneError> {
    let path = Path::new(spec);
    let ext = path
        .extension()
        .and_then(|e| e.to_str())
        .map(|e| e.to_ascii_lowercase());
    let sb = io::Sandbox::for_scene(path, opts.allow_outside_paths)
        .with_max_triangles(opts.max_triangles, opts.bytes_per_triangle)
        .with_max_file_bytes(opts.max_file_bytes);
    let mut scene = match ext.as_deref() {
        Some("obj") => obj::load_obj_scene_in(path, opts.split, &sb)?,
        Some("gltf") | Some("glb") => gltf_load::load_gltf_scene_in(path, &sb)?,
        Some("toml") => scenefile::load_scene_file_in(path, &sb)?,
        Some("aff") | Some("nff") => aff::load_aff_scene_in(path, &sb)?,
        _ => match builtin::by_name(spec) {
            Some(s) => s,
            None if !path.exists() && generate::Spec::parse(spec).is_some() => {
                let g = generate::Spec::parse(spec)
                    .expect("a generator")
                    .map_err(|error| SceneError::Generator {
                        spec: spec.to_string(),
                        error,
                    })?;
                // The budget is checked before the triangles are made.
                sb.admit_triangles(path, None, g.triangles)?;
                g.generate()
            }
            None if !path.exists() && SHARED.iter().any(|s| s.0 == spec) => {
                let what = SHARED.iter().find(|s| s.0 == spec).expect("found").1;
                return load_shared(spec, what, opts);
            }
            None if path.exists() => {
                return Err(SceneError::Invalid {
                    path: path.to_path_buf(),
                    msg: "unsupported file type (expected .obj, .gltf, .glb, .toml or .aff)".into(),
                })
            }
            None => {
                return Err(SceneError::UnknownScene {
                    name: spec.to_string(),
                    suggestion: suggest(spec),
                    known: format!(
                        "a built-in scene ({}), a generated scene ({}) or a shared scene ({})",
                        builtin::NAMES.join(", "),
                        generate::NAMES.map(|g| format!("{g}:SIZE")).join(", "),
                        SHARED.map(|s| s.0).join(", ")
                    ),
                })
            }
        },
    };
    finish(&mut scene, path, &sb, opts)?;
    Ok(scene)
}
