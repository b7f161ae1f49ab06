//! The data-parallel primitives on the device against their definitions: exclusive scan
//! (one block, one level of block sums, two levels), compaction, and the stable radix sort
//! (ties keep their input order), at sizes around the block and tile boundaries.

use geom::Pcg32;
use gpu::kernels::Exec;
use gpu::Gpu;

fn gpu() -> Option<Gpu> {
    testkit::or_skip(Gpu::new(), "gpu")
}

const SIZES: [usize; 9] = [1, 2, 1023, 1024, 1025, 4096, 4097, 70_001, 1_100_000];

#[test]
fn scan_compact_and_sort_match_their_definitions() {
    let Some(g) = gpu() else { return };
    let k = g.kernels();
    let mut rng = Pcg32::new(7, 1);
    for n in SIZES {
        let mut ex = Exec::new(&g, &k);
        let vals: Vec<u32> = (0..n).map(|_| rng.below(5)).collect();
        let input = g.upload("in", &vals);
        let out = g.storage("out", (n as u64 + 1) * 4);
        ex.scan(&input, &out, n as u64);
        let got: Vec<u32> = ex.read(&out, n + 1);
        let mut acc = 0u32;
        for i in 0..n {
            assert_eq!(got[i], acc, "scan n={n} i={i}");
            acc += vals[i];
        }
        assert_eq!(got[n], acc, "scan total n={n}");

        let flags: Vec<u32> = (0..n).map(|_| (rng.below(3) == 0) as u32).collect();
        let fb = g.upload("flags", &flags);
        let (a, b, m) = ex.compact(&fb, &input, None, n as u64);
        let want: Vec<u32> = (0..n as u32).filter(|&i| flags[i as usize] != 0).collect();
        assert_eq!(m as usize, want.len(), "compact count n={n}");
        let ga: Vec<u32> = ex.read(&a, want.len());
        let gb: Vec<u32> = ex.read(&b, want.len());
        assert_eq!(gb, want, "compact indices n={n}");
        let wa: Vec<u32> = want.iter().map(|&i| vals[i as usize]).collect();
        assert_eq!(ga, wa, "compact values n={n}");

        // Few distinct keys (many ties) and full-range keys.
        for spread in [7u32, u32::MAX] {
            let keys: Vec<u32> = (0..n)
                .map(|_| {
                    if spread == u32::MAX {
                        rng.next_u32()
                    } else {
                        rng.below(spread) << 20
                    }
                })
                .collect();
            let kb = g.upload("keys", &keys);
            let vb = g.upload("vals", &(0..n as u32).collect::<Vec<_>>());
            ex.sort_pairs(&kb, &vb, n as u64, 32);
            let gk: Vec<u32> = ex.read(&kb, n);
            let gv: Vec<u32> = ex.read(&vb, n);
            let mut want: Vec<(u32, u32)> = keys.iter().copied().zip(0..n as u32).collect();
            want.sort_by_key(|p| p.0); // stable
            assert_eq!(
                gk,
                want.iter().map(|p| p.0).collect::<Vec<_>>(),
                "sort keys n={n}"
            );
            assert_eq!(
                gv,
                want.iter().map(|p| p.1).collect::<Vec<_>>(),
                "sort values n={n} (stability)"
            );
        }
    }
}
