//! The dual traversal level by level ([`super::Schedule::Breadth`]): one stack of (ray node,
//! object node) pairs per ray level, each step a data-parallel test → count → scan → emit
//! over a chunk of one stack (the GPU's shape), single rays sorted by ray and walked on
//! their own; memory bounded by the pair budget.

use super::*;

impl Traversal<'_> {
    /// [`Schedule::Breadth`] over `nl ≥ 1` ray levels. Pairs wait in
    /// one stack per ray level. Each step takes at most a chunk of `budget / max(b, 2)`
    /// pairs from the top of one stack, so its output fits the pair budget: from the lowest
    /// level holding a full chunk, else from the highest level holding any, so steps are
    /// whole waves and no stack holds more than a chunk plus one step's output. The top
    /// level's pairs are made one chunk of top nodes at a time.
    pub(super) fn level_by_level(
        &self,
        tree: &ObjectTree,
        descent: Descent,
        diag: f32,
        rays: &RaySide,
        c: &mut Counters,
    ) {
        let nl = self.h.levels.len();
        let widest = self
            .h
            .levels
            .iter()
            .flat_map(|l| l.first.windows(2).map(|w| w[1] - w[0]))
            .max()
            .unwrap_or(1);
        let chunk = (self.budget / widest.max(2) as usize).max(1);
        let ray_nodes = self.ray_nodes(rays, diag);
        let nt = self.h.levels[nl - 1].len();
        let mut next_top = 0usize;
        // stacks[L]: pairs at ray level L (0: single rays by leaf position; L ≥ 1: nodes of
        // `levels[L − 1]`).
        let mut stacks: Vec<Pairs> = vec![(Vec::new(), Vec::new()); nl + 1];
        loop {
            if stacks[nl].0.is_empty() && next_top < nt {
                let end = (next_top + chunk).min(nt);
                stacks[nl].0.extend(next_top as u32..end as u32);
                stacks[nl].1.resize(end - next_top, tree.root);
                next_top = end;
            }
            // The lowest level holding a full chunk, else the highest holding any pairs:
            // steps stay large (few passes, each a whole wave), and no stack ever holds
            // more than a chunk plus one step's output.
            let full = stacks.iter().position(|s| s.0.len() >= chunk);
            let Some(l) = full.or_else(|| stacks.iter().rposition(|s| !s.0.is_empty())) else {
                break;
            };
            let held: usize = stacks.iter().map(|s| s.0.len()).sum();
            c.peak_pairs = c.peak_pairs.max(held as u64);
            // Two u32 per pair waiting (ray node, object node).
            c.peak_pair_bytes = c.peak_pair_bytes.max(8 * held as u64);
            let s = &mut stacks[l];
            let at = s.0.len().saturating_sub(chunk);
            let (rn, on) = (s.0.split_off(at), s.1.split_off(at));
            if l == 0 {
                self.ray_step(tree, rays, rn, on, c);
                continue;
            }
            let (below, here) =
                self.node_step(tree, descent, &ray_nodes[l - 1], l - 1, &rn, &on, c);
            for (s, p) in [(l, here), (l - 1, below)] {
                stacks[s].0.extend_from_slice(&p.0);
                stacks[s].1.extend_from_slice(&p.1);
            }
        }
    }

    /// Test (node of `levels[li]`, object node) pairs; run the final tests of the (level-1
    /// node, triangle) survivors and return the expanded pairs: (one ray level down, same
    /// level).
    #[allow(clippy::too_many_arguments)]
    fn node_step(
        &self,
        tree: &ObjectTree,
        descent: Descent,
        nodes: &[RayNode],
        li: usize,
        rn: &[u32],
        on: &[u32],
        c: &mut Counters,
    ) -> (Pairs, Pairs) {
        let level = &self.h.levels[li];
        // Test, decide what each survivor becomes, and count (in the same pass): tests and
        // passes per ray kind, object-node tests apart as well.
        let classify = |node: &RayNode, o: u32| self.classify(tree, descent, node, li, o);
        const BLOCK: usize = 2048;
        let mut action = vec![DROP; rn.len()];
        let (tests, hits, inner) = action
            .par_chunks_mut(BLOCK)
            .enumerate()
            .map(|(b, out)| {
                let (mut t, mut h, mut i) = ([0u64; 4], [0u64; 4], 0u64);
                for (j, a) in out.iter_mut().enumerate() {
                    let (r, o) = (rn[b * BLOCK + j], on[b * BLOCK + j]);
                    let node = &nodes[r as usize];
                    *a = classify(node, o);
                    let k = node.kind as usize;
                    t[k] += 1;
                    h[k] += (*a != DROP) as u64;
                    i += (o & LEAF == 0) as u64;
                }
                (t, h, i)
            })
            .reduce(
                || ([0; 4], [0; 4], 0),
                |a, b| {
                    (
                        std::array::from_fn(|k| a.0[k] + b.0[k]),
                        std::array::from_fn(|k| a.1[k] + b.1[k]),
                        a.2 + b.2,
                    )
                },
            );
        for k in 0..4 {
            c.tests[li][k] += tests[k];
            c.hits[li][k] += hits[k];
        }
        c.object_tests += inner;
        // What the survivors make, in one count pass and one emit pass: (level-1 node,
        // triangle) pairs for the final tests; on the ray side (child, object) for the
        // node's children one level down (leaf positions below level 1); on the object side
        // (node, child) for the collapsed node's children.
        let never = |_| Ok::<(), std::convert::Infallible>(());
        let made = emit_streams(
            action.len(),
            |i| match action[i] {
                FINAL => [1, 0, 0],
                RAY if li == 0 && small(tree, on[i]) => {
                    let [lo, hi] = tree.range[on[i] as usize];
                    [hi - lo + 1, 0, 0]
                }
                RAY => [0, level.children(rn[i] as usize).len() as u32, 0],
                OBJECT => [0, 0, tree.wide[tree.wide_of[on[i] as usize] as usize].count],
                _ => [0; 3],
            },
            never,
            |i, out| match action[i] {
                FINAL => out(0, rn[i], on[i] & !LEAF),
                RAY if li == 0 && small(tree, on[i]) => {
                    let [lo, hi] = tree.range[on[i] as usize];
                    for &tri in &tree.tri_order[lo as usize..=hi as usize] {
                        out(0, rn[i], tri);
                    }
                }
                RAY => {
                    for ch in level.children(rn[i] as usize) {
                        out(1, ch as u32, on[i]);
                    }
                }
                _ => {
                    let w = &tree.wide[tree.wide_of[on[i] as usize] as usize];
                    for &ch in &w.child[..w.count as usize] {
                        out(2, rn[i], ch);
                    }
                }
            },
        );
        let [(fn_, ft), below, here] = match made {
            Ok(m) => m,
            Err(e) => match e {},
        };
        if li == 0 {
            let t0 = Instant::now();
            self.final_tests(&fn_, &ft, c);
            c.final_seconds += t0.elapsed().as_secs_f64();
        }
        (below, here)
    }

    /// Single rays (leaf positions) against object nodes: the pairs are sorted by ray, then
    /// each ray walks its object subtrees depth first on its own (a triangle is a final
    /// test, an inner node's children get robust slab tests, the nearer child first). A ray
    /// reads the closest hit of the steps before this one and its own, so the counts do not
    /// depend on scheduling; its hit's t caps the slabs (inclusive, so a tie with a smaller
    /// triangle id still gets through), and with any-hit a ray stops at its first hit.
    fn ray_step(
        &self,
        tree: &ObjectTree,
        rays: &RaySide,
        mut pos: Vec<u32>,
        mut on: Vec<u32>,
        c: &mut Counters,
    ) {
        let t0 = Instant::now();
        let bits = 32 - (self.h.order.len() as u32).leading_zeros();
        sort_pairs(&mut pos, &mut on, bits.max(1), &mut SortScratch::new());
        let mut head = vec![0u32; pos.len()];
        let mut run_ray = vec![0u32; pos.len()];
        let mut run_size = vec![0u32; pos.len()];
        let runs = compress_runs(&pos, &mut run_ray, &mut head, &mut run_size);
        let (finals, boxes, passes) = (0..runs)
            .into_par_iter()
            .with_min_len(256)
            .fold(
                || ([0u64; 4], 0u64, 0u64, Vec::<u32>::new()),
                |(mut f, mut b, mut p, mut stack), k| {
                    let start = head[k] as usize;
                    stack.clear();
                    stack.extend(on[start..start + run_size[k] as usize].iter().rev());
                    let (kind, w, _) = self.walk_ray(tree, rays, run_ray[k] as usize, &mut stack);
                    f[kind] += w[0];
                    b += w[1];
                    p += w[2];
                    (f, b, p, stack)
                },
            )
            .map(|(f, b, p, _)| (f, b, p))
            .reduce(
                || ([0; 4], 0, 0),
                |a, b| {
                    (
                        std::array::from_fn(|k| a.0[k] + b.0[k]),
                        a.1 + b.1,
                        a.2 + b.2,
                    )
                },
            );
        c.final_seconds += t0.elapsed().as_secs_f64();
        c.final_tests = std::array::from_fn(|k| c.final_tests[k] + finals[k]);
        c.ray_box_tests += boxes;
        c.ray_box_passes += passes;
    }
}
