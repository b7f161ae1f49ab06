//! The Embree 3 peer, through the raw bindings of the `embree` crate (its safe wrappers tie
//! the scene's lifetime to a borrow of the device, which an engine object cannot hold).
//!
//! One triangle geometry holds the whole flat scene, so Embree's `primID` is our triangle id.
//! Embree's kernel is its own (not watertight by default), so its records agree with ours on
//! the triangle and on t within a tolerance, not bit for bit.

use embree::sys::*;
use rayon::prelude::*;
use scene::Geometry;
use std::time::Instant;
use trace::{Hit, RayBatch, TraceMode, TraceStats, Tracer};

/// How rays are handed to Embree.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum EmbreeMode {
    /// `rtcIntersect1` / `rtcOccluded1`, one call per ray (incoherent context).
    Single,
    /// `rtcIntersect1M` / `rtcOccluded1M` on streams of [`STREAM`] rays (coherent context),
    /// Embree's stream API.
    Stream,
}

/// The triangle id of an Embree any-hit record: `rtcOccluded` says that something is hit,
/// not what.
pub const OCCLUDED: u32 = u32::MAX - 1;

/// Rays per stream call.
pub const STREAM: usize = 256;

/// Embree's device and committed scene.
pub struct EmbreeEngine {
    device: RTCDevice,
    scene: RTCScene,
    mode: EmbreeMode,
    /// Wall time of geometry upload and `rtcCommitScene`.
    pub build_seconds: f64,
}

// SAFETY: Embree documents a committed scene as safe for concurrent ray queries from any
// thread; the handles are only released in `drop`, which needs exclusive ownership.
unsafe impl Send for EmbreeEngine {}
unsafe impl Sync for EmbreeEngine {}

/// Why Embree could not build its scene.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("embree: {0}")]
pub struct EmbreeError(pub String);

fn check(device: RTCDevice, what: &str) -> Result<(), EmbreeError> {
    // SAFETY: `device` is a live handle (or null, which Embree accepts for the thread-local
    // error of device creation).
    let e = unsafe { rtcGetDeviceError(device) };
    if e == RTCError::NONE {
        Ok(())
    } else {
        Err(EmbreeError(format!("{what} failed: {e:?}")))
    }
}

impl EmbreeEngine {
    /// Upload the triangles and build Embree's BVH (default build quality, default scene
    /// flags: Embree's standard configuration for a static scene).
    pub fn new(geo: &Geometry, mode: EmbreeMode) -> Result<Self, EmbreeError> {
        let start = Instant::now();
        let n = geo.tris.len();
        if n as u64 * 3 > u32::MAX as u64 {
            return Err(EmbreeError(format!(
                "{n} triangles exceed 32-bit vertex indices"
            )));
        }
        // SAFETY: plain FFI calls on handles created here; buffers are written within the
        // item counts they were allocated with.
        unsafe {
            let device = rtcNewDevice(std::ptr::null());
            if device.is_null() {
                check(std::ptr::null_mut(), "rtcNewDevice")?;
                return Err(EmbreeError("rtcNewDevice returned no device".into()));
            }
            let scene = rtcNewScene(device);
            let engine = EmbreeEngine {
                device,
                scene,
                mode,
                build_seconds: 0.0,
            };
            check(device, "rtcNewScene")?;
            if n > 0 {
                let g = rtcNewGeometry(device, RTCGeometryType::TRIANGLE);
                check(device, "rtcNewGeometry")?;
                let vb = rtcSetNewGeometryBuffer(
                    g,
                    RTCBufferType::VERTEX,
                    0,
                    RTCFormat::FLOAT3,
                    12,
                    3 * n,
                ) as *mut [f32; 3];
                let ib =
                    rtcSetNewGeometryBuffer(g, RTCBufferType::INDEX, 0, RTCFormat::UINT3, 12, n)
                        as *mut [u32; 3];
                if vb.is_null() || ib.is_null() {
                    rtcReleaseGeometry(g);
                    check(device, "rtcSetNewGeometryBuffer")?;
                    return Err(EmbreeError("buffer allocation failed".into()));
                }
                let verts = std::slice::from_raw_parts_mut(vb, 3 * n);
                let idx = std::slice::from_raw_parts_mut(ib, n);
                for (i, t) in geo.tris.iter().enumerate() {
                    for k in 0..3 {
                        verts[3 * i + k] = t[k].to_array();
                    }
                    let b = 3 * i as u32;
                    idx[i] = [b, b + 1, b + 2];
                }
                rtcCommitGeometry(g);
                rtcAttachGeometry(scene, g);
                rtcReleaseGeometry(g);
                check(device, "geometry set-up")?;
            }
            rtcCommitScene(scene);
            check(device, "rtcCommitScene")?;
            // (Not `..engine`: that would copy the handles and release them with `engine`.)
            let mut engine = engine;
            engine.build_seconds = start.elapsed().as_secs_f64();
            Ok(engine)
        }
    }

    fn context(coherent: bool) -> RTCIntersectContext {
        RTCIntersectContext {
            flags: if coherent {
                RTCIntersectContextFlags::COHERENT
            } else {
                RTCIntersectContextFlags::INCOHERENT
            },
            filter: None,
            instID: [u32::MAX; 1],
        }
    }

    fn rtc_ray(rays: &RayBatch, i: usize) -> RTCRay {
        let (o, d) = (rays.org[i], rays.dir[i]);
        // Embree's interval is closed, ours open (t_min < t < t_max); an empty or NaN
        // interval is a miss for both, so pass one Embree also treats as empty.
        let (tnear, tfar) = if rays.t_max[i] > rays.t_min[i] {
            (rays.t_min[i].max(0.0), rays.t_max[i])
        } else {
            (1.0, 0.0)
        };
        RTCRay {
            org_x: o.x,
            org_y: o.y,
            org_z: o.z,
            tnear,
            dir_x: d.x,
            dir_y: d.y,
            dir_z: d.z,
            time: 0.0,
            tfar,
            mask: u32::MAX,
            id: i as u32,
            flags: 0,
        }
    }

    fn empty_hit() -> RTCHit {
        RTCHit {
            Ng_x: 0.0,
            Ng_y: 0.0,
            Ng_z: 0.0,
            u: 0.0,
            v: 0.0,
            primID: u32::MAX,
            geomID: u32::MAX,
            instID: [u32::MAX; 1],
        }
    }

    fn record(rh: &RTCRayHit) -> Hit {
        if rh.hit.geomID == u32::MAX {
            Hit::MISS
        } else {
            Hit {
                tri: rh.hit.primID,
                t: rh.ray.tfar,
                u: rh.hit.u,
                v: rh.hit.v,
            }
        }
    }

    /// Trace `rays[range]` into `out` (same length as the range).
    fn trace_chunk(&self, rays: &RayBatch, first: usize, mode: TraceMode, out: &mut [Hit]) {
        // SAFETY: the scene is committed and outlives the call; ray structs are stack or
        // vector memory of the right layout, and the stream stride is the struct size.
        unsafe {
            match (self.mode, mode) {
                (EmbreeMode::Single, TraceMode::Closest) => {
                    let mut ctx = Self::context(false);
                    for (k, o) in out.iter_mut().enumerate() {
                        let mut rh = RTCRayHit {
                            ray: Self::rtc_ray(rays, first + k),
                            hit: Self::empty_hit(),
                        };
                        rtcIntersect1(self.scene, &mut ctx, &mut rh);
                        *o = Self::record(&rh);
                    }
                }
                (EmbreeMode::Single, TraceMode::Any) => {
                    let mut ctx = Self::context(false);
                    for (k, o) in out.iter_mut().enumerate() {
                        let mut r = Self::rtc_ray(rays, first + k);
                        rtcOccluded1(self.scene, &mut ctx, &mut r);
                        *o = Self::occluded_record(&r);
                    }
                }
                (EmbreeMode::Stream, TraceMode::Closest) => {
                    let mut ctx = Self::context(true);
                    let mut buf: Vec<RTCRayHit> = (0..out.len())
                        .map(|k| RTCRayHit {
                            ray: Self::rtc_ray(rays, first + k),
                            hit: Self::empty_hit(),
                        })
                        .collect();
                    rtcIntersect1M(
                        self.scene,
                        &mut ctx,
                        buf.as_mut_ptr(),
                        buf.len() as u32,
                        std::mem::size_of::<RTCRayHit>(),
                    );
                    for (o, rh) in out.iter_mut().zip(&buf) {
                        *o = Self::record(rh);
                    }
                }
                (EmbreeMode::Stream, TraceMode::Any) => {
                    let mut ctx = Self::context(true);
                    let mut buf: Vec<RTCRay> = (0..out.len())
                        .map(|k| Self::rtc_ray(rays, first + k))
                        .collect();
                    rtcOccluded1M(
                        self.scene,
                        &mut ctx,
                        buf.as_mut_ptr(),
                        buf.len() as u32,
                        std::mem::size_of::<RTCRay>(),
                    );
                    for (o, r) in out.iter_mut().zip(&buf) {
                        *o = Self::occluded_record(r);
                    }
                }
            }
        }
    }

    /// `rtcOccluded` reports a hit by setting `tfar` to −∞ and says nothing of which
    /// triangle; any-hit callers only read `is_hit`, so the record names no real triangle.
    fn occluded_record(r: &RTCRay) -> Hit {
        if r.tfar == f32::NEG_INFINITY {
            Hit {
                tri: OCCLUDED,
                t: f32::NAN,
                u: 0.0,
                v: 0.0,
            }
        } else {
            Hit::MISS
        }
    }
}

impl Drop for EmbreeEngine {
    fn drop(&mut self) {
        // SAFETY: the handles were created in `new` and are released once.
        unsafe {
            rtcReleaseScene(self.scene);
            rtcReleaseDevice(self.device);
        }
    }
}

impl Tracer for EmbreeEngine {
    fn name(&self) -> &str {
        match self.mode {
            EmbreeMode::Single => "embree",
            EmbreeMode::Stream => "embree-stream",
        }
    }

    fn trace(&self, rays: &RayBatch, mode: TraceMode, hits: &mut [Hit], stats: &mut TraceStats) {
        assert_eq!(hits.len(), rays.len(), "one hit record per ray");
        hits.par_chunks_mut(STREAM)
            .enumerate()
            .for_each(|(c, out)| self.trace_chunk(rays, c * STREAM, mode, out));
        stats.rays += rays.len() as u64;
        stats.hits += hits.iter().filter(|h| h.is_hit()).count() as u64;
    }
}
