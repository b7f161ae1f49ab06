//! `rayspace render`: one image (or, through [`super::frames`], an animation) of a scene:
//! load, build the engine, rasterize the primary visibility into the G-buffer, trace the
//! Whitted generations, shade (thesis §3.1, §3.2.6), write the PNG and the statistics. With
//! `--backend gpu` every pass runs as a wgpu kernel (`crates/gpu`).

use super::args::{Backend, RenderArgs};
use super::progress::progress_bar;
use super::{check, check_memory, check_outputs, UsageError};
use anyhow::{bail, Context, Result};
use rayspace::engines;
use rayspace::runner::Runner;
use render::whitted::RenderOptions;
use scene::Geometry;
use serde::Serialize;
use std::collections::BTreeMap;
use std::time::Instant;
use trace::options::Value;

/// `--stats`: the render's statistics and the load's.
#[derive(Serialize)]
struct StatsFile<'a> {
    #[serde(flatten)]
    render: &'a render::RenderStats,
    load_seconds: f64,
    degenerate_skipped: usize,
    raster_setup_triangles: u64,
    raster_fragments: u64,
    /// GPU seconds per phase from timestamp queries (`--backend gpu`; empty otherwise).
    #[serde(skip_serializing_if = "Vec::is_empty")]
    gpu_phase_seconds: Vec<(String, f64)>,
    /// CRSH/RAH: the object side the traversal used (`bvh` or `mesh-spheres`).
    #[serde(skip_serializing_if = "Option::is_none")]
    object_hierarchy: Option<&'static str>,
    /// Every option of the engine with the value it ran with (defaults filled in), keyed as
    /// `rayspace engines --json` keys them.
    engine_config: BTreeMap<String, Value>,
    /// Options whose value the engine changed to fit (the pair budget lowered to fit the
    /// memory limit): option → {"asked", "used"}.
    #[serde(skip_serializing_if = "BTreeMap::is_empty")]
    engine_adapted: BTreeMap<String, Adapted>,
    /// Bytes of the engine's structure (`Tracer::structure_bytes`; CPU engines that say).
    #[serde(skip_serializing_if = "Option::is_none")]
    structure_bytes: Option<u64>,
    /// The process's peak resident memory at the end of the render (whole process: scene,
    /// structure, build scratch, frame buffers).
    #[serde(skip_serializing_if = "Option::is_none")]
    peak_rss_bytes: Option<u64>,
    /// The resident memory the engine's build added at its peak, over what the process
    /// held before it (`trace::memory::PeakWatch`: CPU engines, single-image renders;
    /// the paper's bound is 3× the final structure, `structure_bytes`).
    #[serde(skip_serializing_if = "Option::is_none")]
    build_peak_bytes: Option<u64>,
}

/// An option the engine changed to fit: the value asked for and the one used.
#[derive(Serialize)]
struct Adapted {
    asked: Value,
    used: Value,
}

pub fn cmd_render(a: &RenderArgs) -> Result<()> {
    // Options first, in one place, before anything is loaded (usage errors, exit 2): the
    // engine's against its declarations, then the mode's and the outputs'.
    let cfg = check::engine_config(a.engine, a.backend, &a.options, a.anim.frames.is_some())?;
    let outs = check::render(a)?;
    // Every output is checked before the work: its folder made, none an input, none
    // unwritable.
    let scene_file = std::path::Path::new(&a.scene);
    let first = match a.anim.frames {
        Some(_) => check::frame_path(&outs.out, 0)?,
        None => outs.out.clone(),
    };
    let outputs: Vec<(&str, &std::path::Path)> = [
        ("--out", Some(&first)),
        ("--stats", a.stats.as_ref()),
        ("--frame-csv", a.anim.frame_csv.as_ref()),
        ("--gif", a.anim.gif.as_ref()),
    ]
    .into_iter()
    .filter_map(|(o, p)| Some((o, p?.as_path())))
    .collect();
    for &(opt, p) in &outputs {
        check::make_parent(opt, p).map_err(|e| UsageError(format!("{e:#}")))?;
        check::writable(opt, p)?;
    }
    check_outputs(&outputs, &[scene_file])?;
    // The whole process's memory model (issue 69: the limit bounds the peak): what the
    // process holds now, the render's buffers, and per triangle the scene and the engine's
    // build; a scene too large for it stops while it loads.
    let limit = super::memory_limit(a.max_memory);
    let gpu = a.backend == Backend::Gpu;
    let per_triangle = if gpu {
        0 // the engine's structure lives on the device
    } else {
        engines::config::build_bytes_per_triangle(a.engine, &cfg)
    };
    let held = trace::memory::current_rss().unwrap_or(0);
    let one_light = render::whitted::render_bytes(a.width, a.height, 1);
    check_memory("the render", "--width/--height", one_light, a.max_memory)?;
    super::check_held(held + one_light, a.max_memory)?;
    let budget = limit.saturating_sub(held + one_light);
    let load_opts = a.look.apply(&a.scene, a.load.within(budget, per_triangle));
    let t0 = Instant::now();
    let mut scene = super::load_scene(&a.scene, &load_opts)?;
    if let Some(v) = &a.viewpoint {
        super::set_viewpoint(&mut scene, v)?;
    }
    // Nor any file the scene includes (an OBJ's material library, a TOML file's meshes).
    let read: Vec<&std::path::Path> = scene.report.files.iter().map(|f| f.as_path()).collect();
    check_outputs(&outputs, &read)?;
    let geo = Geometry::from_scene(&scene);
    let load_s = t0.elapsed().as_secs_f64();
    let render_bytes = render::whitted::render_bytes(a.width, a.height, scene.lights.len());
    check_memory("the render", "--width/--height", render_bytes, a.max_memory)?;
    // The engine's build gets what the scene (as the process holds it now) and the render
    // leave: its model must fit (refused before anything is built), the grid checks its own
    // level by level against it, CRSH/RAH lower their pair budget to fit (more, smaller
    // batches, no pair dropped). The runner makes the frame, as it makes every front end's.
    let held = trace::memory::current_rss().unwrap_or(held);
    let left = limit.saturating_sub(held + render_bytes);
    let mut runner = Runner::new(a.engine, cfg.clone(), a.backend)
        .watch_build_memory(!gpu && a.anim.frames.is_none())
        .on_device_error(|e| {
            eprintln!("error: --backend gpu: the device failed ({e}); lower --width/--height");
            std::process::exit(1);
        });
    let mut adapted = BTreeMap::new();
    for (name, asked, used) in runner.fit_memory(geo.len() as u64, left)? {
        say!(
            "{} lowered from {asked} to {used} to fit --max-memory ({} left after the scene, the render and the build)",
            super::args::EngineFlags::flag(name),
            trace::memory::gib(left)
        );
        adapted.insert(
            name.replace('_', "-"),
            Adapted {
                asked: asked.clone(),
                used: used.clone(),
            },
        );
    }
    let cfg = runner.config().clone();
    // The runner keeps the geometry, brought to each frame's time in place.
    let mut runner = runner.with_geometry(geo);
    let r = scene.report.clone();
    say!(
        "loaded {} in {:.2} s: {} triangles, {} meshes, {} materials, {} lights{}{}",
        scene.name,
        load_s,
        scene.triangle_count(),
        scene.meshes.len(),
        scene.materials.len(),
        scene.lights.len(),
        if r.degenerate_skipped > 0 {
            format!(", {} degenerate triangles skipped", r.degenerate_skipped)
        } else {
            String::new()
        },
        if r.notes.is_empty() {
            String::new()
        } else {
            format!(" ({})", r.notes.join("; "))
        },
    );
    if let Some(n) = a.anim.frames {
        return super::frames::render_frames(a, runner, &scene, n, &outs);
    }
    if a.anim.time.is_some() && scene.animation.is_none() {
        bail!("--time: {} is not animated", scene.name);
    }
    let ropts = RenderOptions {
        width: a.width,
        height: a.height,
        bounces: a.bounces,
        spp: a.spp,
    };
    let bar = progress_bar();
    let frame = runner.frame(&scene, a.anim.time, 0, &ropts, &bar)?;
    bar.0.finish_and_clear();
    if let Some((describe, _)) = runner.gpu_describe() {
        say!("GPU: {describe}");
    }
    if let Some(r) = &frame.build_report {
        say!("{r}");
    }
    let out = frame.rendered;
    let (gpu_phases, gpu_timer) = (frame.gpu_phases, runner.gpu_describe().map_or("", |d| d.1));
    let (structure, build_peak) = (frame.structure_bytes, frame.build_peak);
    render::output::write_rgb8_png(&out.rgb8(), a.width, a.height, &outs.out)
        .map_err(anyhow::Error::msg)
        .context("--out")?;
    say!("{}", out.stats.table());
    if !gpu_phases.is_empty() {
        say!("GPU time per phase ({}):", gpu_timer);
        for (p, t) in &gpu_phases {
            say!("  {p:<20} {:>10.3} ms", t * 1e3);
        }
    }
    say!("wrote {}", outs.out.display());
    if let Some(p) = &a.stats {
        let f = StatsFile {
            render: &out.stats,
            load_seconds: load_s,
            degenerate_skipped: r.degenerate_skipped,
            raster_setup_triangles: out.raster.setup,
            raster_fragments: out.raster.fragments,
            gpu_phase_seconds: gpu_phases.clone(),
            object_hierarchy: cfg.object_hierarchy(),
            engine_config: engines::config::values(a.engine, &cfg),
            engine_adapted: adapted,
            structure_bytes: structure,
            peak_rss_bytes: trace::memory::peak_rss(),
            build_peak_bytes: build_peak,
        };
        let json = serde_json::to_string_pretty(&f)?;
        super::write_out("--stats", p, json)?;
        say!("wrote {}", p.display());
    }
    Ok(())
}
