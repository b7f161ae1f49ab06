//! The irregular grid's build on the GPU against the CPU's, pass by pass: on every built-in
//! scene, on random soups and on the real scenes, in the default configuration (merging by
//! runs), the paper's (merging by pairs), the two-level grid, Devillers's macro regions,
//! adaptive subdivision and deep octrees:
//! - the frame and octrees (sparse voxel map, leaf cells, kept references) equal
//!   `accel::grid::build::subdivide`'s bit for bit;
//! - the cells pass (block voxel map, cells in map order, sorted references) equals
//!   `accel::grid::build::finish`'s;
//! - the whole build (SAH merging and expansion too) equals `accel::grid::build_grid`'s: map,
//!   cells, expanded boxes, references and merge rounds;
//! - a grid built by `GpuGrid::new` traces as the CPU grid does; the build's caps and binding
//!   limits refuse with the CPU's lines; the GPU places every pass of the CPU's pass list.
//!
//! Without an adapter every test prints why and passes locally (CI installs lavapipe and
//! requires the GPU).

use accel::grid::build::subdivide;
use accel::grid::{GridConfig, GridEngine, MergeRule, Subdivision, PASSES};
use gpu::grid::{build, voxelmap, PASS_DEVICE};
use gpu::kernels::Kernels;
use gpu::{Gpu, GpuGrid};
use render::raygen::{generate, Kind, Options};
use scene::{builtin, Geometry};
use trace::Device;
use trace::{Hit, TraceMode, TraceStats, Tracer};

fn gpu() -> Option<Gpu> {
    testkit::or_skip(Gpu::new(), "gpu")
}

fn configs() -> [(&'static str, GridConfig); 6] {
    [
        ("default (merge runs)", GridConfig::default()),
        (
            "paper (merge pairs)",
            GridConfig {
                merge_rule: MergeRule::Pairs,
                ..GridConfig::default()
            },
        ),
        ("two-level", GridConfig::two_level()),
        (
            "macro regions",
            GridConfig {
                empty_only: true,
                ..GridConfig::default()
            },
        ),
        (
            "adaptive",
            GridConfig {
                subdivision: Subdivision::Adaptive,
                ..GridConfig::default()
            },
        ),
        (
            "deep",
            GridConfig {
                leaf_density: 40.0,
                top_density: 0.02,
                max_depth: 12,
                ..GridConfig::default()
            },
        ),
    ]
}

fn tri4(tris: &[[geom::Vec3; 3]]) -> Vec<[f32; 4]> {
    tris.iter()
        .flat_map(|t| t.map(|v| [v.x, v.y, v.z, 0.0]))
        .collect()
}

/// The GPU's build of `tris` equals the CPU's, pass by pass.
/// Returns the blocks nested below the top cells' (so callers can check that deep octrees,
/// whose numbering is the subtle part, were exercised).
fn same_build(
    g: &Gpu,
    k: &Kernels,
    tris: &[[geom::Vec3; 3]],
    cfg: &GridConfig,
    what: &str,
) -> usize {
    let (cs, co, _) = subdivide(tris, cfg).unwrap();
    let buf = g.upload("triangles", &tri4(tris));
    let (gs, d, _) = build::subdivide_on_device(g, k, &buf, tris.len(), cfg).unwrap();
    let go = d.read(&mut gpu::kernels::Exec::new(g, k));
    assert_eq!(gs, cs, "{what}: frame");
    same(
        &go.entries,
        &co.entries,
        &format!("{what}: voxel-map entries"),
    );
    same(
        &go.cell_coord,
        &co.cell_coord,
        &format!("{what}: cell coordinates"),
    );
    same(
        &go.cell_level,
        &co.cell_level,
        &format!("{what}: cell levels"),
    );
    same(
        &go.cell_count,
        &co.cell_count,
        &format!("{what}: cell counts"),
    );
    same(
        &go.kept_cell,
        &co.kept_cell,
        &format!("{what}: references' cells"),
    );
    same(
        &go.kept_tri,
        &co.kept_tri,
        &format!("{what}: references' triangles"),
    );
    assert_eq!(go.levels, co.levels, "{what}: levels");
    assert!(co.levels >= 1, "{what}: the octrees split somewhere");
    // The cells pass: voxel map, cells in its order, references by cell.
    let cg = accel::grid::build::finish(&cs, co).unwrap();
    let gg = voxelmap::finish(g, k, &gs, &d).unwrap().read(g, k);
    same(&gg.entries, &cg.entries, &format!("{what}: voxel map"));
    same(&gg.cell_min, &cg.cell_min, &format!("{what}: cells' min"));
    same(&gg.cell_max, &cg.cell_max, &format!("{what}: cells' max"));
    same(
        &gg.ref_first,
        &cg.ref_first,
        &format!("{what}: reference ranges"),
    );
    same(&gg.refs, &cg.refs, &format!("{what}: references"));
    let nested = cg.entries[cs.ntop..]
        .iter()
        .filter(|&&e| e & accel::grid::voxelmap::NODE != 0)
        .count();
    eprintln!(
        "{what}: {} levels, {} cells, {nested} nested blocks",
        cg.shift,
        cg.cells()
    );
    assert_eq!(
        (gg.shift, gg.dims, gg.voxel, gg.bounds),
        (cg.shift, cg.dims, cg.voxel, cg.bounds),
        "{what}: grid frame"
    );
    // The whole build: merging and expansion too.
    let cg = accel::grid::build_grid(tris, cfg).unwrap();
    let gg = gpu::grid::build_on_device(g, k, &buf, tris.len(), cfg)
        .unwrap()
        .read(g, k);
    same(
        &gg.entries,
        &cg.entries,
        &format!("{what}: merged voxel map"),
    );
    same(
        &gg.cell_min,
        &cg.cell_min,
        &format!("{what}: merged cells' min"),
    );
    same(
        &gg.cell_max,
        &cg.cell_max,
        &format!("{what}: merged cells' max"),
    );
    same(
        &gg.ref_first,
        &cg.ref_first,
        &format!("{what}: merged ranges"),
    );
    same(&gg.refs, &cg.refs, &format!("{what}: merged references"));
    same(&gg.exp_min, &cg.exp_min, &format!("{what}: expanded min"));
    same(&gg.exp_max, &cg.exp_max, &format!("{what}: expanded max"));
    assert_eq!(
        gg.build.merge_rounds, cg.build.merge_rounds,
        "{what}: merge rounds"
    );
    nested
}

/// Equal lists, or a panic naming the lengths and the first difference (not the lists).
fn same<T: PartialEq + std::fmt::Debug>(gpu: &[T], cpu: &[T], what: &str) {
    if let Some(i) = (0..gpu.len().min(cpu.len())).find(|&i| gpu[i] != cpu[i]) {
        panic!(
            "{what}: element {i} of {} (GPU) / {} (CPU) differs: {:?} vs {:?}",
            gpu.len(),
            cpu.len(),
            gpu[i],
            cpu[i]
        );
    }
    assert_eq!(gpu.len(), cpu.len(), "{what}: lengths (GPU, CPU)");
}

#[test]
fn builtin_builds_match_the_cpu() {
    let Some(g) = gpu() else { return };
    let k = g.kernels();
    let mut nested = 0;
    for name in builtin::NAMES {
        let geo = Geometry::from_scene(&builtin::by_name(name).unwrap());
        for (cname, cfg) in configs() {
            nested += same_build(&g, &k, &geo.tris, &cfg, &format!("{name} {cname}"));
        }
    }
    assert!(nested > 1000, "deep octrees nest blocks ({nested})");
}

#[test]
fn random_soup_builds_match_the_cpu() {
    let Some(g) = gpu() else { return };
    let k = g.kernels();
    for seed in 0..9u64 {
        let (geo, _) = testkit::grid_case(seed, 40 + 170 * seed as usize, 0);
        let (cname, cfg) = &configs()[seed as usize % 6];
        same_build(&g, &k, &geo.tris, cfg, &format!("soup {seed} {cname}"));
    }
}

#[test]
fn a_grid_built_on_the_gpu_traces_as_the_cpu_grid() {
    let s = builtin::by_name("office").unwrap();
    let geo = Geometry::from_scene(&s);
    let opts = Options {
        width: 48,
        height: 40,
        spp: 1,
        seed: 5,
        ao_distance: None,
    };
    for (cname, cfg) in configs() {
        let Some(g) = gpu() else { return };
        let cpu = GridEngine::new(&geo, &cfg).unwrap();
        let gpu = GpuGrid::new(g, &geo, &cfg).unwrap();
        let passes = gpu.build_passes();
        for (i, (pass, dev)) in PASS_DEVICE.iter().enumerate() {
            let on = if *dev == Device::Gpu { "GPU" } else { "CPU" };
            assert_eq!(
                passes[i].name(),
                format!("{pass} ({on})"),
                "{cname}: pass {i}"
            );
        }
        for kind in [Kind::Primary, Kind::Random] {
            let rays = generate(&s, &geo, kind, &opts);
            let n = rays.len();
            let (mut hc, mut hg) = (vec![Hit::MISS; n], vec![Hit::MISS; n]);
            let (mut sc, mut sg) = (TraceStats::default(), TraceStats::default());
            cpu.trace(&rays, TraceMode::Closest, &mut hc, &mut sc);
            gpu.trace(&rays, TraceMode::Closest, &mut hg, &mut sg);
            same(&hg, &hc, &format!("{cname} {kind:?}: hits"));
            assert_eq!(sg.ray_tri_tests, sc.ray_tri_tests, "{cname} {kind:?}: N_I");
        }
    }
}

#[test]
fn the_gpu_places_every_pass_of_the_cpu_build() {
    let passes: Vec<_> = PASS_DEVICE.iter().map(|p| p.0).collect();
    assert_eq!(passes, PASSES, "the GPU's pass list is the CPU's");
}

#[test]
fn caps_and_binding_limits_refuse_with_clear_lines() {
    let geo = Geometry::from_scene(&builtin::soup(20_000, 1));
    // The build's reference cap from the memory limit: the CPU's error, on the GPU too.
    let cfg = GridConfig {
        max_bytes: 200_000,
        ..GridConfig::default()
    };
    let cpu_err = subdivide(&geo.tris, &cfg).expect_err("the CPU refuses");
    let Some(g) = gpu() else { return };
    let err = GpuGrid::new(g, &geo, &cfg).err().expect("the GPU refuses");
    assert!(
        matches!(&err, gpu::GpuError::Grid(e) if *e == cpu_err),
        "{err} / {cpu_err}"
    );
    assert!(cpu_err.to_string().contains("`max_memory`"), "{cpu_err}");
    // A binding too small for the references: refused, naming them.
    let Some(mut g) = gpu() else { return };
    g.limits.max_storage_buffer_binding_size = geo.tris.len() as u64 * 48;
    let err = GpuGrid::new(g, &geo, &GridConfig::default())
        .err()
        .expect("refused");
    assert!(err.to_string().contains("references"), "{err}");
}

#[test]
fn real_scene_builds_match_the_cpu() {
    let Some(dir) = testkit::scenes() else { return };
    let Some(g) = gpu() else { return };
    let k = g.kernels();
    for rel in [
        "dabrovic-sponza/sponza.obj",
        "bart-kitchen/aff/kitchen.aff",
        "conference/conference.obj",
    ] {
        let path = dir.join(rel);
        if !path.exists() {
            testkit::skip("scenes", format!("{} not present", path.display()));
            return;
        }
        let s = scene::load(path.to_str().unwrap(), &Default::default()).unwrap();
        let geo = Geometry::from_scene(&s);
        // Conference's adaptive build is the slowest on lavapipe (~30 s) and adds no rule
        // that Sponza and Kitchen do not exercise.
        let n = if rel.starts_with("conference") { 1 } else { 2 };
        for (cname, cfg) in [&configs()[0], &configs()[4]].into_iter().take(n) {
            let t0 = std::time::Instant::now();
            same_build(&g, &k, &geo.tris, cfg, &format!("{rel} {cname}"));
            eprintln!("{rel} {cname}: {:.1} s", t0.elapsed().as_secs_f64());
        }
    }
}
