//! Bottom-up construction of the sphere-cone hierarchy (thesis §3.2.7).
//!
//! Level 1 groups `b` consecutive leaves (sorted rays) of the same ray kind: origins bounded
//! by a sphere, directions by the minimal cone built ray by ray (eqs. 3.8–3.11). Level k + 1
//! groups `b` consecutive level-k nodes of the same kind by sphere and cone union — the exact
//! minimal unions or the thesis's eqs. 3.12–3.15. Nodes never mix kinds, so a batch holding
//! shadow, reflection and refraction rays still gets one hierarchy per kind. Every level is a
//! set of flat arrays (8 floats of sphere and cone per node, plus the rays' longest extent
//! and the kind), and children are a contiguous range of the level below.

use geom::cone::Cone;
use geom::{cone8, miniball, Sphere, Vec3};
use rayon::prelude::*;
use trace::RayBatch;

/// Which union formulas build the nodes.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Union {
    /// Minimal enclosing ball of the level-1 origins; exact minimal sphere and cone unions.
    Exact,
    /// The thesis's formulas: eqs. 3.12–3.13 (cones, with the notes' fix) and 3.14–3.15.
    Thesis,
}

impl Union {
    /// Every value by its name (as options spell it).
    pub const NAMES: [(&'static str, Union); 2] =
        [("exact", Union::Exact), ("thesis", Union::Thesis)];
}

/// One level of nodes (structure of arrays).
#[derive(Clone, Debug, Default)]
pub struct Level {
    /// Origin sphere centres.
    pub center: Vec<Vec3>,
    /// Origin sphere radii.
    pub radius: Vec<f32>,
    /// Unit cone axes.
    pub axis: Vec<Vec3>,
    /// Cone half-angle in radians; ≥ π/2 means *wide* (always passes).
    pub angle: Vec<f32>,
    /// sin α and cos α, precomputed for the node tests.
    pub sin: Vec<f32>,
    /// cos α (with `sin`).
    pub cos: Vec<f32>,
    /// Longest t_max of the node's rays (∞ for unbounded rays): the far cap of the tests.
    pub max_t: Vec<f32>,
    /// Ray kind of every ray below the node.
    pub kind: Vec<u8>,
    /// Children of node i: `first[i] .. first[i + 1]` in the level below (leaves for level 1).
    pub first: Vec<u32>,
}

impl Level {
    /// Number of nodes.
    pub fn len(&self) -> usize {
        self.radius.len()
    }

    /// Whether the level has no nodes.
    pub fn is_empty(&self) -> bool {
        self.radius.is_empty()
    }

    /// Node i's origin sphere.
    #[inline]
    pub fn sphere(&self, i: usize) -> Sphere {
        Sphere {
            center: self.center[i],
            radius: self.radius[i],
        }
    }

    /// Node i's direction cone.
    #[inline]
    pub fn cone(&self, i: usize) -> Cone {
        Cone {
            axis: self.axis[i],
            angle: self.angle[i],
        }
    }

    /// The cone with its precomputed sine and cosine.
    #[inline]
    pub fn cone_sc(&self, i: usize) -> geom::cone::ConeSc {
        let a = self.angle[i];
        geom::cone::ConeSc {
            axis: self.axis[i],
            sin: self.sin[i],
            cos: self.cos[i],
            wide: a >= std::f32::consts::FRAC_PI_2,
            full: a >= std::f32::consts::PI,
        }
    }

    /// Node i's children in the level below (leaf positions for level 1).
    #[inline]
    pub fn children(&self, i: usize) -> std::ops::Range<usize> {
        self.first[i] as usize..self.first[i + 1] as usize
    }

    /// The level's arrays from its nodes, each array in one parallel pass (level 1 has a
    /// node per `b` rays of the batch).
    fn from_nodes(first: Vec<u32>, nodes: Vec<(Sphere, Cone, f32, u8)>) -> Level {
        fn col<T: Send>(
            nodes: &[(Sphere, Cone, f32, u8)],
            f: impl Fn(&(Sphere, Cone, f32, u8)) -> T + Sync + Send,
        ) -> Vec<T> {
            nodes.par_iter().with_min_len(1024).map(f).collect()
        }
        // Portable sine and cosine: the GPU backend computes the same bits.
        let (sin, cos): (Vec<f32>, Vec<f32>) = nodes
            .par_iter()
            .with_min_len(1024)
            .map(|n| geom::pmath::sin_cos(n.1.angle))
            .unzip();
        Level {
            center: col(&nodes, |n| n.0.center),
            radius: col(&nodes, |n| n.0.radius),
            axis: col(&nodes, |n| n.1.axis),
            angle: col(&nodes, |n| n.1.angle),
            sin,
            cos,
            max_t: col(&nodes, |n| n.2),
            kind: col(&nodes, |n| n.3),
            first,
        }
    }
}

/// The hierarchy over one ray batch: leaves in `order` (ray indices) and levels 1..=d.
#[derive(Clone, Debug, Default)]
pub struct Hierarchy {
    /// Ray indices in leaf order (the rays that can hit anything).
    pub order: Vec<u32>,
    /// `levels[0]` is level 1 (parents of leaves); the last is the top level.
    pub levels: Vec<Level>,
}

/// Group boundaries: runs of equal `kind`, each cut into groups of `b`; returns `first`
/// (group starts plus the final end). The runs are found and cut in parallel (sorted rays
/// make few runs, one per ray kind, over up to millions of leaves).
fn group_starts(kind: &[u8], b: usize) -> Vec<u32> {
    let n = kind.len();
    let mut runs: Vec<usize> = (0..n)
        .into_par_iter()
        .with_min_len(1 << 14)
        .filter(|&i| i == 0 || kind[i] != kind[i - 1])
        .collect();
    runs.push(n);
    let mut first = Vec::with_capacity(n / b + runs.len() + 1);
    for w in runs.windows(2) {
        let (start, end) = (w[0], w[1]);
        first.par_extend(
            (0..(end - start).div_ceil(b))
                .into_par_iter()
                .with_min_len(1 << 12)
                .map(|g| (start + g * b) as u32),
        );
    }
    first.push(n as u32);
    first
}

/// Build level 1 over the sorted leaves and `levels − 1` more levels above it; with
/// `levels == 0`, keep going until every kind has a single root.
pub fn build(rays: &RayBatch, order: Vec<u32>, b: usize, levels: u32, union: Union) -> Hierarchy {
    assert!((2..=64).contains(&b), "branching factor must be in 2..=64");
    let leaf_kind: Vec<u8> = order
        .par_iter()
        .with_min_len(1 << 14)
        .map(|&r| rays.kind[r as usize])
        .collect();
    let first = group_starts(&leaf_kind, b);
    // Eqs. 3.8–3.11: the level-1 cone grows ray by ray (exact for each added ray), 8 nodes
    // side by side in lanes (geom::cone8, bit for bit the scalar cones). Directions are
    // normalised here, and lengths measured in distance, so rays from files with
    // unnormalised directions are bounded correctly too.
    let unit = |r: u32| rays.dir[r as usize].normalize();
    let ng = first.len() - 1;
    let mut nodes = vec![(Sphere::default(), Cone::WIDE, 0.0f32, 0u8); ng];
    nodes.par_chunks_mut(8).enumerate().for_each(|(blk, out)| {
        let g0 = blk * 8;
        let leaves = |l: usize| &order[first[g0 + l] as usize..first[g0 + l + 1] as usize];
        let mut cones: [Cone; 8] = std::array::from_fn(|l| {
            if l < out.len() {
                Cone::from_dir(unit(leaves(l)[0]))
            } else {
                Cone::WIDE
            }
        });
        let longest = (0..out.len()).map(|l| leaves(l).len()).max().unwrap_or(0);
        for i in 1..longest {
            let mut mask = 0u8;
            let dirs: [Vec3; 8] = std::array::from_fn(|l| {
                if l < out.len() && i < leaves(l).len() {
                    mask |= 1 << l;
                    unit(leaves(l)[i])
                } else {
                    Vec3::Z
                }
            });
            cone8::add_dir8(&mut cones, &dirs, mask);
        }
        // At most 64 leaves (the branching factor's cap): no allocation per node, and one
        // buffer for the block's nodes (not one cleared per node).
        let mut pts = [Vec3::ZERO; 64];
        for (l, node) in out.iter_mut().enumerate() {
            let leaves = leaves(l);
            let r0 = leaves[0] as usize;
            let sphere = match union {
                Union::Exact => {
                    for (p, &r) in pts.iter_mut().zip(leaves) {
                        *p = rays.org[r as usize];
                    }
                    miniball::minimal_ball(&pts[..leaves.len()]).unwrap_or_default()
                }
                Union::Thesis => leaves[1..]
                    .iter()
                    .fold(Sphere::new(rays.org[r0], 0.0), |s, &r| {
                        s.union_thesis(&Sphere::new(rays.org[r as usize], 0.0))
                    }),
            };
            let max_t = leaves
                .iter()
                .map(|&r| rays.t_max[r as usize] * rays.dir[r as usize].length())
                .fold(0.0f32, f32::max)
                * (1.0 + 4.0 * f32::EPSILON);
            *node = (sphere, cones[l], max_t, rays.kind[r0]);
        }
    });
    let mut h = Hierarchy {
        order,
        levels: vec![Level::from_nodes(first, nodes)],
    };
    loop {
        let below = h.levels.last().unwrap();
        let done = if levels == 0 {
            // One root per kind: every node of the top level has a distinct kind.
            below.kind.windows(2).all(|w| w[0] != w[1])
        } else {
            h.levels.len() as u32 >= levels
        };
        if done || below.len() <= 1 {
            break;
        }
        let first = group_starts(&below.kind, b);
        let nodes: Vec<(Sphere, Cone, f32, u8)> = (0..first.len() - 1)
            .into_par_iter()
            .map(|g| {
                let ch = first[g] as usize..first[g + 1] as usize;
                let c0 = ch.start;
                let mut s = below.sphere(c0);
                let mut k = below.cone(c0);
                let mut t = below.max_t[c0];
                for c in ch.start + 1..ch.end {
                    match union {
                        Union::Exact => {
                            s = s.union_exact(&below.sphere(c));
                            k = k.union_exact(&below.cone(c));
                        }
                        Union::Thesis => {
                            s = s.union_thesis(&below.sphere(c));
                            k = k.union_thesis(&below.cone(c));
                        }
                    }
                    t = t.max(below.max_t[c]);
                }
                (s, k, t, below.kind[c0])
            })
            .collect();
        h.levels.push(Level::from_nodes(first, nodes));
    }
    h
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    use testkit::clustered_batch as batch;

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(64))]

        /// Every node contains every ray below it: origin in the sphere, direction in the
        /// cone, t_max within max_t; and nodes never mix kinds.
        #[test]
        fn nodes_contain_their_rays(seed in 0u64..1_000_000, n in 1usize..600, b in 2usize..17, levels in 0u32..5, exact in any::<bool>()) {
            let rays = batch(seed, n);
            let order: Vec<u32> = (0..n as u32).collect();
            let union = if exact { Union::Exact } else { Union::Thesis };
            let h = build(&rays, order, b, levels, union);
            for (li, level) in h.levels.iter().enumerate() {
                prop_assert_eq!(*level.first.last().unwrap() as usize, if li == 0 { n } else { h.levels[li - 1].len() });
                for node in 0..level.len() {
                    // Leaves under this node.
                    let mut range = level.children(node);
                    for lower in h.levels[..li].iter().rev() {
                        range = lower.first[range.start] as usize..lower.first[range.end] as usize;
                    }
                    let s = level.sphere(node);
                    let k = level.cone(node);
                    for &r in &h.order[range] {
                        let r = r as usize;
                        let tol = 1e-5 * (1.0 + s.center.abs().max_element());
                        prop_assert!((rays.org[r] - s.center).length() <= s.radius + tol, "level {} node {}: origin outside", li + 1, node);
                        prop_assert!(k.contains_dir(rays.dir[r]), "level {} node {}: direction outside {:?}", li + 1, node, k);
                        prop_assert!(rays.t_max[r] * rays.dir[r].length() <= level.max_t[node]);
                        prop_assert_eq!(rays.kind[r], level.kind[node]);
                    }
                }
            }
            if levels > 0 {
                prop_assert!(h.levels.len() as u32 <= levels);
            }
        }
    }

    proptest! {
        /// The parallel cut is the sequential definition: a group starts at every run start
        /// and every `b` leaves into a run.
        #[test]
        fn groups_cut_runs_every_b(runs in proptest::collection::vec((0u8..3, 1usize..3000), 0..12), b in 2usize..65) {
            let kinds: Vec<u8> = runs.iter().flat_map(|&(k, len)| std::iter::repeat_n(k, len)).collect();
            let mut want = Vec::new();
            let mut run_start = 0;
            for i in 0..kinds.len() {
                if i > 0 && kinds[i] != kinds[i - 1] {
                    run_start = i;
                }
                if (i - run_start) % b == 0 {
                    want.push(i as u32);
                }
            }
            want.push(kinds.len() as u32);
            prop_assert_eq!(group_starts(&kinds, b), want);
        }
    }

    #[test]
    fn full_pyramid_reaches_one_root_per_kind() {
        let rays = batch(5, 1000);
        let h = build(&rays, (0..1000).collect(), 4, 0, Union::Exact);
        let top = h.levels.last().unwrap();
        let mut kinds = top.kind.clone();
        kinds.dedup();
        assert_eq!(kinds.len(), top.len());
    }
}
