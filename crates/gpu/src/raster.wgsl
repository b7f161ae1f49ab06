// Primary visibility by hardware rasterization into the thesis's G-buffer (§3.1: four
// render targets of 4 × f32, plus the triangle id and barycentrics), with a depth test.
// Depth is reversed and the far plane infinite: depth = near / z (1 at the near plane,
// → 0 far away), compared with `Greater`, so equal depths keep the first-drawn (smaller)
// triangle id, the tie rule of the CPU rasterizer and of closest-hit.

struct View {
    eye: vec4<f32>,
    // (right, clip-space x shift per unit depth of a jittered view)
    right: vec4<f32>,
    // (up, clip-space y shift per unit depth of a jittered view)
    up: vec4<f32>,
    fwd: vec4<f32>,
    // (tan_x, tan_y, near, 1 for a jittered view)
    proj: vec4<f32>,
}

@group(0) @binding(0) var<uniform> r_view: View;
@group(0) @binding(1) var<storage, read> r_tris: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read> r_normals: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read> r_material: array<u32>;
// Per material: diffuse (rgb, -), specular (rgb, shininess).
@group(0) @binding(4) var<storage, read> r_mats: array<vec4<f32>>;

struct VOut {
    @builtin(position) pos: vec4<f32>,
    @location(0) bary: vec2<f32>,
    @location(1) @interpolate(flat) tri: u32,
}

@vertex
fn vs(@builtin(vertex_index) vi: u32) -> VOut {
    let t = vi / 3u;
    let k = vi % 3u;
    let d = r_tris[vi].xyz - r_view.eye.xyz;
    let c = vec3<f32>(dot(d, r_view.right.xyz), dot(d, r_view.up.xyz), dot(d, r_view.fwd.xyz));
    var o: VOut;
    o.pos = vec4<f32>(c.x / r_view.proj.x, c.y / r_view.proj.y, r_view.proj.z, c.z);
    // Antialiasing's sample offset (render::View::jitter), as the CPU rasterizer moves the
    // triangle by −jitter pixels; a centred view skips it, so its bits are untouched.
    if r_view.proj.w != 0.0 {
        o.pos.x = o.pos.x + r_view.right.w * c.z;
        o.pos.y = o.pos.y + r_view.up.w * c.z;
    }
    o.bary = vec2<f32>(select(0.0, 1.0, k == 1u), select(0.0, 1.0, k == 2u));
    o.tri = t;
    return o;
}

struct FOut {
    @location(0) position: vec4<f32>,
    @location(1) normal: vec4<f32>,
    @location(2) diffuse: vec4<f32>,
    @location(3) specular: vec4<f32>,
    // (triangle id, u bits, v bits, 1)
    @location(4) id: vec4<u32>,
}

@fragment
fn fs(v: VOut) -> FOut {
    let t = v.tri;
    let u = v.bary.x;
    let w = v.bary.y;
    let a = r_tris[3u * t].xyz;
    let b = r_tris[3u * t + 1u].xyz;
    let c = r_tris[3u * t + 2u].xyz;
    let s = 1.0 - u - w;
    var o: FOut;
    o.position = vec4<f32>(a * s + b * u + c * w, v.pos.z);
    var n = r_normals[3u * t].xyz * s + r_normals[3u * t + 1u].xyz * u + r_normals[3u * t + 2u].xyz * w;
    let l = length(n);
    if l > 0.0 && l < 1e30 {
        n = n / l;
    } else {
        n = normalize(cross(b - a, c - a));
    }
    o.normal = vec4<f32>(n, 0.0);
    let m = r_material[t];
    o.diffuse = r_mats[2u * m];
    o.specular = r_mats[2u * m + 1u];
    o.id = vec4<u32>(t, bitcast<u32>(u), bitcast<u32>(w), 1u);
    return o;
}
