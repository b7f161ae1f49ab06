//! The CPU backend of the Whitted loop ([`crate::whitted::run`]): the CPU rasterizer's
//! G-buffer (thesis §3.1), surfaces and rays as host arrays ([`crate::secondary`],
//! eqs. 3.1–3.7), Blinn-Phong shading on rayon's threads ([`crate::shade`], eqs.
//! 3.17–3.19), and any [`Tracer`] for the batches. The GPU backend (`gpu::frame`) is its twin
//! with device buffers.

use crate::raster::{rasterize_into, GBuffer, RasterScratch, RasterStats};
use crate::secondary::{bounce_rays_into, shadow_rays_into, Surfaces};
use crate::shade;
use crate::stats::RenderStats;
use crate::view::View;
use crate::whitted::{Backend, Rendered};
use geom::Vec3;
use rayon::prelude::*;
use scene::{Geometry, Scene};
use trace::batch::{Hit, RayBatch};
use trace::tracer::{TraceMode, Tracer};
use trace::TraceStats;

/// A render on the CPU with `tracer`: the image as linear RGB on the host.
pub struct CpuBackend<'a> {
    scene: &'a Scene,
    geo: &'a Geometry,
    tracer: &'a dyn Tracer,
    given: Option<GBuffer>,
    gb: GBuffer,
    raster: RasterStats,
    pixels: Vec<Vec3>,
    arena: FrameArena,
}

/// The buffers of a frame's generations, kept for the next generation and the next
/// frame (`--frames`, the viewer, the bindings): ray batches, hit records, surfaces and
/// shaded colours, refilled in place so a steady frame allocates nothing and faults in
/// no fresh pages for them.
#[derive(Default)]
pub struct FrameArena {
    rays: Vec<RayBatch>,
    hits: Vec<Vec<Hit>>,
    surfaces: Vec<Surfaces>,
    shaded: Vec<Vec3>,
    gbuffer: GBuffer,
    raster: RasterScratch,
}

impl FrameArena {
    /// Keep a finished frame's G-buffer for the next frame's rasterization (a caller that
    /// does not need it once the image is made hands it back).
    pub fn keep_gbuffer(&mut self, gb: GBuffer) {
        self.gbuffer = gb;
    }
}

impl<'a> CpuBackend<'a> {
    /// A backend for frames of `scene` (geometry `geo`) traced by `tracer`.
    pub fn new(scene: &'a Scene, geo: &'a Geometry, tracer: &'a dyn Tracer) -> Self {
        CpuBackend {
            scene,
            geo,
            tracer,
            given: None,
            gb: GBuffer::default(),
            raster: RasterStats::default(),
            pixels: Vec::new(),
            arena: FrameArena::default(),
        }
    }
}

impl CpuBackend<'_> {
    /// The frame over `gb`, a G-buffer of the frame's size made elsewhere (the GPU's
    /// rasterizer, read back), instead of the CPU rasterizer's.
    pub fn with_gbuffer(mut self, gb: GBuffer) -> Self {
        self.given = Some(gb);
        self
    }

    /// The frame with the buffers an earlier frame left (see [`FrameArena`]).
    pub fn with_arena(mut self, arena: FrameArena) -> Self {
        self.arena = arena;
        self
    }

    /// The buffers, for the next frame.
    pub fn into_arena(self) -> FrameArena {
        self.arena
    }

    fn spare_rays(&mut self) -> RayBatch {
        self.arena.rays.pop().unwrap_or_default()
    }

    fn spare_surfaces(&mut self) -> Surfaces {
        self.arena.surfaces.pop().unwrap_or_default()
    }
}

/// Local illumination of every surface of `s` times its throughput ([`shade::local`]) under
/// `scene`'s materials and lights; `occluded[i · lights + l]` says whether light l is hidden
/// from surface i.
pub fn local_shading(s: &Surfaces, scene: &Scene, occluded: &[bool]) -> Vec<Vec3> {
    let mut out = Vec::new();
    shade_into(s, scene, |k| occluded[k], &mut out);
    out
}

/// [`local_shading`] into `out` (kept), in parallel over groups of surfaces shaded in
/// lanes ([`shade::lanes`], the same bits as [`shade::local_with`]), with
/// `occluded(i · lights + l)`.
fn shade_into(
    s: &Surfaces,
    scene: &Scene,
    occluded: impl Fn(usize) -> bool + Sync,
    out: &mut Vec<Vec3>,
) {
    use shade::lanes::{material_lanes, shade_group, LANES};
    let mats = material_lanes(&scene.materials, scene.ambient);
    let isa = geom::Isa::best();
    out.clear();
    out.resize(s.len(), Vec3::ZERO);
    // Groups per task: enough work that a task's bookkeeping is noise.
    const TASK: usize = 64 * LANES;
    out.par_chunks_mut(TASK).enumerate().for_each(|(t, part)| {
        for (g, o) in part.chunks_mut(LANES).enumerate() {
            let first = t * TASK + g * LANES;
            shade_group(s, first, &mats, &scene.lights, &occluded, o, isa);
        }
    });
}

/// `pixels[at[i]] += add[i]` for every i, each pixel's additions in the order of i, so the
/// bytes do not depend on the threads. Every generation's surfaces are in pixel order (the
/// G-buffer's are; a surface's rays carry its pixel, surface-major; the next surfaces are
/// the hits in ray order), so pieces cut where the pixel changes own disjoint pixels and
/// run in parallel; out of order, the additions run serially.
fn add_in_order(pixels: &mut [Vec3], at: &[u32], add: &[Vec3]) {
    const PIECE: usize = 1 << 14;
    let sorted = at.par_windows(2).all(|w| w[0] <= w[1]);
    if !sorted || at.len() < 2 * PIECE {
        for (&p, c) in at.iter().zip(add) {
            pixels[p as usize] += *c;
        }
        return;
    }
    // Cut after a whole pixel's run, about every PIECE additions.
    let mut cuts = vec![0usize];
    let mut k = PIECE;
    while k < at.len() {
        while k < at.len() && at[k] == at[k - 1] {
            k += 1;
        }
        if k < at.len() {
            cuts.push(k);
        }
        k += PIECE;
    }
    cuts.push(at.len());
    // Each piece's pixels: from its first surface's pixel to the next piece's first.
    let mut parts = Vec::with_capacity(cuts.len() - 1);
    let mut rest = pixels;
    let mut base = 0usize;
    for w in cuts.windows(2) {
        let end = if w[1] < at.len() {
            at[w[1]] as usize
        } else {
            base + rest.len()
        };
        let (mine, tail) = std::mem::take(&mut rest).split_at_mut(end - base);
        parts.push((mine, base, w[0]..w[1]));
        rest = tail;
        base = end;
    }
    parts.into_par_iter().for_each(|(mine, base, r)| {
        for i in r {
            mine[at[i] as usize - base] += add[i];
        }
    });
}

impl Backend for CpuBackend<'_> {
    type Surfaces = Surfaces;
    type Rays = RayBatch;
    type Hits = Vec<Hit>;

    fn engine_name(&self) -> String {
        self.tracer.name().to_string()
    }

    fn rasterize(&mut self, view: &View, near: f32) {
        match self.given.take() {
            Some(gb) => {
                self.gb = gb;
                self.raster = RasterStats {
                    triangles: self.geo.len() as u64,
                    ..Default::default()
                };
            }
            None => {
                let mut gb = std::mem::take(&mut self.arena.gbuffer);
                let materials = &self.scene.materials;
                self.raster = rasterize_into(
                    self.geo,
                    materials,
                    view,
                    near,
                    &mut gb,
                    &mut self.arena.raster,
                );
                self.gb = gb;
            }
        }
    }

    fn primary_surfaces(&mut self, view: &View) -> Surfaces {
        let bg = self.scene.background;
        self.pixels.clear();
        self.gb
            .tri
            .par_iter()
            .map(|&t| if t == geom::NO_HIT { bg } else { Vec3::ZERO })
            .collect_into_vec(&mut self.pixels);
        let mut s = self.spare_surfaces();
        s.fill_from_gbuffer(&self.gb, self.geo, view.eye);
        s
    }

    fn surfaces_len(&self, s: &Surfaces) -> Option<u64> {
        Some(s.len() as u64)
    }

    fn shadow_rays(&mut self, s: &Surfaces) -> RayBatch {
        let mut b = self.spare_rays();
        shadow_rays_into(s, &self.scene.lights, &mut b);
        b
    }

    fn bounce_rays(&mut self, s: &Surfaces) -> RayBatch {
        let mut b = self.spare_rays();
        bounce_rays_into(s, &self.scene.materials, &mut b);
        b
    }

    fn rays_len(&self, r: &RayBatch) -> Option<u64> {
        Some(r.len() as u64)
    }

    fn count_kinds(&mut self, r: &RayBatch) -> [u64; 4] {
        r.count_by_kind()
    }

    fn hit_records(&mut self, r: &RayBatch) -> Vec<Hit> {
        let mut hits = self.arena.hits.pop().unwrap_or_default();
        hits.clear();
        hits.resize(r.len(), Hit::MISS);
        hits
    }

    fn trace(
        &mut self,
        r: &RayBatch,
        hits: &mut Vec<Hit>,
        mode: TraceMode,
        stats: &mut TraceStats,
    ) {
        self.tracer.trace(r, mode, hits, stats);
    }

    fn shade(&mut self, s: &Surfaces, shadows: Option<(&RayBatch, &Vec<Hit>)>) {
        let mut shaded = std::mem::take(&mut self.arena.shaded);
        match shadows {
            Some((_, h)) => shade_into(s, self.scene, |k| h[k].is_hit(), &mut shaded),
            None => shade_into(s, self.scene, |_| false, &mut shaded),
        }
        add_in_order(&mut self.pixels, &s.pixel, &shaded);
        self.arena.shaded = shaded;
    }

    fn next_surfaces(&mut self, r: &RayBatch, h: &Vec<Hit>) -> Surfaces {
        let bg = self.scene.background;
        for (i, h) in h.iter().enumerate() {
            if !h.is_hit() {
                self.pixels[r.pixel[i] as usize] += bg * r.throughput[i];
            }
        }
        let mut s = self.spare_surfaces();
        s.fill_from_hits(r, h, self.geo);
        s
    }

    fn recycle(&mut self, r: RayBatch, h: Option<Vec<Hit>>) {
        self.arena.rays.push(r);
        self.arena.hits.extend(h);
    }

    fn recycle_surfaces(&mut self, s: Surfaces) {
        self.arena.surfaces.push(s);
    }

    fn sync(&mut self) {}

    fn finish(&mut self, stats: RenderStats, _linear: bool) -> Rendered {
        Rendered {
            pixels: std::mem::take(&mut self.pixels),
            srgb8: None,
            gbuffer: std::mem::take(&mut self.gb),
            raster: std::mem::take(&mut self.raster),
            stats,
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// In pixel order (with runs of a pixel, and pixels skipped) and out of it, the
    /// additions give the serial loop's bits.
    #[test]
    fn additions_in_order_equal_the_serial_loop() {
        let mut rng = geom::Pcg32::new(9, 4);
        for case in 0..6 {
            let n = [10, 40_000, 100_000, 70_001, 5, 90_000][case];
            let mut at: Vec<u32> = (0..n).map(|_| rng.next_u32() % 50_000).collect();
            if case != 5 {
                at.sort_unstable();
            }
            let add: Vec<Vec3> = (0..n)
                .map(|_| Vec3::new(rng.next_f32(), rng.next_f32() * 1e-3, rng.next_f32() * 7.0))
                .collect();
            let start: Vec<Vec3> = (0..50_000).map(|i| Vec3::splat(i as f32 * 0.1)).collect();
            let mut want = start.clone();
            for (&p, c) in at.iter().zip(&add) {
                want[p as usize] += *c;
            }
            let mut got = start;
            add_in_order(&mut got, &at, &add);
            let bits = |v: &[Vec3]| -> Vec<[u32; 3]> {
                v.iter().map(|c| c.to_array().map(f32::to_bits)).collect()
            };
            assert!(bits(&got) == bits(&want), "case {case}");
        }
    }
}
