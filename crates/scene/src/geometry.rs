//! The flattened, world-space view of a scene that every engine consumes.
//!
//! Flat buffers of plain `Copy` values indexed by u32 triangle id, grouped by mesh so that
//! mesh `m` owns the contiguous range `mesh_first[m] .. mesh_first[m + 1]`.

use crate::model::Scene;
use geom::{Aabb, Mat3, Sphere, Vec3};
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
        let pre = scene
            .animation
            .as_ref()
            .map(|a| a.local_spheres.as_slice())
            .filter(|s| s.len() == scene.meshes.len());
        let mut g = Geometry::default();
        g.mesh_first.push(0);
        for (mi, m) in scene.meshes.iter().enumerate() {
            let xf = m.transform;
            let nxf = Mat3::from_mat4(xf).inverse().transpose();
            let world: Vec<Vec3> = m
                .positions
                .par_iter()
                .map(|p| xf.transform_point3(*p))
                .collect();
            let wn: Vec<Vec3> = m
                .normals
                .par_iter()
                .map(|n| (nxf * *n).normalize_or(Vec3::Y))
                .collect();
            for (t, &mat) in m.triangles.iter().zip(&m.materials) {
                let [a, b, c] = t.map(|i| i as usize);
                g.tris.push([world[a], world[b], world[c]]);
                g.normals.push([wn[a], wn[b], wn[c]]);
                g.material.push(mat);
                g.mesh.push(mi as u32);
            }
            g.mesh_first.push(g.tris.len() as u32);
            let local = match pre {
                Some(s) => s[mi],
                None => m.local_bound().unwrap_or_default(),
            };
            g.mesh_local_sphere.push(local);
            g.mesh_sphere.push(local.transformed(&xf));
        }
        g.bounds = Aabb::from_points(g.tris.iter().flatten().copied());
        g
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
