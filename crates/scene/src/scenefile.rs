//! TOML scene files: compose meshes (files, shapes or built-in scenes), transforms, material
//! overrides, lights and the camera.
//!
//! The format, with every key, is documented for users in `docs/scene-files.md`;
//! `bench/scenes/*.toml` are real examples.

use crate::anim::{Animation, Interp, RotKey, Track, VecKey, VertexKeys, Xform};
use crate::error::Invalid;
use crate::error::SceneError;
use crate::model::{Camera, Light, LoadReport, Material, Scene};
use crate::{builtin, gltf_load, obj, shapes, MeshSplit};
use geom::{Mat4, Quat, Vec3};
use serde::Deserialize;
use std::path::{Path, PathBuf};

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct File {
    name: Option<String>,
    background: Option<[f32; 3]>,
    ambient: Option<[f32; 3]>,
    camera: Option<CameraDef>,
    #[serde(default)]
    lights: Vec<LightDef>,
    #[serde(default)]
    meshes: Vec<MeshDef>,
    animation: Option<IntervalDef>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct IntervalDef {
    start: f32,
    end: f32,
    frames: Option<u32>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct AnimDef {
    #[serde(rename = "loop", default)]
    looping: bool,
    keys: Vec<KeyDef>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct KeyDef {
    t: f32,
    translate: Option<[f32; 3]>,
    rotate: Option<[f32; 3]>,
    scale: Option<Scale>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct CameraDef {
    eye: [f32; 3],
    target: [f32; 3],
    up: Option<[f32; 3]>,
    fov: Option<f32>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct LightDef {
    position: [f32; 3],
    color: Option<[f32; 3]>,
    intensity: Option<f32>,
    attenuation: Option<[f32; 3]>,
}

#[derive(Deserialize)]
#[serde(untagged)]
enum Scale {
    Uniform(f32),
    Axes([f32; 3]),
}

#[derive(Deserialize, Default)]
#[serde(deny_unknown_fields)]
struct MaterialDef {
    diffuse: Option<[f32; 3]>,
    specular: Option<[f32; 3]>,
    shininess: Option<f32>,
    reflectivity: Option<f32>,
    transparency: Option<f32>,
    ior: Option<f32>,
    emission: Option<[f32; 3]>,
    ambient: Option<[f32; 3]>,
}

#[derive(Deserialize)]
#[serde(deny_unknown_fields)]
struct MeshDef {
    name: Option<String>,
    file: Option<String>,
    shape: Option<String>,
    builtin: Option<String>,
    split: Option<String>,
    /// Shape detail: subdivision level for spheres, grid size for planes.
    detail: Option<u32>,
    translate: Option<[f32; 3]>,
    rotate: Option<[f32; 3]>,
    scale: Option<Scale>,
    material: Option<MaterialDef>,
    animation: Option<AnimDef>,
    /// Vertex animation: a numbered OBJ file pattern (`%0Nd`), `frames` files at `fps`.
    sequence: Option<String>,
    frames: Option<u32>,
    fps: Option<f32>,
}

fn euler(a: [f32; 3]) -> Quat {
    Quat::from_euler(
        glam::EulerRot::XYZ,
        a[0].to_radians(),
        a[1].to_radians(),
        a[2].to_radians(),
    )
}

fn numbered(pattern: &str, i: u32) -> Option<String> {
    let p = pattern.find('%')?;
    let rest = &pattern[p + 1..];
    let d = rest.find('d')?;
    let spec = &rest[..d];
    let w: usize = if spec.is_empty() {
        0
    } else {
        spec.trim_start_matches('0')
            .parse()
            .ok()
            .or(Some(0))
            .filter(|w| *w <= 12)?
    };
    Some(format!("{}{:0w$}{}", &pattern[..p], i, &rest[d + 1..]))
}

impl MaterialDef {
    fn apply(&self, m: &mut Material) {
        let v = |a: [f32; 3]| Vec3::from_array(a);
        if let Some(x) = self.diffuse {
            m.diffuse = v(x)
        }
        if let Some(x) = self.specular {
            m.specular = v(x)
        }
        if let Some(x) = self.emission {
            m.emission = v(x)
        }
        if let Some(x) = self.ambient {
            m.ambient = v(x)
        }
        if let Some(x) = self.shininess {
            m.shininess = x
        }
        if let Some(x) = self.reflectivity {
            m.reflectivity = x
        }
        if let Some(x) = self.transparency {
            m.transparency = x
        }
        if let Some(x) = self.ior {
            m.ior = x
        }
    }
}

/// Load a TOML scene file (format above); errors name the file and line.
pub fn load_scene_file(path: &Path) -> Result<Scene, SceneError> {
    load_scene_file_in(path, &crate::io::Sandbox::for_scene(path, false))
}

/// [`load_scene_file`] with the files it references confined to `sb`.
pub fn load_scene_file_in(path: &Path, sb: &crate::io::Sandbox) -> Result<Scene, SceneError> {
    let t0 = std::time::Instant::now();
    let text = sb.read_text(path)?;
    parse_scene_file(&text, path, sb, t0)
}

/// A TOML scene from its text, as if read from `path` (which names it in messages and
/// anchors its relative paths), with the files it references confined to `sb`.
pub fn load_scene_text_in(
    text: &str,
    path: &Path,
    sb: &crate::io::Sandbox,
) -> Result<Scene, SceneError> {
    parse_scene_file(text, path, sb, std::time::Instant::now())
}

/// One `[[meshes]]` entry's contribution: its meshes, their materials and, for a sequence,
/// its vertex keys.
type Entry = (Vec<crate::Mesh>, Vec<Material>, Option<VertexKeys>);

/// What the parse of one file needs everywhere: the file (for errors and relative paths)
/// and the load report the loaders add to.
struct Ctx<'a> {
    path: &'a Path,
    sb: &'a crate::io::Sandbox,
    report: LoadReport,
}

impl Ctx<'_> {
    /// A file path of the scene: relative to the scene file, or `scenes:REL` in the shared
    /// scenes directory (`$RAYSPACE_SCENES`).
    fn resolve(&self, what: &str, f: &str) -> Result<PathBuf, SceneError> {
        let joined = match f.strip_prefix("scenes:") {
            Some(rel) => crate::scenes_dir()
                .ok_or_else(|| {
                    self.bad(what, format!("'{f}': no scenes directory (set RAYSPACE_SCENES or provide ../shared/scenes)"))
                })?
                .join(rel),
            None => self.path.parent().unwrap_or(Path::new(".")).join(f),
        };
        self.sb.admit(self.path, what, f, joined)
    }

    fn bad(&self, what: &str, msg: String) -> SceneError {
        SceneError::invalid(self.path, format!("{what}: {msg}"))
    }
}

fn parse_scene_file(
    text: &str,
    path: &Path,
    sb: &crate::io::Sandbox,
    t0: std::time::Instant,
) -> Result<Scene, SceneError> {
    let file = parse_toml(text, path)?;
    let mut ctx = Ctx {
        path,
        sb,
        report: LoadReport {
            source: Some(path.to_path_buf()),
            ..Default::default()
        },
    };
    let mut scene = Scene::from_file(path, Vec::new(), Vec::new(), LoadReport::default());
    if let Some(n) = &file.name {
        scene.name = n.clone();
    }
    if let Some(a) = file.ambient {
        scene.ambient = Vec3::from_array(a);
    }
    if let Some(b) = file.background {
        scene.background = Vec3::from_array(b);
    }
    if file.meshes.is_empty() {
        return Err(SceneError::invalid(path, "no [[meshes]] entries"));
    }
    // Per mesh of the scene: its keyframe track and vertex keys, if animated.
    let mut anim_meshes: Vec<(usize, Option<Track>, Option<VertexKeys>)> = Vec::new();
    for (i, def) in file.meshes.iter().enumerate() {
        let what = format!("meshes[{i}]");
        let (mut meshes, mut materials, vertex_keys) = mesh_entry(&mut ctx, &what, def)?;
        if let Some(md) = &def.material {
            for m in &mut materials {
                md.apply(m);
            }
        }
        let xf = placement(def.translate, def.rotate, def.scale.as_ref())
            .map_err(|e| ctx.bad(&what, e.0))?;
        for m in &mut meshes {
            m.transform = xf * m.transform;
            if let Some(n) = &def.name {
                m.name = format!("{n}/{}", m.name);
            }
        }
        let first_mesh = scene.meshes.len();
        let count = meshes.len();
        scene.append_meshes(meshes, materials);
        // Each entry's loader keeps to the budget; together they must too.
        sb.admit_triangles(path, None, scene.triangle_count() as u64)?;
        let track = match &def.animation {
            None => None,
            Some(a) => {
                let name = def.name.clone().unwrap_or_else(|| what.clone());
                Some(keyframe_track(a, name).map_err(|e| ctx.bad(&what, e.0))?)
            }
        };
        for m in first_mesh..first_mesh + count {
            anim_meshes.push((m, track.clone(), vertex_keys.clone()));
        }
    }
    scene.report = ctx.report;
    scene.report.source = Some(path.to_path_buf());
    camera_and_lights(&file, &mut scene);
    if anim_meshes
        .iter()
        .any(|(_, t, v)| t.is_some() || v.is_some())
    {
        let start = animate(&file, path, &mut scene, anim_meshes)?;
        scene = scene.at_time(start);
    }
    scene.report.load_seconds = t0.elapsed().as_secs_f64();
    Ok(scene)
}

/// The TOML document; a syntax error names its line (toml's message spans several lines, a
/// source excerpt: keep the first, with the line number computed from the span).
fn parse_toml(text: &str, path: &Path) -> Result<File, SceneError> {
    toml::from_str(text).map_err(|e| {
        let line = e
            .span()
            .map(|s| {
                text.as_bytes()[..s.start.min(text.len())]
                    .iter()
                    .filter(|&&b| b == b'\n')
                    .count()
                    + 1
            })
            .unwrap_or(0);
        SceneError::Parse {
            path: path.to_path_buf(),
            line,
            msg: e.message().to_string(),
        }
    })
}

/// The meshes of one `[[meshes]]` entry, from exactly one of its sources.
fn mesh_entry(ctx: &mut Ctx, what: &str, def: &MeshDef) -> Result<Entry, SceneError> {
    let sources = def.file.is_some() as u32
        + def.shape.is_some() as u32
        + def.builtin.is_some() as u32
        + def.sequence.is_some() as u32;
    if sources != 1 {
        return Err(ctx.bad(
            what,
            "give exactly one of file, shape, builtin or sequence".into(),
        ));
    }
    // A bad `split` is an error whatever the source (it only applies to OBJ files).
    let split: MeshSplit = match &def.split {
        Some(s) => s.parse().map_err(|e: Invalid| ctx.bad(what, e.0))?,
        None => MeshSplit::Groups,
    };
    if let Some(pat) = &def.sequence {
        return sequence_meshes(ctx, what, def, pat);
    }
    if let Some(f) = &def.file {
        let (m, mats) = file_meshes(ctx, what, f, split)?;
        return Ok((m, mats, None));
    }
    if let Some(b) = &def.builtin {
        let s = builtin::by_name(b)
            .ok_or_else(|| ctx.bad(what, format!("unknown built-in scene '{b}'")))?;
        return Ok((s.meshes, s.materials, None));
    }
    let shape = def.shape.as_deref().unwrap_or("");
    let m = shape_mesh(shape, def.detail).map_err(|e| ctx.bad(what, e.0))?;
    Ok((vec![m], vec![Material::default()], None))
}

/// `file = ...`: an OBJ (cut by `split`) or a glTF file.
fn file_meshes(
    ctx: &mut Ctx,
    what: &str,
    f: &str,
    split: MeshSplit,
) -> Result<(Vec<crate::Mesh>, Vec<Material>), SceneError> {
    let p = ctx.resolve(what, f)?;
    let ext = p
        .extension()
        .and_then(|e| e.to_str())
        .unwrap_or("")
        .to_ascii_lowercase();
    match ext.as_str() {
        "obj" => obj::load_obj_meshes(&p, split, &mut ctx.report, ctx.sb),
        "gltf" | "glb" => {
            let s = gltf_load::load_gltf_scene_in(&p, ctx.sb)?;
            ctx.report.degenerate_skipped += s.report.degenerate_skipped;
            Ok((s.meshes, s.materials))
        }
        _ => Err(ctx.bad(
            what,
            format!("unsupported mesh file '{f}' (expected .obj, .gltf or .glb)"),
        )),
    }
}

/// `shape = ...`: a tessellated primitive of `scene::shapes`.
fn shape_mesh(shape: &str, detail: Option<u32>) -> Result<crate::Mesh, Invalid> {
    Ok(match shape {
        "sphere" => shapes::icosphere("sphere", Vec3::ZERO, 1.0, detail.unwrap_or(3).min(7), 0),
        "box" => shapes::cuboid("box", Vec3::splat(-1.0), Vec3::ONE, false, 0),
        "plane" => shapes::quad_grid(
            "plane",
            Vec3::new(-1.0, 0.0, -1.0),
            Vec3::Z * 2.0,
            Vec3::X * 2.0,
            detail.unwrap_or(1).clamp(1, 1024),
            0,
        ),
        "torus" => shapes::torus("torus", Vec3::ZERO, 1.0, 0.35, 48, 16, 0),
        _ => {
            return Err(Invalid::from(format!(
                "unknown shape '{shape}' (expected sphere, box, plane or torus)"
            )))
        }
    })
}

/// `sequence = ...`: numbered OBJ files of one topology, frame i at time i / fps.
fn sequence_meshes(
    ctx: &mut Ctx,
    what: &str,
    def: &MeshDef,
    pat: &str,
) -> Result<Entry, SceneError> {
    let n = def
        .frames
        .ok_or_else(|| ctx.bad(what, "sequence needs frames".into()))?;
    let fps = def.fps.unwrap_or(24.0);
    if !((1..=100_000).contains(&n) && fps.is_finite() && fps > 0.0) {
        return Err(ctx.bad(
            what,
            format!("frames {n} must be 1..=100000 and fps {fps} positive"),
        ));
    }
    let mut keys = Vec::new();
    let mut first: Option<(crate::Mesh, Vec<Material>)> = None;
    for i in 0..n {
        let f = numbered(pat, i).ok_or_else(|| {
            ctx.bad(
                what,
                format!("sequence '{pat}' needs a %d or %0Nd frame number"),
            )
        })?;
        let p = ctx.resolve(what, &f)?;
        let (mut ms, mats) = obj::load_obj_meshes(&p, MeshSplit::Single, &mut ctx.report, ctx.sb)?;
        let m = ms
            .pop()
            .ok_or_else(|| ctx.bad(what, format!("{}: no triangles", p.display())))?;
        if let Some((m0, _)) = &first {
            if m0.positions.len() != m.positions.len() || m0.triangles != m.triangles {
                return Err(ctx.bad(
                    what,
                    format!(
                        "{}: topology differs from frame 0 ({} vertices, {} triangles vs {}, {})",
                        p.display(),
                        m.positions.len(),
                        m.triangles.len(),
                        m0.positions.len(),
                        m0.triangles.len()
                    ),
                ));
            }
        } else {
            first = Some((m.clone(), mats));
        }
        // Every key frame holds a copy of the mesh's vertices: count it as the mesh again.
        ctx.sb
            .admit_triangles(&p, None, (keys.len() as u64 + 1) * m.triangles.len() as u64)?;
        keys.push(m.positions);
    }
    let (m0, mats) = first.expect("n >= 1");
    let vk = VertexKeys {
        times: (0..n).map(|i| i as f32 / fps).collect(),
        positions: keys,
    };
    Ok((vec![m0], mats, Some(vk)))
}

fn scale_vec(s: Option<&Scale>) -> Vec3 {
    match s {
        Some(Scale::Uniform(s)) => Vec3::splat(*s),
        Some(Scale::Axes(a)) => Vec3::from_array(*a),
        None => Vec3::ONE,
    }
}

/// `translate`, `rotate` (Euler XYZ, degrees) and `scale` as one transform.
fn placement(
    translate: Option<[f32; 3]>,
    rotate: Option<[f32; 3]>,
    scale: Option<&Scale>,
) -> Result<Mat4, Invalid> {
    let t = translate.map(Vec3::from_array).unwrap_or(Vec3::ZERO);
    let r = rotate.map(euler).unwrap_or(Quat::IDENTITY);
    let s = scale_vec(scale);
    if !(s.cmpgt(Vec3::ZERO).all() && s.is_finite()) {
        return Err(Invalid::from(format!(
            "scale {s} must be positive and finite"
        )));
    }
    Ok(Mat4::from_scale_rotation_translation(s, r, t))
}

/// `[meshes.animation]`: linear translation and scale, slerp rotation, keyed at increasing t.
fn keyframe_track(a: &AnimDef, name: String) -> Result<Track, Invalid> {
    if a.keys.is_empty()
        || a.keys
            .windows(2)
            .any(|w| w[1].t.partial_cmp(&w[0].t) != Some(std::cmp::Ordering::Greater))
    {
        return Err(Invalid::from(
            "animation keys must be given with increasing t",
        ));
    }
    let mut tr = Track {
        name,
        translation: vec![],
        rotation: vec![],
        scale: vec![],
        interp: Interp::Linear,
        looping: a.looping,
    };
    for k in &a.keys {
        if !k.t.is_finite() {
            return Err(Invalid::from(format!(
                "animation key time {} is not finite",
                k.t
            )));
        }
        let tcb = [0.0; 3];
        let v = Vec3::from_array(k.translate.unwrap_or([0.0; 3]));
        tr.translation.push(VecKey { t: k.t, v, tcb });
        let q = k.rotate.map(euler).unwrap_or(Quat::IDENTITY);
        tr.rotation.push(RotKey { t: k.t, q, tcb });
        let sc = scale_vec(k.scale.as_ref());
        if !(sc.cmpgt(Vec3::ZERO).all() && sc.is_finite() && v.is_finite()) {
            return Err(Invalid::from(format!(
                "animation key at t = {}: scale must be positive, values finite",
                k.t
            )));
        }
        tr.scale.push(VecKey { t: k.t, v: sc, tcb });
    }
    Ok(tr)
}

/// `[camera]` (or a framing of the scene) and `[[lights]]` (or one light above the camera).
fn camera_and_lights(file: &File, scene: &mut Scene) {
    match &file.camera {
        Some(c) => {
            scene.camera = Camera {
                eye: Vec3::from_array(c.eye),
                target: Vec3::from_array(c.target),
                up: c.up.map(Vec3::from_array).unwrap_or(Vec3::Y),
                vfov: c.fov.unwrap_or(45.0),
            };
        }
        None => obj::auto_camera_and_light(scene),
    }
    if !file.lights.is_empty() {
        scene.lights = file
            .lights
            .iter()
            .map(|l| Light {
                position: Vec3::from_array(l.position),
                color: l.color.map(Vec3::from_array).unwrap_or(Vec3::ONE),
                intensity: l.intensity.unwrap_or(1.0),
                attenuation: l.attenuation.unwrap_or([1.0, 0.0, 0.0]),
            })
            .collect();
        // The camera may be automatic; the lights are the file's.
        scene.report.automatic_lights = false;
    } else if file.camera.is_some() {
        let (_, up, _) = scene.camera.basis();
        scene.lights = vec![Light::white(
            scene.camera.eye + up * scene.bounds().diagonal() * 0.3,
            1.0,
        )];
        scene.report.automatic_lights = true;
    }
}

/// The scene's animation from its animated meshes and `[animation]`; returns the start time.
fn animate(
    file: &File,
    path: &Path,
    scene: &mut Scene,
    anim_meshes: Vec<(usize, Option<Track>, Option<VertexKeys>)>,
) -> Result<f32, SceneError> {
    let n = scene.meshes.len();
    let mut tracks: Vec<Track> = Vec::new();
    let mut chains = vec![Vec::new(); n];
    let mut vkeys = vec![None; n];
    let mut last_time = 0.0f32;
    for (m, track, vk) in anim_meshes {
        if let Some(tr) = track {
            last_time = last_time.max(tr.translation.last().map_or(0.0, |k| k.t));
            // One track per [[meshes]] entry, shared by the meshes it produced.
            let i = match tracks.iter().position(|x| *x == tr) {
                Some(i) => i,
                None => {
                    tracks.push(tr);
                    tracks.len() - 1
                }
            };
            chains[m] = vec![
                Xform::Track(i as u32),
                Xform::Static(scene.meshes[m].transform),
            ];
        }
        if let Some(v) = vk {
            last_time = last_time.max(v.times.last().copied().unwrap_or(0.0));
            vkeys[m] = Some(v);
        }
    }
    let local_spheres = crate::model::local_spheres(&scene.meshes, &vkeys);
    let (start, end, frames) = match &file.animation {
        Some(a) => {
            if !(a.start.is_finite() && a.end.is_finite() && a.end >= a.start) {
                return Err(SceneError::invalid(
                    path,
                    format!(
                        "[animation]: start {} and end {} must be finite, end ≥ start",
                        a.start, a.end
                    ),
                ));
            }
            (a.start, a.end, a.frames.unwrap_or(30))
        }
        None => (0.0, last_time, 30),
    };
    scene.animation = Some(Animation {
        start,
        end,
        frames,
        tracks,
        chains,
        vertex_keys: vkeys,
        camera: None,
        local_spheres,
    });
    Ok(start)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn load_str(text: &str, name: &str) -> Result<Scene, SceneError> {
        // One directory per call: the tests run in parallel, and a shared `tri.obj` being
        // rewritten (truncated) while another test reads it made that test see no
        // triangle (a flaky 892 ≠ 893, found in this session's full run).
        static CALL: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(0);
        let n = CALL.fetch_add(1, std::sync::atomic::Ordering::Relaxed);
        let d = std::env::temp_dir().join(format!("rayspace-toml-{}-{n}", std::process::id()));
        std::fs::create_dir_all(&d).unwrap();
        std::fs::write(d.join("tri.obj"), "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n").unwrap();
        let p = d.join(name);
        std::fs::write(&p, text).unwrap();
        crate::load(p.to_str().unwrap(), &Default::default())
    }

    #[test]
    fn composes_files_shapes_and_builtins() {
        let s = load_str(
            r#"
background = [0, 0, 0]
[camera]
eye = [0, 0, 10]
target = [0, 0, 0]
fov = 40
[[lights]]
position = [0, 5, 5]
intensity = 2.0
[[meshes]]
file = "tri.obj"
translate = [1, 2, 3]
scale = 2.0
material = { reflectivity = 0.5, diffuse = [1, 0, 0] }
[[meshes]]
shape = "sphere"
detail = 1
scale = [1, 2, 1]
[[meshes]]
builtin = "cornell"
"#,
            "ok.toml",
        )
        .unwrap();
        assert_eq!(s.triangle_count(), 1 + 80 + 812);
        assert_eq!(s.lights.len(), 1);
        assert_eq!(s.lights[0].intensity, 2.0);
        let m0 = &s.materials[s.meshes[0].materials[0] as usize];
        assert_eq!(m0.reflectivity, 0.5);
        assert_eq!(m0.diffuse, Vec3::X);
        let p = s.meshes[0].transform.transform_point3(Vec3::X);
        assert_eq!(p, Vec3::new(3.0, 2.0, 3.0));
    }

    #[test]
    fn errors_name_file_and_line() {
        let e = load_str("[camera]\neye = [0, 0, 1]\ntarget = [0, 0, 0]\nbogus = 3\n[[meshes]]\nshape = \"box\"\n", "unknown.toml").unwrap_err().to_string();
        assert!(e.contains("unknown.toml:4:") && e.contains("bogus"), "{e}");
        let e = load_str("[[meshes]]\nshape = \"box\"\nscale = 0\n", "scale.toml")
            .unwrap_err()
            .to_string();
        assert!(e.contains("scale.toml") && e.contains("scale"), "{e}");
        let e = load_str("[[meshes]]\nfile = \"missing.obj\"\n", "missing.toml")
            .unwrap_err()
            .to_string();
        assert!(e.contains("missing.obj"), "{e}");
        let e = load_str("[[meshes]]\nshape = \"cube\"\n", "shape.toml")
            .unwrap_err()
            .to_string();
        assert!(e.contains("meshes[0]") && e.contains("cube"), "{e}");
        let e = load_str("[[meshes]\n", "syntax.toml")
            .unwrap_err()
            .to_string();
        assert!(e.contains("syntax.toml:1:"), "{e}");
        let e = load_str(
            "[camera]\neye = [0, 0, 0]\ntarget = [0, 0, 0]\n[[meshes]]\nshape = \"box\"\n",
            "cam.toml",
        )
        .unwrap_err()
        .to_string();
        assert!(e.contains("cam.toml") && e.contains("camera"), "{e}");
    }
}
