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

use numpy::{IntoPyArray, PyArrayMethods, PyReadonlyArray1, PyReadonlyArray2};
use pyo3::create_exception;
use pyo3::prelude::*;
use pyo3::types::PyDict;
use rayspace::engines;
use rayspace::engines::{Backend, Config, EngineError, EngineOptions};
use std::path::PathBuf;
use trace::options::Value;
use trace::{Hit, RayBatch, RayKind, TraceMode};

mod engine;
mod image;
mod scene;
use engine::{batch, hits_dict, Engine};
use image::{check_image, frame, frame_csv_header, png_bytes, render_frame, write_atomic};
use scene::Scene;

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
    let (s, geo, _) = scene.state();
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
    let tag = scene.map(|s| {
        let (m, geo, _) = s.state();
        render::rayfile::SceneTag::of(&m.name, &geo)
    });
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
