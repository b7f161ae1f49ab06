// CRSH's single-ray path on the device, the twin of crates/rsh/src/single.rs: one thread per
// ray walks the object tree's box nodes (objects.wgsl `obj_box_nodes`) with a stack of
// (node, entry); a popped node entered beyond the closest hit so far is skipped; its lanes
// get Ize's robust slab test (the same operations as `boxes_scalar`), its passing leaf
// lanes' triangles the shared watertight kernel in lane order (the closest hit the smallest
// (t bits << 32 | triangle id), as brute force), and its passing inner children are pushed
// farthest first (a stable insertion sort, as the CPU). With any-hit a ray stops at its
// first hit. So hits and every count are the CPU walk's.
//
// A ray whose stack would exceed `stack` entries stops, adds none of its counts and is
// listed after the counters: the host traces it with the CPU twin on the same tree.
//
// Bindings: 1 ray org | t_min, 2 ray dir | t_max, 3 kind | light << 2, 4 box nodes,
// 5 triangles in leaf order (3 × vec4), 6 leaf order (triangle ids), 7 best (tri, t bits),
// 8 counters: 64-bit (low, high) final tests per kind, box tests, box passes, hits (words
// 0..14), then the overflowed rays' count (word 14) and ids (from word 15); 9 the ray constants
// (ray_pre, for the records kernel).

// Parameters of single_walk.
struct SingleWalkParams {
    rays: u32, // rays of the batch
    leaves: u32, // triangles of the tree (1: a lone triangle, no node)
    any: u32, // 1: any hit (stop at the first)
    stack: u32, // stack entries a ray may use (at most STACK)
}

@group(0) @binding(1) var<storage, read> s_org: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read> s_dir: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read> s_kl: array<u32>;
@group(0) @binding(4) var<storage, read> s_boxes: array<u32>;
@group(0) @binding(5) var<storage, read> s_leaf_tris: array<vec4<f32>>;
@group(0) @binding(6) var<storage, read> s_order: array<u32>;
@group(0) @binding(7) var<storage, read_write> s_best: array<vec2<u32>>;
@group(0) @binding(8) var<storage, read_write> s_cnt: array<atomic<u32>>;
@group(0) @binding(9) var<storage, read_write> s_pre: array<vec4<f32>>;

const STACK: u32 = 64u;
const LEAF: u32 = 0x80000000u;
const BOX_WORDS: u32 = 64u; // objects.wgsl
const COUNTERS: u32 = 7u; // final tests × 4 kinds, box tests, box passes, hits
const OVER: u32 = 14u; // the overflow count's word

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

// One ray's walk over the tree.
@compute @workgroup_size(256)
fn single_walk(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(local_invocation_index) li: u32, @builtin(num_workgroups) nwg: vec3<u32>) {
    if li < COUNTERS {
        atomicStore(&wcnt[li], 0u);
    }
    workgroupBarrier();
    let prm = single_walk_params();
    let r = gid.x + gid.y * nwg.x * 256u;
    if r < prm.rays {
        let o4 = s_org[r];
        let d4 = s_dir[r];
        let org = o4.xyz;
        let dir = d4.xyz;
        let t_min = o4.w;
        let t_max = d4.w;
        let pre = ray_pre(dir);
        s_pre[r] = pre;
        let kind = s_kl[r] & 3u;
        let any = prm.any != 0u;
        var best = miss64();
        var finals = 0u;
        var tests = 0u;
        var passes = 0u;
        var over = false;
        if prm.leaves == 1u {
            finals = 1u;
            let h = intersect(org, dir, pre, t_min, t_max, s_leaf_tris[0].xyz, s_leaf_tris[1].xyz, s_leaf_tris[2].xyz);
            if h.w != 0.0 {
                best = u64(bitcast<u32>(h.x)) << 32u;
            }
        } else if prm.leaves > 1u {
            // single::slab_inverse: 1 / d clamped to ±f32::MAX.
            let big = bitcast<f32>(0x7f7fffffu);
            let inv = min(max(vec3<f32>(div(1.0, dir.x), div(1.0, dir.y), div(1.0, dir.z)), vec3<f32>(-big)), vec3<f32>(big));
            var st_node: array<u32, STACK>;
            var st_t: array<f32, STACK>;
            st_node[0] = 0u;
            st_t[0] = bitcast<f32>(0xff800000u);
            var sp = 1u;
            while sp > 0u && !over {
                sp -= 1u;
                let w = st_node[sp];
                let entry = st_t[sp];
                var far = far_of(t_max, best);
                if entry > far {
                    continue;
                }
                let base = BOX_WORDS * w;
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
                tests += count;
                passes += countOneBits(mask);
                // Leaf lanes first, in lane order (they shorten the ray for the inner ones).
                var m = mask & leaves;
                var stop = false;
                while m != 0u {
                    let l = firstTrailingBit(m);
                    m &= m - 1u;
                    let p = s_boxes[base + 48u + l] & ~LEAF;
                    let k = (ntri >> (4u * l)) & 15u;
                    finals += k;
                    for (var j = 0u; j < k; j++) {
                        let q = 3u * (p + j);
                        let h = intersect(org, dir, pre, t_min, t_max, s_leaf_tris[q].xyz, s_leaf_tris[q + 1u].xyz, s_leaf_tris[q + 2u].xyz);
                        if h.w != 0.0 {
                            let key = (u64(bitcast<u32>(h.x)) << 32u) | u64(s_order[p + j]);
                            if key < best {
                                best = key;
                            }
                        }
                    }
                    if any && best != miss64() {
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
                far = far_of(t_max, best);
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
                        if sp >= prm.stack {
                            over = true;
                            break;
                        }
                        st_node[sp] = cn[i];
                        st_t[sp] = ct[i];
                        sp += 1u;
                    }
                }
            }
        }
        if over {
            let at = atomicAdd(&s_cnt[OVER], 1u);
            atomicStore(&s_cnt[OVER + 1u + at], r);
        } else {
            s_best[r] = vec2<u32>(u32(best & u64(0xffffffffu)), u32(best >> 32u));
            atomicAdd(&wcnt[kind], finals);
            atomicAdd(&wcnt[4], tests);
            atomicAdd(&wcnt[5], passes);
            atomicAdd(&wcnt[6], u32(best != miss64()));
        }
    }
    workgroupBarrier();
    if li < COUNTERS {
        let v = atomicLoad(&wcnt[li]);
        if v > 0u {
            // 64-bit (low, high) counters, as traverse.wgsl's add64.
            let old = atomicAdd(&s_cnt[2u * li], v);
            if old + v < old {
                atomicAdd(&s_cnt[2u * li + 1u], 1u);
            }
        }
    }
}
