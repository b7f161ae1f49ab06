//! `rayspace bench gpu`: the GPU backend against the CPU engines on the same rays, phase by
//! phase (the thesis's Tables 4.25–4.27 breakdown: hashing, trimming, compression, sorting,
//! decompression, hierarchy creation, traversal, final tests), plus the G-buffer.
//!
//! Each scene is rendered once on the CPU while every traced batch is recorded; then CPU
//! CRSH and GPU CRSH (and RAH) trace exactly those batches. The hits and the counters of the
//! two are compared in the same run and the report says whether they agree. The irregular
//! grid is built on the GPU too (every pass as kernels, each pass's time reported) and its
//! GPU traversal runs beside the CPU grid on primary, AO and random rays (paper §5, Table
//! 3's kinds), with the same agreement check; then whole 3-bounce frames per engine on both
//! backends, with the GPU frame's host↔device bytes and the image agreement. GPU phase times
//! come from timestamp queries where they time kernels, otherwise from the wall clock with a
//! wait at every phase boundary (the report names which).

use anyhow::Result;
use render::raster::{default_near, rasterize};

use render::View;
use trace::{Hit, TraceStats, Tracer};

use std::time::Instant;

use super::Spec;

use gpu::rsh::engine::comparable_counters as counters;

/// Run the comparison (with RAH beside CRSH when `rah`; the grid alone when `grid_only`);
/// returns the markdown report.
pub fn run(spec: &Spec, rah: bool, grid_only: bool, progress: &dyn Fn(&str)) -> Result<String> {
    let probe = gpu::Gpu::new().map_err(|e| anyhow::anyhow!("bench gpu: {e}"))?;
    let timer = match probe.timer {
        gpu::device::PhaseTimer::Timestamps => "GPU timestamp queries",
        gpu::device::PhaseTimer::WallClock => {
            "wall clock with a wait at every phase boundary (this adapter's timestamps do not time kernels)"
        }
    };
    let mut md = format!("GPU: {}  \nGPU phase timer: {timer}\n", probe.describe());
    drop(probe);
    for name in &spec.scenes {
        if grid_only {
            progress(&format!("{name}: loading"));
            let s = scene::load(name, &scene::LoadOptions::default())?;
            let geo = scene::Geometry::from_scene(&s);
            md += &format!(
                "\n## {} — {} triangles, {}×{}\n",
                s.name,
                geo.len(),
                spec.width,
                spec.height
            );
            progress(&format!("{name}: irregular grid"));
            md += &grid_section(&s, &geo, spec)?;
            continue;
        }
        progress(&format!("{name}: rendering to record the rays"));
        let (s, geo, batches) = super::record(name, spec.width, spec.height, spec.bounces)?;
        let nrays: u64 = batches.iter().map(|b| b.0.len() as u64).sum();
        md += &format!(
            "\n## {} — {} triangles, {}×{}, bounces {}, {} rays in {} batches\n",
            s.name,
            geo.len(),
            spec.width,
            spec.height,
            spec.bounces,
            nrays,
            batches.len()
        );
        // The G-buffer: CPU rasterizer and the GPU render pipeline.
        progress(&format!("{name}: G-buffer"));
        let view = View::new(&s.camera, spec.width, spec.height);
        let near = default_near(&geo);
        let t0 = Instant::now();
        let (cpu_gb, _) = rasterize(&geo, &s.materials, &view, near);
        let cpu_raster = t0.elapsed().as_secs_f64();
        let g = device()?;
        let raster = gpu::GpuRaster::new(&g, &geo, &s.materials)
            .map_err(|e| anyhow::anyhow!("bench gpu: {e}"))?;
        raster
            .check_size(spec.width, spec.height)
            .map_err(|e| anyhow::anyhow!("bench gpu: `width`/`height`: {e}"))?;
        raster.rasterize(&view, near); // warm-up (pipeline compilation)
        let (gpu_gb, _) = raster.rasterize(&view, near);
        let gpu_raster = raster.last_gpu_seconds.get().unwrap_or(f64::NAN);
        let same = cpu_gb
            .tri
            .iter()
            .zip(&gpu_gb.tri)
            .filter(|(a, b)| a == b)
            .count();
        md += &format!(
            "\nG-buffer: CPU rasterizer {:.1} ms, GPU render pipeline {:.1} ms; {:.3} % of pixels name the same triangle.\n",
            cpu_raster * 1e3,
            gpu_raster * 1e3,
            100.0 * same as f64 / cpu_gb.tri.len().max(1) as f64
        );
        drop(raster);
        drop(g);
        let methods: &[rsh::Method] = if rah {
            &[rsh::Method::Crsh, rsh::Method::Rah]
        } else {
            &[rsh::Method::Crsh]
        };
        // The thesis's configurations (bundles behind the mesh spheres), then the dual
        // traversal (the bundles and the object tree descended together, level by level:
        // the breadth schedule, the GPU's), then `bvh`'s single rays through the same tree.
        let mut runs: Vec<(String, Run)> = Vec::new();
        let base = |method| match method {
            rsh::Method::Crsh => rsh::RshConfig::crsh(),
            rsh::Method::Rah => rsh::RshConfig::rah(),
        };
        for &(b, d) in &spec.configs {
            for &method in methods {
                let cfg = rsh::RshConfig {
                    branching: b,
                    levels: d,
                    objects: rsh::ObjectHierarchy::MeshSpheres,
                    ..base(method)
                };
                runs.push((format!("{method:?} {b}/{d}, mesh spheres"), Run::Rsh(cfg)));
            }
        }
        for &method in methods {
            runs.push((
                format!("{method:?}, object BVH (LBVH), bundles, level by level"),
                Run::Rsh(rsh::RshConfig {
                    objects: rsh::ObjectHierarchy::Bvh,
                    builder: rsh::ObjectBuilder::Lbvh,
                    schedule: rsh::Schedule::Breadth,
                    ..base(method)
                }),
            ));
        }
        runs.push((
            "bvh (LBVH), single rays".into(),
            Run::Bvh(accel::BvhConfig {
                builder: accel::bvh::ObjectBuilder::Lbvh,
                path: accel::bvh::RayPath::Single,
            }),
        ));
        for (label, run) in runs {
            progress(&format!("{name}: {label} on the CPU"));
            let g = device()?;
            let fail = |e: gpu::GpuError| anyhow::anyhow!("{e}");
            let (cpu, dev, rsh_cfg): (Box<dyn Tracer>, Dev, _) = match run {
                Run::Rsh(cfg) => (
                    Box::new(rsh::RshEngine::new(&geo, cfg.clone()).map_err(anyhow::Error::msg)?),
                    Dev::Rsh(Box::new(
                        gpu::GpuRsh::new(g, &geo, cfg.clone()).map_err(fail)?,
                    )),
                    Some(cfg),
                ),
                Run::Bvh(cfg) => (
                    Box::new(accel::BvhEngine::new(&geo, cfg.clone()).map_err(anyhow::Error::msg)?),
                    Dev::Bvh(Box::new(gpu::GpuBvh::new(g, &geo, cfg).map_err(fail)?)),
                    None,
                ),
            };
            let gpu = dev.engine();
            // Warm-up on the first batch: drivers compile pipelines at first use (lavapipe
            // JIT-compiles every kernel), which is not the pipeline's cost.
            if let Some((rays, mode, _)) = batches.first() {
                let mut h = vec![Hit::MISS; rays.len()];
                cpu.trace(rays, *mode, &mut h, &mut TraceStats::default());
                gpu.trace(rays, *mode, &mut h, &mut TraceStats::default());
                gpu.take_times();
            }
            let (mut sc, mut sg) = (TraceStats::default(), TraceStats::default());
            let (mut wc, mut wg) = (0.0, 0.0);
            let mut same_hits = true;
            for (rays, mode, _) in &batches {
                let mut hc = vec![Hit::MISS; rays.len()];
                let t0 = Instant::now();
                cpu.trace(rays, *mode, &mut hc, &mut sc);
                wc += t0.elapsed().as_secs_f64();
                progress(&format!("{name}: {label} on the GPU"));
                let mut hg = vec![Hit::MISS; rays.len()];
                let t0 = Instant::now();
                gpu.trace(rays, *mode, &mut hg, &mut sg);
                wg += t0.elapsed().as_secs_f64();
                same_hits &= hc == hg;
            }
            let same_counts = counters(&sc) == counters(&sg);
            let gt = gpu.take_times();
            md += &format!(
                    "\n### {label}: hits {} the CPU's, counters {} ({} node–triangle + {} ray–triangle tests, {:.3} % of brute force)\n\n",
                    if same_hits { "equal" } else { "DIFFER from" },
                    if same_counts { "equal" } else { "DIFFER" },
                    sg.node_tri_tests,
                    sg.ray_tri_tests,
                    100.0 * sg.total_tests() as f64 / (nrays * geo.len() as u64).max(1) as f64
                );
            if !same_counts {
                md += &format!(
                    "Counters that differ (CPU → GPU): {}.\n\n",
                    counter_differences(&counters(&sc), &counters(&sg)).join("; ")
                );
                if let (Some(cfg), Dev::Rsh(g)) = (&rsh_cfg, &dev) {
                    if cfg.method == rsh::Method::Crsh {
                        md += &hash_agreement(g, &batches, &geo, &cfg.hash_bits);
                    }
                }
            }
            md += "| phase | CPU ms | GPU ms | GPU / CPU |\n|---|---:|---:|---:|\n";
            let mut shown = Vec::new();
            for p in crate::engines::phases()
                .into_iter()
                .chain(gt.iter().map(|x| x.0))
            {
                if shown.contains(&p) {
                    continue;
                }
                shown.push(p);
                let c = sc.phases.get(&p).copied();
                let gp = gt.iter().find(|x| x.0 == p).map(|x| x.1);
                if c.is_none() && gp.is_none() {
                    continue;
                }
                let f = |x: Option<f64>| x.map(|v| format!("{:.1}", v * 1e3)).unwrap_or("—".into());
                let ratio = match (c, gp) {
                    (Some(c), Some(g)) if c > 0.0 => format!("{:.2}", g / c),
                    _ => "—".into(),
                };
                md += &format!("| {p} | {} | {} | {ratio} |\n", f(c), f(gp));
            }
            md += &format!(
                "| **trace call, wall** | **{:.1}** | **{:.1}** | **{:.2}** |\n",
                wc * 1e3,
                wg * 1e3,
                wg / wc.max(1e-12)
            );
            md += &format!(
                "\nGPU kernel launches: {}; chunks {}; top nodes {}.\n",
                sg.counters.get(gpu::stats::KERNEL_LAUNCHES).unwrap_or(0),
                sg.counters.get(rsh::stats::CHUNKS).unwrap_or(0),
                sg.counters.get(rsh::stats::TOP_NODES).unwrap_or(0)
            );
        }
        progress(&format!("{name}: irregular grid"));
        md += &grid_section(&s, &geo, spec)?;
        progress(&format!("{name}: whole frames"));
        md += &frames_section(&s, &geo, spec, rah)?;
    }
    Ok(md)
}

/// A configuration the trace rows compare on both backends.
enum Run {
    /// CRSH or RAH.
    Rsh(rsh::RshConfig),
    /// The object-tree walk.
    Bvh(accel::BvhConfig),
}

/// Its GPU engine.
enum Dev {
    Rsh(Box<gpu::GpuRsh>),
    Bvh(Box<gpu::GpuBvh>),
}

impl Dev {
    fn engine(&self) -> &dyn gpu::GpuEngine {
        match self {
            Dev::Rsh(g) => g.as_ref(),
            Dev::Bvh(g) => g.as_ref(),
        }
    }
}

/// Bounces of the whole-frame rows: shadow frames (the rasterized surfaces' shadow rays and
/// shading) and 3-bounce Whitted frames (the thesis's frame times are 3-bounce frames).
const FRAME_BOUNCES: [u32; 2] = [0, 3];

/// Whole Whitted frames (issue 18's rows): per bounce count and engine, the CPU backend's
/// frame (engine build and render: raster, every generation's tracing, ray generation and
/// shading) beside the GPU backend's (engine rebuilt on its device, and the device-resident
/// render), the better of two frames each after a warm-up frame, with the GPU frame's
/// host↔device bytes against the image's and how many pixels differ from the CPU's image by
/// more than 2/255 (the GPU renders' tolerance is 2 %).
fn frames_section(
    s: &scene::Scene,
    geo: &scene::Geometry,
    spec: &Spec,
    rah: bool,
) -> Result<String> {
    use crate::engines::{self, Backend, Engine};
    use crate::runner::Runner;
    use render::whitted::RenderOptions;
    let rgb = |out: &render::whitted::Rendered| -> Vec<[u8; 3]> {
        out.rgb8().chunks(3).map(|c| [c[0], c[1], c[2]]).collect()
    };
    let image = spec.width as u64 * spec.height as u64 * 3;
    let mut md = format!(
        "\n### Whole frames: engine build + render, the better of two after a warm-up\n\nEvery engine runs with its defaults on each backend (on the CPU on {} threads; `rayspace engines` lists them), the frame resident on the device unless the table says otherwise. The target for the traffic is the image's sRGB bytes ({:.2} MB) + 1 MiB.\n\n| bounces | engine | CPU frame ms | GPU frame ms | GPU / CPU | GPU frame | GPU host↔device MB | ≤ image + 1 MiB | pixels off by > 2/255 |\n|---:|---|---:|---:|---:|---|---:|---|---:|\n",
        rayon::current_num_threads(),
        image as f64 / 1e6
    );
    let mut list = vec![Engine::Bvh, Engine::Crsh];
    if rah {
        list.push(Engine::Rah);
    }
    list.push(Engine::Grid);
    for bounces in FRAME_BOUNCES {
        let opts = RenderOptions {
            width: spec.width,
            height: spec.height,
            bounces,
            spp: 1,
        };
        for &engine in &list {
            // Whole frames as every front end makes them (the runner): on the CPU the
            // engine built anew each frame, on the GPU rebuilt on the device it has.
            let mut cpu = Runner::new(engine, engines::Config::of(engine), Backend::Cpu)
                .with_geometry(geo.clone());
            let mut cpu_frame = || -> Result<(f64, Vec<[u8; 3]>)> {
                let t0 = Instant::now();
                let out = cpu.frame(s, None, 0, &opts, &())?.rendered;
                let t = t0.elapsed().as_secs_f64();
                Ok((t, rgb(&out)))
            };
            cpu_frame()?;
            let (c1, img) = cpu_frame()?;
            let c2 = cpu_frame()?.0;
            let gcfg = engines::config::defaults(engine, Backend::Gpu, false);
            let mut gpu = Runner::new(engine, gcfg, Backend::Gpu)
                .with_geometry(geo.clone())
                .on_device_error(|e| {
                    eprintln!("error: bench gpu: the device failed ({e}); a smaller image may fit");
                    std::process::exit(1);
                });
            let mut gpu_frame = || -> Result<(f64, Vec<[u8; 3]>, u64, String)> {
                let t0 = Instant::now();
                let out = gpu.frame(s, None, 0, &opts, &())?.rendered;
                let t = t0.elapsed().as_secs_f64();
                Ok((
                    t,
                    rgb(&out),
                    out.stats.host_device_bytes.unwrap_or(0),
                    out.stats.gpu_frame.clone().unwrap_or_default(),
                ))
            };
            gpu_frame()?;
            let (g1, gimg, bytes, how) = gpu_frame()?;
            let g2 = gpu_frame()?.0;
            let (c, g) = (c1.min(c2), g1.min(g2));
            let off = img
                .iter()
                .zip(&gimg)
                .filter(|(a, b)| a.iter().zip(b.iter()).any(|(p, q)| p.abs_diff(*q) > 2))
                .count();
            md += &format!(
                "| {bounces} | {} | {:.1} | {:.1} | {:.2} | {how} | {:.3} | {} | {:.3} % |\n",
                engine.name(),
                c * 1e3,
                g * 1e3,
                g / c.max(1e-12),
                bytes as f64 / 1e6,
                if bytes <= image + (1 << 20) {
                    "yes"
                } else {
                    "no"
                },
                100.0 * off as f64 / img.len().max(1) as f64
            );
        }
    }
    Ok(md)
}

/// Milliseconds of the build pass `pass` of `e`.
fn pass_ms(e: &dyn Tracer, pass: trace::BuildPass) -> f64 {
    e.build_passes()
        .iter()
        .find(|p| p.pass == pass)
        .map(|p| p.seconds * 1e3)
        .unwrap_or(0.0)
}

/// Timed runs per engine and ray kind in the grid section, interleaved (the best one is
/// reported; the first also warms the drivers up).
const GRID_REPEATS: usize = 4;

/// The irregular grid (paper §5, Table 3's ray kinds): the CPU engine and the GPU engine (its
/// grid built by `GpuGrid::new`, which must equal the CPU's) on the same primary, ambient-occlusion
/// (any hit) and random rays; MRays/s from the best of [`GRID_REPEATS`] runs, the GPU's
/// both from its traversal kernel alone and from the whole trace call (upload, launch,
/// read-back), and whether hits, N_T and N_I agree.
fn grid_section(s: &scene::Scene, geo: &scene::Geometry, spec: &Spec) -> Result<String> {
    use accel::grid::{GridConfig, GridEngine};
    use gpu::GpuEngine;
    use render::raygen::{generate, Kind, Options};
    use trace::TraceMode;
    let cfg = GridConfig::default();
    let t0 = Instant::now();
    let cpu = GridEngine::new(geo, &cfg).map_err(anyhow::Error::msg)?;
    let build = t0.elapsed().as_secs_f64();
    // The GPU builds its own grid (every pass as kernels): the better of two builds (the
    // first also warms the drivers up). Pass times are wall clock, with the waits for the
    // totals each pass reads back.
    let gpu_build = || {
        gpu::GpuGrid::new(device()?, geo, &cfg).map_err(|e| anyhow::anyhow!("bench gpu: grid: {e}"))
    };
    let first = gpu_build()?;
    let second = gpu_build()?;
    let total = |g: &gpu::GpuGrid| {
        g.build_passes()
            .iter()
            .filter(|p| p.pass != gpu::stats::KERNEL_COMPILATION)
            .map(|p| p.seconds)
            .sum::<f64>()
    };
    let gpu = if total(&second) <= total(&first) {
        second
    } else {
        first
    };
    let opts = Options {
        width: spec.width,
        height: spec.height,
        spp: 1,
        seed: 1,
        ao_distance: None,
    };
    let kinds = [
        ("primary", Kind::Primary, TraceMode::Closest),
        ("ao (any hit)", Kind::Ao, TraceMode::Any),
        ("random", Kind::Random, TraceMode::Closest),
    ];
    let passes: Vec<String> = cpu
        .grid
        .build
        .passes()
        .iter()
        .map(|p| format!("{} {:.1}", p.name(), p.seconds * 1e3))
        .collect();
    let gpu_passes: Vec<String> = gpu
        .build_passes()
        .iter()
        .filter(|p| p.pass != gpu::stats::KERNEL_COMPILATION)
        .map(|p| format!("{} {:.1}", p.name(), p.seconds * 1e3))
        .collect();
    let mut md = format!(
        "\n### Irregular grid (λ₁ = {}, λ₂ = {}): {} cells, {} references; CPU build {:.1} ms ({}); GPU build {:.1} ms ({}; kernel compilation {:.0} ms); CPU traversal on {} threads\n\n",
        cfg.top_density,
        cfg.leaf_density,
        cpu.grid.cells(),
        cpu.grid.refs.len(),
        build * 1e3,
        passes.join(", "),
        total(&gpu) * 1e3,
        gpu_passes.join(", "),
        pass_ms(&gpu, gpu::stats::KERNEL_COMPILATION),
        rayon::current_num_threads()
    );
    md += "The GPU traces the grid it built; the agreement column compares it with the CPU-built grid's hits and counts, so a build that differs shows there.\n\n";
    md += "| rays | count | CPU MRays/s | GPU kernel MRays/s | GPU call MRays/s | kernel speed-up over CPU | N_T | N_I | agreement |\n|---|---:|---:|---:|---:|---:|---:|---:|---|\n";
    for (label, kind, mode) in kinds {
        let rays = generate(s, geo, kind, &opts);
        let n = rays.len();
        gpu.take_times();
        let mut res =
            super::grid::time_all(&[&cpu, &gpu], &rays, mode, GRID_REPEATS as u32).into_iter();
        let ((wc, sc, hc), (wg, sg, hg)) = (res.next().unwrap(), res.next().unwrap());
        // The kernel's time per call: the traversal phase, averaged over the calls (every
        // call launches the same kernel on the same rays).
        let kernel = gpu
            .take_times()
            .into_iter()
            .find(|(p, _)| *p == trace::TRAVERSAL)
            .map(|(_, t)| t / GRID_REPEATS as f64);
        let steps = |st: &TraceStats| st.counters.get(accel::grid::TRAVERSAL_STEPS);
        let same = hc == hg
            && sc.ray_tri_tests == sg.ray_tri_tests
            && steps(&sc) == steps(&sg)
            && sc.hits == sg.hits;
        let mrays = |t: f64| n as f64 / t / 1e6;
        md += &format!(
            "| {label} | {n} | {:.2} | {} | {:.2} | {} | {:.2} | {:.2} | {} |\n",
            mrays(wc),
            kernel
                .map(|k| format!("{:.1}", mrays(k)))
                .unwrap_or("—".into()),
            mrays(wg),
            kernel
                .map(|k| format!("{:.1}", wc / k))
                .unwrap_or("—".into()),
            steps(&sg).unwrap_or(0) as f64 / n.max(1) as f64,
            sg.ray_tri_tests as f64 / n.max(1) as f64,
            if same {
                "hits, N_T, N_I equal the CPU's"
            } else {
                "DIFFER from the CPU's"
            }
        );
    }
    Ok(md)
}

/// A device whose errors outside any call (device memory) end the run with one line.
fn device() -> anyhow::Result<gpu::Gpu> {
    let g = gpu::Gpu::new().map_err(|e| anyhow::anyhow!("bench gpu: {e}"))?;
    g.on_device_error(|e| {
        eprintln!("error: bench gpu: the device failed ({e}); a smaller image may fit");
        std::process::exit(1);
    });
    Ok(g)
}

/// Whether the GPU's hash pass gave every ray of `batches` the CPU's key (the first pass
/// whose disagreement changes all counts after it), as a report line.
fn hash_agreement(
    gpu: &gpu::GpuRsh,
    batches: &[(trace::RayBatch, trace::TraceMode, Vec<Hit>)],
    geo: &scene::Geometry,
    bits: &rsh::HashBits,
) -> String {
    let (mut differ, mut first) = (0, None);
    for (n, (rays, _, _)) in batches.iter().enumerate() {
        let (keys, _) = gpu.hash_keys(rays, false);
        for (i, &k) in keys.iter().enumerate() {
            let cpu = rsh::hash::thesis_key(rays, i, &geo.bounds, bits);
            if k != cpu {
                differ += 1;
                first.get_or_insert(format!(
                    "ray {i} of batch {n}: GPU {k:#010x}, CPU {cpu:#010x}, direction bits {:08x?}",
                    rays.dir[i].to_array().map(f32::to_bits)
                ));
            }
        }
    }
    match first {
        None => "Hash keys: all equal the CPU's.\n\n".into(),
        Some(f) => format!("Hash keys: {differ} differ from the CPU's; the first: {f}.\n\n"),
    }
}

/// The counters of two traces that differ, as `path: cpu → gpu` (paths into the serialized
/// [`TraceStats`], e.g. `levels.levels.level 2 SH.tests`), so that a
/// disagreement names the pass it starts in.
fn counter_differences(cpu: &TraceStats, gpu: &TraceStats) -> Vec<String> {
    fn walk(path: &str, a: &serde_json::Value, b: &serde_json::Value, out: &mut Vec<String>) {
        use serde_json::Value;
        match (a, b) {
            (Value::Object(x), Value::Object(y)) => {
                let keys: std::collections::BTreeSet<&String> = x.keys().chain(y.keys()).collect();
                for k in keys {
                    let (u, v) = (
                        x.get(k).unwrap_or(&Value::Null),
                        y.get(k).unwrap_or(&Value::Null),
                    );
                    walk(
                        &format!("{path}{}{k}", if path.is_empty() { "" } else { "." }),
                        u,
                        v,
                        out,
                    );
                }
            }
            (Value::Array(x), Value::Array(y)) if x.len() == y.len() => {
                for (i, (u, v)) in x.iter().zip(y).enumerate() {
                    // Level rows are named by their level and ray kind, not their index.
                    let label = match (u.get("level"), u.get("kind")) {
                        (Some(l), Some(Value::String(k))) => format!("level {l} {k}"),
                        _ => i.to_string(),
                    };
                    walk(&format!("{path}.{label}"), u, v, out);
                }
            }
            _ if a != b => out.push(format!("{path}: {a} → {b}")),
            _ => {}
        }
    }
    let value = |s: &TraceStats| serde_json::to_value(s).unwrap_or_default();
    let mut out = Vec::new();
    walk("", &value(cpu), &value(gpu), &mut out);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counter_differences_name_the_counts_that_differ() {
        let mut a = TraceStats {
            ray_tri_tests: 10,
            ..Default::default()
        };
        a.levels.tests = vec![[1, 2, 3, 4], [5, 6, 7, 8]];
        a.levels.hits = vec![[1, 1, 1, 1], [2, 2, 2, 2]];
        a.counters.record(rsh::stats::CHUNKS, 3);
        let mut b = a.clone();
        assert!(counter_differences(&a, &b).is_empty());
        b.ray_tri_tests = 11;
        b.levels.tests[1][2] = 9;
        b.counters.record(rsh::stats::CHUNKS, 1);
        assert_eq!(
            counter_differences(&a, &b),
            [
                "counters.chunks: 3 → 4",
                "levels.levels.level 2 RE.tests: 7 → 9",
                "ray_tri_tests: 10 → 11"
            ]
        );
    }
}
