//! The GPU G-buffer against the CPU rasterizer, and whole renders (GPU raster + GPU CRSH)
//! against CPU renders.
//!
//! Stated tolerance. The hardware rasterizer snaps vertices to its own sub-pixel grid and
//! interpolates barycentrics in its own precision, so (1) a pixel whose centre lies within
//! rounding of a triangle edge may be covered by the neighbouring triangle: at most 1 % of
//! the covered pixels may name another triangle; (2) where both name the same triangle, the
//! positions agree within 1e-4 of the scene's diagonal; (3) in the final image at most 2 %
//! of the pixels differ by more than 2/255 in any channel (edge pixels and the secondary
//! rays they spawn). With the CPU's G-buffer, the GPU tracer's image is byte-identical; the
//! GPU's ray generation reproduces the CPU's rays bit for bit, and its shading the CPU's
//! colours within 1e-4 (relative: the device's `pow` for the specular exponent).

use gpu::frame::GpuBackend;
use gpu::{Gpu, GpuRaster, GpuRsh, GpuStages};
use render::raster::{default_near, rasterize};
use render::whitted::{render, run, RenderOptions};
use render::View;
use rsh::RshEngine;
use scene::{builtin, Geometry};

fn gpu() -> Option<Gpu> {
    testkit::or_skip(Gpu::new(), "gpu")
}

fn bytes(p: &[geom::Vec3]) -> Vec<u8> {
    p.iter()
        .flat_map(|c| [c.x, c.y, c.z].map(render::output::srgb_encode))
        .collect()
}

#[test]
fn gbuffer_matches_cpu_rasterizer() {
    let Some(g) = gpu() else { return };
    for name in builtin::NAMES {
        let s = builtin::by_name(name).unwrap();
        let geo = Geometry::from_scene(&s);
        let r = GpuRaster::new(&g, &geo, &s.materials).unwrap();
        assert!(r.check_size(160, 120).is_ok());
        let too_wide = r.check_size(g.limits.max_texture_dimension_2d + 1, 1);
        assert!(too_wide.unwrap_err().to_string().contains("texture limit"));
        // The pixel centres, and a view jittered inside the pixels (antialiasing's
        // samples): both rasterizers move the geometry by the same offset.
        let centred = View::new(&s.camera, 160, 120);
        for view in [centred, centred.jittered([0.375, -0.25])] {
            let near = default_near(&geo);
            let (cpu, _) = rasterize(&geo, &s.materials, &view, near);
            let (gpu, _) = r.rasterize(&view, near);
            let covered = cpu.covered().max(1);
            let mut other = 0;
            for p in 0..cpu.tri.len() {
                if cpu.tri[p] != gpu.tri[p] {
                    other += 1;
                    continue;
                }
                if cpu.tri[p] == geom::NO_HIT {
                    continue;
                }
                // Both points lie on the same triangle, so comparing where they project on
                // the screen compares them fully. Within a tenth of a pixel: hardware snaps
                // vertices to a sub-pixel grid and interpolates in its own precision (on an
                // H100 a point at a grazing angle on the stadium lay 1.9 units from the CPU's,
                // a third of its pixel's footprint, yet on the same spot of the screen).
                let screen = |q: geom::Vec3| {
                    let c = q - view.eye;
                    let z = c.dot(view.fwd);
                    let sx = c.dot(view.right) / (z * view.tan_x) * 0.5 * view.width as f32;
                    let sy = c.dot(view.up) / (z * view.tan_y) * 0.5 * view.height as f32;
                    geom::Vec3::new(sx, sy, 0.0)
                };
                let d = (screen(cpu.position[p]) - screen(gpu.position[p])).length();
                assert!(
                    d <= 0.1,
                    "{name} pixel {p}: points {d} pixels apart on the screen ({} and {})",
                    cpu.position[p],
                    gpu.position[p]
                );
                // The hardware snaps vertices to a sub-pixel grid and interpolates the
                // barycentrics its own way (on an H100 they differ from the CPU's by ~1e-3 on
                // a sphere's few-pixel triangles, normals by 2e-3), so the GPU's normal is
                // checked against its own barycentrics; the position check above bounds how
                // far those are from the CPU's.
                let [u, v] = gpu.bary[p];
                let own = geo.shading_normal(gpu.tri[p], u, v);
                assert!(
                    (own - gpu.normal[p]).length() < 1e-4,
                    "{name} pixel {p} (triangle {}): normal {} at its barycentrics ({u}, {v}) is {own}; CPU {}",
                    cpu.tri[p],
                    gpu.normal[p],
                    cpu.normal[p]
                );
                assert_eq!(cpu.diffuse[p], gpu.diffuse[p]);
                assert_eq!(cpu.specular[p], gpu.specular[p]);
            }
            let frac = other as f64 / covered as f64;
            eprintln!(
                "{name} {:?}: {other} of {covered} covered pixels name another triangle",
                view.jitter
            );
            assert!(
                frac <= 0.01,
                "{name}: {:.3} % of pixels differ",
                frac * 100.0
            );
        }
    }
}

#[test]
fn renders_match_cpu_renders() {
    let Some(g) = gpu() else { return };
    let opts = RenderOptions {
        width: 96,
        height: 72,
        bounces: 2,
        spp: 1,
    };
    for name in builtin::NAMES {
        let s = builtin::by_name(name).unwrap();
        let geo = Geometry::from_scene(&s);
        let cpu_engine = RshEngine::new(&geo, crate::common::crsh_spheres()).unwrap();
        let cpu = render(&s, &geo, &cpu_engine, &opts, &());
        let gpu_engine =
            GpuRsh::new(Gpu::new().unwrap(), &geo, crate::common::crsh_spheres()).unwrap();
        // GPU tracer on the CPU's G-buffer: the same image, byte for byte.
        let mixed = render(&s, &geo, &gpu_engine, &opts, &());
        assert_eq!(
            bytes(&mixed.pixels),
            bytes(&cpu.pixels),
            "{name}: GPU tracer image"
        );
        assert_eq!(
            mixed.stats.total_tests, cpu.stats.total_tests,
            "{name}: tests"
        );
        // The GPU frame (GPU raster, ray generation, shading and tracer): within the
        // tolerance.
        let gpu_engine = GpuRsh::new(g.clone(), &geo, crate::common::crsh_spheres()).unwrap();
        let r = GpuRaster::new(&g, &geo, &s.materials).unwrap();
        let mut b = GpuBackend::new(&gpu_engine, &r, &s, &opts, false).unwrap();
        let full = run(&mut b, &s, &geo, &opts, &());
        let (a, b) = (full.rgb8(), bytes(&cpu.pixels));
        let bad = a
            .chunks(3)
            .zip(b.chunks(3))
            .filter(|(x, y)| x.iter().zip(y.iter()).any(|(p, q)| p.abs_diff(*q) > 2))
            .count();
        let frac = bad as f64 / (a.len() / 3) as f64;
        eprintln!("{name}: {bad} pixels differ by more than 2/255");
        assert!(
            frac <= 0.02,
            "{name}: {:.2} % of pixels differ",
            frac * 100.0
        );
    }
}

#[test]
fn ray_generation_and_shading_match_the_cpu_passes() {
    use render::secondary::{bounce_rays, shadow_rays, Surfaces};
    // Twice: on the device as it is, and as if it bound only 4 KiB at once (the passes then
    // run in parts of 128–256 surfaces; a 3000² frame's shadow rays used to exceed
    // lavapipe's 128 MiB binding and panic), there with an ambient light too.
    for small in [false, true] {
        let Some(mut g) = gpu() else { return };
        if small {
            g.limits.max_storage_buffer_binding_size = 4096;
        }
        let kernels = g.kernels();
        let stages = GpuStages::new(&g, &kernels);
        for name in builtin::NAMES {
            let mut s = builtin::by_name(name).unwrap();
            if small {
                s.ambient = geom::Vec3::new(0.3, 0.2, 0.1);
                for (k, m) in s.materials.iter_mut().enumerate() {
                    m.ambient = geom::Vec3::splat(0.25 * k as f32);
                }
            }
            let geo = Geometry::from_scene(&s);
            let view = View::new(&s.camera, 80, 60);
            let (gb, _) = rasterize(&geo, &s.materials, &view, default_near(&geo));
            let first = Surfaces::from_gbuffer(&gb, &geo, view.eye);
            // A second generation: the surfaces the first generation's bounce rays hit.
            let rays = bounce_rays(&first, &s.materials);
            let bf = accel::BruteForce::new(&geo);
            let mut hits = vec![trace::Hit::MISS; rays.len()];
            use trace::Tracer;
            bf.trace(
                &rays,
                trace::TraceMode::Closest,
                &mut hits,
                &mut Default::default(),
            );
            let second = Surfaces::from_hits(&rays, &hits, &geo);
            for (gen, surf) in [first, second].iter().enumerate() {
                let what = format!("{name} generation {gen}");
                let (a, b) = (
                    shadow_rays(surf, &s.lights),
                    stages.shadow_rays(surf, &s.lights),
                );
                assert_eq!(a.org, b.org, "{what}: shadow origins");
                assert_eq!(a.dir, b.dir, "{what}: shadow directions");
                assert_eq!(a.t_max, b.t_max, "{what}: shadow lengths");
                assert_eq!(
                    (a.pixel.clone(), a.light.clone()),
                    (b.pixel.clone(), b.light.clone())
                );
                let (a, b) = (
                    bounce_rays(surf, &s.materials),
                    stages.bounce_rays(surf, &s.materials),
                );
                assert_eq!(a.kind, b.kind, "{what}: bounce kinds");
                assert_eq!(a.org, b.org, "{what}: bounce origins");
                assert_eq!(a.dir, b.dir, "{what}: bounce directions");
                assert_eq!(a.throughput, b.throughput, "{what}: bounce weights");
                assert_eq!(a.t_max, b.t_max);
                let occ: Vec<bool> = (0..surf.len() * s.lights.len())
                    .map(|k| k % 3 == 1)
                    .collect();
                let ca = render::cpu::local_shading(surf, &s, &occ);
                let cb = stages.local_shading(surf, &s, &occ);
                for (i, (x, y)) in ca.iter().zip(&cb).enumerate() {
                    let tol = 1e-4 * x.abs().max_element().max(1e-3);
                    assert!(
                        (*x - *y).abs().max_element() <= tol,
                        "{what}: colour {i}: {x} vs {y}"
                    );
                }
            }
        }
    }
}
