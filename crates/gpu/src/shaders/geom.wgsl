// Geometry of the ray-space hierarchy, mirroring geom::{cone, sphere, miniball, tri} operation
// by operation (see common.wgsl for why the order matters).

// ---------------------------------------------------------------- cones (geom::cone)
struct Cone {
    axis: vec3<f32>,
    angle: f32,
}

fn cone_wide() -> Cone {
    return Cone(vec3<f32>(0.0, 0.0, 1.0), C_PI);
}

fn pad_angle(a: f32) -> f32 {
    return min(mul(a, C_ONE_P_4EPS) + 1e-6, C_PI);
}

fn angle_between(x: vec3<f32>, y: vec3<f32>) -> f32 {
    return p_atan2(len3(cross3(x, y)), dot3(x, y));
}

fn enclosing(axis: vec3<f32>, x1: vec3<f32>, a1: f32, x2: vec3<f32>, a2: f32) -> Cone {
    let angle = max(angle_between(axis, x1) + a1, angle_between(axis, x2) + a2);
    if angle >= C_PI_M_1EM6 {
        return cone_wide();
    }
    return Cone(axis, pad_angle(angle));
}

fn is_zero3(v: vec3<f32>) -> bool {
    return v.x == 0.0 && v.y == 0.0 && v.z == 0.0;
}

fn rotate_towards(x: vec3<f32>, ax: f32, y: vec3<f32>, ay: f32, beta: f32) -> Cone {
    let w = normalize_or_zero3(y - mul3(x, dot3(x, y)));
    if is_zero3(w) {
        return cone_wide();
    }
    let sc = p_sin_cos(beta);
    return enclosing(normalize3(mul3(x, sc.y) + mul3(w, sc.x)), x, ax, y, ay);
}

fn cone_from_dir(d: vec3<f32>) -> Cone {
    return Cone(d, pad_angle(0.0));
}

fn cone_add_dir(k: Cone, r: vec3<f32>) -> Cone {
    if k.angle >= C_PI {
        return cone_wide();
    }
    let theta = angle_between(k.axis, r);
    if theta <= k.angle {
        return k;
    }
    if theta + k.angle >= C_PI_M_1EM6 {
        return rotate_towards(k.axis, k.angle, r, 0.0, mul(theta - k.angle, 0.5));
    }
    let xr = dot3(k.axis, r);
    let q = normalize_or_zero3(mul3(k.axis, xr) - r);
    if is_zero3(q) {
        return cone_wide();
    }
    let sc = p_sin_cos(k.angle);
    let e = mul3(k.axis, sc.y) + mul3(q, sc.x);
    let axis = normalize_or_zero3(e + r);
    if is_zero3(axis) {
        return cone_wide();
    }
    return enclosing(axis, k.axis, k.angle, r, 0.0);
}

fn cone_union_exact(k: Cone, o: Cone) -> Cone {
    if k.angle >= C_PI || o.angle >= C_PI {
        return cone_wide();
    }
    let theta = angle_between(k.axis, o.axis);
    if theta + o.angle <= k.angle {
        return k;
    }
    if theta + k.angle <= o.angle {
        return o;
    }
    let alpha = mul(keep(theta + k.angle) + o.angle, 0.5);
    return rotate_towards(k.axis, k.angle, o.axis, o.angle, alpha - k.angle);
}

fn cone_union_thesis(k: Cone, o: Cone) -> Cone {
    if k.angle >= C_PI || o.angle >= C_PI {
        return cone_wide();
    }
    let axis = normalize_or_zero3(k.axis + o.axis);
    if is_zero3(axis) {
        return cone_wide();
    }
    return enclosing(axis, k.axis, k.angle, o.axis, o.angle);
}

// ---------------------------------------------------------------- spheres (geom::sphere)
fn padded(r: f32, c: vec3<f32>) -> f32 {
    return mul(r, C_ONE_P_PAD) + mul(max_element3(abs(c)), C_PAD);
}

fn sphere_union_exact(s: vec4<f32>, o: vec4<f32>) -> vec4<f32> {
    let d = len3(o.xyz - s.xyz);
    if d + o.w <= s.w {
        return s;
    }
    if d + s.w <= o.w {
        return o;
    }
    let r = mul(keep(d + s.w) + o.w, 0.5);
    var center = s.xyz;
    if d > 0.0 {
        center = s.xyz + mul3(o.xyz - s.xyz, div(r - s.w, d));
    }
    return vec4<f32>(center, padded(r, center));
}

fn sphere_union_thesis(s: vec4<f32>, o: vec4<f32>) -> vec4<f32> {
    let center = mul3(s.xyz + o.xyz, 0.5);
    let r = mul(len3(o.xyz - s.xyz), 0.5) + max(s.w, o.w);
    return vec4<f32>(center, padded(r, center));
}

// ---------------------------------------------------------------- node tests (geom::cone)
// Node: sphere (c, r), cone (axis, angle), sc = (sin α, cos α, longest ray, kind bits).
fn node_test(exact: bool, sph: vec4<f32>, cone: vec4<f32>, sc: vec4<f32>, p: vec3<f32>, d: f32) -> bool {
    let c = sph.xyz;
    let r = sph.w;
    let axis = cone.xyz;
    let wide = cone.w >= C_FRAC_PI_2;
    let full = cone.w >= C_PI;
    let l = sc.z;
    if !exact {
        if wide {
            return true;
        }
        let cp = p - c;
        let len = len3(cp);
        if len > keep(keep(r + l) + d) * C_ONE_P_1EM5 {
            return false;
        }
        let along = dot3(cp, axis);
        let radial = len3(cp - mul3(axis, along));
        return keep(mul(abs(along), sc.x) + keep(d + r)) + mul(1e-5, len) >= mul(radial, sc.y);
    }
    let v = p - c;
    let len = len3(v);
    let reach = d + r;
    if len > keep(keep(r + l) + d) * C_ONE_P_1EM5 {
        return false;
    }
    if full || len <= reach {
        return true;
    }
    let a = dot3(v, axis);
    if a >= mul(len, sc.y) - mul(1e-5, len) {
        return true;
    }
    var dist = len;
    if wide || a > -mul(len, sc.x) {
        let b = len3(v - mul3(axis, a));
        dist = mul(b, sc.y) - mul(a, sc.x);
    }
    return dist <= mul(reach, C_ONE_P_4EPS) + mul(1e-5, len);
}

// ---------------------------------------------------------------- triangles (geom::tri)
// Ray constants of the watertight test: (sx, sy, sz, kx | ky << 2 | kz << 4).
fn ray_pre(d: vec3<f32>) -> vec4<f32> {
    let ad = abs(d);
    var kz = 2u;
    if ad.x > ad.y {
        if ad.x > ad.z {
            kz = 0u;
        }
    } else if ad.y > ad.z {
        kz = 1u;
    }
    var kx = (kz + 1u) % 3u;
    var ky = (kx + 1u) % 3u;
    if d[kz] < 0.0 {
        let t = kx;
        kx = ky;
        ky = t;
    }
    let sz = div(1.0, d[kz]);
    return vec4<f32>(d[kx] * sz, d[ky] * sz, sz, bitcast<f32>(kx | (ky << 2u) | (kz << 4u)));
}

fn dot64(a: vec3<f64>, b: vec3<f64>) -> f64 {
    let xx = mul64(a.x, b.x);
    let yy = mul64(a.y, b.y);
    let zz = mul64(a.z, b.z);
    return keep64(xx + yy) + zz;
}

fn cross64(a: vec3<f64>, b: vec3<f64>) -> vec3<f64> {
    let x = mul64(a.y, b.z) - mul64(b.y, a.z);
    let y = mul64(a.z, b.x) - mul64(b.z, a.x);
    let z = mul64(a.x, b.y) - mul64(b.x, a.y);
    return vec3<f64>(x, y, z);
}

// geom::tri::exact_hit: (t, u, v) of the ray (o, d) at the triangle's plane, in f64 from the
// f32 inputs, rounded once to f32: the same operations in the same order, every product and
// partial sum kept (unfused), the quotient correctly rounded (div64).
fn exact_hit(o: vec3<f32>, d: vec3<f32>, a: vec3<f32>, b: vec3<f32>, c: vec3<f32>) -> vec3<f32> {
    let a64 = vec3<f64>(a);
    let d64 = vec3<f64>(d);
    let e1 = vec3<f64>(b) - a64;
    let e2 = vec3<f64>(c) - a64;
    let s = vec3<f64>(o) - a64;
    let p = cross64(d64, e2);
    let q = cross64(s, e1);
    let inv = div64(1.0lf, dot64(e1, p));
    return vec3<f32>(f32(mul64(dot64(e2, q), inv)), f32(mul64(dot64(s, p), inv)), f32(mul64(dot64(d64, q), inv)));
}

// Returns (t, u, v, 1) on a hit, w = 0 otherwise.
fn intersect(org: vec3<f32>, dir: vec3<f32>, pre: vec4<f32>, t_min: f32, t_max: f32, a0: vec3<f32>, b0: vec3<f32>, c0: vec3<f32>) -> vec4<f32> {
    let bits = bitcast<u32>(pre.w);
    let kx = bits & 3u;
    let ky = (bits >> 2u) & 3u;
    let kz = (bits >> 4u) & 3u;
    let a = a0 - org;
    let b = b0 - org;
    let c = c0 - org;
    let ax = a[kx] - mul(pre.x, a[kz]);
    let ay = a[ky] - mul(pre.y, a[kz]);
    let bx = b[kx] - mul(pre.x, b[kz]);
    let by = b[ky] - mul(pre.y, b[kz]);
    let cx = c[kx] - mul(pre.x, c[kz]);
    let cy = c[ky] - mul(pre.y, c[kz]);
    var u = mul(cx, by) - mul(cy, bx);
    var v = mul(ax, cy) - mul(ay, cx);
    var w = mul(bx, ay) - mul(by, ax);
    if u == 0.0 || v == 0.0 || w == 0.0 {
        u = f32(mul64(f64(cx), f64(by)) - mul64(f64(cy), f64(bx)));
        v = f32(mul64(f64(ax), f64(cy)) - mul64(f64(ay), f64(cx)));
        w = f32(mul64(f64(bx), f64(ay)) - mul64(f64(by), f64(ax)));
    }
    if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
        return vec4<f32>(0.0);
    }
    let det = keep(u + v) + w;
    if det == 0.0 {
        return vec4<f32>(0.0);
    }
    // A shear that overflowed (sx ±∞ or NaN, its exponent all ones): no hit (geom::tri).
    if (bitcast<u32>(pre.x) & 0x7f800000u) == 0x7f800000u {
        return vec4<f32>(0.0);
    }
    let h = exact_hit(org, dir, a0, b0, c0);
    if !(h.x > t_min && h.x < t_max) {
        return vec4<f32>(0.0);
    }
    return vec4<f32>(h, 1.0);
}
