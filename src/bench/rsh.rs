//! `rayspace bench rsh`: the thesis's chapter-4 tables for CRSH and RAH on the same rays.
//!
//! Each scene is rendered once (CRSH, whose hits equal brute force's) while every traced
//! batch is recorded; then every configuration of both engines traces exactly those batches.
//! Brute force is counted as rays × triangles, not traced.
//!
//! Beside the thesis's configurations (every triangle behind per-mesh spheres), both engines
//! also run with the object hierarchy (`--object-hierarchy bvh`: a per-frame LBVH descended
//! with the ray hierarchy, the thesis's §5.1 future work), whose build is timed apart and
//! included in its per-frame cost.

use super::{record, Spec};
use anyhow::Result;
use serde::Serialize;
use trace::{Hit, TraceStats, Tracer};

#[derive(Serialize, Clone)]
pub struct Row {
    pub scene: String,
    pub engine: String,
    pub branching: u32,
    pub levels: u32,
    /// `mesh-spheres` (the thesis) or `bvh`.
    pub objects: String,
    /// Engine build (the object hierarchy, if any), once per frame.
    pub build_seconds: f64,
    pub rays: u64,
    pub triangles: u64,
    pub total_tests: u64,
    pub brute_force_tests: u64,
    pub percent_of_brute_force: f64,
    pub trace_seconds: f64,
    /// Ray–triangle tests alone over rays × triangles (the same figure for every engine).
    pub ray_tri_percent_of_brute_force: f64,
    pub stats: TraceStats,
}

/// Run every scene × configuration × engine; returns the rows and the markdown report.
pub fn run(spec: &Spec, progress: &dyn Fn(&str)) -> Result<(Vec<Row>, String)> {
    let mut rows = Vec::new();
    let mut md = String::new();
    for name in &spec.scenes {
        progress(&format!("{name}: rendering to record the rays"));
        let (s, geo, batches) = record(name, spec.width, spec.height, spec.bounces)?;
        let nrays: u64 = batches.iter().map(|b| b.0.len() as u64).sum();
        md += &format!(
            "\n## {} — {} triangles, {}×{}, bounces {}, {} rays traced\n\n",
            s.name,
            geo.len(),
            spec.width,
            spec.height,
            spec.bounces,
            nrays
        );
        // The configurations as run, less the B/D each row gives.
        let as_run = |e: crate::engines::Engine, c: rsh::RshConfig| {
            crate::engines::config::values(e, &crate::engines::Config::Rsh(c))
                .into_iter()
                .filter(|(k, _)| k != "branching" && k != "levels")
                .map(|(k, v)| format!("--{k} {v}"))
                .collect::<Vec<_>>()
                .join(" ")
        };
        let thesis = |c| rsh::RshConfig {
            objects: rsh::ObjectHierarchy::MeshSpheres,
            ..c
        };
        md += &format!(
            "As run, with each row's `--branching B --levels D`: CRSH `-e crsh {}`, RAH `-e rah {}` (the thesis's traversal: every triangle behind the mesh spheres); CRSH+BVH and RAH+BVH the same with `--object-hierarchy bvh` (the dual traversal over the per-frame SAH tree, depth first). % of brute force: every test (ray-hierarchy node, ray-box and ray-triangle) over rays × triangles, as the thesis counts them (ray-triangle tests alone: `ray_tri_percent_of_brute_force` in the JSON and CSV).\n\n",
            as_run(crate::engines::Engine::Crsh, thesis(rsh::RshConfig::crsh())),
            as_run(crate::engines::Engine::Rah, thesis(rsh::RshConfig::rah())),
        );
        md += "| B/D | CRSH total | CRSH % of brute force | RAH total | RAH % of brute force | RAH / CRSH tests | CRSH trace ms | RAH trace ms | CRSH+BVH % of brute force | RAH+BVH % of brute force | RAH+BVH / CRSH+BVH tests | CRSH+BVH build + trace ms | RAH+BVH build + trace ms | CRSH ÷ CRSH+BVH time |\n|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n";
        let mut detail = String::new();
        for &(b, d) in &spec.configs {
            let mut pair = Vec::new();
            let mesh = rsh::ObjectHierarchy::MeshSpheres;
            let bvh = rsh::ObjectHierarchy::Bvh;
            let crsh = rsh::RshConfig::crsh;
            let rah = rsh::RshConfig::rah;
            for (base_cfg, objects) in [(crsh(), mesh), (rah(), mesh), (crsh(), bvh), (rah(), bvh)]
            {
                let cfg = rsh::RshConfig {
                    branching: b,
                    levels: d,
                    objects,
                    ..base_cfg
                };
                let oname = if objects == bvh {
                    "bvh"
                } else {
                    "mesh-spheres"
                };
                progress(&format!(
                    "{}: {} {b}/{d} {oname}",
                    s.name,
                    match cfg.method {
                        rsh::Method::Crsh => "CRSH",
                        rsh::Method::Rah => "RAH",
                    }
                ));
                let t0 = std::time::Instant::now();
                let e = rsh::RshEngine::new(&geo, cfg).map_err(anyhow::Error::msg)?;
                let build_seconds = t0.elapsed().as_secs_f64();
                let mut st = TraceStats::default();
                let t0 = std::time::Instant::now();
                for (rays, mode, _) in &batches {
                    let mut hits = vec![Hit::MISS; rays.len()];
                    e.trace(rays, *mode, &mut hits, &mut st);
                }
                let secs = t0.elapsed().as_secs_f64();
                let bf = nrays * geo.len() as u64;
                let total = st.total_tests();
                pair.push(Row {
                    scene: s.name.clone(),
                    engine: e.name().to_string(),
                    branching: b,
                    levels: d,
                    objects: oname.into(),
                    build_seconds,
                    rays: nrays,
                    triangles: geo.len() as u64,
                    total_tests: total,
                    brute_force_tests: bf,
                    percent_of_brute_force: 100.0 * total as f64 / bf.max(1) as f64,
                    trace_seconds: secs,
                    ray_tri_percent_of_brute_force: 100.0 * st.ray_tri_tests as f64
                        / bf.max(1) as f64,
                    stats: st,
                });
            }
            let (c, r, cb, rb) = (&pair[0], &pair[1], &pair[2], &pair[3]);
            let frame = |x: &Row| x.build_seconds + x.trace_seconds;
            md += &format!(
                "| {b}/{d} | {} | {:.3} % | {} | {:.3} % | {:.2} | {:.0} | {:.0} | {:.4} % | {:.4} % | {:.2} | {:.0} | {:.0} | {:.1} |\n",
                c.total_tests,
                c.percent_of_brute_force,
                r.total_tests,
                r.percent_of_brute_force,
                r.total_tests as f64 / c.total_tests.max(1) as f64,
                c.trace_seconds * 1e3,
                r.trace_seconds * 1e3,
                cb.percent_of_brute_force,
                rb.percent_of_brute_force,
                rb.total_tests as f64 / cb.total_tests.max(1) as f64,
                frame(cb) * 1e3,
                frame(rb) * 1e3,
                frame(c) / frame(cb).max(1e-9),
            );
            for row in &pair {
                detail += &format!(
                    "\n### {} {} {b}/{d} {}: intersections per level (as the thesis's chapter-4 tables)\n{}",
                    s.name,
                    row.engine.to_uppercase(),
                    row.objects,
                    row.stats.levels.markdown()
                );
                detail += &format!("| **total** | | {} | | |\n", row.total_tests);
            }
            detail += &format!("\n### {} {b}/{d}: phase times (ms; thesis Tables 4.25–4.27)\n\n| phase | CRSH | RAH | RAH / CRSH | CRSH+BVH | RAH+BVH |\n|---|---:|---:|---:|---:|---:|\n", s.name);
            detail += &format!(
                "| object hierarchy build | — | — | — | {:.1} | {:.1} |\n",
                cb.build_seconds * 1e3,
                rb.build_seconds * 1e3
            );
            let phases = crate::engines::phases()
                .into_iter()
                .filter(|p| pair.iter().any(|x| x.stats.phases.contains_key(p)));
            for p in phases {
                let (a, bb) = (c.stats.seconds(p), r.stats.seconds(p));
                let ratio = if a > 0.0 && bb > 0.0 {
                    format!("{:.2}", bb / a)
                } else {
                    "—".into()
                };
                detail += &format!(
                    "| {p} | {:.1} | {:.1} | {ratio} | {:.1} | {:.1} |\n",
                    a * 1e3,
                    bb * 1e3,
                    cb.stats.seconds(p) * 1e3,
                    rb.stats.seconds(p) * 1e3
                );
            }
            rows.extend(pair);
        }
        md += &detail;
    }
    Ok((rows, md))
}

/// CSV of the summary rows.
pub fn csv(rows: &[Row]) -> String {
    let mut s = String::from("scene,engine,branching,levels,objects,build_seconds,rays,triangles,total_tests,brute_force_tests,percent_of_brute_force,node_tri_tests,ray_tri_tests,trace_seconds,ray_box_tests,ray_tri_percent_of_brute_force\n");
    for r in rows {
        s += &format!(
            "{},{},{},{},{},{:.6},{},{},{},{},{:.6},{},{},{:.6},{},{:.6}\n",
            r.scene,
            r.engine,
            r.branching,
            r.levels,
            r.objects,
            r.build_seconds,
            r.rays,
            r.triangles,
            r.total_tests,
            r.brute_force_tests,
            r.percent_of_brute_force,
            r.stats.node_tri_tests,
            r.stats.ray_tri_tests,
            r.trace_seconds,
            r.stats.counters.get(trace::RAY_BOX_TESTS).unwrap_or(0),
            r.ray_tri_percent_of_brute_force
        );
    }
    s
}

/// One chart per scene: intersections per hierarchy level (bars, log scale) for every
/// configuration and engine (groups), like the thesis's Figures 4.7–4.23; with the object
/// hierarchy, its single rays' box tests as one more series.
pub fn charts(rows: &[Row], dir: &std::path::Path) -> Result<Vec<std::path::PathBuf>> {
    let mut files = Vec::new();
    let mut scenes: Vec<&str> = rows.iter().map(|r| r.scene.as_str()).collect();
    scenes.dedup();
    for sc in scenes {
        let rs: Vec<&Row> = rows.iter().filter(|r| r.scene == sc).collect();
        let groups: Vec<String> = rs
            .iter()
            .map(|r| {
                let bvh = if r.objects == "bvh" { "+BVH" } else { "" };
                format!(
                    "{}/{} {}{bvh}",
                    r.branching,
                    r.levels,
                    r.engine.to_uppercase()
                )
            })
            .collect();
        // Series: every level present, top first, then the final ray–triangle tests.
        let mut levels: Vec<u32> = rs
            .iter()
            .flat_map(|r| r.stats.levels.rows().into_iter().map(|row| row.level))
            .collect();
        levels.sort_unstable_by(|a, b| b.cmp(a));
        levels.dedup();
        let mut series: Vec<String> = levels.iter().map(|l| format!("level {l}")).collect();
        series.push("final".into());
        let ray_box = trace::RAY_BOX_TESTS;
        if rs.iter().any(|r| r.stats.counters.contains(ray_box)) {
            series.push(ray_box.to_string());
        }
        let values: Vec<Vec<f64>> = series
            .iter()
            .map(|name| {
                rs.iter()
                    .map(|r| match name.strip_prefix("level ") {
                        Some(l) => {
                            let l: u32 = l.parse().unwrap_or(0);
                            r.stats
                                .levels
                                .rows()
                                .iter()
                                .filter(|row| row.level == l)
                                .map(|row| row.tests)
                                .sum::<u64>() as f64
                        }
                        None if name == ray_box.name() => {
                            r.stats.counters.get(ray_box).unwrap_or(0) as f64
                        }
                        None => r.stats.ray_tri_tests as f64,
                    })
                    .collect()
            })
            .collect();
        let title = format!("{sc}: intersection tests per level");
        files.extend(super::charts::grouped_bars(
            &dir.join(format!("rsh-levels-{}", super::charts::slug(sc))),
            &super::charts::Bars {
                title: &title,
                y_label: "tests",
                groups: &groups,
                series: &series,
                values: &values,
                log_y: true,
            },
        )?);
    }
    Ok(files)
}
