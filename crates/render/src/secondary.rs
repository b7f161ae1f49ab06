//! Surfaces to shade and the secondary rays they spawn (thesis §3.2.3, eqs. 3.1–3.7).
//!
//! A [`Surfaces`] batch is the same thing whether it came from the G-buffer (after
//! rasterization) or from the closest hits of a reflection/refraction batch, so one set of
//! kernels serves every Whitted generation.

use crate::raster::GBuffer;
use geom::ray::{offset_point, OFFSET_REL};
use geom::{Ray, Vec3, NO_HIT};
use rayon::prelude::*;
use scene::{Geometry, Light, Material};
use std::mem::MaybeUninit;
use trace::batch::{Hit, RayBatch, RayKind};
use trace::fill::{scan_pieces, uninit_pieces};

/// Surface points to shade, structure of arrays.
#[derive(Clone, Debug, Default)]
pub struct Surfaces {
    /// Pixel index (y · width + x) the surface contributes to.
    pub pixel: Vec<u32>,
    /// World-space surface point.
    pub pos: Vec<Vec3>,
    /// Unit geometric normal as stored (right-handed winding: outward for closed meshes).
    pub ng: Vec<Vec3>,
    /// Unit interpolated shading normal (eqs. 3.17–3.18).
    pub ns: Vec<Vec3>,
    /// Unit direction of the ray that arrived here.
    pub incident: Vec<Vec3>,
    /// Material index.
    pub material: Vec<u32>,
    /// Colour weight of the surface's contribution to its pixel.
    pub throughput: Vec<Vec3>,
    /// Whitted recursion depth (0 for the rasterized surfaces).
    pub depth: Vec<u8>,
    /// Largest absolute vertex coordinate of the surface's triangle: the magnitude the
    /// self-intersection offset is scaled by ([`offset_point`]).
    pub scale: Vec<f32>,
}

/// Surfaces (or rays) per piece of a parallel refill: large enough that a piece's
/// bookkeeping is noise, small enough that both cores get many pieces.
const PIECE: usize = 8192;

/// One surface, as [`SurfCursor::put`] writes it.
#[derive(Clone, Copy, Debug)]
pub struct Surface {
    /// See [`Surfaces::pixel`].
    pub pixel: u32,
    /// See [`Surfaces::pos`].
    pub pos: Vec3,
    /// See [`Surfaces::ng`].
    pub ng: Vec3,
    /// See [`Surfaces::ns`].
    pub ns: Vec3,
    /// See [`Surfaces::incident`].
    pub incident: Vec3,
    /// See [`Surfaces::material`].
    pub material: u32,
    /// See [`Surfaces::throughput`].
    pub throughput: Vec3,
    /// See [`Surfaces::depth`].
    pub depth: u8,
    /// See [`Surfaces::scale`].
    pub scale: f32,
}

/// One piece of a [`Surfaces`] being refilled ([`Surfaces::refill`]).
pub struct SurfCursor<'a> {
    pixel: &'a mut [MaybeUninit<u32>],
    pos: &'a mut [MaybeUninit<Vec3>],
    ng: &'a mut [MaybeUninit<Vec3>],
    ns: &'a mut [MaybeUninit<Vec3>],
    incident: &'a mut [MaybeUninit<Vec3>],
    material: &'a mut [MaybeUninit<u32>],
    throughput: &'a mut [MaybeUninit<Vec3>],
    depth: &'a mut [MaybeUninit<u8>],
    scale: &'a mut [MaybeUninit<f32>],
    at: usize,
}

impl SurfCursor<'_> {
    /// Write the next surface of the piece (panics past the piece's end).
    #[inline]
    pub fn put(&mut self, s: Surface) {
        let k = self.at;
        self.pixel[k].write(s.pixel);
        self.pos[k].write(s.pos);
        self.ng[k].write(s.ng);
        self.ns[k].write(s.ns);
        self.incident[k].write(s.incident);
        self.material[k].write(s.material);
        self.throughput[k].write(s.throughput);
        self.depth[k].write(s.depth);
        self.scale[k].write(s.scale);
        self.at = k + 1;
    }
}

/// Largest absolute coordinate of triangle `t`'s vertices.
#[inline]
fn tri_scale(geo: &Geometry, t: u32) -> f32 {
    let [a, b, c] = geo.tris[t as usize];
    a.abs().max(b.abs()).max(c.abs()).max_element()
}

impl Surfaces {
    /// Number of surfaces.
    pub fn len(&self) -> usize {
        self.pixel.len()
    }

    /// Whether there are none.
    pub fn is_empty(&self) -> bool {
        self.pixel.is_empty()
    }

    /// The surfaces `r` (a part a device can bind at once).
    pub fn slice(&self, r: std::ops::Range<usize>) -> Surfaces {
        Surfaces {
            pixel: self.pixel[r.clone()].to_vec(),
            pos: self.pos[r.clone()].to_vec(),
            ng: self.ng[r.clone()].to_vec(),
            ns: self.ns[r.clone()].to_vec(),
            incident: self.incident[r.clone()].to_vec(),
            material: self.material[r.clone()].to_vec(),
            throughput: self.throughput[r.clone()].to_vec(),
            depth: self.depth[r.clone()].to_vec(),
            scale: self.scale[r].to_vec(),
        }
    }

    /// Covered G-buffer pixels, in pixel order.
    pub fn from_gbuffer(gb: &GBuffer, geo: &Geometry, eye: Vec3) -> Surfaces {
        let mut s = Surfaces::default();
        s.fill_from_gbuffer(gb, geo, eye);
        s
    }

    /// [`Surfaces::from_gbuffer`] into these buffers (kept: no allocation once they are
    /// large enough), in parallel over rows: count → scan → write.
    pub fn fill_from_gbuffer(&mut self, gb: &GBuffer, geo: &Geometry, eye: Vec3) {
        let (bounds, ranges) = scan_pieces(gb.tri.len(), PIECE, |r| {
            gb.tri[r].iter().filter(|&&t| t != NO_HIT).count()
        });
        self.refill(*bounds.last().expect("bounds"), &bounds, |p, c| {
            for i in ranges[p].clone() {
                let t = gb.tri[i];
                if t == NO_HIT {
                    continue;
                }
                let pos = gb.position[i];
                c.put(Surface {
                    pixel: i as u32,
                    pos,
                    ng: geo.geometric_normal(t),
                    ns: gb.normal[i],
                    incident: (pos - eye).normalize_or(Vec3::Z),
                    material: geo.material[t as usize],
                    throughput: Vec3::ONE,
                    depth: 0,
                    scale: tri_scale(geo, t),
                });
            }
        });
    }

    /// The closest hits of a batch, in ray order (misses are skipped).
    pub fn from_hits(rays: &RayBatch, hits: &[Hit], geo: &Geometry) -> Surfaces {
        let mut s = Surfaces::default();
        s.fill_from_hits(rays, hits, geo);
        s
    }

    /// [`Surfaces::from_hits`] into these buffers, in parallel: count → scan → write.
    pub fn fill_from_hits(&mut self, rays: &RayBatch, hits: &[Hit], geo: &Geometry) {
        let (bounds, ranges) = scan_pieces(hits.len(), PIECE, |r| {
            hits[r].iter().filter(|h| h.is_hit()).count()
        });
        self.refill(*bounds.last().expect("bounds"), &bounds, |p, c| {
            for i in ranges[p].clone() {
                let h = hits[i];
                if !h.is_hit() {
                    continue;
                }
                c.put(Surface {
                    pixel: rays.pixel[i],
                    pos: geo.point(h.tri, h.u, h.v),
                    ng: geo.geometric_normal(h.tri),
                    ns: geo.shading_normal(h.tri, h.u, h.v),
                    incident: rays.dir[i],
                    material: geo.material[h.tri as usize],
                    throughput: rays.throughput[i],
                    depth: rays.depth[i].saturating_add(1),
                    scale: tri_scale(geo, h.tri),
                });
            }
        });
    }

    /// Refill with `n` surfaces written in parallel, piece `i` (`bounds[i]..bounds[i + 1]`)
    /// by `fill(i, cursor)` in order (see [`trace::fill`]). Panics, before any length is
    /// set, if a piece is not written whole.
    pub fn refill(
        &mut self,
        n: usize,
        bounds: &[usize],
        fill: impl Fn(usize, &mut SurfCursor) + Sync,
    ) {
        let mut pixel = uninit_pieces(&mut self.pixel, n, bounds).into_iter();
        let mut pos = uninit_pieces(&mut self.pos, n, bounds).into_iter();
        let mut ng = uninit_pieces(&mut self.ng, n, bounds).into_iter();
        let mut ns = uninit_pieces(&mut self.ns, n, bounds).into_iter();
        let mut incident = uninit_pieces(&mut self.incident, n, bounds).into_iter();
        let mut material = uninit_pieces(&mut self.material, n, bounds).into_iter();
        let mut throughput = uninit_pieces(&mut self.throughput, n, bounds).into_iter();
        let mut depth = uninit_pieces(&mut self.depth, n, bounds).into_iter();
        let mut scale = uninit_pieces(&mut self.scale, n, bounds).into_iter();
        let e = "a piece per bound";
        let cursors: Vec<SurfCursor> = (0..bounds.len() - 1)
            .map(|_| SurfCursor {
                pixel: pixel.next().expect(e),
                pos: pos.next().expect(e),
                ng: ng.next().expect(e),
                ns: ns.next().expect(e),
                incident: incident.next().expect(e),
                material: material.next().expect(e),
                throughput: throughput.next().expect(e),
                depth: depth.next().expect(e),
                scale: scale.next().expect(e),
                at: 0,
            })
            .collect();
        let whole: Vec<bool> = cursors
            .into_par_iter()
            .enumerate()
            .map(|(i, mut c)| {
                fill(i, &mut c);
                c.at == c.pixel.len()
            })
            .collect();
        assert!(
            whole.iter().all(|&w| w),
            "Surfaces::refill: a piece was not written whole"
        );
        // SAFETY: every piece's cursor reached its end, so each of the n elements of every
        // array was written.
        unsafe {
            self.pixel.set_len(n);
            self.pos.set_len(n);
            self.ng.set_len(n);
            self.ns.set_len(n);
            self.incident.set_len(n);
            self.material.set_len(n);
            self.throughput.set_len(n);
            self.depth.set_len(n);
            self.scale.set_len(n);
        }
    }

    /// Geometric and shading normals turned to the side the ray came from.
    #[inline]
    pub fn facing_normals(&self, i: usize) -> (Vec3, Vec3) {
        let inc = self.incident[i];
        let ngf = if self.ng[i].dot(inc) <= 0.0 {
            self.ng[i]
        } else {
            -self.ng[i]
        };
        let nsf = if self.ns[i].dot(ngf) >= 0.0 {
            self.ns[i]
        } else {
            -self.ns[i]
        };
        (ngf, nsf)
    }
}

/// Shadow rays, one per (surface, light), surface-major: ray `s · lights + l`.
///
/// Eqs. 3.1–3.2: the origin is *at the light* and the direction points at the fragment; the
/// ray ends at the fragment moved off its surface towards the light's side by an offset
/// scaled to the coordinates involved ([`offset_point`]), so the fragment's own triangle is
/// never hit, at any distance or angle.
pub fn shadow_rays(s: &Surfaces, lights: &[Light]) -> RayBatch {
    let mut b = RayBatch::default();
    shadow_rays_into(s, lights, &mut b);
    b
}

/// [`shadow_rays`] into `b`'s buffers (kept: no allocation once they are large enough),
/// written in parallel, surface-major as a serial loop makes them. Each light's rays of
/// 16 surfaces are computed in one branch-free loop (vectorised: the
/// multi-versioned builds of [`geom::Isa`]), the same IEEE operations as
/// [`shadow_ray`] per ray, so the same bits (tested).
pub fn shadow_rays_into(s: &Surfaces, lights: &[Light], b: &mut RayBatch) {
    let nl = lights.len();
    let isa = geom::Isa::best();
    let (bounds, ranges) = scan_pieces(s.len(), PIECE, |r| r.len() * nl);
    b.refill(s.len() * nl, 0, &bounds, |piece, c| {
        let r = ranges[piece].clone();
        // A group's rays, light-major: one allocation per piece of PIECE surfaces.
        let mut rays = vec![[0f32; 4]; LANES * nl];
        let mut first = r.start;
        while first < r.end {
            let n = (r.end - first).min(LANES);
            shadow_group(s, first, n, lights, &mut rays, isa);
            for k in 0..n {
                let i = first + k;
                for (l, light) in lights.iter().enumerate() {
                    let [x, y, z, t] = rays[l * LANES + k];
                    let ray = Ray::new(light.position, Vec3::new(x, y, z), 0.0, t);
                    let (px, w) = (s.pixel[i], s.throughput[i]);
                    c.put(ray, RayKind::Shadow, px, l as u32, w, s.depth[i]);
                }
            }
            first += n;
        }
    });
}

/// The shadow ray from `light` to surface `i` (eqs. 3.1–3.2), as [`shadow_rays`] makes it:
/// the reference the lanes are tested against.
pub fn shadow_ray(s: &Surfaces, i: usize, light: &Light) -> Ray {
    let p = s.pos[i];
    let lp = light.position;
    let ng = if s.ng[i].dot(lp - p) >= 0.0 {
        s.ng[i]
    } else {
        -s.ng[i]
    };
    let end = offset_point(p, ng, s.scale[i].max(lp.abs().max_element()));
    let d = end - lp;
    let dist = d.length();
    if dist > 0.0 && dist.is_finite() {
        Ray::new(lp, d / dist, 0.0, dist)
    } else {
        Ray::new(lp, Vec3::Z, 0.0, 0.0)
    }
}

/// Surfaces per group of the shadow rays' lanes.
const LANES: usize = 16;

/// Surfaces `first .. first + n` (n ≤ [`LANES`]): the direction and length of their rays
/// to every light, in lanes, into `rays[l · LANES + k]` (x, y, z, t_max).
fn shadow_group(
    s: &Surfaces,
    first: usize,
    n: usize,
    lights: &[Light],
    rays: &mut [[f32; 4]],
    isa: geom::Isa,
) {
    geom::dispatch_isa!(
        isa,
        shadow_lanes(
            s: &Surfaces,
            first: usize,
            n: usize,
            lights: &[Light],
            rays: &mut [[f32; 4]],
        )
    )
}

/// The group's rays: per light one loop over the lanes with selects only, each lane the
/// operations of [`shadow_ray`] in its order (lanes past `n` repeat the first surface).
#[inline(always)]
fn shadow_lanes(s: &Surfaces, first: usize, n: usize, lights: &[Light], rays: &mut [[f32; 4]]) {
    let z = [[0f32; LANES]; 3];
    let (mut p, mut ng) = (z, z);
    let (mut pmax, mut scale) = ([0f32; LANES], [0f32; LANES]);
    for k in 0..LANES {
        let i = first + if k < n { k } else { 0 };
        let (q, g) = (s.pos[i], s.ng[i]);
        for a in 0..3 {
            p[a][k] = q[a];
            ng[a][k] = g[a];
        }
        // offset_point's |p| term, which depends on the surface only.
        pmax[k] = q.abs().max_element();
        scale[k] = s.scale[i];
    }
    for (l, light) in lights.iter().enumerate() {
        let lp = light.position;
        let lmax = lp.abs().max_element();
        let out: &mut [[f32; 4]; LANES] = (&mut rays[l * LANES..(l + 1) * LANES])
            .try_into()
            .expect("LANES rays per light");
        for k in 0..LANES {
            // ng · (lp − p), in glam's order.
            let t = [lp.x - p[0][k], lp.y - p[1][k], lp.z - p[2][k]];
            let toward = ng[0][k] * t[0] + ng[1][k] * t[1] + ng[2][k] * t[2] >= 0.0;
            let sign = if toward { 1.0f32 } else { -1.0 };
            // offset_point(p, g, max(scale, |lp|)): p + g · (max(|p|, magnitude, 1e-30) · rel),
            // g = ±ng (the sign's product is exact: a negation).
            let m = pmax[k].max(scale[k].max(lmax)).max(1e-30) * OFFSET_REL;
            let d = [
                (p[0][k] + (sign * ng[0][k]) * m) - lp.x,
                (p[1][k] + (sign * ng[1][k]) * m) - lp.y,
                (p[2][k] + (sign * ng[2][k]) * m) - lp.z,
            ];
            let dist = (d[0] * d[0] + d[1] * d[1] + d[2] * d[2]).sqrt();
            let ok = dist > 0.0 && dist.is_finite();
            out[k] = [
                if ok { d[0] / dist } else { 0.0 },
                if ok { d[1] / dist } else { 0.0 },
                if ok { d[2] / dist } else { 1.0 },
                if ok { dist } else { 0.0 },
            ];
        }
    }
}

/// Mirror direction (eq. 3.4) of unit `i` about unit `n`.
#[inline]
pub fn reflect(i: Vec3, n: Vec3) -> Vec3 {
    (i - n * (2.0 * n.dot(i))).normalize()
}

/// Refracted direction (eqs. 3.6–3.7) for unit `i`, unit `n` facing the incident side and
/// relative index `eta` = n₁/n₂; `None` on total internal reflection (k < 0).
#[inline]
pub fn refract(i: Vec3, n: Vec3, eta: f32) -> Option<Vec3> {
    let cosi = -n.dot(i);
    let k = 1.0 - eta * eta * (1.0 - cosi * cosi);
    if k < 0.0 {
        None
    } else {
        Some((i * eta + n * (eta * cosi - k.sqrt())).normalize())
    }
}

/// Reflection and refraction rays of every surface whose material asks for them (eqs.
/// 3.3–3.7). Total internal reflection turns the refracted ray into a reflected one with the
/// refraction's weight. Origins are offset to the side the new ray leaves from.
pub fn bounce_rays(s: &Surfaces, materials: &[Material]) -> RayBatch {
    let mut b = RayBatch::default();
    bounce_rays_into(s, materials, &mut b);
    b
}

/// How many rays surface `i` spawns: one per reflective or transparent property of its
/// material (total internal reflection keeps the refraction's ray as a reflection).
#[inline]
fn bounce_count(s: &Surfaces, materials: &[Material], i: usize) -> usize {
    let m = &materials[s.material[i] as usize];
    (m.reflectivity > 0.0) as usize + (m.transparency > 0.0) as usize
}

/// [`bounce_rays`] into `b`'s buffers, in parallel: count → scan → write, surface-major
/// as a serial loop makes them.
pub fn bounce_rays_into(s: &Surfaces, materials: &[Material], b: &mut RayBatch) {
    let (bounds, ranges) = scan_pieces(s.len(), PIECE, |r| {
        r.map(|i| bounce_count(s, materials, i)).sum()
    });
    b.refill(*bounds.last().expect("bounds"), 0, &bounds, |piece, c| {
        for i in ranges[piece].clone() {
            let m = &materials[s.material[i] as usize];
            if m.reflectivity <= 0.0 && m.transparency <= 0.0 {
                continue;
            }
            let inc = s.incident[i];
            let (ngf, nsf) = s.facing_normals(i);
            let p = s.pos[i];
            let (px, depth) = (s.pixel[i], s.depth[i]);
            let mirror = || {
                let mut d = reflect(inc, nsf);
                if d.dot(ngf) <= 0.0 {
                    // The shading normal bent the mirror direction below the surface.
                    d = reflect(inc, ngf);
                }
                Ray::new(offset_point(p, ngf, s.scale[i]), d, 0.0, f32::INFINITY)
            };
            if m.reflectivity > 0.0 {
                let w = s.throughput[i] * m.reflectivity;
                c.put(mirror(), RayKind::Reflection, px, 0, w, depth);
            }
            if m.transparency > 0.0 {
                let entering = s.ng[i].dot(inc) < 0.0;
                let eta = if entering { 1.0 / m.ior } else { m.ior };
                let w = s.throughput[i] * m.transparency;
                match refract(inc, nsf, eta) {
                    Some(mut d) => {
                        if d.dot(ngf) >= 0.0 {
                            d = refract(inc, ngf, eta).unwrap_or(inc);
                        }
                        let r = Ray::new(offset_point(p, -ngf, s.scale[i]), d, 0.0, f32::INFINITY);
                        c.put(r, RayKind::Refraction, px, 0, w, depth);
                    }
                    None => c.put(mirror(), RayKind::Reflection, px, 0, w, depth),
                }
            }
        }
    });
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The lanes make [`shadow_ray`]'s rays bit for bit, in every build, for surfaces near
    /// and far, on a light, and with the normal either way.
    #[test]
    fn shadow_lanes_equal_shadow_ray() {
        let mut rng = geom::Pcg32::new(5, 77);
        let lights: Vec<Light> = (0..5)
            .map(|i| Light {
                position: rng.unit_vector() * [1.0, 10.0, 1e4, 0.0, 3.0][i],
                color: Vec3::ONE,
                intensity: 1.0,
                attenuation: [1.0, 0.0, 0.0],
            })
            .collect();
        let mut s = Surfaces::default();
        for i in 0..203 {
            let pos = match i % 9 {
                0 => lights[i % 5].position,
                1 => Vec3::ZERO,
                _ => rng.unit_vector() * rng.range(0.0, [1.0, 1e3, 1e6][i % 3]),
            };
            s.pixel.push(i as u32);
            s.pos.push(pos);
            s.ng.push(rng.unit_vector());
            s.ns.push(rng.unit_vector());
            s.incident.push(rng.unit_vector());
            s.material.push(0);
            s.throughput.push(Vec3::splat(rng.next_f32()));
            s.depth.push((i % 3) as u8);
            s.scale.push(rng.range(0.0, 10.0));
        }
        let bits = |r: &Ray| {
            [r.org, r.dir]
                .map(|v| v.to_array().map(f32::to_bits))
                .concat()
                .into_iter()
                .chain([r.t_min.to_bits(), r.t_max.to_bits()])
                .collect::<Vec<u32>>()
        };
        for isa in geom::isa::builds_for_tests("shadow-ray lanes") {
            let mut rays = vec![[0f32; 4]; LANES * lights.len()];
            let mut first = 0;
            while first < s.len() {
                let n = (s.len() - first).min(LANES);
                shadow_group(&s, first, n, &lights, &mut rays, isa);
                for k in 0..n {
                    for (l, light) in lights.iter().enumerate() {
                        let [x, y, z, t] = rays[l * LANES + k];
                        let got = Ray::new(light.position, Vec3::new(x, y, z), 0.0, t);
                        let want = shadow_ray(&s, first + k, light);
                        assert_eq!(
                            bits(&got),
                            bits(&want),
                            "{isa:?} surface {} light {l}",
                            first + k
                        );
                    }
                }
                first += n;
            }
        }
        // The batch: surface-major, every column as the loop writes it.
        let b = shadow_rays(&s, &lights);
        assert_eq!(b.len(), s.len() * lights.len());
        for i in 0..s.len() {
            for (l, light) in lights.iter().enumerate() {
                let k = i * lights.len() + l;
                assert_eq!(bits(&b.ray(k)), bits(&shadow_ray(&s, i, light)));
                assert_eq!(
                    (b.pixel[k], b.light[k], b.depth[k]),
                    (i as u32, l as u32, s.depth[i])
                );
                assert_eq!(
                    (b.kind[k], b.throughput[k]),
                    (RayKind::Shadow as u8, s.throughput[i])
                );
            }
        }
    }

    #[test]
    fn snell_and_tir() {
        let n = Vec3::Y;
        let i = Vec3::new(1.0, -1.0, 0.0).normalize();
        let r = reflect(i, n);
        assert!((r - Vec3::new(1.0, 1.0, 0.0).normalize()).length() < 1e-6);
        let t = refract(i, n, 1.0 / 1.5).unwrap();
        let sin_i = (45f32).to_radians().sin();
        let sin_t = t.x / t.length();
        assert!((sin_i / sin_t - 1.5).abs() < 1e-4, "Snell's law");
        assert!(t.y < 0.0);
        // From glass to air at 45° exceeds the critical angle (41.8°).
        assert!(refract(i, n, 1.5).is_none());
        // Index 1 passes straight through.
        assert!((refract(i, n, 1.0).unwrap() - i).length() < 1e-6);
    }
}
