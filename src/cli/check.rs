//! `render`'s options checked in one place, before anything is loaded: options that do not
//! apply to the chosen engine, backend or mode, outputs whose names do not fit what is
//! written, and where the outputs go when none is named. Every refusal is one line and a
//! usage error (exit 2); only options the user gave are refused (defaults adapt).

use super::args::{Backend, RenderArgs};
use super::UsageError;
use clap::parser::ValueSource;
use clap::{ArgMatches, Args, Command};
use rayspace::engines::{self, Engine};
use rayspace::keywords;
use rayspace::options::{GridArgs, RshArgs};
use std::path::{Path, PathBuf};

/// Whether the user gave option `id` on the command line.
fn given(m: &ArgMatches, id: &str) -> bool {
    matches!(m.try_get_raw(id), Ok(Some(_))) && m.value_source(id) == Some(ValueSource::CommandLine)
}

/// The engine options (CRSH/RAH's and the grid's) the user gave: (flag, keyword).
pub fn given_engine_options(m: &ArgMatches) -> Vec<(String, String)> {
    let mut v = Vec::new();
    for cmd in [
        RshArgs::augment_args(Command::new("rsh")),
        GridArgs::augment_args(Command::new("grid")),
    ] {
        for arg in cmd.get_arguments() {
            if let Some(long) = arg.get_long() {
                if given(m, arg.get_id().as_str()) {
                    v.push((format!("--{long}"), long.replace('-', "_")));
                }
            }
        }
    }
    v
}

/// Refuse engine options that `engine` does not take (`--levels` with a grid, a grid
/// option with CRSH), naming the engines that do.
pub fn engine_options_apply(m: &ArgMatches, engine: Engine) -> Result<(), UsageError> {
    for (flag, kw) in given_engine_options(m) {
        if !engine.takes(&kw) {
            let takers: Vec<&str> = Engine::NAMES
                .iter()
                .filter(|(_, e)| e.takes(&kw))
                .map(|(n, _)| *n)
                .collect();
            return Err(UsageError(format!(
                "{flag} does not apply to --engine {} (it is an option of --engine {})",
                engine.name(),
                takers.join(", ")
            )));
        }
    }
    Ok(())
}

/// Refuse CRSH/RAH options that the run would not read: the object tree's where there is
/// none (`--object-hierarchy mesh-spheres`), the ones the GPU backend's tree does not take
/// (the depth-first schedule, the SAH builder, a path other than single rays or bundles),
/// and the ray hierarchy's where every batch goes as single rays through the tree. `what`
/// names the command in the message.
pub fn rsh_options_apply(
    m: &ArgMatches,
    engine: Engine,
    r: &RshArgs,
    gpu: bool,
    what: &str,
) -> Result<(), UsageError> {
    let Some(method) = engine.rsh_method() else {
        return Ok(());
    };
    let default = if gpu {
        engines::gpu_default_path(method)
    } else {
        engines::method_default_path(method)
    };
    let no_bvh = engines::objects_for(method, r.objects, gpu) == rsh::ObjectHierarchy::MeshSpheres;
    for (flag, kw) in given_engine_options(m) {
        if no_bvh && ["descent", "schedule", "ray_path", "object_builder"].contains(&kw.as_str()) {
            return Err(UsageError(format!(
                "{flag} applies to the object BVH (--object-hierarchy bvh), which this {what} does not use"
            )));
        }
        if gpu && !no_bvh {
            let refuse = match kw.as_str() {
                "schedule" if r.schedule != rsh::Schedule::Breadth => Some(
                    "the CPU backend: the GPU backend runs the dual traversal level by level (--schedule breadth)",
                ),
                "object_builder" if r.builder != rsh::ObjectBuilder::Lbvh => {
                    Some("the CPU backend: the GPU backend builds the LBVH only (--object-builder lbvh)")
                }
                "ray_path"
                    if !matches!(r.path, Some(rsh::RayPath::Single | rsh::RayPath::Bundles)) =>
                {
                    Some(
                        "the CPU backend: the GPU backend takes the object BVH with single rays or bundles (--ray-path single or bundles)",
                    )
                }
                _ => None,
            };
            if let Some(why) = refuse {
                return Err(UsageError(format!("{flag} applies to {why}")));
            }
        }
    }
    // The ray hierarchy's options do nothing where every batch goes as single rays through
    // the object tree.
    if !no_bvh && r.path.unwrap_or(default).tree_only() {
        for (flag, kw) in given_engine_options(m) {
            if keywords::RAY_HIERARCHY.contains(&kw.as_str()) {
                return Err(UsageError(format!(
                    "{flag} applies to the ray hierarchy (--ray-path bundles or auto, or --object-hierarchy mesh-spheres), and --engine {} traces {} through its object tree here",
                    engine.name(),
                    if r.path.unwrap_or(default) == rsh::RayPath::Packets { "packets of rays" } else { "single rays" }
                )));
            }
        }
    }
    Ok(())
}

/// Where `render` writes, settled before the scene loads.
pub struct Outputs {
    /// The PNG, or with `--frames` the frame pattern (`%04d`).
    pub out: PathBuf,
    /// With `--gif` alone: the temporary folder the frames go to (removed afterwards).
    pub temporary: Option<PathBuf>,
}

/// The name the scene goes by before it is loaded: a built-in's or shared scene's name, a
/// generated scene's spec (`hairball:2M` → `hairball-2M`), else the file's stem
/// (`sponza.obj` → `sponza`).
pub fn scene_stem(spec: &str) -> String {
    if let Some(Ok(_)) = scene::generate::Spec::parse(spec) {
        return scene::generate::Spec::stem(spec);
    }
    let p = Path::new(spec);
    if p.extension().is_some() {
        if let Some(s) = p.file_stem() {
            return s.to_string_lossy().into_owned();
        }
    }
    p.file_name()
        .map(|s| s.to_string_lossy().into_owned())
        .filter(|s| !s.is_empty())
        .unwrap_or_else(|| "rayspace".into())
}

/// An output's name must end in `.ext` (any case).
fn extension(opt: &str, out: &Path, ext: &str) -> Result<(), UsageError> {
    let ok = out
        .extension()
        .is_some_and(|e| e.to_string_lossy().eq_ignore_ascii_case(ext));
    if ok {
        Ok(())
    } else {
        Err(UsageError(format!(
            "{opt} {}: the file name must end in .{ext} (the format written)",
            out.display()
        )))
    }
}

/// Every check of `render`'s options that needs no file, in the order a reader would
/// expect them; returns where the outputs go.
pub fn render(a: &RenderArgs, m: &ArgMatches) -> Result<Outputs, UsageError> {
    let anim = &a.anim;
    if anim.frames.is_none() {
        for (given, opt) in [
            (anim.gif.is_some(), "--gif"),
            (anim.fps.is_some(), "--fps"),
            (anim.frame_csv.is_some(), "--frame-csv"),
        ] {
            if given {
                return Err(UsageError(format!(
                    "{opt} needs --frames N: it applies to the frames of an animation"
                )));
            }
        }
    }
    if let Some(f) = anim.fps {
        if !(f.is_finite() && f > 0.0) {
            return Err(UsageError(format!("--fps {f}: must be a positive number")));
        }
    }
    if let Some(t) = anim.time {
        if !t.is_finite() {
            return Err(UsageError(format!("--time {t}: not a finite time")));
        }
    }
    engine_options_apply(m, a.engine)?;
    if a.backend == Backend::Gpu && !a.engine.has_gpu() {
        return Err(UsageError(format!(
            "--backend gpu: --engine {} has no GPU path (the GPU runs {})",
            a.engine.name(),
            Engine::gpu_names().join(", ")
        )));
    }
    rsh_options_apply(m, a.engine, &a.rsh, a.backend == Backend::Gpu, "render")?;
    if let Some(p) = &a.stats {
        extension("--stats", p, "json")?;
    }
    if let Some(p) = &anim.frame_csv {
        extension("--frame-csv", p, "csv")?;
    }
    if let Some(p) = &anim.gif {
        extension("--gif", p, "gif")?;
    }
    let stem = scene_stem(&a.scene);
    let (out, temporary) = match (&a.out, anim.frames) {
        (Some(o), None) => (o.clone(), None),
        (None, None) => (PathBuf::from(format!("{stem}.png")), None),
        (Some(o), Some(_)) => (o.clone(), None),
        (None, Some(_)) if anim.gif.is_some() => {
            let dir = std::env::temp_dir().join(format!("rayspace-frames-{}", std::process::id()));
            (dir.join("%04d.png"), Some(dir))
        }
        (None, Some(_)) => (PathBuf::from(stem).join("%04d.png"), None),
    };
    extension("--out", &out, "png")?;
    if anim.frames.is_some() {
        frame_path(&out, 0)?;
    }
    Ok(Outputs { out, temporary })
}

/// `pattern` with its `%0Nd` (or `%d`) replaced by `frame`.
pub fn frame_path(pattern: &Path, frame: u32) -> Result<PathBuf, UsageError> {
    let s = pattern.to_string_lossy();
    let bad = |m: String| UsageError(format!("--out {s}: {m}"));
    let Some(i) = s.find('%') else {
        return Err(bad(
            "with --frames the name needs a frame number pattern such as %04d".into(),
        ));
    };
    let rest = &s[i + 1..];
    let Some(d) = rest.find('d') else {
        return Err(bad("expected %d or %0Nd".into()));
    };
    let spec = &rest[..d];
    let width: usize = if spec.is_empty() {
        0
    } else {
        match spec.strip_prefix('0').unwrap_or(spec).parse() {
            Ok(w) if w <= 12 => w,
            _ => return Err(bad(format!("bad frame number pattern %{spec}d"))),
        }
    };
    Ok(PathBuf::from(format!(
        "{}{:0width$}{}",
        &s[..i],
        frame,
        &rest[d + 1..]
    )))
}

/// Make the folder an output goes into (`--out new/dir/x.png`), naming the option when
/// that fails.
pub fn make_parent(opt: &str, out: &Path) -> anyhow::Result<()> {
    if let Some(d) = out.parent().filter(|d| !d.as_os_str().is_empty()) {
        if !d.is_dir() {
            std::fs::create_dir_all(d).map_err(|e| {
                anyhow::anyhow!("{opt} {}: cannot make its folder: {e}", out.display())
            })?;
        }
    }
    Ok(())
}
