//! The object tree, from both builders: every triangle once under bounding boxes, the fused
//! pass against Karras's emission, the 8-wide collapse and the single-ray path's copy of it,
//! the SAH builder's quality, and the Morton codes.

use super::*;
use geom::morton::spread;
use geom::Pcg32;

fn soup(n: usize, seed: u64) -> Vec<[Vec3; 3]> {
    let mut rng = Pcg32::new(seed, 1);
    (0..n)
        .map(|_| {
            let c = Vec3::new(
                rng.range(-50.0, 50.0),
                rng.range(-50.0, 50.0),
                rng.range(-50.0, 50.0),
            );
            let mut v = || c + rng.unit_vector() * rng.range(0.0, 3.0);
            [v(), v(), v()]
        })
        .collect()
}

/// Every triangle is a leaf exactly once, and every ancestor's sphere and the box of
/// the child it lies under contain it.
fn check(tris: &[[Vec3; 3]], t: &ObjectTree) {
    let mut seen = vec![0u32; tris.len()];
    // (node, its ancestors with the child slot taken below each)
    let mut stack = vec![(t.root, Vec::<(usize, usize)>::new())];
    let mut max_depth = 0;
    while let Some((node, path)) = stack.pop() {
        if node & LEAF != 0 {
            let tri = (node & !LEAF) as usize;
            seen[tri] += 1;
            max_depth = max_depth.max(path.len() as u32);
            for &(a, k) in &path {
                let s = t.node[a].sphere;
                for v in tris[tri] {
                    assert!(s.contains(v), "node {a} misses a vertex of triangle {tri}");
                    let b = &t.child_box[a][k];
                    assert!(b.contains(v), "box {k} of {a} misses triangle {tri}");
                    assert!(t.node[a].bbox.contains(v) && t.leaf[tri].bbox.contains(v));
                }
            }
        } else {
            for (k, c) in t.child[node as usize].into_iter().enumerate() {
                let mut p = path.clone();
                p.push((node as usize, k));
                stack.push((c, p));
            }
        }
    }
    assert!(seen.iter().all(|&s| s == 1), "every triangle is one leaf");
    if !t.is_empty() {
        assert_eq!(t.depth, max_depth);
    }
    check_ranges(t);
    check_wide(t);
    check_boxes(tris, t);
}

/// The single-ray path's records: every node's lanes cover its binary subtree's triangles
/// once (node lanes by their own nodes, leaf lanes by at most `LANE_TRIS` triangles of the
/// leaf order), each lane's box holds its triangles, masked lanes repeat lane 0, and the
/// triangles are in leaf order.
fn check_boxes(tris: &[[Vec3; 3]], t: &ObjectTree) {
    if t.is_empty() {
        assert!(t.boxes.is_empty());
        return;
    }
    let mut ids = t.leaf_ids.clone();
    ids.sort();
    assert_eq!(
        ids,
        (0..tris.len() as u32).collect::<Vec<_>>(),
        "every triangle once"
    );
    for (p, &tri) in t.leaf_ids.iter().enumerate() {
        assert_eq!(t.leaf_tri(p), tris[tri as usize]);
    }
    // Leaf positions under node `b`, each lane's checked against its box.
    fn cover(t: &ObjectTree, b: usize, seen: &mut Vec<u32>) {
        let n = &t.boxes[b];
        assert!((2..=8).contains(&n.count), "node {b}: {} children", n.count);
        for i in 0..8 {
            let l = if i < n.count as usize { i } else { 0 };
            assert_eq!(n.child[i], n.child[l]);
            assert_eq!(n.min[0][i].to_bits(), n.min[0][l].to_bits());
        }
        for i in 0..n.count as usize {
            let bx = Aabb::new(
                Vec3::new(n.min[0][i], n.min[1][i], n.min[2][i]),
                Vec3::new(n.max[0][i], n.max[1][i], n.max[2][i]),
            );
            let mut below = Vec::new();
            if n.leaves >> i & 1 != 0 {
                assert!(n.child[i] & LEAF != 0);
                let k = n.ntri[i] as u32;
                assert!((1..=LANE_TRIS).contains(&k));
                let p = n.child[i] & !LEAF;
                below.extend(p..p + k);
            } else {
                let c = n.child[i] as usize;
                assert!(c > b && c < t.boxes.len(), "children come after their node");
                cover(t, c, &mut below);
            }
            for &p in &below {
                for v in t.leaf_tri(p as usize) {
                    assert!(bx.contains(v), "node {b} lane {i} misses position {p}");
                }
            }
            seen.extend(below);
        }
    }
    // Box order: the nodes' leaf lanes take consecutive positions, node after node.
    let mut next = 0u32;
    for (b, n) in t.boxes.iter().enumerate() {
        for l in 0..n.count as usize {
            if n.leaves >> l & 1 != 0 {
                assert_eq!(
                    n.child[l] & !LEAF,
                    next,
                    "node {b} lane {l}: the next position"
                );
                next += n.ntri[l] as u32;
            }
        }
    }
    assert_eq!(next as usize, t.leaf_ids.len());
    let mut seen = Vec::new();
    cover(t, 0, &mut seen);
    seen.sort();
    assert_eq!(seen, (0..t.tri_order.len() as u32).collect::<Vec<_>>());
}

/// Both builders.
const BUILDERS: [ObjectBuilder; 2] = [ObjectBuilder::Lbvh, ObjectBuilder::Sah];

/// Every inner node's range of `tri_order` lists exactly its subtree's triangles, left to
/// right.
fn check_ranges(t: &ObjectTree) {
    if t.is_empty() {
        return;
    }
    let mut order = t.tri_order.clone();
    order.sort();
    assert!(order.iter().enumerate().all(|(i, &x)| x == i as u32));
    for h in 0..t.len() {
        let mut leaves = Vec::new();
        let mut st = vec![h as u32];
        while let Some(y) = st.pop() {
            if y & LEAF != 0 {
                leaves.push(y & !LEAF);
            } else {
                let [a, b] = t.child[y as usize];
                st.extend([b, a]);
            }
        }
        let [lo, hi] = t.range[h];
        assert_eq!(
            &t.tri_order[lo as usize..=hi as usize],
            &leaves[..],
            "node {h}"
        );
    }
}

/// The collapsed nodes: each head's lanes are the leaves of a cut of its binary subtree
/// (every triangle below the head under exactly one lane), with the binary bounds bit for
/// bit, and every inner lane is itself a head.
fn check_wide(t: &ObjectTree) {
    if t.is_empty() {
        assert!(t.wide.is_empty());
        return;
    }
    let below = |x: u32| {
        let mut out = Vec::new();
        let mut st = vec![x];
        while let Some(y) = st.pop() {
            if y & LEAF != 0 {
                out.push(y & !LEAF);
            } else {
                st.extend(t.child[y as usize]);
            }
        }
        out.sort();
        out
    };
    assert_eq!(t.wide_of[0], 0, "the root heads the first collapsed node");
    for (h, &wi) in t.wide_of.iter().enumerate() {
        if wi == u32::MAX {
            continue;
        }
        let w = &t.wide[wi as usize];
        let n = w.count as usize;
        assert!((2..=WIDTH).contains(&n));
        let mut tris = Vec::new();
        for i in 0..WIDTH {
            let x = w.child[if i < n { i } else { 0 }];
            assert_eq!(w.child[i], x);
            let b = t.bounds(x);
            for k in 0..3 {
                assert_eq!(w.center[k][i].to_bits(), b.sphere.center[k].to_bits());
                assert_eq!(w.min[k][i].to_bits(), b.bbox.min[k].to_bits());
                assert_eq!(w.max[k][i].to_bits(), b.bbox.max[k].to_bits());
            }
            assert_eq!(w.radius[i].to_bits(), b.sphere.radius.to_bits());
            if i < n {
                if x & LEAF == 0 {
                    assert_ne!(t.wide_of[x as usize], u32::MAX, "inner lanes are heads");
                }
                tris.extend(below(x));
            }
        }
        tris.sort();
        assert_eq!(
            tris,
            below(h as u32),
            "head {h}: its lanes cover its subtree once"
        );
        // Full unless only leaves remain to split.
        assert!(n == WIDTH || w.child[..n].iter().all(|&x| x & LEAF != 0));
    }
}

#[test]
fn trees_cover_every_triangle_once_and_bound_them() {
    for (n, seed) in [(1, 1), (2, 2), (3, 3), (17, 4), (1000, 5), (4097, 6)] {
        let tris = soup(n, seed);
        for b in BUILDERS {
            let t = build(&tris, &[0, n as u32], None, b, Parts::ALL);
            check(&tris, &t);
        }
    }
}

#[test]
fn duplicate_keys_and_meshes_still_make_a_tree() {
    // All triangles at one point: every Morton key equal, ties broken by index.
    let one = [Vec3::ONE, Vec3::ONE, Vec3::ONE];
    let tris = vec![one; 100];
    for b in BUILDERS {
        let t = build(&tris, &[0, 100], None, b, Parts::ALL);
        check(&tris, &t);
    }
    // Several meshes, each a subtree: with mesh spheres the mesh roots take them.
    let tris = soup(600, 9);
    let first = [0u32, 10, 11, 300, 600];
    let spheres: Vec<Sphere> = first
        .windows(2)
        .map(|w| {
            let b = Aabb::from_points(tris[w[0] as usize..w[1] as usize].iter().flatten().copied());
            Sphere::around_box(&b)
        })
        .collect();
    for b in BUILDERS {
        let t = build(&tris, &first, Some(&spheres), b, Parts::ALL);
        check(&tris, &t);
        // The nodes holding exactly one mesh's triangles bound them by the smaller sphere.
        for (i, &[lo, hi]) in t.range.iter().enumerate() {
            for (m, w) in first.windows(2).enumerate() {
                let mut held: Vec<u32> = t.tri_order[lo as usize..=hi as usize].to_vec();
                held.sort();
                if held == (w[0]..w[1]).collect::<Vec<_>>() {
                    let own = Sphere::around_box(&Aabb::from_points(
                        held.iter().flat_map(|&x| tris[x as usize]),
                    ));
                    let want = own.radius.min(spheres[m].radius);
                    assert_eq!(
                        t.node[i].sphere.radius.to_bits(),
                        want.to_bits(),
                        "{b:?} node {i}"
                    );
                }
            }
        }
    }
}

/// The SAH builder's tree costs less than the LBVH's by the surface-area metric (the
/// work a single ray does) on clustered and uniform soups, and both builders give the
/// same tree from run to run.
#[test]
fn sah_trees_beat_the_lbvh_and_repeat() {
    let mut clustered = soup(3000, 11);
    for (i, t) in clustered.iter_mut().enumerate() {
        // A few dense clusters far apart (where Morton order's fixed grid splits badly).
        let off = Vec3::new((i % 3) as f32 * 400.0, (i % 5) as f32 * 7.0, 0.0);
        for v in t.iter_mut() {
            *v = *v * 0.1 + off;
        }
    }
    for tris in [soup(5000, 12), clustered] {
        let n = tris.len() as u32;
        let lbvh = build(&tris, &[0, n], None, ObjectBuilder::Lbvh, Parts::ALL);
        let sah = build(&tris, &[0, n], None, ObjectBuilder::Sah, Parts::ALL);
        let (l, s) = (lbvh.sah_metric().0, sah.sah_metric().0);
        assert!(s < l, "SAH {s} against LBVH {l} collapsed nodes per ray");
        for (b, t) in [(ObjectBuilder::Lbvh, &lbvh), (ObjectBuilder::Sah, &sah)] {
            let again = build(&tris, &[0, n], None, b, Parts::ALL);
            assert_eq!(again.child, t.child);
            assert_eq!(again.tri_order, t.tri_order);
        }
    }
}

/// Karras's construction as it was built before the fused pass: every inner node
/// emitted from the keys alone (Figure 4), then the boxes and depths filled from the
/// leaves up (here recursively).
fn radix_tree_karras(keys: &[u64], order: &[u32], boxes: &[Aabb]) -> RadixTree {
    let ni = keys.len() - 1;
    let mut child = vec![[0u32; 2]; ni];
    let mut range = vec![[0u32; 2]; ni];
    for i in 0..ni {
        let (lo, hi, g) = emit_node(keys, i);
        let left = if lo == g { LEAF | order[g] } else { g as u32 };
        let right = if hi == g + 1 {
            LEAF | order[g + 1]
        } else {
            (g + 1) as u32
        };
        child[i] = [left, right];
        range[i] = [lo as u32, hi as u32];
    }
    fn fill(
        x: u32,
        child: &[[u32; 2]],
        boxes: &[Aabb],
        nbox: &mut [Aabb],
        depth: &mut [u32],
    ) -> (Aabb, u32) {
        if x & LEAF != 0 {
            return (boxes[(x & !LEAF) as usize], 0);
        }
        let [l, r] = child[x as usize];
        let (a, da) = fill(l, child, boxes, nbox, depth);
        let (b, db) = fill(r, child, boxes, nbox, depth);
        nbox[x as usize] = a.union(&b);
        depth[x as usize] = 1 + da.max(db);
        (nbox[x as usize], depth[x as usize])
    }
    let mut nbox = vec![Aabb::default(); ni];
    let mut depth = vec![0u32; ni];
    fill(0, &child, boxes, &mut nbox, &mut depth);
    RadixTree {
        child,
        range,
        depth: depth[0],
        nbox,
    }
}

proptest::proptest! {
    /// The fused bottom-up pass builds Karras's tree: the same children, ranges, box
    /// bits and depth, on sorted keys with many duplicates (the index breaks the ties)
    /// and on all-equal keys.
    #[test]
    fn fused_pass_builds_karras_tree(seed in 0u64..1_000_000, n in 2usize..3000, spread in 1u64..1_000_000) {
        let mut rng = Pcg32::new(seed, 3);
        let mut keys: Vec<u64> = (0..n)
            .map(|_| (rng.next_u32() as u64 % spread) << (rng.below(30) % 4))
            .collect();
        keys.sort();
        let mut order: Vec<u32> = (0..n as u32).collect();
        for i in (1..n).rev() {
            order.swap(i, rng.below(i as u32 + 1) as usize);
        }
        let boxes: Vec<Aabb> = (0..n)
            .map(|_| {
                let c = Vec3::new(rng.range(-9.0, 9.0), rng.range(-9.0, 9.0), rng.range(-9.0, 9.0));
                Aabb::new(c - Vec3::splat(rng.range(0.0, 1.0)), c + Vec3::splat(rng.range(0.0, 1.0)))
            })
            .collect();
        let a = radix_tree(&keys, &order, &boxes);
        let b = radix_tree_karras(&keys, &order, &boxes);
        proptest::prop_assert_eq!(&a.child, &b.child);
        proptest::prop_assert_eq!(&a.range, &b.range);
        proptest::prop_assert_eq!(a.depth, b.depth);
        for (x, y) in a.nbox.iter().zip(&b.nbox) {
            proptest::prop_assert_eq!((x.min.to_array(), x.max.to_array()), (y.min.to_array(), y.max.to_array()));
        }
        let same = vec![7u64; n];
        let a = radix_tree(&same, &order, &boxes);
        let b = radix_tree_karras(&same, &order, &boxes);
        proptest::prop_assert_eq!(&a.child, &b.child);
        proptest::prop_assert_eq!(a.depth, b.depth);
    }
}

#[test]
fn spread_puts_every_bit_in_every_third_place() {
    let mut rng = Pcg32::new(8, 2);
    for bits in 1..=21 {
        for _ in 0..200 {
            let v = rng.next_u32();
            let mut slow = 0u64;
            for k in 0..bits {
                slow |= ((v >> k) as u64 & 1) << (3 * k);
            }
            assert_eq!(spread(v, bits), slow, "{v:#x}, {bits} bits");
        }
    }
}

#[test]
fn morton_codes_interleave_the_axes() {
    let b = Aabb::new(Vec3::ZERO, Vec3::splat(1024.0));
    assert_eq!(morton(Vec3::new(1.0, 0.0, 0.0), &b, 10), 1);
    assert_eq!(morton(Vec3::new(0.0, 1.0, 0.0), &b, 10), 2);
    assert_eq!(morton(Vec3::new(0.0, 0.0, 1.0), &b, 10), 4);
    assert_eq!(morton(Vec3::new(3.0, 0.0, 0.0), &b, 10), 9);
    assert_eq!(morton(Vec3::splat(2000.0), &b, 10), (1 << 30) - 1);
    assert_eq!(morton(Vec3::splat(2000.0), &b, 21), (1 << 63) - 1);
}

/// A tree makes only the records it is asked for, and the same tree either way.
#[test]
fn parts_make_only_their_records() {
    let tris = soup(500, 21);
    let all = build(&tris, &[0, 500], None, ObjectBuilder::Sah, Parts::ALL);
    for (dual, single) in [(true, false), (false, true)] {
        let t = build(
            &tris,
            &[0, 500],
            None,
            ObjectBuilder::Sah,
            Parts { dual, single },
        );
        assert_eq!(t.child, all.child);
        assert_eq!(t.tri_order, all.tri_order);
        assert_eq!(!t.wide.is_empty() && !t.node.is_empty(), dual);
        assert_eq!(!t.boxes.is_empty() && !t.leaf_tris.is_empty(), single);
        assert!(t.bytes() < all.bytes());
    }
}
