// The dual traversal on the device, level by level: the twin of crates/rsh/src/dual (mod.rs's
// ray nodes, beam test, pair classification and single-ray walk; breadth.rs's steps), for
// `--object-hierarchy bvh --ray-path bundles --schedule breadth`. Each step is test → count
// → scan → emit over one chunk of (ray node, object node) pairs, or the single rays' walks
// over their sorted pairs; a step's count is in a state on the device, which the host writes
// where it takes the CPU's steps itself (dual.rs) and the rounds keep (dual_rounds.wgsl).
//
// Every float operation is the CPU's, in its order: products that feed a sum go through mul()
// and sums through keep() (common.wgsl), 1/d is correctly rounded (div), and min/max that may
// meet a NaN ignore it as Rust's f32::min/max do (rmin/rmax), so the pass/fail bits, the
// counts and the hits are the CPU's.
//
// Bindings: 1 level spheres, 2 level cones, 3 level sc (sin, cos, longest ray, kind bits),
// 4 level first (children), 5 the level below's beams, 6 the level's beams (4 × vec4 per node:
// omin | t_min, omax | t_max, 1/d low | reach, 1/d high | 0), 7 leaves (position → ray),
// 8 ray org | t_min, 9 ray dir | t_max, 10 ray constants, 11 ray kind | light << 2,
// 12 tree children, 13 tree node bounds (sphere, grown min, grown max), 14 tree leaf bounds,
// 15 tree ranges, 16 tree leaf order, 17 tree children's boxes, 18 triangles (3 × vec4),
// 19 pairs: ray node, 20 pairs: object node, 21 actions, 22 counts (3 streams) or their
// scanned offsets, 23/24 out: the collapsed nodes' children (ray node, object node), 25 the
// walks' pairs' leaf positions (sorted), 28 best hits (u64: t bits << 32 | triangle),
// 29 counters, 30 the state (dual_rounds.wgsl), 31/32 out: the pairs one ray level down,
// appended to its stack, 33/34 out: the final tests (level-1 node, triangle).

// Parameters of dual_beams_leaf and dual_beams_upper.
struct DualBeamParams {
    nodes: u32, // nodes of the level
    scale: f32, // the reach's scale (ANY_HIT_SIZE_RATIO with any hit, else 1)
    diag: f32, // the scene's diagonal: the longest ray the reach counts
}

// Parameters of dual_classify, dual_emit and (dual_rounds.wgsl) the rounds' kernels.
struct DualPairParams {
    stride: u32, // slots per stream of the step's counts (its pairs' bound)
    level: u32, // the ray nodes' level index (0: level 1)
    exact: u32, // 1: the exact cone test (rsh::NodeTest::Exact), 0: the thesis's
    descent: u32, // 0: size, 1: object first, 2: ray first (rsh::dual::Descent)
    counters: u32, // the level's first counter word (tests, then passes, per kind)
    objects: u32, // the word of the tests against inner object nodes
    room: u32, // pairs each output buffer holds (the rounds' overflow; the host's steps: all)
    pad: u32, // dual_round_pad: the key past the last leaf position
    stage: u32, // the ray level the kernel serves (level index + 1; 0: single rays)
    maxd: u32, // the device's most workgroups per dimension (dual_round_update's size block)
}

// Parameters of dual_walk.
struct DualWalkParams {
    pairs: u32, // threads launched (the pairs' bound; their count is the state's)
    any: u32, // 1: any hit (a ray that hit stops)
    finals: u32, // the first word of the final tests per kind
    boxes: u32, // the word of the slab tests (their passes 2 words on, overflows 4 on)
}

@group(0) @binding(1) var<storage, read> n_sphere: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read> n_cone: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read> n_sc: array<vec4<f32>>;
@group(0) @binding(4) var<storage, read> n_first: array<u32>;
@group(0) @binding(5) var<storage, read> b_below: array<vec4<f32>>;
@group(0) @binding(6) var<storage, read_write> b_beam: array<vec4<f32>>;
@group(0) @binding(7) var<storage, read> d_leaf: array<u32>;
@group(0) @binding(8) var<storage, read> d_org: array<vec4<f32>>;
@group(0) @binding(9) var<storage, read> d_dir: array<vec4<f32>>;
@group(0) @binding(10) var<storage, read> d_pre: array<vec4<f32>>;
@group(0) @binding(11) var<storage, read> d_kl: array<u32>;
@group(0) @binding(12) var<storage, read> t_child: array<vec2<u32>>;
@group(0) @binding(13) var<storage, read> t_node: array<vec4<f32>>;
@group(0) @binding(14) var<storage, read> t_leaf: array<vec4<f32>>;
@group(0) @binding(15) var<storage, read> t_range: array<vec2<u32>>;
@group(0) @binding(16) var<storage, read> t_order: array<u32>;
@group(0) @binding(17) var<storage, read> t_cbox: array<vec4<f32>>;
@group(0) @binding(18) var<storage, read> d_tris: array<vec4<f32>>;
@group(0) @binding(19) var<storage, read> p_ray: array<u32>;
@group(0) @binding(20) var<storage, read> p_obj: array<u32>;
@group(0) @binding(21) var<storage, read_write> p_act: array<u32>;
@group(0) @binding(22) var<storage, read_write> p_cnt: array<u32>;
@group(0) @binding(23) var<storage, read_write> o_ray: array<u32>;
@group(0) @binding(24) var<storage, read_write> o_obj: array<u32>;
@group(0) @binding(25) var<storage, read> w_key: array<u32>;
@group(0) @binding(28) var<storage, read_write> d_best: array<atomic<u64>>;
@group(0) @binding(29) var<storage, read_write> cnt: array<atomic<u32>>;
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
const R_MOST: u32 = 7u;
const R_ROUNDS: u32 = 8u;

const LEAF: u32 = 0x80000000u;
// What a tested pair becomes (rsh::dual's DROP, FINAL, RAY, OBJECT).
const DROP: u32 = 0u;
const FINAL: u32 = 1u;
const RAY: u32 = 2u;
const OBJECT: u32 = 3u;
// rsh::dual's SMALL_SUBTREE: a level-1 node meets a subtree of at most this many triangles
// with final tests instead of its rays' walks.
const SMALL_SUBTREE: u32 = 8u;
// A walk's stack: a popped inner node pushes at most 2, so a walk holds at most one waiting
// sibling per level of its path plus one, and an LBVH over 64-bit keys with 32-bit index
// tie-breaks is at most 97 levels deep (single.wgsl). An overflow is counted, never silent.
const WALK_STACK: u32 = 128u;

var<workgroup> wcnt: array<atomic<u32>, 16>;

fn inf() -> f32 {
    return bitcast<f32>(0x7f800000u);
}

fn is_nan(x: f32) -> bool {
    return (bitcast<u32>(x) & 0x7fffffffu) > 0x7f800000u;
}

// Rust's f32::max and f32::min: a NaN operand gives the other.
fn rmax(a: f32, b: f32) -> f32 {
    if is_nan(b) {
        return a;
    }
    if is_nan(a) {
        return b;
    }
    return max(a, b);
}

fn rmin(a: f32, b: f32) -> f32 {
    if is_nan(b) {
        return a;
    }
    if is_nan(a) {
        return b;
    }
    return min(a, b);
}

fn wcnt_reset(li: u32) {
    if li < 16u {
        atomicStore(&wcnt[li], 0u);
    }
    workgroupBarrier();
}

// A 64-bit device counter (low, high words) at word `at`, as traverse.wgsl's add64.
fn add64(at: u32, v: u32) {
    let old = atomicAdd(&cnt[at], v);
    if old + v < old {
        atomicAdd(&cnt[at + 1u], 1u);
    }
}

// The workgroup's count `i` into the counter at word `at`, once per workgroup.
fn flush_one(i: u32, at: u32) {
    let v = atomicLoad(&wcnt[i]);
    if v > 0u {
        add64(at, v);
    }
}

// ------------------------------------------------------------------ ray nodes (mod.rs)

// A beam (RayNode's beam part): the origins' box [lo, hi], the reciprocal directions' box
// [ilo, ihi], the smallest t_min and the largest t_max.
struct Beam {
    lo: vec3<f32>,
    hi: vec3<f32>,
    ilo: vec3<f32>,
    ihi: vec3<f32>,
    tn: f32,
    tf: f32,
}

fn vmin(a: vec3<f32>, b: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(rmin(a.x, b.x), rmin(a.y, b.y), rmin(a.z, b.z));
}

fn vmax(a: vec3<f32>, b: vec3<f32>) -> vec3<f32> {
    return vec3<f32>(rmax(a.x, b.x), rmax(a.y, b.y), rmax(a.z, b.z));
}

// beam_union of `b` and `x`, from beam_union's empty start (beam_none).
fn beam_add(b: Beam, x: Beam) -> Beam {
    return Beam(vmin(b.lo, x.lo), vmax(b.hi, x.hi), vmin(b.ilo, x.ilo), vmax(b.ihi, x.ihi), rmin(b.tn, x.tn), rmax(b.tf, x.tf));
}

fn beam_none() -> Beam {
    return Beam(vec3<f32>(inf()), vec3<f32>(-inf()), vec3<f32>(inf()), vec3<f32>(-inf()), inf(), 0.0);
}

// Node n's beam and its reach (RayNode; the reach as `Traversal::ray_nodes`).
fn write_beam(n: u32, b: Beam) {
    let p = dual_beam_params();
    var reach = inf();
    if n_cone[n].w < C_FRAC_PI_2 {
        let sc = n_sc[n];
        reach = mul(keep(n_sphere[n].w + mul(rmin(sc.z, p.diag), sc.x)), p.scale);
    }
    b_beam[4u * n] = vec4<f32>(b.lo, b.tn);
    b_beam[4u * n + 1u] = vec4<f32>(b.hi, b.tf);
    b_beam[4u * n + 2u] = vec4<f32>(b.ilo, reach);
    b_beam[4u * n + 3u] = vec4<f32>(b.ihi, 0.0);
}

// Level 1's beams, from their rays (beam_union over origins, 1/d, t ranges).
@compute @workgroup_size(64)
fn dual_beams_leaf(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let n = gid.x + gid.y * nwg.x * 64u;
    if n >= dual_beam_params().nodes {
        return;
    }
    var b = beam_none();
    for (var c = n_first[n]; c < n_first[n + 1u]; c++) {
        let r = d_leaf[c];
        let o = d_org[r];
        let d = d_dir[r];
        let i = vec3<f32>(div(1.0, d.x), div(1.0, d.y), div(1.0, d.z));
        b = beam_add(b, Beam(o.xyz, o.xyz, i, i, o.w, d.w));
    }
    write_beam(n, b);
}

// The beams of a level above 1, from their children's.
@compute @workgroup_size(64)
fn dual_beams_upper(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let n = gid.x + gid.y * nwg.x * 64u;
    if n >= dual_beam_params().nodes {
        return;
    }
    var b = beam_none();
    for (var c = n_first[n]; c < n_first[n + 1u]; c++) {
        let b0 = b_below[4u * c];
        let b1 = b_below[4u * c + 1u];
        let x = Beam(b0.xyz, b1.xyz, b_below[4u * c + 2u].xyz, b_below[4u * c + 3u].xyz, b0.w, b1.w);
        b = beam_add(b, x);
    }
    write_beam(n, b);
}

// RayNode::beam_test: whether some ray of node n may meet box [bmin, bmax] (interval
// products per axis of one sign, widened by far more than their rounding).
fn beam_test(n: u32, bmin: vec3<f32>, bmax: vec3<f32>) -> bool {
    let b0 = b_beam[4u * n];
    let b1 = b_beam[4u * n + 1u];
    let i0 = b_beam[4u * n + 2u];
    let i1 = b_beam[4u * n + 3u];
    var tn = b0.w;
    var tf = b1.w;
    for (var k = 0u; k < 3u; k++) {
        let ilo = i0[k];
        let ihi = i1[k];
        if !(is_finite(ilo) && is_finite(ihi)) {
            continue;
        }
        var near: f32;
        var far: f32;
        var olo: f32;
        var ohi: f32;
        var a: f32;
        var c: f32;
        if ilo > 0.0 {
            near = bmin[k];
            far = bmax[k];
            olo = b0[k];
            ohi = b1[k];
            a = ilo;
            c = ihi;
        } else if ihi < 0.0 {
            near = -bmax[k];
            far = -bmin[k];
            olo = -b1[k];
            ohi = -b0[k];
            a = -ihi;
            c = -ilo;
        } else {
            continue;
        }
        let e = near - ohi;
        var enter = mul(e, c);
        if e >= 0.0 {
            enter = mul(e, a);
        }
        let x = far - olo;
        var exit = mul(x, a);
        if x >= 0.0 {
            exit = mul(x, c);
        }
        let slack = mul(mul(keep(max(abs(near), abs(far)) + max(abs(olo), abs(ohi))), c), 1e-6);
        tn = rmax(tn, keep(enter - slack));
        tf = rmin(tf, keep(exit + slack));
    }
    return tn <= tf;
}

// ------------------------------------------------------------------ object nodes

// An object node's bounds: sphere (centre, radius), grown box.
struct Bounds {
    s: vec4<f32>,
    lo: vec3<f32>,
    hi: vec3<f32>,
}

fn bounds_of(o: u32) -> Bounds {
    if (o & LEAF) != 0u {
        let t = o & ~LEAF;
        return Bounds(t_leaf[3u * t], t_leaf[3u * t + 1u].xyz, t_leaf[3u * t + 2u].xyz);
    }
    return Bounds(t_node[3u * o], t_node[3u * o + 1u].xyz, t_node[3u * o + 2u].xyz);
}

fn radius_of(x: u32) -> f32 {
    if (x & LEAF) != 0u {
        return -inf();
    }
    return t_node[3u * x].w;
}

// A collapsed node's children (rsh::objects's frontier): inner node h's two children, the
// inner member of largest sphere split (the first on ties) until 8 members or only leaves.
struct Frontier {
    f: array<u32, 8>,
    n: u32,
}

fn frontier(h: u32) -> Frontier {
    var f: array<u32, 8>;
    var r: array<f32, 8>;
    let c = t_child[h];
    f[0] = c.x;
    f[1] = c.y;
    r[0] = radius_of(c.x);
    r[1] = radius_of(c.y);
    var n = 2u;
    loop {
        if n >= 8u {
            break;
        }
        var best = 8u;
        for (var i = 0u; i < n; i++) {
            if (f[i] & LEAF) == 0u && (best == 8u || r[i] > r[best]) {
                best = i;
            }
        }
        if best == 8u {
            break;
        }
        let ab = t_child[f[best]];
        for (var j = n; j > best + 1u; j--) {
            f[j] = f[j - 1u];
            r[j] = r[j - 1u];
        }
        f[best] = ab.x;
        f[best + 1u] = ab.y;
        r[best] = radius_of(ab.x);
        r[best + 1u] = radius_of(ab.y);
        n++;
    }
    return Frontier(f, n);
}

// rsh::dual's `small`: inner node o holds at most SMALL_SUBTREE triangles.
fn small(o: u32) -> bool {
    let r = t_range[o];
    return r.y - r.x < SMALL_SUBTREE;
}

// ------------------------------------------------------------------ pair steps (breadth.rs)

// What pair (ray node n of the level, object node o) becomes (Traversal::classify, action).
fn classify(p: DualPairParams, n: u32, o: u32) -> u32 {
    let b = bounds_of(o);
    if !beam_test(n, b.lo, b.hi) || !node_test(p.exact == 1u, n_sphere[n], n_cone[n], n_sc[n], b.s.xyz, b.s.w) {
        return DROP;
    }
    if (o & LEAF) != 0u {
        if p.level == 0u {
            return FINAL;
        }
        return RAY;
    }
    var object = p.descent == 1u;
    if p.descent == 0u {
        object = b.s.w >= b_beam[4u * n + 2u].w;
    }
    if object {
        return OBJECT;
    }
    return RAY;
}

// The pairs of ray level `stage` this round takes: none unless the state is at that level.
fn round_pairs(stage: u32) -> u32 {
    if atomicLoad(&r_state[R_FLAG]) != 0u || atomicLoad(&r_state[R_LEVEL]) != stage {
        return 0u;
    }
    return atomicLoad(&r_state[R_PAIRS]);
}

// Test each pair of the step (its count in the state), count the tests and passes per ray
// kind (and the tests of inner object nodes), and count what each survivor makes in the
// three streams: final tests, pairs one ray level down, pairs of the collapsed node's
// children (p_cnt: stream s at s · stride; the slots past the count are zero, so a scan
// over 3 · stride gives each stream's offsets).
@compute @workgroup_size(256)
fn dual_classify(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(local_invocation_index) li: u32, @builtin(num_workgroups) nwg: vec3<u32>) {
    wcnt_reset(li);
    let p = dual_pair_params();
    let n = round_pairs(p.stage);
    let i = gid.x + gid.y * nwg.x * 256u;
    if i < p.stride {
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
        p_cnt[p.stride + i] = c.y;
        p_cnt[2u * p.stride + i] = c.z;
    }
    workgroupBarrier();
    if li < 4u {
        flush_one(li, p.counters + 2u * li);
        flush_one(4u + li, p.counters + 8u + 2u * li);
    } else if li == 4u {
        flush_one(8u, p.objects);
    }
}

// Put one pair at slot `at` of stream `which`'s buffer of `room` pairs (past it: a round
// overflows, and dual_round_update says so).
fn put(which: u32, at: u32, room: u32, nd: u32, o: u32) {
    if at >= room {
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

// Write what each survivor makes at its scanned offsets (p_cnt holds them here), each stream
// in pair order as par::emit_streams: the final tests from slot 0 of their buffer, the pairs
// one level down appended to that level's stack (after the state's count), the collapsed
// nodes' children from slot 0 of the next step's input.
@compute @workgroup_size(256)
fn dual_emit(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let p = dual_pair_params();
    let i = gid.x + gid.y * nwg.x * 256u;
    if i >= round_pairs(p.stage) {
        return;
    }
    let act = p_act[i];
    let nd = p_ray[i];
    let o = p_obj[i];
    let f = p_cnt[p.stride];
    let fb = p_cnt[2u * p.stride];
    let below = atomicLoad(&r_state[R_BELOW]);
    if act == FINAL {
        put(0u, p_cnt[i], p.room, nd, o & ~LEAF);
    } else if act == RAY {
        if p.level == 0u && small(o) {
            let at = p_cnt[i];
            let rg = t_range[o];
            for (var j = rg.x; j <= rg.y; j++) {
                put(0u, at + j - rg.x, p.room, nd, t_order[j]);
            }
        } else {
            var at = below + p_cnt[p.stride + i] - f;
            for (var c = n_first[nd]; c < n_first[nd + 1u]; c++) {
                put(1u, at, p.room, c, o);
                at++;
            }
        }
    } else if act == OBJECT {
        let fr = frontier(o);
        let at = p_cnt[2u * p.stride + i] - fb;
        for (var j = 0u; j < fr.n; j++) {
            put(2u, at + j, p.room, nd, fr.f[j]);
        }
    }
}

// ------------------------------------------------------------------ single rays (mod.rs)

// geom::Aabb::intersect's entry (Ize's robust slab test), or NaN for a miss.
fn slab(lo: vec3<f32>, hi: vec3<f32>, org: vec3<f32>, inv: vec3<f32>, t_min: f32, t_max: f32) -> f32 {
    var tn = t_min;
    var tf = t_max;
    for (var k = 0u; k < 3u; k++) {
        let a = mul(lo[k] - org[k], inv[k]);
        let b = mul(hi[k] - org[k], inv[k]);
        if is_nan(a) || is_nan(b) {
            continue;
        }
        tn = rmax(tn, min(a, b));
        tf = rmin(tf, mul(max(a, b), C_SLAB_ROBUST));
    }
    if tn <= tf {
        return tn;
    }
    return bitcast<f32>(0x7fc00000u);
}

fn miss64() -> u64 {
    return (u64(0xffffffffu) << 32u) | u64(0xffffffffu);
}

// One thread per sorted pair; the thread at the head of a ray's run (its first pair) walks
// the run: Traversal::walk_ray over the run's object nodes in order, each subtree depth
// first, nearer child first; the ray's best hit of the steps before this one caps the slabs,
// and with any hit it stops at its first. (Heads found in place: no run count to read.)
// The pairs' count is the state's (the host's steps write it; the rounds leave it there).
@compute @workgroup_size(64)
fn dual_walk(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(local_invocation_index) li: u32, @builtin(num_workgroups) nwg: vec3<u32>) {
    wcnt_reset(li);
    let p = dual_walk_params();
    walk_slot(gid.x + gid.y * nwg.x * 64u, round_pairs(0u), p.any != 0u);
    flush_walk(li, p);
}

// A walk's counts, once per workgroup.
fn flush_walk(li: u32, p: DualWalkParams) {
    workgroupBarrier();
    if li < 4u {
        flush_one(li, p.finals + 2u * li);
    } else if li < 7u {
        flush_one(li, p.boxes + 2u * (li - 4u));
    }
}

// The walk of the ray whose run starts at sorted pair k of n (none unless k is a run's
// head), its counts into the workgroup's.
fn walk_slot(k: u32, n: u32, any: bool) {
    if k < n && (k == 0u || w_key[k] != w_key[k - 1u]) {
        let pos = w_key[k];
        let r = d_leaf[pos];
        let kind = d_kl[r] & 3u;
        let had = atomicLoad(&d_best[r]);
        var best = had;
        var finals = 0u;
        var tests = 0u;
        var passes = 0u;
        var over = 0u;
        if !(any && best != miss64()) {
            let o4 = d_org[r];
            let d4 = d_dir[r];
            let org = o4.xyz;
            let dir = d4.xyz;
            let pre = d_pre[r];
            let inv = vec3<f32>(div(1.0, dir.x), div(1.0, dir.y), div(1.0, dir.z));
            var stack: array<u32, WALK_STACK>;
            var done = false;
            for (var j = k; j < n && w_key[j] == pos && !done; j++) {
                stack[0] = p_obj[j];
                var sp = 1u;
                while sp > 0u {
                    sp--;
                    let o = stack[sp];
                    if any && best != miss64() {
                        done = true;
                        break;
                    }
                    if (o & LEAF) != 0u {
                        let t = o & ~LEAF;
                        finals++;
                        let h = intersect(org, dir, pre, o4.w, d4.w, d_tris[3u * t].xyz, d_tris[3u * t + 1u].xyz, d_tris[3u * t + 2u].xyz);
                        if h.w != 0.0 {
                            let key = (u64(bitcast<u32>(h.x)) << 32u) | u64(t);
                            if key < best {
                                best = key;
                            }
                        }
                        continue;
                    }
                    var far = d4.w;
                    if best != miss64() {
                        far = min(d4.w, bitcast<f32>(u32(best >> 32u)));
                    }
                    let ch = t_child[o];
                    var tx = 0.0;
                    var ty = 0.0;
                    var inner = 0u;
                    if (ch.x & LEAF) == 0u {
                        inner++;
                        tx = slab(t_cbox[4u * o].xyz, t_cbox[4u * o + 1u].xyz, org, inv, o4.w, far);
                        if !is_nan(tx) {
                            passes++;
                        }
                    }
                    if (ch.y & LEAF) == 0u {
                        inner++;
                        ty = slab(t_cbox[4u * o + 2u].xyz, t_cbox[4u * o + 3u].xyz, org, inv, o4.w, far);
                        if !is_nan(ty) {
                            passes++;
                        }
                    }
                    tests += inner;
                    if sp + 2u > WALK_STACK {
                        over++;
                        done = true;
                        break;
                    }
                    let hx = !is_nan(tx);
                    let hy = !is_nan(ty);
                    if hx && hy {
                        // The nearer child on top.
                        if tx <= ty {
                            stack[sp] = ch.y;
                            stack[sp + 1u] = ch.x;
                        } else {
                            stack[sp] = ch.x;
                            stack[sp + 1u] = ch.y;
                        }
                        sp += 2u;
                    } else if hx {
                        stack[sp] = ch.x;
                        sp++;
                    } else if hy {
                        stack[sp] = ch.y;
                        sp++;
                    }
                }
            }
            if best < had {
                atomicMin(&d_best[r], best);
            }
        }
        atomicAdd(&wcnt[kind], finals);
        atomicAdd(&wcnt[4u], tests);
        atomicAdd(&wcnt[5u], passes);
        atomicAdd(&wcnt[6u], over);
    }
}
