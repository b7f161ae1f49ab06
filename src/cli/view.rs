//! `rayspace view`: options in, [`rayspace::view`]'s window out.

use super::args::ViewArgs;
use anyhow::Result;

#[cfg(feature = "view")]
pub fn cmd_view(a: &ViewArgs) -> Result<()> {
    use super::args::Backend;
    use rayspace::view::session::{self, Buffer, Session};
    use rayspace::view::window::{self, WindowOptions};
    if let Some(p) = &a.screenshot {
        super::check::writable("--screenshot", p)?;
        super::check_outputs(&[("--screenshot", p)], &[std::path::Path::new(&a.scene)])?;
    }
    let mut scene = super::load_scene(
        &a.scene,
        &a.look.apply(&a.scene, a.load.options(a.max_memory)),
    )?;
    if let Some(v) = &a.viewpoint {
        super::set_viewpoint(&mut scene, v)?;
    }
    if let Some(p) = &a.screenshot {
        let read: Vec<&std::path::Path> = scene.report.files.iter().map(|f| f.as_path()).collect();
        super::check_outputs(&[("--screenshot", p)], &read)?;
    }
    let need = render::whitted::render_bytes(a.width, a.height, scene.lights.len());
    super::check_memory("a frame", "--width/--height", need, a.max_memory)?;
    let backend = match a.backend {
        Backend::Cpu => session::Backend::Cpu,
        Backend::Gpu => session::Backend::Gpu,
    };
    if let Some(t) = a.time {
        if !t.is_finite() {
            anyhow::bail!("--time {t}: not a finite time");
        }
    }
    let mut s = Session::new(
        scene, a.engine, backend, a.width, a.height, a.bounces, a.time,
    )?;
    s.spp = a.spp;
    s.buffer = match a.buffer.as_str() {
        "normals" => Buffer::Normals,
        "kinds" => Buffer::Kinds,
        "tests" => Buffer::Tests,
        _ => Buffer::Shaded,
    };
    window::run(
        s,
        WindowOptions {
            overlay: a.overlay.unwrap_or(a.screenshot.is_none()),
            screenshot: a.screenshot.clone(),
            frames: a.frames,
            scale: a.scale,
            interval: std::time::Duration::from_millis(a.interval_ms),
        },
    )
}

#[cfg(not(feature = "view"))]
pub fn cmd_view(_a: &ViewArgs) -> Result<()> {
    anyhow::bail!(
        "view: this build has no viewer; build with `cargo build --release --features view`"
    )
}
