//! `rayspace bench grid`: the irregular-grid paper's evaluation (Pérard-Gayot et al. 2017,
//! §5) on our engines and the peers, all on the same rays in one process.
//!
//! - Table 1: N_T (traversal steps) and N_I (triangle tests) per primary ray after each
//!   build stage (initial cells, + merge, + merge + expansion).
//! - Table 2: build time and memory over a range of densities (λ₁, λ₂), irregular grid and
//!   two-level grid, with the peers' build times.
//! - Table 3: MRays/s for primary, ambient-occlusion (any hit) and random rays, for the
//!   irregular grid, the two-level grid, obvhs (CWBVH, BVH2) and Embree (with the feature),
//!   as ratios to each peer.
//! - Table 5: merge (M) and expansion (E) applied to a uniform grid (λ = 5), and the paper's
//!   other baseline there, Devillers's macro regions: as the paper describes them (§6),
//!   merge and expansion applied to the *empty* cells only (`GridConfig::empty_only`).
//!
//! Every engine's records are checked against the irregular grid's (itself equal to brute
//! force's, by the test suite) with [`accel::oracle::Agreement`]; disagreements are reported.
//! Timings are the best of `repeats` runs, engines interleaved within each repeat so that
//! machine noise hits all of them alike.

use crate::engines::config::describe;
use crate::engines::{Config, Engine};
use accel::grid::{build_grid, GridConfig, GridEngine};
use accel::oracle::Agreement;
use accel::peers::{BvhKind, ObvhsEngine};
use anyhow::Result;
use render::raygen::{generate, Kind, Options};
use render::View;
use scene::{Geometry, LoadOptions};
use serde::Serialize;
use std::time::Instant;
use trace::{Hit, RayBatch, TraceMode, TraceStats, Tracer};

pub struct Spec {
    pub scenes: Vec<String>,
    pub width: u32,
    pub height: u32,
    /// AO rays per pixel.
    pub ao_spp: u32,
    pub seed: u64,
    pub repeats: u32,
}

/// One engine on one ray kind (Table 3).
#[derive(Serialize, Clone, Debug)]
pub struct PerfRow {
    pub scene: String,
    pub triangles: u64,
    pub engine: String,
    pub kind: String,
    pub rays: u64,
    pub seconds: f64,
    pub mrays_per_s: f64,
    /// Traversal steps per ray (engines that count them).
    pub n_t: Option<f64>,
    /// Ray–triangle tests per ray (engines that count them).
    pub n_i: Option<f64>,
    pub build_seconds: f64,
    pub memory_bytes: Option<u64>,
    /// Records that disagree with the irregular grid's beyond edge and coincidence cases.
    pub wrong: u64,
    pub at_edges: u64,
    pub coincident: u64,
}

/// One grid build (Tables 1, 2 and 5).
#[derive(Serialize, Clone, Debug)]
pub struct GridRow {
    pub scene: String,
    pub table: String,
    pub variant: String,
    pub top_density: f32,
    pub leaf_density: f32,
    pub cells: u64,
    pub references: u64,
    pub resolution: [u32; 3],
    pub build_seconds: f64,
    pub memory_bytes: u64,
    pub n_t: f64,
    pub n_i: f64,
    pub mrays_per_s: f64,
    /// Seconds per build pass (top references, octrees, cells and voxel map, merge,
    /// expansion), as `GridConfig` runs them.
    pub passes: Vec<(String, f64)>,
}

pub struct Report {
    pub perf: Vec<PerfRow>,
    pub grids: Vec<GridRow>,
    pub markdown: String,
}

/// An engine of Table 3 with its build seconds and memory (where known).
type Built = (Box<dyn Tracer>, f64, Option<u64>);

/// The engines of Table 3 that exist in this build.
fn engines(geo: &Geometry) -> Result<Vec<Built>> {
    let mut v: Vec<Built> = Vec::new();
    for cfg in [GridConfig::default(), GridConfig::two_level()] {
        let t0 = Instant::now();
        let g = GridEngine::new(geo, &cfg).map_err(anyhow::Error::msg)?;
        let s = t0.elapsed().as_secs_f64();
        let (c, r, m) = g.grid.memory();
        v.push((Box::new(g), s, Some((c + r + m) as u64)));
    }
    // Our object-tree walk beside the peers' trees.
    let t0 = Instant::now();
    let b = accel::BvhEngine::new(geo, accel::BvhConfig::default()).map_err(anyhow::Error::msg)?;
    let s = t0.elapsed().as_secs_f64();
    let m = b.structure_bytes();
    v.push((Box::new(b), s, m));
    for kind in [BvhKind::CwBvh, BvhKind::Bvh2] {
        let e = ObvhsEngine::new(geo, kind);
        let (s, m) = (e.build_seconds, e.memory_bytes() as u64);
        v.push((Box::new(e), s, Some(m)));
    }
    #[cfg(feature = "embree")]
    for mode in [
        accel::peers::EmbreeMode::Single,
        accel::peers::EmbreeMode::Stream,
    ] {
        let e = accel::peers::EmbreeEngine::new(geo, mode).map_err(anyhow::Error::msg)?;
        let s = e.build_seconds;
        v.push((Box::new(e), s, None));
    }
    Ok(v)
}

/// Trace `rays` with every engine `repeats` times, interleaved; the best time of each.
pub(crate) fn time_all(
    engines: &[&dyn Tracer],
    rays: &RayBatch,
    mode: TraceMode,
    repeats: u32,
) -> Vec<(f64, TraceStats, Vec<Hit>)> {
    let mut out: Vec<(f64, TraceStats, Vec<Hit>)> = engines
        .iter()
        .map(|_| (f64::INFINITY, TraceStats::default(), Vec::new()))
        .collect();
    for _ in 0..repeats.max(1) {
        for (e, o) in engines.iter().zip(out.iter_mut()) {
            let mut hits = vec![Hit::MISS; rays.len()];
            let mut st = TraceStats::default();
            let t0 = Instant::now();
            e.trace(rays, mode, &mut hits, &mut st);
            let s = t0.elapsed().as_secs_f64();
            if s < o.0 {
                *o = (s, st, hits);
            }
        }
    }
    out
}

fn per_ray(st: &TraceStats, n: usize) -> (f64, f64) {
    let n = n.max(1) as f64;
    (
        st.counters.get(accel::grid::TRAVERSAL_STEPS).unwrap_or(0) as f64 / n,
        st.ray_tri_tests as f64 / n,
    )
}

/// Build `cfg` and trace `rays` (closest hit): one row.
fn grid_row(
    geo: &Geometry,
    scene: &str,
    table: &str,
    variant: &str,
    cfg: &GridConfig,
    rays: &RayBatch,
    repeats: u32,
) -> Result<GridRow> {
    let t0 = Instant::now();
    let grid = build_grid(&geo.tris, cfg).map_err(anyhow::Error::msg)?;
    let build = t0.elapsed().as_secs_f64();
    let e = GridEngine {
        grid,
        tris: geo.tris.clone(),
        name: "grid",
    };
    let r = time_all(&[&e], rays, TraceMode::Closest, repeats).remove(0);
    let (n_t, n_i) = per_ray(&r.1, rays.len());
    let (c, rf, m) = e.grid.memory();
    Ok(GridRow {
        scene: scene.to_string(),
        table: table.to_string(),
        variant: variant.to_string(),
        top_density: cfg.top_density,
        leaf_density: cfg.leaf_density,
        cells: e.grid.cells() as u64,
        references: e.grid.refs.len() as u64,
        resolution: e.grid.dims,
        build_seconds: build,
        memory_bytes: (c + rf + m) as u64,
        n_t,
        n_i,
        mrays_per_s: rays.len() as f64 / r.0 / 1e6,
        passes: e
            .build_passes()
            .iter()
            .map(|p| (p.name(), p.seconds))
            .collect(),
    })
}

fn mb(b: u64) -> f64 {
    b as f64 / (1024.0 * 1024.0)
}

/// Run the whole evaluation; `progress(msg)` is called before each step (`STEPS_PER_SCENE` per scene).
pub fn run(spec: &Spec, progress: &dyn Fn(&str)) -> Result<Report> {
    let mut perf = Vec::new();
    let mut grids = Vec::new();
    let mut md = String::new();
    for name in &spec.scenes {
        progress(&format!("{name}: loading, making rays"));
        let s = scene::load(name, &LoadOptions::default())?;
        let geo = Geometry::from_scene(&s);
        let opts = Options {
            width: spec.width,
            height: spec.height,
            spp: spec.ao_spp,
            seed: spec.seed,
            ao_distance: None,
        };
        let primary = View::new(&s.camera, spec.width, spec.height).primary_rays();
        let kinds = [
            ("primary", primary.clone(), TraceMode::Closest),
            ("ao", generate(&s, &geo, Kind::Ao, &opts), TraceMode::Any),
            (
                "random",
                generate(&s, &geo, Kind::Random, &Options { spp: 1, ..opts }),
                TraceMode::Closest,
            ),
        ];
        md += &format!(
            "\n## {} — {} triangles; {}×{} primary rays, {} AO rays ({} spp, any hit), {} random rays\n",
            s.name,
            geo.len(),
            spec.width,
            spec.height,
            kinds[1].1.len(),
            spec.ao_spp,
            kinds[2].1.len()
        );

        // Table 1: build stages.
        progress(&format!("{}: Table 1 (build stages)", s.name));
        md += "\n### Table 1: N_T and N_I per primary ray after each build stage\n\n| stage | cells | references | N_T | N_I | MRays/s | build ms |\n|---|---:|---:|---:|---:|---:|---:|\n";
        let stages = GridConfig::stages();
        for (v, cfg) in &stages {
            let r = grid_row(&geo, &s.name, "1", v, cfg, &primary, spec.repeats)?;
            md += &format!(
                "| {v} | {} | {} | {:.2} | {:.2} | {:.2} | {:.0} |\n",
                r.cells,
                r.references,
                r.n_t,
                r.n_i,
                r.mrays_per_s,
                r.build_seconds * 1e3
            );
            grids.push(r);
        }

        // Table 3: every engine on every ray kind.
        progress(&format!("{}: building the engines and peers", s.name));
        let built = engines(&geo)?;
        let refs: Vec<&dyn Tracer> = built.iter().map(|b| b.0.as_ref()).collect();
        let mut rows: Vec<PerfRow> = Vec::new();
        for (kind, rays, mode) in &kinds {
            progress(&format!("{}: Table 3, {kind} rays", s.name));
            let res = time_all(&refs, rays, *mode, spec.repeats);
            let reference = &res[0].2;
            for ((e, build, mem), (secs, st, hits)) in built.iter().zip(&res) {
                let mut a = Agreement::default();
                a.check(&geo.tris, rays, *mode, reference, hits, 1e-4);
                let counted = st.ray_tri_tests > 0 || rays.is_empty();
                let (n_t, n_i) = per_ray(st, rays.len());
                rows.push(PerfRow {
                    scene: s.name.clone(),
                    triangles: geo.len() as u64,
                    engine: e.name().to_string(),
                    kind: kind.to_string(),
                    rays: rays.len() as u64,
                    seconds: *secs,
                    mrays_per_s: rays.len() as f64 / secs / 1e6,
                    n_t: st
                        .counters
                        .contains(accel::grid::TRAVERSAL_STEPS)
                        .then_some(n_t),
                    n_i: counted.then_some(n_i),
                    build_seconds: *build,
                    memory_bytes: *mem,
                    wrong: a.wrong,
                    at_edges: a.at_edges,
                    coincident: a.coincident,
                });
            }
        }
        md += "\n### Table 3: MRays/s (best of ";
        md += &format!(
            "{}; ratio = irregular grid / engine, same run)\n\n| engine |",
            spec.repeats
        );
        for (k, _, _) in &kinds {
            md += &format!(" {k} MRays/s | grid ÷ it |");
        }
        md +=
            " N_I primary | build ms | memory MB | disagreements (edge/coincident/wrong) |\n|---|";
        md += &"---:|".repeat(2 * kinds.len() + 4);
        md += "\n";
        for (ei, (e, build, mem)) in built.iter().enumerate() {
            md += &format!("| {} |", e.name());
            let (mut edge, mut coinc, mut wrong) = (0, 0, 0);
            for ki in 0..kinds.len() {
                let r = &rows[ki * built.len() + ei];
                let g = &rows[ki * built.len()];
                md += &format!(
                    " {:.2} | {:.2} |",
                    r.mrays_per_s,
                    g.mrays_per_s / r.mrays_per_s
                );
                edge += r.at_edges;
                coinc += r.coincident;
                wrong += r.wrong;
            }
            let p = &rows[ei];
            md += &format!(
                " {} | {:.0} | {} | {edge}/{coinc}/{wrong} |\n",
                p.n_i
                    .map(|x| format!("{x:.2}"))
                    .unwrap_or_else(|| "—".into()),
                build * 1e3,
                mem.map(|m| format!("{:.1}", mb(m)))
                    .unwrap_or_else(|| "—".into()),
            );
        }
        md += &format!(
            "\nAs run: {}; {}; {}; the peers with their own defaults.\n",
            describe(Engine::Grid, &Config::of(Engine::Grid)),
            describe(Engine::Grid2l, &Config::of(Engine::Grid2l)),
            describe(Engine::Bvh, &Config::of(Engine::Bvh)),
        );
        perf.extend(rows);

        // Table 2: densities.
        progress(&format!("{}: Table 2 (densities)", s.name));
        md += "\n### Table 2: build time, memory and primary-ray traversal over densities\n\n| structure | λ₁ | λ₂ | cells | build ms | memory MB | N_T | N_I | MRays/s |\n|---|---:|---:|---:|---:|---:|---:|---:|---:|\n";
        for (l1, l2) in [(0.012f32, 0.24f32), (0.04, 0.8), (0.12, 2.4)] {
            for (v, base) in [
                ("irregular grid", GridConfig::default()),
                ("two-level grid", GridConfig::two_level()),
            ] {
                let cfg = GridConfig {
                    top_density: l1,
                    leaf_density: l2,
                    ..base
                };
                let r = grid_row(&geo, &s.name, "2", v, &cfg, &primary, spec.repeats)?;
                md += &format!(
                    "| {v} | {l1} | {l2} | {} | {:.0} | {:.2} | {:.2} | {:.2} | {:.2} |\n",
                    r.cells,
                    r.build_seconds * 1e3,
                    mb(r.memory_bytes),
                    r.n_t,
                    r.n_i,
                    r.mrays_per_s
                );
                grids.push(r);
            }
        }

        // Table 5: merge and expansion on a uniform grid.
        progress(&format!("{}: Table 5 (uniform-grid ablation)", s.name));
        md += "\n### Table 5: merge (M) and expansion (E) on a uniform grid (λ = 5), primary rays\n\n| variant | resolution | cells | MRays/s | vs uniform | memory MB | N_T | N_I |\n|---|---|---:|---:|---:|---:|---:|---:|\n";
        let uniform = GridConfig {
            top_density: 5.0,
            max_depth: 0,
            merge: false,
            expansion_passes: 0,
            ..Default::default()
        };
        let mut base_mrays = 0.0;
        for (v, merge, passes, empty_only) in [
            ("uniform", false, 0, false),
            ("macro regions (Devillers)", true, 3, true),
            ("M", true, 0, false),
            ("E", false, 3, false),
            ("M + E", true, 3, false),
        ] {
            let cfg = GridConfig {
                merge,
                expansion_passes: passes,
                empty_only,
                ..uniform.clone()
            };
            let r = grid_row(&geo, &s.name, "5", v, &cfg, &primary, spec.repeats)?;
            if v == "uniform" {
                base_mrays = r.mrays_per_s;
            }
            md += &format!(
                "| {v} | {}×{}×{} | {} | {:.2} | {:+.0} % | {:.2} | {:.2} | {:.2} |\n",
                r.resolution[0],
                r.resolution[1],
                r.resolution[2],
                r.cells,
                r.mrays_per_s,
                100.0 * (r.mrays_per_s / base_mrays - 1.0),
                mb(r.memory_bytes),
                r.n_t,
                r.n_i
            );
            grids.push(r);
        }
    }
    Ok(Report {
        perf,
        grids,
        markdown: md,
    })
}

/// Progress steps [`run`] reports per scene.
pub const STEPS_PER_SCENE: u64 = 8;

pub fn perf_csv(rows: &[PerfRow]) -> String {
    let mut s = String::from("scene,triangles,engine,kind,rays,seconds,mrays_per_s,n_t,n_i,build_seconds,memory_bytes,wrong,at_edges,coincident\n");
    let opt = |x: Option<f64>| x.map(|v| format!("{v:.4}")).unwrap_or_default();
    for r in rows {
        s += &format!(
            "{},{},{},{},{},{:.6},{:.4},{},{},{:.6},{},{},{},{}\n",
            r.scene,
            r.triangles,
            r.engine,
            r.kind,
            r.rays,
            r.seconds,
            r.mrays_per_s,
            opt(r.n_t),
            opt(r.n_i),
            r.build_seconds,
            r.memory_bytes.map(|m| m.to_string()).unwrap_or_default(),
            r.wrong,
            r.at_edges,
            r.coincident
        );
    }
    s
}

pub fn grid_csv(rows: &[GridRow]) -> String {
    let mut s = String::from("scene,table,variant,top_density,leaf_density,cells,references,res_x,res_y,res_z,build_seconds,memory_bytes,n_t,n_i,mrays_per_s,top_refs_seconds,octrees_seconds,cells_seconds,merge_seconds,expansion_seconds\n");
    for r in rows {
        let pass = |name: &str| {
            r.passes
                .iter()
                .find(|p| p.0 == name)
                .map(|p| p.1)
                .unwrap_or(0.0)
        };
        s += &format!(
            "{},{},{},{},{},{},{},{},{},{},{:.6},{},{:.4},{:.4},{:.4},{:.6},{:.6},{:.6},{:.6},{:.6}\n",
            r.scene,
            r.table,
            r.variant,
            r.top_density,
            r.leaf_density,
            r.cells,
            r.references,
            r.resolution[0],
            r.resolution[1],
            r.resolution[2],
            r.build_seconds,
            r.memory_bytes,
            r.n_t,
            r.n_i,
            r.mrays_per_s,
            pass("top_refs"),
            pass("octrees"),
            pass("cells"),
            pass("merge"),
            pass("expansion")
        );
    }
    s
}

/// One chart per scene: MRays/s by ray kind (groups) and engine (bars).
pub fn charts(rows: &[PerfRow], dir: &std::path::Path) -> Result<Vec<std::path::PathBuf>> {
    let mut files = Vec::new();
    let mut scenes: Vec<&str> = rows.iter().map(|r| r.scene.as_str()).collect();
    scenes.dedup();
    for sc in scenes {
        let rs: Vec<&PerfRow> = rows.iter().filter(|r| r.scene == sc).collect();
        let mut kinds: Vec<String> = rs.iter().map(|r| r.kind.clone()).collect();
        kinds.dedup();
        let mut engines: Vec<String> = Vec::new();
        for r in &rs {
            if !engines.contains(&r.engine) {
                engines.push(r.engine.clone());
            }
        }
        let values: Vec<Vec<f64>> = engines
            .iter()
            .map(|e| {
                kinds
                    .iter()
                    .map(|k| {
                        rs.iter()
                            .find(|r| &r.engine == e && &r.kind == k)
                            .map_or(0.0, |r| r.mrays_per_s)
                    })
                    .collect()
            })
            .collect();
        let title = format!("{sc}: MRays/s by ray kind");
        files.extend(super::charts::grouped_bars(
            &dir.join(format!("grid-mrays-{}", super::charts::slug(sc))),
            &super::charts::Bars {
                title: &title,
                y_label: "MRays/s",
                groups: &kinds,
                series: &engines,
                values: &values,
                log_y: false,
            },
        )?);
    }
    Ok(files)
}
