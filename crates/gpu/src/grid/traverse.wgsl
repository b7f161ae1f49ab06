// Irregular-grid traversal (Pérard-Gayot et al. 2017, §5), the twin of
// accel/src/grid/traverse.rs operation by operation: enter the grid's box by the slab test,
// find the voxel, then per step look the cell up in the voxel map, test its references with
// the shared watertight kernel (closest: smallest (t, id); any hit: stop at the first), and
// exit through the far planes of the cell's expanded box to the next voxel, never backwards.
// One thread per ray; the counts (steps N_T, tests N_I) per ray, summed on the host in u64.
//
// Floor and the voxel clamps run on floats: every voxel index is below 2^24, so the float
// comparisons decide as the CPU's i64 ones do, and NaN (the CPU's `as i64` gives 0) is
// tested by its bits, which no fast-math assumption can remove.
//
// Bindings: 1 grid constants (box min, box max, voxel size, 1 / voxel size), 2 voxel map,
//           3 cells (2 × vec4<u32>: expanded lo | first reference, expanded hi | end),
//           4 references, 5 triangles (3 × vec4), 6 ray org | t_min, 7 ray dir | t_max,
//           8 records out (triangle, t, u, v bits), 9 counts out (steps, tests).

@group(0) @binding(1) var<storage, read> gr_const: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read> gr_map: array<u32>;
@group(0) @binding(3) var<storage, read> gr_cell: array<vec4<u32>>;
@group(0) @binding(4) var<storage, read> gr_ref: array<u32>;
@group(0) @binding(5) var<storage, read> gr_tris: array<vec4<f32>>;
@group(0) @binding(6) var<storage, read> gr_org: array<vec4<f32>>;
@group(0) @binding(7) var<storage, read> gr_dir: array<vec4<f32>>;
@group(0) @binding(8) var<storage, read_write> gr_rec: array<vec4<u32>>;
@group(0) @binding(9) var<storage, read_write> gr_cnt: array<vec2<u32>>;

// Parameters of grid_trace.
struct GridTraceParams {
    rays: u32, // rays traced
    any_hit: u32, // 1: any hit (stop at the first), 0: closest
    shift: u32, // log2 of the top cells' resolution in voxels
    dims: vec3<u32>, // the virtual grid's dimensions in voxels
    top_dims: vec3<u32>, // the top grid's dimensions
}

// The voxel map read by `lookup` (map.wgsl).
fn map_entry(i: u32) -> u32 {
    return gr_map[i];
}

fn f_inf() -> f32 {
    return bitcast<f32>(0x7f800000u);
}

fn is_nan32(x: f32) -> bool {
    return (bitcast<u32>(x) & 0x7fffffffu) > 0x7f800000u;
}

// floor(x) as the CPU's floor_i64 (NaN → 0), as a float.
fn floor_or_zero(x: f32) -> f32 {
    if is_nan32(x) {
        return 0.0;
    }
    return floor(x);
}


// Irregular-grid traversal, one thread per ray.
@compute @workgroup_size(256)
fn grid_trace(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let p = grid_trace_params();
    let r = gid.x + gid.y * nwg.x * 256u;
    if r >= p.rays {
        return;
    }
    let any_hit = p.any_hit != 0u;
    let dims = p.dims;
    let bmin = gr_const[0].xyz;
    let bmax = gr_const[1].xyz;
    let voxel = gr_const[2].xyz;
    let inv_voxel = gr_const[3].xyz;
    let ow = gr_org[r];
    let dw = gr_dir[r];
    let o = ow.xyz;
    let d = dw.xyz;
    // d.recip(): 1 / ±0 is ±∞, written out rather than left to a division by zero.
    var inv = vec3<f32>(0.0);
    for (var k = 0u; k < 3u; k++) {
        if d[k] == 0.0 {
            inv[k] = bitcast<f32>(0x7f800000u | (bitcast<u32>(d[k]) & 0x80000000u));
        } else {
            inv[k] = div(1.0, d[k]);
        }
    }
    var best_tri = 0xffffffffu;
    var best = vec3<f32>(f_inf(), 0.0, 0.0);
    var steps = 0u;
    var tests = 0u;
    // Aabb::intersect over the grid's box, clipped to [t_min, t_max].
    var tn = ow.w;
    var tf = dw.w;
    for (var k = 0u; k < 3u; k++) {
        let a = mul(keep(bmin[k] - o[k]), inv[k]);
        let b = mul(keep(bmax[k] - o[k]), inv[k]);
        if is_nan32(a) || is_nan32(b) {
            continue;
        }
        var lo = b;
        var hi = a;
        if a <= b {
            lo = a;
            hi = b;
        }
        tn = max(tn, lo);
        tf = min(tf, mul(hi, C_SLAB_ROBUST));
    }
    if tn <= tf {
        let t_leave = tf;
        let pre = ray_pre(d);
        let neg = vec3<bool>(bitcast<u32>(d.x) >> 31u != 0u, bitcast<u32>(d.y) >> 31u != 0u, bitcast<u32>(d.z) >> 31u != 0u);
        let p0 = o + mul3(d, tn);
        var v = vec3<u32>(0u);
        for (var k = 0u; k < 3u; k++) {
            let f = floor_or_zero(mul(keep(p0[k] - bmin[k]), inv_voxel[k]));
            v[k] = u32(clamp(f, 0.0, f32(dims[k] - 1u)));
        }
        loop {
            let c = lookup(v, p.shift, p.top_dims);
            steps += 1u;
            let lo_b = gr_cell[2u * c];
            let hi_e = gr_cell[2u * c + 1u];
            var done = false;
            for (var i = lo_b.w; i < hi_e.w; i++) {
                tests += 1u;
                let t = gr_ref[i];
                let h = intersect(o, d, pre, ow.w, dw.w, gr_tris[3u * t].xyz, gr_tris[3u * t + 1u].xyz, gr_tris[3u * t + 2u].xyz);
                if h.w != 0.0 {
                    if h.x < best.x || (h.x == best.x && t < best_tri) {
                        best_tri = t;
                        best = h.xyz;
                    }
                    if any_hit {
                        done = true;
                        break;
                    }
                }
            }
            if done {
                break;
            }
            // Exit through the three far planes of the cell's expanded box.
            var t_exit = f_inf();
            var axis = 3u;
            for (var k = 0u; k < 3u; k++) {
                if d[k] == 0.0 {
                    continue;
                }
                var side = hi_e[k];
                if neg[k] {
                    side = lo_b[k];
                }
                let plane = keep(bmin[k] + mul(f32(side), voxel[k]));
                let t = mul(keep(plane - o[k]), inv[k]);
                if t < t_exit {
                    t_exit = t;
                    axis = k;
                }
            }
            if best.x < t_exit || t_exit >= t_leave || axis == 3u {
                break;
            }
            let p = o + mul3(d, t_exit);
            var next = v;
            var out = false;
            for (var k = 0u; k < 3u; k++) {
                if k == axis {
                    if neg[k] {
                        if lo_b[k] == 0u {
                            out = true;
                        }
                        next[k] = lo_b[k] - 1u;
                    } else {
                        next[k] = hi_e[k];
                    }
                } else if d[k] != 0.0 {
                    // Forward only: rounding must never move the voxel back along the ray.
                    var f = floor_or_zero(mul(keep(p[k] - bmin[k]), inv_voxel[k]));
                    if neg[k] {
                        f = min(f, f32(v[k]));
                    } else {
                        f = max(f, f32(v[k]));
                    }
                    if f < 0.0 || f >= f32(dims[k]) {
                        out = true;
                    } else {
                        next[k] = u32(f);
                    }
                }
                if next[k] >= dims[k] {
                    out = true;
                }
            }
            if out {
                break;
            }
            v = next;
        }
    }
    if best_tri == 0xffffffffu {
        gr_rec[r] = vec4<u32>(0xffffffffu, 0x7f800000u, 0u, 0u);
    } else {
        gr_rec[r] = vec4<u32>(best_tri, bitcast<u32>(best.x), bitcast<u32>(best.y), bitcast<u32>(best.z));
    }
    gr_cnt[r] = vec2<u32>(steps, tests);
}
