//! A hostile environment, as an attacker or an unlucky user makes it: planted links and
//! files where temporaries go, outputs that name inputs or each other, outputs nobody can
//! write, signals and file-size limits, control characters in names, cameras that overflow.
//! Every case gets one clear line and the right exit status, changes no file outside the
//! named outputs, and leaves no temporary behind.

use crate::common::{bin, fails, ok, tmp, words};
use std::path::Path;

/// The names in `d` that look like a temporary of ours.
fn temporaries(d: &Path) -> Vec<String> {
    std::fs::read_dir(d)
        .unwrap()
        .filter_map(|e| e.ok())
        .map(|e| e.file_name().to_string_lossy().into_owned())
        .filter(|n| n.starts_with(".rayspace-"))
        .collect()
}

const TRI_OBJ: &str = "mtllib tri.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl m\nf 1 2 3\n";
const TRI_MTL: &str = "newmtl m\nKd 0.5 0.5 0.5\n";

/// A planted symbolic link at the output is replaced, not written through; a replaced
/// output keeps its permissions; a 240-byte name works; nothing temporary remains.
#[test]
fn outputs_are_replaced_never_redirected() {
    let d = tmp("hostile-links");
    let target = d.join("victim.txt");
    std::fs::write(&target, "keep me").unwrap();
    let out = d.join("x.png");
    #[cfg(unix)]
    std::os::unix::fs::symlink(&target, &out).unwrap();
    ok(&words(&format!(
        "render cornell -W 16 -H 16 -b 0 --out {}",
        out.display()
    )));
    assert_eq!(std::fs::read_to_string(&target).unwrap(), "keep me");
    assert!(!std::fs::symlink_metadata(&out).unwrap().is_symlink());
    #[cfg(unix)]
    {
        use std::os::unix::fs::PermissionsExt as _;
        std::fs::set_permissions(&out, std::fs::Permissions::from_mode(0o600)).unwrap();
        ok(&words(&format!(
            "render cornell -W 16 -H 16 -b 0 --out {}",
            out.display()
        )));
        let mode = std::fs::metadata(&out).unwrap().permissions().mode();
        assert_eq!(mode & 0o777, 0o600, "the output kept its permissions");
    }
    let long = d.join(format!("{}.png", "n".repeat(236)));
    ok(&words(&format!(
        "render cornell -W 16 -H 16 -b 0 --out {}",
        long.display()
    )));
    assert!(long.exists());
    assert!(temporaries(&d).is_empty(), "{:?}", temporaries(&d));
}

/// No output may be a file the command reads, the scene's included files among them, or
/// another output of the same command: exit 2, one line, nothing written; the same commands
/// with distinct paths run.
#[test]
fn outputs_never_clobber_inputs_or_each_other() {
    let d = tmp("hostile-clobber");
    let (obj, mtl) = (d.join("tri.obj"), d.join("tri.mtl"));
    std::fs::write(&obj, TRI_OBJ).unwrap();
    std::fs::write(&mtl, TRI_MTL).unwrap();
    let rays = d.join("r.rays");
    ok(&words(&format!(
        "rays {} --kind random -W 8 -H 8 -o {}",
        obj.display(),
        rays.display()
    )));
    // A material library may have any name, an output's too.
    let (obj2, lib) = (d.join("tri2.obj"), d.join("lib.json"));
    std::fs::write(&obj2, TRI_OBJ.replace("tri.mtl", "lib.json")).unwrap();
    std::fs::write(&lib, TRI_MTL).unwrap();
    let (o, m, r) = (obj.display(), mtl.display(), rays.display());
    let (o2, l) = (obj2.display(), lib.display());
    let png = d.join("a.png");
    for (cmd, needle) in [
        (format!("rays {o} -W 8 -H 8 -o {m}"), "--out"),
        (format!("trace {r} --scene {o} -o {m}"), "--out"),
        (format!("trace {r} --scene {o} -o {r}"), "--out"),
        (
            format!("render {o2} -W 8 -H 8 -o {} --stats {l}", png.display()),
            "--stats",
        ),
    ] {
        let out = bin().args(words(&cmd)).output().unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{cmd}: {err}");
        assert!(
            err.contains(needle) && err.contains("is an input of this command"),
            "{cmd}: {err}"
        );
    }
    assert_eq!(std::fs::read_to_string(&mtl).unwrap(), TRI_MTL);
    assert_eq!(std::fs::read_to_string(&lib).unwrap(), TRI_MTL);
    assert!(!png.exists(), "refused before rendering");
    let x = d.join("x.json");
    fails(
        &words(&format!(
            "trace {r} --scene {o} -o {} --json {}",
            x.display(),
            x.display()
        )),
        &["--out and --json name the same file"],
    );
    fails(
        &words(&format!(
            "bench rsh --scenes cornell --width 8 --height 8 --json {} --csv {}",
            x.display(),
            x.display()
        )),
        &["--json and --csv name the same file"],
    );
    ok(&words(&format!(
        "trace {r} --scene {o} -o {} --json {}",
        d.join("h.hits").display(),
        x.display()
    )));
    assert!(temporaries(&d).is_empty());
}

/// Outputs are checked before the scene loads: a folder nothing can be written to, frame
/// patterns with two numbers or a number in a folder's name.
#[test]
fn unwritable_outputs_and_bad_patterns_are_refused_first() {
    let d = tmp("hostile-outputs");
    let t0 = std::time::Instant::now();
    // A missing scene would exit 1: these exit 2 before it is looked for.
    for (args, needle) in [
        ("-o /sys/x.png".to_string(), "--out"),
        (
            format!("--frames 2 --out {}/a%d/x.png", d.display()),
            "not its folder",
        ),
        (
            format!("--frames 2 --out {}/x%d-%d.png", d.display()),
            "not several",
        ),
    ] {
        let cmd = format!("render no-such-scene.obj {args}");
        let out = bin().args(words(&cmd)).output().unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{cmd}: {err}");
        assert!(err.contains(needle), "{cmd}: {err}");
        assert_eq!(err.trim().lines().count(), 1, "{err}");
    }
    assert!(t0.elapsed().as_secs() < 20);
}

/// A file-size limit turns the write that passes it into an error (not a kill by SIGXFSZ),
/// and SIGINT while `--gif` renders removes its frames' folder; each says so in one line.
#[cfg(unix)]
#[test]
fn limits_and_signals_leave_nothing_behind() {
    let d = tmp("hostile-signals");
    let exe = env!("CARGO_BIN_EXE_rayspace");
    let out = std::process::Command::new("bash")
        .arg("-c")
        .arg(format!(
            "ulimit -f 4; exec {exe} render office -W 256 -H 256 -b 0 -o {}/big.png",
            d.display()
        ))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(err.contains("--out") && err.contains("too large"), "{err}");
    assert!(temporaries(&d).is_empty(), "{:?}", temporaries(&d));
    // An animation long enough to be interrupted while its frames are written.
    let anim = d.join("anim.toml");
    std::fs::write(
        &anim,
        "[[meshes]]\nbuiltin = \"office\"\n[meshes.animation]\nkeys = [{ t = 0 }, { t = 1, translate = [0.1, 0, 0] }]\n",
    )
    .unwrap();
    let child = std::process::Command::new(exe)
        .args(words(&format!(
            "render {} --frames 2000 -W 96 -H 96 --gif {}/a.gif",
            anim.display(),
            d.display()
        )))
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::piped())
        .spawn()
        .unwrap();
    // Wait until the frames' folder exists, then interrupt.
    let t0 = std::time::Instant::now();
    while temporaries(&d).is_empty() && t0.elapsed().as_secs() < 30 {
        std::thread::sleep(std::time::Duration::from_millis(20));
    }
    std::thread::sleep(std::time::Duration::from_millis(300));
    // SAFETY: a plain kill(2) of our own child.
    unsafe { libc::kill(child.id() as i32, libc::SIGINT) };
    let out = child.wait_with_output().unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(130), "{err}");
    assert!(err.contains("interrupted by SIGINT"), "{err}");
    assert!(temporaries(&d).is_empty(), "{:?}", temporaries(&d));
    assert!(!d.join("a.gif").exists());
}

/// Control characters from a file are escaped when printed; a camera whose direction
/// overflows is refused and blamed on the camera.
#[test]
fn text_and_cameras_from_files_are_checked() {
    let d = tmp("hostile-text");
    let toml = d.join("s.toml");
    std::fs::write(
        &toml,
        "name = \"evil\\u001b[2Jname\"\n[[meshes]]\nbuiltin = \"cornell\"\n",
    )
    .unwrap();
    let o = ok(&words(&format!(
        "render {} -W 8 -H 8 -b 0 -o {}",
        toml.display(),
        d.join("s.png").display()
    )));
    let text = String::from_utf8_lossy(&o.stdout);
    assert!(!text.contains('\u{1b}'), "raw escape printed");
    assert!(text.contains("evil\\x1b[2Jname"), "{text}");
    std::fs::write(
        &toml,
        "[camera]\neye = [-3e38, 0, 0]\ntarget = [3e38, 0, 0]\n[[meshes]]\nbuiltin = \"cornell\"\n",
    )
    .unwrap();
    fails(
        &words(&format!("render {} -W 8 -H 8", toml.display())),
        &["camera"],
    );
    fails(
        &words(&format!(
            "rays cornell --viewpoint=-3e38,0,0,3e38,0,0 -o {}",
            d.join("r.rays").display()
        )),
        &["--viewpoint", "camera"],
    );
}

/// Two scenes with the same file name in different folders: the report gives each its own
/// section and images.
#[test]
fn report_scenes_that_share_a_file_name_stay_apart() {
    let d = tmp("hostile-report");
    let mut specs = Vec::new();
    for (k, shift) in [("a", 0.0), ("b", 2.0)] {
        let sub = d.join(k);
        std::fs::create_dir_all(&sub).unwrap();
        let obj = TRI_OBJ.replace("v 0 1 0", &format!("v 0 1 {shift}"));
        std::fs::write(sub.join("tri.obj"), obj).unwrap();
        std::fs::write(sub.join("tri.mtl"), TRI_MTL).unwrap();
        specs.push(sub.join("tri.obj").display().to_string());
    }
    let out = d.join("report");
    ok(&words(&format!(
        "report --quick --size 16 --scenes {} -o {}",
        specs.join(","),
        out.display()
    )));
    let json: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(out.join("report.json")).unwrap()).unwrap();
    let ids: Vec<&str> = json["scenes"]
        .as_array()
        .unwrap()
        .iter()
        .map(|s| s["id"].as_str().unwrap())
        .collect();
    assert_eq!(ids, ["tri", "tri-2"]);
    let html = std::fs::read_to_string(out.join("index.html")).unwrap();
    for id in ids {
        assert!(html.contains(&format!("id=\"scene-{id}\"")), "{id}");
        assert!(out.join(format!("img/{id}-grid.png")).exists(), "{id}");
    }
}

/// The memory limit bounds the whole process: with every engine, a render under
/// `--max-memory` either peaks within it (10 % allowed) or is refused before allocating,
/// with one line and status 1; a limit from `ulimit -v` is kept the same way, and an
/// allocation the system refuses anyway ends with one line too, never an abort or a panic.
#[test]
fn memory_limits_bound_every_engine() {
    let d = tmp("hostile-memory");
    let engines = [
        "bvh",
        "crsh",
        "rah",
        "grid",
        "grid2l",
        "obvhs-cwbvh",
        "obvhs-bvh2",
        "brute",
    ];
    let limit_mib = 120u64;
    let (mut ran, mut refused) = (0, 0);
    for e in engines {
        let json = d.join(format!("{e}.json"));
        let out = bin()
            .args(words(&format!(
                "render hairball:120k -b 0 -W 32 -H 32 -e {e} --max-memory {limit_mib} --out {} --stats {}",
                d.join(format!("{e}.png")).display(),
                json.display()
            )))
            .output()
            .unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert!(
            !err.contains("panicked") && !err.contains("memory allocation"),
            "{e}: {err}"
        );
        if out.status.success() {
            let v: serde_json::Value =
                serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
            let peak = v["peak_rss_bytes"].as_u64().unwrap();
            assert!(
                peak <= limit_mib * (1 << 20) * 11 / 10,
                "{e}: peak {peak} over --max-memory {limit_mib} MiB"
            );
            ran += 1;
        } else {
            assert_eq!(out.status.code(), Some(1), "{e}: {err}");
            assert!(err.contains("--max-memory"), "{e}: {err}");
            assert_eq!(err.trim().lines().count(), 1, "{e}: {err}");
            refused += 1;
        }
    }
    assert!(ran > 0 && refused > 0, "{ran} ran, {refused} refused");
    // Far too large for the limit: refused while the scene is made, at once.
    let t0 = std::time::Instant::now();
    fails(
        &words(&format!(
            "render hairball:2M -b 0 -W 64 -H 64 --max-memory 200 --out {}",
            d.join("x.png").display()
        )),
        &["--max-memory", "triangles"],
    );
    assert!(t0.elapsed().as_secs() < 10, "refused before generating");
    #[cfg(unix)]
    {
        let exe = env!("CARGO_BIN_EXE_rayspace");
        let mut cases = vec![
            (700_000, "render hairball:2M -b 0 -W 64 -H 64"),
            (
                700_000,
                "render hairball:2M -b 0 -W 64 -H 64 -e obvhs-cwbvh",
            ),
        ];
        // So little that the render's own allocations fail. (A binary linked with Embree
        // cannot even be loaded in so little address space: the dynamic loader's refusal,
        // before any of the program runs, is not the program's to word.)
        if !cfg!(feature = "embree") {
            cases.push((30_000, "render cornell -W 64 -H 64"));
        }
        for (vm, cmd) in cases {
            let out = std::process::Command::new("bash")
                .arg("-c")
                .arg(format!(
                    "ulimit -v {vm}; exec {exe} {cmd} --out {}",
                    d.join("u.png").display()
                ))
                .output()
                .unwrap();
            let err = String::from_utf8_lossy(&out.stderr);
            assert_eq!(out.status.code(), Some(1), "ulimit -v {vm} {cmd}: {err}");
            let lines: Vec<&str> = err.trim().lines().collect();
            assert_eq!(lines.len(), 1, "ulimit -v {vm} {cmd}: {err}");
            assert!(
                lines[0].starts_with("error: ") && !err.contains("panicked"),
                "{err}"
            );
        }
    }
    assert!(temporaries(&d).is_empty());
}

/// Paths from the environment: a scenes folder that is not one is said once (the built-in
/// scenes still render); the viewer without a display and the GPU backend without a
/// runtime folder print no dependency's paths or driver noise.
#[test]
fn the_environment_is_checked_and_said_once() {
    let d = tmp("hostile-env");
    let file = d.join("not-a-folder");
    std::fs::write(&file, "x").unwrap();
    let out = bin()
        .args(words(&format!(
            "render cornell -W 8 -H 8 -b 0 --out {}",
            d.join("c.png").display()
        )))
        .env("RAYSPACE_SCENES", &file)
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert!(out.status.success(), "{err}");
    assert_eq!(err.matches("RAYSPACE_SCENES").count(), 1, "{err}");
    assert!(err.contains("not a folder"), "{err}");
    let out = bin()
        .args(words(&format!(
            "view cornell --screenshot {}",
            d.join("v.png").display()
        )))
        .env_remove("DISPLAY")
        .env_remove("WAYLAND_DISPLAY")
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    assert_eq!(out.status.code(), Some(1), "{err}");
    assert!(err.contains("cannot reach a display"), "{err}");
    assert!(!err.contains("registry") && !err.contains(".rs:"), "{err}");
    let out = bin()
        .args(words(&format!(
            "render cornell -W 8 -H 8 -b 0 --backend gpu --out {}",
            d.join("g.png").display()
        )))
        .env_remove("XDG_RUNTIME_DIR")
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&out.stderr);
    if out.status.success() {
        assert!(!err.contains("XDG_RUNTIME_DIR"), "{err}");
    } else {
        testkit::skip("gpu", format!("no GPU backend here: {err}"));
    }
}
