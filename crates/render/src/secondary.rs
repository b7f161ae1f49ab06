//! Surfaces to shade and the secondary rays they spawn (thesis §3.2.3, eqs. 3.1–3.7).
//!
//! A [`Surfaces`] batch is the same thing whether it came from the G-buffer (after
//! rasterization) or from the closest hits of a reflection/refraction batch, so one set of
//! kernels serves every Whitted generation.

use crate::raster::GBuffer;
use geom::ray::offset_point;
use geom::{Ray, Vec3, NO_HIT};
use rayon::prelude::*;
use scene::{Geometry, Light, Material};
use trace::batch::{Hit, RayBatch, RayKind};

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
        for (p, &t) in gb.tri.iter().enumerate() {
            if t == NO_HIT {
                continue;
            }
            let pos = gb.position[p];
            s.pixel.push(p as u32);
            s.pos.push(pos);
            s.ng.push(geo.geometric_normal(t));
            s.ns.push(gb.normal[p]);
            s.incident.push((pos - eye).normalize_or(Vec3::Z));
            s.material.push(geo.material[t as usize]);
            s.throughput.push(Vec3::ONE);
            s.depth.push(0);
            s.scale.push(tri_scale(geo, t));
        }
        s
    }

    /// The closest hits of a batch, in ray order (misses are skipped).
    pub fn from_hits(rays: &RayBatch, hits: &[Hit], geo: &Geometry) -> Surfaces {
        let mut s = Surfaces::default();
        for (i, h) in hits.iter().enumerate() {
            if !h.is_hit() {
                continue;
            }
            s.pixel.push(rays.pixel[i]);
            s.pos.push(geo.point(h.tri, h.u, h.v));
            s.ng.push(geo.geometric_normal(h.tri));
            s.ns.push(geo.shading_normal(h.tri, h.u, h.v));
            s.incident.push(rays.dir[i]);
            s.material.push(geo.material[h.tri as usize]);
            s.throughput.push(rays.throughput[i]);
            s.depth.push(rays.depth[i].saturating_add(1));
            s.scale.push(tri_scale(geo, h.tri));
        }
        s
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
    let n = s.len() * lights.len();
    let rays: Vec<(Ray, u32, u32)> = (0..n)
        .into_par_iter()
        .map(|k| {
            let (i, l) = (k / lights.len(), k % lights.len());
            let lp = lights[l].position;
            let p = s.pos[i];
            let ng = if s.ng[i].dot(lp - p) >= 0.0 {
                s.ng[i]
            } else {
                -s.ng[i]
            };
            let end = offset_point(p, ng, s.scale[i].max(lp.abs().max_element()));
            let d = end - lp;
            let dist = d.length();
            let ray = if dist > 0.0 && dist.is_finite() {
                Ray::new(lp, d / dist, 0.0, dist)
            } else {
                Ray::new(lp, Vec3::Z, 0.0, 0.0)
            };
            (ray, s.pixel[i], l as u32)
        })
        .collect();
    let mut b = RayBatch::with_capacity(n);
    for (k, (r, px, l)) in rays.into_iter().enumerate() {
        let i = k / lights.len();
        b.push(r, RayKind::Shadow, px, l, s.throughput[i], s.depth[i]);
    }
    b
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
    let per: Vec<Vec<(Ray, RayKind, Vec3)>> = (0..s.len())
        .into_par_iter()
        .map(|i| {
            let m = &materials[s.material[i] as usize];
            let mut out = Vec::new();
            let inc = s.incident[i];
            let (ngf, nsf) = s.facing_normals(i);
            let p = s.pos[i];
            let mirror = || {
                let mut d = reflect(inc, nsf);
                if d.dot(ngf) <= 0.0 {
                    // The shading normal bent the mirror direction below the surface.
                    d = reflect(inc, ngf);
                }
                Ray::new(offset_point(p, ngf, s.scale[i]), d, 0.0, f32::INFINITY)
            };
            if m.reflectivity > 0.0 {
                out.push((
                    mirror(),
                    RayKind::Reflection,
                    s.throughput[i] * m.reflectivity,
                ));
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
                        out.push((
                            Ray::new(offset_point(p, -ngf, s.scale[i]), d, 0.0, f32::INFINITY),
                            RayKind::Refraction,
                            w,
                        ));
                    }
                    None => out.push((mirror(), RayKind::Reflection, w)),
                }
            }
            out
        })
        .collect();
    let mut b = RayBatch::with_capacity(per.iter().map(|v| v.len()).sum());
    for (i, rays) in per.into_iter().enumerate() {
        for (r, k, w) in rays {
            b.push(r, k, s.pixel[i], 0, w, s.depth[i]);
        }
    }
    b
}

#[cfg(test)]
mod tests {
    use super::*;

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
