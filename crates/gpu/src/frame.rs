//! The GPU backend of the Whitted loop ([`render::whitted::run`], thesis chapter 3,
//! Figure 3.1): the twin of [`render::cpu::CpuBackend`] with every step a kernel and
//! nothing but the image and a few totals crossing to the host.
//!
//! Rasterize into a G-buffer that stays on the device ([`GpuRaster::rasterize_device`]) →
//! surfaces of the covered pixels (`frame.wgsl`, compacted by the backend's scan) → per
//! generation: shadow rays (`stages.wgsl`) traced by the engine on the device
//! ([`GpuEngine::trace_device_part`]) → Blinn-Phong shading, reading the shadow rays'
//! records → colours added to their pixels; reflection/refraction rays (`stages.wgsl`,
//! compacted) → traced → the background behind the misses → the next generation's surfaces
//! from the hits. Finally the image is encoded to sRGB bytes on the device and read back.
//!
//! A generation's surfaces are held in parts of at most [`GpuBackend::part_size`] surfaces,
//! so that every buffer a kernel binds (a part's shadow rays, bounce slots, hits) fits one
//! binding of the device however many surfaces the bounces spawn; parts are processed in
//! order, so the sums are the same as in one part. A frame of ordinary size is one part.
//!
//! What the host reads back per frame: once, at the end, the sRGB image (3 bytes per
//! pixel) with the engine's counts of every trace of the frame, which stayed on the device
//! until then ([`GpuEngine::take_pending`]: CRSH's single-ray counter blocks, the grid's step
//! and test sums, 20 bytes per 1024 rays), and the generations' sizes ([`sizes`]). A
//! generation's size is counted by a scan on the device and stays there: its buffers are
//! allocated at its bound (one surface per covered pixel or bounce ray, at most two bounce
//! rays per surface, as the scene's materials allow), and every launch over them, the engine's included
//! ([`GpuEngine::trace_device_counted`]), reads it there through an indirect dispatch. Only
//! where the bound would not fit (one binding, the engine's part, the memory budget), or the
//! engine sizes its passes on the host (the thesis's bundles behind mesh spheres), is a size
//! read back (4 bytes) to allocate exactly. The dual traversal (CRSH's or RAH's bundles
//! through the object tree) is paced by the device alone; where one of its traces did not
//! finish (too few rounds, too little room), [`render_frame`] traces the frame again with
//! the host pacing. The launches' parameter blocks go the other way.
//! [`crate::Gpu::bytes_moved`] counts every one of them.
//!
//! The pixel accumulation is order-independent of scheduling: one thread per run of equal
//! pixels adds that pixel's colours in surface order, which is the CPU loop's order, so a
//! frame's image bytes depend only on its inputs.

use crate::device::{Gpu, GpuError};
use crate::kernels::params::{
    EncodeParams, FrameCountParams, GbFlagsParams, GbSurfacesParams, HitSurfacesParams,
    KindCountParams, MissesParams,
};
use crate::kernels::{launch, DevLen, DevSize, Exec, Threads};
use crate::raster::{DeviceGBuffer, GpuRaster};
use crate::rays::DeviceRays;
use crate::stages::{Surf, SurfSizes};
use crate::GpuEngine;

pub mod sizes;
mod totals;
use render::raster::{GBuffer, RasterStats};
use render::stats::{FramePhase, RenderStats};
use render::whitted::{Backend, RenderOptions, Rendered};
use render::View;
use scene::Scene;
use sizes::{Capacity, Counted, Deferrals};
use std::time::Instant;
pub(crate) use totals::{copy_pending, sum_totals, totals_on_device, TOTALS_CHUNK};
pub use totals::{settle, trace_device};
use trace::{TraceMode, TraceStats};

/// One part of a generation's surfaces on the device: `stages.wgsl`'s six arrays and their
/// pixels.
pub struct DeviceSurfaces {
    s: Surf,
    pix: wgpu::Buffer,
    /// The surfaces, or with `sizes` their bound (the buffers' room).
    len: u64,
    /// A count only the device holds ([`sizes`]), made ready for the launches over it.
    sizes: Option<SurfSizes>,
}

impl DeviceSurfaces {
    fn new(g: &Gpu, n: u64) -> DeviceSurfaces {
        DeviceSurfaces {
            s: Surf::new(g, n),
            pix: g.storage("surface pixel", n * 4),
            len: n,
            sizes: None,
        }
    }
}

/// One part of a ray batch on the device: the rays, and a bounce ray's weight (shadow rays
/// carry none: their surface's throughput applies).
pub struct DeviceBatch {
    /// The rays; with `count`, `rays.len` is their bound.
    rays: DeviceRays,
    weight: Option<wgpu::Buffer>,
    /// A bounce batch's refraction rays (counted on the device as it was made).
    refractions: u64,
    /// A count only the device holds ([`sizes`]), and a bounce batch's per-chunk
    /// refraction counts (buffer, words) left there with it.
    count: Option<(DevSize, Option<(wgpu::Buffer, u64)>)>,
}

/// `n` in parts of at most `per` (one empty part when `n` is 0, so that a launch that
/// makes no surface still runs, as it always did).
fn parts(n: u64, per: u64) -> Vec<(u64, u64)> {
    if n == 0 {
        return vec![(0, 0)];
    }
    (0..n.div_ceil(per))
        .map(|k| (k * per, per.min(n - k * per)))
        .collect()
}

/// Why a frame cannot run on the device at all (`None`: it can): the G-buffer's targets and
/// the image must each fit one binding, and its pixels index in u32. A generation's rays
/// never stop a frame: they come in parts that fit ([`GpuBackend::part_size`]).
pub fn too_big(gpu: &Gpu, opts: &RenderOptions) -> Option<String> {
    let cap = gpu.max_binding().min(gpu.limits.max_buffer_size);
    // The G-buffer's targets (rows padded to 256 bytes) and the image, 16 bytes per pixel.
    let gbuffer = (opts.width as u64 * 16).next_multiple_of(256) * opts.height as u64;
    if gbuffer > cap {
        return Some(format!(
            "the G-buffer needs {} MiB in one binding (the device allows {} MiB)",
            gbuffer >> 20,
            cap >> 20
        ));
    }
    None
}

/// A frame rendered on the device ([`render_frame`]).
pub struct DeviceFrame {
    /// The frame.
    pub out: Rendered,
    /// Whether a generation came in more than one part ([`GpuBackend::in_parts`]).
    pub in_parts: bool,
    /// Whether it was traced twice: a trace the device paced alone did not finish, so the
    /// host paced the second ([`GpuEngine::take_incomplete`]).
    pub again: bool,
}

/// One frame of `scene` (its geometry `geo`) on `engine`'s device: [`render::whitted::run`]
/// over a [`GpuBackend`] (with `keep_gbuffer`, the G-buffer read back too). Where a trace
/// that the device paced alone did not finish (it is seen with the image, in the frame's
/// one read-back), the frame is traced again with the host pacing every trace, and the
/// engine takes more rounds or room in later frames; the read-backs and dispatches of both
/// are the frame's.
pub fn render_frame(
    engine: &dyn GpuEngine,
    raster: &GpuRaster,
    scene: &Scene,
    geo: &scene::Geometry,
    opts: &RenderOptions,
    progress: &dyn render::whitted::Progress,
    keep_gbuffer: bool,
) -> Result<DeviceFrame, GpuError> {
    let mut b = GpuBackend::new(engine, raster, scene, opts, keep_gbuffer)?;
    let out = render::whitted::run(&mut b, scene, geo, opts, progress);
    if !engine.take_incomplete() {
        let in_parts = b.in_parts;
        return Ok(DeviceFrame {
            out,
            in_parts,
            again: false,
        });
    }
    engine.pace(true);
    let again = GpuBackend::new(engine, raster, scene, opts, keep_gbuffer).map(|mut b| {
        let out = render::whitted::run(&mut b, scene, geo, opts, progress);
        (out, b.in_parts)
    });
    engine.pace(false);
    let (out, in_parts) = again?;
    Ok(DeviceFrame {
        out,
        in_parts,
        again: true,
    })
}

/// A frame of one scene on `engine`'s device (see the module's documentation). A caller
/// that runs [`render::whitted::run`] over it directly, not through [`render_frame`], must
/// check [`GpuEngine::take_incomplete`] afterwards: a trace the device paced alone that did
/// not finish leaves a frame that is not the CPU's.
pub struct GpuBackend<'a> {
    engine: &'a dyn GpuEngine,
    raster: &'a GpuRaster,
    scene: &'a Scene,
    g: &'a Gpu,
    ex: Exec<'a>,
    part: u64,
    lights: wgpu::Buffer,
    mats: wgpu::Buffer,
    gb: Option<DeviceGBuffer>,
    img: Option<wgpu::Buffer>,
    npix: u64,
    host_gbuffer: Option<GBuffer>,
    keep_gbuffer: bool,
    /// Which generations may stay device-sized.
    cap: Capacity,
    /// Most bounce rays a surface spawns in this scene: 1 for a material that reflects, 1
    /// more if it is also transparent (`stages.wgsl`'s bounce slots), the most of any
    /// material; 0: no generation after the first.
    per_surface: u64,
    /// The counts device-sized generations left on the device, read with the image.
    deferred: Deferrals,
    /// Whether a generation came in more than one part.
    pub in_parts: bool,
}

impl<'a> GpuBackend<'a> {
    /// A frame of `scene` with `engine` (built over the scene's geometry) and `raster`
    /// (holding it, on the engine's device), of `opts`'s size; with `keep_gbuffer` the
    /// G-buffer is also read back to the host (for a view of it), else only the image comes
    /// back.
    pub fn new(
        engine: &'a dyn GpuEngine,
        raster: &'a GpuRaster,
        scene: &'a Scene,
        opts: &RenderOptions,
        keep_gbuffer: bool,
    ) -> Result<Self, GpuError> {
        let g = engine.gpu();
        raster.check_size(opts.width, opts.height)?;
        if let Some(why) = too_big(g, opts) {
            return Err(GpuError::Limits(why));
        }
        // Counts a frame that stopped short left behind are not this frame's.
        drop(engine.take_pending());
        let part = Self::part_size(g, scene);
        let cap = Capacity {
            engine: engine.counts_on_device(),
            part,
            rays: engine.max_rays() as u64,
            lights: scene.lights.len() as u64,
            budget: sizes::BUDGET,
        };
        Ok(GpuBackend {
            engine,
            raster,
            scene,
            g,
            ex: Exec::new(g, engine.kernels()),
            part,
            lights: g.upload("lights", &crate::stages::light_rows(&scene.lights)),
            mats: g.upload(
                "materials",
                &crate::stages::material_rows(&scene.materials, scene.ambient),
            ),
            gb: None,
            img: None,
            npix: 0,
            host_gbuffer: None,
            keep_gbuffer,
            cap,
            per_surface: scene
                .materials
                .iter()
                .map(|m| (m.reflectivity > 0.0) as u64 + (m.transparency > 0.0) as u64)
                .max()
                .unwrap_or(0),
            deferred: Deferrals::default(),
            in_parts: false,
        })
    }

    /// At most `bytes` for one generation's buffers sized by its bound instead of its count
    /// ([`sizes`]; default [`sizes::BUDGET`]): a generation over it reads its count back.
    /// 0 reads every count back, as a device without room for bounds would.
    pub fn with_sized_budget(mut self, bytes: u64) -> Self {
        self.cap.budget = bytes;
        self
    }

    /// The most surfaces of one part: its shadow rays (a vec4 origin and direction per
    /// light) and bounce slots (two per surface) must fit one binding, and index in u32.
    pub fn part_size(g: &Gpu, scene: &Scene) -> u64 {
        let cap = g.max_binding().min(g.limits.max_buffer_size);
        let per = scene.lights.len().max(2) as u64;
        (cap / (16 * per)).min(u32::MAX as u64 / per).max(1)
    }

    /// `words` of `buf` read back, and with them, in the same read-back, the counter blocks
    /// the engine left on the device ([`GpuEngine::take_pending`]), whose counts go into
    /// `stats`.
    fn read_with_counts<T: bytemuck::Pod>(
        &mut self,
        buf: &wgpu::Buffer,
        words: u64,
        stats: &mut RenderStats,
    ) -> Vec<T> {
        let pending = self.engine.take_pending();
        let engine: u64 = pending.iter().map(|p| p.1).sum();
        let sizes = self.deferred.words();
        if engine + sizes == 0 {
            return self.ex.read(buf, words as usize);
        }
        let all = self
            .g
            .storage("image and counters", (words + engine + sizes) * 4);
        self.ex.copy(buf, 0, &all, words * 4);
        copy_pending(&mut self.ex, &pending, &all, words * 4);
        self.deferred.copy(&mut self.ex, &all, (words + engine) * 4);
        let raw: Vec<u32> = self.ex.read(&all, (words + engine + sizes) as usize);
        let (w, e) = (words as usize, (words + engine) as usize);
        self.engine.settle(&raw[w..e], &mut stats.trace);
        self.deferred.settle(&raw[e..], stats);
        bytemuck::cast_slice(&raw[..w]).to_vec()
    }

    /// Room for the surfaces a scan of `n` flags into `offs` places (their count at
    /// `offs[n]`), as (first surface, part) pairs: where the bound `n` fits ([`sizes`]),
    /// one part at the bound whose count stays on the device (returned, for the
    /// statistics); else the count read back and the surfaces split into exact parts.
    fn place(
        &mut self,
        offs: &wgpu::Buffer,
        n: u64,
    ) -> (Vec<(u64, DeviceSurfaces)>, Option<DevLen>) {
        let g = self.g;
        if self.cap.fits(n) {
            let count = DevLen {
                buf: offs.clone(),
                at: n,
                cap: n,
            };
            let mut s = DeviceSurfaces::new(g, n);
            s.sizes = Some(SurfSizes::new(&mut self.ex, &count, self.cap.lights));
            return (vec![(0, s)], Some(count));
        }
        let placed = self.ex.read_at(offs, n as usize) as u64;
        let p = parts(placed, self.part);
        self.in_parts |= p.len() > 1;
        let parts = p
            .into_iter()
            .map(|(first, count)| (first, DeviceSurfaces::new(g, count)))
            .collect();
        (parts, None)
    }
}

impl Backend for GpuBackend<'_> {
    type Surfaces = Vec<DeviceSurfaces>;
    type Rays = Vec<DeviceBatch>;
    type Hits = Vec<wgpu::Buffer>;

    fn engine_name(&self) -> String {
        self.engine.name().to_string()
    }

    fn rasterize(&mut self, view: &View, near: f32) {
        self.gb = Some(self.raster.rasterize_device(view, near));
        if self.keep_gbuffer {
            self.host_gbuffer = Some(self.raster.rasterize(view, near).0);
        }
    }

    fn primary_surfaces(&mut self, view: &View) -> Vec<DeviceSurfaces> {
        let g = self.g;
        let (w, h) = (view.width, view.height);
        let npix = w as u64 * h as u64;
        self.npix = npix;
        let bg = self.scene.background;
        let img = g.storage("image", npix * 16);
        let gb = self.gb.take().expect("rasterized first");
        let (tris, _, material) = self.raster.scene_buffers();
        let ex = &mut self.ex;
        let flags = g.storage("covered", npix * 4);
        let offs = g.storage("covered offsets", (npix + 1) * 4);
        let p = GbFlagsParams {
            pixels: npix as u32,
            width: w,
            stride: gb.stride,
            background: bg.to_array(),
        };
        ex.run(
            launch::FrGbFlags {
                gb_id: &gb.id,
                flags: &flags,
                img: &img,
            },
            p,
            npix,
            256,
        );
        ex.scan(&flags, &offs, npix);
        let (parts, covered) = self.place(&offs, npix);
        if let Some(c) = &covered {
            self.deferred.push(Counted::Covered, c);
        }
        let mut out = Vec::new();
        for (first, s) in parts {
            let count = s.len;
            let p = GbSurfacesParams {
                pixels: npix as u32,
                width: w,
                stride: gb.stride,
                first: first as u32,
                count: count as u32,
                eye: view.eye.to_array(),
            };
            let l = launch::FrGbSurfaces {
                flags: &flags,
                offs: &offs,
                g_tris: tris,
                g_material: material,
                gb_pos: &gb.pos,
                gb_nrm: &gb.normal,
                gb_id: &gb.id,
                s_pos: &s.s.pos,
                s_ng: &s.s.ng,
                s_ns: &s.s.ns,
                s_inc: &s.s.inc,
                s_tw: &s.s.tw,
                s_mat: &s.s.mat,
                s_pix: &s.pix,
            };
            self.ex.run(l, p, npix, 256);
            out.push(s);
        }
        self.img = Some(img);
        out
    }

    fn surfaces_len(&self, s: &Vec<DeviceSurfaces>) -> Option<u64> {
        if s.iter().any(|p| p.sizes.is_some()) {
            return None;
        }
        Some(s.iter().map(|p| p.len).sum())
    }

    fn shadow_rays(&mut self, s: &Vec<DeviceSurfaces>) -> Vec<DeviceBatch> {
        let g = self.g;
        let nl = self.scene.lights.len() as u64;
        let mut out = Vec::new();
        for surf in s {
            let (n, m) = (surf.len, surf.len * nl);
            if m == 0 {
                continue;
            }
            let rays = DeviceRays::storage(g, "shadow", m);
            let sz = surf.sizes.as_ref();
            surf.s
                .shadow_rays(&mut self.ex, &self.lights, &surf.pix, &rays, n, nl, sz);
            out.push(DeviceBatch {
                rays,
                weight: None,
                refractions: 0,
                count: sz.map(|z| (z.lights.clone(), None)),
            });
        }
        out
    }

    fn bounce_rays(&mut self, s: &Vec<DeviceSurfaces>) -> Vec<DeviceBatch> {
        let g = self.g;
        let mut out = Vec::new();
        if self.per_surface == 0 {
            // No material reflects or refracts: no bounce ray, known without a count.
            return out;
        }
        for surf in s {
            // With the surfaces' count on the device, `slots` is the slots' bound.
            let slots = 2 * surf.len;
            if slots == 0 {
                continue;
            }
            // The bounce rays' bound: at most `per_surface` of a surface's two slots fill.
            let bound = self.per_surface * surf.len;
            let (b_org, b_dir, b_w) = (
                g.storage("slot org", slots * 16),
                g.storage("slot dir", slots * 16),
                g.storage("slot weight", slots * 16),
            );
            let sz = surf.sizes.as_ref();
            let over_slots = Threads::of(sz.map(|z| &z.slots), slots);
            // The kernel flags the filled slots. New buffers are zeroed (wgpu's guarantee),
            // so the flags past a device count are 0 and the scan over the bound counts the
            // filled slots only.
            let flags = g.storage("slot flags", slots * 4);
            let offs = g.storage("slot offsets", (slots + 1) * 4);
            let ex = &mut self.ex;
            surf.s
                .bounce_rays(ex, &self.mats, [&b_org, &b_dir, &b_w, &flags], surf.len, sz);
            ex.scan(&flags, &offs, slots);
            let chunks = slots.div_ceil(TOTALS_CHUNK);
            let kinds = g.storage("slot kind counts", chunks * 4);
            let l = launch::FrSlotKindCount {
                flags: &flags,
                col: &b_w,
                out_u: &kinds,
            };
            let p = KindCountParams {
                rays: slots as u32,
                kind: trace::RayKind::Refraction as u32,
            };
            let threads = match sz {
                // A thread per chunk of the bound; the chunks past the count count none.
                Some(z) => Threads::Patched {
                    first: &z.slots,
                    threads: chunks,
                },
                None => Threads::Host(chunks),
            };
            ex.run_on(l, p, threads, 256);
            let filled = DevLen {
                buf: offs.clone(),
                at: slots,
                cap: bound,
            };
            let (r, refractions, count) = if self.cap.fits(bound) {
                // The batch's size and refraction count stay on the device.
                let rs = ex.size(&filled, 1, 256);
                (bound, 0, Some((rs, Some((kinds.clone(), chunks)))))
            } else {
                // The batch's size and its refraction count in one read-back.
                let both = g.storage("slot totals", (1 + chunks) * 4);
                ex.copy_at(&offs, slots * 4, &both, 0, 4);
                ex.copy_at(&kinds, 0, &both, 4, chunks * 4);
                let words: Vec<u32> = ex.read(&both, 1 + chunks as usize);
                let refractions: u64 = words[1..].iter().map(|&c| c as u64).sum();
                (words[0] as u64, refractions, None)
            };
            if r == 0 {
                continue;
            }
            let rays = DeviceRays::storage(g, "bounce", r);
            let weight = g.storage("bounce weight", r * 16);
            ex.run_on(
                launch::FrBounceEmit {
                    flags: &flags,
                    offs: &offs,
                    b_org: &b_org,
                    b_dir: &b_dir,
                    col: &b_w,
                    s_pix: &surf.pix,
                    r_org: &rays.org,
                    r_dir: &rays.dir,
                    r_kl: &rays.kl,
                    r_pix: &rays.pix,
                    r_w: &weight,
                },
                FrameCountParams { n: slots as u32 },
                over_slots,
                256,
            );
            out.push(DeviceBatch {
                rays,
                weight: Some(weight),
                refractions,
                count,
            });
        }
        out
    }

    fn rays_len(&self, r: &Vec<DeviceBatch>) -> Option<u64> {
        if r.iter().any(|b| b.count.is_some()) {
            return None;
        }
        Some(r.iter().map(|b| b.rays.len).sum())
    }

    fn count_kinds(&mut self, r: &Vec<DeviceBatch>) -> [u64; 4] {
        let mut k = [0u64; 4];
        for b in r {
            if let Some((n, refr)) = &b.count {
                // Counted with the image (`finish`).
                let kind = match b.weight {
                    None => Counted::Shadow,
                    Some(_) => Counted::Bounce,
                };
                self.deferred.push(kind, &n.count());
                if let Some((buf, words)) = refr {
                    self.deferred.push_words(Counted::Refractions, buf, *words);
                }
            } else if b.weight.is_none() {
                k[1] += b.rays.len;
            } else {
                k[3] += b.refractions;
                k[2] += b.rays.len - b.refractions;
            }
        }
        k
    }

    fn hit_records(&mut self, _r: &Vec<DeviceBatch>) -> Vec<wgpu::Buffer> {
        // The engine's trace makes its record buffers on the device.
        Vec::new()
    }

    fn trace(
        &mut self,
        r: &Vec<DeviceBatch>,
        hits: &mut Vec<wgpu::Buffer>,
        mode: TraceMode,
        stats: &mut TraceStats,
    ) {
        self.ex.finish();
        *hits = r
            .iter()
            .map(|b| match &b.count {
                Some((n, _)) => {
                    // Counted with the image (`finish`).
                    self.deferred.push(Counted::Traced, &n.count());
                    self.engine
                        .trace_device_counted(&b.rays, n, mode, stats)
                        .expect("a device-sized batch goes to an engine that counts on the device")
                }
                None => trace_device(self.engine, &b.rays, mode, stats),
            })
            .collect();
    }

    fn shade(
        &mut self,
        s: &Vec<DeviceSurfaces>,
        shadows: Option<(&Vec<DeviceBatch>, &Vec<wgpu::Buffer>)>,
    ) {
        let g = self.g;
        let nl = self.scene.lights.len() as u64;
        let img = self.img.clone().expect("primary surfaces first");
        // The shadow batches are the non-empty parts, in order.
        let mut recs = shadows.map(|(_, h)| h.iter());
        for surf in s {
            let (n, m) = (surf.len, surf.len * nl);
            let sz = surf.sizes.as_ref();
            // The shading reads the shadow rays' records; with no shadow ray (no light) it
            // reads none, and binds a stand-in.
            let none;
            let rec = if m > 0 {
                recs.as_mut()
                    .and_then(|r| r.next())
                    .expect("a shadow batch per part with rays")
            } else {
                none = g.storage("no shadow records", 16);
                &none
            };
            if n > 0 {
                let colour = g.storage("colour", n * 16);
                let ex = &mut self.ex;
                surf.s
                    .shade(ex, &self.lights, &self.mats, rec, &colour, n, nl, sz);
                ex.run_on(
                    launch::FrAccumulate {
                        s_pix: &surf.pix,
                        img: &img,
                        col: &colour,
                    },
                    FrameCountParams { n: n as u32 },
                    Threads::of(sz.map(|z| &z.one), n),
                    256,
                );
            }
        }
    }

    fn next_surfaces(
        &mut self,
        r: &Vec<DeviceBatch>,
        h: &Vec<wgpu::Buffer>,
    ) -> Vec<DeviceSurfaces> {
        let g = self.g;
        let bg = self.scene.background;
        let img = self.img.clone().expect("primary surfaces first");
        let (tris, normals, material) = self.raster.scene_buffers();
        let mut out = Vec::new();
        for (b, rec) in r.iter().zip(h) {
            // With the batch's count on the device, `n` is its bound.
            let n = b.rays.len;
            let weight = b.weight.as_ref().expect("bounce rays carry weights");
            let rs = b.count.as_ref().map(|c| &c.0);
            let over_rays = Threads::of(rs, n);
            // The background behind the misses and the hit flags (zeroed when made, so
            // past a device count they are 0), then the surfaces of the hits.
            let hflags = g.storage("hit flags", n * 4);
            let hoffs = g.storage("hit offsets", (n + 1) * 4);
            self.ex.run_on(
                launch::FrMisses {
                    r_pix: &b.rays.pix,
                    r_w: weight,
                    rec,
                    img: &img,
                    flags: &hflags,
                },
                MissesParams {
                    rays: n as u32,
                    background: bg.to_array(),
                },
                over_rays,
                256,
            );
            self.ex.scan(&hflags, &hoffs, n);
            for (first, next) in self.place(&hoffs, n).0 {
                let count = next.len;
                let l = launch::FrHitSurfaces {
                    flags: &hflags,
                    offs: &hoffs,
                    rec,
                    r_dir: &b.rays.dir,
                    r_pix: &b.rays.pix,
                    r_w: weight,
                    g_tris: tris,
                    g_normals: normals,
                    g_material: material,
                    s_pos: &next.s.pos,
                    s_ng: &next.s.ng,
                    s_ns: &next.s.ns,
                    s_inc: &next.s.inc,
                    s_tw: &next.s.tw,
                    s_mat: &next.s.mat,
                    s_pix: &next.pix,
                };
                let p = HitSurfacesParams {
                    rays: n as u32,
                    first: first as u32,
                    count: count as u32,
                };
                self.ex.run_on(l, p, over_rays, 256);
                out.push(next);
            }
        }
        out
    }

    fn sync(&mut self) {
        self.ex.finish();
        self.g
            .device
            .poll(wgpu::PollType::wait_indefinitely())
            .expect("GPU device lost");
    }

    fn finish(&mut self, mut stats: RenderStats, linear: bool) -> Rendered {
        let t0 = Instant::now();
        let npix = self.npix;
        let img = self.img.clone().expect("primary surfaces first");
        let (pixels, srgb8) = if linear {
            // The linear image out (antialiasing averages the samples' pixels on the host).
            let raw: Vec<f32> = self.read_with_counts(&img, 4 * npix, &mut stats);
            let px = raw
                .chunks_exact(4)
                .map(|c| geom::Vec3::new(c[0], c[1], c[2]))
                .collect();
            (px, None)
        } else {
            // The image out, as sRGB bytes.
            let words = (3 * npix).div_ceil(4);
            let enc = self.g.storage("srgb", words * 4);
            self.ex.run(
                launch::FrEncode {
                    img: &img,
                    out_u: &enc,
                },
                EncodeParams {
                    words: words as u32,
                    pixels: npix as u32,
                },
                words,
                256,
            );
            let raw: Vec<u32> = self.read_with_counts(&enc, words, &mut stats);
            let mut srgb8: Vec<u8> = raw.iter().flat_map(|w| w.to_le_bytes()).collect();
            srgb8.truncate(3 * npix as usize);
            (Vec::new(), Some(srgb8))
        };
        self.sync();
        stats.add_phase(FramePhase::Shading, t0.elapsed().as_secs_f64());
        Rendered {
            pixels,
            srgb8,
            gbuffer: self.host_gbuffer.take().unwrap_or_default(),
            raster: RasterStats {
                triangles: stats.triangles,
                ..Default::default()
            },
            stats,
        }
    }
}
