//! The front door for programs that bring their own geometry: triangles from arrays
//! ([`scene::SceneBuilder`], [`Scene::from_arrays`]), an engine by name with its options,
//! batches of rays traced, hit points and normals, updates between frames and rebuilds, and a
//! frame rendered ([`crate::runner::Runner`]). Everything here is what the command line and
//! the Python bindings run, so a result is theirs too.
//!
//! ```
//! use rayspace::{Engine, Ray, Scene, SceneEngine, TraceMode};
//! // Two triangles (a unit square in z = 0), from arrays.
//! let vertices = [[0.0, 0.0, 0.0], [1.0, 0.0, 0.0], [0.0, 1.0, 0.0], [1.0, 1.0, 0.0]];
//! let faces = [[0, 1, 2], [1, 3, 2]];
//! let mut scene = Scene::from_arrays(&vertices, &faces).unwrap();
//! let mut engine = SceneEngine::new(&scene, Engine::Bvh, &[]).unwrap();
//! let down = |x, y| Ray::new([x, y, 1.0].into(), [0.0, 0.0, -1.0].into(), 0.0, f32::INFINITY);
//! let hits = engine.trace(&scene, &[down(0.2, 0.2), down(0.8, 0.9), down(2.0, 2.0)], TraceMode::Closest).unwrap();
//! assert_eq!(hits.iter().map(|h| h.tri).collect::<Vec<_>>(), [0, 1, u32::MAX]);
//! // The square moves; an engine built before must be rebuilt to trace it.
//! let moved: Vec<[f32; 3]> = vertices.iter().map(|p| [p[0], p[1], -1.0]).collect();
//! scene.set_vertices(0, &moved).unwrap();
//! assert!(engine.trace(&scene, &[down(0.2, 0.2)], TraceMode::Closest).is_err());
//! engine.rebuild(&scene).unwrap();
//! assert_eq!(engine.trace(&scene, &[down(0.2, 0.2)], TraceMode::Closest).unwrap()[0].t, 2.0);
//! ```

use crate::engines::{self, config, Backend, Config, Engine, EngineError, EngineOptions};
use geom::{Ray, Vec3};
use scene::{Geometry, Scene};
use std::sync::Arc;
use trace::options::Value;
use trace::{BatchError, Hit, RayBatch, RayKind, TraceMode, TraceStats, Tracer};

/// Why a batch was not traced.
#[derive(Debug, thiserror::Error)]
pub enum TraceError {
    /// The scene changed (its vertices or transforms) since the engine was built.
    #[error("the scene changed since this engine was built: rebuild the engine first")]
    Stale,
    /// A ray that no engine takes (a NaN origin, a zero direction, bounds out of order).
    #[error(transparent)]
    Rays(#[from] BatchError),
    /// The batch and its hits would need more memory than the limit leaves.
    #[error("{rays} rays need {}, more than the {} memory limit: trace them in parts", trace::memory::gib(*need), trace::memory::gib(*limit))]
    Memory {
        /// The rays.
        rays: usize,
        /// The bytes they need.
        need: u64,
        /// The limit.
        limit: u64,
    },
}

/// An engine built over one state of a scene: its triangles as they were at the build
/// (kept, for hit points and normals), the engine's structure, and which scene state it
/// was built for, so that tracing a scene that changed since is an error, never stale hits.
pub struct SceneEngine {
    engine: Engine,
    /// The configuration asked for, and the one built (fitted to the memory limit).
    asked: Config,
    cfg: Config,
    geo: Arc<Geometry>,
    tracer: Box<dyn Tracer + Send>,
    report: Option<String>,
    /// The scene state built for ([`scene::SceneId`]: every change makes a new one); None
    /// after a rebuild that failed.
    built_for: Option<u64>,
    /// Options lowered to fit the memory limit: (keyword, asked, used).
    adapted: Vec<(&'static str, Value, Value)>,
    build_seconds: f64,
}

impl SceneEngine {
    /// Build `engine` over `scene` with `options` (keyword and value, as
    /// [`engines::config::options`] declares them; none: the engine's defaults), within the
    /// process's memory limit ([`trace::memory::limit`]; options with a memory budget are
    /// lowered to fit, [`SceneEngine::adapted`] says which).
    pub fn new(
        scene: &Scene,
        engine: Engine,
        options: &[(&str, Value)],
    ) -> Result<SceneEngine, EngineError> {
        let given = options
            .iter()
            .map(|(k, v)| (k.to_string(), v.clone()))
            .collect();
        let cfg = config::config(engine, Backend::Cpu, &EngineOptions::new(given, false))?;
        SceneEngine::with_config(scene, engine, cfg)
    }

    /// Build `engine` over `scene` with the configuration `cfg` (see [`SceneEngine::new`]).
    pub fn with_config(
        scene: &Scene,
        engine: Engine,
        cfg: Config,
    ) -> Result<SceneEngine, EngineError> {
        SceneEngine::over(scene, Arc::new(Geometry::from_scene(scene)), engine, cfg)
    }

    /// [`SceneEngine::with_config`] over `geo`, the scene's geometry as already made
    /// ([`Geometry::from_scene`] of `scene` as it is now: a binding that keeps both shares
    /// it rather than making it again).
    pub fn over(
        scene: &Scene,
        geo: Arc<Geometry>,
        engine: Engine,
        mut cfg: Config,
    ) -> Result<SceneEngine, EngineError> {
        debug_assert_eq!(geo.len(), scene.triangle_count(), "the scene's geometry");
        cfg.validate(engine)?;
        let asked = cfg.clone();
        let limit = trace::memory::limit(None);
        let held = trace::memory::current_rss().unwrap_or(0);
        let adapted = cfg.fit_memory(engine, geo.len() as u64, limit.saturating_sub(held))?;
        let t0 = std::time::Instant::now();
        let b = engines::build(engine, &cfg, &geo)?;
        Ok(SceneEngine {
            engine,
            asked,
            cfg,
            geo,
            tracer: b.tracer,
            report: b.report,
            built_for: Some(scene.id.get()),
            adapted,
            build_seconds: t0.elapsed().as_secs_f64(),
        })
    }

    /// Bring the engine to `scene`'s current state: its triangles taken again and the
    /// structure built again (every engine of this library builds per frame: its build
    /// is the thesis's and the grid paper's per-frame step).
    pub fn rebuild(&mut self, scene: &Scene) -> Result<(), EngineError> {
        self.rebuild_over(scene, Arc::new(Geometry::from_scene(scene)))
    }

    /// [`SceneEngine::rebuild`] over `geo`, the scene's geometry as already made (see
    /// [`SceneEngine::over`]).
    pub fn rebuild_over(&mut self, scene: &Scene, geo: Arc<Geometry>) -> Result<(), EngineError> {
        // The last structure is freed before the next is built (the memory limit holds
        // one); until the build succeeds the engine traces nothing.
        self.built_for = None;
        self.tracer = Box::new(accel::BruteForce::new(&Geometry::default()));
        *self = SceneEngine::over(scene, geo, self.engine, self.asked.clone())?;
        Ok(())
    }

    /// Whether the engine was built for `scene` as it is now.
    pub fn is_current(&self, scene: &Scene) -> bool {
        self.built_for == Some(scene.id.get())
    }

    /// The nearest hit (or, with [`TraceMode::Any`], any hit) of each ray, in order; a miss
    /// is [`Hit::MISS`] (triangle `u32::MAX`). Triangles are numbered as the scene's
    /// (a scene from arrays: the faces' rows).
    pub fn trace(
        &self,
        scene: &Scene,
        rays: &[Ray],
        mode: TraceMode,
    ) -> Result<Vec<Hit>, TraceError> {
        let need = rays.len() as u64
            * (render::whitted::BYTES_PER_RAY + std::mem::size_of::<Hit>() as u64);
        let limit = trace::memory::limit(None);
        if need > limit {
            return Err(TraceError::Memory {
                rays: rays.len(),
                need,
                limit,
            });
        }
        let batch = RayBatch::from_rays(rays, RayKind::Primary);
        let mut hits = vec![Hit::MISS; rays.len()];
        self.trace_batch(scene, &batch, mode, &mut hits, &mut TraceStats::default())?;
        Ok(hits)
    }

    /// [`SceneEngine::trace`] of a batch into `hits` (as long as the batch), adding the
    /// engine's counters and phase times to `stats`.
    pub fn trace_batch(
        &self,
        scene: &Scene,
        rays: &RayBatch,
        mode: TraceMode,
        hits: &mut [Hit],
        stats: &mut TraceStats,
    ) -> Result<(), TraceError> {
        if !self.is_current(scene) {
            return Err(TraceError::Stale);
        }
        rays.validate()?;
        assert_eq!(hits.len(), rays.len(), "one hit record per ray");
        self.tracer.trace(rays, mode, hits, stats);
        Ok(())
    }

    /// The world-space point of a hit (None for a miss).
    pub fn point(&self, hit: &Hit) -> Option<Vec3> {
        hit.is_hit().then(|| self.geo.point(hit.tri, hit.u, hit.v))
    }

    /// The interpolated unit shading normal at a hit (None for a miss).
    pub fn normal(&self, hit: &Hit) -> Option<Vec3> {
        hit.is_hit()
            .then(|| self.geo.shading_normal(hit.tri, hit.u, hit.v))
    }

    /// The unit geometric normal of the triangle hit (None for a miss).
    pub fn geometric_normal(&self, hit: &Hit) -> Option<Vec3> {
        hit.is_hit().then(|| self.geo.geometric_normal(hit.tri))
    }

    /// The engine.
    pub fn engine(&self) -> Engine {
        self.engine
    }

    /// Its configuration (every option's value: [`engines::config::values`]).
    pub fn config(&self) -> &Config {
        &self.cfg
    }

    /// The triangles it was built over.
    pub fn geometry(&self) -> &Geometry {
        &self.geo
    }

    /// The built engine, for the [`Tracer`] interface (statistics, build passes).
    pub fn tracer(&self) -> &(dyn Tracer + Send) {
        self.tracer.as_ref()
    }

    /// What was built, in one line, where the engine says (the grids).
    pub fn report(&self) -> Option<&str> {
        self.report.as_deref()
    }

    /// Options lowered to fit the memory limit: (keyword, asked, used).
    pub fn adapted(&self) -> &[(&'static str, Value, Value)] {
        &self.adapted
    }

    /// Seconds the last build took.
    pub fn build_seconds(&self) -> f64 {
        self.build_seconds
    }
}
