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
