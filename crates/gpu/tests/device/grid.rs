//! The irregular grid's GPU traversal against its oracles: on every built-in scene (Whitted
//! batches, primary, ambient-occlusion and random rays), in the paper's configuration, the
//! two-level grid, the adaptive subdivision and Devillers's macro regions, and on random
//! soups with the grid property tests' awkward rays (±0 components, axis-parallel, on cell
//! planes, bounded and unbounded), the GPU returns the CPU grid's hit records bit for bit,
//! brute force's closest hits, and the CPU's N_T and N_I. Without an adapter every test
//! prints why and passes locally (CI installs lavapipe and requires the GPU).

use crate::common;
use accel::grid::{build_grid, GridConfig, GridEngine, Subdivision};

use accel::BruteForce;
use gpu::{Gpu, GpuGrid};
use render::raygen::{generate, Kind, Options};
use scene::{builtin, Geometry};
use trace::{Hit, RayBatch, TraceMode, TraceStats, Tracer};

fn gpu() -> Option<Gpu> {
    testkit::or_skip(Gpu::new(), "gpu")
}

/// GPU against CPU grid (bits, N_T, N_I) and against brute force (closest: the record; any:
/// whether something is hit).
fn compare(cpu: &GridEngine, gpu: &GpuGrid, rays: &RayBatch, mode: TraceMode, what: &str) {
    let n = rays.len();
    let (mut hc, mut hg, mut hb) = (vec![Hit::MISS; n], vec![Hit::MISS; n], vec![Hit::MISS; n]);
    let (mut sc, mut sg) = (TraceStats::default(), TraceStats::default());
    cpu.trace(rays, mode, &mut hc, &mut sc);
    gpu.trace(rays, mode, &mut hg, &mut sg);
    let brute = BruteForce::new(&Geometry::soup(cpu.tris.clone(), geom::Vec3::Y));
    brute.trace(rays, mode, &mut hb, &mut TraceStats::default());
    for i in 0..n {
        assert_eq!(hg[i], hc[i], "{what}: ray {i} GPU vs CPU grid");
        if mode == TraceMode::Closest {
            assert_eq!(hg[i], hb[i], "{what}: ray {i} GPU vs brute force");
        } else {
            assert_eq!(hg[i].is_hit(), hb[i].is_hit(), "{what}: ray {i} any hit");
        }
    }
    assert_eq!(sg.rays, sc.rays, "{what}: rays");
    assert_eq!(sg.hits, sc.hits, "{what}: hits");
    assert_eq!(sg.ray_tri_tests, sc.ray_tri_tests, "{what}: N_I");
    assert_eq!(
        sg.counters.get(accel::grid::TRAVERSAL_STEPS),
        sc.counters.get(accel::grid::TRAVERSAL_STEPS),
        "{what}: N_T"
    );
    assert!(sg.counters.contains(gpu::stats::KERNEL_LAUNCHES));
}

fn configs() -> [(&'static str, GridConfig); 4] {
    [
        ("paper", GridConfig::default()),
        ("two-level", GridConfig::two_level()),
        (
            "adaptive",
            GridConfig {
                subdivision: Subdivision::Adaptive,
                ..GridConfig::default()
            },
        ),
        (
            "macro regions",
            GridConfig {
                empty_only: true,
                ..GridConfig::default()
            },
        ),
    ]
}

/// The CPU engine and the GPU engine over the very same grid.
fn engines(g: Gpu, geo: &Geometry, cfg: &GridConfig) -> (GridEngine, GpuGrid) {
    let cpu = GridEngine::new(geo, cfg).unwrap();
    let gpu = GpuGrid::upload(g, &cpu.grid, &geo.tris, "grid-gpu").unwrap();
    (cpu, gpu)
}

#[test]
fn builtin_scenes_match_the_cpu_grid() {
    let Some(g) = gpu() else { return };
    eprintln!("adapter: {}", g.describe());
    drop(g);
    for name in builtin::NAMES {
        let s = builtin::by_name(name).unwrap();
        let geo = Geometry::from_scene(&s);
        let opts = Options {
            width: 40,
            height: 32,
            spp: 2,
            seed: 7,
            ao_distance: None,
        };
        let mut sets: Vec<(String, RayBatch, TraceMode)> = vec![
            (
                "primary".into(),
                generate(&s, &geo, Kind::Primary, &opts),
                TraceMode::Closest,
            ),
            (
                "ao".into(),
                generate(&s, &geo, Kind::Ao, &opts),
                TraceMode::Any,
            ),
            (
                "random".into(),
                generate(&s, &geo, Kind::Random, &opts),
                TraceMode::Closest,
            ),
        ];
        for (k, (rays, mode, _)) in testkit::record_render(&s, &geo, 40, 32, 2)
            .into_iter()
            .enumerate()
        {
            sets.push((format!("whitted batch {k}"), rays, mode));
        }
        for (cname, cfg) in configs() {
            let Some(g) = gpu() else { return };
            let (cpu, gpu) = engines(g, &geo, &cfg);
            for (what, rays, mode) in &sets {
                compare(&cpu, &gpu, rays, *mode, &format!("{name} {cname} {what}"));
            }
        }
    }
}

#[test]
fn random_soups_match_the_cpu_grid() {
    for seed in 0..6u64 {
        let Some(g) = gpu() else { return };
        let (geo, rays) = testkit::grid_case(seed, 60 + 90 * seed as usize, 3000);
        let (_, cfg) = &configs()[seed as usize % 4];
        let (cpu, gpu) = engines(g, &geo, cfg);
        for mode in [TraceMode::Closest, TraceMode::Any] {
            compare(&cpu, &gpu, &rays, mode, &format!("soup {seed} {mode:?}"));
        }
    }
}

#[test]
fn small_bindings_split_rays_and_refuse_big_grids() {
    // A binding just large enough for cornell's grid: rays go in parts of a sixteenth of it,
    // and a 20,000-triangle soup's grid, whose references do not fit, is refused with a line naming them.
    let s = builtin::by_name("cornell").unwrap();
    let geo = Geometry::from_scene(&s);
    let cpu = GridEngine::new(&geo, &GridConfig::default()).unwrap();
    let gr = &cpu.grid;
    let limit = common::tight_binding(&cpu, &geo);
    let Some(mut g) = gpu() else { return };
    g.limits.max_storage_buffer_binding_size = limit;
    let soup = Geometry::from_scene(&builtin::soup(20_000, 1));
    let big = build_grid(&soup.tris, &GridConfig::default()).unwrap();
    assert!(
        big.refs.len() as u64 * 4 > limit,
        "the soup has more references"
    );
    let err = GpuGrid::upload(g, &big, &soup.tris, "grid-gpu")
        .err()
        .expect("refused");
    assert!(err.to_string().contains("references"), "{err}");
    let Some(mut g) = gpu() else { return };
    g.limits.max_storage_buffer_binding_size = limit;
    let gpu = GpuGrid::upload(g, gr, &geo.tris, "grid-gpu").unwrap();
    let opts = Options {
        width: 128,
        height: 96,
        spp: 1,
        seed: 3,
        ao_distance: None,
    };
    let rays = generate(&s, &geo, Kind::Random, &opts);
    assert!(
        rays.len() as u64 > limit / 16,
        "more rays than one launch takes"
    );
    let mut st = TraceStats::default();
    let mut h = vec![Hit::MISS; rays.len()];
    gpu.trace(&rays, TraceMode::Closest, &mut h, &mut st);
    assert!(
        st.counters[gpu::stats::KERNEL_LAUNCHES] >= 2,
        "traced in parts"
    );
    compare(&cpu, &gpu, &rays, TraceMode::Closest, "cornell in parts");
}
