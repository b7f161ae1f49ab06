// Small data-parallel passes: stream compaction of (a, b) pairs by flags with scanned
// offsets, run-length compression of equal consecutive keys, and run expansion.
// Params u0 = (n, mode, total, -).
// Bindings: 1 flags / keys, 2 offsets (n + 1), 3 a in, 4 b in, 5 a out, 6 b out, 7 c out.

@group(0) @binding(1) var<storage, read> x_flag: array<u32>;
@group(0) @binding(2) var<storage, read> x_off: array<u32>;
@group(0) @binding(3) var<storage, read> x_a: array<u32>;
@group(0) @binding(4) var<storage, read> x_b: array<u32>;
@group(0) @binding(5) var<storage, read_write> y_a: array<u32>;
@group(0) @binding(6) var<storage, read_write> y_b: array<u32>;
@group(0) @binding(7) var<storage, read_write> y_c: array<u32>;

fn lin(gid: vec3<u32>, nwg: vec3<u32>) -> u32 {
    return gid.x + gid.y * nwg.x * 256u;
}

// y[off[i]] = x[i] where flag[i]; mode 1: b is the index i itself.
@compute @workgroup_size(256)
fn compact(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let i = lin(gid, nwg);
    if i < P.u0.x && x_flag[i] != 0u {
        let o = x_off[i];
        y_a[o] = x_a[i];
        if P.u0.y == 1u {
            y_b[o] = i;
        } else {
            y_b[o] = x_b[i];
        }
    }
}

// Head flags of runs of equal keys (keys in binding 3).
@compute @workgroup_size(256)
fn run_heads(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let i = lin(gid, nwg);
    if i < P.u0.x {
        y_a[i] = select(0u, 1u, i == 0u || x_a[i] != x_a[i - 1u]);
    }
}

// Chunks: key and base (the head position) at the head's scanned index; keys in binding 3.
@compute @workgroup_size(256)
fn run_chunks(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let i = lin(gid, nwg);
    if i < P.u0.x && x_flag[i] != 0u {
        let c = x_off[i];
        y_a[c] = x_a[i];
        y_b[c] = i;
    }
}

// Chunk sizes from consecutive bases (bases in binding 4); P.u0.z = the element count.
@compute @workgroup_size(256)
fn run_sizes(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let c = lin(gid, nwg);
    if c < P.u0.x {
        var end = P.u0.z;
        if c + 1u < P.u0.x {
            end = x_b[c + 1u];
        }
        y_c[c] = end - x_b[c];
    }
}

// Identity values 0..n (the chunk indices that travel with the chunk keys through the sort).
@compute @workgroup_size(256)
fn iota(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let i = lin(gid, nwg);
    if i < P.u0.x {
        y_a[i] = i;
    }
}

// Sizes of the chunks in sorted order: y[j] = size[order[j]] (order in binding 3, sizes in 4).
@compute @workgroup_size(256)
fn gather(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let i = lin(gid, nwg);
    if i < P.u0.x {
        y_a[i] = x_b[x_a[i]];
    }
}

// Decompression: chunk j (in sorted order) expands to positions base[c] .. base[c] + size[c]
// (c = order[j]) at its scanned offset, mapped through the trimmed ray ids.
// Bindings: 1 trimmed ray ids, 2 offsets (chunks + 1), 3 sorted order, 4 bases, 5 leaves.
@compute @workgroup_size(256)
fn expand_runs(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let j = lin(gid, nwg);
    if j < P.u0.x {
        let c = x_a[j];
        let base = x_b[c];
        let o = x_off[j];
        let size = x_off[j + 1u] - o;
        for (var k = 0u; k < size; k++) {
            y_a[o + k] = x_flag[base + k];
        }
    }
}

// Kind histogram of the sorted leaves (kind = top two key bits of the sorted keys).
@compute @workgroup_size(256)
fn kind_hist(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let i = lin(gid, nwg);
    if i < P.u0.x {
        let k = x_a[x_b[i]] & 3u;
        // Counted with plain stores of run boundaries: the kinds are sorted, so the first
        // index of every kind is where it differs from its predecessor.
        if i == 0u || (x_a[x_b[i - 1u]] & 3u) != k {
            y_a[k] = i;
            y_b[k] = 1u;
        }
    }
}
