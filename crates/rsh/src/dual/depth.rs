//! The dual traversal depth first ([`super::Schedule::Depth`], the default): every top ray
//! node is one task popping pairs from its own stack, children tested 8 at a time in AVX
//! lanes ([`crate::node8`]), the final tests among the pair tests.

use super::*;

impl Traversal<'_> {
    /// [`Schedule::Depth`] over `nl ≥ 1` ray levels, the final tests among it: every top
    /// ray node is one task that pops pairs from its own stack (`peak_pairs`: the most one
    /// task held). An object node's children are pushed in [`ANY_HIT_BIAS`]'s order
    /// (nearer first along the ray node's cone axis for the closest hit), a ray node's
    /// children in leaf order.
    pub(super) fn depth_first(
        &self,
        tree: &ObjectTree,
        descent: Descent,
        diag: f32,
        rays: &RaySide,
        c: &mut Counters,
    ) {
        let nl = self.h.levels.len();
        let ray_nodes = self.ray_nodes(rays, diag);
        // Any hit: per node, its rays still without a hit (a node at 0 has no work left),
        // and each node's parent, so a ray's first hit is counted off every node above it.
        // Only the task of the ray's top node touches these (Relaxed atomics, never
        // contended).
        let open = rays.any_hit.then(|| self.open_rays());
        let resolve = |p: usize| {
            if let Some((left, parent)) = &open {
                let mut n = p;
                for (l, up) in left.iter().zip(parent) {
                    n = up[n] as usize;
                    l[n].fetch_sub(1, Ordering::Relaxed);
                }
            }
        };
        let done = |li: usize, n: usize| {
            open.as_ref()
                .is_some_and(|(left, _)| left[li][n].load(Ordering::Relaxed) == 0)
        };
        // Ray nodes as lanes for the children tests (RAH's node test on a CPU with AVX; every
        // level but the top is some node's children).
        let lanes = (self.test == NodeTest::Rah && node8::available()).then(|| {
            ray_nodes[..nl - 1]
                .iter()
                .map(|level| NodeLanes::new(level.len(), |i| level[i].fields()))
                .collect::<Vec<_>>()
        });
        let nt = self.h.levels[nl - 1].len();
        let bias = if rays.any_hit { ANY_HIT_BIAS } else { 0.0 };
        let t = (0..nt)
            .into_par_iter()
            .with_min_len(4)
            .fold(
                || (Tally::new(nl), Vec::<Job>::new(), Vec::<u32>::new()),
                |(mut t, mut stack, mut walk), top| {
                    stack.push(Job {
                        l: nl as u32,
                        r: top as u32,
                        o: tree.root,
                        act: DROP,
                    });
                    while let Some(j) = stack.pop() {
                        t.peak = t.peak.max(stack.len() as u64 + 1);
                        let (r, o) = (j.r as usize, j.o);
                        let li = j.l as usize - 1;
                        let node = &ray_nodes[li][r];
                        let k = node.kind as usize;
                        // An any-hit node whose rays all hit has no work left, whatever
                        // the pair was to become.
                        if done(li, r) {
                            continue;
                        }
                        let a = if j.act != DROP {
                            j.act
                        } else {
                            let a = self.classify(tree, descent, node, li, o);
                            t.count(li, k, a != DROP, o);
                            a
                        };
                        match a {
                            FINAL => {
                                t.finals[k] += self.final_test(r, o & !LEAF, &mut |p| resolve(p))
                            }
                            RAY if li >= 1 && lanes.is_some() => {
                                // The children against the object 8 at a time; the pairs
                                // that pass wait with their action, first child on top.
                                let (cl, lanes) = (li - 1, &lanes.as_ref().unwrap()[li - 1]);
                                let ch = self.h.levels[li].children(r);
                                let ob = tree.bounds(o);
                                let (p, d) = (ob.sphere.center, ob.sphere.radius);
                                let from = stack.len();
                                for x0 in ch.clone().step_by(8) {
                                    let n = (ch.end - x0).min(8);
                                    let m = node8::test8(lanes, x0, p, d, &ob.bbox);
                                    for (i, x) in (x0..x0 + n).enumerate() {
                                        if done(cl, x) {
                                            continue;
                                        }
                                        let cn = &ray_nodes[cl][x];
                                        let pass = m >> i & 1 != 0;
                                        t.count(cl, cn.kind as usize, pass, o);
                                        if pass {
                                            stack.push(Job {
                                                l: li as u32,
                                                r: x as u32,
                                                o,
                                                act: action(descent, cn, cl, o, d),
                                            });
                                        }
                                    }
                                }
                                stack[from..].reverse();
                            }
                            RAY if li == 0 && small(tree, o) => {
                                // A small subtree: its triangles' exact tests, the node's
                                // rays 8 lanes at a time, in leaf order (each of the node's
                                // rays walking it alone would cost more: a walk's set-up, its
                                // slab tests and scalar triangle tests, per ray).
                                let [lo, hi] = tree.range[o as usize];
                                for &tri in &tree.tri_order[lo as usize..=hi as usize] {
                                    if done(li, r) {
                                        break;
                                    }
                                    t.finals[k] += self.final_test(r, tri, &mut |p| resolve(p));
                                }
                            }
                            RAY if li == 0 => {
                                // Single rays: each walks the object's subtree now, first
                                // ray first (the order their pairs would leave the stack).
                                for x in self.h.levels[0].children(r) {
                                    walk.clear();
                                    walk.push(o);
                                    let (kind, w, first) = self.walk_ray(tree, rays, x, &mut walk);
                                    if first {
                                        resolve(x);
                                    }
                                    t.finals[kind] += w[0];
                                    t.boxes += w[1];
                                    t.passes += w[2];
                                }
                            }
                            RAY => {
                                let ch = self.h.levels[li].children(r);
                                stack.extend(ch.rev().map(|x| Job {
                                    l: li as u32,
                                    r: x as u32,
                                    o,
                                    act: DROP,
                                }));
                            }
                            OBJECT => {
                                // The collapsed node's children against the ray node, 8 at
                                // a time (or one by one: the same tests); the survivors wait
                                // with their action, in `ANY_HIT_BIAS`'s order (nearest along
                                // the cone's axis on top with the closest hit).
                                let w = &tree.wide[tree.wide_of[o as usize] as usize];
                                let n = w.count as usize;
                                let m = if lanes.is_some() {
                                    node8::test8_objects(&node.fields(), w)
                                } else {
                                    (0..n).fold(0u8, |m, i| {
                                        let b = tree.bounds(w.child[i]);
                                        let pass = node.beam_test(&b.bbox)
                                            && node.cone_test(
                                                self.test,
                                                b.sphere.center,
                                                b.sphere.radius,
                                            );
                                        m | (pass as u8) << i
                                    })
                                };
                                let mut near = [(0.0f32, 0u32, DROP); 8];
                                let mut ns = 0;
                                for (i, &x) in w.child[..n].iter().enumerate() {
                                    let pass = m >> i & 1 != 0;
                                    t.count(li, k, pass, x);
                                    if pass {
                                        // The child's sphere from the collapsed node's lanes
                                        // (not its own record, elsewhere in memory).
                                        let c = Vec3::new(
                                            w.center[0][i],
                                            w.center[1][i],
                                            w.center[2][i],
                                        );
                                        let along = (c - node.center).dot(node.cone.axis);
                                        let a = action(descent, node, li, x, w.radius[i]);
                                        let key = along - bias * w.radius[i];
                                        // Insertion by key (ties keep the children's order).
                                        let mut at = ns;
                                        while at > 0 && near[at - 1].0 > key {
                                            near[at] = near[at - 1];
                                            at -= 1;
                                        }
                                        near[at] = (key, x, a);
                                        ns += 1;
                                    }
                                }
                                stack.extend(near[..ns].iter().rev().map(|&(_, o, act)| Job {
                                    l: j.l,
                                    r: j.r,
                                    o,
                                    act,
                                }));
                            }
                            _ => {}
                        }
                    }
                    (t, stack, walk)
                },
            )
            .map(|(t, _, _)| t)
            .reduce(|| Tally::new(nl), Tally::merge);
        for li in 0..nl {
            c.tests[li] = t.tests[li];
            c.hits[li] = t.hits[li];
        }
        c.object_tests += t.inner;
        c.final_tests = std::array::from_fn(|k| c.final_tests[k] + t.finals[k]);
        c.ray_box_tests += t.boxes;
        c.ray_box_passes += t.passes;
        c.peak_pairs = c.peak_pairs.max(t.peak);
        let workers = rayon::current_num_threads() as u64;
        let bytes = t.peak * std::mem::size_of::<Job>() as u64 * workers;
        c.peak_pair_bytes = c.peak_pair_bytes.max(bytes);
    }
}
