//! Eq. 3.19 (thesis §3.4) for [`LANES`] surfaces at a time, the same bits as
//! [`super::local_with`] surface by surface, and much less work per surface.
//!
//! Surfaces are gathered into structure-of-arrays lanes; per light, one branch-free loop over
//! the lanes does eqs. 3.19a–f and the half-vector's cosine (compiled for AVX2 or AVX-512 it
//! runs 8 or 16 lanes per instruction), then the specular power (3.19g) runs lane by lane
//! through the same `powf` as the scalar code, then a second branch-free loop adds 3.19h–i.
//! Each lane computes exactly the IEEE operations of the scalar function in its order (a
//! skipped light or a zero-length light vector is a blend that keeps the old colour), and
//! Rust never fuses a multiply with an add, so every build returns the scalar function's
//! bits (tested on random surfaces and on the renderer's frames).
//!
//! The power is the one cost vectors cannot take: `powf` must stay the platform's, bit for
//! bit. It is skipped where its result is known exactly: a cosine below the material's
//! [`underflow_below`] gives +0, as `powf` would.

// Lane loops index several arrays by the lane number: that is the shape that vectorises.
#![allow(clippy::needless_range_loop)]

use crate::secondary::Surfaces;
use geom::{Isa, Vec3};
use scene::{Light, Material};

/// Surfaces per group.
pub const LANES: usize = 16;

/// The cosines below which `x^shininess` is exactly +0 in f32 (for x > 0): below
/// 2^(−151 / shininess), x^s < 2^−151, a quarter of the smallest subnormal, so any `powf`
/// within a relative error far above a correctly rounded one's rounds it to +0. 0 (skip
/// nothing) for a shininess that is not finite and positive.
pub fn underflow_below(shininess: f32) -> f32 {
    if !(shininess.is_finite() && shininess > 0.0) {
        return 0.0;
    }
    let c = (-151.0 / shininess as f64).exp2();
    // Rounded down into f32, so every f32 below it is below the real bound.
    let f = c as f32;
    if f as f64 > c {
        f.next_down()
    } else {
        f
    }
}

/// Per-material constants of the lanes: colours and the power's underflow bound.
#[derive(Clone, Copy, Debug)]
pub struct MatLane {
    base: Vec3,
    diffuse: Vec3,
    specular: Vec3,
    shininess: f32,
    zero_below: f32,
}

/// The lanes' constants of every material under the scene's ambient light (made once per
/// shading pass).
pub fn material_lanes(materials: &[Material], ambient: Vec3) -> Vec<MatLane> {
    materials
        .iter()
        .map(|m| MatLane {
            // As the scalar function starts its colour.
            base: m.emission + m.ambient * ambient,
            diffuse: m.diffuse,
            specular: m.specular,
            shininess: m.shininess,
            zero_below: underflow_below(m.shininess),
        })
        .collect()
}

/// Shade surfaces `first .. first + out.len()` (at most [`LANES`]) of `s`: eq. 3.19 with
/// light l hidden from surface i where `occluded(i · lights + l)`, each result times the
/// surface's throughput, into `out`, with the build `isa` (which the CPU must run).
pub fn shade_group(
    s: &Surfaces,
    first: usize,
    mats: &[MatLane],
    lights: &[Light],
    occluded: &(impl Fn(usize) -> bool + ?Sized),
    out: &mut [Vec3],
    isa: Isa,
) {
    debug_assert!(out.len() <= LANES);
    geom::dispatch_isa!(
        isa,
        group(
            s: &Surfaces,
            first: usize,
            mats: &[MatLane],
            lights: &[Light],
            occluded: &(impl Fn(usize) -> bool + ?Sized),
            out: &mut [Vec3],
        )
    )
}

/// Three lanes of coordinates.
type V3 = [[f32; LANES]; 3];

/// `a · b`, lane by lane, in glam's order: (x·x + y·y) + z·z.
#[inline(always)]
fn dot(a: &V3, b: &V3, k: usize) -> f32 {
    a[0][k] * b[0][k] + a[1][k] * b[1][k] + a[2][k] * b[2][k]
}

/// The group, written so that every loop over `k` is branch-free (selects only) and
/// vectorises; `#[inline(always)]` so that each `target_feature` build
/// ([`geom::dispatch_isa`]) gets its own copy.
#[inline(always)]
fn group(
    s: &Surfaces,
    first: usize,
    mats: &[MatLane],
    lights: &[Light],
    occluded: &(impl Fn(usize) -> bool + ?Sized),
    out: &mut [Vec3],
) {
    let n = out.len();
    let nl = lights.len();
    let z = [[0f32; LANES]; 3];
    let (mut p, mut view, mut ng, mut ns) = (z, z, z, z);
    let (mut col, mut dif, mut spe) = (z, z, z);
    let mut shin = [0f32; LANES];
    let mut zero_below = [0f32; LANES];
    // Gather; lanes past `n` repeat the group's first surface (their results are dropped).
    for k in 0..LANES {
        let i = first + if k < n { k } else { 0 };
        let m = &mats[s.material[i] as usize];
        for (a, v) in [
            (&mut p, s.pos[i]),
            (&mut view, s.incident[i]),
            (&mut ng, s.ng[i]),
            (&mut ns, s.ns[i]),
            (&mut col, m.base),
            (&mut dif, m.diffuse),
            (&mut spe, m.specular),
        ] {
            a[0][k] = v.x;
            a[1][k] = v.y;
            a[2][k] = v.z;
        }
        shin[k] = m.shininess;
        zero_below[k] = m.zero_below;
    }
    // Surfaces::facing_normals: the geometric normal towards the viewer, then the shading
    // normal onto its side.
    let mut nrm = z;
    for k in 0..LANES {
        // `ng · inc <= 0` keeps it (a NaN flips it, as there).
        #[allow(clippy::neg_cmp_op_on_partial_ord)]
        let flip_g = !(dot(&ng, &view, k) <= 0.0);
        for c in 0..3 {
            ng[c][k] = if flip_g { -ng[c][k] } else { ng[c][k] };
        }
        let keep_s = dot(&ns, &ng, k) >= 0.0;
        for c in 0..3 {
            nrm[c][k] = if keep_s { ns[c][k] } else { -ns[c][k] };
        }
    }
    let mut visible = [false; LANES];
    let mut go = [false; LANES];
    let mut cos_h = [0f32; LANES];
    let mut sf = [0f32; LANES];
    let (mut dterm, mut sscale) = (z, z);
    for (l, light) in lights.iter().enumerate() {
        for (k, v) in visible.iter_mut().enumerate() {
            *v = k < n && !occluded((first + k) * nl + l);
        }
        if !visible.iter().any(|&v| v) {
            continue;
        }
        let lp = light.position;
        let [c0, c1, c2] = light.attenuation;
        let lc = light.color * light.intensity;
        for k in 0..LANES {
            let t = [lp.x - p[0][k], lp.y - p[1][k], lp.z - p[2][k]];
            let dist = (t[0] * t[0] + t[1] * t[1] + t[2] * t[2]).sqrt(); // 3.19b
                                                                         // `if dist <= 0.0 { continue }` (a NaN distance goes on, as there).
            #[allow(clippy::neg_cmp_op_on_partial_ord)]
            let apart = !(dist <= 0.0);
            go[k] = visible[k] && apart;
            let ld = [t[0] / dist, t[1] / dist, t[2] / dist]; // 3.19a
            let att = 1.0 / (c0 + dist * c1 + dist * dist * c2); // 3.19c
                                                                 // 3.19e: (ldir − view).normalize_or_zero().
            let h = [ld[0] - view[0][k], ld[1] - view[1][k], ld[2] - view[2][k]];
            let rcp = 1.0 / (h[0] * h[0] + h[1] * h[1] + h[2] * h[2]).sqrt();
            let ok = rcp.is_finite() && rcp > 0.0;
            let h = [
                if ok { h[0] * rcp } else { 0.0 },
                if ok { h[1] * rcp } else { 0.0 },
                if ok { h[2] * rcp } else { 0.0 },
            ];
            let df = ld[0] * nrm[0][k] + ld[1] * nrm[1][k] + ld[2] * nrm[2][k];
            let df = df.clamp(0.0, 1.0); // 3.19f
            cos_h[k] = h[0] * nrm[0][k] + h[1] * nrm[1][k] + h[2] * nrm[2][k];
            let scale = [lc.x * att, lc.y * att, lc.z * att];
            for c in 0..3 {
                dterm[c][k] = dif[c][k] * scale[c] * df;
                sscale[c][k] = spe[c][k] * scale[c];
            }
        }
        // 3.19g, lane by lane, through the scalar code's own `powf`.
        for k in 0..LANES {
            if !go[k] {
                continue;
            }
            let x = cos_h[k].max(0.0);
            sf[k] = if x > 0.0 && x < zero_below[k] {
                0.0 // x^s is +0 exactly (underflow_below).
            } else {
                x.powf(shin[k]).clamp(0.0, 1.0)
            };
        }
        for k in 0..LANES {
            for c in 0..3 {
                let lit = col[c][k] + dterm[c][k] + sscale[c][k] * sf[k]; // 3.19h, 3.19i
                col[c][k] = if go[k] { lit } else { col[c][k] };
            }
        }
    }
    for (k, o) in out.iter_mut().enumerate() {
        *o = Vec3::new(col[0][k], col[1][k], col[2][k]) * s.throughput[first + k];
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use geom::Pcg32;

    /// Below the bound, this platform's `powf` gives +0: the largest 4,096 floats under it,
    /// for the shininess values of the shared scenes and a spread of others.
    #[test]
    fn underflow_bound_is_exact() {
        for s in [3.0f32, 8.0, 32.0, 76.5, 97.4304, 112.56, 255.0, 1e4] {
            let c = underflow_below(s);
            assert!(c > 0.0 && c < 1.0, "{s}: {c}");
            let mut x = c;
            for _ in 0..4096 {
                x = x.next_down();
                assert_eq!(x.powf(s).to_bits(), 0, "{x}^{s}");
            }
            // Not a loose bound: where x^s reaches 2^-148 (2^3 times the bound) the power
            // is no longer zero.
            let above = (c as f64 * (3.0 / s as f64).exp2()) as f32;
            assert!(above.powf(s) > 0.0, "{s}");
        }
        // Below 2^-149 there is no f32 to skip: small powers skip nothing.
        for s in [0.0f32, -1.0, f32::NAN, f32::INFINITY, 0.5, 1.0] {
            assert_eq!(underflow_below(s), 0.0);
        }
    }

    /// Random surfaces, materials and lights: every build returns the scalar function's
    /// bits, for every group size.
    #[test]
    fn lanes_equal_the_scalar_function() {
        let builds = geom::isa::builds_for_tests("shading lanes");
        let mut rng = Pcg32::new(3, 19);
        let v = |r: &mut Pcg32, s: f32| Vec3::new(r.range(-s, s), r.range(-s, s), r.range(-s, s));
        for case in 0..200 {
            let n = 1 + case % 40;
            let materials: Vec<Material> = (0..4)
                .map(|m| Material {
                    emission: v(&mut rng, 0.2).abs() * (m % 2) as f32,
                    ambient: v(&mut rng, 1.0).abs(),
                    diffuse: v(&mut rng, 1.0).abs(),
                    specular: v(&mut rng, 1.0).abs() * (m != 3) as u32 as f32,
                    shininess: [1.0, 32.0, 255.0, 0.0][m],
                    ..Default::default()
                })
                .collect();
            let lights: Vec<Light> = (0..1 + case % 5)
                .map(|_| Light {
                    position: v(&mut rng, 10.0),
                    color: v(&mut rng, 1.0).abs(),
                    intensity: rng.range(0.1, 3.0),
                    attenuation: [1.0, rng.range(0.0, 0.5), rng.range(0.0, 0.1)],
                })
                .collect();
            let mut s = Surfaces::default();
            for i in 0..n {
                let pos = if i % 7 == 3 {
                    lights[0].position
                } else {
                    v(&mut rng, 10.0)
                };
                s.pixel.push(i as u32);
                s.pos.push(pos);
                s.ng.push(rng.unit_vector());
                let ns = (s.ng[i] + v(&mut rng, 0.5)).normalize_or(Vec3::Z);
                s.ns.push(ns);
                s.incident.push(rng.unit_vector());
                s.material.push((i % 4) as u32);
                s.throughput.push(v(&mut rng, 1.0).abs());
                s.depth.push(0);
                s.scale.push(1.0);
            }
            let ambient = v(&mut rng, 0.3).abs();
            let occluded: Vec<bool> = (0..n * lights.len())
                .map(|_| rng.next_u32().is_multiple_of(3))
                .collect();
            let hidden = |k: usize| occluded[k];
            let want: Vec<[u32; 3]> = (0..n)
                .map(|i| {
                    let m = &materials[s.material[i] as usize];
                    let vis = |l: usize| !occluded[i * lights.len() + l];
                    let c =
                        super::super::local_with(&s, i, m, &lights, vis, ambient) * s.throughput[i];
                    c.to_array().map(f32::to_bits)
                })
                .collect();
            let mats = material_lanes(&materials, ambient);
            for &isa in &builds {
                let mut got = vec![Vec3::ZERO; n];
                for (g, out) in got.chunks_mut(LANES).enumerate() {
                    shade_group(&s, g * LANES, &mats, &lights, &hidden, out, isa);
                }
                let got: Vec<[u32; 3]> =
                    got.iter().map(|c| c.to_array().map(f32::to_bits)).collect();
                assert_eq!(got, want, "case {case}, {isa:?}");
            }
        }
    }
}
