// The Whitted loop's per-generation passes around the traces, mirroring render::secondary
// and render::shade: shadow-ray generation (eqs. 3.1–3.2), reflection/refraction-ray
// generation (eqs. 3.3–3.7) and Blinn-Phong shading with attenuation (eqs. 3.19a–i).
// Surfaces: 1 position, 2 geometric normal, 3 shading normal, 4 incident direction (all
// xyz, w = 0), 5 (throughput rgb, offset scale), 6 material.
// Scene: 7 lights (3 × vec4: position + intensity, colour, attenuation), 8 materials
// (4 × vec4: diffuse + shininess, specular + reflectivity, emission + transparency,
// ior + the ambient term k_a ⊙ L_a).

@group(0) @binding(1) var<storage, read> s_pos: array<vec4<f32>>;
@group(0) @binding(2) var<storage, read> s_ng: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read> s_ns: array<vec4<f32>>;
@group(0) @binding(4) var<storage, read> s_inc: array<vec4<f32>>;
@group(0) @binding(5) var<storage, read> s_tw: array<vec4<f32>>;
@group(0) @binding(6) var<storage, read> s_mat: array<u32>;
@group(0) @binding(7) var<storage, read> lights: array<vec4<f32>>;
@group(0) @binding(8) var<storage, read> mats: array<vec4<f32>>;
// Outputs: rays (origin + t_min, direction + t_max, weight rgb + kind) or colours.
@group(0) @binding(9) var<storage, read_write> o_org: array<vec4<f32>>;
@group(0) @binding(10) var<storage, read_write> o_dir: array<vec4<f32>>;
@group(0) @binding(11) var<storage, read_write> o_w: array<vec4<f32>>;
// Shading: the shadow rays' hit records (triangle, t, u, v bits), per (surface, light): a hit
// hides the light (read as the engine wrote them, with no pass of occlusion flags between).
@group(0) @binding(12) var<storage, read> shadow_rec: array<vec4<u32>>;
// Shadow rays: the surfaces' pixels in, each ray's kind | light << 2 and pixel out (the
// layout of rsh::DeviceRays).
@group(0) @binding(13) var<storage, read> s_pix: array<u32>;
@group(0) @binding(14) var<storage, read_write> o_kl: array<u32>;
@group(0) @binding(15) var<storage, read_write> o_pix: array<u32>;
// Bounce rays: whether each slot holds a ray (the flags the frame's scan compacts by).
@group(0) @binding(16) var<storage, read_write> o_flags: array<u32>;

// Parameters of shadow_rays, bounce_rays and shade_local.
struct StageParams {
    surfaces: u32, // surfaces of the generation
    lights: u32, // lights of the scene (shadow_rays, shade_local)
}

fn inf() -> f32 {
    return bitcast<f32>(0x7f800000u);
}

// geom::ray::offset_point
fn offset_point(p: vec3<f32>, n: vec3<f32>, magnitude: f32) -> vec3<f32> {
    let m = max(max(max_element3(abs(p)), magnitude), 1e-30);
    return p + mul3(n, m * C_OFFSET_REL);
}

fn lin_id(gid: vec3<u32>, nwg: vec3<u32>) -> u32 {
    return gid.x + gid.y * nwg.x * 256u;
}

// Shadow rays of the surfaces.
@compute @workgroup_size(256)
fn shadow_rays(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let prm = stage_params();
    let k = lin_id(gid, nwg);
    if k >= prm.surfaces * prm.lights {
        return;
    }
    let i = k / prm.lights;
    let l = k % prm.lights;
    let lp = lights[3u * l].xyz;
    let p = s_pos[i].xyz;
    var ng = s_ng[i].xyz;
    if !(dot3(ng, lp - p) >= 0.0) {
        ng = -ng;
    }
    let end = offset_point(p, ng, max(s_tw[i].w, max_element3(abs(lp))));
    let d = end - lp;
    let dist = len3(d);
    o_org[k] = vec4<f32>(lp, 0.0);
    o_kl[k] = 1u | (l << 2u);
    o_pix[k] = s_pix[i];
    if dist > 0.0 && is_finite(dist) {
        o_dir[k] = vec4<f32>(div3(d, dist), dist);
    } else {
        o_dir[k] = vec4<f32>(0.0, 0.0, 1.0, 0.0);
    }
}

// (ngf, nsf): Surfaces::facing_normals.
fn facing(i: u32) -> array<vec3<f32>, 2> {
    let inc = s_inc[i].xyz;
    var ngf = s_ng[i].xyz;
    if !(dot3(ngf, inc) <= 0.0) {
        ngf = -ngf;
    }
    var nsf = s_ns[i].xyz;
    if !(dot3(nsf, ngf) >= 0.0) {
        nsf = -nsf;
    }
    return array<vec3<f32>, 2>(ngf, nsf);
}

fn reflect3(i: vec3<f32>, n: vec3<f32>) -> vec3<f32> {
    return normalize3(i - mul3(n, 2.0 * dot3(n, i)));
}

// w = 0 on total internal reflection.
fn refract3(i: vec3<f32>, n: vec3<f32>, eta: f32) -> vec4<f32> {
    let cosi = -dot3(n, i);
    let k = 1.0 - mul(eta * eta, 1.0 - mul(cosi, cosi));
    if k < 0.0 {
        return vec4<f32>(0.0);
    }
    return vec4<f32>(normalize3(mul3(i, eta) + mul3(n, mul(eta, cosi) - sqrt32(k))), 1.0);
}

fn mirror(i: u32, f: array<vec3<f32>, 2>) -> array<vec4<f32>, 2> {
    let inc = s_inc[i].xyz;
    var d = reflect3(inc, f[1]);
    if dot3(d, f[0]) <= 0.0 {
        d = reflect3(inc, f[0]);
    }
    return array<vec4<f32>, 2>(vec4<f32>(offset_point(s_pos[i].xyz, f[0], s_tw[i].w), 0.0), vec4<f32>(d, inf()));
}

// Two slots per surface: 2i reflection (or nothing), 2i + 1 refraction, or the reflection
// total internal reflection turns it into (or nothing). o_flags: 1 for a filled slot.
// o_w.w = kind (2 reflection, 3 refraction) or 0 for an empty slot.
@compute @workgroup_size(256)
fn bounce_rays(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let prm = stage_params();
    let i = lin_id(gid, nwg);
    if i >= prm.surfaces {
        return;
    }
    let m = s_mat[i];
    let reflectivity = mats[4u * m + 1u].w;
    let transparency = mats[4u * m + 2u].w;
    let ior = mats[4u * m + 3u].x;
    let tw = s_tw[i].xyz;
    let f = facing(i);
    o_w[2u * i] = vec4<f32>(0.0);
    o_w[2u * i + 1u] = vec4<f32>(0.0);
    o_flags[2u * i] = u32(reflectivity > 0.0);
    o_flags[2u * i + 1u] = u32(transparency > 0.0);
    if reflectivity > 0.0 {
        let r = mirror(i, f);
        o_org[2u * i] = r[0];
        o_dir[2u * i] = r[1];
        o_w[2u * i] = vec4<f32>(tw * reflectivity, 2.0);
    }
    if transparency > 0.0 {
        let inc = s_inc[i].xyz;
        let entering = dot3(s_ng[i].xyz, inc) < 0.0;
        var eta = ior;
        if entering {
            eta = div(1.0, ior);
        }
        let w = tw * transparency;
        let t = refract3(inc, f[1], eta);
        if t.w != 0.0 {
            var d = t.xyz;
            if dot3(d, f[0]) >= 0.0 {
                let t2 = refract3(inc, f[0], eta);
                d = select(inc, t2.xyz, t2.w != 0.0);
            }
            o_org[2u * i + 1u] = vec4<f32>(offset_point(s_pos[i].xyz, -f[0], s_tw[i].w), 0.0);
            o_dir[2u * i + 1u] = vec4<f32>(d, inf());
            o_w[2u * i + 1u] = vec4<f32>(w, 3.0);
        } else {
            let r = mirror(i, f);
            o_org[2u * i + 1u] = r[0];
            o_dir[2u * i + 1u] = r[1];
            o_w[2u * i + 1u] = vec4<f32>(w, 2.0);
        }
    }
}

fn mulv(a: vec3<f32>, b: vec3<f32>) -> vec3<f32> {
    return bitcast<vec3<f32>>(bitcast<vec3<u32>>(a * b) | vec3<u32>(opaque_zero()));
}

// Local illumination times throughput, into o_w.xyz.
@compute @workgroup_size(256)
fn shade_local(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let prm = stage_params();
    let i = lin_id(gid, nwg);
    if i >= prm.surfaces {
        return;
    }
    let m = s_mat[i];
    let diffuse = mats[4u * m].xyz;
    let shininess = mats[4u * m].w;
    let specular = mats[4u * m + 1u].xyz;
    var color = mats[4u * m + 2u].xyz + mats[4u * m + 3u].yzw;
    let n = facing(i)[1];
    let p = s_pos[i].xyz;
    let view = s_inc[i].xyz;
    for (var l = 0u; l < prm.lights; l++) {
        if shadow_rec[i * prm.lights + l].x != 0xffffffffu {
            continue;
        }
        let to_light = lights[3u * l].xyz - p;
        let dist = len3(to_light);
        if dist <= 0.0 {
            continue;
        }
        let ldir = div3(to_light, dist);
        let att3 = lights[3u * l + 2u].xyz;
        let att = div(1.0, keep(att3.x + mul(dist, att3.y)) + mul(dist * dist, att3.z));
        let half = normalize_or_zero3(ldir - view);
        let df = clamp(dot3(ldir, n), 0.0, 1.0);
        let base = max(dot3(half, n), 0.0);
        var sf = 0.0;
        if base > 0.0 {
            sf = clamp(pow(base, shininess), 0.0, 1.0);
        } else if shininess <= 0.0 {
            sf = 1.0;
        }
        let scale = lights[3u * l + 1u].xyz * lights[3u * l].w * att;
        color = color + mul3(mulv(diffuse, scale), df);
        color = color + mul3(mulv(specular, scale), sf);
    }
    o_w[i] = vec4<f32>(color * s_tw[i].xyz, 0.0);
}
