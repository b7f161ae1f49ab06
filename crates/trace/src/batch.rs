//! The ray batch every engine consumes, and per-ray hit records (the thesis's §3.1 rays:
//! shadow, reflection and refraction, plus primary rays when they are traced).

use geom::{Ray, Vec3, NO_HIT};

/// What a ray is for. Stored as `u8` in batches; the ray-space hierarchies hash by kind.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
#[repr(u8)]
pub enum RayKind {
    /// From the camera (traced only when primary visibility is not rasterized).
    Primary = 0,
    /// From a surface towards a light (any hit).
    Shadow = 1,
    /// Mirror reflection (closest hit).
    Reflection = 2,
    /// Refraction through a transparent surface (closest hit).
    Refraction = 3,
}

impl RayKind {
    /// Every kind, in the order of their numbers.
    pub const ALL: [RayKind; 4] = [
        RayKind::Primary,
        RayKind::Shadow,
        RayKind::Reflection,
        RayKind::Refraction,
    ];

    /// The kind numbered `k` (unknown numbers are primary).
    pub fn from_u8(k: u8) -> RayKind {
        match k {
            1 => RayKind::Shadow,
            2 => RayKind::Reflection,
            3 => RayKind::Refraction,
            _ => RayKind::Primary,
        }
    }

    /// The two-letter name of the thesis's tables (PR, SH, RE, RF).
    pub fn short(self) -> &'static str {
        ["PR", "SH", "RE", "RF"][self as usize]
    }

    /// The kind's name in reports (`shadow`, ...).
    pub fn name(self) -> &'static str {
        match self {
            RayKind::Primary => "primary",
            RayKind::Shadow => "shadow",
            RayKind::Reflection => "reflection",
            RayKind::Refraction => "refraction",
        }
    }
}

/// A structure-of-arrays batch of rays. All vectors have the same length.
#[derive(Clone, Debug, Default)]
pub struct RayBatch {
    /// Origins.
    pub org: Vec<Vec3>,
    /// Directions (unit length).
    pub dir: Vec<Vec3>,
    /// Hits at t ≤ t_min are ignored.
    pub t_min: Vec<f32>,
    /// Hits at t ≥ t_max are ignored (a shadow ray ends at its light).
    pub t_max: Vec<f32>,
    /// [`RayKind`] as u8.
    pub kind: Vec<u8>,
    /// Pixel index (y · width + x) the ray contributes to.
    pub pixel: Vec<u32>,
    /// Light index for shadow rays (0 otherwise).
    pub light: Vec<u32>,
    /// Colour weight of the ray's contribution to its pixel.
    pub throughput: Vec<Vec3>,
    /// Whitted recursion depth of the surface that spawned the ray.
    pub depth: Vec<u8>,
    /// Width of the image that `pixel` indexes (pixel = y · width + x), or 0 when the rays
    /// have no screen layout (ray files, random rays). RAH groups rays by screen position.
    pub width: u32,
}

impl RayBatch {
    /// An empty batch with room for `n` rays.
    pub fn with_capacity(n: usize) -> Self {
        RayBatch {
            org: Vec::with_capacity(n),
            dir: Vec::with_capacity(n),
            t_min: Vec::with_capacity(n),
            t_max: Vec::with_capacity(n),
            kind: Vec::with_capacity(n),
            pixel: Vec::with_capacity(n),
            light: Vec::with_capacity(n),
            throughput: Vec::with_capacity(n),
            depth: Vec::with_capacity(n),
            width: 0,
        }
    }

    /// Number of rays.
    pub fn len(&self) -> usize {
        self.org.len()
    }

    /// Append the rays of `other` (made in parts, e.g. on a device that binds a limited
    /// number of rays at once).
    pub fn append(&mut self, mut other: RayBatch) {
        self.org.append(&mut other.org);
        self.dir.append(&mut other.dir);
        self.t_min.append(&mut other.t_min);
        self.t_max.append(&mut other.t_max);
        self.kind.append(&mut other.kind);
        self.pixel.append(&mut other.pixel);
        self.light.append(&mut other.light);
        self.throughput.append(&mut other.throughput);
        self.depth.append(&mut other.depth);
        if self.width == 0 {
            self.width = other.width;
        }
    }

    /// Whether the batch has no rays.
    pub fn is_empty(&self) -> bool {
        self.org.is_empty()
    }

    /// Append one ray with its kind, pixel, light, throughput and depth.
    pub fn push(
        &mut self,
        ray: Ray,
        kind: RayKind,
        pixel: u32,
        light: u32,
        throughput: Vec3,
        depth: u8,
    ) {
        self.org.push(ray.org);
        self.dir.push(ray.dir);
        self.t_min.push(ray.t_min);
        self.t_max.push(ray.t_max);
        self.kind.push(kind as u8);
        self.pixel.push(pixel);
        self.light.push(light);
        self.throughput.push(throughput);
        self.depth.push(depth);
    }

    /// A batch of plain rays (kind, pixel and weights left neutral).
    pub fn from_rays(rays: &[Ray], kind: RayKind) -> Self {
        let mut b = RayBatch::with_capacity(rays.len());
        for (i, r) in rays.iter().enumerate() {
            b.push(*r, kind, i as u32, 0, Vec3::ONE, 0);
        }
        b
    }

    /// Rays `r` as a batch of their own (a part of a batch too large for one call of a
    /// device).
    pub fn slice(&self, r: std::ops::Range<usize>) -> RayBatch {
        RayBatch {
            org: self.org[r.clone()].to_vec(),
            dir: self.dir[r.clone()].to_vec(),
            t_min: self.t_min[r.clone()].to_vec(),
            t_max: self.t_max[r.clone()].to_vec(),
            kind: self.kind[r.clone()].to_vec(),
            pixel: self.pixel[r.clone()].to_vec(),
            light: self.light[r.clone()].to_vec(),
            throughput: self.throughput[r.clone()].to_vec(),
            depth: self.depth[r].to_vec(),
            width: self.width,
        }
    }

    /// Ray `i` as a [`Ray`].
    #[inline]
    pub fn ray(&self, i: usize) -> Ray {
        Ray {
            org: self.org[i],
            dir: self.dir[i],
            t_min: self.t_min[i],
            t_max: self.t_max[i],
        }
    }

    /// Rays per kind, indexed by `RayKind as usize`.
    pub fn count_by_kind(&self) -> [u64; 4] {
        // Four branch-free counts per block (they vectorise), not one counter in memory
        // per ray.
        let mut c = [0u64; 4];
        for block in self.kind.chunks(1 << 16) {
            let mut n = [0u32; 4];
            for &k in block {
                let k = k.min(3);
                n[0] += (k == 0) as u32;
                n[1] += (k == 1) as u32;
                n[2] += (k == 2) as u32;
                n[3] += (k == 3) as u32;
            }
            for (c, n) in c.iter_mut().zip(n) {
                *c += n as u64;
            }
        }
        c
    }

    /// Check the invariants engines rely on: equal lengths, finite origins, finite non-zero
    /// directions, t_min ≤ t_max and no NaN bounds.
    pub fn validate(&self) -> Result<(), BatchError> {
        let n = self.org.len();
        let lens = [
            self.dir.len(),
            self.t_min.len(),
            self.t_max.len(),
            self.kind.len(),
            self.pixel.len(),
            self.light.len(),
            self.throughput.len(),
            self.depth.len(),
        ];
        if lens.iter().any(|&l| l != n) {
            return Err(BatchError::Lengths);
        }
        for i in 0..n {
            let (o, d) = (self.org[i], self.dir[i]);
            if !geom::finite3(o) || !geom::finite3(d) || d == Vec3::ZERO {
                return Err(BatchError::Ray {
                    index: i,
                    org: o,
                    dir: d,
                });
            }
            if self.t_min[i].is_nan() || self.t_max[i].is_nan() || self.t_min[i] > self.t_max[i] {
                return Err(BatchError::Range {
                    index: i,
                    t_min: self.t_min[i],
                    t_max: self.t_max[i],
                });
            }
        }
        Ok(())
    }
}

/// Why a batch breaks the invariants engines rely on ([`RayBatch::validate`]).
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum BatchError {
    /// The arrays are not all as long as the origins.
    #[error("ray batch arrays have different lengths")]
    Lengths,
    /// A ray's origin or direction is not finite, or its direction is zero.
    #[error(
        "ray {index}: origin {org} / direction {dir} must be finite and the direction non-zero"
    )]
    Ray {
        /// The ray's index in the batch.
        index: usize,
        /// Its origin.
        org: Vec3,
        /// Its direction.
        dir: Vec3,
    },
    /// A ray's t range is NaN or empty the wrong way round.
    #[error("ray {index}: bad t range [{t_min}, {t_max}]")]
    Range {
        /// The ray's index in the batch.
        index: usize,
        /// Its t_min.
        t_min: f32,
        /// Its t_max.
        t_max: f32,
    },
}

/// The result for one ray: the triangle hit (or [`NO_HIT`]), its distance and barycentrics
/// (u, v) of vertices 1 and 2.
///
/// Closest-hit queries return the smallest t, ties broken by the smallest triangle id, so that
/// every engine returns bit-identical records. Any-hit queries return some hit in range.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Hit {
    /// Triangle index into the scene's `Geometry` ([`NO_HIT`] for a miss).
    pub tri: u32,
    /// Distance along the ray (∞ for a miss).
    pub t: f32,
    /// Barycentric weight of vertex 1.
    pub u: f32,
    /// Barycentric weight of vertex 2.
    pub v: f32,
}

impl Hit {
    /// The record of a ray that hit nothing.
    pub const MISS: Hit = Hit {
        tri: NO_HIT,
        t: f32::INFINITY,
        u: 0.0,
        v: 0.0,
    };

    /// Whether the ray hit a triangle.
    #[inline]
    pub fn is_hit(&self) -> bool {
        self.tri != NO_HIT
    }

    /// True when (t, tri) is closer than the current record under the tie rule.
    #[inline]
    pub fn closer(&self, t: f32, tri: u32) -> bool {
        t < self.t || (t == self.t && tri < self.tri)
    }
}
