//! The flattened, world-space view of a scene that every engine consumes.
//!
//! Flat buffers of plain `Copy` values indexed by u32 triangle id, grouped by mesh so that
//! mesh `m` owns the contiguous range `mesh_first[m] .. mesh_first[m + 1]`.

use crate::model::Scene;
use geom::{Aabb, Mat3, Mat4, Sphere, Vec3};
use rayon::prelude::*;

/// A scene flattened for the engines: world-space triangles in flat arrays, grouped by mesh,
/// with the meshes' culling spheres (what every `Tracer` is built from).
#[derive(Clone, Debug, Default)]
pub struct Geometry {
    /// World-space vertices of each triangle.
    pub tris: Vec<[Vec3; 3]>,
    /// World-space unit vertex normals of each triangle.
    pub normals: Vec<[Vec3; 3]>,
    /// Material id of each triangle.
    pub material: Vec<u32>,
    /// Mesh id of each triangle.
    pub mesh: Vec<u32>,
    /// Prefix offsets: mesh m owns triangles `mesh_first[m] .. mesh_first[m+1]`.
    pub mesh_first: Vec<u32>,
    /// Object-space minimal bounding sphere of each mesh (thesis §3.2.1), precomputed once.
    pub mesh_local_sphere: Vec<Sphere>,
    /// World-space culling sphere of each mesh: the local sphere updated by the mesh
    /// transform (thesis §3.2.2), never recomputed from the vertices.
    pub mesh_sphere: Vec<Sphere>,
    /// Bounding box of all triangles.
    pub bounds: Aabb,
    /// What the last fill wrote, so that the next one can leave unmoved meshes as they are.
    kept: Kept,
}

/// The last fill's scene and, per mesh, the transform it was written with (`None`: its
/// vertices were animated, so it is always rewritten) and the bounds of its triangles.
#[derive(Clone, Debug, Default)]
struct Kept {
    scene: u64,
    /// Meshes the last fill wrote (the others it left as they were).
    written: usize,
    xf: Vec<Option<[u32; 16]>>,
    bounds: Vec<Aabb>,
}

/// A transform's bits (−0 and +0 differ: they can give different vertex bits).
fn xf_bits(m: &Mat4) -> [u32; 16] {
    m.to_cols_array().map(f32::to_bits)
}

impl Geometry {
    /// A hash of the triangles' vertex bits, in order (FNV-1a over 32-bit words): what a
    /// ray file records to say which scene its rays were made for. Equal geometry gives an
    /// equal hash; any moved vertex almost surely another one. Never 0.
    pub fn content_hash(&self) -> u64 {
        let mut h: u64 = 0xcbf2_9ce4_8422_2325;
        let mut add = |w: u32| {
            h ^= w as u64;
            h = h.wrapping_mul(0x0000_0100_0000_01b3);
        };
        add(self.tris.len() as u32);
        for t in &self.tris {
            for v in t {
                add(v.x.to_bits());
                add(v.y.to_bits());
                add(v.z.to_bits());
            }
        }
        h.max(1)
    }

    /// The world-space triangles of `scene`. Mesh culling spheres are the object-space
    /// minimal spheres transformed by each mesh's transform; for an animated scene the
    /// object-space spheres are the animation's precomputed ones (valid at every time), so
    /// a frame costs no miniball at all (thesis §3.2.2).
    pub fn from_scene(scene: &Scene) -> Geometry {
        let mut g = Geometry::default();
        g.fill(scene, |m| (scene.meshes[m].transform, None));
        g
    }

    /// [`Geometry::from_scene`] written into these buffers (a scene as it stands, each mesh
    /// placed by its own transform; what did not move since the last fill of this scene is
    /// left as it was).
    pub fn refill(&mut self, scene: &Scene) {
        self.fill(scene, |m| (scene.meshes[m].transform, None));
    }

    /// The world-space triangles of animated `scene` at time `t` — bit for bit
    /// `from_scene(&scene.at_time(t))` — written into these buffers (a frame of an
    /// animation: kept from the last frame, so no allocation and no fresh pages), without
    /// copying the scene: every track is evaluated once, every mesh's chain composed from
    /// those matrices, meshes in parallel. When the buffers hold this scene's last fill
    /// ([`Scene::id`]), a mesh without vertex animation whose transform has the same bits
    /// is not written again: a steady frame rewrites only what moved. (Buffers changed by
    /// hand since are not noticed: fill them with a fresh `Geometry`.)
    pub fn refill_at(&mut self, scene: &Scene, t: f32) {
        let Some(a) = &scene.animation else {
            return self.fill(scene, |m| (scene.meshes[m].transform, None));
        };
        let tracks = a.track_matrices(t);
        self.fill(scene, |m| {
            let mesh = &scene.meshes[m];
            let xf = a.mesh_transform_with(m, &tracks).unwrap_or(mesh.transform);
            let moved = match a.vertex_keys.get(m) {
                Some(Some(vk)) => {
                    let p = vk.at(t);
                    let n = crate::model::smooth_normals(&p, &mesh.triangles);
                    Some((p, n))
                }
                _ => None,
            };
            (xf, moved)
        });
    }

    /// Fill the arrays from `scene`'s meshes, mesh m placed by `state(m)`: its transform
    /// and, for a vertex-animated mesh, its positions and normals at the frame's time.
    #[allow(clippy::type_complexity)]
    fn fill(
        &mut self,
        scene: &Scene,
        state: impl Fn(usize) -> (Mat4, Option<(Vec<Vec3>, Vec<Vec3>)>) + Sync,
    ) {
        let pre = scene
            .animation
            .as_ref()
            .map(|a| a.local_spheres.as_slice())
            .filter(|s| s.len() == scene.meshes.len());
        self.mesh_first.clear();
        self.mesh_first.push(0u32);
        for m in &scene.meshes {
            let last = *self.mesh_first.last().expect("starts at 0");
            self.mesh_first.push(last + m.triangles.len() as u32);
        }
        let n = *self.mesh_first.last().expect("starts at 0") as usize;
        // The buffers hold this scene's last fill: a mesh with no vertex animation whose
        // transform has the same bits is left as it is (the same arithmetic would write the
        // same bits again). Most meshes of an animated scene stand still from one frame to
        // the next (BART Kitchen: 86 of 393 move, 7,182 of 110,520 triangles).
        let kept = std::mem::take(&mut self.kept);
        let reuse = kept.scene == scene.id.get()
            && kept.xf.len() == scene.meshes.len()
            && self.tris.len() == n;
        // Every element is written below; a buffer of the right length (the last frame's)
        // is overwritten in place.
        self.tris.resize(n, [Vec3::ZERO; 3]);
        self.normals.resize(n, [Vec3::ZERO; 3]);
        self.material.resize(n, 0);
        self.mesh.resize(n, 0);
        // Meshes in parallel, each writing its own range of the flat arrays (the order of
        // the serial loop: mesh by mesh, triangle by triangle), with the same arithmetic.
        let mut tris = self.tris.as_mut_slice();
        let mut normals = self.normals.as_mut_slice();
        let mut material = self.material.as_mut_slice();
        let mut mesh = self.mesh.as_mut_slice();
        let mut parts = Vec::with_capacity(scene.meshes.len());
        for m in &scene.meshes {
            let k = m.triangles.len();
            let (a, b) = std::mem::take(&mut tris).split_at_mut(k);
            let (c, d) = std::mem::take(&mut normals).split_at_mut(k);
            let (e, f) = std::mem::take(&mut material).split_at_mut(k);
            let (h, i) = std::mem::take(&mut mesh).split_at_mut(k);
            parts.push((a, c, e, h));
            (tris, normals, material, mesh) = (b, d, f, i);
        }
        #[allow(clippy::type_complexity)]
        let done: Vec<((Sphere, Sphere), (Option<[u32; 16]>, Aabb), bool)> = parts
            .into_par_iter()
            .zip(scene.meshes.par_iter())
            .enumerate()
            .map(|(mi, ((tris, normals, material, mesh), m))| {
                let (xf, moved) = state(mi);
                let local = match pre {
                    Some(s) => s[mi],
                    None => m.local_bound().unwrap_or_default(),
                };
                let spheres = (local, local.transformed(&xf));
                let bits = moved.is_none().then(|| xf_bits(&xf));
                if reuse && bits.is_some() && kept.xf[mi] == bits {
                    return (spheres, (bits, kept.bounds[mi]), false);
                }
                let (positions, vnormals) = match &moved {
                    Some((p, n)) => (p.as_slice(), n.as_slice()),
                    None => (m.positions.as_slice(), m.normals.as_slice()),
                };
                let nxf = Mat3::from_mat4(xf).inverse().transpose();
                let world: Vec<Vec3> = positions.iter().map(|p| xf.transform_point3(*p)).collect();
                let wn: Vec<Vec3> = vnormals
                    .iter()
                    .map(|n| (nxf * *n).normalize_or(Vec3::Y))
                    .collect();
                for (k, (t, &mat)) in m.triangles.iter().zip(&m.materials).enumerate() {
                    let [a, b, c] = t.map(|i| i as usize);
                    tris[k] = [world[a], world[b], world[c]];
                    normals[k] = [wn[a], wn[b], wn[c]];
                    material[k] = mat;
                    mesh[k] = mi as u32;
                }
                let bounds = Aabb::from_points(tris.iter().flatten().copied());
                (spheres, (bits, bounds), true)
            })
            .collect();
        let marks_written = done.iter().filter(|d| d.2).count();
        let (spheres, marks): (Vec<(Sphere, Sphere)>, Vec<(Option<[u32; 16]>, Aabb)>) =
            done.into_iter().map(|(s, m, _)| (s, m)).unzip();
        (self.mesh_local_sphere, self.mesh_sphere) = spheres.into_iter().unzip();
        let (xf, bounds): (Vec<Option<[u32; 16]>>, Vec<Aabb>) = marks.into_iter().unzip();
        // Minimum and maximum are exact: the meshes' boxes united in mesh order.
        self.bounds = bounds.iter().fold(Aabb::EMPTY, |a, b| a.union(b));
        self.kept = Kept {
            scene: scene.id.get(),
            written: marks_written,
            xf,
            bounds,
        };
    }

    /// A bare triangle soup as one mesh, every vertex normal `normal`, material 0 (for tests
    /// and synthetic inputs; no culling spheres).
    pub fn soup(tris: Vec<[Vec3; 3]>, normal: Vec3) -> Geometry {
        let n = tris.len();
        Geometry {
            normals: vec![[normal; 3]; n],
            material: vec![0; n],
            mesh: vec![0; n],
            mesh_first: vec![0, n as u32],
            bounds: Aabb::from_points(tris.iter().flatten().copied()),
            tris,
            ..Default::default()
        }
    }

    /// How many meshes the last fill wrote ([`Geometry::refill_at`] leaves a mesh that did
    /// not move since the fill before as it was).
    pub fn meshes_written(&self) -> usize {
        self.kept.written
    }

    /// Number of triangles.
    pub fn len(&self) -> usize {
        self.tris.len()
    }

    /// Whether there are no triangles.
    pub fn is_empty(&self) -> bool {
        self.tris.is_empty()
    }

    /// Number of meshes.
    pub fn mesh_count(&self) -> usize {
        self.mesh_first.len().saturating_sub(1)
    }

    /// Geometric unit normal of triangle `t`.
    #[inline]
    pub fn geometric_normal(&self, t: u32) -> Vec3 {
        let [a, b, c] = self.tris[t as usize];
        geom::tri::geometric_normal(a, b, c)
    }

    /// Interpolated shading normal (thesis eqs. 3.17–3.18: barycentric weights of the hit).
    #[inline]
    pub fn shading_normal(&self, t: u32, u: f32, v: f32) -> Vec3 {
        let [n0, n1, n2] = self.normals[t as usize];
        let n = (n0 * (1.0 - u - v) + n1 * u + n2 * v).normalize_or_zero();
        if n == Vec3::ZERO {
            self.geometric_normal(t)
        } else {
            n
        }
    }

    /// The point of triangle `t` at barycentrics (u, v).
    #[inline]
    pub fn point(&self, t: u32, u: f32, v: f32) -> Vec3 {
        let [a, b, c] = self.tris[t as usize];
        a * (1.0 - u - v) + b * u + c * v
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A frame's geometry refilled in place equals the one made from the scene at that
    /// time, bit for bit, whatever size the buffers had before.
    #[test]
    fn refill_at_equals_from_scene_at_time() {
        let text = "[camera]\neye = [0, 2, 8]\ntarget = [0, 0, 0]\n[[meshes]]\nshape = \"plane\"\nscale = 5\n[[meshes]]\nshape = \"box\"\n[meshes.animation]\nkeys = [{ t = 0 }, { t = 1, translate = [2, 1, 0], rotate = [0, 90, 0], scale = 0.5 }]\n[[meshes]]\nshape = \"sphere\"\n[meshes.animation]\nkeys = [{ t = 0, translate = [0, 3, 0] }, { t = 2, rotate = [45, 0, 30] }]\n";
        let path = std::path::Path::new("anim.toml");
        let sb = crate::io::Sandbox::for_scene(path, false);
        let scene = crate::scenefile::load_scene_text_in(text, path, &sb).unwrap();
        assert!(scene.animation.is_some());
        let mut g = Geometry::soup(vec![[Vec3::ONE; 3]; 7], Vec3::Y);
        // A copy of the scene with the plane's vertices moved (an edited file loaded
        // again): its own identity, so nothing of the first scene's fill is kept.
        let mut edited = scene.clone();
        for p in &mut edited.meshes[0].positions {
            p.y += 0.25;
        }
        // Forwards, back, the same time twice (every mesh kept), the box's last key and
        // after it (the box kept), then the edited scene and the first again.
        let steps: [(&Scene, f32, usize); 9] = [
            (&scene, 0.0, 3),
            (&scene, 0.37, 2),
            (&scene, 1.0, 2),
            (&scene, 1.5, 1),
            (&scene, 1.5, 0),
            (&scene, 0.37, 2),
            (&edited, 0.37, 3),
            (&edited, 0.5, 2),
            (&scene, 0.5, 3),
        ];
        for (scene, t, written) in steps {
            let want = Geometry::from_scene(&scene.at_time(t));
            g.refill_at(scene, t);
            assert_eq!(g.meshes_written(), written, "meshes written at t = {t}");
            let bits = |g: &Geometry| -> Vec<u32> {
                g.tris
                    .iter()
                    .chain(&g.normals)
                    .flatten()
                    .flat_map(|v| v.to_array().map(f32::to_bits))
                    .collect()
            };
            assert_eq!(bits(&g), bits(&want), "t = {t}");
            assert_eq!(
                (&g.material, &g.mesh, &g.mesh_first),
                (&want.material, &want.mesh, &want.mesh_first)
            );
            assert_eq!(g.mesh_sphere, want.mesh_sphere);
            assert_eq!(g.bounds, want.bounds);
            assert_eq!(scene.frame_at(t).camera, scene.at_time(t).camera);
        }
    }
}
