// How many of the trimmed rays are of each kind: every hierarchy level's layout (thesis
// §3.2.7: kinds are sorted, so each kind's leaves follow the previous kind's); bindings in
// prims/bindings.wgsl, and the counts here.

// Parameters of trim_kinds.
struct TrimKindsParams {
    rays: u32, // rays of the batch (trimmed or not: flags in x_flag)
}

@group(0) @binding(8) var<storage, read_write> y_kinds: array<atomic<u32>>;

var<workgroup> wkinds: array<atomic<u32>, 4>;

// Per kind (kind | light << 2 in x_a) the rays whose flag (x_flag: the trim's) is set, added
// per workgroup, then once per workgroup into y_kinds.
@compute @workgroup_size(256)
fn trim_kinds(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(local_invocation_index) li: u32, @builtin(num_workgroups) nwg: vec3<u32>) {
    if li < 4u {
        atomicStore(&wkinds[li], 0u);
    }
    workgroupBarrier();
    let i = lin(gid, nwg);
    if i < trim_kinds_params().rays && x_flag[i] != 0u {
        atomicAdd(&wkinds[x_a[i] & 3u], 1u);
    }
    workgroupBarrier();
    if li < 4u {
        let v = atomicLoad(&wkinds[li]);
        if v > 0u {
            atomicAdd(&y_kinds[li], v);
        }
    }
}

// ------------------------------------------------------------------ the layout on the device
// Where a frame sizes nothing on the host (engine.rs's device-laid trace), the trimmed rays
// are compacted into buffers of the batch's bound and their count and kinds stay on the
// device: the slots past the count are padded with the largest key, so that a stable sort of
// every slot leaves the trimmed rays first, in their own order (a real key equal to the
// padding's stays ahead of it), and each hierarchy level's layout is computed here from the
// kinds, as build.rs computes it on the host.

// Parameters of trim_pad.
struct TrimPadParams {
    n: u32, // slots (the batch's bound); the count is x_off[n]
    value: u32, // what the slots past the count hold
}

// Slots i ≥ x_off[n] (the compaction's count) of y_a and y_b set to the padding.
@compute @workgroup_size(256)
fn trim_pad(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let p = trim_pad_params();
    let i = lin(gid, nwg);
    if i < p.n && i >= x_off[p.n] {
        y_a[i] = p.value;
        y_b[i] = p.value;
    }
}

// Parameters of level_layout.
struct LevelLayoutParams {
    b: u32, // the branching factor
    union_thesis: u32, // LevelParams's union_thesis
    levels: u32, // the configuration's levels (0: until every kind has one root)
    max_levels: u32, // the levels the host laid out (the bound of the actual ones)
    maxd: u32, // the device's most workgroups per dimension
}

// Words of one level's block in y_a: its size block (n = nodes, then the workgroups of 64
// threads: kernels.rs's `DevSize`) and its LevelParams (build.wgsl).
const LAYOUT_WORDS: u32 = 20u;

// One thread: rsh::build's loop over the trimmed rays' kinds (x_a, 4 words): per level its
// nodes per kind, the children they take, and the stop rules (the configured levels, or one
// root per kind; a level of at most one node); levels past the last get zero nodes. After
// the levels: the levels built and the top level's nodes.
@compute @workgroup_size(1)
fn level_layout(@builtin(global_invocation_id) gid: vec3<u32>) {
    let p = level_layout_params();
    var below = vec4<u32>(x_a[0], x_a[1], x_a[2], x_a[3]);
    var built = 0u;
    var top = 0u;
    var stopped = false;
    for (var l = 0u; l < p.max_levels; l++) {
        let at = LAYOUT_WORDS * l;
        for (var w = 0u; w < LAYOUT_WORDS; w++) {
            y_a[at + w] = 0u;
        }
        y_a[at + 2u] = 1u;
        y_a[at + 3u] = 1u;
        if stopped {
            continue;
        }
        let nodes = (below + vec4<u32>(p.b - 1u)) / p.b;
        let total = nodes.x + nodes.y + nodes.z + nodes.w;
        let run = vec4<u32>(0u, below.x, below.x + below.y, below.x + below.y + below.z);
        let cum = vec4<u32>(0u, nodes.x, nodes.x + nodes.y, nodes.x + nodes.y + nodes.z);
        let groups = (total + 63u) / 64u;
        var x = groups;
        var y = 1u;
        if groups > p.maxd {
            y = (groups + p.maxd - 1u) / p.maxd;
            x = (groups + y - 1u) / y;
        }
        y_a[at] = total;
        y_a[at + 1u] = x;
        y_a[at + 2u] = y;
        y_a[at + 4u] = total;
        y_a[at + 5u] = p.b;
        y_a[at + 6u] = p.union_thesis;
        y_a[at + 7u] = below.x + below.y + below.z + below.w;
        for (var k = 0u; k < 4u; k++) {
            y_a[at + 8u + k] = run[k];
            y_a[at + 12u + k] = cum[k];
            y_a[at + 16u + k] = below[k];
        }
        built = l + 1u;
        top = total;
        var done = built >= p.levels;
        if p.levels == 0u {
            done = all(nodes <= vec4<u32>(1u));
        }
        stopped = done || total <= 1u;
        below = nodes;
    }
    y_a[LAYOUT_WORDS * p.max_levels] = built;
    y_a[LAYOUT_WORDS * p.max_levels + 1u] = top;
}

// Parameters of runs_below.
struct RunsBelowParams {
    n: u32, // slots; the trimmed rays' count is x_a[n] (the trim's offsets)
}

// One thread: CRSH's chunks of the trimmed rays (the runs that start before their count,
// x_off being the run heads' offsets), leaving out the run of the padding past them.
@compute @workgroup_size(1)
fn runs_below(@builtin(global_invocation_id) gid: vec3<u32>) {
    let p = runs_below_params();
    y_a[0] = x_off[x_a[p.n]];
}
