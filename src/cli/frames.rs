//! `rayspace render --frames N`: the per-frame pipeline of a dynamic scene (the papers' use
//! case: CRSH §3.2.2 updates the mesh spheres by transform, the irregular grid is rebuilt
//! every frame, §5.3): update, rebuild, render, with build and trace times apart, the frames
//! as PNGs, per-frame CSV and an animated GIF.

use super::args::RenderArgs;
use super::check::{frame_path, Outputs};
use super::progress::step_bar;
use anyhow::{bail, Context, Result};
use rayspace::frames::FrameRow;
use rayspace::runner::Runner;
use render::whitted::RenderOptions;

/// The per-frame pipeline: update transforms (and the meshes' culling spheres, by transform),
/// rebuild the engine, render; build and trace times apart.
pub fn render_frames(
    a: &RenderArgs,
    mut runner: Runner,
    scene: &scene::Scene,
    n: u32,
    outs: &Outputs,
) -> Result<()> {
    let Some(anim) = &scene.animation else {
        bail!(
            "--frames: {} is not animated (BART .aff files and TOML scenes with keyframes are)",
            scene.name
        );
    };
    let times: Vec<f32> = match a.anim.fps {
        Some(f) => (0..n).map(|i| anim.start + i as f32 / f).collect(),
        None => anim.frame_times(n),
    };
    let bar = step_bar(n as u64);
    let opts = RenderOptions {
        width: a.width,
        height: a.height,
        bounces: a.bounces,
        spp: a.spp,
    };
    let mut rows = Vec::new();
    let mut stats = Vec::new();
    let mut gif_frames = Vec::new();
    // The runner keeps the geometry's and the renderer's buffers from one frame to the
    // next, and on the GPU one device, its kernels and its engine, rebuilt per frame.
    for (i, &t) in times.iter().enumerate() {
        bar.step(&format!("frame {i} (t = {t:.3})"));
        let f = runner.frame(scene, Some(t), i as u32, &opts, &())?;
        let (out, row) = (f.rendered, f.row);
        let path = frame_path(&outs.out, i as u32)?;
        render::output::write_rgb8_png(&out.rgb8(), a.width, a.height, &path)
            .map_err(anyhow::Error::msg)
            .context("--out")?;
        if a.anim.gif.is_some() {
            gif_frames.push(out.rgb8());
        }
        if a.stats.is_some() {
            stats.push(out.stats);
        }
        rows.push(row);
    }
    bar.0.finish_and_clear();
    let mean = |f: &dyn Fn(&FrameRow) -> f64| rows.iter().map(f).sum::<f64>() / rows.len() as f64;
    say!(
        "{} frames of {} ({}×{}, engine {}): mean per frame update {:.1} ms, build {:.1} ms, render {:.1} ms{}",
        rows.len(),
        scene.name,
        a.width,
        a.height,
        a.engine.name(),
        mean(&|r| r.update_ms),
        mean(&|r| r.build_ms),
        mean(&|r| r.render_ms),
        {
            // Ray-space hierarchies build their structure inside the render, per batch.
            let h = mean(&|r| r.phases_ms.iter().filter(|p| p.0.is_build()).map(|p| p.1).sum());
            if h > 0.0 {
                format!(
                    " (of which ray-hierarchy build {h:.1} ms, traversal and final tests {:.1} ms)",
                    mean(&|r| r.phases_ms.iter().filter(|p| !p.0.is_build()).map(|p| p.1).sum())
                )
            } else {
                String::new()
            }
        }
    );
    if outs.temporary.is_none() {
        say!(
            "wrote {} … {}",
            frame_path(&outs.out, 0)?.display(),
            frame_path(&outs.out, n - 1)?.display()
        );
    }
    if let Some(p) = &a.stats {
        super::write_out("--stats", p, serde_json::to_string_pretty(&stats)?)?;
        say!("wrote {} (every frame's statistics)", p.display());
    }
    if let Some(p) = &a.anim.frame_csv {
        let mut csv = FrameRow::csv_header() + "\n";
        for r in &rows {
            csv += &(r.csv_line() + "\n");
        }
        super::write_out("--frame-csv", p, csv)?;
        say!("wrote {}", p.display());
    }
    if let Some(p) = &a.anim.gif {
        let delay_ms = a.anim.fps.map_or(100.0, |f| 1000.0 / f) as u32;
        render::output::write_gif(&gif_frames, a.width, a.height, delay_ms, p)
            .map_err(anyhow::Error::msg)
            .context("--gif")?;
        say!("wrote {}", p.display());
    }
    Ok(())
}
