// Hierarchy construction (thesis §3.2.7), mirroring rsh::build: one thread per node.
// Level 1 groups `b` consecutive sorted leaves of one kind (origin sphere: minimal ball, in
// f64 as geom::miniball; cone: grown ray by ray, eqs. 3.8–3.11); upper levels unite `b`
// consecutive children of one kind. Kinds are sorted (the kind is the key's top bits), so a
// node's children are found from per-kind run starts and node counts, without a search.
//
// Bindings (level 1): 1 leaves, 2 ray org, 3 ray dir, 4 shuffles, 5 sphere, 6 cone, 7 sc,
//                     8 first.  (upper): 1 child sphere, 2 child cone, 3 child sc, 5..8 out.

// Parameters of build_leaf_level and build_upper_level: one level of the hierarchy.
struct LevelParams {
    nodes: u32, // nodes of the level
    b: u32, // children per node (the branching factor)
    union_thesis: u32, // 1: the thesis's sphere/cone union, 0: the exact one
    children: u32, // children in the level below (the sentinel of o_first)
    run: vec4<u32>, // per kind: where its children start in the level below
    cum: vec4<u32>, // per kind: its first node in this level (cumulative)
    below: vec4<u32>, // per kind: its children in the level below
}

@group(0) @binding(1) var<storage, read> b_leaf: array<u32>;
@group(0) @binding(2) var<storage, read> b_org: array<vec4<f32>>;
@group(0) @binding(3) var<storage, read> b_dir: array<vec4<f32>>;
@group(0) @binding(4) var<storage, read> b_shuffle: array<u32>;
@group(0) @binding(5) var<storage, read_write> o_sphere: array<vec4<f32>>;
@group(0) @binding(6) var<storage, read_write> o_cone: array<vec4<f32>>;
@group(0) @binding(7) var<storage, read_write> o_sc: array<vec4<f32>>;
@group(0) @binding(8) var<storage, read_write> o_first: array<u32>;

@group(0) @binding(9) var<storage, read> c_sphere: array<vec4<f32>>;
@group(0) @binding(10) var<storage, read> c_cone: array<vec4<f32>>;
@group(0) @binding(11) var<storage, read> c_sc: array<vec4<f32>>;

// Children [start, end) and kind of node g.
fn node_range(g: u32) -> vec3<u32> {
    let p = level_params();
    var k = 0u;
    for (var j = 1u; j < 4u; j++) {
        if g >= p.cum[j] {
            k = j;
        }
    }
    let start = p.run[k] + (g - p.cum[k]) * p.b;
    let end = min(start + p.b, p.run[k] + p.below[k]);
    return vec3<u32>(start, end, k);
}

// ---------------------------------------------------------------- minimal ball (f64)
struct Ball {
    c: vec3<f64>,
    r2: f64,
}

fn ls64(v: vec3<f64>) -> f64 {
    let xx = mul64(v.x, v.x);
    let yy = mul64(v.y, v.y);
    let zz = mul64(v.z, v.z);
    return keep64(xx + yy) + zz;
}

fn ball_contains(bl: Ball, p: vec3<f64>) -> bool {
    return ls64(p - bl.c) <= mul64(bl.r2, 1.0lf + 1e-10lf) + 1e-20lf;
}

fn ball2(a: vec3<f64>, b: vec3<f64>) -> Ball {
    let c = mul3_64(a + b, 0.5lf);
    return Ball(c, ls64(a - c));
}

fn ball3(a: vec3<f64>, b: vec3<f64>, c: vec3<f64>) -> Ball {
    let ab = b - a;
    let ac = c - a;
    let n = cross64(ab, ac);
    let n2 = ls64(n);
    let m = max(ls64(ab), ls64(ac));
    if n2 <= 1e-24lf * (m * m) {
        var best = ball2(a, b);
        let x = ball2(a, c);
        if x.r2 >= best.r2 {
            best = x;
        }
        let y = ball2(b, c);
        if y.r2 >= best.r2 {
            best = y;
        }
        return best;
    }
    let off = div3_64(mul3_64(cross64(n, ab), ls64(ac)) + mul3_64(cross64(ac, n), ls64(ab)), 2.0lf * n2);
    return Ball(a + off, ls64(off));
}

fn ball4(a: vec3<f64>, b: vec3<f64>, c: vec3<f64>, d: vec3<f64>) -> Ball {
    let u = b - a;
    let v = c - a;
    let w = d - a;
    let det = dot64(u, cross64(v, w));
    let scale = sqrt64(ls64(u)) * sqrt64(ls64(v)) * sqrt64(ls64(w));
    if abs(det) > 1e-12lf * scale {
        let off = div3_64(keep3_64(mul3_64(cross64(v, w), ls64(u)) + mul3_64(cross64(w, u), ls64(v))) + mul3_64(cross64(u, v), ls64(w)), 2.0lf * det);
        return Ball(a + off, ls64(off));
    }
    var pts = array<vec3<f64>, 4>(a, b, c, d);
    var best = Ball(a, 1e300lf);
    var found = false;
    for (var skip = 0u; skip < 4u; skip++) {
        var q: array<vec3<f64>, 3>;
        var k = 0u;
        for (var i = 0u; i < 4u; i++) {
            if i != skip {
                q[k] = pts[i];
                k++;
            }
        }
        let bl = ball3(q[0], q[1], q[2]);
        var all = true;
        for (var i = 0u; i < 4u; i++) {
            if !ball_contains(bl, pts[i]) {
                all = false;
            }
        }
        if all && (!found || bl.r2 < best.r2) {
            best = bl;
            found = true;
        }
    }
    return best;
}

const MAXB: u32 = 64u;

fn minimal_ball(start: u32, count: u32) -> vec4<f32> {
    // The CPU's fixed shuffle for `count` points (table row count: offset count·(count−1)/2).
    var p: array<vec3<f64>, MAXB>;
    let row = count * (count - 1u) / 2u;
    for (var i = 0u; i < count; i++) {
        let src = b_shuffle[row + i];
        p[i] = vec3<f64>(b_org[b_leaf[start + src]].xyz);
    }
    var bl = Ball(vec3<f64>(0.0lf), -1.0lf);
    for (var i = 0u; i < count; i++) {
        if ball_contains(bl, p[i]) {
            continue;
        }
        bl = Ball(p[i], 0.0lf);
        for (var j = 0u; j < i; j++) {
            if ball_contains(bl, p[j]) {
                continue;
            }
            bl = ball2(p[i], p[j]);
            for (var k = 0u; k < j; k++) {
                if ball_contains(bl, p[k]) {
                    continue;
                }
                bl = ball3(p[i], p[j], p[k]);
                for (var l = 0u; l < k; l++) {
                    if !ball_contains(bl, p[l]) {
                        bl = ball4(p[i], p[j], p[k], p[l]);
                    }
                }
            }
        }
    }
    var r = 0.0lf;
    for (var i = 0u; i < count; i++) {
        r = max(r, sqrt64(ls64(p[i] - bl.c)));
    }
    let center = vec3<f32>(bl.c);
    var r32 = f32(r);
    for (var i = 0u; i < count; i++) {
        r32 = max(r32, len3(b_org[b_leaf[start + i]].xyz - center));
    }
    return vec4<f32>(center, mul(r32, C_ONE_P_8EPS) + mul(max_element3(abs(center)), C_8EPS));
}

fn write_node(g: u32, s: vec4<f32>, k: Cone, t: f32, kind: u32, start: u32) {
    o_sphere[g] = s;
    o_cone[g] = vec4<f32>(k.axis, k.angle);
    let sc = p_sin_cos(k.angle);
    o_sc[g] = vec4<f32>(sc.x, sc.y, t, bitcast<f32>(kind));
    o_first[g] = start;
    let p = level_params();
    if g + 1u == p.nodes {
        o_first[p.nodes] = p.children;
    }
}

// Level 1 of the hierarchy over the sorted leaves.
@compute @workgroup_size(64)
fn build_leaf_level(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let g = gid.x + gid.y * nwg.x * 64u;
    if g >= level_params().nodes {
        return;
    }
    let rg = node_range(g);
    let count = rg.y - rg.x;
    var s: vec4<f32>;
    if level_params().union_thesis == 0u {
        s = minimal_ball(rg.x, count);
    } else {
        s = vec4<f32>(b_org[b_leaf[rg.x]].xyz, 0.0);
        for (var i = rg.x + 1u; i < rg.y; i++) {
            s = sphere_union_thesis(s, vec4<f32>(b_org[b_leaf[i]].xyz, 0.0));
        }
    }
    var k = cone_from_dir(normalize3(b_dir[b_leaf[rg.x]].xyz));
    for (var i = rg.x + 1u; i < rg.y; i++) {
        k = cone_add_dir(k, normalize3(b_dir[b_leaf[i]].xyz));
    }
    var t = 0.0;
    for (var i = rg.x; i < rg.y; i++) {
        let d = b_dir[b_leaf[i]];
        t = max(t, d.w * len3(d.xyz));
    }
    write_node(g, s, k, t * C_ONE_P_4EPS, rg.z, rg.x);
}

// A level of the hierarchy over the level below.
@compute @workgroup_size(64)
fn build_upper_level(@builtin(global_invocation_id) gid: vec3<u32>, @builtin(num_workgroups) nwg: vec3<u32>) {
    let g = gid.x + gid.y * nwg.x * 64u;
    if g >= level_params().nodes {
        return;
    }
    let rg = node_range(g);
    var s = c_sphere[rg.x];
    let c0 = c_cone[rg.x];
    var k = Cone(c0.xyz, c0.w);
    var t = c_sc[rg.x].z;
    for (var c = rg.x + 1u; c < rg.y; c++) {
        let cc = c_cone[c];
        if level_params().union_thesis == 0u {
            s = sphere_union_exact(s, c_sphere[c]);
            k = cone_union_exact(k, Cone(cc.xyz, cc.w));
        } else {
            s = sphere_union_thesis(s, c_sphere[c]);
            k = cone_union_thesis(k, Cone(cc.xyz, cc.w));
        }
        t = max(t, c_sc[c].z);
    }
    write_node(g, s, k, t, rg.z, rg.x);
}
