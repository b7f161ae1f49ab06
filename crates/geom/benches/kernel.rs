//! The shared ray–triangle kernel's cost: `geom::intersect` (watertight inside test, exact
//! distance in f64) against the same test finishing with the paper's f32 distance
//! `(u·az + v·bz + w·cz) / det` (Woop et al. 2013; what the kernel computed before the
//! distance was exact), kept here only as the comparison, on the same rays and triangles in
//! the same run: a brute-force sweep of 1024 rays over 256 triangles of a mixed scene (most
//! tests miss, as in an engine's leaves) and over the triangles each ray hits (every test
//! reaches the distance).

use criterion::{criterion_group, criterion_main, Criterion, Throughput};
use geom::tri::RayPre;
use geom::{intersect, Pcg32, Ray, TriHit};
use glam::Vec3;
use std::hint::black_box;

/// The paper's distance after the same inside test (the kernel before exact t).
fn paper_t(r: &RayPre, a: Vec3, b: Vec3, c: Vec3) -> Option<TriHit> {
    let (a, b, c) = (a - r.org, b - r.org, c - r.org);
    let (kx, ky, kz) = (r.kx as usize, r.ky as usize, r.kz as usize);
    let (ax, ay) = (a[kx] - r.sx * a[kz], a[ky] - r.sy * a[kz]);
    let (bx, by) = (b[kx] - r.sx * b[kz], b[ky] - r.sy * b[kz]);
    let (cx, cy) = (c[kx] - r.sx * c[kz], c[ky] - r.sy * c[kz]);
    let (u, v, w) = (cx * by - cy * bx, ax * cy - ay * cx, bx * ay - by * ax);
    if (u < 0.0 || v < 0.0 || w < 0.0) && (u > 0.0 || v > 0.0 || w > 0.0) {
        return None;
    }
    let det = u + v + w;
    if det == 0.0 {
        return None;
    }
    let sz = 1.0 / r.dir[kz];
    let (az, bz, cz) = (sz * a[kz], sz * b[kz], sz * c[kz]);
    let inv = 1.0 / det;
    let t = (u * az + v * bz + w * cz) * inv;
    (t > r.t_min && t < r.t_max).then_some(TriHit {
        t,
        u: v * inv,
        v: w * inv,
    })
}

fn bench(c: &mut Criterion) {
    let mut rng = Pcg32::new(3, 9);
    // Boxes' faces, sphere-like fans and slivers in a cube of side 20.
    let tris: Vec<[Vec3; 3]> = (0..256)
        .map(|i| {
            let a = rng.unit_vector() * rng.range(0.0, 10.0);
            let e = rng.unit_vector() * rng.range(0.5, 8.0);
            let f = if i % 4 == 0 {
                e.cross(rng.unit_vector()).normalize_or_zero() * rng.range(0.01, 0.1)
            } else {
                rng.unit_vector() * rng.range(0.5, 8.0)
            };
            [a, a + e, a + f]
        })
        .collect();
    let rays: Vec<RayPre> = (0..1024)
        .map(|_| {
            RayPre::new(&Ray::new(
                rng.unit_vector() * rng.range(0.0, 10.0),
                rng.unit_vector(),
                0.0,
                f32::INFINITY,
            ))
        })
        .collect();
    let pairs: Vec<(usize, usize)> = (0..rays.len())
        .flat_map(|r| (0..tris.len()).map(move |t| (r, t)))
        .filter(|&(r, t)| intersect(&rays[r], tris[t][0], tris[t][1], tris[t][2]).is_some())
        .collect();
    type Kernel = fn(&RayPre, Vec3, Vec3, Vec3) -> Option<TriHit>;
    let kernels: [(&str, Kernel); 2] = [("exact t", intersect), ("paper's t", paper_t)];
    let mut g = c.benchmark_group("ray-triangle kernel, 1024 rays x 256 triangles");
    g.throughput(Throughput::Elements((rays.len() * tris.len()) as u64));
    for (name, k) in kernels {
        g.bench_function(format!("{name}: every pair (most miss)"), |b| {
            b.iter(|| {
                let mut n = 0u32;
                for r in &rays {
                    for t in &tris {
                        n += k(r, t[0], t[1], t[2]).is_some() as u32;
                    }
                }
                black_box(n)
            })
        });
    }
    g.finish();
    let mut g = c.benchmark_group(format!(
        "ray-triangle kernel, {} hitting pairs",
        pairs.len()
    ));
    g.throughput(Throughput::Elements(pairs.len() as u64));
    for (name, k) in kernels {
        g.bench_function(format!("{name}: hits only"), |b| {
            b.iter(|| {
                let mut s = 0.0f32;
                for &(r, t) in &pairs {
                    let [a, bb, cc] = tris[t];
                    s += k(&rays[r], a, bb, cc).map_or(0.0, |h| h.t);
                }
                black_box(s)
            })
        });
    }
    g.finish();
}

criterion_group!(benches, bench);
criterion_main!(benches);
