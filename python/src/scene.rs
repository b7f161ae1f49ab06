//! `rayspace.Scene`: a scene loaded from a file or a name, or made from arrays
//! (`scene::arrays`), and changed between frames (`update`: a mesh's vertices or
//! transform). A scene holds its model and the flattened triangles engines build on; an
//! update replaces both, and engines built before it refuse to trace until rebuilt
//! (`crate::engine`).

use crate::err;
use numpy::{IntoPyArray, PyArray3, PyArrayMethods, PyReadonlyArray2, PyUntypedArrayMethods};
use pyo3::prelude::*;
use std::sync::{Arc, RwLock};
use std::time::Instant;

/// The scene as it is now: its model and its geometry (replaced whole by an update, so an
/// engine or a render holding the last one keeps it).
#[derive(Clone)]
pub(crate) struct State {
    pub scene: Arc<scene::Scene>,
    pub geo: Arc<scene::Geometry>,
}

/// A loaded scene and its triangles (the model and the flattened geometry engines build on).
#[pyclass(module = "rayspace._rayspace", frozen)]
pub(crate) struct Scene {
    state: RwLock<State>,
    load_seconds: f64,
}

impl Scene {
    pub(crate) fn from_scene(s: scene::Scene, load_seconds: f64) -> Scene {
        let geo = scene::Geometry::from_scene(&s);
        Scene {
            state: RwLock::new(State {
                scene: Arc::new(s),
                geo: Arc::new(geo),
            }),
            load_seconds,
        }
    }

    /// The scene as it is now.
    pub(crate) fn now(&self) -> State {
        self.state.read().unwrap_or_else(|p| p.into_inner()).clone()
    }

    /// The model as it is now.
    pub(crate) fn model(&self) -> Arc<scene::Scene> {
        self.now().scene
    }

    /// Mesh `mesh` given new vertices and/or a new transform (see `update`).
    fn apply(
        &self,
        py: Python<'_>,
        mesh: usize,
        vertices: Option<PyReadonlyArray2<'_, f32>>,
        transform: Option<PyReadonlyArray2<'_, f32>>,
    ) -> PyResult<()> {
        let v = vertices.as_ref().map(|v| rows("vertices", v)).transpose()?;
        let xf = transform
            .as_ref()
            .map(|m| matrix("transform", m))
            .transpose()?;
        py.detach(|| -> PyResult<()> {
            // One update at a time: the next starts from this one's scene.
            let mut st = self.state.write().unwrap_or_else(|p| p.into_inner());
            let mut s = (*st.scene).clone();
            if let Some(v) = v {
                s.set_vertices(mesh, v).map_err(err)?;
            }
            if let Some(xf) = xf {
                s.set_transform(mesh, xf).map_err(err)?;
            }
            // The geometry of the scene as it is now (a fresh scene identity: engines
            // built before are no longer current).
            let geo = scene::Geometry::from_scene(&s);
            *st = State {
                scene: Arc::new(s),
                geo: Arc::new(geo),
            };
            Ok(())
        })
    }

    /// The model, the geometry and the load's seconds.
    pub(crate) fn state(&self) -> (Arc<scene::Scene>, Arc<scene::Geometry>, f64) {
        let s = self.now();
        (s.scene, s.geo, self.load_seconds)
    }
}

/// Rows of 3 values of an (N, 3) array, C-contiguous as the package passes them.
fn rows<'a, T: numpy::Element + Copy>(
    name: &str,
    a: &'a PyReadonlyArray2<'_, T>,
) -> PyResult<&'a [[T; 3]]> {
    if a.shape()[1] != 3 {
        return Err(err(format!(
            "{name}: expected shape (N, 3), got {:?}",
            a.shape()
        )));
    }
    let flat = a
        .as_slice()
        .map_err(|_| err(format!("{name}: expected a C-contiguous array")))?;
    // Read in place: rows copied out first would double a large mesh's memory.
    let (rows, rest) = flat.as_chunks::<3>();
    debug_assert!(rest.is_empty());
    Ok(rows)
}

/// `a` (any array-like) as the package converts it (`rayspace._array`: any real or integer
/// dtype and strides, converted once; a `TypeError` for what is not numbers, `Error` for
/// the wrong shape or an integer out of range): a C-contiguous array of `dtype` with
/// `cols` columns.
fn convert<'py, T: numpy::Element>(
    a: &Bound<'py, PyAny>,
    name: &str,
    dtype: &str,
    cols: usize,
) -> PyResult<PyReadonlyArray2<'py, T>> {
    let py = a.py();
    let np = py.import("numpy")?;
    let shape = if cols == 3 {
        (py.None(), 3usize.into_pyobject(py)?.into_any().unbind())
    } else {
        (
            4usize.into_pyobject(py)?.into_any().unbind(),
            4usize.into_pyobject(py)?.into_any().unbind(),
        )
    };
    let arr =
        py.import("rayspace")?
            .getattr("_array")?
            .call1((name, a, np.getattr(dtype)?, shape))?;
    arr.extract::<PyReadonlyArray2<'py, T>>()
}

/// A row-major 4 × 4 matrix (NumPy's `M @ p` convention) as the library's transform.
fn matrix(name: &str, m: &PyReadonlyArray2<'_, f32>) -> PyResult<geom::Mat4> {
    if m.shape() != [4, 4] {
        return Err(err(format!(
            "{name}: expected shape (4, 4), got {:?}",
            m.shape()
        )));
    }
    let s = m
        .as_slice()
        .map_err(|_| err(format!("{name}: expected a C-contiguous array")))?;
    let mut a = [0.0f32; 16];
    a.copy_from_slice(s);
    // Row-major rows are glam's columns of the transpose.
    Ok(geom::Mat4::from_cols_array(&a).transpose())
}

#[pymethods]
impl Scene {
    /// Load a built-in scene (cornell, spheres, soup, stadium, office) or a file (.obj,
    /// .gltf/.glb, .toml, BART .aff), as the command line does (`meshes`: `--meshes`,
    /// `allow_outside_paths`: `--allow-outside-paths`).
    #[staticmethod]
    #[pyo3(signature = (spec, meshes = "groups", allow_outside_paths = false, fill = None, exposure = None))]
    fn load(
        py: Python<'_>,
        spec: &str,
        meshes: &str,
        allow_outside_paths: bool,
        fill: Option<bool>,
        exposure: Option<f32>,
    ) -> PyResult<Scene> {
        // A named shared scene takes its own look where none is asked for, as `render`.
        let named = scene::named_look(spec);
        let fill = fill.or(named.map(|n| n.0));
        let exposure = exposure.or(named.map(|n| n.1)).unwrap_or(0.0);
        let split = trace::by_name(meshes, "meshes", &scene::MeshSplit::NAMES)
            .map_err(|e| err(format!("meshes='{meshes}': {e}")))?;
        if !(exposure.is_finite() && (-16.0..=16.0).contains(&exposure)) {
            return Err(err(format!(
                "exposure={exposure}: must be a number of stops in -16..=16"
            )));
        }
        let opts = scene::LoadOptions {
            split,
            allow_outside_paths,
            fill,
            exposure,
            ..Default::default()
        }
        .for_memory(trace::memory::limit(None));
        let spec = spec.to_string();
        py.detach(move || {
            let t0 = Instant::now();
            let s = scene::load(&spec, &opts).map_err(err)?;
            Ok(Scene::from_scene(s, t0.elapsed().as_secs_f64()))
        })
    }

    /// A scene of one mesh from arrays, as Open3D's `add_triangles` or trimesh take one:
    /// `vertices` (N, 3) and `faces` (M, 3) vertex indices (any real and integer
    /// array-likes, converted once), diffuse grey, with the automatic camera and light of a
    /// bare OBJ. Hits name the faces' rows (degenerate faces are kept, never hit).
    #[staticmethod]
    #[pyo3(signature = (vertices, faces, transform = None, name = "arrays"))]
    fn from_arrays(
        vertices: &Bound<'_, PyAny>,
        faces: &Bound<'_, PyAny>,
        transform: Option<&Bound<'_, PyAny>>,
        name: &str,
    ) -> PyResult<Scene> {
        let py = vertices.py();
        let m = (
            convert::<f32>(vertices, "vertices", "float32", 3)?,
            convert::<u32>(faces, "faces", "uint32", 3)?,
            transform
                .map(|t| convert::<f32>(t, "transform", "float32", 4))
                .transpose()?,
        );
        from_meshes(py, &[m], name)
    }

    /// A scene of several meshes: `meshes` a sequence of `(vertices, faces)` or
    /// `(vertices, faces, transform)` (a row-major 4 × 4 matrix). Triangles are numbered
    /// mesh after mesh, each in its faces' order; `update(mesh=i, ...)` changes mesh `i`.
    #[staticmethod]
    #[pyo3(signature = (meshes, name = "arrays"))]
    fn from_meshes(meshes: &Bound<'_, PyAny>, name: &str) -> PyResult<Scene> {
        let py = meshes.py();
        let mut ms = Vec::new();
        for (i, m) in meshes.try_iter()?.enumerate() {
            let m = m?;
            let parts: Vec<Bound<'_, PyAny>> = m.extract().map_err(|_| {
                pyo3::exceptions::PyTypeError::new_err(format!(
                    "meshes[{i}]: expected (vertices, faces) or (vertices, faces, transform)"
                ))
            })?;
            if !(2..=3).contains(&parts.len()) {
                return Err(pyo3::exceptions::PyTypeError::new_err(format!(
                    "meshes[{i}]: expected (vertices, faces) or (vertices, faces, transform), got {} items",
                    parts.len()
                )));
            }
            let at = |what: &str| format!("meshes[{i}] {what}");
            ms.push((
                convert::<f32>(&parts[0], &at("vertices"), "float32", 3)?,
                convert::<u32>(&parts[1], &at("faces"), "uint32", 3)?,
                parts
                    .get(2)
                    .filter(|t| !t.is_none())
                    .map(|t| convert::<f32>(t, &at("transform"), "float32", 4))
                    .transpose()?,
            ));
        }
        from_meshes(py, &ms, name)
    }

    /// Change the scene between frames: mesh `mesh`'s `vertices` (as many as it has; its
    /// faces stay) and/or its `transform` (row-major 4 × 4). Engines built before must be
    /// rebuilt (`Engine.rebuild()`) before they trace again; renders see it at once.
    #[pyo3(signature = (vertices = None, transform = None, mesh = 0))]
    fn update(
        &self,
        vertices: Option<&Bound<'_, PyAny>>,
        transform: Option<&Bound<'_, PyAny>>,
        mesh: usize,
    ) -> PyResult<()> {
        let v = vertices
            .map(|v| convert::<f32>(v, "vertices", "float32", 3))
            .transpose()?;
        let xf = transform
            .map(|t| convert::<f32>(t, "transform", "float32", 4))
            .transpose()?;
        let py = match (vertices, transform) {
            (Some(a), _) | (None, Some(a)) => a.py(),
            (None, None) => return Err(err("update: give vertices, a transform or both")),
        };
        self.apply(py, mesh, v, xf)
    }

    /// The scene's name.
    #[getter]
    fn name(&self) -> String {
        self.model().name.clone()
    }

    /// Triangles (after degenerate ones are skipped; a scene from arrays keeps every face).
    #[getter]
    fn triangle_count(&self) -> usize {
        self.now().geo.len()
    }

    /// Meshes (the unit of bounding-sphere culling).
    #[getter]
    fn mesh_count(&self) -> usize {
        self.now().geo.mesh_count()
    }

    /// Point lights.
    #[getter]
    fn light_count(&self) -> usize {
        self.model().lights.len()
    }

    /// The scene's box as ((min x, y, z), (max x, y, z)).
    #[getter]
    fn bounds(&self) -> ([f32; 3], [f32; 3]) {
        let b = self.now().geo.bounds;
        (b.min.to_array(), b.max.to_array())
    }

    /// Whether the scene has an animation (BART .aff, TOML keyframes).
    #[getter]
    fn animated(&self) -> bool {
        self.model().animation.is_some()
    }

    /// The animation's (start, end) time, or None.
    #[getter]
    fn time_range(&self) -> Option<(f32, f32)> {
        self.model().animation.as_ref().map(|a| (a.start, a.end))
    }

    /// Wall time of the load.
    #[getter]
    fn load_seconds(&self) -> f64 {
        self.load_seconds
    }

    /// The loader's warnings.
    #[getter]
    fn warnings(&self) -> Vec<String> {
        self.model().report.warnings.clone()
    }

    /// The scene at animation time `t` (as `--time`).
    fn at_time(&self, py: Python<'_>, t: f32) -> PyResult<Scene> {
        if !t.is_finite() {
            return Err(err(format!("t={t}: not a finite time")));
        }
        let s = self.model();
        if s.animation.is_none() {
            return Err(err(format!("t: {} is not animated", s.name)));
        }
        Ok(py.detach(move || Scene::from_scene(s.at_time(t), 0.0)))
    }

    /// The times of `n` frames spread over the animation (as `--frames n`).
    fn frame_times(&self, n: u32) -> PyResult<Vec<f32>> {
        let s = self.model();
        match &s.animation {
            Some(a) if n > 0 => Ok(a.frame_times(n)),
            Some(_) => Err(err("frames=0: expected at least one frame")),
            None => Err(err(format!(
                "frames: {} is not animated (BART .aff files and TOML scenes with keyframes are)",
                s.name
            ))),
        }
    }

    /// The triangles as an (N, 3, 3) float32 array (triangle, vertex, axis), in the
    /// order hit records index.
    fn triangles<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray3<f32>> {
        let geo = self.now().geo;
        let flat: Vec<f32> = geo
            .tris
            .iter()
            .flat_map(|t| t.iter().flat_map(|v| v.to_array()))
            .collect();
        flat.into_pyarray(py)
            .reshape([geo.len(), 3, 3])
            .expect("9 floats per triangle")
    }

    fn __repr__(&self) -> String {
        let st = self.now();
        format!(
            "Scene('{}', {} triangles, {} meshes, {} lights{})",
            st.scene.name,
            st.geo.len(),
            st.geo.mesh_count(),
            st.scene.lights.len(),
            if st.scene.animation.is_some() {
                ", animated"
            } else {
                ""
            }
        )
    }
}

/// A scene of `meshes` (vertices, faces, transform) named `name` (see `Scene.from_meshes`).
#[allow(clippy::type_complexity)]
fn from_meshes(
    py: Python<'_>,
    meshes: &[(
        PyReadonlyArray2<'_, f32>,
        PyReadonlyArray2<'_, u32>,
        Option<PyReadonlyArray2<'_, f32>>,
    )],
    name: &str,
) -> PyResult<Scene> {
    let t0 = Instant::now();
    let mut b = scene::SceneBuilder::new(name);
    for (i, (v, f, xf)) in meshes.iter().enumerate() {
        let (v, f) = (rows("vertices", v)?, rows("faces", f)?);
        let what = |e: scene::ArrayError| {
            if meshes.len() == 1 {
                err(e)
            } else {
                err(format!("meshes[{i}]: {e}"))
            }
        };
        let m = py.detach(|| b.mesh(v, f, None)).map_err(what)?;
        if let Some(xf) = xf {
            b.transform(m, matrix("transform", xf)?).map_err(what)?;
        }
    }
    let s = py.detach(move || b.build()).map_err(err)?;
    Ok(Scene::from_scene(s, t0.elapsed().as_secs_f64()))
}
