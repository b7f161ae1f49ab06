//! The build's tables and passes against their definitions.

use super::*;

/// The depth table gives eq. 1's depth for every count: exhaustively up to 2^18 and at
/// spread counts beyond, over cell shapes from flat to cubic and both densities' scales.
#[test]
fn depth_table_equals_the_paper_rule() {
    for (tsize, density) in [
        (Vec3::new(1.0, 1.0, 1.0), 2.4),
        (Vec3::new(0.37, 2.9, 0.011), 2.4),
        (Vec3::new(13.0, 7.0, 5.0), 0.5),
        (Vec3::new(1e-3, 2e-3, 5e-4), 8.0),
    ] {
        let b = Aabb::new(Vec3::ZERO, tsize * 4.0);
        let cfg = GridConfig {
            leaf_density: density,
            ..GridConfig::default()
        };
        let mut st = setup(b, 1 << 22, &cfg).unwrap();
        st.tsize = tsize;
        let table = st.depth_table(density, 1 << 22);
        let by_table = |n: u32| table.iter().filter(|&&t| t <= n).count() as u32;
        let counts = (1..1u32 << 18)
            .chain((18..22).flat_map(|e| (0..4096).map(move |k| (1 << e) + k * 997)));
        for n in counts {
            assert_eq!(
                by_table(n),
                st.paper_depth(n, density),
                "count {n}, {tsize:?}"
            );
        }
        assert_eq!(by_table(0), 0);
    }
}

/// The top-cell builder makes the level-by-level passes' grid bit for bit (voxel map, cells,
/// references), on scenes from one object to a dense object in a huge cell, under both
/// subdivision rules, deep and shallow octrees, and a top grid of one cell.
#[test]
fn top_cell_build_equals_the_level_passes() {
    use scene::{builtin, generate::Spec, Geometry};
    let hairball = Spec::parse("hairball:6k").unwrap().unwrap().generate();
    let scenes = [
        ("cornell", builtin::cornell()),
        ("office", builtin::office(1)),
        ("spheres", builtin::spheres()),
        ("stadium", builtin::stadium()),
        ("soup", builtin::soup(3000, 7)),
        ("hairball", hairball),
    ];
    let configs = [
        ("paper", GridConfig::default()),
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
                top_density: 0.02,
                leaf_density: 9.0,
                max_depth: 12,
                ..GridConfig::default()
            },
        ),
        (
            "one top cell",
            GridConfig {
                top_density: 1e-6,
                ..GridConfig::default()
            },
        ),
        (
            "flat",
            GridConfig {
                max_depth: 0,
                ..GridConfig::default()
            },
        ),
    ];
    let mut nested = 0;
    for (name, sc) in &scenes {
        let geo = Geometry::from_scene(sc);
        for (what, cfg) in &configs {
            let b = initial_by_levels(&geo.tris, cfg).unwrap();
            // One wave, and waves of a few top cells each (the parts appended in turn).
            for wave in [u64::MAX, 1, 97] {
                let a = topcells::initial_in_waves(&geo.tris, cfg, wave).unwrap();
                let at = format!("{name}, {what}, waves of {wave} references");
                assert_eq!(a.shift, b.shift, "{at}: levels");
                assert_eq!(a.top_dims, b.top_dims, "{at}: top grid");
                same(&a.entries, &b.entries, &format!("{at}: voxel map"));
                same(&a.cell_min, &b.cell_min, &format!("{at}: cell minima"));
                same(&a.cell_max, &b.cell_max, &format!("{at}: cell maxima"));
                same(
                    &a.ref_first,
                    &b.ref_first,
                    &format!("{at}: reference ranges"),
                );
                same(&a.refs, &b.refs, &format!("{at}: references"));
                assert_eq!(a.build.initial_cells, b.build.initial_cells, "{at}");
                let top = a.top_dims.iter().product::<u32>() as usize;
                nested += a.entries[top..]
                    .iter()
                    .filter(|&&e| e & voxelmap::NODE != 0)
                    .count();
            }
        }
    }
    assert!(nested > 0, "some octree is deeper than one block");
}

/// The top-cell builder's caps refuse what the level passes refuse, with the same kind of
/// error naming the memory limit.
#[test]
fn top_cell_build_keeps_the_caps() {
    let geo = scene::Geometry::from_scene(&scene::builtin::soup(20_000, 1));
    let cfg = GridConfig {
        max_bytes: 200_000,
        ..GridConfig::default()
    };
    let a = initial(&geo.tris, &cfg).expect_err("refused");
    assert!(matches!(a, GridError::TooBig { .. }), "{a}");
    assert!(a.to_string().contains("`max_memory`"), "{a}");
    let b = initial_by_levels(&geo.tris, &cfg).expect_err("refused");
    assert!(matches!(b, GridError::TooBig { .. }), "{b}");
}

/// `a == b`, or a failure naming the first index where they differ.
fn same<T: PartialEq + std::fmt::Debug>(a: &[T], b: &[T], what: &str) {
    if let Some(i) = (0..a.len().min(b.len())).find(|&i| a[i] != b[i]) {
        panic!("{what}: differ first at {i}: {:?} against {:?}", a[i], b[i]);
    }
    assert_eq!(a.len(), b.len(), "{what}: lengths");
}

/// Waves cover the top cells in order, each at least one top cell and, before its last
/// top cell holding references, below the wave's reference budget.
#[test]
fn waves_split_the_top_cells_by_references() {
    let first = [0u32, 5, 5, 9, 30, 31, 31, 40, 40, 40];
    for budget in [1u64, 4, 10, 100] {
        let w = topcells::waves(&first, budget);
        assert_eq!(w.first().map(|r| r.start), Some(0));
        assert_eq!(w.last().map(|r| r.end), Some(first.len() - 1));
        for pair in w.windows(2) {
            assert_eq!(pair[0].end, pair[1].start);
        }
        for r in &w {
            assert!(!r.is_empty());
            let last = r
                .clone()
                .rev()
                .find(|&t| first[t + 1] > first[t])
                .unwrap_or(r.start);
            let refs = (first[last] - first[r.start]) as u64;
            assert!(refs < budget.max(1), "{r:?} with budget {budget}");
        }
    }
    // A budget of one reference: one wave per non-empty top cell, empty ones riding along
    // (those past the last reference with the last wave).
    assert_eq!(topcells::waves(&first, 1), [0..1, 1..3, 3..4, 4..5, 5..9]);
    assert_eq!(topcells::waves(&first, 100), vec![0..9]);
    assert_eq!(topcells::waves(&[0, 0, 0], 4), vec![0..2]);
}
