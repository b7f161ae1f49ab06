//! The brute-force oracle as a test harness for any engine: record the batches a render
//! traces ([`Recorder`]; `testkit::record_render` answers a whole render's by brute force),
//! and check another engine against them ([`assert_same_hits`], or for peers with their own
//! kernels [`Agreement`]).

use geom::{Ray, Vec3};
use std::sync::Mutex;
use trace::{Hit, RayBatch, TraceMode, TraceStats, Tracer};

/// A tracer that forwards to `inner` and keeps every batch it was given with the answers.
/// Wrapping brute force records the oracle's answers; wrapping another engine records the
/// exact rays a render traced (benchmarks replay them for every configuration).
pub struct Recorder<'a> {
    /// The engine asked.
    pub inner: &'a dyn Tracer,
    /// Every batch traced, with its mode and the answers.
    pub batches: Mutex<Vec<(RayBatch, TraceMode, Vec<Hit>)>>,
}

impl<'a> Recorder<'a> {
    /// A recorder around `inner`.
    pub fn new(inner: &'a dyn Tracer) -> Self {
        Recorder {
            inner,
            batches: Mutex::new(Vec::new()),
        }
    }

    /// The recorded (rays, mode, hits), in trace order.
    pub fn into_batches(self) -> Vec<(RayBatch, TraceMode, Vec<Hit>)> {
        self.batches.into_inner().unwrap_or_else(|e| e.into_inner())
    }
}

impl Tracer for Recorder<'_> {
    fn name(&self) -> &str {
        self.inner.name()
    }

    fn trace(&self, rays: &RayBatch, mode: TraceMode, hits: &mut [Hit], stats: &mut TraceStats) {
        self.inner.trace(rays, mode, hits, stats);
        self.batches
            .lock()
            .unwrap_or_else(|e| e.into_inner())
            .push((rays.clone(), mode, hits.to_vec()));
    }
}

/// Trace `rays` with `engine` and panic (naming `what` and the ray) unless the result equals
/// `expect`: closest-hit records bit for bit (one shared kernel and tie rule), any-hit as
/// booleans.
pub fn assert_same_hits(
    engine: &dyn Tracer,
    rays: &RayBatch,
    mode: TraceMode,
    expect: &[Hit],
    what: &str,
) {
    let mut got = vec![Hit::MISS; rays.len()];
    engine.trace(rays, mode, &mut got, &mut TraceStats::default());
    for (i, (g, e)) in got.iter().zip(expect).enumerate() {
        match mode {
            TraceMode::Closest => assert_eq!(g, e, "{what}: ray {i} {:?}", rays.ray(i)),
            TraceMode::Any => {
                assert_eq!(g.is_hit(), e.is_hit(), "{what}: ray {i} {:?}", rays.ray(i))
            }
        }
    }
}

/// How a peer compares with the oracle when bit-identical records cannot be required:
/// Embree has its own triangle kernel, and obvhs's node tests are not conservative at box
/// faces (no Ize-style rounding), so both can decide differently on a ray that passes
/// (within rounding) through a triangle edge or vertex, which the watertight kernel
/// decides one consistent way.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Agreement {
    /// Rays compared.
    pub rays: u64,
    /// Same triangle and t within [`T_TOL`] (closest hit), or same boolean (any hit).
    pub same: u64,
    /// Different answers on a ray that passes within [`EDGE_EPS`] (relative) of a triangle
    /// edge or vertex ([`ray_grazes_edge`]), or (with `t_floor`) a lost oracle hit nearer
    /// than the peer can see.
    pub at_edges: u64,
    /// Both hit at the same t (within [`T_TOL`]) but on different triangles: coincident
    /// surfaces (overlapping coplanar triangles, as in BART Kitchen), where which one is
    /// "closest" is decided by rounding. The point hit is the same.
    pub coincident: u64,
    /// Anything else: a real disagreement. Tests require zero.
    pub wrong: u64,
    /// The first few wrong rays: (index, oracle, engine).
    pub examples: Vec<(usize, Hit, Hit)>,
}

/// t tolerance for kernels other than ours, relative to t + |origin|∞ (ulp-level
/// differences in how t is computed, amplified at grazing angles).
pub const T_TOL: f32 = 1e-4;
/// Relative distance between a ray and a triangle edge within which kernels may disagree
/// (single-precision rounding of the ray and the edge functions is ~1e-7 relative).
pub const EDGE_EPS: f32 = 1e-5;

impl Agreement {
    /// Compare `got` with the oracle's `expect` for `rays` over `tris`. Oracle hits with
    /// `t <= t_floor` may be lost (a peer that cannot see hits that near); 0 for none.
    /// A peer's record may lack a location (t not finite: Embree's any-hit answer).
    pub fn check(
        &mut self,
        tris: &[[Vec3; 3]],
        rays: &RayBatch,
        mode: TraceMode,
        expect: &[Hit],
        got: &[Hit],
        t_floor: f32,
    ) {
        for (i, (e, g)) in expect.iter().zip(got).enumerate() {
            self.rays += 1;
            // A kernel's t error scales with the coordinates involved (the origin and the
            // vertices), not only with t: e.g. Conference's walls, 2,500 units wide, hit
            // from 1 unit away by a ray at |o| = 1,000.
            let scale = (e.t.abs() + rays.org[i].abs().max_element()).max(1.0);
            let t_close = |a: &Hit, b: &Hit| (a.t - b.t).abs() <= T_TOL * scale;
            let ok = match mode {
                TraceMode::Any => e.is_hit() == g.is_hit(),
                TraceMode::Closest => {
                    e.is_hit() == g.is_hit() && (!e.is_hit() || (e.tri == g.tri && t_close(e, g)))
                }
            };
            if ok {
                self.same += 1;
                continue;
            }
            let near = e.is_hit() && e.t <= t_floor && (!g.is_hit() || g.t > e.t);
            let on_peer_triangle = || {
                // The peer's record must name a triangle that really passes through the
                // point it reports.
                let r = rays.ray(i);
                let p = r.org + r.dir * g.t;
                tris.get(g.tri as usize).is_some_and(|t| {
                    point_triangle_distance(p, t) <= T_TOL * scale * r.dir.length().max(1.0)
                })
            };
            if mode == TraceMode::Closest
                && e.is_hit()
                && g.is_hit()
                && t_close(e, g)
                && on_peer_triangle()
            {
                self.coincident += 1;
            } else if near || ray_grazes_edge(tris, &rays.ray(i), EDGE_EPS) {
                self.at_edges += 1;
            } else {
                self.wrong += 1;
                if self.examples.len() < 8 {
                    self.examples.push((i, *e, *g));
                }
            }
        }
    }
}

/// Distance from `p` to the triangle `t` (closest point by regions, Ericson 2005 §5.1.5).
pub fn point_triangle_distance(p: Vec3, t: &[Vec3; 3]) -> f32 {
    let [a, b, c] = t.map(|v| v.as_dvec3());
    let p = p.as_dvec3();
    let (ab, ac, ap) = (b - a, c - a, p - a);
    let (d1, d2) = (ab.dot(ap), ac.dot(ap));
    let q = if d1 <= 0.0 && d2 <= 0.0 {
        a
    } else {
        let bp = p - b;
        let (d3, d4) = (ab.dot(bp), ac.dot(bp));
        let cp = p - c;
        let (d5, d6) = (ab.dot(cp), ac.dot(cp));
        let vc = d1 * d4 - d3 * d2;
        let vb = d5 * d2 - d1 * d6;
        let va = d3 * d6 - d5 * d4;
        if d3 >= 0.0 && d4 <= d3 {
            b
        } else if vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0 {
            a + ab * (d1 / (d1 - d3))
        } else if d6 >= 0.0 && d5 <= d6 {
            c
        } else if vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0 {
            a + ac * (d2 / (d2 - d6))
        } else if va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0 {
            b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6)))
        } else {
            let den = va + vb + vc;
            if den == 0.0 {
                // Degenerate triangle: the nearest of its vertices will do.
                [a, b, c]
                    .into_iter()
                    .min_by(|x, y| (p - *x).length().total_cmp(&(p - *y).length()))
                    .unwrap_or(a)
            } else {
                a + ab * (vb / den) + ac * (vc / den)
            }
        }
    };
    (p - q).length() as f32
}

/// Whether `ray` passes within `eps` · (1 + |p|) of an edge (or vertex) of any triangle,
/// where p is the closest point: the rays on which triangle kernels may legitimately
/// disagree. O(rays × triangles); for tests.
pub fn ray_grazes_edge(tris: &[[Vec3; 3]], ray: &Ray, eps: f32) -> bool {
    let d = ray.dir.as_dvec3().normalize();
    let o = ray.org.as_dvec3();
    tris.iter().any(|t| {
        (0..3).any(|k| {
            let (a, b) = (t[k].as_dvec3(), t[(k + 1) % 3].as_dvec3());
            // Closest points of the line o + s·d and the segment a + r·(b − a), r ∈ [0, 1].
            let e = b - a;
            let w = o - a;
            let (ee, ed, ew, dw) = (e.dot(e), e.dot(d), e.dot(w), d.dot(w));
            let den = ee - ed * ed;
            let r = if ee == 0.0 {
                0.0
            } else if den.abs() < 1e-18 {
                (ew / ee).clamp(0.0, 1.0)
            } else {
                ((ew - ed * dw) / den).clamp(0.0, 1.0)
            };
            let q = a + e * r;
            let s = (q - o).dot(d);
            let p = o + d * s;
            (p - q).length() <= eps as f64 * (1.0 + q.length())
        })
    })
}
