// The device-resident Whitted frame's own passes (frame.rs), the twins of the host steps of
// render::whitted::render_with and render::secondary: surfaces from the G-buffer and from
// closest hits (Surfaces::from_gbuffer / from_hits), the shadow and bounce rays' kinds and
// pixels, the pixel accumulation in the CPU's order, the misses' background (with the hit
// flags), the sRGB encoding of the image (render::output::srgb_encode) and the small
// per-trace totals the host reads back instead of the records.
//
// Surfaces (as stages.wgsl reads them): 1 position, 2 geometric normal, 3 shading normal,
// 4 incident direction (xyz, w = 0), 5 (throughput rgb, offset scale), 6 material, 7 pixel.
// Rays (as the engines read them, rsh::DeviceRays): 8 origin | t_min, 9 direction | t_max,
// 10 kind | light << 2, 11 pixel, 12 weight (rgb, 0).
// Scene: 13 triangles (3 × vec4 per triangle), 14 vertex normals (3 × vec4), 15 material ids.
// 16 hit records (triangle, t, u, v bits), 17 flags, 18 offsets (scan of the flags),
// 19 image (linear rgb, 0), 20 colours / bounce slot weights (rgb, kind), 21 G-buffer
// position (xyz, depth), 22 G-buffer normal, 23 G-buffer id (triangle, u, v, covered),
// 24 bounce slot origins, 25 bounce slot directions, 26 u32 out (totals, sRGB words),
// 27 per-ray counters (grid: steps, tests).

@group(0) @binding(1) var<storage, read_write> s_pos: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read_write> s_ng: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read_write> s_ns: array<vec4<f32>>;
@group(0) @binding(4) var<storage, read_write> s_inc: array<vec4<f32>>;
@group(0) @binding(5) var<storage, read_write> s_tw: array<vec4<f32>>;
@group(0) @binding(6) var<storage, read_write> s_mat: array<u32>;
@group(0) @binding(7) var<storage, read_write> s_pix: array<u32>;
@group(0) @binding(8) var<storage, read_write> r_org: array<vec4<f32>>;
@group(0) @binding(9) var<storage, read_write> r_dir: array<vec4<f32>>;
@group(0) @binding(10) var<storage, read_write> r_kl: array<u32>;
@group(0) @binding(11) var<storage, read_write> r_pix: array<u32>;
@group(0) @binding(12) var<storage, read_write> r_w: array<vec4<f32>>;
@group(0) @binding(13) var<storage, read> g_tris: array<vec4<f32>>;
@group(0) @binding(14) var<storage, read> g_normals: array<vec4<f32>>;
@group(0) @binding(15) var<storage, read> g_material: array<u32>;
@group(0) @binding(16) var<storage, read> rec: array<vec4<u32>>;
@group(0) @binding(17) var<storage, read_write> flags: array<u32>;
@group(0) @binding(18) var<storage, read> offs: array<u32>;
@group(0) @binding(19) var<storage, read_write> img: array<vec4<f32>>;
@group(0) @binding(20) var<storage, read> col: array<vec4<f32>>;
@group(0) @binding(21) var<storage, read> gb_pos: array<vec4<f32>>;
@group(0) @binding(22) var<storage, read> gb_nrm: array<vec4<f32>>;
@group(0) @binding(23) var<storage, read> gb_id: array<vec4<u32>>;
@group(0) @binding(24) var<storage, read> b_org: array<vec4<f32>>;
@group(0) @binding(25) var<storage, read> b_dir: array<vec4<f32>>;
@group(0) @binding(26) var<storage, read_write> out_u: array<u32>;
@group(0) @binding(27) var<storage, read> cnt: array<vec2<u32>>;

const NO_HIT: u32 = 0xffffffffu;

// Parameters of fr_gb_flags.
struct GbFlagsParams {
    pixels: u32, // pixels of the image
    width: u32, // the image width
    stride: u32, // the G-buffer's row stride in texels
    background: vec3<f32>, // the background colour (linear RGB)
}

// Parameters of fr_gb_surfaces: the part of the surfaces from `first` on, `count` of them.
struct GbSurfacesParams {
    pixels: u32, // pixels of the image
    width: u32, // the image width
    stride: u32, // the G-buffer's row stride in texels
    first: u32, // the part's first surface
    count: u32, // the part's surfaces
    eye: vec3<f32>, // the camera's position
}

// Parameters of fr_hit_surfaces: the part of the surfaces from `first` on, `count` of them.
struct HitSurfacesParams {
    rays: u32, // rays of the batch
    first: u32, // the part's first surface
    count: u32, // the part's surfaces
}

// Parameters of the kernels that take one count (fr_accumulate, fr_bounce_emit).
struct FrameCountParams {
    n: u32, // the rays, surfaces or slots, as each kernel says
}

// Parameters of fr_misses.
struct MissesParams {
    rays: u32, // bounce rays traced
    background: vec3<f32>, // the background colour (linear RGB)
}

// Parameters of fr_encode.
struct EncodeParams {
    words: u32, // u32 words of the sRGB bytes
    pixels: u32, // pixels of the image
}

// Parameters of fr_totals.
struct TotalsParams {
    rays: u32, // rays whose records are summed
    counters: u32, // 1: per-ray (steps, tests) counters are bound and summed
}

// Parameters of fr_slot_kind_count.
struct KindCountParams {
    rays: u32, // rays of the batch
    kind: u32, // the kind counted (RayKind's number)
}

fn fid(gid: vec3<u32>, nwg: vec3<u32>) -> u32 {
    return gid.x + gid.y * nwg.x * 256u;
}

fn mulv(a: vec3<f32>, b: vec3<f32>) -> vec3<f32> {
    return bitcast<vec3<f32>>(bitcast<vec3<u32>>(a * b) | vec3<u32>(opaque_zero()));
}

fn vert(t: u32, k: u32) -> vec3<f32> {
    return g_tris[3u * t + k].xyz;
}

// geom::tri::geometric_normal: (b − a) × (c − a), normalised or zero.
fn geometric_normal(t: u32) -> vec3<f32> {
    let a = vert(t, 0u);
    return normalize_or_zero3(cross3(vert(t, 1u) - a, vert(t, 2u) - a));
}

// Surfaces' offset scale: the largest absolute vertex coordinate (secondary::tri_scale).
fn tri_scale(t: u32) -> f32 {
    let m = max(max(abs(vert(t, 0u)), abs(vert(t, 1u))), abs(vert(t, 2u)));
    return max_element3(m);
}

// Geometry::point: a (1 − u − v) + b u + c v, glam's order.
fn point(t: u32, u: f32, v: f32) -> vec3<f32> {
    let s = keep(1.0 - u) - v;
    return keep3(keep3(mul3(vert(t, 0u), s) + mul3(vert(t, 1u), u)) + mul3(vert(t, 2u), v));
}

fn keep3(x: vec3<f32>) -> vec3<f32> {
    return bitcast<vec3<f32>>(bitcast<vec3<u32>>(x) | vec3<u32>(opaque_zero()));
}

// Geometry::shading_normal: the interpolated vertex normal, or the geometric normal where
// it vanishes.
fn shading_normal(t: u32, u: f32, v: f32) -> vec3<f32> {
    let s = keep(1.0 - u) - v;
    let n0 = g_normals[3u * t].xyz;
    let n1 = g_normals[3u * t + 1u].xyz;
    let n2 = g_normals[3u * t + 2u].xyz;
    let n = normalize_or_zero3(keep3(keep3(mul3(n0, s) + mul3(n1, u)) + mul3(n2, v)));
    if all(n == vec3<f32>(0.0)) {
        return geometric_normal(t);
    }
    return n;
}

// ---------------------------------------------------------------- G-buffer
// Covered flags, and the image's start: the background where nothing is seen, else 0.
@compute @workgroup_size(256)
fn fr_gb_flags(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let prm = gb_flags_params();
    let p = fid(gid, nwg);
    if p >= prm.pixels {
        return;
    }
    let q = (p / prm.width) * prm.stride + p % prm.width;
    let covered = gb_id[q].w != 0u;
    flags[p] = u32(covered);
    img[p] = select(vec4<f32>(prm.background, 0.0), vec4<f32>(0.0), covered);
}

// Surfaces::from_gbuffer: one surface per covered pixel, in pixel order.
@compute @workgroup_size(256)
fn fr_gb_surfaces(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let prm = gb_surfaces_params();
    let p = fid(gid, nwg);
    if p >= prm.pixels || flags[p] == 0u {
        return;
    }
    // Surface offs[p], if it is in this part.
    let i = offs[p] - prm.first;
    if offs[p] < prm.first || i >= prm.count {
        return;
    }
    let q = (p / prm.width) * prm.stride + p % prm.width;
    let t = gb_id[q].x;
    let pos = gb_pos[q].xyz;
    s_pix[i] = p;
    s_pos[i] = vec4<f32>(pos, 0.0);
    s_ng[i] = vec4<f32>(geometric_normal(t), 0.0);
    s_ns[i] = vec4<f32>(gb_nrm[q].xyz, 0.0);
    var inc = normalize_or_zero3(pos - prm.eye);
    if all(inc == vec3<f32>(0.0)) {
        inc = vec3<f32>(0.0, 0.0, 1.0);
    }
    s_inc[i] = vec4<f32>(inc, 0.0);
    s_mat[i] = g_material[t];
    s_tw[i] = vec4<f32>(1.0, 1.0, 1.0, tri_scale(t));
}

// ---------------------------------------------------------------- accumulation
// Each pixel's colours added in surface order, one thread
// per run of equal pixels (a generation's surfaces are in pixel order), so the sums are the
// CPU's `pixels[p] += c` in the same order, whatever the scheduling.
@compute @workgroup_size(256)
fn fr_accumulate(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let prm = frame_count_params();
    let i = fid(gid, nwg);
    let n = prm.n;
    if i >= n {
        return;
    }
    let p = s_pix[i];
    if i > 0u && s_pix[i - 1u] == p {
        return;
    }
    var c = img[p].xyz;
    for (var j = i; j < n && s_pix[j] == p; j++) {
        c = c + col[j].xyz;
    }
    img[p] = vec4<f32>(c, 0.0);
}

// The background times the weight of
// every bounce ray that hit nothing, added per pixel in ray order (rays are in pixel order);
// and each ray's hit flag, for the scan that places the next generation's surfaces.
@compute @workgroup_size(256)
fn fr_misses(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let prm = misses_params();
    let i = fid(gid, nwg);
    let n = prm.rays;
    if i >= n {
        return;
    }
    flags[i] = u32(rec[i].x != NO_HIT);
    let p = r_pix[i];
    if i > 0u && r_pix[i - 1u] == p {
        return;
    }
    var c = img[p].xyz;
    var missed = false;
    for (var j = i; j < n && r_pix[j] == p; j++) {
        if rec[j].x == NO_HIT {
            c = c + mulv(prm.background, r_w[j].xyz);
            missed = true;
        }
    }
    if missed {
        img[p] = vec4<f32>(c, 0.0);
    }
}

// ---------------------------------------------------------------- bounce rays
// The filled slots (flagged by stages.wgsl's bounce_rays) as a ray batch, in slot order
// (surface-major, reflection before refraction: secondary::bounce_rays's order).
@compute @workgroup_size(256)
fn fr_bounce_emit(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let prm = frame_count_params();
    let k = fid(gid, nwg);
    if k >= prm.n || flags[k] == 0u {
        return;
    }
    let j = offs[k];
    r_org[j] = b_org[k];
    r_dir[j] = b_dir[k];
    r_kl[j] = u32(col[k].w);
    r_pix[j] = s_pix[k / 2u];
    r_w[j] = vec4<f32>(col[k].xyz, 0.0);
}

// ---------------------------------------------------------------- surfaces from hits
// Surfaces::from_hits: one surface per hit, in ray order.
@compute @workgroup_size(256)
fn fr_hit_surfaces(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let prm = hit_surfaces_params();
    let i = fid(gid, nwg);
    if i >= prm.rays || flags[i] == 0u {
        return;
    }
    // Surface offs[i], if it is in this part.
    let j = offs[i] - prm.first;
    if offs[i] < prm.first || j >= prm.count {
        return;
    }
    let h = rec[i];
    let t = h.x;
    let u = bitcast<f32>(h.z);
    let v = bitcast<f32>(h.w);
    s_pix[j] = r_pix[i];
    s_pos[j] = vec4<f32>(point(t, u, v), 0.0);
    s_ng[j] = vec4<f32>(geometric_normal(t), 0.0);
    s_ns[j] = vec4<f32>(shading_normal(t, u, v), 0.0);
    s_inc[j] = vec4<f32>(r_dir[i].xyz, 0.0);
    s_mat[j] = g_material[t];
    s_tw[j] = vec4<f32>(r_w[i].xyz, tri_scale(t));
}

// ---------------------------------------------------------------- the image out
// render::output::srgb_encode of one channel.
fn srgb(c0: f32) -> u32 {
    var c = clamp(c0, 0.0, 1.0);
    if c0 != c0 {
        c = 0.0;
    }
    var s: f32;
    if c <= 0.0031308 {
        s = mul(12.92, c);
    } else {
        s = mul(1.055, pow(c, keep(1.0 / 2.4))) - 0.055;
    }
    return min(u32(max(mul(s, 255.0) + 0.5, 0.0)), 255u);
}

// The image as sRGB bytes (r, g, b per pixel, row-major),
// four to a word: what the PNG stores, and all the host reads back of a frame's image.
@compute @workgroup_size(256)
fn fr_encode(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let prm = encode_params();
    let k = fid(gid, nwg);
    if k >= prm.words {
        return;
    }
    var w = 0u;
    for (var b = 0u; b < 4u; b++) {
        let q = 4u * k + b;
        if q < 3u * prm.pixels {
            let c = img[q / 3u][q % 3u];
            w = w | (srgb(c) << (8u * b));
        }
    }
    out_u[k] = w;
}

// ---------------------------------------------------------------- per-trace totals
// Per chunk of 1024 rays: hits, and with the
// grid's per-ray counters their sums as (low, high) words, so that a trace's totals come back
// in a few words per thousand rays instead of the records.
@compute @workgroup_size(256)
fn fr_totals(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let prm = totals_params();
    let c = fid(gid, nwg);
    let n = prm.rays;
    let lo = c * 1024u;
    if lo >= n {
        return;
    }
    let hi = min(lo + 1024u, n);
    var hits = 0u;
    var s = vec4<u32>(0u);
    for (var i = lo; i < hi; i++) {
        hits += u32(rec[i].x != NO_HIT);
        if prm.counters != 0u {
            let x = cnt[i];
            let a = s.x + x.x;
            s.y += u32(a < s.x);
            s.x = a;
            let b = s.z + x.y;
            s.w += u32(b < s.z);
            s.z = b;
        }
    }
    out_u[5u * c] = hits;
    out_u[5u * c + 1u] = s.x;
    out_u[5u * c + 2u] = s.y;
    out_u[5u * c + 3u] = s.z;
    out_u[5u * c + 4u] = s.w;
}

// Flagged bounce slots of one kind per chunk of 1024 (the bounce batch's refraction count,
// before its rays are emitted: read back with the batch's size, in one read-back).
@compute @workgroup_size(256)
fn fr_slot_kind_count(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let prm = kind_count_params();
    let c = fid(gid, nwg);
    let n = prm.rays;
    let lo = c * 1024u;
    if lo >= n {
        return;
    }
    var k = 0u;
    for (var i = lo; i < min(lo + 1024u, n); i++) {
        k += u32(flags[i] != 0u && (u32(col[i].w) & 3u) == prm.kind);
    }
    out_u[c] = k;
}
