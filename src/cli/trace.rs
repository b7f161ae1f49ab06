//! `rayspace rays` and `rayspace trace`: ray files out of a scene, and one engine over a ray
//! file (hits, MRays/s and the engine's counters). The file format is
//! `render::rayfile`'s; hagrid's headerless ray files are read too.

use super::args::{Backend, RaysArgs, TraceArgs};
use super::{check, check_memory, check_outputs, UsageError};
use anyhow::{bail, Result};
use rayspace::engines;
use render::rayfile::RayFormat;
use scene::Geometry;
use serde::Serialize;
use std::time::Instant;

pub fn cmd_rays(a: &RaysArgs) -> Result<()> {
    let outputs = [("--out", a.out.as_path())];
    check::writable("--out", &a.out)?;
    check_outputs(&outputs, &[std::path::Path::new(&a.scene)])?;
    let mut scene = super::load_scene(&a.scene, &a.load.options(a.max_memory))?;
    let read: Vec<&std::path::Path> = scene.report.files.iter().map(|f| f.as_path()).collect();
    check_outputs(&outputs, &read)?;
    if let Some(v) = &a.viewpoint {
        super::set_viewpoint(&mut scene, v)?;
    }
    if let Some(d) = a.ao_distance {
        if !(d.is_finite() && d > 0.0) {
            bail!("--ao-distance {d}: must be positive and finite");
        }
    }
    let geo = Geometry::from_scene(&scene);
    use render::raygen::{generate, Options};
    let kind = a.kind;
    let n = a.width as u64 * a.height as u64 * a.spp as u64;
    if n > 1 << 28 {
        bail!("--width × --height × --spp = {n} rays is more than 2^28");
    }
    // The rays, their file image (32 bytes each) and, for the kinds made from rasterized
    // surfaces, a render's worth of G-buffer and surfaces.
    let rasterized = !matches!(kind, render::raygen::Kind::Random);
    let need = n * (render::whitted::BYTES_PER_RAY + 32)
        + if rasterized {
            a.width as u64 * a.height as u64 * render::whitted::BYTES_PER_PIXEL
        } else {
            0
        };
    check_memory("the rays", "--width/--height/--spp", need, a.max_memory)?;
    let rays = generate(
        &scene,
        &geo,
        kind,
        &Options {
            width: a.width,
            height: a.height,
            spp: a.spp,
            seed: a.seed,
            ao_distance: a.ao_distance,
        },
    );
    let tag = render::rayfile::SceneTag::of(&scene.name, &geo);
    render::rayfile::write_rays_for(&a.out, &rays, Some(&tag)).map_err(anyhow::Error::msg)?;
    say!(
        "wrote {} {} rays of {} to {}",
        rays.len(),
        clap::ValueEnum::to_possible_value(&a.kind)
            .map_or_else(String::new, |v| v.get_name().to_string()),
        scene.name,
        a.out.display()
    );
    Ok(())
}

pub fn cmd_trace(a: &TraceArgs) -> Result<()> {
    // The engine's options against its declarations, as `render` checks them.
    let mut cfg = check::engine_config(a.engine, Backend::Cpu, &a.options, false)?;
    let outputs: Vec<(&str, &std::path::Path)> =
        [("--out", a.out.as_ref()), ("--json", a.json.as_ref())]
            .into_iter()
            .filter_map(|(o, p)| Some((o, p?.as_path())))
            .collect();
    for &(opt, p) in &outputs {
        check::make_parent(opt, p).map_err(|e| UsageError(format!("{e:#}")))?;
        check::writable(opt, p)?;
    }
    check_outputs(&outputs, &[&a.rays, std::path::Path::new(&a.scene)])?;
    let file = render::rayfile::read_ray_file(&a.rays, trace::RayKind::Primary, a.format)
        .map_err(anyhow::Error::msg)?;
    if file.format == RayFormat::Hagrid && a.format.is_none() {
        eprintln!(
            "notice: {} has no rayspace header: read as hagrid's headerless rays ({} rays of 6 × f32); --format rayspace refuses such a file",
            a.rays.display(),
            file.rays.len()
        );
    }
    let rays = file.rays;
    // The process's memory model: what it holds now (the rays and their hits), and per
    // triangle the scene and the engine's build; a scene too large stops while it loads.
    let limit = super::memory_limit(a.max_memory);
    let hits_bytes = rays.len() as u64 * std::mem::size_of::<trace::Hit>() as u64;
    let held = trace::memory::current_rss().unwrap_or(0) + hits_bytes;
    super::check_held(held, a.max_memory)?;
    let per_triangle = engines::config::build_bytes_per_triangle(a.engine, &cfg);
    let load = a.load.within(limit.saturating_sub(held), per_triangle);
    let scene = super::load_scene(&a.scene, &load)?;
    let read: Vec<&std::path::Path> = scene.report.files.iter().map(|f| f.as_path()).collect();
    check_outputs(&outputs, &read)?;
    let geo = Geometry::from_scene(&scene);
    let held = trace::memory::current_rss().unwrap_or(held) + hits_bytes;
    for (name, asked, used) in
        cfg.fit_memory(a.engine, geo.len() as u64, limit.saturating_sub(held))?
    {
        say!(
            "{} lowered from {asked} to {used} to fit --max-memory",
            super::args::EngineFlags::flag(name)
        );
    }
    if let Some(tag) = &file.scene {
        let here = render::rayfile::SceneTag::of(&scene.name, &geo);
        if tag.hash != 0 && tag.hash != here.hash {
            eprintln!(
                "warning: {} was made for scene '{}' (content hash {:016x}), not for {} ('{}', {:016x}): the rays may not mean what they did",
                a.rays.display(),
                super::printable(&tag.name),
                tag.hash,
                a.scene,
                here.name,
                here.hash
            );
        }
    }
    let mode = if a.any_hit {
        trace::TraceMode::Any
    } else {
        trace::TraceMode::Closest
    };
    // Every repetition builds the engine and traces the rays afresh; the hits and counters
    // are the same each time (deterministic), the last repetition's are kept.
    let mut runs: Vec<(f64, f64)> = Vec::with_capacity(a.repeat as usize);
    // Per run: the engine's build passes and the trace's phases (seconds), by name.
    let mut phase_runs: Vec<Vec<(String, f64)>> = Vec::with_capacity(a.repeat as usize);
    let mut hits = vec![trace::Hit::MISS; rays.len()];
    let mut st = trace::TraceStats::default();
    let mut name = String::new();
    for rep in 0..a.repeat {
        let t0 = Instant::now();
        let built = engines::build(a.engine, &cfg, &geo)?;
        if rep == 0 {
            if let Some(r) = &built.report {
                say!("{r}");
            }
        }
        let engine = built.tracer;
        let build = t0.elapsed().as_secs_f64();
        st = trace::TraceStats::default();
        let t1 = Instant::now();
        engine.trace(&rays, mode, &mut hits, &mut st);
        runs.push((build, t1.elapsed().as_secs_f64()));
        phase_runs.push(
            engine
                .build_passes()
                .into_iter()
                .map(|p| (format!("build: {}", p.name()), p.seconds))
                .chain(st.phases.iter().map(|(p, s)| (p.to_string(), *s)))
                .collect(),
        );
        name = engine.name().to_string();
    }
    let (build, secs) = (
        median(runs.iter().map(|r| r.0)),
        median(runs.iter().map(|r| r.1)),
    );
    let n = rays.len().max(1) as f64;
    say!(
        "{} rays, {} triangles, engine {} ({}): build {:.1} ms, trace {:.1} ms, {:.3} MRays/s{}",
        rays.len(),
        geo.len(),
        name,
        match mode {
            trace::TraceMode::Any => "any hit",
            trace::TraceMode::Closest => "closest hit",
        },
        build * 1e3,
        secs * 1e3,
        n / secs.max(1e-12) / 1e6,
        if runs.len() > 1 {
            format!(" (medians of {} runs)", runs.len())
        } else {
            String::new()
        }
    );
    let config = engines::config::values(a.engine, &cfg);
    if !config.is_empty() {
        let words: Vec<String> = config.iter().map(|(k, v)| format!("--{k} {v}")).collect();
        say!("engine configuration: {}", words.join(" "));
    }
    if runs.len() > 1 {
        let list = runs
            .iter()
            .map(|(b, t)| format!("{:.1}+{:.1}", b * 1e3, t * 1e3))
            .collect::<Vec<_>>()
            .join(", ");
        say!("runs (build+trace ms): {list}");
    }
    if let Some(first) = phase_runs.first().filter(|p| !p.is_empty()) {
        // Each phase (in the first run's order) with its median over the runs that have it.
        let list = first
            .iter()
            .map(|(p, _)| {
                let each = phase_runs
                    .iter()
                    .filter_map(|r| r.iter().find(|x| &x.0 == p).map(|x| x.1));
                format!("{p} {:.1}", median(each) * 1e3)
            })
            .collect::<Vec<_>>()
            .join(", ");
        say!(
            "phases (ms{}): {list}",
            if runs.len() > 1 { ", medians" } else { "" }
        );
    }
    say!("hits {}, ray-triangle tests {} ({:.2}/ray), node-triangle tests {}, total tests {} ({:.4} % of brute force)", st.hits, st.ray_tri_tests, st.ray_tri_tests as f64 / n, st.node_tri_tests, st.total_tests(), 100.0 * st.total_tests() as f64 / (n * geo.len() as f64));
    say!(
        "ray-triangle tests as % of brute force: {:.4} % (every engine's exact tests against rays × triangles)",
        st.percent_of_brute_force(geo.len() as u64)
    );
    for (k, v) in st.counters.iter() {
        say!(
            "  {k}: {v}{}",
            if k == accel::grid::TRAVERSAL_STEPS {
                format!(" ({:.2}/ray)", v as f64 / n)
            } else {
                String::new()
            }
        );
    }
    if let Some(o) = &a.out {
        render::rayfile::write_hits(o, &hits, mode).map_err(anyhow::Error::msg)?;
        say!("wrote {}", o.display());
    }
    if let Some(j) = &a.json {
        let phases = phase_runs.first().map_or_else(Vec::new, |first| {
            first
                .iter()
                .map(|(p, _)| {
                    let each = phase_runs
                        .iter()
                        .filter_map(|r| r.iter().find(|x| &x.0 == p).map(|x| x.1));
                    (p.clone(), median(each))
                })
                .collect()
        });
        let summary = TraceSummary {
            rays: rays.len() as u64,
            triangles: geo.len() as u64,
            engine: name,
            engine_config: config,
            mode: match mode {
                trace::TraceMode::Any => "any hit",
                trace::TraceMode::Closest => "closest hit",
            },
            build_seconds: build,
            trace_seconds: secs,
            mrays_per_second: n / secs.max(1e-12) / 1e6,
            runs: runs.clone(),
            phases,
            hits: st.hits,
            ray_tri_tests: st.ray_tri_tests,
            node_tri_tests: st.node_tri_tests,
            total_tests: st.total_tests(),
            brute_force_tests: rays.len() as u64 * geo.len() as u64,
            counters: st
                .counters
                .iter()
                .map(|(k, v)| (k.to_string(), v))
                .collect(),
        };
        super::write_out("--json", j, serde_json::to_string_pretty(&summary)?)?;
        say!("wrote {}", j.display());
    }
    Ok(())
}

/// `trace --json`: the printed summary as numbers (times in seconds, medians over the
/// repetitions; `runs` lists each repetition's build and trace seconds).
#[derive(Serialize)]
struct TraceSummary {
    rays: u64,
    triangles: u64,
    engine: String,
    /// Every option of the engine with the value it ran with, keyed as `rayspace engines
    /// --json` keys them.
    engine_config: std::collections::BTreeMap<String, trace::options::Value>,
    mode: &'static str,
    build_seconds: f64,
    trace_seconds: f64,
    mrays_per_second: f64,
    runs: Vec<(f64, f64)>,
    phases: Vec<(String, f64)>,
    hits: u64,
    ray_tri_tests: u64,
    node_tri_tests: u64,
    total_tests: u64,
    brute_force_tests: u64,
    counters: Vec<(String, u64)>,
}

/// The median of some values (the upper one of an even count; at least one value).
fn median(values: impl Iterator<Item = f64>) -> f64 {
    let mut v: Vec<f64> = values.collect();
    v.sort_by(f64::total_cmp);
    v[v.len() / 2]
}
