// The dual traversal's steps without the host (dual.rs's `run_rounds`): the same schedule as
// dual.wgsl's host-driven steps where no stack reaches the pair budget's chunk, which is
// then "the highest level holding pairs, all of them": each round takes every pair of the
// current ray level (a count on the device), emits its final tests, appends its pairs one ray
// level down to that level's stack and leaves the pairs of collapsed nodes' children as the
// next round's input. Every buffer holds `cap` pairs (cap < chunk); a round that would pass
// it sets the overflow flag, after which every round does nothing and the host traces the
// batch again with its own steps. The host encodes rounds for every level and the single
// rays' walk without knowing how many each needs: a kernel of ray level L (its `stage`) acts
// only while the state's level is L, and the state moves one level down when its level has
// no pairs left. The state (r_state, u32 words): 0 overflow flag, 1 pairs of the current
// level, 2 pairs of the level below, 3 the most pairs held at once, 4 the last round's final
// tests, 5 the current ray level (0: single rays), 6 walked (the single rays' step ran).
// Bindings: 30 state, 31 the level below's stack: ray node, 32 object node, 33 final tests:
// level-1 node, 34 triangle (with dual.wgsl's: 19/20 the round's input, 21 actions, 22 counts
// then offsets, 23/24 the next round's input).

// Parameters of the rounds' kernels.
struct DualRoundParams {
    cap: u32, // pairs every buffer holds (the counts' stride)
    level: u32, // the ray nodes' level index (0: level 1)
    exact: u32, // 1: the exact cone test
    descent: u32, // 0: size, 1: object first, 2: ray first
    counters: u32, // the level's first counter word
    objects: u32, // the word of the tests against inner object nodes
    pad: u32, // dual_round_pad: the key past the last leaf position
    stage: u32, // the ray level the kernel serves (level index + 1; 0: single rays)
}

@group(0) @binding(30) var<storage, read_write> r_state: array<atomic<u32>>;
@group(0) @binding(31) var<storage, read_write> r_below_ray: array<u32>;
@group(0) @binding(32) var<storage, read_write> r_below_obj: array<u32>;
@group(0) @binding(33) var<storage, read_write> r_fin_ray: array<u32>;
@group(0) @binding(34) var<storage, read_write> r_fin_obj: array<u32>;

const R_FLAG: u32 = 0u;
const R_PAIRS: u32 = 1u;
const R_BELOW: u32 = 2u;
const R_PEAK: u32 = 3u;
const R_FINALS: u32 = 4u;
const R_LEVEL: u32 = 5u;
const R_WALKED: u32 = 6u;

// The pairs of ray level `stage` this round takes: none unless the state is at that level.
fn round_pairs(stage: u32) -> u32 {
    if atomicLoad(&r_state[R_FLAG]) != 0u || atomicLoad(&r_state[R_LEVEL]) != stage {
        return 0u;
    }
    return atomicLoad(&r_state[R_PAIRS]);
}

fn as_pair_params(r: DualRoundParams) -> DualPairParams {
    return DualPairParams(r.cap, r.level, r.exact, r.descent, r.counters, r.objects);
}

// dual_classify over the round's pairs (a count in the state); the counts of the slots past
// it (to cap) are zero, so the scan over 3 · cap gives each stream's offsets.
@compute @workgroup_size(256)
fn dual_round_classify(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(local_invocation_index) li: u32, @builtin(num_workgroups) nwg: vec3<u32>) {
    wcnt_reset(li);
    let r = dual_round_params();
    let p = as_pair_params(r);
    let n = round_pairs(r.stage);
    let i = gid.x + gid.y * nwg.x * 256u;
    if i < r.cap {
        var c = vec3<u32>(0u);
        if i < n {
            let nd = p_ray[i];
            let o = p_obj[i];
            let act = classify(p, nd, o);
            let k = bitcast<u32>(n_sc[nd].w) & 3u;
            atomicAdd(&wcnt[k], 1u);
            if act != DROP {
                atomicAdd(&wcnt[4u + k], 1u);
            }
            if (o & LEAF) == 0u {
                atomicAdd(&wcnt[8u], 1u);
            }
            p_act[i] = act;
            if act == FINAL {
                c.x = 1u;
            } else if act == RAY {
                if p.level == 0u && small(o) {
                    let rg = t_range[o];
                    c.x = rg.y - rg.x + 1u;
                } else {
                    c.y = n_first[nd + 1u] - n_first[nd];
                }
            } else if act == OBJECT {
                c.z = frontier(o).n;
            }
        }
        p_cnt[i] = c.x;
        p_cnt[r.cap + i] = c.y;
        p_cnt[2u * r.cap + i] = c.z;
    }
    workgroupBarrier();
    if li < 4u {
        flush_one(li, p.counters + 2u * li);
        flush_one(4u + li, p.counters + 8u + 2u * li);
    } else if li == 4u {
        flush_one(8u, p.objects);
    }
}

// Put one pair at slot `at` of a buffer of cap pairs (past it: the round overflows, and the
// update kernel says so).
fn put(which: u32, at: u32, cap: u32, nd: u32, o: u32) {
    if at >= cap {
        return;
    }
    if which == 0u {
        r_fin_ray[at] = nd;
        r_fin_obj[at] = o;
    } else if which == 1u {
        r_below_ray[at] = nd;
        r_below_obj[at] = o;
    } else {
        o_ray[at] = nd;
        o_obj[at] = o;
    }
}

// dual_emit for a round: final tests from slot 0 of their buffer, the pairs one level down
// appended to that level's stack, the collapsed nodes' children from slot 0 of the next
// round's input.
@compute @workgroup_size(256)
fn dual_round_emit(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let r = dual_round_params();
    let i = gid.x + gid.y * nwg.x * 256u;
    if i >= round_pairs(r.stage) {
        return;
    }
    let act = p_act[i];
    let nd = p_ray[i];
    let o = p_obj[i];
    let f = p_cnt[r.cap];
    let fb = p_cnt[2u * r.cap];
    let below = atomicLoad(&r_state[R_BELOW]);
    if act == FINAL {
        put(0u, p_cnt[i], r.cap, nd, o & ~LEAF);
    } else if act == RAY {
        if r.level == 0u && small(o) {
            let at = p_cnt[i];
            let rg = t_range[o];
            for (var j = rg.x; j <= rg.y; j++) {
                put(0u, at + j - rg.x, r.cap, nd, t_order[j]);
            }
        } else {
            var at = below + p_cnt[r.cap + i] - f;
            for (var c = n_first[nd]; c < n_first[nd + 1u]; c++) {
                put(1u, at, r.cap, c, o);
                at++;
            }
        }
    } else if act == OBJECT {
        let fr = frontier(o);
        let at = p_cnt[2u * r.cap + i] - fb;
        for (var j = 0u; j < fr.n; j++) {
            put(2u, at + j, r.cap, nd, fr.f[j]);
        }
    }
}

// After a round's emit (one thread): the most pairs held (this round's input and the level
// below's stack, as the host's steps count them), the overflow check, the level below's new
// length, the next round's input count and this round's final tests.
@compute @workgroup_size(1)
fn dual_round_update(@builtin(global_invocation_id) gid: vec3<u32>) {
    let r = dual_round_params();
    let n = round_pairs(r.stage);
    // (Read by this round's final tests alone: none unless the round ran.)
    atomicStore(&r_state[R_FINALS], 0u);
    if n == 0u {
        return;
    }
    let below = atomicLoad(&r_state[R_BELOW]);
    atomicMax(&r_state[R_PEAK], n + below);
    let f = p_cnt[r.cap];
    let b = p_cnt[2u * r.cap] - f;
    let h = p_cnt[3u * r.cap] - f - b;
    if f > r.cap || below + b > r.cap || h > r.cap {
        atomicStore(&r_state[R_FLAG], 1u);
        return;
    }
    atomicStore(&r_state[R_BELOW], below + b);
    atomicStore(&r_state[R_PAIRS], h);
    atomicStore(&r_state[R_FINALS], f);
}

// After a level's rounds (one thread): where the state is at that level and it has no pairs
// left, the level below's stack becomes the input.
@compute @workgroup_size(1)
fn dual_round_descend(@builtin(global_invocation_id) gid: vec3<u32>) {
    let r = dual_round_params();
    if atomicLoad(&r_state[R_FLAG]) != 0u || atomicLoad(&r_state[R_LEVEL]) != r.stage || atomicLoad(&r_state[R_PAIRS]) != 0u {
        return;
    }
    atomicStore(&r_state[R_LEVEL], r.stage - 1u);
    let n = atomicLoad(&r_state[R_BELOW]);
    atomicStore(&r_state[R_PAIRS], n);
    atomicStore(&r_state[R_BELOW], 0u);
    // Held now: the new level's pairs alone (the single rays' step counts them here).
    atomicMax(&r_state[R_PEAK], n);
}

// The single rays' stack (a copy) padded to cap with a key past every leaf position, so the
// sort over all cap slots leaves the pairs in the host's order, the padding last; where the
// state has not reached the single rays, every slot is padding (and nothing walks).
@compute @workgroup_size(256)
fn dual_round_pad(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let r = dual_round_params();
    let i = gid.x + gid.y * nwg.x * 256u;
    let n = round_pairs(0u);
    if i == 0u && atomicLoad(&r_state[R_FLAG]) == 0u && atomicLoad(&r_state[R_LEVEL]) == 0u {
        atomicStore(&r_state[R_WALKED], 1u);
    }
    if i < r.cap && i >= n {
        r_below_ray[i] = r.pad;
        r_below_obj[i] = 0u;
    }
}

// dual_walk over the single rays' stack of the rounds (its count in the state).
@compute @workgroup_size(64)
fn dual_round_walk(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(local_invocation_index) li: u32, @builtin(num_workgroups) nwg: vec3<u32>) {
    wcnt_reset(li);
    let p = dual_walk_params();
    walk_slot(gid.x + gid.y * nwg.x * 64u, round_pairs(0u), p.any != 0u);
    flush_walk(li, p);
}
