//! The Whitted loop's per-generation passes as kernels (`stages.wgsl`): shadow-ray
//! generation, reflection/refraction-ray generation and Blinn-Phong shading, the twins of
//! `render::secondary` and `render::shade`.
//!
//! `Surf` launches them on surfaces that live on the device: the GPU backend of the loop
//! ([`crate::frame::GpuBackend`]) runs them so. [`GpuStages`] runs the same launches on host
//! surfaces, one pass at a time (uploaded, run in parts that fit the device's bindings, read
//! back): what the pass tests compare with the CPU passes, whose rays the kernels reproduce
//! bit for bit (same operation order, unfused products); the shading uses the device's `pow`
//! for the specular exponent and may differ from the CPU's in the last bits.

use crate::device::Gpu;
use crate::kernels::params::StageParams;
use crate::kernels::{launch, DevLen, DevSize, Exec, Kernels, Threads};
use crate::rays::DeviceRays;
use geom::Vec3;
use render::secondary::Surfaces;
use scene::{Light, Material, Scene};
use std::cell::RefCell;
use trace::{RayBatch, RayKind};

/// The GPU passes on host surfaces, one at a time, with the seconds they took (wall clock,
/// including the transfers) per pass.
pub struct GpuStages<'g> {
    gpu: &'g Gpu,
    kernels: &'g Kernels,
    /// Seconds per pass (`shadow-ray kernel`, `shading kernel`, `bounce-ray kernel`).
    pub times: RefCell<Vec<(&'static str, f64)>>,
}

fn v4(v: Vec3, w: f32) -> [f32; 4] {
    [v.x, v.y, v.z, w]
}

/// `n` surfaces' buffers on the device (`stages.wgsl`'s surface arrays), and the launches
/// of the three passes over them, shared by the GPU backend ([`crate::frame`]) and the
/// per-pass [`GpuStages`].
pub(crate) struct Surf {
    pub pos: wgpu::Buffer,
    pub ng: wgpu::Buffer,
    pub ns: wgpu::Buffer,
    pub inc: wgpu::Buffer,
    pub tw: wgpu::Buffer,
    pub mat: wgpu::Buffer,
}

/// A part of surfaces whose count only the device holds, made ready for the launches over
/// it (one single-workgroup launch, once per part): the count, the count × lights (its
/// shadow rays) and the count × 2 (its bounce slots).
pub(crate) struct SurfSizes {
    pub one: DevSize,
    pub lights: DevSize,
    pub slots: DevSize,
}

impl SurfSizes {
    /// The sizes of `count` surfaces under `nl` lights.
    pub fn new(ex: &mut Exec, count: &DevLen, nl: u64) -> SurfSizes {
        let mut z = ex
            .sizes(count, &[(1, 256), (nl as u32, 256), (2, 256)])
            .into_iter();
        let mut next = || z.next().expect("three blocks");
        SurfSizes {
            one: next(),
            lights: next(),
            slots: next(),
        }
    }
}

impl Surf {
    /// Room for `n` surfaces (filled by the device frame's kernels).
    pub fn new(g: &Gpu, n: u64) -> Surf {
        Surf {
            pos: g.storage("surface pos", n * 16),
            ng: g.storage("surface ng", n * 16),
            ns: g.storage("surface ns", n * 16),
            inc: g.storage("surface incident", n * 16),
            tw: g.storage("surface throughput", n * 16),
            mat: g.storage("surface material", n * 4),
        }
    }

    /// The shadow rays of `n` surfaces with pixels `pix` and `nl` lights (`lights`:
    /// [`light_rows`]) into `rays` (segments, kind | light << 2 and pixel), ray
    /// `surface · nl + light`; `sz`: of the first `sz.one` of the `n` (a size on the device).
    #[allow(clippy::too_many_arguments)] // one launch: its bindings and sizes
    pub fn shadow_rays(
        &self,
        ex: &mut Exec,
        lights: &wgpu::Buffer,
        pix: &wgpu::Buffer,
        rays: &DeviceRays,
        n: u64,
        nl: u64,
        sz: Option<&SurfSizes>,
    ) {
        let threads = match sz {
            Some(z) => Threads::Device {
                first: &z.one,
                over: &z.lights,
            },
            None => Threads::Host(n * nl),
        };
        ex.run_on(
            launch::ShadowRays {
                s_pos: &self.pos,
                s_ng: &self.ng,
                s_tw: &self.tw,
                lights,
                o_org: &rays.org,
                o_dir: &rays.dir,
                s_pix: pix,
                o_kl: &rays.kl,
                o_pix: &rays.pix,
            },
            StageParams {
                surfaces: n as u32,
                lights: nl as u32,
            },
            threads,
            256,
        );
    }

    /// Local shading of `n` surfaces under `nl` lights into `colour`, with the shadow rays'
    /// hit records `shadow_rec` per (surface, light; a hit hides the light) and `mats`
    /// ([`material_rows`]); `sz`: of the first `sz.one`.
    #[allow(clippy::too_many_arguments)] // one launch: its bindings and sizes
    pub fn shade(
        &self,
        ex: &mut Exec,
        lights: &wgpu::Buffer,
        mats: &wgpu::Buffer,
        shadow_rec: &wgpu::Buffer,
        colour: &wgpu::Buffer,
        n: u64,
        nl: u64,
        sz: Option<&SurfSizes>,
    ) {
        ex.run_on(
            launch::ShadeLocal {
                s_pos: &self.pos,
                s_ng: &self.ng,
                s_ns: &self.ns,
                s_inc: &self.inc,
                s_tw: &self.tw,
                s_mat: &self.mat,
                lights,
                mats,
                o_w: colour,
                shadow_rec,
            },
            StageParams {
                surfaces: n as u32,
                lights: nl as u32,
            },
            Threads::of(sz.map(|z| &z.one), n),
            256,
        );
    }

    /// The bounce slots of `n` surfaces (2 per surface: origin, direction, weight + kind,
    /// and a filled flag); `sz`: of the first `sz.one`.
    pub fn bounce_rays(
        &self,
        ex: &mut Exec,
        mats: &wgpu::Buffer,
        slots: [&wgpu::Buffer; 4],
        n: u64,
        sz: Option<&SurfSizes>,
    ) {
        ex.run_on(
            launch::BounceRays {
                s_pos: &self.pos,
                s_ng: &self.ng,
                s_ns: &self.ns,
                s_inc: &self.inc,
                s_tw: &self.tw,
                s_mat: &self.mat,
                mats,
                o_org: slots[0],
                o_dir: slots[1],
                o_w: slots[2],
                o_flags: slots[3],
            },
            StageParams {
                surfaces: n as u32,
                lights: 0,
            },
            Threads::of(sz.map(|z| &z.one), n),
            256,
        );
    }
}

impl<'g> GpuStages<'g> {
    /// The passes on `gpu`, with its compiled `kernels` (an engine's, [`crate::GpuRsh::kernels`],
    /// or [`Kernels::new`]).
    pub fn new(gpu: &'g Gpu, kernels: &'g Kernels) -> Self {
        GpuStages {
            gpu,
            kernels,
            times: RefCell::new(Vec::new()),
        }
    }

    fn surf(&self, s: &Surfaces) -> Surf {
        let g = self.gpu;
        let f = |v: &[Vec3]| -> Vec<[f32; 4]> { v.iter().map(|&x| v4(x, 0.0)).collect() };
        let tw: Vec<[f32; 4]> = s
            .throughput
            .iter()
            .zip(&s.scale)
            .map(|(&t, &sc)| v4(t, sc))
            .collect();
        Surf {
            pos: g.upload("surface pos", &f(&s.pos)),
            ng: g.upload("surface ng", &f(&s.ng)),
            ns: g.upload("surface ns", &f(&s.ns)),
            inc: g.upload("surface incident", &f(&s.incident)),
            tw: g.upload("surface throughput", &tw),
            mat: g.upload("surface material", &s.material),
        }
    }

    fn lights(&self, lights: &[Light]) -> wgpu::Buffer {
        self.gpu.upload("lights", &light_rows(lights))
    }

    fn materials(&self, m: &[Material], ambient: Vec3) -> wgpu::Buffer {
        self.gpu.upload("materials", &material_rows(m, ambient))
    }

    fn timed<T>(&self, name: &'static str, f: impl FnOnce() -> T) -> T {
        let t0 = std::time::Instant::now();
        let r = f();
        let dt = t0.elapsed().as_secs_f64();
        let mut t = self.times.borrow_mut();
        match t.iter_mut().find(|x| x.0 == name) {
            Some(e) => e.1 += dt,
            None => t.push((name, dt)),
        }
        r
    }
}

/// The lights as `stages.wgsl` reads them: position + intensity, colour, attenuation.
pub(crate) fn light_rows(lights: &[Light]) -> Vec<[f32; 4]> {
    lights
        .iter()
        .flat_map(|l| {
            let [c, li, q] = l.attenuation;
            [
                v4(l.position, l.intensity),
                v4(l.color, 0.0),
                [c, li, q, 0.0],
            ]
        })
        .collect()
}

/// The materials as `stages.wgsl` reads them (diffuse + shininess, specular + reflectivity,
/// emission + transparency, ior + the ambient term); the ambient term k_a ⊙ L_a is multiplied
/// here, with the same f32 product as `render::shade::local`.
pub(crate) fn material_rows(m: &[Material], ambient: Vec3) -> Vec<[f32; 4]> {
    m.iter()
        .flat_map(|m| {
            let a = m.ambient * ambient;
            [
                v4(m.diffuse, m.shininess),
                v4(m.specular, m.reflectivity),
                v4(m.emission, m.transparency),
                [m.ior, a.x, a.y, a.z],
            ]
        })
        .collect()
}

fn ray_of(o: [f32; 4], d: [f32; 4]) -> geom::Ray {
    geom::Ray::new(
        Vec3::new(o[0], o[1], o[2]),
        Vec3::new(d[0], d[1], d[2]),
        o[3],
        d[3],
    )
}

impl GpuStages<'_> {
    fn shadow_rays_part(&self, s: &Surfaces, lights: &[Light]) -> RayBatch {
        let (n, nl) = (s.len(), lights.len());
        if n * nl == 0 {
            return RayBatch::default();
        }
        self.timed("shadow-ray kernel", || {
            let g = self.gpu;
            let mut ex = Exec::new(g, self.kernels);
            let sf = self.surf(s);
            let lb = self.lights(lights);
            let m = (n * nl) as u64;
            let pix = g.upload("surface pixel", &s.pixel);
            let rays = DeviceRays::storage(g, "shadow", m);
            sf.shadow_rays(&mut ex, &lb, &pix, &rays, n as u64, nl as u64, None);
            let o: Vec<[f32; 4]> = ex.read(&rays.org, m as usize);
            let d: Vec<[f32; 4]> = ex.read(&rays.dir, m as usize);
            let kl: Vec<u32> = ex.read(&rays.kl, m as usize);
            let px: Vec<u32> = ex.read(&rays.pix, m as usize);
            let mut b = RayBatch::with_capacity(m as usize);
            for k in 0..m as usize {
                let i = k / nl;
                // The kind, light and pixel as the kernel wrote them (the pass test
                // compares them with the CPU's).
                b.push(
                    ray_of(o[k], d[k]),
                    RayKind::from_u8((kl[k] & 3) as u8),
                    px[k],
                    kl[k] >> 2,
                    s.throughput[i],
                    s.depth[i],
                );
            }
            b
        })
    }

    fn local_shading_part(&self, s: &Surfaces, scene: &Scene, occluded: &[bool]) -> Vec<Vec3> {
        let (materials, lights) = (&scene.materials, &scene.lights);
        let n = s.len();
        if n == 0 {
            return Vec::new();
        }
        self.timed("shading kernel", || {
            let g = self.gpu;
            let mut ex = Exec::new(g, self.kernels);
            let sf = self.surf(s);
            let lb = self.lights(lights);
            let mb = self.materials(materials, scene.ambient);
            // As the engines' records: a hit (any triangle) or a miss.
            let occ: Vec<[u32; 4]> = occluded
                .iter()
                .map(|&o| match o {
                    true => [0, 0, 0, 0],
                    false => [geom::NO_HIT, f32::INFINITY.to_bits(), 0, 0],
                })
                .collect();
            let ob = g.upload("shadow records", &occ);
            let out = g.storage("colour", n as u64 * 16);
            sf.shade(
                &mut ex,
                &lb,
                &mb,
                &ob,
                &out,
                n as u64,
                lights.len() as u64,
                None,
            );
            let c: Vec<[f32; 4]> = ex.read(&out, n);
            c.iter().map(|c| Vec3::new(c[0], c[1], c[2])).collect()
        })
    }

    fn bounce_rays_part(&self, s: &Surfaces, materials: &[Material]) -> RayBatch {
        let n = s.len();
        if n == 0 {
            return RayBatch::default();
        }
        self.timed("bounce-ray kernel", || {
            let g = self.gpu;
            let mut ex = Exec::new(g, self.kernels);
            let sf = self.surf(s);
            let mb = self.materials(materials, Vec3::ZERO);
            let m = 2 * n as u64;
            let (org, dir, w, filled) = (
                g.storage("org", m * 16),
                g.storage("dir", m * 16),
                g.storage("weight", m * 16),
                g.storage("filled", m * 4),
            );
            sf.bounce_rays(&mut ex, &mb, [&org, &dir, &w, &filled], n as u64, None);
            let o: Vec<[f32; 4]> = ex.read(&org, m as usize);
            let d: Vec<[f32; 4]> = ex.read(&dir, m as usize);
            let wt: Vec<[f32; 4]> = ex.read(&w, m as usize);
            let fl: Vec<u32> = ex.read(&filled, m as usize);
            let mut b = RayBatch::default();
            // Slots in order: surface-major, reflection before refraction (the CPU's order).
            for k in 0..m as usize {
                // Compacted by the flag, as the frame does (a flag that disagrees with the
                // kind makes a ray the CPU's batch does not have, or loses one).
                if fl[k] == 0 {
                    continue;
                }
                let kind = match wt[k][3] as u32 {
                    2 => RayKind::Reflection,
                    3 => RayKind::Refraction,
                    _ => RayKind::Primary,
                };
                let i = k / 2;
                b.push(
                    ray_of(o[k], d[k]),
                    kind,
                    s.pixel[i],
                    0,
                    Vec3::new(wt[k][0], wt[k][1], wt[k][2]),
                    s.depth[i],
                );
            }
            b
        })
    }

    /// Surfaces per part when each costs `bytes` in the largest binding of a pass: the
    /// device's binding and buffer limits bound a part, never the work (a 3000² frame's
    /// shadow rays exceed lavapipe's 128 MiB binding and are made in two parts).
    fn part(&self, bytes: u64) -> usize {
        let lim = &self.gpu.limits;
        let cap = lim.max_storage_buffer_binding_size.min(lim.max_buffer_size);
        ((cap / bytes.max(1)) as usize).max(1)
    }

    /// The surfaces in parts of at most `per`.
    fn parts(n: usize, per: usize) -> impl Iterator<Item = std::ops::Range<usize>> {
        (0..n).step_by(per).map(move |a| a..(a + per).min(n))
    }
}

/// Each pass runs on parts of the surfaces that fit the device's bindings; surfaces are
/// independent, so the parts' results, in order, are the whole's.
impl GpuStages<'_> {
    /// Shadow rays, one per (surface, light), surface-major (`secondary::shadow_rays`).
    pub fn shadow_rays(&self, s: &Surfaces, lights: &[Light]) -> RayBatch {
        // Per surface: one origin and one direction (vec4) per light.
        let per = self.part(16 * lights.len().max(1) as u64);
        let mut b = RayBatch::default();
        for r in Self::parts(s.len(), per) {
            b.append(self.shadow_rays_part(&s.slice(r), lights));
        }
        b
    }

    /// Local illumination of every surface times its throughput (`shade::local`);
    /// `occluded[i · lights + l]` says whether light l is hidden from surface i.
    pub fn local_shading(&self, s: &Surfaces, scene: &Scene, occluded: &[bool]) -> Vec<Vec3> {
        // Per surface: a vec4 per surface array and the colour, a u32 per light.
        let nl = scene.lights.len();
        let per = self.part(16u64.max(4 * nl as u64));
        let mut c = Vec::with_capacity(s.len());
        for r in Self::parts(s.len(), per) {
            let occ = &occluded[r.start * nl..r.end * nl];
            c.extend(self.local_shading_part(&s.slice(r), scene, occ));
        }
        c
    }

    /// Reflection and refraction rays (`secondary::bounce_rays`).
    pub fn bounce_rays(&self, s: &Surfaces, materials: &[Material]) -> RayBatch {
        // Per surface: two ray slots of origin, direction and weight (vec4 each).
        let per = self.part(32);
        let mut b = RayBatch::default();
        for r in Self::parts(s.len(), per) {
            b.append(self.bounce_rays_part(&s.slice(r), materials));
        }
        b
    }
}
