//! Animation: keyframed rigid transforms per mesh (a transform chain of static matrices and
//! named tracks), vertex-animated meshes, and an animated camera. [`Scene::at_time`](crate::Scene::at_time) turns an
//! animated scene into the static scene of one instant, which every engine then rebuilds
//! its structures for (the papers' per-frame rebuild).
//!
//! Tracks follow BART (Lext et al. 2001), whose keys are Kochanek–Bartels splines: positions
//! and scales as cubic Hermite segments with TCB tangents, rotations as a squad spline of
//! quaternions. As in BART's `kbsplpos.c`/`kbsplrot.c`, the first and last key only shape the
//! tangents: the curve runs from key 1 to key n−2 and is clamped outside. Tracks with fewer
//! than four keys, and tracks from TOML scene files, interpolate linearly (rotations by slerp).

use crate::error::Invalid;
use geom::{Mat4, Quat, Sphere, Vec3};

/// One key of a vector track (translation or scale).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct VecKey {
    /// Key time (seconds, scene time).
    pub t: f32,
    /// Value at the key.
    pub v: Vec3,
    /// Kochanek–Bartels tension, continuity, bias.
    pub tcb: [f32; 3],
}

/// One key of a rotation track: a unit quaternion (from BART's axis + angle in degrees).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct RotKey {
    /// Key time (seconds, scene time).
    pub t: f32,
    /// Rotation at the key.
    pub q: Quat,
    /// Kochanek–Bartels tension, continuity, bias.
    pub tcb: [f32; 3],
}

/// How a track interpolates between keys.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Interp {
    /// BART: Kochanek–Bartels (4 keys or more; fewer fall back to linear).
    KochanekBartels,
    /// Linear translation and scale, slerp rotation.
    Linear,
}

/// A named rigid-motion track: translation, rotation and scale, each optional; the matrix is
/// T·R·S (BART's order).
#[derive(Clone, Debug, PartialEq)]
pub struct Track {
    /// The track's name (BART's `x` groups name the track they follow).
    pub name: String,
    /// Translation keys (none: no translation).
    pub translation: Vec<VecKey>,
    /// Rotation keys (none: no rotation).
    pub rotation: Vec<RotKey>,
    /// Scale keys (none: unit scale).
    pub scale: Vec<VecKey>,
    /// How keys are interpolated.
    pub interp: Interp,
    /// Repeat the keyed interval forever (TOML `loop = true`); BART tracks clamp.
    pub looping: bool,
}

/// One link of a mesh's transform chain, outermost first.
#[derive(Clone, Debug, PartialEq)]
pub enum Xform {
    /// A fixed matrix.
    Static(Mat4),
    /// Index into [`Animation::tracks`].
    Track(u32),
}

/// Vertex animation of one mesh: positions at key times, linearly interpolated, clamped.
#[derive(Clone, Debug, PartialEq)]
pub struct VertexKeys {
    /// Key times, increasing.
    pub times: Vec<f32>,
    /// `positions[k]` has one entry per mesh vertex.
    pub positions: Vec<Vec<Vec3>>,
}

/// A scene's motion: keyframed rigid tracks per transform chain and vertex keys per mesh.
#[derive(Clone, Debug, PartialEq)]
pub struct Animation {
    /// The animation interval and its suggested frame count (BART's `a` line).
    pub start: f32,
    /// End of the interval.
    pub end: f32,
    /// Suggested frame count over the interval.
    pub frames: u32,
    /// The rigid-motion tracks the chains refer to.
    pub tracks: Vec<Track>,
    /// Per mesh (same order as [`Scene::meshes`](crate::Scene::meshes)): the transform chain, outermost first.
    /// An empty chain leaves the mesh's own `transform`.
    pub chains: Vec<Vec<Xform>>,
    /// Per mesh: vertex animation, if any.
    pub vertex_keys: Vec<Option<VertexKeys>>,
    /// The camera's track (BART: the track named "camera"): translation = eye; the rotation
    /// turns the default view (looking along −z, y up).
    pub camera: Option<u32>,
    /// Object-space culling sphere of each mesh, valid at every time: the minimal ball of
    /// the mesh's vertices, or for vertex-animated meshes of all key positions together (an
    /// interpolated vertex lies on a segment between two key positions, inside the ball).
    pub local_spheres: Vec<Sphere>,
}

/// The keys a linear interpolation at time `t` mixes: (a, b, u), clamped to the first and
/// last key (a = b there). Otherwise the segment is the first in file order whose end time
/// exceeds `t`, as BART's reference code picks it (`kbsplpos.c`, `ComputeIAndU`), so that
/// tracks whose times repeat or go back evaluate as BART's own viewer does; for sorted times
/// this is the usual segment, and `t` always lies in the chosen one (u ∈ [0, 1)).
fn lerp_segment(times: impl Fn(usize) -> f32, n: usize, t: f32) -> (usize, usize, f32) {
    if n == 1 || t <= times(0) {
        return (0, 0, 0.0);
    }
    if t >= times(n - 1) {
        return (n - 1, n - 1, 0.0);
    }
    let i = (1..n).find(|&i| t < times(i)).unwrap_or(n - 1);
    let span = times(i) - times(i - 1);
    let u = if span > 0.0 {
        (t - times(i - 1)) / span
    } else {
        1.0
    };
    (i - 1, i, u)
}

/// A Kochanek–Bartels segment at time `t`: keys i−1 … i+2 shape the curve between keys i and
/// i+1 (1 ≤ i ≤ n−3, clamped as in BART), u ∈ [0, 1] along it, and the outgoing tangent
/// multipliers at key i and the incoming ones at key i+1 (Kochanek & Bartels 1984, with
/// BART's time adjustment for uneven key spacing).
struct KbSegment {
    i: usize,
    u: f32,
    out: [f32; 2],
    inc: [f32; 2],
}

fn kb_segment(
    times: impl Fn(usize) -> f32,
    tcb: impl Fn(usize) -> [f32; 3],
    n: usize,
    t: f32,
) -> KbSegment {
    let (i, u) = if t <= times(1) {
        (1, 0.0)
    } else if t >= times(n - 2) {
        (n - 3, 1.0)
    } else {
        let mut i = 1;
        while i < n - 3 && t >= times(i + 1) {
            i += 1;
        }
        let span = times(i + 1) - times(i);
        (
            i,
            if span > 0.0 {
                (t - times(i)) / span
            } else {
                1.0
            },
        )
    };
    let tk = [times(i - 1), times(i), times(i + 1), times(i + 2)];
    // BART's time adjustment, negative where times go back, as in the reference code.
    // Coincident times would divide by zero (NaN in the reference): such a key gets no
    // adjustment.
    let ratio = |a: f32, b: f32| if b != 0.0 { a / b } else { 0.5 };
    let adj0 = 2.0 * ratio(tk[2] - tk[1], tk[2] - tk[0]);
    let adj1 = 2.0 * ratio(tk[2] - tk[1], tk[3] - tk[1]);
    let [te0, c0, b0] = tcb(i);
    let [te1, c1, b1] = tcb(i + 1);
    KbSegment {
        i,
        u,
        out: [
            0.5 * adj0 * (1.0 - te0) * (1.0 + c0) * (1.0 + b0),
            0.5 * adj0 * (1.0 - te0) * (1.0 - c0) * (1.0 - b0),
        ],
        inc: [
            0.5 * adj1 * (1.0 - te1) * (1.0 - c1) * (1.0 + b1),
            0.5 * adj1 * (1.0 - te1) * (1.0 + c1) * (1.0 - b1),
        ],
    }
}

fn eval_vec(keys: &[VecKey], interp: Interp, t: f32) -> Option<Vec3> {
    let n = keys.len();
    if n == 0 {
        return None;
    }
    if interp == Interp::Linear || n < 4 {
        let (a, b, u) = lerp_segment(|k| keys[k].t, n, t);
        return Some(keys[a].v.lerp(keys[b].v, u));
    }
    let KbSegment { i, u, out: o, inc } = kb_segment(|k| keys[k].t, |k| keys[k].tcb, n, t);
    let (p0, p1, p2, p3) = (keys[i - 1].v, keys[i].v, keys[i + 1].v, keys[i + 2].v);
    let dp = p2 - p1;
    let tout = o[1] * dp + o[0] * (p1 - p0);
    let tin = inc[1] * (p3 - p2) + inc[0] * dp;
    // Hermite cubic C0 + C1 u + C2 u² + C3 u³.
    let c2 = 3.0 * dp - 2.0 * tout - tin;
    let c3 = -2.0 * dp + tout + tin;
    Some(p1 + u * (tout + u * (c2 + u * c3)))
}

fn qlog(q: Quat) -> Quat {
    // log of a unit quaternion: (θ·axis, 0) where q = (cos θ, sin θ·axis).
    let v = Vec3::new(q.x, q.y, q.z);
    let s = v.length();
    if s < 1e-6 {
        return Quat::from_xyzw(v.x, v.y, v.z, 0.0);
    }
    let th = s.atan2(q.w);
    let k = th / s;
    Quat::from_xyzw(v.x * k, v.y * k, v.z * k, 0.0)
}

fn qexp(q: Quat) -> Quat {
    let v = Vec3::new(q.x, q.y, q.z);
    let th = v.length();
    if th < 1e-6 {
        return Quat::from_xyzw(v.x, v.y, v.z, 1.0).normalize();
    }
    let k = th.sin() / th;
    Quat::from_xyzw(v.x * k, v.y * k, v.z * k, th.cos())
}

fn qscale(q: Quat, s: f32) -> Quat {
    Quat::from_xyzw(q.x * s, q.y * s, q.z * s, q.w * s)
}

fn eval_rot(keys: &[RotKey], interp: Interp, t: f32) -> Option<Quat> {
    let n = keys.len();
    if n == 0 {
        return None;
    }
    if interp == Interp::Linear || n < 4 {
        let (a, b, u) = lerp_segment(|k| keys[k].t, n, t);
        return Some(keys[a].q.slerp(keys[b].q, u));
    }
    let KbSegment { i, u, out: o, inc } = kb_segment(|k| keys[k].t, |k| keys[k].tcb, n, t);
    let q0 = keys[i - 1].q;
    let q1 = keys[i].q;
    let mut q2 = keys[i + 1].q;
    let q3 = keys[i + 2].q;
    // Consecutive quaternions at an acute angle (kbsplrot.c).
    if q1.dot(q2) < 0.0 {
        q2 = -q2;
    }
    let logdq = qlog(q1.inverse() * q2);
    let tout = qscale(logdq, o[1]) + qscale(qlog(q0.inverse() * q1), o[0]);
    let tin = qscale(logdq, inc[0]) + qscale(qlog(q2.inverse() * q3), inc[1]);
    let a = q1 * qexp(qscale(tout - logdq, 0.5));
    let b = q2 * qexp(qscale(logdq - tin, 0.5));
    // Squad(u; q1, a, b, q2) = Slerp(2u(1−u); Slerp(u; q1, q2), Slerp(u; a, b)).
    let s1 = slerp_raw(q1, q2, u);
    let s2 = slerp_raw(a, b, u);
    Some(slerp_raw(s1, s2, 2.0 * u * (1.0 - u)).normalize())
}

/// Slerp without shortest-path flipping (squad needs the arcs as given).
fn slerp_raw(a: Quat, b: Quat, u: f32) -> Quat {
    let d = a.dot(b).clamp(-1.0, 1.0);
    let th = d.acos();
    if th.abs() < 1e-5 {
        return qscale(a, 1.0 - u) + qscale(b, u);
    }
    let s = th.sin();
    qscale(a, ((1.0 - u) * th).sin() / s) + qscale(b, (u * th).sin() / s)
}

impl Track {
    fn local_time(&self, t: f32) -> f32 {
        if !self.looping {
            return t;
        }
        let all = self
            .translation
            .iter()
            .map(|k| k.t)
            .chain(self.rotation.iter().map(|k| k.t))
            .chain(self.scale.iter().map(|k| k.t));
        let (lo, hi) = all.fold((f32::INFINITY, f32::NEG_INFINITY), |(a, b), x| {
            (a.min(x), b.max(x))
        });
        if hi > lo {
            lo + (t - lo).rem_euclid(hi - lo)
        } else {
            t
        }
    }

    /// Translation, rotation and scale at time `t` (identity parts where a channel is absent).
    pub fn trs(&self, t: f32) -> (Vec3, Quat, Vec3) {
        let t = self.local_time(t);
        (
            eval_vec(&self.translation, self.interp, t).unwrap_or(Vec3::ZERO),
            eval_rot(&self.rotation, self.interp, t).unwrap_or(Quat::IDENTITY),
            eval_vec(&self.scale, self.interp, t).unwrap_or(Vec3::ONE),
        )
    }

    /// T·R·S at time `t`.
    pub fn matrix(&self, t: f32) -> Mat4 {
        let (tr, r, s) = self.trs(t);
        Mat4::from_scale_rotation_translation(s, r, tr)
    }
}

impl Animation {
    /// Every key finite (times, values, tension/continuity/bias) and every rotation a
    /// non-zero quaternion, so that no time of the animation yields a NaN vertex (a NaN
    /// rotation key in a TOML file loaded and made every frame after it NaN, found by
    /// fuzzing). Scale keys may be zero: a mesh scaled to nothing has no area and is hit
    /// by no ray.
    pub fn validate(&self) -> Result<(), Invalid> {
        if !(self.start.is_finite() && self.end.is_finite() && (self.end - self.start).is_finite())
        {
            return Err(Invalid::from(format!(
                "animation interval [{}, {}] must be finite (and so must its length)",
                self.start, self.end
            )));
        }
        let fin = |x: &[f32]| x.iter().all(|v| v.is_finite());
        for tr in &self.tracks {
            let bad = |what: &str, k: usize| {
                Err(Invalid::from(format!(
                    "animation track '{}': {what} key {} is not finite",
                    tr.name,
                    k + 1
                )))
            };
            for (what, keys) in [("translation", &tr.translation), ("scale", &tr.scale)] {
                if let Some(k) = keys
                    .iter()
                    .position(|k| !(fin(&[k.t]) && fin(&k.v.to_array()) && fin(&k.tcb)))
                {
                    return bad(what, k);
                }
            }
            if let Some(k) = tr.rotation.iter().position(|k| {
                !(fin(&[k.t]) && fin(&k.q.to_array()) && fin(&k.tcb) && k.q.length() > 1e-6)
            }) {
                return bad("rotation", k);
            }
        }
        for (m, keys) in self.vertex_keys.iter().enumerate() {
            if let Some(k) = keys {
                if !fin(&k.times) || k.positions.iter().any(|p| p.iter().any(|v| !v.is_finite())) {
                    return Err(Invalid::from(format!(
                        "vertex animation of mesh {m}: a key is not finite"
                    )));
                }
            }
        }
        Ok(())
    }

    /// The world transform of mesh `m` at time `t` (None: the mesh's own transform).
    pub fn mesh_transform(&self, m: usize, t: f32) -> Option<Mat4> {
        self.chain_product(m, |i| self.tracks[i].matrix(t))
    }

    /// Mesh m's chain, outermost first, multiplied out with `track(i)` for track i (None
    /// for an empty chain).
    fn chain_product(&self, m: usize, track: impl Fn(usize) -> Mat4) -> Option<Mat4> {
        let chain = self.chains.get(m)?;
        if chain.is_empty() {
            return None;
        }
        Some(chain.iter().fold(Mat4::IDENTITY, |acc, x| {
            acc * match x {
                Xform::Static(s) => *s,
                Xform::Track(i) => track(*i as usize),
            }
        }))
    }

    /// Every track's matrix at time `t`, each evaluated once (BART's hierarchy shares a
    /// node's track among all the meshes below it), in parallel.
    pub fn track_matrices(&self, t: f32) -> Vec<Mat4> {
        use rayon::prelude::*;
        self.tracks.par_iter().map(|tr| tr.matrix(t)).collect()
    }

    /// [`Animation::mesh_transform`] from the tracks' matrices at the frame's time
    /// ([`Animation::track_matrices`]): the same product, in the same order, so the same
    /// bits, without evaluating a shared track again for every mesh below it.
    pub fn mesh_transform_with(&self, m: usize, tracks: &[Mat4]) -> Option<Mat4> {
        self.chain_product(m, |i| tracks[i])
    }

    /// The times of `n` frames spread evenly over [start, end] (BART's `a` line).
    pub fn frame_times(&self, n: u32) -> Vec<f32> {
        (0..n)
            .map(|i| {
                if n <= 1 {
                    self.start
                } else {
                    // The fraction first: (end − start) · i overflows f32 for a long
                    // interval (an `end = 3e38` made frame 2 infinite, found by fuzzing).
                    self.start + (self.end - self.start) * (i as f32 / (n - 1) as f32)
                }
            })
            .collect()
    }
}

impl VertexKeys {
    /// The vertex positions at time `t` (linear between keys, clamped outside them).
    pub fn at(&self, t: f32) -> Vec<Vec3> {
        let (a, b, u) = lerp_segment(|k| self.times[k], self.times.len(), t);
        if a == b {
            return self.positions[a].clone();
        }
        self.positions[a]
            .iter()
            .zip(&self.positions[b])
            .map(|(p, q)| p.lerp(*q, u))
            .collect()
    }
}
