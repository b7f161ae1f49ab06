//! `rayspace bench ...`: options in, the reports of [`rayspace::bench`] out (stdout and the
//! `--md/--json/--csv/--charts` files), each report headed by the provenance line.

use super::args::{BenchBudgetArgs, BenchGpuArgs, BenchGridArgs, BenchRshArgs, BenchScaleArgs};
use super::progress::step_bar;
use super::{check_dir, check_out_dir, check_outputs};
use anyhow::{Context, Result};
use rayspace::bench::{self, provenance};
use rayspace::engines::{self, Backend, Engine, OBVHS_VERSION};
use scene::Geometry;
use std::path::Path;
use std::path::PathBuf;

#[cfg(feature = "gpu")]
pub fn cmd_bench_gpu(a: &BenchGpuArgs) -> Result<()> {
    if let Some(p) = &a.md {
        check_out_dir("--md", p)?;
    }
    let configs =
        bench::parse_configs(&a.configs).map_err(|e| anyhow::anyhow!("--configs: {e}"))?;
    let scenes = bench::scenes(a.spec.scenes.as_deref(), &["cornell"], &["sponza"])?;
    // Per scene: the recording render (or the load), each configuration, the grid.
    let per = if a.grid_only {
        2
    } else {
        2 + configs.len() as u64 * if a.rah { 2 } else { 1 }
    };
    let bar = step_bar(scenes.len() as u64 * per);
    let spec = a.spec.spec(scenes, configs, a.bounces);
    let md = bench::gpu::run(&spec, a.rah, a.grid_only, &|m| bar.step(m))?;
    bar.0.finish_and_clear();
    let report = format!("# rayspace bench gpu\n\n{}\n{md}", provenance());
    say!("{report}");
    if let Some(p) = &a.md {
        super::write_out("--md", p, &report)?;
        say!("wrote {}", p.display());
    }
    Ok(())
}

#[cfg(not(feature = "gpu"))]
pub fn cmd_bench_gpu(_a: &BenchGpuArgs) -> Result<()> {
    anyhow::bail!("bench gpu: this build has no GPU backend; build with `cargo build --release --features gpu`")
}

/// A benchmark's outputs: each writable, no two the same file.
fn check_reports(outputs: &[(&str, &Option<std::path::PathBuf>)]) -> Result<()> {
    let given: Vec<(&str, &Path)> = outputs
        .iter()
        .filter_map(|(o, p)| Some((*o, p.as_deref()?)))
        .collect();
    for &(opt, p) in &given {
        super::check::writable(opt, p)?;
    }
    check_outputs(&given, &[])?;
    Ok(())
}

pub fn cmd_bench_rsh(a: &BenchRshArgs) -> Result<()> {
    check_reports(&[
        ("--json", &a.out.json),
        ("--csv", &a.out.csv),
        ("--md", &a.out.md),
    ])?;
    let configs =
        bench::parse_configs(&a.configs).map_err(|e| anyhow::anyhow!("--configs: {e}"))?;
    let scenes = bench::scenes(
        a.spec.scenes.as_deref(),
        &["cornell", "office"],
        &["sponza"],
    )?;
    if let Some(d) = &a.out.charts {
        check_dir("--charts", d)?;
    }
    // Per scene: the recording render, then four engines per configuration (CRSH, RAH, each
    // with mesh spheres and with the BVH).
    let bar = step_bar(scenes.len() as u64 * (1 + 4 * configs.len() as u64));
    let spec = a.spec.spec(scenes, configs, a.bounces);
    let (rows, md) = bench::rsh::run(&spec, &|m| bar.step(m))?;
    bar.0.finish_and_clear();
    if let Some(d) = &a.out.charts {
        report_charts(bench::rsh::charts(&rows, d));
    }
    let report = format!(
        "# rayspace bench rsh

{}
{md}",
        provenance()
    );
    say!("{report}");
    if let Some(p) = &a.out.md {
        super::write_out("--md", p, &report)?;
    }
    if let Some(p) = &a.out.json {
        super::write_out("--json", p, serde_json::to_string_pretty(&rows)?)?;
    }
    if let Some(p) = &a.out.csv {
        super::write_out("--csv", p, bench::rsh::csv(&rows))?;
    }
    Ok(())
}

/// Report the chart files, or why there are none: the tables are written either way, so a
/// missing font only costs the pictures.
fn report_charts(charts: Result<Vec<PathBuf>>) {
    match charts {
        Ok(files) => files.iter().for_each(|f| say!("wrote {}", f.display())),
        Err(e) => eprintln!("warning: charts not written: {e:#}"),
    }
}

pub fn cmd_bench_grid(a: &BenchGridArgs) -> Result<()> {
    check_reports(&[
        ("--json", &a.out.json),
        ("--csv", &a.out.csv),
        ("--grids-csv", &a.grids_csv),
        ("--md", &a.out.md),
    ])?;
    if let Some(d) = &a.out.charts {
        check_dir("--charts", d)?;
    }
    let scenes = bench::scenes(
        a.spec.scenes.as_deref(),
        &["cornell", "office", "stadium"],
        &["sponza", "conference", "kitchen"],
    )?;
    let bar = step_bar(scenes.len() as u64 * bench::grid::STEPS_PER_SCENE);
    let spec = bench::grid::Spec {
        scenes,
        width: a.spec.width,
        height: a.spec.height,
        ao_spp: a.ao_spp,
        seed: a.seed,
        repeats: a.repeats,
    };
    let rep = bench::grid::run(&spec, &|m| bar.step(m))?;
    bar.0.finish_and_clear();
    let report = format!(
        "# rayspace bench grid

{}; peers: obvhs {}{}
{}",
        provenance(),
        OBVHS_VERSION,
        if accel::peers::HAS_EMBREE {
            ", Embree 3 (system library, `embree` crate 0.3.8)"
        } else {
            "; Embree not in this build (`--features embree`)"
        },
        rep.markdown
    );
    say!("{report}");
    if let Some(p) = &a.out.md {
        super::write_out("--md", p, &report)?;
    }
    if let Some(p) = &a.out.json {
        let v = serde_json::json!({ "table3": rep.perf, "grids": rep.grids });
        super::write_out("--json", p, serde_json::to_string_pretty(&v)?)?;
    }
    if let Some(p) = &a.out.csv {
        super::write_out("--csv", p, bench::grid::perf_csv(&rep.perf))?;
    }
    if let Some(p) = &a.grids_csv {
        super::write_out("--grids-csv", p, bench::grid::grid_csv(&rep.grids))?;
    }
    if let Some(d) = &a.out.charts {
        report_charts(bench::grid::charts(&rep.perf, d));
    }
    Ok(())
}

pub fn cmd_bench_budget(a: &BenchBudgetArgs) -> Result<()> {
    if let Some(p) = &a.csv {
        check_out_dir("--csv", p)?;
    }
    let budgets: Vec<f64> =
        a.ms.split(',')
            .map(|x| match x.trim().parse::<f64>() {
                // At most an hour: a frame budget beyond that has no meaning, and the
                // samples that fit in it would overflow the count.
                Ok(v) if v.is_finite() && v > 0.0 && v <= 3.6e6 => Ok(v),
                _ => Err(anyhow::anyhow!(
                    "--ms: '{x}' is not a number of milliseconds in (0, 3600000]"
                )),
            })
            .collect::<Result<_>>()?;
    let engines: Vec<Engine> = a
        .engines
        .split(',')
        .map(|x| Engine::parse(x).context("--engines"))
        .collect::<Result<_>>()?;
    let scene = super::load_scene(&a.scene, &a.load.options(None))?;
    // The engines' defaults, with the grid's dynamic-scene expansion (one pass per frame).
    let closures: Vec<(String, Box<bench::budget::BuildFn>)> = engines
        .iter()
        .map(|&e| {
            let cfg = engines::config::defaults(e, Backend::Cpu, true);
            let f: Box<bench::budget::BuildFn> =
                Box::new(move |geo: &Geometry| Ok(engines::build(e, &cfg, geo)?.tracer));
            (e.name().to_string(), f)
        })
        .collect();
    let builders: Vec<bench::budget::Builder> = closures
        .iter()
        .map(|(n, f)| (n.as_str(), f.as_ref()))
        .collect();
    let bar = step_bar(engines.len() as u64 * a.frames as u64);
    let rows = bench::budget::run(
        &scene,
        &builders,
        a.width,
        a.height,
        a.frames,
        &budgets,
        &|m| bar.step(m),
    )?;
    bar.0.finish_and_clear();
    say!(
        "# rayspace bench budget\n\n{}\n\n{} — {} frames, build and primary rays inside the budget; AO rays are any-hit, one per pixel per sample\n\n{}",
        provenance(),
        scene.name,
        a.frames,
        bench::budget::markdown(&rows, a.width, a.height)
    );
    if let Some(p) = &a.csv {
        let mut csv =
            String::from("scene,engine,frames,build_ms,primary_ms,ao_ms_per_spp,budget_ms,spp\n");
        for r in &rows {
            for (b, n) in &r.spp {
                csv += &format!(
                    "{},{},{},{:.3},{:.3},{:.3},{},{}\n",
                    r.scene, r.engine, r.frames, r.build_ms, r.primary_ms, r.ao_ms_per_spp, b, n
                );
            }
        }
        super::write_out("--csv", p, csv)?;
    }
    Ok(())
}

pub fn cmd_bench_scale(a: &BenchScaleArgs) -> Result<()> {
    check_reports(&[
        ("--json", &a.out.json),
        ("--csv", &a.out.csv),
        ("--md", &a.out.md),
    ])?;
    if let Some(d) = &a.out.charts {
        check_dir("--charts", d)?;
    }
    let generators: Vec<String> = a
        .generators
        .split(',')
        .map(|g| g.trim().to_string())
        .filter(|g| !g.is_empty())
        .collect();
    for g in &generators {
        if !scene::generate::NAMES.contains(&g.as_str()) {
            anyhow::bail!(
                "--generators: '{g}' is not a generator ({})",
                scene::generate::NAMES.join(", ")
            );
        }
    }
    let mut sizes = Vec::new();
    for s in a.sizes.split(',').map(str::trim).filter(|s| !s.is_empty()) {
        match scene::generate::Spec::parse(&format!("city:{s}")) {
            Some(Ok(spec)) => sizes.push(spec.triangles),
            Some(Err(e)) => anyhow::bail!("--sizes: {e}"),
            None => unreachable!("city is a generator"),
        }
    }
    if generators.is_empty() || sizes.is_empty() {
        anyhow::bail!("--generators/--sizes: nothing to run");
    }
    let engines: Vec<Engine> = match &a.engines {
        Some(list) => list
            .split(',')
            .map(|x| Engine::parse(x).context("--engines"))
            .collect::<Result<_>>()?,
        None => {
            let mut v = Engine::all_but_brute();
            v.push(Engine::Brute);
            v
        }
    };
    let spec = bench::scale::Spec {
        generators,
        sizes,
        engines,
        width: a.width,
        height: a.height,
        seed: a.seed,
        repeats: a.repeats,
        brute_max: a.brute_max,
    };
    let bar = step_bar(bench::scale::steps(&spec));
    // The peak renders' files, in a folder made exclusively (removed when dropped).
    let tmp = render::output::TempFolder::new_in(&std::env::temp_dir(), "rayspace-scale-")
        .context("bench scale: a temporary folder")?;
    let peak = |scene: &str, e: Engine| -> Result<bench::scale::Peaks> {
        if a.no_peak {
            return Ok(Default::default());
        }
        peak_of_render(tmp.path(), scene, e, a.width, a.height)
    };
    let result = bench::scale::run(&spec, &peak, &|m| bar.step(m));
    bar.0.finish_and_clear();
    drop(tmp);
    let (rows, slopes) = result?;
    if let Some(d) = &a.out.charts {
        report_charts(bench::scale::charts(&spec, &rows, d));
    }
    let report = format!(
        "# rayspace bench scale\n\n{}\n\n{}x{} pixels, seed {}, best of {} runs per ray kind.\n\n{}",
        provenance(),
        a.width,
        a.height,
        a.seed,
        a.repeats,
        bench::scale::markdown(&rows, &slopes)
    );
    say!("{report}");
    if let Some(p) = &a.out.md {
        super::write_out("--md", p, &report)?;
    }
    if let Some(p) = &a.out.json {
        let j = serde_json::json!({ "rows": rows, "slopes": slopes });
        super::write_out("--json", p, serde_json::to_string_pretty(&j)?)?;
    }
    if let Some(p) = &a.out.csv {
        super::write_out("--csv", p, bench::scale::csv(&rows))?;
    }
    Ok(())
}

/// The whole-process peak memory of `render SCENE -e ENGINE -b 0` in a child process (this
/// executable), and what its engine's build added at its peak, read from its `--stats`;
/// `None` where the system does not report them.
fn peak_of_render(
    tmp: &std::path::Path,
    scene: &str,
    e: Engine,
    width: u32,
    height: u32,
) -> Result<bench::scale::Peaks> {
    let stats = tmp.join("stats.json");
    let out = std::process::Command::new(std::env::current_exe()?)
        .args(["render", scene, "-e", e.name(), "-b", "0"])
        .args(["-W", &width.to_string(), "-H", &height.to_string()])
        .arg("-o")
        .arg(tmp.join("render.png"))
        .arg("--stats")
        .arg(&stats)
        .output()
        .context("bench scale: the peak-memory render")?;
    if !out.status.success() {
        anyhow::bail!(
            "bench scale: render {scene} -e {} failed: {}",
            e.name(),
            String::from_utf8_lossy(&out.stderr).trim()
        );
    }
    let v: serde_json::Value = serde_json::from_str(&std::fs::read_to_string(&stats)?)?;
    Ok(bench::scale::Peaks {
        process: v.get("peak_rss_bytes").and_then(|b| b.as_u64()),
        build: v.get("build_peak_bytes").and_then(|b| b.as_u64()),
    })
}
