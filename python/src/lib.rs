//! `rayspace._rayspace`: the Python bindings (PyO3). Scenes load, engines build, rays are
//! made and traced, and frames render through the same library calls as the command line
//! (`rayspace::engines`, `rayspace::options`, `render::whitted`), so a result from Python is
//! the command line's, byte for byte. The GIL is released while anything long runs.
//!
//! The friendly argument checks (dtype, shape, contiguity, finiteness) and the docstrings of
//! the public API live in the Python package (`rayspace/__init__.py`); this module checks
//! again what it relies on. Messages name options by their keywords (`levels=99`), never by
//! the command line's flags: the library writes an option between backticks, and [`err`]
//! spells it the Python way.

use numpy::{
    IntoPyArray, PyArray3, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2,
    PyUntypedArrayMethods,
};
use pyo3::create_exception;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use rayspace::engines;
use rayspace::engines::{Backend, Config, EngineError, EngineOptions};
use std::path::PathBuf;
use std::sync::{Arc, Mutex};
use std::time::Instant;
use trace::options::Value;
use trace::{Hit, RayBatch, RayKind, TraceMode, TraceStats, Tracer};

mod image;
use image::{check_image, frame, frame_csv_header, png_bytes, render_frame, write_atomic};

create_exception!(
    _rayspace,
    Error,
    pyo3::exceptions::PyValueError,
    "A rayspace error: bad input, a bad option or a failed load or build."
);

/// A library message as Python words: an option written `` `name`=value `` becomes
/// `name=value`, and a bare `` `name` `` loses its backticks.
fn pythonic(msg: &str) -> String {
    let mut out = String::with_capacity(msg.len());
    let mut rest = msg;
    while let Some(i) = rest.find('`') {
        out += &rest[..i];
        let after = &rest[i + 1..];
        match after.find('`') {
            Some(j)
                if after[..j]
                    .chars()
                    .all(|c| c.is_ascii_lowercase() || c == '_') =>
            {
                out += &after[..j];
                rest = &after[j + 1..];
            }
            _ => {
                out.push('`');
                rest = after;
            }
        }
    }
    out + rest
}

fn err(e: impl std::fmt::Display) -> PyErr {
    Error::new_err(pythonic(&e.to_string()))
}

/// A loaded scene and its triangles (the model and the flattened geometry engines build on).
#[pyclass(module = "rayspace._rayspace", frozen)]
struct Scene {
    scene: Arc<scene::Scene>,
    geo: Arc<scene::Geometry>,
    load_seconds: f64,
}

impl Scene {
    fn from_scene(s: scene::Scene, load_seconds: f64) -> Scene {
        let geo = scene::Geometry::from_scene(&s);
        Scene {
            scene: Arc::new(s),
            geo: Arc::new(geo),
            load_seconds,
        }
    }
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

    /// The scene's name.
    #[getter]
    fn name(&self) -> String {
        self.scene.name.clone()
    }

    /// Triangles (after degenerate ones are skipped).
    #[getter]
    fn triangle_count(&self) -> usize {
        self.geo.len()
    }

    /// Meshes (the unit of bounding-sphere culling).
    #[getter]
    fn mesh_count(&self) -> usize {
        self.geo.mesh_count()
    }

    /// Point lights.
    #[getter]
    fn light_count(&self) -> usize {
        self.scene.lights.len()
    }

    /// The scene's box as ((min x, y, z), (max x, y, z)).
    #[getter]
    fn bounds(&self) -> ([f32; 3], [f32; 3]) {
        let b = self.scene.bounds();
        (b.min.to_array(), b.max.to_array())
    }

    /// Whether the scene has an animation (BART .aff, TOML keyframes).
    #[getter]
    fn animated(&self) -> bool {
        self.scene.animation.is_some()
    }

    /// The animation's (start, end) time, or None.
    #[getter]
    fn time_range(&self) -> Option<(f32, f32)> {
        self.scene.animation.as_ref().map(|a| (a.start, a.end))
    }

    /// Wall time of the load.
    #[getter]
    fn load_seconds(&self) -> f64 {
        self.load_seconds
    }

    /// The loader's warnings.
    #[getter]
    fn warnings(&self) -> Vec<String> {
        self.scene.report.warnings.clone()
    }

    /// The scene at animation time `t` (as `--time`).
    fn at_time(&self, py: Python<'_>, t: f32) -> PyResult<Scene> {
        if !t.is_finite() {
            return Err(err(format!("t={t}: not a finite time")));
        }
        if self.scene.animation.is_none() {
            return Err(err(format!("t: {} is not animated", self.scene.name)));
        }
        let s = self.scene.clone();
        Ok(py.detach(move || Scene::from_scene(s.at_time(t), 0.0)))
    }

    /// The times of `n` frames spread over the animation (as `--frames n`).
    fn frame_times(&self, n: u32) -> PyResult<Vec<f32>> {
        match &self.scene.animation {
            Some(a) if n > 0 => Ok(a.frame_times(n)),
            Some(_) => Err(err("frames=0: expected at least one frame")),
            None => Err(err(format!(
                "frames: {} is not animated (BART .aff files and TOML scenes with keyframes are)",
                self.scene.name
            ))),
        }
    }

    /// The triangles as an (N, 3, 3) float32 array (triangle, vertex, axis), in the
    /// order hit records index.
    fn triangles<'py>(&self, py: Python<'py>) -> Bound<'py, PyArray3<f32>> {
        let flat: Vec<f32> = self
            .geo
            .tris
            .iter()
            .flat_map(|t| t.iter().flat_map(|v| v.to_array()))
            .collect();
        let n = self.geo.len();
        flat.into_pyarray(py)
            .reshape([n, 3, 3])
            .expect("9 floats per triangle")
    }

    fn __repr__(&self) -> String {
        format!(
            "Scene('{}', {} triangles, {} meshes, {} lights{})",
            self.scene.name,
            self.geo.len(),
            self.geo.mesh_count(),
            self.scene.lights.len(),
            if self.scene.animation.is_some() {
                ", animated"
            } else {
                ""
            }
        )
    }
}

/// Python keyword arguments as the library's keyword values (`bool` before `int`: a Python
/// bool is an int).
fn keyword_values(options: Option<&Bound<'_, PyDict>>) -> PyResult<Vec<(String, Value)>> {
    let mut out = Vec::new();
    if let Some(d) = options {
        for (k, v) in d.iter() {
            let k: String = k.extract()?;
            let value = if let Ok(b) = v.cast::<pyo3::types::PyBool>() {
                Value::Bool(b.is_true())
            } else if let Ok(i) = v.extract::<i64>() {
                Value::Int(i)
            } else if let Ok(x) = v.extract::<f64>() {
                Value::Float(x)
            } else if let Ok(s) = v.extract::<String>() {
                Value::Str(s)
            } else {
                return Err(pyo3::exceptions::PyTypeError::new_err(format!(
                    "{k}: expected a bool, a number or a string, got {}",
                    v.get_type().name()?
                )));
            };
            out.push((k, value));
        }
    }
    Ok(out)
}

/// The engine named `engine` (the registry's default engine when `None`) and its
/// configuration from keyword arguments (each checked against the engine's declarations;
/// the engine's defaults for the rest). An unknown keyword is a `TypeError`, as Python's own.
pub(crate) fn parse_engine(
    engine: Option<&str>,
    options: Option<&Bound<'_, PyDict>>,
    dynamic: bool,
) -> PyResult<(engines::Engine, Config)> {
    let e = match engine {
        Some(n) => engines::Engine::parse(n).map_err(err)?,
        None => engines::DEFAULT_ENGINE,
    };
    let asked = EngineOptions::new(keyword_values(options)?, dynamic);
    let cfg = engines::config::config(e, Backend::Cpu, &asked).map_err(|k| match k {
        EngineError::Unknown { .. } => {
            pyo3::exceptions::PyTypeError::new_err(pythonic(&k.to_string()))
        }
        _ => err(k),
    })?;
    Ok((e, cfg))
}

/// An engine built over a scene.
#[pyclass(module = "rayspace._rayspace", frozen)]
struct Engine {
    tracer: Box<dyn Tracer + Send>,
    report: Option<String>,
    build_seconds: f64,
    last: Mutex<TraceStats>,
}

#[pymethods]
impl Engine {
    #[new]
    #[pyo3(signature = (scene, name, **options))]
    fn new(
        py: Python<'_>,
        scene: &Scene,
        name: &str,
        options: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Engine> {
        let (engine, cfg) = parse_engine(Some(name), options, false)?;
        let geo = scene.geo.clone();
        py.detach(move || {
            let t0 = Instant::now();
            let b = engines::build(engine, &cfg, &geo).map_err(err)?;
            Ok(Engine {
                tracer: b.tracer,
                report: b.report,
                build_seconds: t0.elapsed().as_secs_f64(),
                last: Mutex::new(TraceStats::default()),
            })
        })
    }

    #[getter]
    fn name(&self) -> String {
        self.tracer.name().to_string()
    }

    #[getter]
    fn build_seconds(&self) -> f64 {
        self.build_seconds
    }

    #[getter]
    fn build_report(&self) -> Option<String> {
        self.report.clone()
    }

    #[getter]
    fn build_passes(&self) -> Vec<(String, f64)> {
        self.tracer
            .build_passes()
            .iter()
            .map(|p| (p.name(), p.seconds))
            .collect()
    }

    #[pyo3(signature = (origins, directions, tmin = None, tmax = None, any_hit = false))]
    fn trace<'py>(
        &self,
        py: Python<'py>,
        origins: PyReadonlyArray2<'py, f32>,
        directions: PyReadonlyArray2<'py, f32>,
        tmin: Option<PyReadonlyArray1<'py, f32>>,
        tmax: Option<PyReadonlyArray1<'py, f32>>,
        any_hit: bool,
    ) -> PyResult<Bound<'py, PyDict>> {
        let rays = batch(&origins, &directions, tmin.as_ref(), tmax.as_ref())?;
        let mode = if any_hit {
            TraceMode::Any
        } else {
            TraceMode::Closest
        };
        let tracer = &self.tracer;
        let (hits, st) = py.detach(|| {
            let mut hits = vec![Hit::MISS; rays.len()];
            let mut st = TraceStats::default();
            tracer.trace(&rays, mode, &mut hits, &mut st);
            (hits, st)
        });
        *self.last.lock().unwrap_or_else(|p| p.into_inner()) = st;
        hits_dict(py, &hits)
    }

    /// The counters of the last `trace` (the command line's `--stats` "trace" object).
    fn counters<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let st = self.last.lock().unwrap_or_else(|p| p.into_inner()).clone();
        let mut v = serde_json::to_value(&st).map_err(err)?;
        v["total_tests"] = st.total_tests().into();
        json_to_py(py, &v)
    }

    fn __repr__(&self) -> String {
        format!("Engine('{}')", self.tracer.name())
    }
}

/// A JSON value as the Python object `json.loads` makes of it.
fn json_to_py<'py>(py: Python<'py>, v: &serde_json::Value) -> PyResult<Bound<'py, PyAny>> {
    py.import("json")?.call_method1("loads", (v.to_string(),))
}

/// Rays from (N, 3) origin and direction arrays and optional (N,) bounds (default 0 and ∞),
/// checked as every engine requires ([`RayBatch::validate`]: the message names the ray).
fn batch(
    origins: &PyReadonlyArray2<'_, f32>,
    directions: &PyReadonlyArray2<'_, f32>,
    tmin: Option<&PyReadonlyArray1<'_, f32>>,
    tmax: Option<&PyReadonlyArray1<'_, f32>>,
) -> PyResult<RayBatch> {
    let vec3s = |name: &str, a: &PyReadonlyArray2<'_, f32>| -> PyResult<Vec<geom::Vec3>> {
        if a.shape()[1] != 3 {
            return Err(err(format!(
                "{name}: expected shape (N, 3), got {:?}",
                a.shape()
            )));
        }
        let s = a
            .as_slice()
            .map_err(|_| err(format!("{name}: expected a C-contiguous array")))?;
        Ok(s.chunks_exact(3).map(geom::Vec3::from_slice).collect())
    };
    let org = vec3s("origins", origins)?;
    let dir = vec3s("directions", directions)?;
    let n = org.len();
    if dir.len() != n {
        return Err(err(format!(
            "directions: {} rays, but origins has {n}",
            dir.len()
        )));
    }
    let bound = |name: &str, a: Option<&PyReadonlyArray1<'_, f32>>, d: f32| -> PyResult<Vec<f32>> {
        match a {
            None => Ok(vec![d; n]),
            Some(a) => {
                let s = a
                    .as_slice()
                    .map_err(|_| err(format!("{name}: expected a C-contiguous array")))?;
                if s.len() != n {
                    return Err(err(format!("{name}: {} values for {n} rays", s.len())));
                }
                Ok(s.to_vec())
            }
        }
    };
    // The batch, its hit records and the hit arrays handed back, checked before they are
    // allocated.
    let need = n as u64 * (render::whitted::BYTES_PER_RAY + 2 * std::mem::size_of::<Hit>() as u64);
    let limit = trace::memory::limit(None);
    if n > u32::MAX as usize || need > limit {
        return Err(err(format!(
            "{n} rays need {}, more than the {} limit: trace them in parts",
            trace::memory::gib(need),
            trace::memory::gib(limit)
        )));
    }
    let t_min = bound("tmin", tmin, 0.0)?;
    let t_max = bound("tmax", tmax, f32::INFINITY)?;
    // The batch `RayBatch::from_rays(.., Primary)` makes (pixel = ray index, neutral
    // weights), filled column by column: no per-ray pushes and no intermediate copy, as
    // the columns' allocation is most of what a call adds to the trace.
    let b = RayBatch {
        org,
        dir,
        t_min,
        t_max,
        kind: vec![RayKind::Primary as u8; n],
        pixel: (0..n as u32).collect(),
        light: vec![0; n],
        throughput: vec![geom::Vec3::ONE; n],
        depth: vec![0; n],
        width: 0,
    };
    b.validate().map_err(err)?;
    Ok(b)
}

/// Hit records as `{"t", "triangle", "u", "v"}` arrays (a miss: triangle 0xFFFFFFFF, t ∞).
fn hits_dict<'py>(py: Python<'py>, hits: &[Hit]) -> PyResult<Bound<'py, PyDict>> {
    fn column<'py, T: numpy::Element>(
        py: Python<'py>,
        hits: &[Hit],
        f: impl Fn(&Hit) -> T,
    ) -> Bound<'py, numpy::PyArray1<T>> {
        hits.iter().map(f).collect::<Vec<_>>().into_pyarray(py)
    }
    let d = PyDict::new(py);
    d.set_item("t", column(py, hits, |h| h.t))?;
    d.set_item("triangle", column(py, hits, |h| h.tri))?;
    d.set_item("u", column(py, hits, |h| h.u))?;
    d.set_item("v", column(py, hits, |h| h.v))?;
    Ok(d)
}

/// Rays as `{"origins", "directions", "tmin", "tmax"}` arrays.
fn rays_dict<'py>(py: Python<'py>, r: &RayBatch) -> PyResult<Bound<'py, PyDict>> {
    let n = r.len();
    let flat = |v: &[geom::Vec3]| -> Vec<f32> { v.iter().flat_map(|p| p.to_array()).collect() };
    let d = PyDict::new(py);
    d.set_item("origins", flat(&r.org).into_pyarray(py).reshape([n, 3])?)?;
    d.set_item("directions", flat(&r.dir).into_pyarray(py).reshape([n, 3])?)?;
    d.set_item("tmin", r.t_min.clone().into_pyarray(py))?;
    d.set_item("tmax", r.t_max.clone().into_pyarray(py))?;
    Ok(d)
}

/// The rays `rayspace rays` makes (`--kind`, `--width`, `--height`, `--spp`, `--seed`,
/// `--ao-distance`).
#[pyfunction]
#[pyo3(signature = (scene, kind = "primary", width = 512, height = 512, spp = 1, seed = 1, ao_distance = None))]
#[allow(clippy::too_many_arguments)]
fn rays<'py>(
    py: Python<'py>,
    scene: &Scene,
    kind: &str,
    width: u32,
    height: u32,
    spp: u32,
    seed: u64,
    ao_distance: Option<f32>,
) -> PyResult<Bound<'py, PyDict>> {
    let k = trace::by_name(kind, "ray kind", &render::raygen::Kind::NAMES)
        .map_err(|e| err(format!("kind='{kind}': {e}")))?;
    check_image(width, height, 0)?;
    if !(1..=1024).contains(&spp) {
        return Err(err(format!("spp={spp}: expected 1..=1024")));
    }
    let n = width as u64 * height as u64 * spp as u64;
    if n > 1 << 28 {
        return Err(err(format!(
            "width × height × spp = {n} rays is more than 2^28"
        )));
    }
    if let Some(d) = ao_distance {
        if !(d.is_finite() && d > 0.0) {
            return Err(err(format!("ao_distance={d}: must be positive and finite")));
        }
    }
    let (s, geo) = (scene.scene.clone(), scene.geo.clone());
    let opts = render::raygen::Options {
        width,
        height,
        spp,
        seed,
        ao_distance,
    };
    let r = py.detach(move || render::raygen::generate(&s, &geo, k, &opts));
    rays_dict(py, &r)
}

#[pyfunction]
fn read_rays<'py>(py: Python<'py>, path: PathBuf) -> PyResult<Bound<'py, PyDict>> {
    let r = py
        .detach(|| render::rayfile::read_rays(&path, RayKind::Primary))
        .map_err(err)?;
    rays_dict(py, &r)
}

#[pyfunction]
#[pyo3(signature = (path, origins, directions, tmin = None, tmax = None, scene = None))]
fn write_rays(
    py: Python<'_>,
    path: PathBuf,
    origins: PyReadonlyArray2<'_, f32>,
    directions: PyReadonlyArray2<'_, f32>,
    tmin: Option<PyReadonlyArray1<'_, f32>>,
    tmax: Option<PyReadonlyArray1<'_, f32>>,
    scene: Option<&Scene>,
) -> PyResult<()> {
    render::output::check_output(&path).map_err(|e| err(format!("path: {e}")))?;
    let r = batch(&origins, &directions, tmin.as_ref(), tmax.as_ref())?;
    let tag = scene.map(|s| render::rayfile::SceneTag::of(&s.scene.name, &s.geo));
    py.detach(|| render::rayfile::write_rays_for(&path, &r, tag.as_ref()))
        .map_err(err)
}

/// A hit file's records and whether they answer any-hit queries.
#[pyfunction]
fn read_hits<'py>(py: Python<'py>, path: PathBuf) -> PyResult<(Bound<'py, PyDict>, bool)> {
    let (hits, mode) = py
        .detach(|| render::rayfile::read_hits(&path))
        .map_err(err)?;
    Ok((hits_dict(py, &hits)?, mode == TraceMode::Any))
}

#[pyfunction]
#[pyo3(signature = (path, t, triangle, u, v, any_hit = false))]
fn write_hits(
    py: Python<'_>,
    path: PathBuf,
    t: PyReadonlyArray1<'_, f32>,
    triangle: PyReadonlyArray1<'_, u32>,
    u: PyReadonlyArray1<'_, f32>,
    v: PyReadonlyArray1<'_, f32>,
    any_hit: bool,
) -> PyResult<()> {
    render::output::check_output(&path).map_err(|e| err(format!("path: {e}")))?;
    let contiguous = |name: &str, s: Result<&[f32], _>| -> PyResult<Vec<f32>> {
        s.map(|s: &[f32]| s.to_vec())
            .map_err(|_: numpy::AsSliceError| err(format!("{name}: expected a C-contiguous array")))
    };
    let (t, u, v) = (
        contiguous("t", t.as_slice())?,
        contiguous("u", u.as_slice())?,
        contiguous("v", v.as_slice())?,
    );
    let tri = triangle
        .as_slice()
        .map_err(|_| err("triangle: expected a C-contiguous array"))?;
    let n = t.len();
    if [tri.len(), u.len(), v.len()].iter().any(|&l| l != n) {
        return Err(err("t, triangle, u and v must have one value per ray each"));
    }
    let hits: Vec<Hit> = (0..n)
        .map(|i| Hit {
            tri: tri[i],
            t: t[i],
            u: u[i],
            v: v[i],
        })
        .collect();
    let mode = if any_hit {
        TraceMode::Any
    } else {
        TraceMode::Closest
    };
    py.detach(|| render::rayfile::write_hits(&path, &hits, mode))
        .map_err(err)
}

/// Every engine option, from the engines' declarations: per option its keyword, what it
/// takes, its one-line doc, the engines that take it and its default.
#[pyfunction]
fn engine_options(py: Python<'_>) -> PyResult<Vec<Bound<'_, PyDict>>> {
    engines::config::options()
        .into_iter()
        .map(|o| {
            let d = PyDict::new(py);
            d.set_item("name", o.name)?;
            d.set_item("takes", o.kind.range())?;
            d.set_item("doc", o.doc)?;
            d.set_item(
                "engines",
                o.engines.iter().map(|e| e.name()).collect::<Vec<_>>(),
            )?;
            d.set_item("default", o.default_text())?;
            Ok(d)
        })
        .collect()
}

/// The engines this build can name (`--engine`'s values).
#[pyfunction]
fn engine_names() -> Vec<String> {
    engines::Engine::NAMES
        .iter()
        .map(|(n, _)| n.to_string())
        .collect()
}

#[pymodule]
fn _rayspace(m: &Bound<'_, PyModule>) -> PyResult<()> {
    m.add("Error", m.py().get_type::<Error>())?;
    m.add("MISS", geom::NO_HIT)?;
    m.add_class::<Scene>()?;
    m.add_class::<Engine>()?;
    m.add_function(wrap_pyfunction!(rays, m)?)?;
    m.add_function(wrap_pyfunction!(read_rays, m)?)?;
    m.add_function(wrap_pyfunction!(write_rays, m)?)?;
    m.add_function(wrap_pyfunction!(read_hits, m)?)?;
    m.add_function(wrap_pyfunction!(write_hits, m)?)?;
    m.add_function(wrap_pyfunction!(render_frame, m)?)?;
    m.add_function(wrap_pyfunction!(png_bytes, m)?)?;
    m.add_function(wrap_pyfunction!(frame, m)?)?;
    m.add_function(wrap_pyfunction!(frame_csv_header, m)?)?;
    m.add_function(wrap_pyfunction!(write_atomic, m)?)?;
    m.add_function(wrap_pyfunction!(engine_names, m)?)?;
    m.add_function(wrap_pyfunction!(engine_options, m)?)?;
    m.add("DEFAULT_ENGINE", engines::DEFAULT_ENGINE.name())?;
    Ok(())
}
