// The `bvh` engine's single rays on the device, the twin of crates/accel/src/bvh/single.rs:
// one thread per ray walks the object tree's box nodes (objects.wgsl `obj_box_nodes`) with a stack of
// (node, entry); a popped node entered beyond the closest hit so far is skipped; its lanes
// get Ize's robust slab test (the same operations as `boxes_scalar`), its passing leaf
// lanes' triangles the shared watertight kernel in lane order (the closest hit the smallest
// (t bits << 32 | triangle id), as brute force), and its passing inner children are pushed
// farthest first (a stable insertion sort, as the CPU). With any-hit a ray stops at its
// first hit. So hits and every count are the CPU walk's.
//
// A ray's stack lives in private memory, `stack` entries (at most STACK). A ray that would
// need more stops, adds none of its counts and is listed after the counters; a second pass
// (single_walk_deep, a fixed pool of threads over the list) walks the listed rays again from
// the start with DEEP entries each in storage memory, which no LBVH can exceed: a node test
// pushes at most 7 more entries than it pops, once per box level on the path, and a radix
// tree over 64-bit keys with 32-bit index tie-breaks is at most 97 levels deep (7 · 97 + 1
// < DEEP). Should it ever be exceeded, the ray is counted in word OVER_DEEP and left for the
// host.
//
// A finished ray writes its hit record itself (triangle, t, u, v bits; a miss: NO_HIT, +inf):
// the winner's t, u and v from the same shared kernel call that made it the winner, which is
// what final.wgsl's `records` recomputes for the bundles (the same inputs, the triangle's
// vertices copied bit for bit into leaf order), so no records pass follows the walk.
//
// Bindings: 1 ray org | t_min, 2 ray dir | t_max, 3 kind | light << 2, 4 box nodes,
// 5 triangles in leaf order (3 × vec4), 6 leaf order (triangle ids), 7 hit records,
// 8 counters: 64-bit (low, high) final tests per kind, box tests, box passes, hits (words
// 0..14), then the overflowed rays' count (word 14) and ids (from word 15).

// Parameters of single_walk.
struct SingleWalkParams {
    rays: u32, // rays of the batch
    leaves: u32, // triangles of the tree (1: a lone triangle, no node)
    any: u32, // 1: any hit (stop at the first)
    stack: u32, // stack entries a ray may use (at most STACK)
    pool: u32, // threads of the deep pass
}

@group(0) @binding(1) var<storage, read> s_org: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read> s_dir: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read> s_kl: array<u32>;
@group(0) @binding(4) var<storage, read> s_boxes: array<u32>;
@group(0) @binding(5) var<storage, read> s_leaf_tris: array<vec4<f32>>;
@group(0) @binding(6) var<storage, read> s_order: array<u32>;
@group(0) @binding(7) var<storage, read_write> s_rec: array<vec4<u32>>;
@group(0) @binding(8) var<storage, read_write> s_cnt: array<atomic<u32>>;
@group(0) @binding(10) var<storage, read_write> s_stack: array<vec2<u32>>;

const STACK: u32 = 64u;
const LEAF: u32 = 0x80000000u;
const BOX_WORDS: u32 = 64u; // objects.wgsl
const COUNTERS: u32 = 7u; // final tests × 4 kinds, box tests, box passes, hits
const OVER_DEEP: u32 = 14u; // rays the deep pass could not finish
const OVER: u32 = 15u; // the overflow count's word
const DEEP: u32 = 1024u; // stack entries per ray in the deep pass
const PRIVATE: u32 = 0xffffffffu; // deep_base: the private stack

var<workgroup> wcnt: array<atomic<u32>, 7>;

fn miss64() -> u64 {
    return (u64(0xffffffffu) << 32u) | u64(0xffffffffu);
}

// The ray's reach: t_max, or the closest hit's t when nearer.
fn far_of(t_max: f32, best: u64) -> f32 {
    if best == miss64() {
        return t_max;
    }
    return min(t_max, bitcast<f32>(u32(best >> 32u)));
}

fn box_word(i: u32) -> f32 {
    return bitcast<f32>(s_boxes[i]);
}

// The stack: private entries, or the deep pass's slice of s_stack from deep_base.
var<private> st_node: array<u32, STACK>;
var<private> st_t: array<f32, STACK>;
var<private> deep_base: u32;

fn st_set(i: u32, node: u32, t: f32) {
    if deep_base == PRIVATE {
        st_node[i] = node;
        st_t[i] = t;
    } else {
        s_stack[deep_base + i] = vec2<u32>(node, bitcast<u32>(t));
    }
}

fn st_get(i: u32) -> vec2<u32> {
    if deep_base == PRIVATE {
        return vec2<u32>(st_node[i], bitcast<u32>(st_t[i]));
    }
    return s_stack[deep_base + i];
}

// What one ray's walk found and did.
struct Walk {
    best: u64,
    u: u32, // the best hit's u and v bits
    v: u32,
    finals: u32,
    tests: u32,
    passes: u32,
    over: bool,
}

// Ray r's walk with at most `limit` stack entries (see the module comment).
fn walk(r: u32, limit: u32) -> Walk {
    let prm = single_walk_params();
    let o4 = s_org[r];
    let d4 = s_dir[r];
    let org = o4.xyz;
    let dir = d4.xyz;
    let t_min = o4.w;
    let t_max = d4.w;
    let pre = ray_pre(dir);
    let any = prm.any != 0u;
    var w = Walk(miss64(), 0u, 0u, 0u, 0u, 0u, false);
    if prm.leaves == 1u {
        w.finals = 1u;
        let h = intersect(org, dir, pre, t_min, t_max, s_leaf_tris[0].xyz, s_leaf_tris[1].xyz, s_leaf_tris[2].xyz);
        if h.w != 0.0 {
            w.best = u64(bitcast<u32>(h.x)) << 32u;
            w.u = bitcast<u32>(h.y);
            w.v = bitcast<u32>(h.z);
        }
        return w;
    }
    if prm.leaves == 0u {
        return w;
    }
    // single::slab_inverse: 1 / d clamped to ±f32::MAX.
    let big = bitcast<f32>(0x7f7fffffu);
    let inv = min(max(vec3<f32>(div(1.0, dir.x), div(1.0, dir.y), div(1.0, dir.z)), vec3<f32>(-big)), vec3<f32>(big));
    st_set(0u, 0u, bitcast<f32>(0xff800000u));
    var sp = 1u;
    while sp > 0u && !w.over {
        sp -= 1u;
        let top = st_get(sp);
        let node = top.x;
        let entry = bitcast<f32>(top.y);
        var far = far_of(t_max, w.best);
        if entry > far {
            continue;
        }
        let base = BOX_WORDS * node;
        let count = s_boxes[base + 56u];
        let leaves = s_boxes[base + 57u];
        let ntri = s_boxes[base + 58u];
        // boxes_scalar: per lane, the entry and whether the slabs meet.
        var mask = 0u;
        var tn: array<f32, 8>;
        for (var i = 0u; i < count; i++) {
            var near = t_min;
            var fl = bitcast<f32>(0x7f800000u);
            for (var k = 0u; k < 3u; k++) {
                let a = (box_word(base + 8u * k + i) - org[k]) * inv[k];
                let b = (box_word(base + 24u + 8u * k + i) - org[k]) * inv[k];
                near = max(near, min(a, b));
                fl = min(fl, max(a, b));
            }
            if near <= min(far, mul(fl, C_SLAB_ROBUST)) {
                mask |= 1u << i;
                tn[i] = near;
            }
        }
        w.tests += count;
        w.passes += countOneBits(mask);
        // Leaf lanes first, in lane order (they shorten the ray for the inner ones).
        var m = mask & leaves;
        var stop = false;
        while m != 0u {
            let l = firstTrailingBit(m);
            m &= m - 1u;
            let p = s_boxes[base + 48u + l] & ~LEAF;
            let k = (ntri >> (4u * l)) & 15u;
            w.finals += k;
            for (var j = 0u; j < k; j++) {
                let q = 3u * (p + j);
                let h = intersect(org, dir, pre, t_min, t_max, s_leaf_tris[q].xyz, s_leaf_tris[q + 1u].xyz, s_leaf_tris[q + 2u].xyz);
                if h.w != 0.0 {
                    let key = (u64(bitcast<u32>(h.x)) << 32u) | u64(s_order[p + j]);
                    if key < w.best {
                        w.best = key;
                        w.u = bitcast<u32>(h.y);
                        w.v = bitcast<u32>(h.z);
                    }
                }
            }
            if any && w.best != miss64() {
                stop = true;
                break;
            }
        }
        if stop {
            break;
        }
        // Inner children, farthest first onto the stack (nearest popped next).
        var cn: array<u32, 8>;
        var ct: array<f32, 8>;
        var ni = 0u;
        m = mask & ~leaves;
        while m != 0u {
            let l = firstTrailingBit(m);
            m &= m - 1u;
            cn[ni] = s_boxes[base + 48u + l];
            ct[ni] = tn[l];
            ni += 1u;
        }
        far = far_of(t_max, w.best);
        for (var i = 1u; i < ni; i++) {
            var j = i;
            while j > 0u && ct[j - 1u] < ct[j] {
                let tc = cn[j];
                cn[j] = cn[j - 1u];
                cn[j - 1u] = tc;
                let tt = ct[j];
                ct[j] = ct[j - 1u];
                ct[j - 1u] = tt;
                j -= 1u;
            }
        }
        for (var i = 0u; i < ni; i++) {
            if ct[i] <= far {
                if sp >= limit {
                    w.over = true;
                    break;
                }
                st_set(sp, cn[i], ct[i]);
                sp += 1u;
            }
        }
    }
    return w;
}

// A finished walk: its hit record and its counts (into the workgroup's).
fn finished(r: u32, w: Walk) {
    if w.best == miss64() {
        s_rec[r] = vec4<u32>(0xffffffffu, 0x7f800000u, 0u, 0u);
    } else {
        s_rec[r] = vec4<u32>(u32(w.best & u64(0xffffffffu)), u32(w.best >> 32u), w.u, w.v);
    }
    atomicAdd(&wcnt[s_kl[r] & 3u], w.finals);
    atomicAdd(&wcnt[4], w.tests);
    atomicAdd(&wcnt[5], w.passes);
    atomicAdd(&wcnt[6], u32(w.best != miss64()));
}

// The workgroup's counts from zero (every invocation calls it, before any count).
fn start_counts(li: u32) {
    if li < COUNTERS {
        atomicStore(&wcnt[li], 0u);
    }
    workgroupBarrier();
}

// The workgroup's counts into the 64-bit (low, high) counters, as traverse.wgsl's add64
// (every invocation calls it, after its counts).
fn flush_counts(li: u32) {
    workgroupBarrier();
    if li < COUNTERS {
        let v = atomicLoad(&wcnt[li]);
        if v > 0u {
            let old = atomicAdd(&s_cnt[2u * li], v);
            if old + v < old {
                atomicAdd(&s_cnt[2u * li + 1u], 1u);
            }
        }
    }
}

// One ray's walk over the tree, its stack private.
@compute @workgroup_size(256)
fn single_walk(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(local_invocation_index) li: u32, @builtin(num_workgroups) nwg: vec3<u32>) {
    start_counts(li);
    let prm = single_walk_params();
    let r = gid.x + gid.y * nwg.x * 256u;
    if r < prm.rays {
        deep_base = PRIVATE;
        let w = walk(r, prm.stack);
        if w.over {
            let at = atomicAdd(&s_cnt[OVER], 1u);
            atomicStore(&s_cnt[OVER + 1u + at], r);
        } else {
            finished(r, w);
        }
    }
    flush_counts(li);
}

// The rays single_walk listed, walked again from the start, each with DEEP stack entries in
// storage memory: `pool` threads take the list in turn.
@compute @workgroup_size(256)
fn single_walk_deep(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(local_invocation_index) li: u32, @builtin(num_workgroups) nwg: vec3<u32>) {
    start_counts(li);
    let prm = single_walk_params();
    let tid = gid.x + gid.y * nwg.x * 256u;
    let listed = atomicLoad(&s_cnt[OVER]);
    if tid < prm.pool {
        deep_base = tid * DEEP;
        for (var i = tid; i < listed; i += prm.pool) {
            let r = atomicLoad(&s_cnt[OVER + 1u + i]);
            let w = walk(r, DEEP);
            if w.over {
                atomicAdd(&s_cnt[OVER_DEEP], 1u);
            } else {
                finished(r, w);
            }
        }
    }
    flush_counts(li);
}
