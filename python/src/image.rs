//! The bindings' images: `render` (one frame's image and `--stats`), `frame` (a frame of
//! an animation as `render --frames` makes it, with the worker's buffers kept from one frame
//! to the next), the `--frame-csv` header, PNG bytes and atomic writes.

use crate::{err, parse_engine, Scene};
use numpy::{IntoPyArray, PyArray3, PyArrayMethods, PyUntypedArrayMethods};
use pyo3::prelude::*;
use pyo3::types::{PyBytes, PyDict};
use rayspace::engines;
use rayspace::runner::Runner;
use std::path::PathBuf;

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
    let (engine, cfg) = parse_engine(engine, options, dynamic)?;
    check_image(width, height, bounces)?;
    if !(1..=render::whitted::MAX_SPP).contains(&spp) {
        return Err(err(format!(
            "spp={spp}: must be 1..={}",
            render::whitted::MAX_SPP
        )));
    }
    if let Some(t) = time {
        if !t.is_finite() {
            return Err(err(format!("time={t}: not a finite time")));
        }
        if scene.model().animation.is_none() {
            return Err(err(format!(
                "time={t}: {} is not animated",
                scene.model().name
            )));
        }
    }
    let (mut sc, geo, load_seconds) = scene.state();
    let ropts = render::whitted::RenderOptions {
        width,
        height,
        bounces,
        spp,
    };
    let left = rayspace::runner::memory_left(trace::memory::limit(None), &ropts, sc.lights.len())
        .map_err(err)?;
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
        let cam =
            scene::Camera::from_viewpoint(&text).map_err(|e| err(format!("viewpoint={e}")))?;
        std::sync::Arc::make_mut(&mut sc)
            .set_camera(cam)
            .map_err(|e| err(format!("viewpoint={text}: {e}")))?;
    }
    let (rgb, stats) = py.detach(move || -> PyResult<(Vec<u8>, String)> {
        // The frame as `render` makes it: the runner fits the engine to the memory limit,
        // builds it (measuring what the build adds at its peak) and renders.
        let mut runner = Runner::new(engine, cfg, engines::Backend::Cpu)
            .watch_build_memory(true)
            .with_geometry((*geo).clone());
        let adapted = adapted_json(runner.fit_memory(geo.len() as u64, left).map_err(err)?);
        let cfg = runner.config().clone();
        drop(geo);
        let f = runner.frame(&sc, time, 0, &ropts, &()).map_err(err)?;
        let out = &f.rendered;
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
        if let Some(b) = f.structure_bytes {
            v["structure_bytes"] = b.into();
        }
        if let Some(b) = trace::memory::peak_rss() {
            v["peak_rss_bytes"] = b.into();
        }
        if let Some(b) = f.build_peak {
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
    let (engine, cfg) = parse_engine(engine, options, true)?;
    check_image(width, height, bounces)?;
    if !t.is_finite() {
        return Err(err(format!("t={t}: not a finite time")));
    }
    let (sc, geo, _) = scene.state();
    if sc.animation.is_none() {
        return Err(err(format!(
            "frames: {} is not animated (BART .aff files and TOML scenes with keyframes are)",
            sc.name
        )));
    }
    let ropts = render::whitted::RenderOptions {
        width,
        height,
        bounces,
        spp: 1,
    };
    let left = rayspace::runner::memory_left(trace::memory::limit(None), &ropts, sc.lights.len())
        .map_err(err)?;
    let triangles = geo.len() as u64;
    drop(geo);
    let (png, line) = py.detach(move || -> PyResult<(Vec<u8>, String)> {
        // A worker renders its frames one after another on its thread: its runner keeps
        // the geometry's and the renderer's buffers from one frame to the next, as
        // `--frames` keeps them.
        let f = RUNNER
            .with(|r| -> Result<rayspace::Frame, rayspace::FrameError> {
                let mut r = r.borrow_mut();
                let same = r
                    .as_ref()
                    .is_some_and(|r| r.engine() == engine && r.asked() == &cfg);
                if !same {
                    *r = Some(Runner::new(engine, cfg.clone(), engines::Backend::Cpu));
                }
                let r = r.as_mut().expect("made above");
                r.fit_memory(triangles, left)?;
                r.frame(&sc, Some(t), index, &ropts, &())
            })
            .map_err(err)?;
        let png = render::output::png_bytes(&f.rendered.pixels, width, height).map_err(err)?;
        Ok((png, f.row.csv_line()))
    })?;
    Ok((PyBytes::new(py, &png), line))
}

thread_local! {
    /// The runner of the frames rendered on this thread (the last engine and options asked
    /// for), with its buffers.
    static RUNNER: std::cell::RefCell<Option<Runner>> = const { std::cell::RefCell::new(None) };
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

/// What the runner lowered to fit the memory limit, as `--stats`'s `engine_adapted`
/// object (option → {"asked", "used"}).
fn adapted_json(changes: &[rayspace::runner::Adapted]) -> serde_json::Value {
    let mut out = serde_json::Map::new();
    for (name, asked, used) in changes {
        out.insert(
            name.replace('_', "-"),
            serde_json::json!({ "asked": asked, "used": used }),
        );
    }
    serde_json::Value::Object(out)
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
