//! The irregular grid's traversal (paper §5) eight rays at a time: one ray per AVX2 lane,
//! each lane running [`super::traverse::trace_ray`]'s steps for its own ray.
//!
//! Why lanes of rays and not lanes of triangles: on the real scenes a traversal step tests
//! few triangles (Sponza primary rays: N_I / N_T ≈ 1.3), so eight triangles of one cell
//! would leave most lanes empty, while every step of every ray does the same work — a
//! voxel-map descent, a cell record, the watertight tests of its list, the exit through the
//! cell's far planes — which lines up across rays whatever cells they are in. The eight
//! rays' dependent loads are in flight together (what [`super::traverse::trace_stream`]
//! gets from prefetching): voxel-map entries by gathers, cell records and triangles as one
//! row load per lane transposed into component vectors (cheaper than gathers).
//!
//! Per step: idle lanes take new rays (their entry computed eight at a time); each lane
//! finds its cell and reads its record; the cells' reference lists become one queue of
//! (lane, reference) jobs tested eight at a time whatever lane they belong to (a lane per
//! ray would idle while the longest list runs); then every lane leaves its cell.
//!
//! Exactness: every lane performs the scalar code's IEEE-754 operations in the same order
//! (no FMA: the kernel enables AVX2 only, and Rust never contracts), so each lane's voxel
//! walk, cell visits, tests, hits and counts are [`super::traverse::trace_ray`]'s bit for
//! bit:
//! - the triangle test is [`geom::tri::intersect`] per lane: vertex minus origin, shear
//!   (product, then difference), the three edge functions, the sign test, det = (u + v) + w,
//!   ((u·az + v·bz) + w·cz) · (1 / det). A lane whose edge function is exactly zero is
//!   redone by the scalar kernel (its f64 path), as [`geom::tri8`] does;
//! - the closest hit is the minimum over (t, triangle), which does not depend on the order
//!   of the tests; an any-hit lane stops at the first hit of its list order, as the scalar
//!   loop does, so the test counts agree too;
//! - `floor` is the rounding instruction, with the scalar conversion's saturation (both
//!   ways) and NaN cases mapped to values that take the same branch (see `floor_i32`);
//! - the entry's `f32::max`/`min` keep the scalar operand choice except between +0 and −0,
//!   which give the same voxel (see `enter8`).
//!
//! Without AVX2 (checked at run time), or where an index would not fit the gathers' signed
//! 32-bit offsets, the batch goes to [`super::traverse::trace_stream`] instead.

use super::traverse::RayCounts;
use super::Grid;
use geom::Vec3;
use trace::{Hit, RayBatch, TraceMode};

/// Rays traced together.
pub const LANES: usize = 8;

/// Whether this CPU runs the 8-lane traversal (AVX2).
pub fn available() -> bool {
    #[cfg(target_arch = "x86_64")]
    {
        std::arch::is_x86_feature_detected!("avx2")
    }
    #[cfg(not(target_arch = "x86_64"))]
    {
        false
    }
}

/// Whether every gather offset of `g` over `tris` fits an i32 (triangle floats, cell
/// record words, voxel-map entries, references), and triangle 0 and cell 0 exist (idle
/// lanes read them and ignore what they read).
fn fits(g: &Grid, tris: &[[Vec3; 3]]) -> bool {
    let lim = i32::MAX as usize;
    !tris.is_empty()
        && tris.len() < lim / 9
        && !g.trav.is_empty()
        && g.trav.len() < lim / 8
        && g.entries.len() < lim
        && g.refs.len() < lim
}

/// Whether [`trace()`] takes the 8-lane kernel for `g` on this CPU.
pub fn used(g: &Grid, tris: &[[Vec3; 3]]) -> bool {
    available() && fits(g, tris)
}

/// Trace rays `first..first + hits.len()` of `rays`, writing each ray's hit; returns the
/// summed counters. Same hits and counters as [`super::traverse::trace_stream`].
pub fn trace(
    g: &Grid,
    tris: &[[Vec3; 3]],
    rays: &RayBatch,
    first: usize,
    hits: &mut [Hit],
    mode: TraceMode,
) -> RayCounts {
    #[cfg(target_arch = "x86_64")]
    if used(g, tris) {
        // SAFETY: AVX2 is present (checked by `used`), and every offset fits (`fits`).
        return unsafe { avx2::trace(g, tris, rays, first, hits, mode) };
    }
    super::traverse::trace_stream(g, tris, rays, first, hits, mode)
}

#[cfg(target_arch = "x86_64")]
mod avx2 {
    use super::super::traverse::RayCounts;
    use super::super::voxelmap::{INDEX, LOG_DIM_MASK, LOG_DIM_SHIFT};
    use super::super::{CellRec, Grid};
    use super::LANES;
    use geom::tri::{intersect, RayPre};
    use geom::tri8::watertight8;
    use geom::Vec3;
    use std::arch::x86_64::*;
    use trace::{Hit, RayBatch, TraceMode};

    const _: () = assert!(std::mem::size_of::<[Vec3; 3]>() == 36);
    const _: () = assert!(std::mem::size_of::<CellRec>() == 32);

    #[derive(Clone, Copy, Default)]
    #[repr(C, align(32))]
    struct F8([f32; LANES]);
    #[derive(Clone, Copy, Default)]
    #[repr(C, align(32))]
    struct I8([i32; LANES]);

    /// The lanes' state, structure of arrays (loaded into registers per phase; refilling a
    /// lane writes its column).
    #[derive(Default)]
    struct State {
        /// Each lane's ray as it entered the grid, its voxel and exit distance since.
        r: Entry,
        best_t: F8,
        steps: I8,
        tests: I8,
        /// All ones for a lane tracing a ray.
        active: I8,
        /// The current cell's exit box and the cursor in its reference list.
        lo: [I8; 3],
        hi: [I8; 3],
        cur: I8,
        end: I8,
    }

    #[inline(always)]
    unsafe fn ld(a: &F8) -> __m256 {
        _mm256_load_ps(a.0.as_ptr())
    }
    #[inline(always)]
    unsafe fn ldi(a: &I8) -> __m256i {
        _mm256_load_si256(a.0.as_ptr() as *const __m256i)
    }
    #[inline(always)]
    unsafe fn st(a: &mut F8, v: __m256) {
        _mm256_store_ps(a.0.as_mut_ptr(), v)
    }
    #[inline(always)]
    unsafe fn sti(a: &mut I8, v: __m256i) {
        _mm256_store_si256(a.0.as_mut_ptr() as *mut __m256i, v)
    }
    #[inline(always)]
    unsafe fn mask_bits(m: __m256i) -> u32 {
        _mm256_movemask_ps(_mm256_castsi256_ps(m)) as u32
    }
    /// Integer lanes where float lanes compare true.
    #[inline(always)]
    unsafe fn im(m: __m256) -> __m256i {
        _mm256_castps_si256(m)
    }
    #[inline(always)]
    unsafe fn fm(m: __m256i) -> __m256 {
        _mm256_castsi256_ps(m)
    }

    /// `floor(x)` as i32 with the scalar `floor_i64`'s outcomes: exact below 2^31 in
    /// magnitude; above it i32::MAX (the scalar value is ≥ 2^31: past every grid bound, as
    /// i32::MAX is); below −2^31 i32::MIN (negative, as the scalar value is); NaN → 0 (as
    /// `NaN as i64`).
    #[inline(always)]
    unsafe fn floor_i32(x: __m256) -> __m256i {
        let f = _mm256_floor_ps(x);
        let i = _mm256_cvttps_epi32(f);
        let big = im(_mm256_cmp_ps::<_CMP_GE_OQ>(
            f,
            _mm256_set1_ps(2_147_483_648.0),
        ));
        let i = _mm256_blendv_epi8(i, _mm256_set1_epi32(i32::MAX), big);
        let nan = im(_mm256_cmp_ps::<_CMP_UNORD_Q>(x, x));
        _mm256_andnot_si256(nan, i)
    }

    /// The grid's constants as the kernel reads them.
    struct Consts {
        bmin: [__m256; 3],
        bmax: [__m256; 3],
        voxel: [__m256; 3],
        inv_voxel: [__m256; 3],
        dims_m1: [__m256i; 3],
    }

    impl Consts {
        #[target_feature(enable = "avx2")]
        fn new(g: &Grid) -> Consts {
            Consts {
                bmin: [0, 1, 2].map(|k| _mm256_set1_ps(g.bounds.min[k])),
                bmax: [0, 1, 2].map(|k| _mm256_set1_ps(g.bounds.max[k])),
                voxel: [0, 1, 2].map(|k| _mm256_set1_ps(g.voxel[k])),
                inv_voxel: [0, 1, 2].map(|k| _mm256_set1_ps(g.inv_voxel[k])),
                dims_m1: [0, 1, 2].map(|k| _mm256_set1_epi32(g.dims[k] as i32 - 1)),
            }
        }
    }

    /// A ray's state at its entry into the grid (`traverse::Lane::new`'s), eight rays at a time.
    #[derive(Clone, Copy, Default)]
    struct Entry {
        o: [F8; 3],
        d: [F8; 3],
        inv: [F8; 3],
        /// All ones where the direction's component has its sign bit set.
        neg: [I8; 3],
        /// The shear's axes (kx, ky, kz) and the origin's components on them.
        k: [I8; 3],
        ok: [F8; 3],
        sx: F8,
        sy: F8,
        t_min: F8,
        t_max: F8,
        v: [I8; 3],
        t_leave: F8,
    }

    impl Entry {
        /// Lane `x` of `from` into lane `j`.
        fn copy_lane(&mut self, j: usize, from: &Entry, x: usize) {
            for c in 0..3 {
                self.o[c].0[j] = from.o[c].0[x];
                self.d[c].0[j] = from.d[c].0[x];
                self.inv[c].0[j] = from.inv[c].0[x];
                self.neg[c].0[j] = from.neg[c].0[x];
                self.k[c].0[j] = from.k[c].0[x];
                self.ok[c].0[j] = from.ok[c].0[x];
                self.v[c].0[j] = from.v[c].0[x];
            }
            for (dst, src) in [
                (&mut self.sx, &from.sx),
                (&mut self.sy, &from.sy),
                (&mut self.t_min, &from.t_min),
                (&mut self.t_max, &from.t_max),
                (&mut self.t_leave, &from.t_leave),
            ] {
                dst.0[j] = src.0[x];
            }
        }
    }

    /// Rays that entered the grid, waiting for a lane: `lane[at..n]` index `e`'s columns,
    /// `ray` the rays (relative to the block's first, then to the chunk's).
    #[derive(Default)]
    struct Queue {
        e: Entry,
        lane: [u8; LANES],
        ray: [usize; LANES],
        n: usize,
        at: usize,
        /// Rays of the block that miss the grid (bit x: ray x).
        missed: u32,
    }

    /// Rows r0..r7 of an 8×8 matrix to its columns.
    #[inline(always)]
    unsafe fn transpose8(r: [__m256; 8]) -> [__m256; 8] {
        let t0 = _mm256_unpacklo_ps(r[0], r[1]);
        let t1 = _mm256_unpackhi_ps(r[0], r[1]);
        let t2 = _mm256_unpacklo_ps(r[2], r[3]);
        let t3 = _mm256_unpackhi_ps(r[2], r[3]);
        let t4 = _mm256_unpacklo_ps(r[4], r[5]);
        let t5 = _mm256_unpackhi_ps(r[4], r[5]);
        let t6 = _mm256_unpacklo_ps(r[6], r[7]);
        let t7 = _mm256_unpackhi_ps(r[6], r[7]);
        let u0 = _mm256_shuffle_ps::<0x44>(t0, t2);
        let u1 = _mm256_shuffle_ps::<0xEE>(t0, t2);
        let u2 = _mm256_shuffle_ps::<0x44>(t1, t3);
        let u3 = _mm256_shuffle_ps::<0xEE>(t1, t3);
        let u4 = _mm256_shuffle_ps::<0x44>(t4, t6);
        let u5 = _mm256_shuffle_ps::<0xEE>(t4, t6);
        let u6 = _mm256_shuffle_ps::<0x44>(t5, t7);
        let u7 = _mm256_shuffle_ps::<0xEE>(t5, t7);
        [
            _mm256_permute2f128_ps::<0x20>(u0, u4),
            _mm256_permute2f128_ps::<0x20>(u1, u5),
            _mm256_permute2f128_ps::<0x20>(u2, u6),
            _mm256_permute2f128_ps::<0x20>(u3, u7),
            _mm256_permute2f128_ps::<0x31>(u0, u4),
            _mm256_permute2f128_ps::<0x31>(u1, u5),
            _mm256_permute2f128_ps::<0x31>(u2, u6),
            _mm256_permute2f128_ps::<0x31>(u3, u7),
        ]
    }

    /// Per lane, `x` if `k` is 0, `y` if 1, `z` if 2.
    #[inline(always)]
    unsafe fn pick(k: __m256i, x: __m256, y: __m256, z: __m256) -> __m256 {
        let is1 = fm(_mm256_cmpeq_epi32(k, _mm256_set1_epi32(1)));
        let is2 = fm(_mm256_cmpeq_epi32(k, _mm256_set1_epi32(2)));
        _mm256_blendv_ps(_mm256_blendv_ps(x, y, is1), z, is2)
    }

    /// The entry states of rays `first..first + n` (n ≤ 8) into `q`: `traverse::Lane::new` per lane
    /// (`Aabb::intersect`, the entry voxel, `RayPre::new`), the same operations in the same
    /// order. Of the two zeros `f32::max`/`min` may return for ±0 operands, the interval
    /// keeps either: its ends are only compared, or scale a direction added to the origin,
    /// which gives the same voxel for +0 and −0.
    #[target_feature(enable = "avx2")]
    fn enter8(rays: &RayBatch, first: usize, n: usize, q: &mut Queue, c: &Consts) {
        let mut raw = [F8::default(); 8];
        for x in 0..n {
            let (o, d) = (rays.org[first + x], rays.dir[first + x]);
            for k in 0..3 {
                raw[k].0[x] = o[k];
                raw[3 + k].0[x] = d[k];
            }
            raw[6].0[x] = rays.t_min[first + x];
            raw[7].0[x] = rays.t_max[first + x];
        }
        // SAFETY (every block below): AVX2 is enabled for this function; loads and stores
        // are of aligned local arrays.
        unsafe {
            let zero = _mm256_setzero_ps();
            let one = _mm256_set1_ps(1.0);
            let o = [ld(&raw[0]), ld(&raw[1]), ld(&raw[2])];
            let d = [ld(&raw[3]), ld(&raw[4]), ld(&raw[5])];
            let inv = d.map(|x| _mm256_div_ps(one, x));
            let (mut tn, mut tf) = (ld(&raw[6]), ld(&raw[7]));
            let robust = _mm256_set1_ps(geom::aabb::SLAB_ROBUST);
            for k in 0..3 {
                let a = _mm256_mul_ps(_mm256_sub_ps(c.bmin[k], o[k]), inv[k]);
                let b = _mm256_mul_ps(_mm256_sub_ps(c.bmax[k], o[k]), inv[k]);
                let nan = _mm256_or_ps(
                    _mm256_cmp_ps::<_CMP_UNORD_Q>(a, a),
                    _mm256_cmp_ps::<_CMP_UNORD_Q>(b, b),
                );
                let le = _mm256_cmp_ps::<_CMP_LE_OQ>(a, b);
                let lo = _mm256_blendv_ps(b, a, le);
                let hi = _mm256_mul_ps(_mm256_blendv_ps(a, b, le), robust);
                // f32::max / f32::min: the other operand where one is NaN (lo and hi are not).
                let take_lo = _mm256_or_ps(
                    _mm256_cmp_ps::<_CMP_GT_OQ>(lo, tn),
                    _mm256_cmp_ps::<_CMP_UNORD_Q>(tn, tn),
                );
                let take_hi = _mm256_or_ps(
                    _mm256_cmp_ps::<_CMP_LT_OQ>(hi, tf),
                    _mm256_cmp_ps::<_CMP_UNORD_Q>(tf, tf),
                );
                tn = _mm256_blendv_ps(tn, lo, _mm256_andnot_ps(nan, take_lo));
                tf = _mm256_blendv_ps(tf, hi, _mm256_andnot_ps(nan, take_hi));
            }
            let inside = _mm256_movemask_ps(_mm256_cmp_ps::<_CMP_LE_OQ>(tn, tf)) as u32;
            let e = &mut q.e;
            for k in 0..3 {
                let p = _mm256_add_ps(o[k], _mm256_mul_ps(d[k], tn));
                let f = floor_i32(_mm256_mul_ps(_mm256_sub_ps(p, c.bmin[k]), c.inv_voxel[k]));
                let v = _mm256_min_epi32(_mm256_max_epi32(f, _mm256_setzero_si256()), c.dims_m1[k]);
                sti(&mut e.v[k], v);
                st(&mut e.o[k], o[k]);
                st(&mut e.d[k], d[k]);
                st(&mut e.inv[k], inv[k]);
                sti(&mut e.neg[k], _mm256_srai_epi32::<31>(im(d[k])));
            }
            st(&mut e.t_min, ld(&raw[6]));
            st(&mut e.t_max, ld(&raw[7]));
            st(&mut e.t_leave, tf);
            // RayPre::new: kz the axis of |d|'s largest component (x > y, x > z, y > z, as
            // the scalar comparisons, false for NaN), kx and ky the next two, swapped when
            // d[kz] < 0.
            let ad = d.map(|x| _mm256_andnot_ps(_mm256_set1_ps(-0.0), x));
            let gxy = _mm256_cmp_ps::<_CMP_GT_OQ>(ad[0], ad[1]);
            let gxz = _mm256_cmp_ps::<_CMP_GT_OQ>(ad[0], ad[2]);
            let gyz = _mm256_cmp_ps::<_CMP_GT_OQ>(ad[1], ad[2]);
            let two = _mm256_set1_epi32(2);
            let kz = _mm256_blendv_epi8(
                _mm256_blendv_epi8(two, _mm256_set1_epi32(1), im(gyz)),
                _mm256_blendv_epi8(two, _mm256_setzero_si256(), im(gxz)),
                im(gxy),
            );
            let dkz = pick(kz, d[0], d[1], d[2]);
            // (k + 1) mod 3 for k in 0..3.
            let inc = |k: __m256i| {
                let k1 = _mm256_add_epi32(k, _mm256_set1_epi32(1));
                _mm256_andnot_si256(_mm256_cmpeq_epi32(k1, _mm256_set1_epi32(3)), k1)
            };
            let kx0 = inc(kz);
            let ky0 = inc(kx0);
            let swap = im(_mm256_cmp_ps::<_CMP_LT_OQ>(dkz, zero));
            let kx = _mm256_blendv_epi8(kx0, ky0, swap);
            let ky = _mm256_blendv_epi8(ky0, kx0, swap);
            let sz = _mm256_div_ps(one, dkz);
            st(&mut e.sx, _mm256_mul_ps(pick(kx, d[0], d[1], d[2]), sz));
            st(&mut e.sy, _mm256_mul_ps(pick(ky, d[0], d[1], d[2]), sz));
            for (i, k) in [kx, ky, kz].into_iter().enumerate() {
                sti(&mut e.k[i], k);
                st(&mut e.ok[i], pick(k, o[0], o[1], o[2]));
            }
            let valid = if n == LANES { 0xff } else { (1u32 << n) - 1 };
            q.missed = valid & !inside;
            q.n = 0;
            q.at = 0;
            for x in 0..n {
                if inside & (1 << x) != 0 {
                    q.lane[q.n] = x as u8;
                    q.ray[q.n] = x;
                    q.n += 1;
                }
            }
        }
    }

    /// See [`super::trace`].
    #[target_feature(enable = "avx2")]
    pub unsafe fn trace(
        g: &Grid,
        tris: &[[Vec3; 3]],
        rays: &RayBatch,
        first: usize,
        hits: &mut [Hit],
        mode: TraceMode,
    ) -> RayCounts {
        unsafe { run(g, tris, rays, first, hits, mode) }
    }

    #[target_feature(enable = "avx2")]
    unsafe fn run(
        g: &Grid,
        tris: &[[Vec3; 3]],
        rays: &RayBatch,
        first: usize,
        hits: &mut [Hit],
        mode: TraceMode,
    ) -> RayCounts {
        let any = mode == TraceMode::Any;
        let tri_f = tris.as_ptr() as *const f32;
        let entries = g.entries.as_ptr() as *const i32;
        let trav = g.trav.as_ptr() as *const i32;
        let refs = g.refs.as_ptr() as *const i32;
        let mut s = State::default();
        let mut ray = [0usize; LANES];
        let mut pre: [Option<RayPre>; LANES] = [None; LANES];
        let mut best = [Hit::MISS; LANES];
        let mut total = RayCounts::default();
        let mut next = 0usize;
        let consts = Consts::new(g);
        let mut q = Queue::default();
        // The test queue's jobs (lane, reference index), reused from step to step.
        let mut jobs_lane: Vec<i32> = Vec::with_capacity(256);
        let mut jobs_ref: Vec<i32> = Vec::with_capacity(256);

        // Grid constants.
        let Consts {
            bmin,
            voxel,
            inv_voxel,
            dims_m1,
            ..
        } = consts;
        let shift = _mm256_set1_epi32(g.shift as i32);
        let td0 = _mm256_set1_epi32(g.top_dims[0] as i32);
        let td1 = _mm256_set1_epi32(g.top_dims[1] as i32);
        let zero_i = _mm256_setzero_si256();
        let one = _mm256_set1_epi32(1);
        let nine = _mm256_set1_epi32(9);
        let zero_f = _mm256_setzero_ps();

        loop {
            // 1. Idle lanes take the next rays that enter the grid, whose entry states are
            //    computed eight at a time (rays that miss the grid are answered there).
            for j in 0..LANES {
                if s.active.0[j] != 0 {
                    continue;
                }
                while q.at == q.n && next < hits.len() {
                    let n = (hits.len() - next).min(LANES);
                    enter8(rays, first + next, n, &mut q, &consts);
                    for x in 0..n {
                        if q.missed & (1 << x) != 0 {
                            hits[next + x] = Hit::MISS;
                        }
                    }
                    for r in &mut q.ray[..q.n] {
                        *r += next;
                    }
                    next += n;
                }
                if q.at == q.n {
                    break;
                }
                let x = q.lane[q.at] as usize;
                let e = &q.e;
                ray[j] = q.ray[q.at];
                q.at += 1;
                s.r.copy_lane(j, e, x);
                pre[j] = Some(RayPre {
                    org: Vec3::new(e.o[0].0[x], e.o[1].0[x], e.o[2].0[x]),
                    dir: Vec3::new(e.d[0].0[x], e.d[1].0[x], e.d[2].0[x]),
                    kx: e.k[0].0[x] as u8,
                    ky: e.k[1].0[x] as u8,
                    kz: e.k[2].0[x] as u8,
                    sx: e.sx.0[x],
                    sy: e.sy.0[x],
                    t_min: e.t_min.0[x],
                    t_max: e.t_max.0[x],
                });
                best[j] = Hit::MISS;
                s.best_t.0[j] = f32::INFINITY;
                s.steps.0[j] = 0;
                s.tests.0[j] = 0;
                s.active.0[j] = -1;
            }
            let mut act = ldi(&s.active);
            if mask_bits(act) == 0 {
                return total;
            }

            // 2. The cell of each lane's voxel: the top entry, then down the blocks
            //    (`Grid::lookup`, `voxelmap::descend`).
            let v = [ldi(&s.r.v[0]), ldi(&s.r.v[1]), ldi(&s.r.v[2])];
            let t = [0, 1, 2].map(|k| _mm256_srlv_epi32(v[k], shift));
            let top = _mm256_add_epi32(
                t[0],
                _mm256_mullo_epi32(td0, _mm256_add_epi32(t[1], _mm256_mullo_epi32(td1, t[2]))),
            );
            let mut e = _mm256_mask_i32gather_epi32::<4>(zero_i, entries, top, act);
            let mut sh = shift;
            loop {
                // NODE is the sign bit.
                let node = _mm256_and_si256(act, _mm256_cmpgt_epi32(zero_i, e));
                if mask_bits(node) == 0 {
                    break;
                }
                let k = _mm256_and_si256(
                    _mm256_srli_epi32::<{ LOG_DIM_SHIFT as i32 }>(e),
                    _mm256_set1_epi32(LOG_DIM_MASK as i32),
                );
                let sh2 = _mm256_sub_epi32(sh, k);
                let m = _mm256_sub_epi32(_mm256_sllv_epi32(one, k), one);
                let c = [0, 1, 2].map(|a| _mm256_and_si256(_mm256_srlv_epi32(v[a], sh2), m));
                let i = _mm256_or_si256(
                    c[0],
                    _mm256_or_si256(
                        _mm256_sllv_epi32(c[1], k),
                        _mm256_sllv_epi32(c[2], _mm256_add_epi32(k, k)),
                    ),
                );
                let idx = _mm256_add_epi32(_mm256_and_si256(e, _mm256_set1_epi32(INDEX as i32)), i);
                e = _mm256_mask_i32gather_epi32::<4>(e, entries, idx, node);
                sh = _mm256_blendv_epi8(sh, sh2, node);
            }

            // 3. The cells' records (exit box and reference range): one 32-byte load per
            //    lane, transposed into field vectors (idle lanes read cell 0's, unused).
            let mut cell = I8::default();
            sti(&mut cell, e);
            let rec = |x: usize| _mm256_loadu_ps(trav.add(8 * cell.0[x] as usize) as *const f32);
            let f = transpose8([
                rec(0),
                rec(1),
                rec(2),
                rec(3),
                rec(4),
                rec(5),
                rec(6),
                rec(7),
            ])
            .map(|x| im(x));
            for c in 0..3 {
                sti(&mut s.lo[c], f[c]);
                sti(&mut s.hi[c], f[3 + c]);
            }
            sti(&mut s.cur, f[6]);
            sti(&mut s.end, f[7]);
            let steps = _mm256_sub_epi32(ldi(&s.steps), act);
            sti(&mut s.steps, steps);

            // 4. The cells' triangles as one queue of (lane, reference) jobs, lane by lane in
            //    list order, tested eight jobs at a time whatever lane they belong to: a
            //    step tests few triangles (Sponza: 1.3 on average), so one lane per ray
            //    would leave three quarters of the lanes idle while the longest list runs.
            let cur = ldi(&s.cur);
            let end = ldi(&s.end);
            let len = _mm256_and_si256(act, _mm256_sub_epi32(end, cur));
            let mut curs = I8::default();
            let mut lens = I8::default();
            sti(&mut curs, cur);
            sti(&mut lens, len);
            jobs_lane.clear();
            jobs_ref.clear();
            for j in 0..LANES {
                let c = curs.0[j];
                for r in c..c + lens.0[j] {
                    jobs_lane.push(j as i32);
                    jobs_ref.push(r);
                }
            }
            let kk = [ldi(&s.r.k[0]), ldi(&s.r.k[1]), ldi(&s.r.k[2])];
            let okk = [ld(&s.r.ok[0]), ld(&s.r.ok[1]), ld(&s.r.ok[2])];
            let ray_f = [ld(&s.r.sx), ld(&s.r.sy)];
            let iota = _mm256_setr_epi32(0, 1, 2, 3, 4, 5, 6, 7);
            let mut at = 0;
            while at < jobs_lane.len() {
                let n = (jobs_lane.len() - at).min(LANES);
                let mut jl = I8::default();
                let mut jr = I8::default();
                jl.0[..n].copy_from_slice(&jobs_lane[at..at + n]);
                jr.0[..n].copy_from_slice(&jobs_ref[at..at + n]);
                let lane = ldi(&jl);
                // Jobs of lanes still tracing (an any-hit lane answered earlier in the queue
                // tests no further).
                let tm = _mm256_and_si256(
                    _mm256_cmpgt_epi32(_mm256_set1_epi32(n as i32), iota),
                    _mm256_permutevar8x32_epi32(ldi(&s.active), lane),
                );
                let job_at = at;
                at += n;
                if mask_bits(tm) == 0 {
                    continue;
                }
                let tri = _mm256_mask_i32gather_epi32::<4>(zero_i, refs, ldi(&jr), tm);
                let fmask = fm(tm);
                let perm = |x: __m256| _mm256_permutevar8x32_ps(x, lane);
                let kj = kk.map(|k| _mm256_permutevar8x32_epi32(k, lane));
                let oj = okk.map(perm);
                let [sx, sy] = ray_f.map(perm);
                // The jobs' triangles: one 8-float load per job (a, b, c.x, c.y: the first 8
                // of its 9 floats) transposed into component vectors, and c.z gathered;
                // masked-out jobs read triangle 0 (there is one: a job exists).
                let mut tix = I8::default();
                sti(&mut tix, tri);
                let row = |x: usize| _mm256_loadu_ps(tri_f.add(9 * tix.0[x] as usize));
                let [ax0, ay0, az0, bx0, by0, bz0, cx0, cy0] = transpose8([
                    row(0),
                    row(1),
                    row(2),
                    row(3),
                    row(4),
                    row(5),
                    row(6),
                    row(7),
                ]);
                let tb = _mm256_mullo_epi32(tri, nine);
                let cz0 =
                    _mm256_i32gather_ps::<4>(tri_f, _mm256_add_epi32(tb, _mm256_set1_epi32(8)));
                // Vertex components on the job ray's axes kj[c], minus the origin's.
                let is = |k: __m256i| {
                    (
                        fm(_mm256_cmpeq_epi32(k, _mm256_set1_epi32(1))),
                        fm(_mm256_cmpeq_epi32(k, _mm256_set1_epi32(2))),
                    )
                };
                let sel = [is(kj[0]), is(kj[1]), is(kj[2])];
                let comp = |x: __m256, y: __m256, z: __m256, c: usize| {
                    let (e1, e2) = sel[c];
                    _mm256_sub_ps(_mm256_blendv_ps(_mm256_blendv_ps(x, y, e1), z, e2), oj[c])
                };
                let rel = |x: __m256, y: __m256, z: __m256| {
                    [comp(x, y, z, 0), comp(x, y, z, 1), comp(x, y, z, 2)]
                };
                let wt = watertight8(
                    rel(ax0, ay0, az0),
                    rel(bx0, by0, bz0),
                    rel(cx0, cy0, cz0),
                    [sx, sy],
                );
                let look = _mm256_movemask_ps(_mm256_and_ps(wt.scalar, fmask));
                if look == 0 {
                    continue;
                }
                // The jobs the vector test does not reject are decided by the scalar kernel
                // (its exact distance), and update their lane in queue order, which is each
                // lane's list order.
                let mut tria = I8::default();
                sti(&mut tria, tri);
                for x in 0..n {
                    let j = jl.0[x] as usize;
                    if look & (1 << x) == 0 || s.active.0[j] == 0 {
                        continue;
                    }
                    let id = tria.0[x] as u32;
                    let [a, b, c] = tris[id as usize];
                    let p = pre[j].as_ref().expect("an active lane has its ray");
                    let Some(h) = intersect(p, a, b, c) else {
                        continue;
                    };
                    let (t, u, v) = (h.t, h.u, h.v);
                    if best[j].closer(t, id) {
                        best[j] = Hit { tri: id, t, u, v };
                        s.best_t.0[j] = t;
                    }
                    if any {
                        // Answered: the scalar loop returns after this test, its
                        // (position in the list + 1)-th.
                        let tested = jobs_ref[job_at + x] - curs.0[j] + 1;
                        hits[ray[j]] = best[j];
                        total.steps += s.steps.0[j] as u64;
                        total.tests += (s.tests.0[j] + tested) as u64;
                        s.active.0[j] = 0;
                    }
                }
            }
            // Lanes not answered by an any-hit query here tested their whole list.
            act = ldi(&s.active);
            let tests = _mm256_add_epi32(ldi(&s.tests), _mm256_and_si256(act, len));
            sti(&mut s.tests, tests);

            // 5. Leave each lane's cell through its exit box's far planes (`Lane::leave`).
            let o = [ld(&s.r.o[0]), ld(&s.r.o[1]), ld(&s.r.o[2])];
            let d = [ld(&s.r.d[0]), ld(&s.r.d[1]), ld(&s.r.d[2])];
            let neg = [ldi(&s.r.neg[0]), ldi(&s.r.neg[1]), ldi(&s.r.neg[2])];
            let lo = [ldi(&s.lo[0]), ldi(&s.lo[1]), ldi(&s.lo[2])];
            let hi = [ldi(&s.hi[0]), ldi(&s.hi[1]), ldi(&s.hi[2])];
            let mut t_exit = _mm256_set1_ps(f32::INFINITY);
            let mut axis = _mm256_set1_epi32(3);
            for k in 0..3 {
                let moving = _mm256_cmp_ps::<_CMP_NEQ_UQ>(d[k], zero_f);
                let face = _mm256_blendv_epi8(hi[k], lo[k], neg[k]);
                let plane =
                    _mm256_add_ps(bmin[k], _mm256_mul_ps(_mm256_cvtepi32_ps(face), voxel[k]));
                let tk = _mm256_mul_ps(_mm256_sub_ps(plane, o[k]), ld(&s.r.inv[k]));
                let upd = _mm256_and_ps(moving, _mm256_cmp_ps::<_CMP_LT_OQ>(tk, t_exit));
                t_exit = _mm256_blendv_ps(t_exit, tk, upd);
                axis = _mm256_blendv_epi8(axis, _mm256_set1_epi32(k as i32), im(upd));
            }
            let mut done = _mm256_or_si256(
                im(_mm256_or_ps(
                    _mm256_cmp_ps::<_CMP_LT_OQ>(ld(&s.best_t), t_exit),
                    _mm256_cmp_ps::<_CMP_GE_OQ>(t_exit, ld(&s.r.t_leave)),
                )),
                _mm256_cmpeq_epi32(axis, _mm256_set1_epi32(3)),
            );
            let mut nv = [zero_i; 3];
            for k in 0..3 {
                let p = _mm256_add_ps(o[k], _mm256_mul_ps(d[k], t_exit));
                let f = floor_i32(_mm256_mul_ps(_mm256_sub_ps(p, bmin[k]), inv_voxel[k]));
                let forward = _mm256_blendv_epi8(
                    _mm256_max_epi32(f, v[k]),
                    _mm256_min_epi32(f, v[k]),
                    neg[k],
                );
                let still = im(_mm256_cmp_ps::<_CMP_EQ_OQ>(d[k], zero_f));
                let across = _mm256_blendv_epi8(hi[k], _mm256_sub_epi32(lo[k], one), neg[k]);
                let on_axis = _mm256_cmpeq_epi32(axis, _mm256_set1_epi32(k as i32));
                let n =
                    _mm256_blendv_epi8(_mm256_blendv_epi8(forward, v[k], still), across, on_axis);
                let out = _mm256_or_si256(
                    _mm256_cmpgt_epi32(zero_i, n),
                    _mm256_cmpgt_epi32(n, dims_m1[k]),
                );
                done = _mm256_or_si256(done, out);
                nv[k] = n;
            }
            let go = _mm256_andnot_si256(done, act);
            for k in 0..3 {
                sti(&mut s.r.v[k], _mm256_blendv_epi8(v[k], nv[k], go));
            }
            let fin = mask_bits(_mm256_and_si256(done, act));
            if fin != 0 {
                for j in 0..LANES {
                    if fin & (1 << j) != 0 {
                        hits[ray[j]] = best[j];
                        total.steps += s.steps.0[j] as u64;
                        total.tests += s.tests.0[j] as u64;
                        s.active.0[j] = 0;
                    }
                }
            }
        }
    }
}
