//! The dual traversal's node test ([`crate::dual`]) in AVX lanes, both ways round:
//! - eight ray nodes against one object node (`test8`): the pairs a ray-side expansion
//!   makes (a node's children, contiguous in their level, against the object the node met);
//! - one ray node against eight object nodes (`test8_objects`): the pairs an object-side
//!   expansion makes (the children of a collapsed node, [`accel::bvh::objects::WideNode`]).
//!
//! The test is the scalar one, lane by lane, with the same IEEE operations in the same order
//! and no fused multiply-add, so every lane's answer equals the scalar test's bit for bit
//! (and so do the traversal's counts):
//! - RAH's node test (thesis eq. 3.16, Roger et al. 2007 §4.2) of the node's cone against the
//!   object's bounding sphere ([`geom::cone::rah_test`]); wide cones pass;
//! - the beam test of the node's rays against the object's box (interval slab arithmetic,
//!   `RayNode::beam_test` in [`crate::dual`]).
//!
//! The exact cone test ([`crate::NodeTest::Exact`]) and CPUs without AVX take the scalar path.

use accel::bvh::objects::WideNode;
use geom::{Aabb, Vec3};

/// One ray level's node records as lanes (structure of arrays, padded by 8 so a window of 8
/// lanes starting at any node is in bounds).
pub(crate) struct NodeLanes {
    /// Origin sphere centre (x, y, z) and radius.
    pub c: [Vec<f32>; 3],
    pub radius: Vec<f32>,
    /// Cone axis (x, y, z), sin α, cos α; `wide` is all ones where the cone always passes.
    pub axis: [Vec<f32>; 3],
    pub sin: Vec<f32>,
    pub cos: Vec<f32>,
    pub wide: Vec<f32>,
    /// Longest ray (a distance: the cone test), smallest t_min and largest t_max (the rays'
    /// parameter: the beam test).
    pub max_t: Vec<f32>,
    pub tmin: Vec<f32>,
    pub tmax: Vec<f32>,
    /// The beam: origins' box and reciprocal directions' box, per axis.
    pub omin: [Vec<f32>; 3],
    pub omax: [Vec<f32>; 3],
    pub ilo: [Vec<f32>; 3],
    pub ihi: [Vec<f32>; 3],
}

/// What one node contributes to its lane (the fields of `dual::RayNode` the test reads).
pub(crate) struct NodeFields {
    pub center: Vec3,
    pub radius: f32,
    pub axis: Vec3,
    pub sin: f32,
    pub cos: f32,
    pub wide: bool,
    pub max_t: f32,
    pub tmin: f32,
    pub tmax: f32,
    pub omin: Vec3,
    pub omax: Vec3,
    pub ilo: Vec3,
    pub ihi: Vec3,
}

impl NodeLanes {
    /// The lanes of `n` nodes, node i's fields from `f(i)`.
    pub fn new(n: usize, f: impl Fn(usize) -> NodeFields + Sync) -> NodeLanes {
        use rayon::prelude::*;
        let z = || vec![0.0f32; n + 8];
        let z3 = || [z(), z(), z()];
        let mut l = NodeLanes {
            c: z3(),
            radius: z(),
            axis: z3(),
            sin: z(),
            cos: z(),
            wide: z(),
            max_t: z(),
            tmin: z(),
            tmax: z(),
            omin: z3(),
            omax: z3(),
            ilo: z3(),
            ihi: z3(),
        };
        // Every node's 25 lanes written in parallel (level 1 has a node per `b` rays of the
        // batch, and this runs on every trace), each task its own nodes.
        {
            let [c0, c1, c2] = &mut l.c;
            let [a0, a1, a2] = &mut l.axis;
            let [n0, n1, n2] = &mut l.omin;
            let [x0, x1, x2] = &mut l.omax;
            let [i0, i1, i2] = &mut l.ilo;
            let [h0, h1, h2] = &mut l.ihi;
            let out: [par::SharedMut<f32>; 25] = [
                c0,
                c1,
                c2,
                &mut l.radius,
                a0,
                a1,
                a2,
                &mut l.sin,
                &mut l.cos,
                &mut l.wide,
                &mut l.max_t,
                &mut l.tmin,
                &mut l.tmax,
                n0,
                n1,
                n2,
                x0,
                x1,
                x2,
                i0,
                i1,
                i2,
                h0,
                h1,
                h2,
            ]
            .map(|v| par::SharedMut(v.as_mut_ptr()));
            (0..n).into_par_iter().with_min_len(1024).for_each(|i| {
                let x = f(i);
                let wide = if x.wide { f32::from_bits(!0) } else { 0.0 };
                // In the order of `out`.
                let v = [
                    x.center.x, x.center.y, x.center.z, x.radius, x.axis.x, x.axis.y, x.axis.z,
                    x.sin, x.cos, wide, x.max_t, x.tmin, x.tmax, x.omin.x, x.omin.y, x.omin.z,
                    x.omax.x, x.omax.y, x.omax.z, x.ilo.x, x.ilo.y, x.ilo.z, x.ihi.x, x.ihi.y,
                    x.ihi.z,
                ];
                for (o, v) in out.iter().zip(v) {
                    // SAFETY: lane i < n of each array (n + 8 long) is written by this task
                    // only; the arrays outlive the pass.
                    unsafe { o.write(i, v) };
                }
            });
        }
        l
    }
}

/// Whether this CPU runs [`test8`].
pub(crate) fn available() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::arch::is_x86_feature_detected!("avx")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// Lanes `first .. first + 8` against the object of sphere `(p, d)` and box `b`: bit i set
/// when node `first + i` passes both the RAH cone test and the beam test. Lanes past the
/// level's nodes read padding; the caller masks them. Needs [`available`].
#[inline]
pub(crate) fn test8(l: &NodeLanes, first: usize, p: Vec3, d: f32, b: &Aabb) -> u8 {
    assert!(first + 8 <= l.radius.len(), "a window of lanes");
    #[cfg(target_arch = "x86_64")]
    {
        debug_assert!(available());
        // SAFETY: AVX is present (the caller checked `available`); the window is in bounds.
        unsafe { avx::test8(l, first, p, d, b) }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let _ = (l, first, p, d, b);
        unreachable!("test8 without AVX")
    }
}

/// One ray node against the 8 children of a collapsed object node
/// ([`accel::bvh::objects::WideNode`]): bit i set when child i passes both tests, the same tests as
/// [`test8`] with the roles of the lanes swapped (the node broadcast, the objects in lanes).
/// Lanes past the node's `count` are masked off. Needs [`available`].
#[inline]
pub(crate) fn test8_objects(n: &NodeFields, w: &WideNode) -> u8 {
    #[cfg(target_arch = "x86_64")]
    {
        debug_assert!(available());
        // SAFETY: AVX is present (the caller checked `available`).
        unsafe { avx::test8_objects(n, w) & ((1u32 << w.count) - 1) as u8 }
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        let _ = (n, w);
        unreachable!("test8_objects without AVX")
    }
}

#[cfg(target_arch = "x86_64")]
mod avx {
    use super::{NodeFields, NodeLanes};
    use accel::bvh::objects::WideNode;
    use geom::{Aabb, Vec3};
    use std::arch::x86_64::*;

    #[inline]
    #[target_feature(enable = "avx")]
    unsafe fn ld(v: &[f32], at: usize) -> __m256 {
        _mm256_loadu_ps(v.as_ptr().add(at))
    }

    /// A ray node's fields as lanes (one node per lane, or one node broadcast).
    struct Node {
        c: [__m256; 3],
        r: __m256,
        axis: [__m256; 3],
        sin: __m256,
        cos: __m256,
        wide: __m256,
        max_t: __m256,
        tmin: __m256,
        tmax: __m256,
        omin: [__m256; 3],
        omax: [__m256; 3],
        ilo: [__m256; 3],
        ihi: [__m256; 3],
    }

    /// An object's sphere and box as lanes.
    struct Object {
        p: [__m256; 3],
        d: __m256,
        bmin: [__m256; 3],
        bmax: [__m256; 3],
    }

    #[target_feature(enable = "avx")]
    pub(super) unsafe fn test8(l: &NodeLanes, at: usize, p: Vec3, d: f32, b: &Aabb) -> u8 {
        let n = Node {
            c: [ld(&l.c[0], at), ld(&l.c[1], at), ld(&l.c[2], at)],
            r: ld(&l.radius, at),
            axis: [ld(&l.axis[0], at), ld(&l.axis[1], at), ld(&l.axis[2], at)],
            sin: ld(&l.sin, at),
            cos: ld(&l.cos, at),
            wide: ld(&l.wide, at),
            max_t: ld(&l.max_t, at),
            tmin: ld(&l.tmin, at),
            tmax: ld(&l.tmax, at),
            omin: [ld(&l.omin[0], at), ld(&l.omin[1], at), ld(&l.omin[2], at)],
            omax: [ld(&l.omax[0], at), ld(&l.omax[1], at), ld(&l.omax[2], at)],
            ilo: [ld(&l.ilo[0], at), ld(&l.ilo[1], at), ld(&l.ilo[2], at)],
            ihi: [ld(&l.ihi[0], at), ld(&l.ihi[1], at), ld(&l.ihi[2], at)],
        };
        let s = _mm256_set1_ps;
        let o = Object {
            p: [s(p.x), s(p.y), s(p.z)],
            d: s(d),
            bmin: [s(b.min.x), s(b.min.y), s(b.min.z)],
            bmax: [s(b.max.x), s(b.max.y), s(b.max.z)],
        };
        test(&n, &o)
    }

    #[target_feature(enable = "avx")]
    pub(super) unsafe fn test8_objects(x: &NodeFields, w: &WideNode) -> u8 {
        let s = _mm256_set1_ps;
        let s3 = |v: Vec3| [s(v.x), s(v.y), s(v.z)];
        let n = Node {
            c: s3(x.center),
            r: s(x.radius),
            axis: s3(x.axis),
            sin: s(x.sin),
            cos: s(x.cos),
            wide: s(if x.wide { f32::from_bits(!0) } else { 0.0 }),
            max_t: s(x.max_t),
            tmin: s(x.tmin),
            tmax: s(x.tmax),
            omin: s3(x.omin),
            omax: s3(x.omax),
            ilo: s3(x.ilo),
            ihi: s3(x.ihi),
        };
        // The node is 32-byte aligned and every lane array is 32 bytes.
        let l = |v: &[f32; 8]| _mm256_load_ps(v.as_ptr());
        let o = Object {
            p: [l(&w.center[0]), l(&w.center[1]), l(&w.center[2])],
            d: l(&w.radius),
            bmin: [l(&w.min[0]), l(&w.min[1]), l(&w.min[2])],
            bmax: [l(&w.max[0]), l(&w.max[1]), l(&w.max[2])],
        };
        test(&n, &o)
    }

    /// The beam test and RAH's cone test, lane by lane, with the scalar tests' operations
    /// in their order.
    #[inline]
    #[target_feature(enable = "avx")]
    unsafe fn test(n: &Node, o: &Object) -> u8 {
        let sign = _mm256_set1_ps(-0.0);
        let abs = |x: __m256| _mm256_andnot_ps(sign, x);
        let neg = |x: __m256| _mm256_xor_ps(sign, x);
        let zero = _mm256_setzero_ps();
        let inf = _mm256_set1_ps(f32::INFINITY);
        let (r, max_t, dv) = (n.r, n.max_t, o.d);

        // The beam: tn ≤ tf after every axis whose reciprocal directions are finite and of
        // one sign (dual::RayNode::beam_test).
        let mut tn = n.tmin;
        let mut tf = n.tmax;
        for k in 0..3 {
            let (ilo, ihi) = (n.ilo[k], n.ihi[k]);
            let finite = _mm256_and_ps(
                _mm256_cmp_ps::<_CMP_LT_OQ>(abs(ilo), inf),
                _mm256_cmp_ps::<_CMP_LT_OQ>(abs(ihi), inf),
            );
            let pos = _mm256_cmp_ps::<_CMP_GT_OQ>(ilo, zero);
            let negd = _mm256_cmp_ps::<_CMP_LT_OQ>(ihi, zero);
            let active = _mm256_and_ps(finite, _mm256_or_ps(pos, negd));
            let (bmin, bmax) = (o.bmin[k], o.bmax[k]);
            let (omin, omax) = (n.omin[k], n.omax[k]);
            // blendv(a, b, m): b where m is set.
            let near = _mm256_blendv_ps(neg(bmax), bmin, pos);
            let far = _mm256_blendv_ps(neg(bmin), bmax, pos);
            let olo = _mm256_blendv_ps(neg(omax), omin, pos);
            let ohi = _mm256_blendv_ps(neg(omin), omax, pos);
            let a = _mm256_blendv_ps(neg(ihi), ilo, pos);
            let c = _mm256_blendv_ps(neg(ilo), ihi, pos);
            let e = _mm256_sub_ps(near, ohi);
            let e_pos = _mm256_cmp_ps::<_CMP_GE_OQ>(e, zero);
            let enter = _mm256_blendv_ps(_mm256_mul_ps(e, c), _mm256_mul_ps(e, a), e_pos);
            let x = _mm256_sub_ps(far, olo);
            let x_pos = _mm256_cmp_ps::<_CMP_GE_OQ>(x, zero);
            let exit = _mm256_blendv_ps(_mm256_mul_ps(x, a), _mm256_mul_ps(x, c), x_pos);
            let m1 = _mm256_max_ps(abs(near), abs(far));
            let m2 = _mm256_max_ps(abs(olo), abs(ohi));
            let slack = _mm256_mul_ps(
                _mm256_mul_ps(_mm256_add_ps(m1, m2), c),
                _mm256_set1_ps(1e-6),
            );
            // f32::max / min keep the non-NaN operand: max_ps returns its second operand
            // when either is NaN, and tn, tf are never NaN.
            let tn2 = _mm256_max_ps(_mm256_sub_ps(enter, slack), tn);
            let tf2 = _mm256_min_ps(_mm256_add_ps(exit, slack), tf);
            tn = _mm256_blendv_ps(tn, tn2, active);
            tf = _mm256_blendv_ps(tf, tf2, active);
        }
        let beam = _mm256_cmp_ps::<_CMP_LE_OQ>(tn, tf);

        // RAH's cone test (geom::cone::rah_test), glam's operation order.
        let cpx = _mm256_sub_ps(o.p[0], n.c[0]);
        let cpy = _mm256_sub_ps(o.p[1], n.c[1]);
        let cpz = _mm256_sub_ps(o.p[2], n.c[2]);
        let dot = |x: __m256, y: __m256, z: __m256, u: __m256, v: __m256, w: __m256| {
            _mm256_add_ps(
                _mm256_add_ps(_mm256_mul_ps(x, u), _mm256_mul_ps(y, v)),
                _mm256_mul_ps(z, w),
            )
        };
        let len = _mm256_sqrt_ps(dot(cpx, cpy, cpz, cpx, cpy, cpz));
        let reach = _mm256_mul_ps(
            _mm256_add_ps(_mm256_add_ps(r, max_t), dv),
            _mm256_set1_ps(1.0 + 1e-5),
        );
        // Rejected only when len > reach (a NaN passes, as in the scalar `if`).
        let near_enough = _mm256_cmp_ps::<_CMP_NGT_UQ>(len, reach);
        let [ax, ay, az] = n.axis;
        let along = dot(cpx, cpy, cpz, ax, ay, az);
        let rx = _mm256_sub_ps(cpx, _mm256_mul_ps(ax, along));
        let ry = _mm256_sub_ps(cpy, _mm256_mul_ps(ay, along));
        let rz = _mm256_sub_ps(cpz, _mm256_mul_ps(az, along));
        let radial = _mm256_sqrt_ps(dot(rx, ry, rz, rx, ry, rz));
        let lhs = _mm256_add_ps(
            _mm256_add_ps(_mm256_mul_ps(abs(along), n.sin), _mm256_add_ps(dv, r)),
            _mm256_mul_ps(_mm256_set1_ps(1e-5), len),
        );
        let inside = _mm256_cmp_ps::<_CMP_GE_OQ>(lhs, _mm256_mul_ps(radial, n.cos));
        let cone = _mm256_or_ps(n.wide, _mm256_and_ps(near_enough, inside));
        _mm256_movemask_ps(_mm256_and_ps(cone, beam)) as u8
    }
}
