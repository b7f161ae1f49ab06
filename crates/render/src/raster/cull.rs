//! The setup's first test in lanes: [`LANES`] triangles taken to camera space and tested
//! against the five clip planes (near plane and guard band, thesis §3.1's rasterization)
//! in one branch-free loop, so that the many triangles outside the view leave after a few
//! vector instructions each. Every lane computes [`View::to_camera`] and
//! [`super::plane_dist`]'s operations in their order (compiled for AVX2 or AVX-512, the
//! same IEEE operations), so the verdicts are the scalar test's (tested).

// Lane loops index several arrays by the lane number: that is the shape that vectorises.
#![allow(clippy::needless_range_loop)]

use super::GUARD;
use crate::view::View;
use geom::{Isa, Vec3};

/// Triangles per group.
pub const LANES: usize = 16;

/// A group's camera-space vertices and clip verdicts.
pub struct Verdicts {
    /// Camera-space coordinates: `c[vertex][axis][lane]`.
    c: [[[f32; LANES]; 3]; 3],
    /// Not entirely outside any plane, nor (unclipped) entirely beside the image.
    pub keep: [bool; LANES],
    /// Inside every plane (no clipping needed).
    pub inside: [bool; LANES],
}

impl Verdicts {
    /// Lane `k`'s camera-space vertices.
    pub fn vertex(&self, k: usize) -> [Vec3; 3] {
        let c = &self.c;
        [0, 1, 2].map(|v| Vec3::new(c[v][0][k], c[v][1][k], c[v][2][k]))
    }
}

/// The verdicts of `tris` (at most [`LANES`]) under `view` and the near plane `near`, with
/// the build `isa` (which the CPU must run).
pub fn cull_group(view: &View, near: f32, tris: &[[Vec3; 3]], isa: Isa) -> Verdicts {
    debug_assert!(tris.len() <= LANES && !tris.is_empty());
    geom::dispatch_isa!(isa, group(view: &View, near: f32, tris: &[[Vec3; 3]]) -> Verdicts)
}

/// The group: gathered (lanes past the slice repeat its first triangle), then one loop
/// over the lanes with selects only.
#[inline(always)]
fn group(view: &View, near: f32, tris: &[[Vec3; 3]]) -> Verdicts {
    let mut w = [[[0f32; LANES]; 3]; 3];
    for k in 0..LANES {
        let t = &tris[if k < tris.len() { k } else { 0 }];
        for v in 0..3 {
            w[v][0][k] = t[v].x;
            w[v][1][k] = t[v].y;
            w[v][2][k] = t[v].z;
        }
    }
    let (e, r, u, f) = (view.eye, view.right, view.up, view.fwd);
    let (tx, ty) = (view.tan_x, view.tan_y);
    // Beyond these, in NDC units, a triangle's points are over 4 pixels off the image.
    let (mx, my) = (
        1.0 + 8.0 / view.width as f32,
        1.0 + 8.0 / view.height as f32,
    );
    let mut out = Verdicts {
        c: [[[0f32; LANES]; 3]; 3],
        keep: [false; LANES],
        inside: [false; LANES],
    };
    for k in 0..LANES {
        let mut cam = [[0f32; 3]; 3];
        for v in 0..3 {
            // View::to_camera: d = p − eye, then (d · right, d · up, d · fwd).
            let d = [w[v][0][k] - e.x, w[v][1][k] - e.y, w[v][2][k] - e.z];
            cam[v] = [
                d[0] * r.x + d[1] * r.y + d[2] * r.z,
                d[0] * u.x + d[1] * u.y + d[2] * u.z,
                d[0] * f.x + d[1] * f.y + d[2] * f.z,
            ];
            for a in 0..3 {
                out.c[v][a][k] = cam[v][a];
            }
        }
        // plane_dist's five planes, each at the three vertices.
        let (mut all_out, mut all_in) = (false, true);
        for p in 0..5 {
            let mut d = [0f32; 3];
            for v in 0..3 {
                let [x, y, z] = cam[v];
                d[v] = match p {
                    0 => z - near,
                    1 => x / tx + GUARD * z,
                    2 => GUARD * z - x / tx,
                    3 => y / ty + GUARD * z,
                    _ => GUARD * z - y / ty,
                };
            }
            all_out |= d[0] < 0.0 && d[1] < 0.0 && d[2] < 0.0;
            all_in &= d[0] >= 0.0 && d[1] >= 0.0 && d[2] >= 0.0;
        }
        // A triangle no plane cuts and whose three vertices lie beyond one side of the image
        // (by 4 pixels: far more than the f32 test's rounding, 1e-6 of the image, plus the
        // ±0.5 pixel jitter) covers no pixel centre: the bounding box it would get is empty.
        // Clipped triangles are left to the full setup, whose new vertices carry the
        // rounding of the clip.
        let mut off = false;
        for p in 0..4 {
            let mut beyond = true;
            for v in 0..3 {
                let [x, y, z] = cam[v];
                let d = match p {
                    0 => x / tx - mx * z,
                    1 => -(x / tx) - mx * z,
                    2 => y / ty - my * z,
                    _ => -(y / ty) - my * z,
                };
                beyond &= d > 0.0;
            }
            off |= beyond;
        }
        out.keep[k] = !(all_out || (all_in && off));
        out.inside[k] = all_in;
    }
    out
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::raster::{plane_dist, setup_triangle};
    use geom::Pcg32;
    use scene::Camera;

    /// Every build gives the scalar test's verdicts and camera-space bits, on triangles in
    /// front of, behind, across and around the view (near plane and guard band).
    #[test]
    fn lanes_equal_the_scalar_planes() {
        let mut rng = Pcg32::new(41, 3);
        let cam = Camera {
            eye: Vec3::new(0.3, 1.0, 5.0),
            target: Vec3::new(0.0, 0.2, 0.0),
            up: Vec3::Y,
            vfov: 50.0,
        };
        let view = View::new(&cam, 160, 90);
        let near = 1e-2;
        let tris: Vec<[Vec3; 3]> = (0..2000)
            .map(|i| {
                let s = [0.1f32, 2.0, 20.0, 200.0][i % 4];
                let c = Vec3::new(rng.range(-s, s), rng.range(-s, s), rng.range(-s, s));
                [0, 1, 2].map(|_| c + rng.unit_vector() * rng.range(0.0, s))
            })
            .collect();
        let (mut kept, mut inside, mut dropped) = (0, 0, 0);
        for isa in geom::isa::builds_for_tests("clip-test lanes") {
            for (g, group) in tris.chunks(LANES - 3).enumerate() {
                let v = cull_group(&view, near, group, isa);
                for (k, t) in group.iter().enumerate() {
                    let c = t.map(|p| view.to_camera(p));
                    let got = v.vertex(k).map(|p| p.to_array().map(f32::to_bits));
                    assert_eq!(got, c.map(|p| p.to_array().map(f32::to_bits)));
                    let d = |p: usize| c.map(|x| plane_dist(&view, near, x, p));
                    let out = (0..5).any(|p| d(p).iter().all(|&x| x < 0.0));
                    let all_in = (0..5).all(|p| d(p).iter().all(|&x| x >= 0.0));
                    assert_eq!(v.inside[k], all_in, "{isa:?} {g}/{k}");
                    // Kept whenever the scalar planes keep it and the full setup makes a
                    // screen triangle of it: the lanes drop only triangles that cover
                    // nothing.
                    let mut made = Vec::new();
                    if !out {
                        setup_triangle(&view, near, 0, c, all_in, &mut made);
                    }
                    assert!(!v.keep[k] || !out, "{isa:?} {g}/{k}");
                    if !made.is_empty() {
                        assert!(v.keep[k], "{isa:?} {g}/{k}: a covering triangle dropped");
                    }
                    dropped += (!out && !v.keep[k]) as usize;
                    kept += !out as usize;
                    inside += all_in as usize;
                }
            }
        }
        // The cases are mixed: some triangles leave, some are clipped, some are inside.
        assert!(kept > 0 && kept < tris.len() * 3 && inside > 0 && inside < kept);
        assert!(dropped > 0, "some unclipped triangles lie beside the image");
    }
}
