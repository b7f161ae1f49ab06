//! `render`'s options checked in one place, before anything is loaded: the engine's options
//! against its declarations (the registry's [`engines::config::config`]: options of another
//! engine or backend, values out of range), options that do not apply to the mode, outputs
//! whose names do not fit what is written, and where the outputs go when none is named.
//! Every refusal is one line and a usage error (exit 2); only options the user gave are
//! refused (defaults adapt).

use super::args::{Backend, EngineFlags, RenderArgs};
use super::UsageError;
use rayspace::engines::{self, Config, Engine};
use std::path::{Path, PathBuf};

/// The configuration `engine` runs with on `backend` with the engine options given (every
/// option checked against the engine's declarations: its name, whether this engine and
/// backend take it, its value); a refusal is a usage error naming the flag.
pub fn engine_config(
    engine: Engine,
    backend: Backend,
    flags: &EngineFlags,
    dynamic: bool,
) -> Result<Config, UsageError> {
    engines::config::config(engine, backend, &flags.asked(dynamic))
        .map_err(|e| UsageError(super::spell::flags_in(&e.to_string())))
}

/// Where `render` writes, settled before the scene loads.
pub struct Outputs {
    /// The PNG, or with `--frames` the frame pattern (`%04d`).
    pub out: PathBuf,
    /// With `--gif` alone: the temporary folder the frames go to, beside the GIF (removed
    /// when dropped, or by the interrupt handler).
    pub temporary: Option<render::output::TempFolder>,
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
/// expect them (the engine's options are [`engine_config`]'s); returns where the outputs
/// go.
pub fn render(a: &RenderArgs) -> Result<Outputs, UsageError> {
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
            let gif = anim.gif.as_ref().expect("matched");
            make_parent("--gif", gif).map_err(|e| UsageError(format!("{e:#}")))?;
            let parent = match gif.parent() {
                Some(d) if !d.as_os_str().is_empty() => d,
                _ => Path::new("."),
            };
            let dir =
                render::output::TempFolder::new_in(parent, ".rayspace-frames-").map_err(|e| {
                    UsageError(format!(
                        "--gif {}: cannot make a folder for its frames beside it: {e}",
                        gif.display()
                    ))
                })?;
            (dir.path().join("%04d.png"), Some(dir))
        }
        (None, Some(_)) => (PathBuf::from(stem).join("%04d.png"), None),
    };
    extension("--out", &out, "png")?;
    if anim.frames.is_some() {
        frame_path(&out, 0)?;
    }
    Ok(Outputs { out, temporary })
}

/// `pattern` with its `%0Nd` (or `%d`) replaced by `frame`: exactly one, in the file's
/// name (a folder per frame, or two numbers in one name, would not be the frames asked for).
pub fn frame_path(pattern: &Path, frame: u32) -> Result<PathBuf, UsageError> {
    let s = pattern.to_string_lossy();
    let bad = |m: String| UsageError(format!("--out {s}: {m}"));
    let name = pattern
        .file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default();
    if pattern
        .parent()
        .is_some_and(|d| d.to_string_lossy().contains('%'))
    {
        return Err(bad(
            "the frame number pattern must be in the file's name, not its folder".into(),
        ));
    }
    if name.matches('%').count() > 1 {
        return Err(bad(
            "one frame number pattern (%04d) in the name, not several".into(),
        ));
    }
    let Some(i) = s.rfind('%') else {
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

/// An output must be writable before any work: its folder exists (made by [`make_parent`]),
/// it is not a directory or a special file, and a file can be created in its folder (a
/// probe made and removed at once: a read-only or special file system, `/sys`, is found
/// now, not after the render).
pub fn writable(opt: &str, out: &Path) -> Result<(), UsageError> {
    render::output::check_writable(out).map_err(|e| UsageError(format!("{opt} {e}")))
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
