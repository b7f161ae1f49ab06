//! Scenes from arrays: the way in for geometry that is already in memory (a mesh from
//! NumPy, a simulator's buffers, a procedural model) rather than in a file, and the changes
//! a dynamic scene makes between frames (new vertex positions, new transforms).
//!
//! A scene's triangles are numbered in mesh order, each mesh's in the order of its faces:
//! the hits of a scene made from one vertex array and one face array name the faces' rows.
//! So that they always do, faces are kept as given, degenerate ones too (a zero-area
//! triangle is never hit: the exact test's determinant is zero), where the file loaders
//! drop them. Everything is checked before it is used: an index out of range, a vertex
//! that is not finite or a singular transform is a typed error naming the row.
//!
//! A scene without lights gets the automatic camera and light of a bare OBJ (and its
//! ambient fill), so that a first render of it shows it; one given lights and a camera
//! keeps them.

use crate::autocam;
use crate::error::ArrayError;
use crate::model::{smooth_normals, Camera, Light, LoadReport, Material, Mesh, Scene, SceneId};
use crate::SceneError;
use geom::{Mat4, Vec3};

/// The most faces a scene holds (triangle ids are 31-bit, as [`Scene::validate`] says).
const MAX_FACES: usize = u32::MAX as usize / 2;

/// Vertices from rows of three coordinates, checked finite.
fn vertices(rows: &[[f32; 3]]) -> Result<Vec<Vec3>, ArrayError> {
    if rows.len() > u32::MAX as usize {
        return Err(ArrayError::TooMany {
            what: "vertices",
            count: rows.len(),
            max: u32::MAX as usize,
        });
    }
    rows.iter()
        .enumerate()
        .map(|(row, p)| {
            let v = Vec3::from_array(*p);
            if v.is_finite() {
                Ok(v)
            } else {
                Err(ArrayError::NotFinite { row, value: v })
            }
        })
        .collect()
}

/// Faces checked against `n` vertices.
fn faces(faces: &[[u32; 3]], n: usize) -> Result<Vec<[u32; 3]>, ArrayError> {
    if faces.is_empty() {
        return Err(ArrayError::NoFaces);
    }
    if faces.len() > MAX_FACES {
        return Err(ArrayError::TooMany {
            what: "faces",
            count: faces.len(),
            max: MAX_FACES,
        });
    }
    for (row, f) in faces.iter().enumerate() {
        if let Some(&index) = f.iter().find(|&&i| i as usize >= n) {
            return Err(ArrayError::Index {
                row,
                index,
                vertices: n,
            });
        }
    }
    Ok(faces.to_vec())
}

/// A scene put together from arrays: meshes (vertex and face arrays, a material, a
/// transform), materials, lights and a camera, each optional but the first mesh.
///
/// ```
/// use scene::{Light, Material, SceneBuilder};
/// let mut b = SceneBuilder::new("two triangles");
/// let red = b.material(Material::diffuse("red", geom::Vec3::new(0.8, 0.1, 0.1)));
/// b.mesh(&[[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [1.0, 1.0, 0.0]],
///        &[[0, 1, 2], [1, 3, 2]], Some(red)).unwrap();
/// b.light(Light::white(geom::Vec3::new(0.0, 0.0, 3.0), 1.0));
/// let scene = b.build().unwrap();
/// assert_eq!(scene.triangle_count(), 2);
/// ```
#[derive(Clone, Debug, Default)]
pub struct SceneBuilder {
    name: String,
    meshes: Vec<Mesh>,
    materials: Vec<Material>,
    lights: Vec<Light>,
    camera: Option<Camera>,
    /// The material of meshes given none (made on first use).
    grey: Option<u32>,
}

impl SceneBuilder {
    /// An empty scene called `name`.
    pub fn new(name: impl Into<String>) -> SceneBuilder {
        SceneBuilder {
            name: name.into(),
            ..Default::default()
        }
    }

    /// Add a material; its index is what [`SceneBuilder::mesh`] takes.
    pub fn material(&mut self, m: Material) -> u32 {
        self.materials.push(m);
        self.materials.len() as u32 - 1
    }

    /// Add a mesh of `positions` and `faces` (rows of vertex indices, counter-clockwise
    /// seen from the front), of `material` (None: diffuse grey), and return its index.
    /// Its triangles follow the earlier meshes' in the scene's numbering.
    pub fn mesh(
        &mut self,
        positions: &[[f32; 3]],
        faces: &[[u32; 3]],
        material: Option<u32>,
    ) -> Result<usize, ArrayError> {
        let p = vertices(positions)?;
        let f = self::faces(faces, p.len())?;
        let total = self.meshes.iter().map(|m| m.triangles.len()).sum::<usize>() + f.len();
        if total > MAX_FACES {
            return Err(ArrayError::TooMany {
                what: "faces",
                count: total,
                max: MAX_FACES,
            });
        }
        let material = match material {
            Some(m) if m as usize >= self.materials.len() => {
                return Err(ArrayError::NoMaterial {
                    material: m,
                    materials: self.materials.len(),
                })
            }
            Some(m) => m,
            None => *self.grey.get_or_insert_with(|| {
                self.materials
                    .push(Material::diffuse("grey", Vec3::splat(0.7)));
                self.materials.len() as u32 - 1
            }),
        };
        let name = format!("mesh{}", self.meshes.len());
        self.meshes.push(Mesh::new(name, p, f, material));
        Ok(self.meshes.len() - 1)
    }

    /// Place mesh `mesh` by `transform` (object to world).
    pub fn transform(&mut self, mesh: usize, transform: Mat4) -> Result<(), ArrayError> {
        let meshes = self.meshes.len();
        let m = self
            .meshes
            .get_mut(mesh)
            .ok_or(ArrayError::NoMesh { mesh, meshes })?;
        check_transform(mesh, &transform)?;
        m.transform = transform;
        Ok(())
    }

    /// Add a point light (a scene given none gets the automatic one).
    pub fn light(&mut self, light: Light) {
        self.lights.push(light);
    }

    /// Look through `camera` (a scene given none is framed automatically).
    pub fn camera(&mut self, camera: Camera) {
        self.camera = Some(camera);
    }

    /// The scene, checked as a loaded one is ([`Scene::validate`]).
    pub fn build(self) -> Result<Scene, SceneError> {
        if self.meshes.is_empty() {
            return Err(ArrayError::NoFaces.into());
        }
        let mut s = Scene::from_file(
            std::path::Path::new(&self.name),
            self.meshes,
            self.materials,
            LoadReport::default(),
        );
        s.name = self.name;
        if self.lights.is_empty() {
            autocam::auto_camera_and_light(&mut s);
            autocam::apply_fill(&mut s);
        } else {
            s.lights = self.lights;
            s.camera = Camera::framing(&s.bounds());
        }
        if let Some(c) = self.camera {
            s.camera = c;
        }
        s.validate()?;
        Ok(s)
    }
}

/// A transform engines can use: finite and invertible.
fn check_transform(mesh: usize, m: &Mat4) -> Result<(), ArrayError> {
    let det = m.determinant();
    if det.is_finite() && det.abs() > 1e-30 && m.to_cols_array().iter().all(|v| v.is_finite()) {
        Ok(())
    } else {
        Err(ArrayError::Transform { mesh })
    }
}

impl Scene {
    /// A scene of one mesh: `positions` (rows x, y, z) and `faces` (rows of vertex
    /// indices), diffuse grey, with the automatic camera and light of a bare OBJ. Hits name
    /// the faces' rows. More meshes, materials and lights: [`SceneBuilder`].
    pub fn from_arrays(positions: &[[f32; 3]], faces: &[[u32; 3]]) -> Result<Scene, SceneError> {
        let mut b = SceneBuilder::new("arrays");
        b.mesh(positions, faces, None)?;
        b.build()
    }

    /// Give mesh `mesh` new vertex positions (as many as it has; its faces stay), with
    /// its normals recomputed: a deforming mesh's next frame. Engines built before must be
    /// built again to see it.
    pub fn set_vertices(&mut self, mesh: usize, positions: &[[f32; 3]]) -> Result<(), SceneError> {
        let meshes = self.meshes.len();
        let m = self
            .meshes
            .get(mesh)
            .ok_or(ArrayError::NoMesh { mesh, meshes })?;
        if positions.len() != m.positions.len() {
            return Err(ArrayError::VertexCount {
                mesh,
                given: positions.len(),
                has: m.positions.len(),
            }
            .into());
        }
        if let Some(Some(_)) = self
            .animation
            .as_ref()
            .and_then(|a| a.vertex_keys.get(mesh))
        {
            return Err(ArrayError::Animated {
                mesh,
                what: "vertices",
            }
            .into());
        }
        let p = vertices(positions)?;
        let m = &mut self.meshes[mesh];
        m.normals = smooth_normals(&p, &m.triangles);
        m.positions = p;
        // An animated scene keeps each mesh's object-space culling sphere (valid at every
        // time): this mesh's is its new vertices'.
        if let Some(a) = &mut self.animation {
            if let Some(s) = a.local_spheres.get_mut(mesh) {
                *s = m.local_bound().unwrap_or_default();
            }
        }
        self.id = SceneId::fresh();
        Ok(())
    }

    /// Place mesh `mesh` by `transform` (object to world) from now on.
    pub fn set_transform(&mut self, mesh: usize, transform: Mat4) -> Result<(), SceneError> {
        let meshes = self.meshes.len();
        if mesh >= meshes {
            return Err(ArrayError::NoMesh { mesh, meshes }.into());
        }
        if let Some(a) = &self.animation {
            if a.mesh_transform(mesh, a.start).is_some() {
                return Err(ArrayError::Animated {
                    mesh,
                    what: "transform",
                }
                .into());
            }
        }
        check_transform(mesh, &transform)?;
        self.meshes[mesh].transform = transform;
        self.id = SceneId::fresh();
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::Geometry;

    const QUAD: [[f32; 3]; 4] = [
        [0.0, 0.0, 0.0],
        [1.0, 0.0, 0.0],
        [0.0, 1.0, 0.0],
        [1.0, 1.0, 0.0],
    ];

    #[test]
    fn faces_keep_their_rows_degenerate_ones_too() {
        // Row 1 is degenerate (a repeated vertex): kept, so row 2 is still triangle 2.
        let s = Scene::from_arrays(&QUAD, &[[0, 1, 2], [1, 1, 2], [1, 3, 2]]).unwrap();
        let g = Geometry::from_scene(&s);
        assert_eq!(g.len(), 3);
        assert_eq!(g.tris[2], [QUAD[1], QUAD[3], QUAD[2]].map(Vec3::from_array));
        assert_eq!(s.lights.len(), 1, "the automatic light");
        assert!(s.report.automatic_lights);
    }

    #[test]
    fn bad_arrays_name_the_row() {
        let e = Scene::from_arrays(&QUAD, &[[0, 1, 2], [1, 4, 2]]).unwrap_err();
        assert_eq!(
            e.to_string(),
            "face 1: vertex index 4 is out of range (4 vertices)"
        );
        let mut p = QUAD;
        p[3][1] = f32::NAN;
        let e = Scene::from_arrays(&p, &[[0, 1, 2]]).unwrap_err();
        assert!(e.to_string().starts_with("vertex 3 is not finite"), "{e}");
        assert!(Scene::from_arrays(&QUAD, &[]).is_err());
        let mut b = SceneBuilder::new("x");
        assert!(matches!(
            b.mesh(&QUAD, &[[0, 1, 2]], Some(3)),
            Err(ArrayError::NoMaterial { .. })
        ));
    }

    #[test]
    fn updates_move_the_triangles_and_refuse_what_does_not_fit() {
        let mut s = Scene::from_arrays(&QUAD, &[[0, 1, 2], [1, 3, 2]]).unwrap();
        let id = s.id.get();
        let moved: Vec<[f32; 3]> = QUAD.iter().map(|p| [p[0], p[1], p[2] + 2.0]).collect();
        s.set_vertices(0, &moved).unwrap();
        assert_ne!(
            s.id.get(),
            id,
            "a changed scene is another scene to what it kept"
        );
        assert_eq!(
            Geometry::from_scene(&s).tris[0][0],
            Vec3::new(0.0, 0.0, 2.0)
        );
        s.set_transform(0, Mat4::from_translation(Vec3::X)).unwrap();
        assert_eq!(
            Geometry::from_scene(&s).tris[0][0],
            Vec3::new(1.0, 0.0, 2.0)
        );
        assert!(matches!(
            s.set_vertices(0, &moved[..3]).unwrap_err(),
            SceneError::Arrays(ArrayError::VertexCount {
                given: 3,
                has: 4,
                ..
            })
        ));
        assert!(s.set_transform(0, Mat4::ZERO).is_err());
        assert!(s.set_transform(1, Mat4::IDENTITY).is_err());
    }
}
