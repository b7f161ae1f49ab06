//! Irregular-grid traversal (paper §5): a 3-D DDA on the virtual grid whose step is
//! recomputed from the current cell's (expanded) box at every step.

use super::Grid;
use geom::tri::RayPre;
use geom::{intersect, Ray, Vec3};
use render::{Hit, TraceMode};

/// Per-ray counters: traversal steps (cells visited, N_T) and triangle tests (N_I).
#[derive(Clone, Copy, Debug, Default)]
pub struct RayCounts {
    pub steps: u64,
    pub tests: u64,
}

/// Trace one ray. Closest hit: smallest t, ties to the smallest triangle id (as brute force).
pub fn trace_ray(g: &Grid, tris: &[[Vec3; 3]], ray: &Ray, mode: TraceMode) -> (Hit, RayCounts) {
    let mut counts = RayCounts::default();
    let mut best = Hit::MISS;
    let (o, d) = (ray.org, ray.dir);
    let inv = d.recip();
    let Some((t_enter, t_leave)) = g.bounds.intersect(o, inv, ray.t_min, ray.t_max) else {
        return (best, counts);
    };
    let pre = RayPre::new(ray);
    // The sign bit decides the direction: a −0.0 component must not walk backwards.
    let neg = [
        d.x.is_sign_negative(),
        d.y.is_sign_negative(),
        d.z.is_sign_negative(),
    ];
    let dirs = [d.x, d.y, d.z];
    let voxel_of =
        |p: Vec3, k: usize| -> i64 { ((p[k] - g.bounds.min[k]) * g.inv_voxel[k]).floor() as i64 };
    let p0 = o + d * t_enter;
    let mut v = [0usize, 1, 2].map(|k| voxel_of(p0, k).clamp(0, g.dims[k] as i64 - 1) as u32);
    loop {
        let c = g.lookup(v) as usize;
        counts.steps += 1;
        for &t in g.cell_refs(c) {
            counts.tests += 1;
            let [a, b, cc] = tris[t as usize];
            if let Some(h) = intersect(&pre, a, b, cc) {
                if best.closer(h.t, t) {
                    best = Hit {
                        tri: t,
                        t: h.t,
                        u: h.u,
                        v: h.v,
                    };
                }
                if mode == TraceMode::Any {
                    return (best, counts);
                }
            }
        }
        // Exit through the three far planes of the cell's expanded box.
        let (lo, hi) = (g.exp_min[c], g.exp_max[c]);
        let mut t_exit = f32::INFINITY;
        let mut axis = 3;
        for k in 0..3 {
            if dirs[k] == 0.0 {
                continue;
            }
            let plane = g.bounds.min[k] + (if neg[k] { lo[k] } else { hi[k] }) as f32 * g.voxel[k];
            let t = (plane - o[k]) * inv[k];
            if t < t_exit {
                t_exit = t;
                axis = k;
            }
        }
        // A hit before the exit is final: everything closer lies in the cells passed so far
        // (or in cells the expanded box covers, whose triangles this cell holds).
        if best.t < t_exit || t_exit >= t_leave || axis == 3 {
            break;
        }
        let p = o + d * t_exit;
        let mut next = [0i64; 3];
        for k in 0..3 {
            next[k] = if k == axis {
                // The cell's integer boundary on the exit axis.
                if neg[k] {
                    lo[k] as i64 - 1
                } else {
                    hi[k] as i64
                }
            } else if dirs[k] == 0.0 {
                v[k] as i64
            } else {
                // Forward only: rounding must never move the voxel back along the ray.
                let f = voxel_of(p, k);
                if neg[k] {
                    f.min(v[k] as i64)
                } else {
                    f.max(v[k] as i64)
                }
            };
            if next[k] < 0 || next[k] >= g.dims[k] as i64 {
                return (best, counts);
            }
        }
        v = next.map(|x| x as u32);
    }
    (best, counts)
}
