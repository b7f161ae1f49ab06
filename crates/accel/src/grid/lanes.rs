//! The irregular grid's traversal (paper §5) eight rays at a time: one ray per AVX2 lane,
//! each lane running [`super::traverse::trace_ray`]'s steps for its own ray.
//!
//! Why lanes of rays and not lanes of triangles: on the real scenes a traversal step tests
//! few triangles (Sponza primary rays: N_I / N_T ≈ 1.3), so eight triangles of one cell
//! would leave most lanes empty, while every step of every ray does the same work — a
//! voxel-map descent, a cell record, the watertight tests of its list, the exit through the
//! cell's far planes — which lines up across rays whatever cells they are in. The loads are
//! gathers, so the eight rays' dependent loads are in flight together (what
//! [`super::traverse::trace_stream`] gets from prefetching, here for free).
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
//! - `floor` is the rounding instruction, with the scalar conversion's saturation and NaN
//!   cases mapped to values that take the same branch (see `floor_i32`).
//!
//! Without AVX2 (checked at run time), or where an index would not fit the gathers' signed
//! 32-bit offsets, the batch goes to [`super::traverse::trace_stream`] instead.

use super::traverse::RayCounts;
use super::Grid;
use geom::Vec3;
use render::{Hit, RayBatch, TraceMode};

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
/// record words, voxel-map entries, references).
fn fits(g: &Grid, tris: &[[Vec3; 3]]) -> bool {
    let lim = i32::MAX as usize;
    tris.len() < lim / 9 && g.trav.len() < lim / 8 && g.entries.len() < lim && g.refs.len() < lim
}

/// Whether [`trace`] takes the 8-lane kernel for `g` on this CPU.
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
    use super::super::traverse::{Lane, RayCounts};
    use super::super::voxelmap::{INDEX, LOG_DIM_SHIFT};
    use super::super::{CellRec, Grid};
    use super::LANES;
    use geom::tri::{intersect, RayPre};
    use geom::Vec3;
    use render::{Hit, RayBatch, TraceMode};
    use std::arch::x86_64::*;

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
        sz: F8,
        t_min: F8,
        t_max: F8,
        v: [I8; 3],
        t_leave: F8,
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
        // The test queue's jobs (lane, reference index), reused from step to step.
        let mut jobs_lane: Vec<i32> = Vec::with_capacity(256);
        let mut jobs_ref: Vec<i32> = Vec::with_capacity(256);

        // Grid constants.
        let bmin = [0, 1, 2].map(|k| _mm256_set1_ps(g.bounds.min[k]));
        let voxel = [0, 1, 2].map(|k| _mm256_set1_ps(g.voxel[k]));
        let inv_voxel = [0, 1, 2].map(|k| _mm256_set1_ps(g.inv_voxel[k]));
        let dims = [0, 1, 2].map(|k| _mm256_set1_epi32(g.dims[k] as i32));
        let shift = _mm256_set1_epi32(g.shift as i32);
        let td0 = _mm256_set1_epi32(g.top_dims[0] as i32);
        let td1 = _mm256_set1_epi32(g.top_dims[1] as i32);
        let zero_i = _mm256_setzero_si256();
        let one = _mm256_set1_epi32(1);
        let nine = _mm256_set1_epi32(9);
        let zero_f = _mm256_setzero_ps();

        loop {
            // 1. Idle lanes take the next rays that enter the grid (rays that miss it are
            //    answered at once).
            for j in 0..LANES {
                if s.active.0[j] != 0 {
                    continue;
                }
                while next < hits.len() {
                    let i = next;
                    next += 1;
                    let Some(l) = Lane::new(g, &rays.ray(first + i)) else {
                        hits[i] = Hit::MISS;
                        continue;
                    };
                    ray[j] = i;
                    pre[j] = Some(l.pre);
                    best[j] = Hit::MISS;
                    let p = &l.pre;
                    let kk = [p.kx, p.ky, p.kz];
                    for (c, &kc) in kk.iter().enumerate() {
                        s.o[c].0[j] = l.o[c];
                        s.d[c].0[j] = l.d[c];
                        s.inv[c].0[j] = l.inv[c];
                        s.neg[c].0[j] = -(l.neg[c] as i32);
                        s.k[c].0[j] = kc as i32;
                        s.ok[c].0[j] = p.org[kc];
                        s.v[c].0[j] = l.v[c] as i32;
                    }
                    s.sx.0[j] = p.sx;
                    s.sy.0[j] = p.sy;
                    s.sz.0[j] = p.sz;
                    s.t_min.0[j] = p.t_min;
                    s.t_max.0[j] = p.t_max;
                    s.t_leave.0[j] = l.t_leave;
                    s.best_t.0[j] = f32::INFINITY;
                    s.steps.0[j] = 0;
                    s.tests.0[j] = 0;
                    s.active.0[j] = -1;
                    break;
                }
            }
            let mut act = ldi(&s.active);
            if mask_bits(act) == 0 {
                return total;
            }

            // 2. The cell of each lane's voxel: the top entry, then down the blocks
            //    (`Grid::lookup`, `voxelmap::descend`).
            let v = [ldi(&s.v[0]), ldi(&s.v[1]), ldi(&s.v[2])];
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
                    _mm256_set1_epi32(0xf),
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

            // 3. The cell's record: exit box and reference range.
            let base = _mm256_slli_epi32::<3>(e);
            let word = |f: i32| {
                _mm256_mask_i32gather_epi32::<4>(
                    zero_i,
                    trav,
                    _mm256_add_epi32(base, _mm256_set1_epi32(f)),
                    act,
                )
            };
            for c in 0..3 {
                sti(&mut s.lo[c], word(c as i32));
                sti(&mut s.hi[c], word(3 + c as i32));
            }
            sti(&mut s.cur, word(6));
            sti(&mut s.end, word(7));
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
            let kk = [ldi(&s.k[0]), ldi(&s.k[1]), ldi(&s.k[2])];
            let okk = [ld(&s.ok[0]), ld(&s.ok[1]), ld(&s.ok[2])];
            let ray_f = [ld(&s.sx), ld(&s.sy), ld(&s.sz), ld(&s.t_min), ld(&s.t_max)];
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
                let tb = _mm256_mullo_epi32(tri, nine);
                let fmask = fm(tm);
                let perm = |x: __m256| _mm256_permutevar8x32_ps(x, lane);
                let kj = kk.map(|k| _mm256_permutevar8x32_epi32(k, lane));
                let oj = okk.map(perm);
                let [sx, sy, sz, t_min, t_max] = ray_f.map(perm);
                // Vertex v's component on the job ray's axis kj[c], minus its origin's.
                let comp = |v: i32, c: usize| {
                    let idx =
                        _mm256_add_epi32(_mm256_add_epi32(tb, _mm256_set1_epi32(3 * v)), kj[c]);
                    _mm256_sub_ps(
                        _mm256_mask_i32gather_ps::<4>(zero_f, tri_f, idx, fmask),
                        oj[c],
                    )
                };
                let (akx, aky, akz) = (comp(0, 0), comp(0, 1), comp(0, 2));
                let (bkx, bky, bkz) = (comp(1, 0), comp(1, 1), comp(1, 2));
                let (ckx, cky, ckz) = (comp(2, 0), comp(2, 1), comp(2, 2));
                let ax = _mm256_sub_ps(akx, _mm256_mul_ps(sx, akz));
                let ay = _mm256_sub_ps(aky, _mm256_mul_ps(sy, akz));
                let bx = _mm256_sub_ps(bkx, _mm256_mul_ps(sx, bkz));
                let by = _mm256_sub_ps(bky, _mm256_mul_ps(sy, bkz));
                let cx = _mm256_sub_ps(ckx, _mm256_mul_ps(sx, ckz));
                let cy = _mm256_sub_ps(cky, _mm256_mul_ps(sy, ckz));
                let u = _mm256_sub_ps(_mm256_mul_ps(cx, by), _mm256_mul_ps(cy, bx));
                let vv = _mm256_sub_ps(_mm256_mul_ps(ax, cy), _mm256_mul_ps(ay, cx));
                let w = _mm256_sub_ps(_mm256_mul_ps(bx, ay), _mm256_mul_ps(by, ax));
                let eq0 = |x| _mm256_cmp_ps::<_CMP_EQ_OQ>(x, zero_f);
                let lt0 = |x| _mm256_cmp_ps::<_CMP_LT_OQ>(x, zero_f);
                let gt0 = |x| _mm256_cmp_ps::<_CMP_GT_OQ>(x, zero_f);
                let redo = _mm256_or_ps(_mm256_or_ps(eq0(u), eq0(vv)), eq0(w));
                let rej = _mm256_and_ps(
                    _mm256_or_ps(_mm256_or_ps(lt0(u), lt0(vv)), lt0(w)),
                    _mm256_or_ps(_mm256_or_ps(gt0(u), gt0(vv)), gt0(w)),
                );
                let det = _mm256_add_ps(_mm256_add_ps(u, vv), w);
                let az = _mm256_mul_ps(sz, akz);
                let bz = _mm256_mul_ps(sz, bkz);
                let cz = _mm256_mul_ps(sz, ckz);
                let ts = _mm256_add_ps(
                    _mm256_add_ps(_mm256_mul_ps(u, az), _mm256_mul_ps(vv, bz)),
                    _mm256_mul_ps(w, cz),
                );
                let inv = _mm256_div_ps(_mm256_set1_ps(1.0), det);
                let tt = _mm256_mul_ps(ts, inv);
                let inside = _mm256_and_ps(
                    _mm256_cmp_ps::<_CMP_GT_OQ>(tt, t_min),
                    _mm256_cmp_ps::<_CMP_LT_OQ>(tt, t_max),
                );
                let hit = _mm256_andnot_ps(
                    _mm256_or_ps(_mm256_or_ps(redo, rej), eq0(det)),
                    _mm256_and_ps(inside, fmask),
                );
                let look = _mm256_movemask_ps(_mm256_or_ps(hit, _mm256_and_ps(redo, fmask)));
                if look == 0 {
                    continue;
                }
                // Hits (and jobs the scalar kernel decides) update their lane in queue order,
                // which is each lane's list order.
                let hit_bits = _mm256_movemask_ps(hit);
                let (mut ta, mut ua, mut va, mut tria) =
                    (F8::default(), F8::default(), F8::default(), I8::default());
                st(&mut ta, tt);
                st(&mut ua, _mm256_mul_ps(vv, inv));
                st(&mut va, _mm256_mul_ps(w, inv));
                sti(&mut tria, tri);
                for x in 0..n {
                    let j = jl.0[x] as usize;
                    if look & (1 << x) == 0 || s.active.0[j] == 0 {
                        continue;
                    }
                    let id = tria.0[x] as u32;
                    let h = if hit_bits & (1 << x) != 0 {
                        Some((ta.0[x], ua.0[x], va.0[x]))
                    } else {
                        let [a, b, c] = tris[id as usize];
                        let p = pre[j].as_ref().expect("an active lane has its ray");
                        intersect(p, a, b, c).map(|h| (h.t, h.u, h.v))
                    };
                    let Some((t, u, v)) = h else { continue };
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
            let o = [ld(&s.o[0]), ld(&s.o[1]), ld(&s.o[2])];
            let d = [ld(&s.d[0]), ld(&s.d[1]), ld(&s.d[2])];
            let neg = [ldi(&s.neg[0]), ldi(&s.neg[1]), ldi(&s.neg[2])];
            let lo = [ldi(&s.lo[0]), ldi(&s.lo[1]), ldi(&s.lo[2])];
            let hi = [ldi(&s.hi[0]), ldi(&s.hi[1]), ldi(&s.hi[2])];
            let mut t_exit = _mm256_set1_ps(f32::INFINITY);
            let mut axis = _mm256_set1_epi32(3);
            for k in 0..3 {
                let moving = _mm256_cmp_ps::<_CMP_NEQ_UQ>(d[k], zero_f);
                let face = _mm256_blendv_epi8(hi[k], lo[k], neg[k]);
                let plane =
                    _mm256_add_ps(bmin[k], _mm256_mul_ps(_mm256_cvtepi32_ps(face), voxel[k]));
                let tk = _mm256_mul_ps(_mm256_sub_ps(plane, o[k]), ld(&s.inv[k]));
                let upd = _mm256_and_ps(moving, _mm256_cmp_ps::<_CMP_LT_OQ>(tk, t_exit));
                t_exit = _mm256_blendv_ps(t_exit, tk, upd);
                axis = _mm256_blendv_epi8(axis, _mm256_set1_epi32(k as i32), im(upd));
            }
            let mut done = _mm256_or_si256(
                im(_mm256_or_ps(
                    _mm256_cmp_ps::<_CMP_LT_OQ>(ld(&s.best_t), t_exit),
                    _mm256_cmp_ps::<_CMP_GE_OQ>(t_exit, ld(&s.t_leave)),
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
                    _mm256_cmpgt_epi32(n, _mm256_sub_epi32(dims[k], one)),
                );
                done = _mm256_or_si256(done, out);
                nv[k] = n;
            }
            let go = _mm256_andnot_si256(done, act);
            for k in 0..3 {
                sti(&mut s.v[k], _mm256_blendv_epi8(v[k], nv[k], go));
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
