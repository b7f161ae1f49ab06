//! Scene model types.

use crate::anim::VertexKeys;
use crate::error::Invalid;
use crate::error::SceneError;
use geom::{finite3, miniball, tri, Mat4, Sphere, Vec3};
use rayon::prelude::*;
use std::path::PathBuf;

/// A Blinn-Phong material with Whitted-style reflection and refraction weights.
#[derive(Clone, Debug, PartialEq)]
pub struct Material {
    /// Name (from the file, or made up).
    pub name: String,
    /// Diffuse colour (Blinn-Phong k_d, eq. 3.17).
    pub diffuse: Vec3,
    /// Specular colour (Blinn-Phong k_s).
    pub specular: Vec3,
    /// Blinn-Phong exponent.
    pub shininess: f32,
    /// Weight of the mirror reflection (0 = none).
    pub reflectivity: f32,
    /// Weight of the refracted ray (0 = opaque).
    pub transparency: f32,
    /// Index of refraction of the material (the outside is 1).
    pub ior: f32,
    /// Emitted colour, added unlit.
    pub emission: Vec3,
    /// Ambient reflectance k_a (OBJ `Ka`, AFF `fm` ambient), lit by the scene's ambient
    /// light [`Scene::ambient`] alone; zero by default.
    pub ambient: Vec3,
}

impl Default for Material {
    fn default() -> Self {
        Material {
            name: "default".into(),
            diffuse: Vec3::splat(0.7),
            specular: Vec3::splat(0.2),
            shininess: 32.0,
            reflectivity: 0.0,
            transparency: 0.0,
            ior: 1.0,
            emission: Vec3::ZERO,
            ambient: Vec3::ZERO,
        }
    }
}

impl Material {
    /// Check the values shading relies on: colours finite and non-negative, shininess finite
    /// and non-negative, reflectivity and transparency in [0, 1], and for a transparent
    /// material an index of refraction in [0.01, 100].
    pub fn validate(&self) -> Result<(), Invalid> {
        for (what, c) in [
            ("diffuse", self.diffuse),
            ("specular", self.specular),
            ("emission", self.emission),
            ("ambient", self.ambient),
        ] {
            if !(c.is_finite() && c.min_element() >= 0.0) {
                return Err(Invalid::from(format!(
                    "{what} colour {c} must be finite and non-negative"
                )));
            }
        }
        if !(self.shininess.is_finite() && self.shininess >= 0.0) {
            return Err(Invalid::from(format!(
                "shininess {} must be finite and non-negative",
                self.shininess
            )));
        }
        for (what, v) in [
            ("reflectivity", self.reflectivity),
            ("transparency", self.transparency),
        ] {
            if !(0.0..=1.0).contains(&v) {
                return Err(Invalid::from(format!("{what} {v} must be in [0, 1]")));
            }
        }
        if self.transparency > 0.0 && !(0.01..=100.0).contains(&self.ior) {
            return Err(Invalid::from(format!(
                "index of refraction {} of a transparent material must be in [0.01, 100]",
                self.ior
            )));
        }
        Ok(())
    }

    /// A plain diffuse material of colour `c`.
    pub fn diffuse(name: &str, c: Vec3) -> Self {
        Material {
            name: name.into(),
            diffuse: c,
            ..Default::default()
        }
    }
    /// A mirror of `reflectivity` tinted by `tint`.
    pub fn mirror(name: &str, tint: Vec3, reflectivity: f32) -> Self {
        Material {
            name: name.into(),
            diffuse: tint,
            specular: Vec3::splat(0.5),
            shininess: 64.0,
            reflectivity,
            ..Default::default()
        }
    }
    /// Clear glass of index of refraction `ior`.
    pub fn glass(name: &str, ior: f32) -> Self {
        Material {
            name: name.into(),
            diffuse: Vec3::splat(0.02),
            specular: Vec3::splat(0.8),
            shininess: 128.0,
            reflectivity: 0.1,
            transparency: 0.88,
            ior,
            emission: Vec3::ZERO,
            ambient: Vec3::ZERO,
        }
    }
}

/// A point light with the thesis's attenuation 1 / (c + l·d + q·d²) (eq. 3.19c).
#[derive(Clone, Debug, PartialEq)]
pub struct Light {
    /// Position.
    pub position: Vec3,
    /// Colour.
    pub color: Vec3,
    /// Intensity (scales the colour).
    pub intensity: f32,
    /// (constant, linear, quadratic).
    pub attenuation: [f32; 3],
}

impl Light {
    /// A white light of `intensity` without attenuation.
    pub fn white(position: Vec3, intensity: f32) -> Self {
        Light {
            position,
            color: Vec3::ONE,
            intensity,
            attenuation: [1.0, 0.0, 0.0],
        }
    }
}

/// A pinhole camera. `vfov` is the vertical field of view in degrees.
#[derive(Clone, Debug, PartialEq)]
pub struct Camera {
    /// Position.
    pub eye: Vec3,
    /// The point looked at.
    pub target: Vec3,
    /// The up direction (need not be orthogonal to the view direction).
    pub up: Vec3,
    /// Vertical field of view in degrees.
    pub vfov: f32,
}

impl Camera {
    /// The camera of a viewpoint `EX,EY,EZ,TX,TY,TZ[,FOV]`: eye, target and vertical field
    /// of view in degrees (default 45), up along +y; whether it makes a usable view is
    /// [`Scene::set_camera`]'s check.
    pub fn from_viewpoint(s: &str) -> Result<Camera, crate::error::ViewpointError> {
        let bad = || crate::error::ViewpointError::Form(s.to_string());
        let v: Vec<f32> = s
            .split(',')
            .map(|x| x.trim().parse::<f32>())
            .collect::<Result<_, _>>()
            .map_err(|_| bad())?;
        if !(v.len() == 6 || v.len() == 7) || v.iter().any(|x| !x.is_finite()) {
            return Err(bad());
        }
        Ok(Camera {
            eye: Vec3::new(v[0], v[1], v[2]),
            target: Vec3::new(v[3], v[4], v[5]),
            up: Vec3::Y,
            vfov: v.get(6).copied().unwrap_or(45.0),
        })
    }

    /// Orthonormal basis (right, up, forward) of the view.
    pub fn basis(&self) -> (Vec3, Vec3, Vec3) {
        let f = (self.target - self.eye).normalize();
        let r = f.cross(self.up).normalize();
        let u = r.cross(f);
        (r, u, f)
    }

    /// A camera that frames `bounds` from a pleasant three-quarter view.
    pub fn framing(bounds: &geom::Aabb) -> Camera {
        let c = bounds.center();
        let radius = (bounds.diagonal() * 0.5).max(1e-3);
        let vfov: f32 = 45.0;
        let dist = radius / (vfov.to_radians() * 0.5).sin() * 1.05;
        let dir = Vec3::new(0.35, 0.3, 1.0).normalize();
        Camera {
            eye: c + dir * dist,
            target: c,
            up: Vec3::Y,
            vfov,
        }
    }
}

/// A named triangle mesh in its own object space, placed by `transform`.
#[derive(Clone, Debug)]
pub struct Mesh {
    /// Name (from the file's group, material or node).
    pub name: String,
    /// Object-space vertex positions.
    pub positions: Vec<Vec3>,
    /// Per-vertex normals (same length as `positions`).
    pub normals: Vec<Vec3>,
    /// Vertex indices of each triangle.
    pub triangles: Vec<[u32; 3]>,
    /// Per-triangle index into [`Scene::materials`].
    pub materials: Vec<u32>,
    /// Object-to-world transform.
    pub transform: Mat4,
}

impl Mesh {
    /// A mesh with smooth area-weighted normals computed from its triangles.
    pub fn new(
        name: impl Into<String>,
        positions: Vec<Vec3>,
        triangles: Vec<[u32; 3]>,
        material: u32,
    ) -> Mesh {
        let normals = smooth_normals(&positions, &triangles);
        let materials = vec![material; triangles.len()];
        Mesh {
            name: name.into(),
            positions,
            normals,
            triangles,
            materials,
            transform: Mat4::IDENTITY,
        }
    }

    /// Minimal bounding sphere of the vertices actually used, in object space (thesis §3.2.1).
    pub fn local_bound(&self) -> Option<Sphere> {
        let mut used = vec![false; self.positions.len()];
        for t in &self.triangles {
            for &i in t {
                used[i as usize] = true;
            }
        }
        let pts: Vec<Vec3> = self
            .positions
            .iter()
            .zip(&used)
            .filter(|(_, u)| **u)
            .map(|(p, _)| *p)
            .collect();
        miniball::minimal_ball(&pts)
    }

    /// Drop zero-area (and non-finite) triangles; returns how many were dropped.
    pub fn remove_degenerate(&mut self) -> usize {
        let before = self.triangles.len();
        let pos = &self.positions;
        let keep: Vec<bool> = self
            .triangles
            .iter()
            .map(|t| {
                !tri::is_degenerate(pos[t[0] as usize], pos[t[1] as usize], pos[t[2] as usize])
            })
            .collect();
        let mut k = keep.iter();
        self.triangles.retain(|_| *k.next().unwrap());
        let mut k = keep.iter();
        self.materials.retain(|_| *k.next().unwrap());
        before - self.triangles.len()
    }
}

/// Area-weighted vertex normals (the unnormalised face normal's length is twice the area).
pub fn smooth_normals(positions: &[Vec3], triangles: &[[u32; 3]]) -> Vec<Vec3> {
    let mut n = vec![Vec3::ZERO; positions.len()];
    for t in triangles {
        let (a, b, c) = (
            positions[t[0] as usize],
            positions[t[1] as usize],
            positions[t[2] as usize],
        );
        let fnrm = (b - a).cross(c - a);
        if finite3(fnrm) {
            for &i in t {
                n[i as usize] += fnrm;
            }
        }
    }
    n.iter().map(|v| v.normalize_or(Vec3::Y)).collect()
}

/// What a loader noticed and handled (printed by the CLI).
#[derive(Clone, Debug, Default)]
pub struct LoadReport {
    /// The file loaded (None for built-in scenes).
    pub source: Option<PathBuf>,
    /// Degenerate (zero-area) triangles dropped.
    pub degenerate_skipped: usize,
    /// Vertices whose normals were computed because the file had none.
    pub normals_computed: usize,
    /// Seconds spent loading.
    pub load_seconds: f64,
    /// Anything else worth a line (approximations, ignored features).
    pub notes: Vec<String>,
    /// The scene's lights were placed by the loader (the file has none), so it gets the
    /// ambient fill unless told otherwise ([`crate::LoadOptions::fill`]).
    pub automatic_lights: bool,
    /// Suspicious content that was loaded anyway, each naming `file:line` (the CLI prints
    /// them as `warning:` lines).
    pub warnings: Vec<String>,
    /// Every file the load read: the scene file and what it references (material
    /// libraries, buffers, meshes, includes). A command's outputs may be none of them.
    pub files: Vec<PathBuf>,
}

/// A scene's identity, for what is kept from one use of its meshes to the next
/// ([`crate::Geometry::refill_at`] leaves a mesh that did not move as the last fill wrote
/// it). Every scene made gets a new one, and so does every clone (a clone may be changed
/// apart from its original); code that changes a scene's meshes in place gives it a new
/// one ([`SceneId::fresh`]).
#[derive(Debug, PartialEq, Eq)]
pub struct SceneId(u64);

impl SceneId {
    /// An identity no other scene of this process has.
    pub fn fresh() -> SceneId {
        static NEXT: std::sync::atomic::AtomicU64 = std::sync::atomic::AtomicU64::new(1);
        SceneId(NEXT.fetch_add(1, std::sync::atomic::Ordering::Relaxed))
    }

    /// The number.
    pub fn get(&self) -> u64 {
        self.0
    }
}

impl Default for SceneId {
    fn default() -> Self {
        SceneId::fresh()
    }
}

impl Clone for SceneId {
    fn clone(&self) -> Self {
        SceneId::fresh()
    }
}

/// A loaded scene: meshes with transforms, materials, lights, camera, and its animation.
#[derive(Clone, Debug)]
pub struct Scene {
    /// This scene's identity (see [`SceneId`]).
    pub id: SceneId,
    /// Name (the file stem or the built-in's name).
    pub name: String,
    /// Meshes, each in its own object space.
    pub meshes: Vec<Mesh>,
    /// Materials, indexed by the meshes' per-triangle ids.
    pub materials: Vec<Material>,
    /// Point lights.
    pub lights: Vec<Light>,
    /// The camera (files without one are framed automatically).
    pub camera: Camera,
    /// Colour of rays that leave the scene.
    pub background: Vec3,
    /// Ambient light (AFF `am`, TOML `ambient`), reflected by each material's
    /// [`Material::ambient`]; zero (thesis eq. 3.19 exactly) unless the scene defines one.
    pub ambient: Vec3,
    /// What the loader noticed.
    pub report: LoadReport,
    /// Keyframed motion, when the scene is animated ([`Scene::at_time`]).
    pub animation: Option<crate::anim::Animation>,
}

impl Scene {
    /// A scene read from `path` (named after the file stem), with a placeholder camera, no
    /// lights and a dark background, for loaders to finish.
    pub fn from_file(
        path: &std::path::Path,
        meshes: Vec<Mesh>,
        materials: Vec<Material>,
        report: LoadReport,
    ) -> Scene {
        Scene {
            id: SceneId::fresh(),
            name: path
                .file_stem()
                .map(|s| s.to_string_lossy().into_owned())
                .unwrap_or_default(),
            meshes,
            materials,
            lights: Vec::new(),
            camera: Camera {
                eye: Vec3::Z,
                target: Vec3::ZERO,
                up: Vec3::Y,
                vfov: 45.0,
            },
            background: Vec3::new(0.1, 0.1, 0.12),
            ambient: Vec3::ZERO,
            report,
            animation: None,
        }
    }

    /// Change the exposure by `ev` stops: every light, the ambient light, the background
    /// and every emission scaled by 2^ev. The Whitted image is linear in them (each pixel
    /// a sum of light × reflectance × throughput terms), so this is a camera's exposure,
    /// applied before the sRGB encoding's clamp. 0 changes nothing.
    pub fn expose(&mut self, ev: f32) {
        if ev == 0.0 {
            return;
        }
        let k = ev.exp2();
        for l in &mut self.lights {
            l.intensity *= k;
        }
        self.ambient *= k;
        self.background *= k;
        for m in &mut self.materials {
            m.emission *= k;
        }
    }

    /// Triangles over all meshes.
    pub fn triangle_count(&self) -> usize {
        self.meshes.iter().map(|m| m.triangles.len()).sum()
    }

    /// World-space bounds of all triangles.
    pub fn bounds(&self) -> geom::Aabb {
        let mut b = geom::Aabb::EMPTY;
        for m in &self.meshes {
            for t in &m.triangles {
                for &i in t {
                    b.grow(m.transform.transform_point3(m.positions[i as usize]));
                }
            }
        }
        b
    }

    /// Check the invariants engines rely on: at least one triangle, finite coordinates,
    /// valid indices and material ids, invertible transforms, sane camera and lights.
    pub fn validate(&self) -> Result<(), SceneError> {
        let path = self
            .report
            .source
            .clone()
            .unwrap_or_else(|| PathBuf::from(&self.name));
        if self.triangle_count() == 0 {
            let detail = if self.report.degenerate_skipped > 0 {
                format!(
                    " ({} degenerate triangles were skipped)",
                    self.report.degenerate_skipped
                )
            } else {
                String::new()
            };
            return Err(SceneError::Empty { path, detail });
        }
        if self.triangle_count() > u32::MAX as usize / 2 {
            return Err(SceneError::invalid(&path, "more than 2^31 triangles"));
        }
        for m in &self.materials {
            m.validate()
                .map_err(|e| SceneError::invalid(&path, format!("material '{}': {e}", m.name)))?;
        }
        if let Some(a) = &self.animation {
            a.validate().map_err(|e| SceneError::invalid(&path, e.0))?;
        }
        if !(self.ambient.is_finite() && self.ambient.min_element() >= 0.0) {
            return Err(SceneError::invalid(
                &path,
                format!(
                    "ambient light {} must be finite and non-negative",
                    self.ambient
                ),
            ));
        }
        for m in &self.meshes {
            let det = m.transform.determinant();
            if !(det.is_finite()
                && det.abs() > 1e-30
                && m.transform.to_cols_array().iter().all(|v| v.is_finite()))
            {
                return Err(SceneError::invalid(
                    &path,
                    format!("mesh '{}': transform is singular or not finite", m.name),
                ));
            }
            if let Some(p) = m.positions.iter().find(|p| !finite3(**p)) {
                return Err(SceneError::invalid(
                    &path,
                    format!("mesh '{}': non-finite vertex {p}", m.name),
                ));
            }
            if m.normals.len() != m.positions.len() || m.materials.len() != m.triangles.len() {
                return Err(SceneError::invalid(
                    &path,
                    format!("mesh '{}': attribute counts disagree", m.name),
                ));
            }
            for t in &m.triangles {
                if t.iter().any(|&i| i as usize >= m.positions.len()) {
                    return Err(SceneError::invalid(
                        &path,
                        format!("mesh '{}': vertex index out of range", m.name),
                    ));
                }
            }
            if m.materials
                .iter()
                .any(|&i| i as usize >= self.materials.len())
            {
                return Err(SceneError::invalid(
                    &path,
                    format!("mesh '{}': material id out of range", m.name),
                ));
            }
        }
        let c = &self.camera;
        let f = c.target - c.eye;
        // The view's direction and basis must be finite too: an eye and a target far apart
        // (±3e38) overflow their difference, and every ray would be NaN.
        let basis_finite = || {
            let (r, u, w) = c.basis();
            finite3(r) && finite3(u) && finite3(w)
        };
        let finite = finite3(c.eye)
            && finite3(c.target)
            && finite3(c.up)
            && finite3(f)
            && f.length().is_finite();
        if !finite
            || f.length() <= 0.0
            || f.cross(c.up).length() <= 1e-6 * f.length() * c.up.length()
            || !basis_finite()
        {
            return Err(SceneError::invalid(&path, "camera: eye, target and up must be finite, eye ≠ target at a representable distance, up not parallel to the view"));
        }
        if !(c.vfov > 0.0 && c.vfov < 180.0) {
            return Err(SceneError::invalid(
                &path,
                format!("camera: fov {} is not in (0, 180) degrees", c.vfov),
            ));
        }
        for (i, l) in self.lights.iter().enumerate() {
            let a = l.attenuation;
            if !finite3(l.position)
                || !finite3(l.color)
                || !l.intensity.is_finite()
                || a.iter().any(|v| !v.is_finite() || *v < 0.0)
                || a.iter().all(|v| *v == 0.0)
            {
                return Err(SceneError::invalid(&path, format!("light {i}: position, colour, intensity must be finite and attenuation non-negative, not all zero")));
            }
        }
        for m in &self.materials {
            let vals = [m.shininess, m.reflectivity, m.transparency, m.ior];
            if !vals.iter().all(|v| v.is_finite())
                || !finite3(m.diffuse)
                || !finite3(m.specular)
                || !finite3(m.emission)
                || m.ior <= 0.0
            {
                return Err(SceneError::invalid(
                    &path,
                    format!("material '{}': values must be finite and ior > 0", m.name),
                ));
            }
        }
        Ok(())
    }

    /// Append another scene's meshes and materials (material ids are rebased).
    pub fn append_meshes(&mut self, mut meshes: Vec<Mesh>, materials: Vec<Material>) {
        let base = self.materials.len() as u32;
        for m in &mut meshes {
            for id in &mut m.materials {
                *id += base;
            }
        }
        self.materials.extend(materials);
        self.meshes.extend(meshes);
    }
}

impl Scene {
    /// The static scene at time `t`: mesh transforms from their chains, vertex-animated
    /// positions (with recomputed smooth normals), the animated camera. A scene without
    /// animation is returned unchanged.
    pub fn at_time(&self, t: f32) -> Scene {
        let mut s = self.clone();
        let Some(a) = &self.animation else {
            return s;
        };
        // Each track once per frame; then every mesh's chain from those matrices.
        let tracks = a.track_matrices(t);
        s.meshes.par_iter_mut().enumerate().for_each(|(m, mesh)| {
            if let Some(x) = a.mesh_transform_with(m, &tracks) {
                mesh.transform = x;
            }
            if let Some(Some(vk)) = a.vertex_keys.get(m) {
                mesh.positions = vk.at(t);
                mesh.normals = smooth_normals(&mesh.positions, &mesh.triangles);
            }
        });
        s.camera = self.camera_at(t);
        s
    }

    /// Look through `camera` from now on, at every time (an animation's camera track no
    /// longer moves it), as a scene file's `[camera]` would; refused, with the scene as it
    /// was, when it makes no usable view (see [`Scene::validate`]).
    pub fn set_camera(&mut self, camera: Camera) -> Result<(), SceneError> {
        let before = std::mem::replace(&mut self.camera, camera);
        if let Err(e) = self.validate() {
            self.camera = before;
            return Err(e);
        }
        if let Some(a) = &mut self.animation {
            a.camera = None;
        }
        Ok(())
    }

    /// The camera at time `t` (the animation's camera track, if any).
    pub fn camera_at(&self, t: f32) -> Camera {
        let base = &self.camera;
        let Some((a, ci)) = self.animation.as_ref().and_then(|a| Some((a, a.camera?))) else {
            return base.clone();
        };
        let tr = &a.tracks[ci as usize];
        let (pos, rot, _) = tr.trs(t);
        let eye = if tr.translation.is_empty() {
            base.eye
        } else {
            pos
        };
        let (dir, up) = if tr.rotation.is_empty() {
            (base.target - base.eye, base.up)
        } else {
            // BART's GetCamera: the viewer looks along −z with y up, rotated.
            (rot * -Vec3::Z, rot * Vec3::Y)
        };
        Camera {
            eye,
            target: eye + dir.normalize_or(-Vec3::Z),
            up,
            vfov: base.vfov,
        }
    }

    /// What a frame at time `t` renders with besides its geometry
    /// ([`crate::Geometry::refill_at`]): the camera at `t`, the lights, materials,
    /// background and ambient light, without copying the meshes or the animation (a render
    /// reads neither: its triangles are the geometry's).
    pub fn frame_at(&self, t: f32) -> Scene {
        Scene {
            id: SceneId::fresh(),
            name: self.name.clone(),
            meshes: Vec::new(),
            materials: self.materials.clone(),
            lights: self.lights.clone(),
            camera: self.camera_at(t),
            background: self.background,
            ambient: self.ambient,
            report: self.report.clone(),
            animation: None,
        }
    }
}

/// The object-space culling sphere of each mesh, valid at every time: the minimal ball of
/// the mesh's vertices, or for a vertex-animated mesh of all its key positions together (see
/// [`Animation::local_spheres`](crate::anim::Animation::local_spheres)).
pub fn local_spheres(meshes: &[Mesh], keys: &[Option<VertexKeys>]) -> Vec<Sphere> {
    meshes
        .iter()
        .enumerate()
        .map(|(i, m)| match keys.get(i) {
            Some(Some(k)) => {
                let all: Vec<Vec3> = k.positions.iter().flatten().copied().collect();
                geom::miniball::minimal_ball(&all).unwrap_or_default()
            }
            _ => m.local_bound().unwrap_or_default(),
        })
        .collect()
}
