//! `rayspace report`: every reproduction on one static page.
//!
//! One run renders each scene with every engine (with the difference to a reference engine
//! and thumbnails of where each ray kind was traced), runs the thesis's chapter-4 benchmark
//! ([`crate::bench::rsh`], Tables 4.4–4.24) and the irregular-grid paper's
//! ([`crate::bench::grid`], Tables 1, 2, 3, 5), measures how each engine's frame cost grows
//! with the triangle count and the pixel count (the [`scene::builtin::spheres_family`]
//! family, log-log with fitted slopes), and writes `index.html` (self-contained: images and
//! SVG charts beside it, no script, no network) with `report.json` holding every number the
//! page shows. The published figures ([`published`]) sit in adjacent columns with the ratio.

pub mod html;
pub mod published;
pub mod ray_hierarchy;

use crate::bench::{self, charts};
use crate::engines::{Backend, Config, Engine};
use crate::runner::Runner;
use anyhow::{anyhow, Context, Result};
use render::whitted::RenderOptions;
use scene::{Geometry, LoadOptions, Scene};
use serde::Serialize;
use std::path::{Path, PathBuf};
use std::time::Instant;
use trace::RayKind;

/// What a report covers.
pub struct Spec {
    /// Scenes rendered (built-in names or files).
    pub scenes: Vec<String>,
    /// Scenes of the thesis benchmark and of the grid paper's.
    pub rsh_scenes: Vec<String>,
    pub grid_scenes: Vec<String>,
    /// The small version (CI): small images, one timing run, short scaling series.
    pub quick: bool,
    /// Image side of renders and benchmarks.
    pub side: u32,
    /// Reflection/refraction generations of the renders.
    pub bounces: u32,
    /// Output directory (made if missing).
    pub out: PathBuf,
}

impl Spec {
    /// The default report: built-in scenes plus the papers' real scenes when the shared
    /// scenes are present; `--quick` keeps to small built-ins.
    pub fn new(scenes: Option<&str>, quick: bool, side: Option<u32>, out: PathBuf) -> Result<Spec> {
        let side = side.unwrap_or(if quick { 128 } else { 512 });
        let (renders, rsh, grid) = if quick {
            (
                bench::scenes(scenes, &["cornell", "spheres"], &[])?,
                bench::scenes(scenes, &["cornell", "office"], &[])?,
                bench::scenes(scenes, &["cornell"], &[])?,
            )
        } else {
            (
                bench::scenes(
                    scenes,
                    &["cornell", "spheres", "office"],
                    &["sponza", "conference", "kitchen"],
                )?,
                bench::scenes(scenes, &["cornell", "office"], &["sponza"])?,
                bench::scenes(
                    scenes,
                    &["cornell", "office", "stadium"],
                    &["sponza", "conference", "kitchen"],
                )?,
            )
        };
        Ok(Spec {
            scenes: renders,
            rsh_scenes: rsh,
            grid_scenes: grid,
            quick,
            side,
            bounces: 2,
            out,
        })
    }

    /// The scaling series: (family levels, image side) for the triangle axis and (family
    /// level, image sides) for the pixel axis.
    fn scaling(&self) -> ((Vec<u32>, u32), (u32, Vec<u32>)) {
        if self.quick {
            ((vec![1, 2, 3], 64), (2, vec![32, 64, 128]))
        } else {
            (
                (vec![1, 2, 3, 4, 5, 6], 256),
                (3, vec![128, 256, 512, 1024, 2048]),
            )
        }
    }

    /// The generated scenes' sweep (`bench scale`): the irregular-grid paper's scene classes
    /// from 10 k to 1 M triangles (quick: two small sizes of two classes, two engines), every
    /// report engine but RAH (its bundles on random rays cost minutes at 1 M triangles and
    /// add nothing the other engines do not show), brute force at the smallest size only.
    pub fn generated(&self) -> bench::scale::Spec {
        let (generators, sizes, engines, side) = if self.quick {
            (
                vec!["hairball", "city"],
                vec![2_000, 8_000],
                vec![Engine::Bvh, Engine::Crsh, Engine::Grid],
                64,
            )
        } else {
            let mut e = engine_list();
            e.retain(|&x| x != Engine::Rah);
            (
                vec!["hairball", "city", "nested"],
                vec![10_000, 100_000, 1_000_000],
                e,
                256,
            )
        };
        let mut engines = engines;
        engines.push(Engine::Brute);
        bench::scale::Spec {
            generators: generators.into_iter().map(String::from).collect(),
            // The generators make about the size asked for (±10 %).
            brute_max: sizes[0] + sizes[0] / 5,
            sizes,
            engines,
            width: side,
            height: side,
            seed: 1,
            repeats: 1,
        }
    }

    /// Steps `progress` is called with, for a progress bar.
    pub fn steps(&self) -> u64 {
        let ((levels, _), (_, sides)) = self.scaling();
        (self.scenes.len() * (engine_list().len() + 2)
            + self.rsh_scenes.len() * 6 * 4
            + self.grid_scenes.len() * crate::bench::grid::STEPS_PER_SCENE as usize
            + (levels.len() + sides.len()) * engine_list().len()) as u64
            + bench::scale::steps(&self.generated())
    }
}

/// The engines a report renders with and scales (brute force is added per scene where it
/// is affordable; its tests are counted, never timed, in the scaling curves).
pub fn engine_list() -> Vec<Engine> {
    let mut v = vec![
        Engine::Bvh,
        Engine::Crsh,
        Engine::Rah,
        Engine::Grid,
        Engine::ObvhsCwbvh,
    ];
    if cfg!(feature = "embree") {
        v.push(Engine::Embree);
    }
    v
}

/// Engines whose tests are counted: CRSH and RAH count all of theirs (node and triangle
/// tests), `bvh` its ray–box and ray–triangle tests, the grid its ray–triangle tests (its
/// traversal steps visit cells, they test nothing); the peers count only the triangle tests
/// of our kernel at their leaves, without their box tests, so they are left out rather than
/// shown as cheaper than they are.
fn counts_tests(e: Engine) -> bool {
    matches!(
        e,
        Engine::Bvh | Engine::Crsh | Engine::Rah | Engine::Grid | Engine::Brute
    )
}

#[derive(Serialize, Clone, Debug)]
pub struct RenderRow {
    pub engine: String,
    /// Ours (bit-identical hits to brute force, so identical pixels) rather than a peer
    /// (equal within the peers' stated tolerance: a ray on an edge shared by two triangles
    /// may report the other one, and its shading may differ).
    pub exact: bool,
    /// Relative to the report's directory.
    pub image: String,
    /// |engine − reference| × 8 per channel; `None` for the reference itself.
    pub diff_image: Option<String>,
    pub build_ms: f64,
    pub render_ms: f64,
    pub rays: u64,
    pub total_tests: u64,
    /// Pixels whose 8-bit colour differs from the reference's.
    pub differing_pixels: u64,
    pub max_channel_difference: u8,
}

#[derive(Serialize, Clone, Debug)]
pub struct KindThumb {
    pub kind: String,
    pub image: String,
    pub rays: u64,
}

#[derive(Serialize, Clone, Debug)]
pub struct SceneReport {
    pub name: String,
    /// The scene's section id and image name prefix: its name's slug, made unique among the
    /// report's scenes (two files of the same name in different folders get `-2`, `-3`).
    pub id: String,
    pub source: String,
    pub triangles: u64,
    pub width: u32,
    pub height: u32,
    pub bounces: u32,
    /// The engine the others are compared with (brute force where affordable).
    pub reference: String,
    pub renders: Vec<RenderRow>,
    pub ray_kinds: Vec<KindThumb>,
    /// Engines not run on this scene, and why.
    pub skipped: Vec<(String, String)>,
}

#[derive(Serialize, Clone, Debug)]
pub struct ScalePoint {
    pub engine: String,
    pub scene: String,
    pub triangles: u64,
    pub pixels: u64,
    pub rays: u64,
    /// Build + render (raster, all traced generations, shading).
    pub frame_seconds: f64,
    pub build_seconds: f64,
    /// `None` where the engine does not count all of its tests.
    pub total_tests: Option<u64>,
}

#[derive(Serialize, Clone, Debug)]
pub struct Slope {
    /// `triangles` or `pixels`.
    pub axis: String,
    /// `seconds` or `tests`.
    pub measure: String,
    pub engine: String,
    pub slope: f64,
}

#[derive(Serialize, Clone, Debug, Default)]
pub struct Scaling {
    pub triangles: Vec<ScalePoint>,
    pub pixels: Vec<ScalePoint>,
    pub slopes: Vec<Slope>,
}

/// Everything the page shows (written as `report.json`).
#[derive(Serialize)]
pub struct Report {
    pub provenance: String,
    pub commit: String,
    pub quick: bool,
    pub side: u32,
    pub scenes: Vec<SceneReport>,
    pub rsh: Vec<bench::rsh::Row>,
    /// "When does a ray-space hierarchy pay?" ([`ray_hierarchy`]).
    pub ray_hierarchy: ray_hierarchy::RayHierarchy,
    pub grid_perf: Vec<bench::grid::PerfRow>,
    pub grid_builds: Vec<bench::grid::GridRow>,
    pub scaling: Scaling,
    /// The generated scenes' sweep ([`Spec::generated`], `bench scale`'s rows and slopes;
    /// no peak memory: `bench scale` measures it in child processes).
    pub generated: Vec<bench::scale::Row>,
    pub generated_slopes: Vec<bench::scale::Slope>,
    /// Chart files by section (relative paths), empty where charts could not be drawn.
    pub charts: Vec<(String, String)>,
    /// Why charts are missing, if they are (no usable font).
    pub charts_note: Option<String>,
    pub seconds: f64,
}

fn write(dir: &Path, rel: &str, bytes: &[u8]) -> Result<String> {
    render::output::write_atomic(&dir.join(rel), bytes).map_err(|e| anyhow!("report: {e}"))?;
    Ok(rel.to_string())
}

fn png(dir: &Path, rel: &str, rgb: &[u8], w: u32, h: u32) -> Result<String> {
    let bytes = render::output::rgb8_png(rgb, w, h).map_err(|e| anyhow!("{rel}: {e}"))?;
    write(dir, rel, &bytes)
}

/// The engines a scene is rendered with, the reference first: brute force where it is
/// affordable, else the grid (bit-identical to brute force by the test suite).
fn render_list(brute_affordable: bool) -> Vec<Engine> {
    let mut list = engine_list();
    list.retain(|&e| e != Engine::Grid);
    list.insert(0, Engine::Grid);
    if brute_affordable {
        list.insert(0, Engine::Brute);
    }
    list
}

/// Brute force is rendered where rays × triangles stays small (a few seconds on 2 cores).
fn brute_affordable(geo: &Geometry, s: &Scene, side: u32, bounces: u32) -> bool {
    let rays = side as u64 * side as u64 * (s.lights.len() as u64 + bounces as u64);
    rays * geo.len() as u64 <= 4_000_000_000
}

fn render_scene(
    spec: &Spec,
    name: &str,
    progress: &dyn Fn(&str),
    unique: impl Fn(&str) -> String,
) -> Result<SceneReport> {
    let dir = &spec.out;
    progress(&format!("{name}: loading"));
    let s = scene::load(name, &LoadOptions::default())?;
    let geo = Geometry::from_scene(&s);
    // Memory is checked before the renders allocate it, as `render` does.
    let need = render::whitted::render_bytes(spec.side, spec.side, s.lights.len());
    let limit = trace::memory::limit(None);
    if need > limit {
        anyhow::bail!(
            "`size`={}: a render of {} needs {}, more than the {} this machine allows",
            spec.side,
            s.name,
            trace::memory::gib(need),
            trace::memory::gib(limit)
        );
    }
    let slug = unique(&charts::slug(&s.name));
    let opts = RenderOptions {
        width: spec.side,
        height: spec.side,
        bounces: spec.bounces,
        spp: 1,
    };
    let affordable = brute_affordable(&geo, &s, spec.side, spec.bounces);
    let list = render_list(affordable);
    let mut skipped = Vec::new();
    if !affordable {
        skipped.push((
            "brute".to_string(),
            format!(
                "{} triangles × ~{} rays is too many tests for a report; the grid (bit-identical to brute force by the test suite) is the reference",
                geo.len(),
                spec.side as u64 * spec.side as u64 * (s.lights.len() as u64 + spec.bounces as u64)
            ),
        ));
    }
    let reference = list[0];
    let mut renders = Vec::new();
    let mut ref_rgb: Vec<u8> = Vec::new();
    let mut ray_kinds = Vec::new();
    for &e in &list {
        progress(&format!("{}: {}", s.name, e.name()));
        // The frame as every front end makes it, recording the engine's batches.
        let f = Runner::new(e, Config::of(e), Backend::Cpu)
            .record(true)
            .with_geometry(geo.clone())
            .frame(&s, None, 0, &opts, &())?;
        let (build_ms, render_ms) = (f.row.build_ms, f.row.render_ms);
        let out = f.rendered;
        let rgb = render::output::to_rgb8(&out.pixels, spec.side, spec.side).into_raw();
        let image = png(
            dir,
            &format!("img/{slug}-{}.png", e.name()),
            &rgb,
            spec.side,
            spec.side,
        )?;
        let batches = f.batches;
        let (mut diff_image, mut differing, mut max_d) = (None, 0u64, 0u8);
        if e == reference {
            ref_rgb = rgb.clone();
            // Where each ray kind was traced: rays per pixel, one heat map per kind.
            let npix = spec.side as usize * spec.side as usize;
            for kind in RayKind::ALL {
                let mut counts = vec![0u32; npix];
                let mut n = 0u64;
                for (b, _, _) in &batches {
                    for (k, &p) in b.kind.iter().zip(&b.pixel) {
                        if *k == kind as u8 && (p as usize) < npix {
                            counts[p as usize] += 1;
                            n += 1;
                        }
                    }
                }
                if n == 0 {
                    continue; // primaries are rasterized, not traced
                }
                let rel = format!("img/{slug}-rays-{}.png", charts::slug(kind.name()));
                ray_kinds.push(KindThumb {
                    kind: kind.name().to_string(),
                    image: png(
                        dir,
                        &rel,
                        &render::output::heat_rgb8(&counts),
                        spec.side,
                        spec.side,
                    )?,
                    rays: n,
                });
            }
        } else {
            let d: Vec<u8> = rgb
                .iter()
                .zip(&ref_rgb)
                .map(|(a, b)| a.abs_diff(*b))
                .collect();
            for px in d.chunks_exact(3) {
                let m = px.iter().copied().max().unwrap_or(0);
                differing += (m > 0) as u64;
                max_d = max_d.max(m);
            }
            let amplified: Vec<u8> = d.iter().map(|v| v.saturating_mul(8)).collect();
            diff_image = Some(png(
                dir,
                &format!("img/{slug}-diff-{}.png", e.name()),
                &amplified,
                spec.side,
                spec.side,
            )?);
        }
        renders.push(RenderRow {
            engine: e.name().to_string(),
            exact: !matches!(
                e,
                Engine::ObvhsCwbvh | Engine::ObvhsBvh2 | Engine::Embree | Engine::EmbreeStream
            ),
            image,
            diff_image,
            build_ms,
            render_ms,
            rays: out.stats.rays_traced(),
            total_tests: out.stats.trace.total_tests(),
            differing_pixels: differing,
            max_channel_difference: max_d,
        });
    }
    Ok(SceneReport {
        name: s.name.clone(),
        id: slug.clone(),
        source: name.to_string(),
        triangles: geo.len() as u64,
        width: spec.side,
        height: spec.side,
        bounces: spec.bounces,
        reference: reference.name().to_string(),
        renders,
        ray_kinds,
        skipped,
    })
}

/// One frame (build + render) of `engine` on `s` at `side`².
fn frame_point(s: &Scene, geo: &Geometry, e: Engine, side: u32) -> Result<ScalePoint> {
    let f = Runner::new(e, Config::of(e), Backend::Cpu)
        .with_geometry(geo.clone())
        .frame(
            s,
            None,
            0,
            &RenderOptions {
                width: side,
                height: side,
                bounces: 1,
                spp: 1,
            },
            &(),
        )?;
    let build_seconds = f.row.build_ms / 1e3;
    let frame_seconds = (f.row.update_ms + f.row.build_ms + f.row.render_ms) / 1e3;
    let out = f.rendered;
    Ok(ScalePoint {
        engine: e.name().to_string(),
        scene: s.name.clone(),
        triangles: geo.len() as u64,
        pixels: side as u64 * side as u64,
        rays: out.stats.rays_traced(),
        frame_seconds,
        build_seconds,
        total_tests: counts_tests(e).then(|| out.stats.trace.total_tests()),
    })
}

fn scaling(spec: &Spec, progress: &dyn Fn(&str)) -> Result<Scaling> {
    let ((levels, tri_side), (pix_level, sides)) = spec.scaling();
    let mut sc = Scaling::default();
    for &l in &levels {
        let s = scene::builtin::spheres_family(l);
        let geo = Geometry::from_scene(&s);
        for e in engine_list() {
            progress(&format!("scaling: {} triangles, {}", geo.len(), e.name()));
            sc.triangles.push(frame_point(&s, &geo, e, tri_side)?);
        }
    }
    let s = scene::builtin::spheres_family(pix_level);
    let geo = Geometry::from_scene(&s);
    for &side in &sides {
        for e in engine_list() {
            progress(&format!("scaling: {side}², {}", e.name()));
            sc.pixels.push(frame_point(&s, &geo, e, side)?);
        }
    }
    // Brute force's tests are counted (rays × triangles of the same frames), not traced.
    for axis in ["triangles", "pixels"] {
        let pts = if axis == "triangles" {
            &sc.triangles
        } else {
            &sc.pixels
        };
        let x = |p: &ScalePoint| {
            if axis == "triangles" {
                p.triangles as f64
            } else {
                p.pixels as f64
            }
        };
        let mut slopes = Vec::new();
        for (e, measure) in engine_list()
            .into_iter()
            .map(|e| (e.name().to_string(), "seconds"))
            .chain(
                engine_list()
                    .into_iter()
                    .filter(|e| counts_tests(*e))
                    .map(|e| (e.name().to_string(), "tests")),
            )
            .chain([("brute (counted)".to_string(), "tests")])
        {
            let p: Vec<(f64, f64)> = series(pts, &e, measure, x);
            if let Some(k) = charts::loglog_slope(&p) {
                slopes.push(Slope {
                    axis: axis.into(),
                    measure: measure.into(),
                    engine: e,
                    slope: k,
                });
            }
        }
        sc.slopes.extend(slopes);
    }
    Ok(sc)
}

/// The (x, y) points of one curve: an engine's frame seconds or tests; `brute (counted)`
/// is rays × triangles of the first engine's frames (every engine traces the same rays).
fn series(
    pts: &[ScalePoint],
    engine: &str,
    measure: &str,
    x: impl Fn(&ScalePoint) -> f64,
) -> Vec<(f64, f64)> {
    if engine == "brute (counted)" {
        let first = engine_list()[0].name();
        return pts
            .iter()
            .filter(|p| p.engine == first)
            .map(|p| (x(p), (p.rays * p.triangles) as f64))
            .collect();
    }
    pts.iter()
        .filter(|p| p.engine == engine)
        .filter_map(|p| {
            let y = if measure == "seconds" {
                Some(p.frame_seconds)
            } else {
                p.total_tests.map(|t| t as f64)
            };
            y.map(|y| (x(p), y))
        })
        .collect()
}

/// Draw every chart; the error (no font) is returned for the page to say.
fn draw_charts(r: &Report, spec: &Spec) -> Result<Vec<(String, String)>> {
    let cdir = spec.out.join("charts");
    let rel = |p: &PathBuf| -> Option<String> {
        let name = p.file_name()?.to_string_lossy();
        (p.extension()? == "svg").then(|| format!("charts/{name}"))
    };
    let mut out = Vec::new();
    for p in bench::rsh::charts(&r.rsh, &cdir)? {
        out.extend(rel(&p).map(|f| ("rsh-levels".to_string(), f)));
    }
    // Phase times of the first configuration per scene: one group per phase.
    let mut scenes: Vec<&str> = r.rsh.iter().map(|x| x.scene.as_str()).collect();
    scenes.dedup();
    for sc in scenes {
        let rows: Vec<&bench::rsh::Row> = r.rsh.iter().filter(|x| x.scene == sc).take(4).collect();
        let phases: Vec<trace::Phase> = crate::engines::phases()
            .into_iter()
            .filter(|p| rows.iter().any(|x| x.stats.phases.contains_key(p)))
            .collect();
        let groups: Vec<String> = phases.iter().map(|p| p.to_string()).collect();
        let series: Vec<String> = rows
            .iter()
            .map(|x| format!("{} {}", x.engine.to_uppercase(), x.objects))
            .collect();
        let values: Vec<Vec<f64>> = rows
            .iter()
            .map(|x| phases.iter().map(|p| x.stats.seconds(*p) * 1e3).collect())
            .collect();
        let (b, d) = rows.first().map_or((0, 0), |x| (x.branching, x.levels));
        let title = format!("{sc} {b}/{d}: trace phase times");
        for p in charts::grouped_bars(
            &cdir.join(format!("rsh-phases-{}", charts::slug(sc))),
            &charts::Bars {
                title: &title,
                y_label: "ms",
                groups: &groups,
                series: &series,
                values: &values,
                log_y: false,
            },
        )? {
            out.extend(rel(&p).map(|f| ("rsh-phases".to_string(), f)));
        }
    }
    for p in bench::grid::charts(&r.grid_perf, &cdir)? {
        out.extend(rel(&p).map(|f| ("grid-mrays".to_string(), f)));
    }
    for p in bench::scale::charts(&spec.generated(), &r.generated, &cdir)? {
        out.extend(rel(&p).map(|f| ("generated".to_string(), f)));
    }
    for axis in ["triangles", "pixels"] {
        let pts = if axis == "triangles" {
            &r.scaling.triangles
        } else {
            &r.scaling.pixels
        };
        let x = |p: &ScalePoint| {
            if axis == "triangles" {
                p.triangles as f64
            } else {
                p.pixels as f64
            }
        };
        for measure in ["seconds", "tests"] {
            let mut names: Vec<String> = engine_list()
                .into_iter()
                .filter(|e| measure == "seconds" || counts_tests(*e))
                .map(|e| e.name().to_string())
                .collect();
            if measure == "tests" {
                names.push("brute (counted)".into());
            }
            let curves: Vec<(String, Vec<(f64, f64)>)> = names
                .into_iter()
                .map(|n| {
                    let s = series(pts, &n, measure, x);
                    (n, s)
                })
                .collect();
            let title = format!(
                "{} against {}",
                if measure == "seconds" {
                    "frame time (build + render)"
                } else {
                    "intersection tests"
                },
                if axis == "triangles" {
                    "triangle count"
                } else {
                    "pixel count"
                }
            );
            for p in charts::loglog_lines(
                &cdir.join(format!("scaling-{measure}-{axis}")),
                &charts::Lines {
                    title: &title,
                    x_label: axis,
                    y_label: if measure == "seconds" {
                        "seconds"
                    } else {
                        "tests"
                    },
                    series: &curves,
                },
            )? {
                out.extend(rel(&p).map(|f| (format!("scaling-{measure}-{axis}"), f)));
            }
        }
    }
    Ok(out)
}

/// Run everything and write `spec.out/{index.html, report.json, img/, charts/}`.
pub fn run(spec: &Spec, progress: &dyn Fn(&str)) -> Result<Report> {
    let t0 = Instant::now();
    for sub in ["img", "charts"] {
        let d = spec.out.join(sub);
        std::fs::create_dir_all(&d).with_context(|| format!("`out`={}", d.display()))?;
    }
    let mut scenes: Vec<SceneReport> = Vec::new();
    for name in &spec.scenes {
        let s = render_scene(spec, name, progress, |slug| {
            let taken = |id: &str| scenes.iter().any(|x| x.id == id);
            (1..)
                .map(|k| {
                    if k == 1 {
                        slug.to_string()
                    } else {
                        format!("{slug}-{k}")
                    }
                })
                .find(|id| !taken(id))
                .expect("some suffix is free")
        })?;
        scenes.push(s);
    }
    let configs = vec![(8, 2), (8, 3), (8, 4), (16, 2), (16, 3), (16, 4)];
    let (rsh, _) = bench::rsh::run(
        &bench::Spec {
            scenes: spec.rsh_scenes.clone(),
            configs,
            width: spec.side,
            height: spec.side,
            bounces: 1,
        },
        progress,
    )?;
    let ray_hierarchy = ray_hierarchy::run(
        &spec.rsh_scenes,
        spec.side,
        spec.bounces,
        if spec.quick { 1 } else { 2 },
        &rsh,
        progress,
    )?;
    let grid = bench::grid::run(
        &bench::grid::Spec {
            scenes: spec.grid_scenes.clone(),
            width: spec.side,
            height: spec.side,
            ao_spp: 2,
            seed: 1,
            repeats: if spec.quick { 1 } else { 2 },
        },
        progress,
    )?;
    let scaling = scaling(spec, progress)?;
    let (generated, generated_slopes) =
        bench::scale::run(&spec.generated(), &|_, _| Ok(Default::default()), progress)?;
    let mut r = Report {
        provenance: bench::provenance(),
        commit: env!("RAYSPACE_BUILD_COMMIT").to_string(),
        quick: spec.quick,
        side: spec.side,
        scenes,
        rsh,
        ray_hierarchy,
        grid_perf: grid.perf,
        grid_builds: grid.grids,
        scaling,
        generated,
        generated_slopes,
        charts: Vec::new(),
        charts_note: None,
        seconds: 0.0,
    };
    match draw_charts(&r, spec) {
        Ok(c) => r.charts = c,
        Err(e) => r.charts_note = Some(format!("charts were not drawn: {e}")),
    }
    r.seconds = t0.elapsed().as_secs_f64();
    let json = serde_json::to_string_pretty(&r).context("report.json")?;
    write(&spec.out, "report.json", json.as_bytes())?;
    write(&spec.out, "index.html", html::page(&r).as_bytes())?;
    Ok(r)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_reference_is_brute_force_or_the_grid() {
        let with = render_list(true);
        assert_eq!(&with[..2], &[Engine::Brute, Engine::Grid]);
        let without = render_list(false);
        assert_eq!(without[0], Engine::Grid);
        assert!(!without.contains(&Engine::Brute));
        assert_eq!(without.len() + 1, with.len());
        assert!(without.contains(&Engine::Crsh) && without.contains(&Engine::Rah));
    }

    #[test]
    fn slopes_fit_power_laws() {
        let p: Vec<(f64, f64)> = [1.0, 10.0, 100.0]
            .iter()
            .map(|&x: &f64| (x, 3.0 * x.powf(1.5)))
            .collect();
        assert!((charts::loglog_slope(&p).unwrap() - 1.5).abs() < 1e-9);
        assert!(charts::loglog_slope(&p[..1]).is_none());
    }
}
