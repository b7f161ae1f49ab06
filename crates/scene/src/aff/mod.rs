//! BART's AFF scene files (Lext, Assarsson & Möller 2001: NFF plus includes, a transform
//! hierarchy with keyframed tracks, triangle meshes and animated triangles).
//!
//! Read: `v` (view), `b`, `am`, `l`/`la`, `f`/`fm` materials, `p`, `pp`, `tt`, `ttp`, `c`
//! (open cone side, 32 segments), `s` (sphere, tessellated), `m` meshes (vertices, normals,
//! texture coordinates, triangles with per-corner indices), `tpa` animated triangles, `xs`
//! static and `x` animated transform groups, `k` keyframes (translation, rotation in degrees,
//! scale, visibility), `a` (animation interval), `i` includes (relative to the including file).
//! Texture maps are ignored (no textures in the renderer); `la` lights are placed at their
//! given position; visibility keys are read and ignored. Each `m` block, each transform
//! group's loose polygons and each group's animated triangles become a separate mesh, so
//! that every animated object keeps its own transform and bounding sphere.
//!
//! Every error names the file and line.

mod blocks;
mod lex;

use crate::anim::{Animation, Interp, Track, VertexKeys, Xform};
use lex::{tokenize, Cursor};

/// Largest element counts accepted (absurd sizes are errors, not allocations).
const MAX_COUNT: usize = 50_000_000;
/// Deepest include nesting (deeper is taken for a cycle).
const MAX_INCLUDE_DEPTH: usize = 32;
/// Most file loads of one scene, includes counted each time (BART's kitchen loads 200):
/// files that include the next one twice would otherwise load 2^depth files.
const MAX_FILES: usize = 10_000;
use crate::error::SceneError;
use crate::model::{smooth_normals, Camera, Light, LoadReport, Material, Mesh, Scene};
use crate::shapes;
use geom::{Mat4, Quat, Vec3};
use std::path::{Path, PathBuf};

/// A mesh being collected: loose polygons of one transform group, or an `m` block.
#[derive(Default)]
struct Builder {
    name: String,
    positions: Vec<Vec3>,
    normals: Vec<Option<Vec3>>,
    triangles: Vec<[u32; 3]>,
    materials: Vec<u32>,
}

impl Builder {
    fn add_tri(&mut self, p: [Vec3; 3], n: Option<[Vec3; 3]>, mat: u32) {
        let b = self.positions.len() as u32;
        self.positions.extend(p);
        match n {
            Some(n) => self.normals.extend(n.map(Some)),
            None => self.normals.extend([None; 3]),
        }
        self.triangles.push([b, b + 1, b + 2]);
        self.materials.push(mat);
    }
    /// Triangles without normals (tessellated shapes).
    fn add_soup(&mut self, tris: &[[Vec3; 3]], mat: u32) {
        for &t in tris {
            self.add_tri(t, None, mat);
        }
    }
    fn add_fan(&mut self, p: &[Vec3], n: Option<&[Vec3]>, mat: u32) {
        for k in 1..p.len().saturating_sub(1) {
            let nn = n.map(|n| [n[0], n[k], n[k + 1]]);
            self.add_tri([p[0], p[k], p[k + 1]], nn, mat);
        }
    }
}

struct Parser {
    /// Where included files may live.
    sb: crate::io::Sandbox,
    meshes: Vec<Mesh>,
    /// Triangles in `meshes` (the budget counts them with the open group's).
    mesh_triangles: u64,
    chains: Vec<Vec<Xform>>,
    vertex_keys: Vec<Option<VertexKeys>>,
    materials: Vec<Material>,
    current_material: u32,
    lights: Vec<Light>,
    camera: Option<Camera>,
    background: Vec3,
    /// The global ambient light (`am`).
    ambient: Vec3,
    /// The current transform chain (outermost first); track links hold names until the end.
    stack: Vec<Link>,
    tracks: Vec<Track>,
    anim: Option<(f32, f32, u32)>,
    notes: Vec<String>,
    /// `file:line: ...` warnings (see [`LoadReport::warnings`]).
    warnings: Vec<String>,
    files: usize,
    /// Animated triangles of the current group: (key times, per-key positions).
    tpa: Option<TpaGroup>,
    loose: Builder,
    include_stack: Vec<PathBuf>,
}

/// Animated triangles of one group: key times, per-key positions (3 per triangle), and one
/// material per triangle.
type TpaGroup = (Vec<f32>, Vec<Vec<Vec3>>, Vec<u32>);

#[derive(Clone)]
enum Link {
    Static(Mat4),
    Named(String),
}

impl Parser {
    fn chain(&self) -> Vec<Link> {
        self.stack.clone()
    }

    fn push_mesh(&mut self, b: Builder, keys: Option<VertexKeys>) {
        if b.triangles.is_empty() {
            return;
        }
        self.mesh_triangles += b.triangles.len() as u64;
        let computed = smooth_normals(&b.positions, &b.triangles);
        let normals = b
            .normals
            .iter()
            .zip(&computed)
            .map(|(n, c)| n.map(|n| n.normalize_or(*c)).unwrap_or(*c))
            .collect();
        self.meshes.push(Mesh {
            name: b.name,
            positions: b.positions,
            normals,
            triangles: b.triangles,
            materials: b.materials,
            transform: Mat4::IDENTITY,
        });
        self.chains.push(
            self.chain()
                .into_iter()
                .map(|l| match l {
                    Link::Static(m) => Xform::Static(m),
                    // Resolved to track indices in `finish`; u32::MAX marks "by name".
                    Link::Named(n) => {
                        let i = self.tracks.iter().position(|t| t.name == n);
                        match i {
                            Some(i) => Xform::Track(i as u32),
                            None => {
                                self.tracks.push(Track {
                                    name: n,
                                    translation: vec![],
                                    rotation: vec![],
                                    scale: vec![],
                                    interp: Interp::KochanekBartels,
                                    looping: false,
                                });
                                Xform::Track(self.tracks.len() as u32 - 1)
                            }
                        }
                    }
                })
                .collect(),
        );
        self.vertex_keys.push(keys);
    }

    /// Close the current group's loose polygons and animated triangles as meshes.
    fn flush(&mut self, label: &str) {
        let b = std::mem::take(&mut self.loose);
        let name = format!("{label} #{}", self.meshes.len());
        self.push_mesh(Builder { name, ..b }, None);
        if let Some((times, keys, mats)) = self.tpa.take() {
            let n = keys.first().map_or(0, |k| k.len());
            let triangles: Vec<[u32; 3]> = (0..n as u32 / 3)
                .map(|i| [3 * i, 3 * i + 1, 3 * i + 2])
                .collect();
            let b = Builder {
                name: format!("{label} animated triangles #{}", self.meshes.len()),
                positions: keys[0].clone(),
                normals: vec![None; n],
                triangles,
                materials: mats,
            };
            self.push_mesh(
                b,
                Some(VertexKeys {
                    times,
                    positions: keys,
                }),
            );
        }
    }

    fn file(&mut self, path: &Path) -> Result<(), SceneError> {
        if self.include_stack.len() >= MAX_INCLUDE_DEPTH {
            return Err(SceneError::invalid(
                path,
                format!("includes nested deeper than {MAX_INCLUDE_DEPTH} (a cycle?)"),
            ));
        }
        if self.files >= MAX_FILES {
            return Err(SceneError::invalid(
                path,
                format!("more than {MAX_FILES} file loads (includes fanning out?)"),
            ));
        }
        // Some BART files carry Latin-1 bytes in comments; the syntax itself is ASCII.
        let bytes = self.sb.read_file(path)?;
        let src = String::from_utf8_lossy(&bytes);
        self.files += 1;
        self.include_stack.push(path.to_path_buf());
        let toks = tokenize(&src);
        let mut c = Cursor {
            toks: &toks,
            pos: 0,
            path,
        };
        let label = path
            .file_stem()
            .map(|s| s.to_string_lossy().into_owned())
            .unwrap_or_default();
        let depth0 = self.stack.len();
        self.block(&mut c, &label, depth0, path)?;
        if self.stack.len() != depth0 {
            return Err(c.err("unclosed '{' at end of file"));
        }
        self.flush(&label);
        self.include_stack.pop();
        Ok(())
    }

    /// The entities of one file (or of one include), up to its end.
    fn block(
        &mut self,
        c: &mut Cursor,
        label: &str,
        depth0: usize,
        path: &Path,
    ) -> Result<(), SceneError> {
        while let Some(w) = c.peek() {
            let w = w.to_string();
            let line = c.line();
            c.pos += 1;
            let mat = self.current_material;
            match w.as_str() {
                "v" => self.view(c, line)?,
                "b" => self.background = c.vec3("background colour")?,
                "am" => self.ambient = c.vec3("ambient colour")?,
                "l" | "la" => self.light(c, w == "la")?,
                "f" => self.fill(c)?,
                "fm" => self.fill_material(c)?,
                "p" | "pp" => self.polygon(c, w == "pp", mat)?,
                "tt" | "ttp" => self.textured_triangle(c, w == "ttp", mat)?,
                "c" => {
                    let b = c.vec3("cone base")?;
                    let r0 = c.num("base radius")?.abs();
                    let a = c.vec3("cone apex")?;
                    let r1 = c.num("apex radius")?.abs();
                    if (a - b).length() == 0.0 {
                        return Err(c.err_at(line, "cone: base and apex coincide"));
                    }
                    self.loose
                        .add_soup(&shapes::cone_wall(b, r0, a, r1, 32), mat);
                }
                "s" => {
                    let ctr = c.vec3("sphere centre")?;
                    let r = c.num("sphere radius")?.abs();
                    self.loose.add_soup(&shapes::uv_sphere(ctr, r, 16, 32), mat);
                }
                "m" => self.mesh(c, label, mat)?,
                "tpa" => self.animated_triangle(c, line, label, mat)?,
                "xs" => {
                    let s = c.vec3("scale")?;
                    let axis = c.vec3("rotation axis")?;
                    let deg = c.num("rotation angle")?;
                    let t = c.vec3("translation")?;
                    c.expect("{")?;
                    let m = Mat4::from_scale_rotation_translation(s, axis_angle(axis, deg), t);
                    self.flush(label);
                    self.stack.push(Link::Static(m));
                }
                "x" => {
                    let name = c.word("transform name")?;
                    c.expect("{")?;
                    self.flush(label);
                    self.stack.push(Link::Named(name));
                }
                "}" => {
                    if self.stack.len() <= depth0 {
                        return Err(c.err_at(line, "'}' without a matching '{'"));
                    }
                    self.flush(label);
                    self.stack.pop();
                }
                "k" => self.keys(c)?,
                "a" => self.interval(c, line)?,
                "i" => self.include(c, line, label, path)?,
                other => return Err(c.err_at(line, format!("unknown AFF entity '{other}'"))),
            }
            // After every entity: a sphere adds about a thousand triangles, so a 100 KB
            // file of them would make a 5-million-triangle scene.
            let open = self.loose.triangles.len()
                + self
                    .tpa
                    .as_ref()
                    .map_or(0, |(_, k, _)| k.first().map_or(0, |k| k.len() / 3));
            self.sb
                .admit_triangles(path, Some(line), self.mesh_triangles + open as u64)?;
        }
        Ok(())
    }

    /// `v from .. at .. up .. angle .. hither .. resolution .. ..`: the camera.
    fn view(&mut self, c: &mut Cursor, line: usize) -> Result<(), SceneError> {
        c.expect("from")?;
        let eye = c.vec3("from")?;
        c.expect("at")?;
        let target = c.vec3("at")?;
        c.expect("up")?;
        let up = c.vec3("up")?;
        c.expect("angle")?;
        let vfov = c.num("angle")?;
        c.expect("hither")?;
        c.num("hither")?;
        c.expect("resolution")?;
        c.num("resolution")?;
        c.num("resolution")?;
        if !(vfov > 0.0 && vfov < 180.0) || (target - eye).length() == 0.0 {
            return Err(c.err_at(
                line,
                "view: angle must be in (0, 180) and 'at' differ from 'from'",
            ));
        }
        self.camera = Some(Camera {
            eye,
            target,
            up,
            vfov,
        });
        Ok(())
    }

    /// `l X Y Z [R G B]` or `la NAME X Y Z [R G B]` (animated lights stay where given).
    fn light(&mut self, c: &mut Cursor, animated: bool) -> Result<(), SceneError> {
        if animated {
            c.word("light name")?;
            self.notes
                .push("animated lights placed at their given position".into());
        }
        let p = c.vec3("light position")?;
        let col = if c.is_number() {
            c.vec3("light colour")?
        } else {
            Vec3::ONE
        };
        self.lights.push(Light {
            position: p,
            color: col,
            intensity: 1.0,
            attenuation: [1.0, 0.0, 0.0],
        });
        Ok(())
    }

    /// `f R G B Kd Ks shine T ior`: NFF fill material.
    fn fill(&mut self, c: &mut Cursor) -> Result<(), SceneError> {
        let col = c.vec3("fill colour")?;
        let kd = c.num("Kd")?;
        let ks = c.num("Ks")?;
        let shine = c.num("shine")?;
        let t = c.num("transmittance")?;
        let ior = c.num("index of refraction")?;
        self.material(Vec3::ZERO, col * kd, Vec3::splat(ks), shine, t, ior);
        Ok(())
    }

    /// `fm amb diff spec shine T ior`: AFF's full material.
    fn fill_material(&mut self, c: &mut Cursor) -> Result<(), SceneError> {
        let a = c.vec3("ambient")?;
        let d = c.vec3("diffuse")?;
        let s = c.vec3("specular")?;
        let shine = c.num("shine")?;
        let t = c.num("transmittance")?;
        let ior = c.num("index of refraction")?;
        self.material(a, d, s, shine, t, ior);
        Ok(())
    }

    /// `p N v...` or `pp N (v n)...`: a polygon, as a triangle fan.
    fn polygon(&mut self, c: &mut Cursor, normals: bool, mat: u32) -> Result<(), SceneError> {
        let n = c.count("vertex count", 1 << 20)?;
        let mut ps = Vec::with_capacity(c.capacity(n, 3));
        let mut ns = Vec::with_capacity(c.capacity(n, 3));
        for _ in 0..n {
            ps.push(c.vec3("polygon vertex")?);
            if normals {
                ns.push(c.vec3("polygon normal")?);
            }
        }
        self.loose.add_fan(&ps, normals.then_some(&ns[..]), mat);
        Ok(())
    }

    /// `tt NAME (v u v)×3` or `ttp NAME (v n u v)×3`: a textured triangle (texture ignored).
    fn textured_triangle(
        &mut self,
        c: &mut Cursor,
        normals: bool,
        mat: u32,
    ) -> Result<(), SceneError> {
        c.word("texture name")?;
        let mut ps = [Vec3::ZERO; 3];
        let mut ns = [Vec3::ZERO; 3];
        for k in 0..3 {
            ps[k] = c.vec3("triangle vertex")?;
            if normals {
                ns[k] = c.vec3("triangle normal")?;
            }
            c.num("texture u")?;
            c.num("texture v")?;
        }
        self.loose.add_tri(ps, normals.then_some(ns), mat);
        Ok(())
    }

    /// `tpa N (t (v n)×3)×N`: a triangle with keyframed vertices.
    fn animated_triangle(
        &mut self,
        c: &mut Cursor,
        line: usize,
        label: &str,
        mat: u32,
    ) -> Result<(), SceneError> {
        let nk = c.count("key count", 1 << 16)?;
        let mut times = Vec::with_capacity(c.capacity(nk, 1));
        let mut pos = Vec::with_capacity(c.capacity(nk, 1));
        for _ in 0..nk {
            times.push(c.num("key time")?);
            let mut p = [Vec3::ZERO; 3];
            for v in &mut p {
                *v = c.vec3("animated vertex")?;
                c.vec3("animated normal")?;
            }
            pos.push(p);
        }
        if nk == 0 || times.windows(2).any(|w| w[1] < w[0]) {
            return Err(c.err_at(line, "tpa: key times must be given and increasing"));
        }
        // All animated triangles of one group share the key times (BART's do); otherwise
        // the group is split.
        if self.tpa.as_ref().is_some_and(|(t, _, _)| *t != times) {
            let b = std::mem::take(&mut self.loose);
            self.flush(label);
            self.loose = b;
        }
        let e = self
            .tpa
            .get_or_insert_with(|| (times.clone(), vec![Vec::new(); nk], Vec::new()));
        for (k, p) in pos.iter().enumerate() {
            e.1[k].extend_from_slice(p);
        }
        e.2.push(mat);
        Ok(())
    }

    /// `a START END FRAMES`: the animation interval.
    fn interval(&mut self, c: &mut Cursor, line: usize) -> Result<(), SceneError> {
        let s = c.num("animation start")?;
        let e = c.num("animation end")?;
        let n = c.count("frame count", 1 << 20)?;
        if e < s {
            return Err(c.err_at(line, format!("animation end {e} is before its start {s}")));
        }
        self.anim = Some((s, e, n as u32));
        Ok(())
    }

    /// `i DETAIL FILE`: an included file, relative to this one.
    fn include(
        &mut self,
        c: &mut Cursor,
        line: usize,
        label: &str,
        path: &Path,
    ) -> Result<(), SceneError> {
        c.num("detail level")?;
        let f = c.word("include file name")?;
        let p = path.parent().unwrap_or(Path::new(".")).join(&f);
        if !p.exists() {
            return Err(c.err_at(
                line,
                format!("included file {} does not exist", p.display()),
            ));
        }
        let p = self.sb.admit(path, "include", &f, p).map_err(|e| match e {
            SceneError::Outside { msg, .. } | SceneError::Invalid { msg, .. } => {
                c.err_at(line, msg)
            }
            e => e,
        })?;
        self.flush(label);
        self.file(&p)
    }

    fn material(&mut self, a: Vec3, d: Vec3, s: Vec3, shine: f32, t: f32, ior: f32) {
        let transparent = t > 0.0 && ior > 0.0;
        let m = Material {
            name: format!("aff{}", self.materials.len()),
            diffuse: d,
            specular: s,
            shininess: shine.max(1.0),
            reflectivity: 0.0,
            transparency: if transparent { t.min(1.0) } else { 0.0 },
            ior: if transparent { ior } else { 1.0 },
            emission: Vec3::ZERO,
            ambient: a,
        };
        self.current_material = match self.materials.iter().position(|x| {
            x.diffuse == m.diffuse
                && x.specular == m.specular
                && x.shininess == m.shininess
                && x.transparency == m.transparency
                && x.ior == m.ior
        }) {
            Some(i) => i as u32,
            None => {
                self.materials.push(m);
                self.materials.len() as u32 - 1
            }
        };
    }
}

fn axis_angle(axis: Vec3, deg: f32) -> Quat {
    let a = axis.normalize_or_zero();
    if a == Vec3::ZERO || deg == 0.0 {
        Quat::IDENTITY
    } else {
        Quat::from_axis_angle(a, deg.to_radians())
    }
}

/// Load a BART/NFF scene: `path` is the top-level `.aff` (or `.nff`) file.
pub fn load_aff_scene(path: &Path) -> Result<Scene, SceneError> {
    load_aff_scene_in(path, &crate::io::Sandbox::for_scene(path, false))
}

/// [`load_aff_scene`] with included files confined to `sb`.
pub fn load_aff_scene_in(path: &Path, sb: &crate::io::Sandbox) -> Result<Scene, SceneError> {
    let t0 = std::time::Instant::now();
    let mut p = Parser {
        sb: sb.clone(),
        meshes: vec![],
        mesh_triangles: 0,
        chains: vec![],
        vertex_keys: vec![],
        materials: vec![Material::default()],
        current_material: 0,
        lights: vec![],
        camera: None,
        background: Vec3::ZERO,
        ambient: Vec3::ZERO,
        stack: vec![],
        tracks: vec![],
        anim: None,
        notes: vec![],
        warnings: vec![],
        files: 0,
        tpa: None,
        loose: Builder::default(),
        include_stack: vec![],
    };
    p.file(path)?;
    let mut degenerate = 0;
    // Drop degenerate triangles of rigid meshes (animated triangles may be degenerate at
    // some keys and not others; they stay).
    for (m, k) in p.meshes.iter_mut().zip(&p.vertex_keys) {
        if k.is_none() {
            degenerate += m.remove_degenerate();
        }
    }
    let keep: Vec<bool> = p.meshes.iter().map(|m| !m.triangles.is_empty()).collect();
    let mut it = keep.iter();
    p.meshes.retain(|_| *it.next().unwrap());
    let mut it = keep.iter();
    p.chains.retain(|_| *it.next().unwrap());
    let mut it = keep.iter();
    p.vertex_keys.retain(|_| *it.next().unwrap());
    if p.meshes.is_empty() {
        return Err(SceneError::Empty {
            path: path.to_path_buf(),
            detail: String::new(),
        });
    }
    let mut notes = vec![format!("BART AFF, {} files", p.files)];
    notes.extend(
        p.notes
            .iter()
            .cloned()
            .collect::<std::collections::BTreeSet<_>>(),
    );
    let report = LoadReport {
        source: Some(path.to_path_buf()),
        degenerate_skipped: degenerate,
        load_seconds: t0.elapsed().as_secs_f64(),
        notes,
        warnings: p.warnings.clone(),
        ..Default::default()
    };
    let animated = p.anim.is_some()
        || p.tracks.iter().any(|t| t.name == "camera")
        || p.chains
            .iter()
            .flatten()
            .any(|x| matches!(x, Xform::Track(_)))
        || p.vertex_keys.iter().any(Option::is_some);
    if !animated {
        // A still scene keeps its `xs` groups' static transforms (without an animation
        // they are not evaluated per frame, so they are applied here).
        for (m, chain) in p.meshes.iter_mut().zip(&p.chains) {
            m.transform = chain.iter().fold(Mat4::IDENTITY, |acc, x| match x {
                Xform::Static(s) => acc * *s,
                Xform::Track(_) => unreachable!("a still scene has no tracks"),
            }) * m.transform;
        }
    }
    let mut scene = Scene::from_file(path, p.meshes, p.materials, report);
    scene.background = p.background;
    scene.ambient = p.ambient;
    scene.lights = p.lights;
    let bounds = scene.bounds();
    scene.camera = p.camera.unwrap_or_else(|| Camera::framing(&bounds));
    // Light intensity: BART colours are already radiance-like; the thesis's attenuation is
    // off (c = 1). Dim many lights so that the sum stays in range.
    let n = scene.lights.len().max(1) as f32;
    for l in &mut scene.lights {
        l.intensity = (2.0 / n).min(1.0);
    }
    if animated {
        let (start, end, frames) = p.anim.unwrap_or((0.0, 1.0, 30));
        let camera = p
            .tracks
            .iter()
            .position(|t| t.name == "camera")
            .map(|i| i as u32);
        let local_spheres = crate::model::local_spheres(&scene.meshes, &p.vertex_keys);
        scene.animation = Some(Animation {
            start,
            end,
            frames,
            tracks: p.tracks,
            chains: p.chains,
            vertex_keys: p.vertex_keys,
            camera,
            local_spheres,
        });
        // The scene as loaded is its first frame.
        scene = scene.at_time(start);
    }
    Ok(scene)
}
