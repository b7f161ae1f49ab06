// The bindings and thread index shared by the small data-parallel passes (compact.wgsl,
// runs.wgsl, permute.wgsl, rsh/kinds.wgsl), prepended to each of them.
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

