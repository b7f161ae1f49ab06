//! The bindings' images: `render` (one frame's image and `--stats`), `frame` (a frame of
//! an animation as `render --frames` makes it, with the worker's buffers kept from one frame
//! to the next), the `--frame-csv` header, PNG bytes and atomic writes.

use crate::{err, parse_engine, Scene};
use numpy::{IntoPyArray, PyArray3, PyArrayMethods, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyDict};
use rayspace::engines;
use std::path::PathBuf;
use std::time::Instant;

/// `rayspace render`'s image and `--stats` JSON (as a string) for one frame.
#[pyfunction(name = "render")]
#[pyo3(signature = (scene, engine = None, width = 512, height = 512, bounces = 3, time = None, dynamic = false, spp = 1, viewpoint = None, **options))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn render_frame<'py>(
    py: Python<'py>,
    scene: &Scene,
    engine: Option<&str>,
    width: u32,
    height: u32,
    bounces: u32,
    time: Option<f32>,
    dynamic: bool,
    spp: u32,
    viewpoint: Option<&Bound<'py, PyAny>>,
    options: Option<&Bound<'py, PyDict>>,
) -> PyResult<(Bound<'py, PyArray3<u8>>, String)> {
    let (engine, mut cfg) = parse_engine(engine, options, dynamic)?;
    check_image(width, height, bounces)?;
    if !(1..=render::whitted::MAX_SPP).contains(&spp) {
        return Err(err(format!(
            "spp={spp}: must be 1..={}",
            render::whitted::MAX_SPP
        )));
    }
    let frame = match time {
        Some(t) => Some(scene.at_time(py, t)?),
        None => None,
    };
    let s = frame.as_ref().unwrap_or(scene);
    let left = render_memory(width, height, s.scene.lights.len())?;
    let adapted = fit(&mut cfg, engine, s.geo.len(), left)?;
    let (mut sc, geo, load_seconds) = (s.scene.clone(), s.geo.clone(), s.load_seconds);
    if let Some(v) = viewpoint {
        // As `--viewpoint`: a string "EX,EY,EZ,TX,TY,TZ[,FOV]" or 6 or 7 numbers.
        let text = match v.extract::<String>() {
            Ok(t) => t,
            Err(_) => v
                .extract::<Vec<f64>>()
                .map_err(|_| {
                    pyo3::exceptions::PyTypeError::new_err(
                        "viewpoint: expected a string EX,EY,EZ,TX,TY,TZ[,FOV] or 6 or 7 numbers",
                    )
                })?
                .iter()
                .map(|x| x.to_string())
                .collect::<Vec<_>>()
                .join(","),
        };
        let cam = scene::Camera::from_viewpoint(&text)
            .map_err(|e| err(format!("viewpoint={e}")))?;
        std::sync::Arc::make_mut(&mut sc)
            .set_camera(cam)
            .map_err(|e| err(format!("viewpoint={text}: {e}")))?;
    }
    let ropts = render::whitted::RenderOptions {
        width,
        height,
        bounces,
        spp,
    };
    let (rgb, stats) = py.detach(move || -> PyResult<(Vec<u8>, String)> {
        // What the build adds at its peak, as `render --stats` measures it (started before
        // the build's clock: it reads and writes /proc).
        let watch = trace::memory::PeakWatch::start();
        let t1 = Instant::now();
        let tracer = engines::build(engine, &cfg, &geo).map_err(err)?.tracer;
        let build_s = t1.elapsed().as_secs_f64();
        let build_peak = watch.and_then(|w| w.added());
        let mut out = render::whitted::render(&sc, &geo, tracer.as_ref(), &ropts, &());
        out.stats.put_build(build_s, tracer.build_passes());
        let rgb = render::output::to_rgb8(&out.pixels, width, height).into_raw();
        let mut v = serde_json::to_value(&out.stats).map_err(err)?;
        v["load_seconds"] = load_seconds.into();
        v["degenerate_skipped"] = sc.report.degenerate_skipped.into();
        v["raster_setup_triangles"] = out.raster.setup.into();
        v["raster_fragments"] = out.raster.fragments.into();
        // The object side CRSH/RAH ran with, the engine's configuration and what it changed
        // to fit the memory limit, as `render --stats` says them.
        if let Some(o) = cfg.object_hierarchy() {
            v["object_hierarchy"] = o.into();
        }
        v["engine_config"] =
            serde_json::to_value(engines::config::values(engine, &cfg)).map_err(err)?;
        if adapted.as_object().is_some_and(|o| !o.is_empty()) {
            v["engine_adapted"] = adapted;
        }
        // The structure's bytes, the process's peak memory and the build's, as `render
        // --stats` has them.
        if let Some(b) = tracer.structure_bytes() {
            v["structure_bytes"] = b.into();
        }
        if let Some(b) = trace::memory::peak_rss() {
            v["peak_rss_bytes"] = b.into();
        }
        if let Some(b) = build_peak {
            v["build_peak_bytes"] = b.into();
        }
        Ok((rgb, v.to_string()))
    })?;
    let img = rgb
        .into_pyarray(py)
        .reshape([height as usize, width as usize, 3])?;
    Ok((img, stats))
}

/// Frame `index` of an animated scene at time `t`, as `render --frames` makes it (the
/// engine options of a frame: the grid's single expansion pass): the PNG bytes and the
/// `--frame-csv` line.
#[pyfunction]
#[pyo3(signature = (scene, t, index, engine = None, width = 512, height = 512, bounces = 3, **options))]
#[allow(clippy::too_many_arguments)]
pub(crate) fn frame<'py>(
    py: Python<'py>,
    scene: &Scene,
    t: f32,
    index: u32,
    engine: Option<&str>,
    width: u32,
    height: u32,
    bounces: u32,
    options: Option<&Bound<'py, PyDict>>,
) -> PyResult<(Bound<'py, PyBytes>, String)> {
    let (engine, mut cfg) = parse_engine(engine, options, true)?;
    check_image(width, height, bounces)?;
    if !t.is_finite() {
        return Err(err(format!("t={t}: not a finite time")));
    }
    if scene.scene.animation.is_none() {
        return Err(err(format!(
            "frames: {} is not animated (BART .aff files and TOML scenes with keyframes are)",
            scene.scene.name
        )));
    }
    let left = render_memory(width, height, scene.scene.lights.len())?;
    fit(&mut cfg, engine, scene.geo.len(), left)?;
    let sc = scene.scene.clone();
    let ropts = render::whitted::RenderOptions {
        width,
        height,
        bounces,
        spp: 1,
    };
    let (png, line) = py.detach(move || -> PyResult<(Vec<u8>, String)> {
        // A worker renders its frames one after another on its thread: the geometry's and
        // the renderer's buffers are kept from one frame to the next, as `--frames` keeps
        // them.
        let (out, row) = FRAME_BUFFERS
            .with(|b| {
                let mut b = b.borrow_mut();
                rayspace::frames::frame_with(&mut b, &sc, t, index, engine, &cfg, &ropts)
            })
            .map_err(err)?;
        let png = render::output::png_bytes(&out.pixels, width, height).map_err(err)?;
        Ok((png, row.csv_line()))
    })?;
    Ok((PyBytes::new(py, &png), line))
}

thread_local! {
    /// The buffers of the frames rendered on this thread ([`rayspace::frames::FrameBuffers`]).
    static FRAME_BUFFERS: std::cell::RefCell<rayspace::frames::FrameBuffers> =
        std::cell::RefCell::new(Default::default());
}

/// The `--frame-csv` header line.
#[pyfunction]
pub(crate) fn frame_csv_header() -> String {
    rayspace::frames::FrameRow::csv_header()
}

/// `--width`, `--height` and `--bounces` checked as the command line checks them.
pub(crate) fn check_image(width: u32, height: u32, bounces: u32) -> PyResult<()> {
    let max = render::whitted::MAX_SIDE;
    for (opt, v) in [("width", width), ("height", height)] {
        if !(1..=max).contains(&v) {
            return Err(err(format!("{opt}={v}: expected 1..={max}")));
        }
    }
    if bounces > render::whitted::MAX_BOUNCES {
        return Err(err(format!(
            "bounces={bounces}: expected 0..={}",
            render::whitted::MAX_BOUNCES
        )));
    }
    Ok(())
}

/// The memory a render needs, checked against the limit; returns what it and the process's
/// present memory leave for the engine's structure (its model is checked against it).
fn render_memory(width: u32, height: u32, lights: usize) -> PyResult<u64> {
    let need = render::whitted::render_bytes(width, height, lights);
    let limit = trace::memory::limit(None);
    if need > limit {
        return Err(err(format!(
            "width/height: the render needs {}, more than the {} limit",
            trace::memory::gib(need),
            trace::memory::gib(limit)
        )));
    }
    // What the process holds now (the interpreter, the scene) is not the engine's either.
    let held = trace::memory::current_rss().unwrap_or(0);
    Ok(limit.saturating_sub(need + held))
}

/// `cfg` of `engine` over `triangles` fitted to the `bytes` the render leaves, as `render`
/// fits it (the build's model must fit; the grid's build checks its own against them; CRSH
/// and RAH lower their pair budget): what it changed, as `--stats`'s `engine_adapted`
/// object.
fn fit(
    cfg: &mut engines::Config,
    engine: engines::Engine,
    triangles: usize,
    bytes: u64,
) -> PyResult<serde_json::Value> {
    let changes = cfg
        .fit_memory(engine, triangles as u64, bytes)
        .map_err(err)?;
    let mut out = serde_json::Map::new();
    for (name, asked, used) in changes {
        out.insert(
            name.replace('_', "-"),
            serde_json::json!({ "asked": asked, "used": used }),
        );
    }
    Ok(serde_json::Value::Object(out))
}

/// PNG bytes of an H×W×3 uint8 image, encoded as the command line encodes its images.
#[pyfunction]
pub(crate) fn png_bytes<'py>(
    py: Python<'py>,
    image: numpy::PyReadonlyArray3<'py, u8>,
) -> PyResult<Bound<'py, PyBytes>> {
    let sh = image.shape();
    if sh[2] != 3 {
        return Err(err(format!("image: expected shape (H, W, 3), got {sh:?}")));
    }
    let rgb = image
        .as_slice()
        .map_err(|_| err("image: expected a C-contiguous array"))?;
    let (h, w) = (
        u32::try_from(sh[0]).map_err(err)?,
        u32::try_from(sh[1]).map_err(err)?,
    );
    let bytes = render::output::rgb8_png(rgb, w, h).map_err(err)?;
    Ok(PyBytes::new(py, &bytes))
}

/// Write bytes to `path` atomically (temp file + rename), as every rayspace output.
#[pyfunction]
pub(crate) fn write_atomic(path: PathBuf, data: &[u8]) -> PyResult<()> {
    render::output::check_output(&path).map_err(|e| err(format!("path: {e}")))?;
    render::output::write_atomic(&path, data).map_err(err)
}
