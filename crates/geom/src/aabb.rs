//! Axis-aligned boxes and the ray–box slab test.

use crate::ray::Ray;
use glam::Vec3;

/// An axis-aligned box `[min, max]`. The empty box has `min > max`.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Aabb {
    /// Smallest corner.
    pub min: Vec3,
    /// Largest corner.
    pub max: Vec3,
}

impl Default for Aabb {
    fn default() -> Self {
        Self::EMPTY
    }
}

/// The slab test's far-distance factor, 1 + 2γ₃ (Ize, "Robust BVH Ray Traversal", 2013):
/// see [`Aabb::intersect`]. Public so that the GPU's twin of the test uses the same bits.
pub const SLAB_ROBUST: f32 =
    1.0 + 2.0 * (3.0 * f32::EPSILON * 0.5) / (1.0 - 3.0 * f32::EPSILON * 0.5);

impl Aabb {
    /// The empty box (min = +∞, max = −∞): the identity of [`Aabb::union`] and [`Aabb::grow`].
    pub const EMPTY: Aabb = Aabb {
        min: Vec3::splat(f32::INFINITY),
        max: Vec3::splat(f32::NEG_INFINITY),
    };

    /// The box with corners `min` and `max`.
    pub fn new(min: Vec3, max: Vec3) -> Self {
        Aabb { min, max }
    }

    /// The box of a triangle: [`Aabb::from_points`] of its three vertices (the same
    /// minima and maxima in the same order), inlined: the builders make one per triangle
    /// per frame, and the iterator version was not inlined there.
    #[inline]
    pub fn of_triangle(t: &[Vec3; 3]) -> Self {
        let e = Self::EMPTY;
        Aabb {
            min: e.min.min(t[0]).min(t[1]).min(t[2]),
            max: e.max.max(t[0]).max(t[1]).max(t[2]),
        }
    }

    /// The smallest box containing `pts` ([`Aabb::EMPTY`] for none).
    pub fn from_points(pts: impl IntoIterator<Item = Vec3>) -> Self {
        let mut b = Self::EMPTY;
        for p in pts {
            b.grow(p);
        }
        b
    }

    /// Grow the box to contain `p`.
    #[inline]
    pub fn grow(&mut self, p: Vec3) {
        self.min = self.min.min(p);
        self.max = self.max.max(p);
    }

    /// The smallest box containing both boxes.
    #[inline]
    pub fn union(&self, o: &Aabb) -> Aabb {
        Aabb {
            min: self.min.min(o.min),
            max: self.max.max(o.max),
        }
    }

    /// Whether the box contains no point (some min > max).
    #[inline]
    pub fn is_empty(&self) -> bool {
        self.min.x > self.max.x || self.min.y > self.max.y || self.min.z > self.max.z
    }

    /// max − min (0 for an empty box).
    #[inline]
    pub fn extent(&self) -> Vec3 {
        if self.is_empty() {
            Vec3::ZERO
        } else {
            self.max - self.min
        }
    }

    /// The centre point.
    #[inline]
    pub fn center(&self) -> Vec3 {
        (self.min + self.max) * 0.5
    }

    /// The length of the diagonal (0 for an empty box).
    #[inline]
    pub fn diagonal(&self) -> f32 {
        self.extent().length()
    }

    /// Half the surface area (the SAH cost's area term).
    #[inline]
    pub fn half_area(&self) -> f32 {
        let e = self.extent();
        e.x * e.y + e.y * e.z + e.z * e.x
    }

    /// Whether `p` lies in the closed box.
    #[inline]
    pub fn contains(&self, p: Vec3) -> bool {
        p.cmpge(self.min).all() && p.cmple(self.max).all()
    }

    /// Slab test: the parametric interval of the ray inside the box, clipped to the ray's
    /// `[t_min, t_max]`, or `None` when it is empty.
    ///
    /// `inv_dir` is `1 / dir` (±inf for zero components, with the sign of a ±0.0 component).
    /// The `0 · ∞ = NaN` case (origin on a slab plane of an axis-parallel ray) leaves that axis
    /// unrestricted: boxes are closed. The far distance is enlarged by `1 + 2γ₃` (Ize, "Robust BVH Ray
    /// Traversal", 2013) so that rounding can never turn a hit into a miss.
    #[inline]
    pub fn intersect(
        &self,
        org: Vec3,
        inv_dir: Vec3,
        t_min: f32,
        t_max: f32,
    ) -> Option<(f32, f32)> {
        let (mut tn, mut tf) = (t_min, t_max);
        for k in 0..3 {
            let a = (self.min[k] - org[k]) * inv_dir[k];
            let b = (self.max[k] - org[k]) * inv_dir[k];
            // NaN only from 0 · ∞: the origin lies on this slab's plane and the ray runs
            // parallel to it, so this axis does not restrict the interval. (glam's SIMD
            // min/max do not ignore NaN, hence the scalar form.)
            if a.is_nan() || b.is_nan() {
                continue;
            }
            let (lo, hi) = if a <= b { (a, b) } else { (b, a) };
            tn = tn.max(lo);
            tf = tf.min(hi * SLAB_ROBUST);
        }
        if tn <= tf {
            Some((tn, tf))
        } else {
            None
        }
    }

    /// Convenience form of [`Aabb::intersect`] for a [`Ray`].
    pub fn intersect_ray(&self, r: &Ray) -> Option<(f32, f32)> {
        self.intersect(r.org, r.dir.recip(), r.t_min, r.t_max)
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proptest::prelude::*;

    use testkit::v3;

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(1024))]

        /// If any point of the ray segment lies inside the box, the slab test reports a hit
        /// whose interval contains that point's t.
        #[test]
        fn never_misses_a_contained_point(
            lo in v3(10.0), ext in (0.0f32..5.0, 0.0f32..5.0, 0.0f32..5.0),
            inside in (0.0f32..=1.0, 0.0f32..=1.0, 0.0f32..=1.0),
            dir in v3(1.0), axis_zero in 0usize..4, t_in in 0.0f32..20.0,
        ) {
            let b = Aabb::new(lo, lo + Vec3::new(ext.0, ext.1, ext.2));
            let p = b.min + b.extent() * Vec3::new(inside.0, inside.1, inside.2);
            let mut d = dir;
            if axis_zero < 3 { d[axis_zero] = 0.0; }
            prop_assume!(d.length() > 1e-3);
            let d = d.normalize();
            let o = p - d * t_in;
            let hit = b.intersect(o, d.recip(), 0.0, f32::INFINITY);
            prop_assert!(hit.is_some(), "box {b:?} point {p:?} o {o:?} d {d:?}");
            let (tn, tf) = hit.unwrap();
            let slack = 1e-4 * (1.0 + t_in);
            prop_assert!(tn <= t_in + slack && t_in <= tf + slack);
        }

        /// A ray whose every sampled point is far outside the box (by more than rounding) is a miss.
        #[test]
        fn far_rays_miss(lo in v3(10.0), ext in (0.1f32..5.0, 0.1f32..5.0, 0.1f32..5.0), shift in 0.5f32..5.0, dir in v3(1.0)) {
            let b = Aabb::new(lo, lo + Vec3::new(ext.0, ext.1, ext.2));
            // A ray in the plane x = max.x + shift never enters the box.
            let o = Vec3::new(b.max.x + shift, lo.y, lo.z);
            let mut d = dir;
            d.x = 0.0;
            prop_assume!(d.length() > 1e-3);
            prop_assert!(b.intersect(o, d.normalize().recip(), 0.0, f32::INFINITY).is_none());
        }
    }

    #[test]
    fn origin_on_slab_plane_with_zero_direction() {
        let b = Aabb::new(Vec3::ZERO, Vec3::ONE);
        // o.x == min.x and d.x == 0: (0 - 0) * inf = NaN must not poison the result.
        let r = Ray::new(Vec3::new(0.0, 0.5, -1.0), Vec3::Z, 0.0, f32::INFINITY);
        let (tn, tf) = b.intersect_ray(&r).unwrap();
        assert!((tn - 1.0).abs() < 1e-6 && (tf - 2.0).abs() < 1e-5);
        // -0.0 direction component.
        let r = Ray::new(
            Vec3::new(0.5, 0.5, -1.0),
            Vec3::new(-0.0, 0.0, 1.0),
            0.0,
            f32::INFINITY,
        );
        assert!(b.intersect_ray(&r).is_some());
        assert!(b
            .intersect_ray(&Ray::new(Vec3::new(0.5, 0.5, 1.5), Vec3::Z, 0.0, 1.0))
            .is_none());
    }

    #[test]
    fn a_triangles_box_is_its_points_box() {
        let mut rng = crate::rng::Pcg32::new(7, 1);
        let mut f = || (rng.next_f32() - 0.5) * 100.0;
        for _ in 0..1000 {
            let t = [0; 3].map(|_| Vec3::new(f(), f(), f()));
            let a = Aabb::of_triangle(&t);
            let b = Aabb::from_points(t);
            assert_eq!(
                a.min.to_array().map(f32::to_bits),
                b.min.to_array().map(f32::to_bits)
            );
            assert_eq!(
                a.max.to_array().map(f32::to_bits),
                b.max.to_array().map(f32::to_bits)
            );
        }
        let odd = [Vec3::new(-0.0, 0.0, f32::NAN), Vec3::ZERO, Vec3::INFINITY];
        assert_eq!(
            format!("{:?}", Aabb::of_triangle(&odd)),
            format!("{:?}", Aabb::from_points(odd))
        );
    }

    #[test]
    fn area_and_empty() {
        let b = Aabb::new(Vec3::ZERO, Vec3::new(1.0, 2.0, 3.0));
        assert_eq!(b.half_area(), 2.0 + 6.0 + 3.0);
        assert!(Aabb::EMPTY.is_empty());
        assert_eq!(Aabb::EMPTY.extent(), Vec3::ZERO);
        assert!(b.contains(Vec3::new(1.0, 0.0, 3.0)));
    }
}

/// Every triangle's box ([`Aabb::of_triangle`], in parallel) and their union, the scene's
/// box (min and max make it exactly, whatever the order of the reduction): where the
/// builders (the object tree, the grid) start each frame.
pub fn triangle_boxes(tris: &[[Vec3; 3]]) -> (Vec<Aabb>, Aabb) {
    use rayon::prelude::*;
    let boxes: Vec<Aabb> = tris
        .par_iter()
        .with_min_len(4096)
        .map(Aabb::of_triangle)
        .collect();
    let all = boxes
        .par_iter()
        .with_min_len(4096)
        .copied()
        .reduce(Aabb::default, |a, b| a.union(&b));
    (boxes, all)
}

/// Exact triangle–box overlap by the separating axis theorem (Akenine-Möller 2001): the box
/// axes, the triangle normal and the 9 edge cross products. Touching counts as overlapping.
pub fn tri_overlaps_box(b: &Aabb, t: &[Vec3; 3]) -> bool {
    let c = b.center();
    let h = (b.max - b.min) * 0.5;
    let v = [t[0] - c, t[1] - c, t[2] - c];
    // Box axes.
    for k in 0..3 {
        let lo = v[0][k].min(v[1][k]).min(v[2][k]);
        let hi = v[0][k].max(v[1][k]).max(v[2][k]);
        if lo > h[k] || hi < -h[k] {
            return false;
        }
    }
    let e = [v[1] - v[0], v[2] - v[1], v[0] - v[2]];
    // Triangle normal.
    let n = e[0].cross(e[1]);
    let r = h.x * n.x.abs() + h.y * n.y.abs() + h.z * n.z.abs();
    let s = n.dot(v[0]);
    if s > r || s < -r {
        return false;
    }
    // Edge × box-axis cross products.
    let axes = [Vec3::X, Vec3::Y, Vec3::Z];
    for ed in &e {
        for ax in &axes {
            let a = ax.cross(*ed);
            if a == Vec3::ZERO {
                continue;
            }
            let p = [a.dot(v[0]), a.dot(v[1]), a.dot(v[2])];
            let r = h.x * a.x.abs() + h.y * a.y.abs() + h.z * a.z.abs();
            let lo = p[0].min(p[1]).min(p[2]);
            let hi = p[0].max(p[1]).max(p[2]);
            if lo > r || hi < -r {
                return false;
            }
        }
    }
    true
}

/// `a · v` for axis `i` of [`TriBoxSat`], skipping the products by components that are zero
/// by construction: the box axes are unit vectors and box axis k × an edge has a zero k
/// component (glam's cross gives exactly ±0 there, and 1·x = x). A skipped product only
/// adds ±0 to the sum, so the result equals the full dot product's in value (at most the sign
/// of a zero differs, which no comparison sees).
#[inline(always)]
fn project(i: usize, a: Vec3, v: Vec3) -> f32 {
    match i {
        0 => v.x,
        1 => v.y,
        2 => v.z,
        3 => a.dot(v),
        _ => match (i - 4) % 3 {
            0 => (a.y * v.y) + (a.z * v.z),
            1 => (a.x * v.x) + (a.z * v.z),
            _ => (a.x * v.x) + (a.y * v.y),
        },
    }
}

/// The separating-axis test of [`tri_overlaps_box`] prepared once per triangle, for testing
/// one triangle against many boxes of one size (grid cells, the 8 children of an octree
/// node): the 13 axes and the triangle's projection interval on each are computed once, and
/// a box then costs one dot product and two comparisons per axis.
///
/// Projections are taken in absolute coordinates rather than relative to the box centre, so
/// an answer may differ from [`tri_overlaps_box`] for a triangle within rounding of the
/// coordinates' magnitude (a few ulps) of the box; callers that need a conservative answer pad
/// their boxes far above that (the irregular grid's reference padding is 1e-5 of the scene's
/// magnitude, ~80 ulps). A zero axis (parallel edge) projects everything to 0 and never
/// separates, as the skipped axis in [`tri_overlaps_box`].
#[derive(Clone, Copy, Debug)]
pub struct TriBoxSat {
    axis: [Vec3; 13],
    lo: [f32; 13],
    hi: [f32; 13],
}

impl TriBoxSat {
    /// The 13 axes of triangle `t` and its extent along each (once per triangle).
    pub fn new(t: &[Vec3; 3]) -> Self {
        let e = [t[1] - t[0], t[2] - t[1], t[0] - t[2]];
        let mut axis = [Vec3::ZERO; 13];
        axis[0] = Vec3::X;
        axis[1] = Vec3::Y;
        axis[2] = Vec3::Z;
        axis[3] = e[0].cross(e[1]);
        for (i, ed) in e.iter().enumerate() {
            for (k, ax) in [Vec3::X, Vec3::Y, Vec3::Z].iter().enumerate() {
                axis[4 + 3 * i + k] = ax.cross(*ed);
            }
        }
        let (mut lo, mut hi) = ([0f32; 13], [0f32; 13]);
        for (i, a) in axis.iter().enumerate() {
            // Three calls, not `t.map`: the array map of a 13-step loop is not inlined (a
            // tenth of the grid's octree pass went to its iterator adapters).
            let p = [
                project(i, *a, t[0]),
                project(i, *a, t[1]),
                project(i, *a, t[2]),
            ];
            lo[i] = p[0].min(p[1]).min(p[2]);
            hi[i] = p[0].max(p[1]).max(p[2]);
        }
        TriBoxSat { axis, lo, hi }
    }

    /// A box's projected radius on each axis, for half-extent `h` (the same for every box of
    /// that size).
    #[inline]
    pub fn radii(&self, h: Vec3) -> [f32; 13] {
        let mut r = [0f32; 13];
        for (r, a) in r.iter_mut().zip(&self.axis) {
            *r = h.x * a.x.abs() + h.y * a.y.abs() + h.z * a.z.abs();
        }
        r
    }

    /// Does the triangle overlap the box of centre `c` whose radii are `r` (from
    /// [`TriBoxSat::radii`])? Touching counts.
    #[inline]
    pub fn overlaps(&self, c: Vec3, r: &[f32; 13]) -> bool {
        self.axis
            .iter()
            .zip(self.lo.iter().zip(&self.hi))
            .zip(r)
            .enumerate()
            .all(|(i, ((a, (&lo, &hi)), &r))| {
                let p = project(i, *a, c);
                !(lo > p + r || hi < p - r)
            })
    }

    /// [`TriBoxSat::overlaps`] for 8 boxes of one size at once (an octree node's children):
    /// bit k is set when the box of centre `(c[0][k], c[1][k], c[2][k])` overlaps. Each lane
    /// performs exactly the arithmetic of `overlaps` (the same products and sums of
    /// `project`, in the same order, no fused multiply–add), so the mask equals 8 calls bit
    /// for bit; the 13 axes
    /// are run for all lanes instead of stopping at the first separating one, which the
    /// lanes repay. Compiled for AVX where the CPU has it (runtime detection), else for the
    /// baseline's 4-wide SSE.
    #[inline]
    pub fn overlaps8(&self, c: &[[f32; 8]; 3], r: &[f32; 13]) -> u8 {
        #[cfg(target_arch = "x86_64")]
        {
            if std::arch::is_x86_feature_detected!("avx") {
                // SAFETY: the CPU has AVX.
                return unsafe { self.overlaps8_avx(c, r) };
            }
        }
        self.overlaps8_lanes(c, r)
    }

    /// [`TriBoxSat::overlaps8_lanes`] in AVX intrinsics: the same products and sums per lane
    /// (no fused multiply–add), the separations kept as float compare masks and ORed in
    /// 256-bit registers (AVX has no 256-bit integer operations, so the lanes' `u32` flags
    /// would compile to 128-bit halves), and the answer read with one movemask.
    #[cfg(target_arch = "x86_64")]
    #[target_feature(enable = "avx")]
    unsafe fn overlaps8_avx(&self, c: &[[f32; 8]; 3], r: &[f32; 13]) -> u8 {
        use std::arch::x86_64::*;
        let (lo, hi) = (&self.lo, &self.hi);
        let x = _mm256_loadu_ps(c[0].as_ptr());
        let y = _mm256_loadu_ps(c[1].as_ptr());
        let z = _mm256_loadu_ps(c[2].as_ptr());
        let s = |v: f32| _mm256_set1_ps(v);
        let mut sep = _mm256_setzero_ps();
        // Separated along axis i: lo > p + r or hi < p − r (ordered compares: a NaN never
        // separates, as in the scalar test).
        macro_rules! test {
            ($i:expr, $p:expr) => {{
                let p = $p;
                let ra = s(r[$i]);
                let above = _mm256_cmp_ps::<_CMP_GT_OQ>(s(lo[$i]), _mm256_add_ps(p, ra));
                let below = _mm256_cmp_ps::<_CMP_LT_OQ>(s(hi[$i]), _mm256_sub_ps(p, ra));
                sep = _mm256_or_ps(sep, _mm256_or_ps(above, below));
            }};
        }
        test!(0, x);
        test!(1, y);
        test!(2, z);
        let n = self.axis[3];
        test!(
            3,
            _mm256_add_ps(
                _mm256_add_ps(_mm256_mul_ps(s(n.x), x), _mm256_mul_ps(s(n.y), y)),
                _mm256_mul_ps(s(n.z), z)
            )
        );
        for e in 0..3 {
            let i = 4 + 3 * e;
            let [a, b, d] = [self.axis[i], self.axis[i + 1], self.axis[i + 2]];
            test!(
                i,
                _mm256_add_ps(_mm256_mul_ps(s(a.y), y), _mm256_mul_ps(s(a.z), z))
            );
            test!(
                i + 1,
                _mm256_add_ps(_mm256_mul_ps(s(b.x), x), _mm256_mul_ps(s(b.z), z))
            );
            test!(
                i + 2,
                _mm256_add_ps(_mm256_mul_ps(s(d.x), x), _mm256_mul_ps(s(d.y), y))
            );
        }
        !(_mm256_movemask_ps(sep) as u8)
    }

    #[inline(always)]
    fn overlaps8_lanes(&self, c: &[[f32; 8]; 3], r: &[f32; 13]) -> u8 {
        // `project`'s three shapes, each lane-wise: a box axis reads one coordinate, the
        // normal takes the full dot product, an edge axis drops its zero component.
        #[inline(always)]
        fn test(out: &mut [u32; 8], lo: f32, hi: f32, ra: f32, p: impl Fn(usize) -> f32) {
            for (k, o) in out.iter_mut().enumerate() {
                let p = p(k);
                *o |= (lo > p + ra || hi < p - ra) as u32;
            }
        }
        let mut out = [0u32; 8];
        let (lo, hi) = (&self.lo, &self.hi);
        for (k, ck) in c.iter().enumerate() {
            test(&mut out, lo[k], hi[k], r[k], |l| ck[l]);
        }
        let n = self.axis[3];
        test(&mut out, lo[3], hi[3], r[3], |l| {
            (n.x * c[0][l]) + (n.y * c[1][l]) + (n.z * c[2][l])
        });
        for e in 0..3 {
            let i = 4 + 3 * e;
            let [a, b, d] = [self.axis[i], self.axis[i + 1], self.axis[i + 2]];
            test(&mut out, lo[i], hi[i], r[i], |l| {
                (a.y * c[1][l]) + (a.z * c[2][l])
            });
            test(&mut out, lo[i + 1], hi[i + 1], r[i + 1], |l| {
                (b.x * c[0][l]) + (b.z * c[2][l])
            });
            test(&mut out, lo[i + 2], hi[i + 2], r[i + 2], |l| {
                (d.x * c[0][l]) + (d.y * c[1][l])
            });
        }
        out.iter()
            .enumerate()
            .fold(0u8, |m, (k, &o)| m | ((o == 0) as u8) << k)
    }
}

#[cfg(test)]
mod overlap_tests {
    use super::*;
    use crate::rng::Pcg32;
    use proptest::prelude::*;

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(2000))]

        /// Sampled points of the triangle inside the box imply overlap; a triangle separated
        /// from the box by a clear margin along some axis does not overlap.
        #[test]
        fn matches_sampling(seed in 0u64..1_000_000) {
            let mut rng = Pcg32::new(seed, 21);
            let lo = Vec3::new(rng.range(-2.0, 2.0), rng.range(-2.0, 2.0), rng.range(-2.0, 2.0));
            let b = Aabb::new(lo, lo + Vec3::new(rng.range(0.1, 2.0), rng.range(0.1, 2.0), rng.range(0.1, 2.0)));
            let t = [0, 1, 2].map(|_| Vec3::new(rng.range(-4.0, 4.0), rng.range(-4.0, 4.0), rng.range(-4.0, 4.0)));
            let overlaps = tri_overlaps_box(&b, &t);
            let mut inside = false;
            for _ in 0..4000 {
                let (mut u, mut v) = (rng.next_f32(), rng.next_f32());
                if u + v > 1.0 { u = 1.0 - u; v = 1.0 - v; }
                let p = t[0] * (1.0 - u - v) + t[1] * u + t[2] * v;
                if b.contains(p) { inside = true; break; }
            }
            if inside { prop_assert!(overlaps); }
            // Shrink-test: if the box grown by 0.05 does not overlap, the box does not either.
            let grown = Aabb::new(b.min - Vec3::splat(0.05), b.max + Vec3::splat(0.05));
            if !tri_overlaps_box(&grown, &t) { prop_assert!(!overlaps); }
        }
    }

    proptest! {
        #![proptest_config(ProptestConfig::with_cases(4000))]

        /// The prepared test agrees with [`tri_overlaps_box`] up to rounding: whatever the
        /// exact test finds overlapping, the prepared one finds overlapping a box grown by
        /// 1e-5 of the magnitude (the grid's padding), and vice versa.
        #[test]
        fn prepared_sat_matches(seed in 0u64..1_000_000, scale in prop::sample::select(vec![1.0f32, 100.0, 1e4])) {
            let mut rng = Pcg32::new(seed, 77);
            let off = Vec3::new(rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), rng.range(-1.0, 1.0)) * scale;
            let lo = off + Vec3::new(rng.range(-2.0, 2.0), rng.range(-2.0, 2.0), rng.range(-2.0, 2.0));
            let b = Aabb::new(lo, lo + Vec3::new(rng.range(0.01, 2.0), rng.range(0.01, 2.0), rng.range(0.01, 2.0)));
            let t = [0, 1, 2].map(|_| off + Vec3::new(rng.range(-3.0, 3.0), rng.range(-3.0, 3.0), rng.range(-3.0, 3.0)));
            let pad = 1e-5 * (scale + 4.0);
            let grown = Aabb::new(b.min - Vec3::splat(pad), b.max + Vec3::splat(pad));
            let sat = TriBoxSat::new(&t);
            let prepared = |bx: &Aabb| sat.overlaps(bx.center(), &sat.radii((bx.max - bx.min) * 0.5));
            if tri_overlaps_box(&b, &t) { prop_assert!(prepared(&grown)); }
            if prepared(&b) { prop_assert!(tri_overlaps_box(&grown, &t)); }
        }

        /// The 8-lane test equals 8 single tests bit for bit, for the 8 children of a box the
        /// triangle crosses (many of them touching it within rounding) and for any lanes.
        #[test]
        fn eight_lanes_equal_eight_calls(seed in 0u64..1_000_000, scale in prop::sample::select(vec![1.0f32, 100.0, 1e4])) {
            let mut rng = Pcg32::new(seed, 78);
            let off = Vec3::new(rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), rng.range(-1.0, 1.0)) * scale;
            let t = [0, 1, 2].map(|_| off + Vec3::new(rng.range(-1.0, 1.0), rng.range(-1.0, 1.0), rng.range(-1.0, 1.0)));
            // Parent box around the triangle's centroid; children at 2c + (k&1, k>>1&1, k>>2).
            let h = Vec3::new(rng.range(0.01, 1.0), rng.range(0.01, 1.0), rng.range(0.01, 1.0));
            let centre = (t[0] + t[1] + t[2]) / 3.0;
            let sat = TriBoxSat::new(&t);
            let r = sat.radii(h * 0.5 + Vec3::splat(1e-5 * scale));
            let child = |k: usize| {
                let o = Vec3::new((k & 1) as f32, ((k >> 1) & 1) as f32, (k >> 2) as f32) - Vec3::splat(0.5);
                centre + o * h
            };
            let c: [[f32; 8]; 3] = std::array::from_fn(|a| std::array::from_fn(|k| child(k)[a]));
            let single = (0..8).fold(0u8, |m, k| {
                m | (sat.overlaps(Vec3::new(c[0][k], c[1][k], c[2][k]), &r) as u8) << k
            });
            prop_assert_eq!(sat.overlaps8(&c, &r), single);
            prop_assert_eq!(sat.overlaps8_lanes(&c, &r), single);
        }
    }

    #[test]
    fn simple_cases() {
        let b = Aabb::new(Vec3::ZERO, Vec3::ONE);
        // A large triangle slicing through the box with all vertices outside.
        assert!(tri_overlaps_box(
            &b,
            &[
                Vec3::new(-5.0, 0.5, -5.0),
                Vec3::new(5.0, 0.5, -5.0),
                Vec3::new(0.0, 0.5, 10.0)
            ]
        ));
        // Same plane, moved above the box.
        assert!(!tri_overlaps_box(
            &b,
            &[
                Vec3::new(-5.0, 1.5, -5.0),
                Vec3::new(5.0, 1.5, -5.0),
                Vec3::new(0.0, 1.5, 10.0)
            ]
        ));
        // Near the corner but separated along the (1,1,1) diagonal plane.
        assert!(!tri_overlaps_box(
            &b,
            &[
                Vec3::new(2.0, 0.9, 0.9),
                Vec3::new(0.9, 2.0, 0.9),
                Vec3::new(0.9, 0.9, 2.0)
            ]
        ));
        // Touching a face counts.
        assert!(tri_overlaps_box(
            &b,
            &[
                Vec3::new(1.0, 0.2, 0.2),
                Vec3::new(2.0, 0.2, 0.2),
                Vec3::new(1.5, 0.8, 0.2)
            ]
        ));
    }
}
