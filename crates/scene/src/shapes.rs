//! Procedural meshes for built-in scenes and scene files.

use crate::model::Mesh;
use geom::Vec3;
use std::collections::HashMap;

/// A grid of `n × n` quads spanning `origin + s·u + t·v` for s, t ∈ [0, 1], facing `u × v`.
pub fn quad_grid(name: &str, origin: Vec3, u: Vec3, v: Vec3, n: u32, material: u32) -> Mesh {
    let n = n.max(1);
    let mut pos = Vec::new();
    for j in 0..=n {
        for i in 0..=n {
            pos.push(origin + u * (i as f32 / n as f32) + v * (j as f32 / n as f32));
        }
    }
    let mut tris = Vec::new();
    let idx = |i: u32, j: u32| j * (n + 1) + i;
    for j in 0..n {
        for i in 0..n {
            tris.push([idx(i, j), idx(i + 1, j), idx(i + 1, j + 1)]);
            tris.push([idx(i, j), idx(i + 1, j + 1), idx(i, j + 1)]);
        }
    }
    let mut m = Mesh::new(name, pos, tris, material);
    let nrm = u.cross(v).normalize();
    m.normals.iter_mut().for_each(|x| *x = nrm);
    m
}

/// An axis-aligned box with flat faces (24 vertices, 12 triangles), normals facing out
/// (or in, for rooms).
pub fn cuboid(name: &str, min: Vec3, max: Vec3, inward: bool, material: u32) -> Mesh {
    let e = max - min;
    let faces = [
        (min, Vec3::new(0.0, 0.0, e.z), Vec3::new(0.0, e.y, 0.0)), // -x
        (
            Vec3::new(max.x, min.y, min.z),
            Vec3::new(0.0, e.y, 0.0),
            Vec3::new(0.0, 0.0, e.z),
        ), // +x
        (min, Vec3::new(e.x, 0.0, 0.0), Vec3::new(0.0, 0.0, e.z)), // -y
        (
            Vec3::new(min.x, max.y, min.z),
            Vec3::new(0.0, 0.0, e.z),
            Vec3::new(e.x, 0.0, 0.0),
        ), // +y
        (min, Vec3::new(0.0, e.y, 0.0), Vec3::new(e.x, 0.0, 0.0)), // -z
        (
            Vec3::new(min.x, min.y, max.z),
            Vec3::new(e.x, 0.0, 0.0),
            Vec3::new(0.0, e.y, 0.0),
        ), // +z
    ];
    let mut pos = Vec::new();
    let mut nrm = Vec::new();
    let mut tris = Vec::new();
    for (o, u, v) in faces {
        let (u, v) = if inward { (v, u) } else { (u, v) };
        let b = pos.len() as u32;
        let n = u.cross(v).normalize();
        for p in [o, o + u, o + u + v, o + v] {
            pos.push(p);
            nrm.push(n);
        }
        tris.push([b, b + 1, b + 2]);
        tris.push([b, b + 2, b + 3]);
    }
    let mut m = Mesh::new(name, pos, tris, material);
    m.normals = nrm;
    m
}

/// An icosphere: an icosahedron subdivided `level` times (20·4^level triangles).
pub fn icosphere(name: &str, center: Vec3, radius: f32, level: u32, material: u32) -> Mesh {
    let (v, f) = geom::polyhedra::icosahedron();
    let mut pos: Vec<Vec3> = v.iter().map(|p| p.normalize()).collect();
    let mut tris: Vec<[u32; 3]> = f.to_vec();
    for _ in 0..level {
        let mut mid: HashMap<(u32, u32), u32> = HashMap::new();
        let mut next = Vec::with_capacity(tris.len() * 4);
        let mut midpoint = |a: u32, b: u32, pos: &mut Vec<Vec3>| -> u32 {
            let key = (a.min(b), a.max(b));
            *mid.entry(key).or_insert_with(|| {
                pos.push(((pos[a as usize] + pos[b as usize]) * 0.5).normalize());
                pos.len() as u32 - 1
            })
        };
        for [a, b, c] in tris {
            let ab = midpoint(a, b, &mut pos);
            let bc = midpoint(b, c, &mut pos);
            let ca = midpoint(c, a, &mut pos);
            next.extend_from_slice(&[[a, ab, ca], [b, bc, ab], [c, ca, bc], [ab, bc, ca]]);
        }
        tris = next;
    }
    let normals = pos.clone();
    let pos = pos.iter().map(|p| center + *p * radius).collect();
    let mut m = Mesh::new(name, pos, tris, material);
    m.normals = normals;
    m
}

/// A closed tube of radius `r` swept along a closed curve sampled at `n` points, `k` sides.
fn tube(name: &str, curve: impl Fn(f32) -> Vec3, r: f32, n: u32, k: u32, material: u32) -> Mesh {
    let mut pos = Vec::new();
    let mut nrm = Vec::new();
    let tau = std::f32::consts::TAU;
    for i in 0..n {
        let s = i as f32 / n as f32 * tau;
        let p = curve(s);
        let tangent = (curve(s + 1e-3) - curve(s - 1e-3)).normalize();
        let helper = if tangent.y.abs() < 0.9 {
            Vec3::Y
        } else {
            Vec3::X
        };
        let b1 = tangent.cross(helper).normalize();
        let b2 = tangent.cross(b1);
        for j in 0..k {
            let a = j as f32 / k as f32 * tau;
            let d = b1 * a.cos() + b2 * a.sin();
            pos.push(p + d * r);
            nrm.push(d);
        }
    }
    let mut tris = Vec::new();
    for i in 0..n {
        for j in 0..k {
            let a = i * k + j;
            let b = ((i + 1) % n) * k + j;
            let c = ((i + 1) % n) * k + (j + 1) % k;
            let d = i * k + (j + 1) % k;
            tris.push([a, b, c]);
            tris.push([a, c, d]);
        }
    }
    let mut m = Mesh::new(name, pos, tris, material);
    m.normals = nrm;
    m
}

/// A torus in the xz-plane: major radius `big`, minor radius `small`.
pub fn torus(
    name: &str,
    center: Vec3,
    big: f32,
    small: f32,
    n: u32,
    k: u32,
    material: u32,
) -> Mesh {
    tube(
        name,
        move |s| center + Vec3::new(big * s.cos(), 0.0, big * s.sin()),
        small,
        n,
        k,
        material,
    )
}

/// A (p, q) torus knot: a dense, self-winding tube (the "teapot" of the stadium scene).
pub fn torus_knot(
    name: &str,
    center: Vec3,
    scale: f32,
    (p, q): (f32, f32),
    n: u32,
    k: u32,
    material: u32,
) -> Mesh {
    let curve = move |s: f32| {
        let r = 2.0 + (q * s).cos();
        center + Vec3::new(r * (p * s).cos(), -(q * s).sin(), r * (p * s).sin()) * (scale / 3.0)
    };
    tube(name, curve, 0.12 * scale, n, k, material)
}

/// The open side wall of a cone or cylinder from `base` (radius `r0`) to `apex` (radius
/// `r1`), `segments` around, as a triangle soup without degenerate triangles (NFF/AFF cones
/// have no caps). `base` and `apex` must differ.
pub fn cone_wall(base: Vec3, r0: f32, apex: Vec3, r1: f32, segments: usize) -> Vec<[Vec3; 3]> {
    let axis = (apex - base).normalize();
    let (u, v) = axis.any_orthonormal_pair();
    let ring = |c: Vec3, r: f32, k: usize| {
        let a = std::f32::consts::TAU * k as f32 / segments as f32;
        c + r * (a.cos() * u + a.sin() * v)
    };
    let mut out = Vec::with_capacity(2 * segments);
    for k in 0..segments {
        let (p0, p1) = (ring(base, r0, k), ring(base, r0, k + 1));
        let (q0, q1) = (ring(apex, r1, k), ring(apex, r1, k + 1));
        for t in [[p0, p1, q1], [p0, q1, q0]] {
            if !geom::tri::is_degenerate(t[0], t[1], t[2]) {
                out.push(t);
            }
        }
    }
    out
}

/// A UV sphere of `stacks` × `slices`, as a triangle soup without the degenerate triangles
/// at the poles (the AFF `s` entity).
pub fn uv_sphere(c: Vec3, r: f32, stacks: usize, slices: usize) -> Vec<[Vec3; 3]> {
    let p = |i: usize, j: usize| {
        let th = std::f32::consts::PI * i as f32 / stacks as f32;
        let ph = std::f32::consts::TAU * j as f32 / slices as f32;
        c + r * Vec3::new(th.sin() * ph.cos(), th.cos(), th.sin() * ph.sin())
    };
    let mut out = Vec::with_capacity(2 * stacks * slices);
    for i in 0..stacks {
        for j in 0..slices {
            for t in [
                [p(i, j), p(i + 1, j), p(i + 1, j + 1)],
                [p(i, j), p(i + 1, j + 1), p(i, j + 1)],
            ] {
                if !geom::tri::is_degenerate(t[0], t[1], t[2]) {
                    out.push(t);
                }
            }
        }
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn counts_and_normals() {
        assert_eq!(icosphere("s", Vec3::ZERO, 1.0, 2, 0).triangles.len(), 320);
        assert_eq!(
            cuboid("b", Vec3::ZERO, Vec3::ONE, false, 0).triangles.len(),
            12
        );
        assert_eq!(
            quad_grid("q", Vec3::ZERO, Vec3::X, Vec3::Z, 5, 0)
                .triangles
                .len(),
            50
        );
        assert_eq!(
            torus("t", Vec3::ZERO, 1.0, 0.3, 12, 8, 0).triangles.len(),
            192
        );
        // Outward box normals point away from the centre; the winding agrees with them.
        let b = cuboid("b", Vec3::ZERO, Vec3::ONE, false, 0);
        for t in &b.triangles {
            let [p0, p1, p2] = t.map(|i| b.positions[i as usize]);
            let gn = (p1 - p0).cross(p2 - p0).normalize();
            let c = (p0 + p1 + p2) / 3.0;
            assert!(gn.dot(c - Vec3::splat(0.5)) > 0.0);
            assert!(gn.dot(b.normals[t[0] as usize]) > 0.99);
        }
        let r = cuboid("r", Vec3::ZERO, Vec3::ONE, true, 0);
        for t in &r.triangles {
            let [p0, p1, p2] = t.map(|i| r.positions[i as usize]);
            let gn = (p1 - p0).cross(p2 - p0).normalize();
            assert!(gn.dot((p0 + p1 + p2) / 3.0 - Vec3::splat(0.5)) < 0.0);
            assert!(gn.dot(r.normals[t[0] as usize]) > 0.99);
        }
    }
}
