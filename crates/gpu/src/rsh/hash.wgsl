// The ray hash (thesis §3.2.3, eqs. 3.3–3.11), mirroring rsh::hash: the thesis's 32-bit
// typed key of every ray, or RAH's screen key, with the validity flag trimming reads and the
// ray constants of the intersection kernel. The rest of the leaf order (trim, compress, sort,
// decompress) is prims/*.wgsl, sequenced by rsh/order.rs.

// ---------------------------------------------------------------- hash_keys
// Bindings: 1 org, 2 dir, 3 kind | light << 2, 4 pixel, 5 keys, 6 valid, 7 ray constants.
// Parameters of hash_keys.
struct HashParams {
    rays: u32, // rays to hash
    screen: u32, // 1: RAH's screen key (Z-order of the pixel), 0: the thesis's hash
    width: u32, // the image width (for the screen key)
    light_bits: u32, // bits of the light index in a shadow ray's key
    shadow_dir_bits: u32, // bits per direction coordinate of a shadow ray's key
    origin_bits: u32, // bits per origin coordinate of another ray's key
    dir_bits: u32, // bits per direction coordinate of another ray's key
    box_min: vec3<f32>, // the scene box's minimum
    box_ext: vec3<f32>, // its extent (max(extent, 1e-30), as the CPU computes it)
}

@group(0) @binding(1) var<storage, read> h_org: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read> h_dir: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read> h_kl: array<u32>;
@group(0) @binding(4) var<storage, read> h_pixel: array<u32>;
@group(0) @binding(5) var<storage, read_write> h_keys: array<u32>;
@group(0) @binding(6) var<storage, read_write> h_valid: array<u32>;
@group(0) @binding(7) var<storage, read_write> h_pre: array<vec4<f32>>;

fn part1by1(v: u32) -> u32 {
    var x = v & 0xffffu;
    x = (x | (x << 8u)) & 0x00ff00ffu;
    x = (x | (x << 4u)) & 0x0f0f0f0fu;
    x = (x | (x << 2u)) & 0x33333333u;
    x = (x | (x << 1u)) & 0x55555555u;
    return x;
}

fn part1by2(v: u32) -> u32 {
    var x = v & 0x3ffu;
    x = (x | (x << 16u)) & 0x030000ffu;
    x = (x | (x << 8u)) & 0x0300f00fu;
    x = (x | (x << 4u)) & 0x030c30c3u;
    x = (x | (x << 2u)) & 0x09249249u;
    return x;
}

fn quant(x: f32, bits: u32) -> u32 {
    let n = f32(1u << bits);
    // Rust's `as u32` saturates (negative → 0); x is in [0, 1] here.
    return min(u32(max(x * n, 0.0)), (1u << bits) - 1u);
}

// Ray hash keys, validity flags and intersection constants.
@compute @workgroup_size(256)
fn hash_keys(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let p = hash_params();
    let i = gid.x + gid.y * nwg.x * 256u;
    if i >= p.rays {
        return;
    }
    let o = h_org[i];
    let d = h_dir[i];
    h_valid[i] = select(0u, 1u, o.w < d.w);
    h_pre[i] = ray_pre(d.xyz);
    let kind = h_kl[i] & 3u;
    let light = h_kl[i] >> 2u;
    if p.screen == 1u {
        var z = 0u;
        if p.width > 0u {
            let x = h_pixel[i] % p.width;
            let y = h_pixel[i] / p.width;
            z = ((part1by1(y & 0x1fffu) << 1u) | part1by1(x & 0x1fffu)) & 0x03ffffffu;
        }
        h_keys[i] = (kind << 30u) | ((light & 15u) << 26u) | z;
        return;
    }
    // spherical01 (rsh::hash): θ = acos(z)/π, φ = (atan2(y, x) + π)/2π, clamped to [0, 1].
    let theta = clamp(p_acos(d.z) * C_FRAC_1_PI, 0.0, 1.0);
    let phi = clamp(keep(p_atan2(d.y, d.x) + C_PI) * C_HALF_FRAC_1_PI, 0.0, 1.0);
    var payload = 0u;
    if kind == 1u {
        let sb = p.shadow_dir_bits;
        let l = light & ((1u << p.light_bits) - 1u);
        let dirk = (part1by1(quant(theta, sb)) << 1u) | part1by1(quant(phi, sb));
        payload = (l << (2u * sb)) | dirk;
    } else {
        let u = clamp(div3v(o.xyz - p.box_min, p.box_ext), vec3<f32>(0.0), vec3<f32>(1.0));
        let ob = p.origin_bits;
        let org = (part1by2(quant(u.x, ob)) << 2u) | (part1by2(quant(u.y, ob)) << 1u) | part1by2(quant(u.z, ob));
        let db = p.dir_bits;
        let dirk = (part1by1(quant(theta, db)) << 1u) | part1by1(quant(phi, db));
        payload = (org << (2u * db)) | dirk;
    }
    h_keys[i] = (kind << 30u) | payload;
}
