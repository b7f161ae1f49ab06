//! `rayspace.Engine`: an engine built over a scene as it was at the build
//! (`rayspace::SceneEngine`, the library's front door: the memory limit fitted, the build,
//! batches traced), rebuilt on request after the scene changes; traced after a change
//! without a rebuild, it raises instead of answering for the old triangles.

use crate::scene::Scene;
use crate::{err, parse_engine};
use numpy::{
    IntoPyArray, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2, PyUntypedArrayMethods,
};
use pyo3::prelude::*;
use pyo3::types::PyDict;
use rayspace::{SceneEngine, TraceError};
use std::sync::{Mutex, RwLock};
use trace::{Hit, RayBatch, RayKind, TraceMode, TraceStats};

/// An engine built over a scene.
#[pyclass(module = "rayspace._rayspace", frozen)]
pub(crate) struct Engine {
    scene: Py<Scene>,
    /// Traces share it, a rebuild replaces it. It is locked only while the GIL is released
    /// and nothing inside needs the GIL, so a thread waiting for it never holds the GIL
    /// that its holder needs.
    inner: RwLock<SceneEngine>,
    last: Mutex<TraceStats>,
}

impl Engine {
    /// `f` of the engine, the GIL released while it waits for the engine and runs.
    fn with<R: Send>(&self, py: Python<'_>, f: impl FnOnce(&SceneEngine) -> R + Send) -> R {
        py.detach(|| f(&self.inner.read().unwrap_or_else(|p| p.into_inner())))
    }
}

/// What an engine traced after its scene changed says.
const STALE: &str =
    "the scene changed since this engine was built (Scene.update): call engine.rebuild() first";

#[pymethods]
impl Engine {
    #[new]
    #[pyo3(signature = (scene, name, **options))]
    fn new(
        py: Python<'_>,
        scene: Bound<'_, Scene>,
        name: &str,
        options: Option<&Bound<'_, PyDict>>,
    ) -> PyResult<Engine> {
        let (engine, cfg) = parse_engine(Some(name), options, false)?;
        let st = scene.get().now();
        let e = py
            .detach(move || SceneEngine::over(&st.scene, st.geo, engine, cfg))
            .map_err(err)?;
        Ok(Engine {
            scene: scene.unbind(),
            inner: RwLock::new(e),
            last: Mutex::new(TraceStats::default()),
        })
    }

    /// Bring the engine to its scene's current state (after `Scene.update`): the engine
    /// built again over the scene's triangles as they are now (every engine here builds
    /// per frame; none refits).
    fn rebuild(&self, py: Python<'_>) -> PyResult<()> {
        let st = self.scene.get().now();
        py.detach(|| {
            self.inner
                .write()
                .unwrap_or_else(|p| p.into_inner())
                .rebuild_over(&st.scene, st.geo)
        })
        .map_err(err)
    }

    /// Whether the engine was built for its scene as it is now.
    #[getter]
    fn current(&self, py: Python<'_>) -> bool {
        let s = self.scene.get().model();
        self.with(py, |e| e.is_current(&s))
    }

    #[getter]
    fn name(&self, py: Python<'_>) -> String {
        self.with(py, |e| e.tracer().name().to_string())
    }

    #[getter]
    fn build_seconds(&self, py: Python<'_>) -> f64 {
        self.with(py, |e| e.build_seconds())
    }

    #[getter]
    fn build_report(&self, py: Python<'_>) -> Option<String> {
        self.with(py, |e| e.report().map(String::from))
    }

    #[getter]
    fn build_passes(&self, py: Python<'_>) -> Vec<(String, f64)> {
        self.with(py, |e| {
            e.tracer()
                .build_passes()
                .iter()
                .map(|p| (p.name(), p.seconds))
                .collect()
        })
    }

    #[pyo3(signature = (origins, directions, tmin = None, tmax = None, any_hit = false, points = false, normals = false))]
    #[allow(clippy::too_many_arguments)]
    fn trace<'py>(
        &self,
        py: Python<'py>,
        origins: PyReadonlyArray2<'py, f32>,
        directions: PyReadonlyArray2<'py, f32>,
        tmin: Option<PyReadonlyArray1<'py, f32>>,
        tmax: Option<PyReadonlyArray1<'py, f32>>,
        any_hit: bool,
        points: bool,
        normals: bool,
    ) -> PyResult<Bound<'py, PyDict>> {
        let rays = batch(&origins, &directions, tmin.as_ref(), tmax.as_ref())?;
        let mode = if any_hit {
            TraceMode::Any
        } else {
            TraceMode::Closest
        };
        let scene = self.scene.get().model();
        type Traced = (Vec<Hit>, TraceStats, Option<Vec<f32>>, Option<Vec<f32>>);
        let (hits, st, pts, nrm) = self
            .with(py, |engine| -> Result<Traced, TraceError> {
                let mut hits = vec![Hit::MISS; rays.len()];
                let mut st = TraceStats::default();
                engine.trace_batch(&scene, &rays, mode, &mut hits, &mut st)?;
                // World-space hit points and unit shading normals (NaN for a miss), on
                // request, from the triangles the engine was built over.
                let vec3s = |f: &dyn Fn(&Hit) -> Option<geom::Vec3>| -> Vec<f32> {
                    hits.iter()
                        .flat_map(|h| f(h).map_or([f32::NAN; 3], |p| p.to_array()))
                        .collect()
                };
                let pts = points.then(|| vec3s(&|h| engine.point(h)));
                let nrm = normals.then(|| vec3s(&|h| engine.normal(h)));
                Ok((hits, st, pts, nrm))
            })
            .map_err(|e| match e {
                TraceError::Stale => err(STALE),
                e => err(e),
            })?;
        *self.last.lock().unwrap_or_else(|p| p.into_inner()) = st;
        let d = hits_dict(py, &hits)?;
        for (key, v) in [("point", pts), ("normal", nrm)] {
            if let Some(v) = v {
                d.set_item(key, v.into_pyarray(py).reshape([hits.len(), 3])?)?;
            }
        }
        Ok(d)
    }

    /// The counters of the last `trace` (the command line's `--stats` "trace" object).
    fn counters<'py>(&self, py: Python<'py>) -> PyResult<Bound<'py, PyAny>> {
        let st = self.last.lock().unwrap_or_else(|p| p.into_inner()).clone();
        let mut v = serde_json::to_value(&st).map_err(err)?;
        v["total_tests"] = st.total_tests().into();
        json_to_py(py, &v)
    }

    fn __repr__(&self, py: Python<'_>) -> String {
        format!("Engine('{}')", self.name(py))
    }
}

/// A JSON value as the Python object `json.loads` makes of it.
pub(crate) fn json_to_py<'py>(
    py: Python<'py>,
    v: &serde_json::Value,
) -> PyResult<Bound<'py, PyAny>> {
    py.import("json")?.call_method1("loads", (v.to_string(),))
}

/// Rays from (N, 3) origin and direction arrays and optional (N,) bounds (default 0 and ∞),
/// checked as every engine requires ([`RayBatch::validate`]: the message names the ray).
pub(crate) fn batch(
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
pub(crate) fn hits_dict<'py>(py: Python<'py>, hits: &[Hit]) -> PyResult<Bound<'py, PyDict>> {
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
