//! The command line: a good render writes a PNG and JSON; bad input gets a one-line error
//! naming the file, line or option, a non-zero exit, and never a panic.

use super::common::{bin, fails, ok, tmp, words};
use std::path::Path;

/// The README's first command: `rayspace` with no arguments renders the default scene to
/// `spheres.png` (512×512, named after the scene) in the working directory, prints the stats
/// table and says where the image went.
#[test]
fn no_arguments_render_the_default_scene() {
    let dir = tmp("default");
    let o = bin().current_dir(&dir).output().unwrap();
    assert!(o.status.success(), "{}", String::from_utf8_lossy(&o.stderr));
    let stdout = String::from_utf8_lossy(&o.stdout);
    assert!(
        stdout.contains("| spheres") || stdout.contains("spheres"),
        "{stdout}"
    );
    assert!(stdout.contains("wrote spheres.png"), "{stdout}");
    let img = image::open(dir.join("spheres.png")).unwrap().to_rgb8();
    assert_eq!(img.dimensions(), (512, 512));
    // Not a blank frame: the sky, the checkerboard's two tiles and the lit spheres give
    // many distinct colours.
    let mut colours: Vec<[u8; 3]> = img.pixels().map(|p| p.0).collect();
    colours.sort_unstable();
    colours.dedup();
    assert!(colours.len() > 1000, "{} colours", colours.len());
    std::fs::remove_dir_all(&dir).ok();
}

#[test]
fn usage_errors_are_one_line_with_status_2() {
    for args in [
        &["render", "--width", "abc"][..],
        &["render", "--engine", "warp"],
        &["render", "--no-such-option"],
        &["bench"],
    ] {
        let out = bin().args(args).output().unwrap();
        let err = String::from_utf8_lossy(&out.stderr);
        assert_eq!(out.status.code(), Some(2), "{args:?}: {err}");
        assert_eq!(err.lines().count(), 1, "{args:?}: {err}");
        assert!(err.starts_with("error: "), "{err}");
    }
    // A run-time error (the file, not the usage) exits with 1.
    let out = bin()
        .args(["render", "no-such-scene.obj"])
        .output()
        .unwrap();
    assert_eq!(out.status.code(), Some(1));
    // --help still prints the help and succeeds.
    let out = bin().args(["render", "--help"]).output().unwrap();
    assert!(out.status.success());
    assert!(String::from_utf8_lossy(&out.stdout).contains("--engine"));
}

#[test]
fn render_writes_png_and_stats() {
    let d = tmp("ok");
    let png = d.join("a.png");
    let json = d.join("a.json");
    let out = ok(&words(&format!(
        "render spheres --width 40 --height 30 --bounces 1 --out {} --stats {}",
        png.display(),
        json.display()
    )));
    let stdout = String::from_utf8_lossy(&out.stdout);
    assert!(
        stdout.contains("| rasterize |") && stdout.contains("brute force (rays x triangles)"),
        "{stdout}"
    );
    let img = image::open(&png).unwrap();
    assert_eq!((img.width(), img.height()), (40, 30));
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
    assert!(v["total_tests"].as_u64().unwrap() > 0);
    assert!(v["brute_force_tests"].as_u64().unwrap() >= v["total_tests"].as_u64().unwrap());
    assert_eq!(v["engine"], "bvh");
    assert_eq!(v["engine_config"]["ray-path"], "packets");
    // Same command again: identical image bytes.
    let png2 = d.join("b.png");
    let out = bin()
        .args([
            "render",
            "spheres",
            "--width",
            "40",
            "--height",
            "30",
            "--bounces",
            "1",
            "--out",
            png2.to_str().unwrap(),
        ])
        .output()
        .unwrap();
    assert!(out.status.success());
    assert_eq!(std::fs::read(&png).unwrap(), std::fs::read(&png2).unwrap());
}

fn write(d: &Path, name: &str, text: &str) -> String {
    let p = d.join(name);
    std::fs::write(&p, text).unwrap();
    p.to_str().unwrap().to_string()
}

#[test]
fn bad_files() {
    let d = tmp("bad");
    let out = d.join("x.png");
    let o = out.to_str().unwrap();
    fails(
        &["render", "/nonexistent/scene.obj", "--out", o],
        &["/nonexistent/scene.obj"],
    );
    fails(
        &["render", "no-such-scene", "--out", o],
        &["no-such-scene", "cornell"],
    );
    let p = write(&d, "nan.obj", "v 0 0 0\nv 1 0 0\nv 0 NaN 0\nf 1 2 3\n");
    fails(&["render", &p, "--out", o], &["nan.obj:3:", "non-finite"]);
    let p = write(&d, "idx.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 9\n");
    fails(&["render", &p, "--out", o], &["idx.obj:4:", "out of range"]);
    let p = write(&d, "empty.obj", "# nothing here\n");
    fails(&["render", &p, "--out", o], &["empty.obj", "no triangles"]);
    let p = write(&d, "flat.obj", "v 0 0 0\nv 1 1 1\nv 2 2 2\nf 1 2 3\n");
    fails(
        &["render", &p, "--out", o],
        &["flat.obj", "no triangles", "degenerate"],
    );
    let p = write(&d, "bad.toml", "[[meshes]]\nshape = \"box\"\nwat = 1\n");
    fails(&["render", &p, "--out", o], &["bad.toml:3:", "wat"]);
    let p = write(&d, "bad.gltf", "{ not json");
    fails(&["render", &p, "--out", o], &["bad.gltf"]);
    let p = write(&d, "scene.txt", "hello");
    fails(&["render", &p, "--out", o], &["scene.txt", "unsupported"]);
    // An output folder is made when missing, but not under a file.
    let under_file = format!("{p}/x.png");
    fails(
        &["render", "cornell", "--out", &under_file],
        &["--out", "x.png"],
    );
    // A directory where a file is expected.
    fails(&["render", d.to_str().unwrap(), "--out", o], &[]);
    // A small file that expands past the memory limit stops while it loads (24 MiB, less
    // what the program holds, at about 470 bytes a triangle with the default engine's
    // build: some 25,000 triangles; 100 spheres are about 100,000).
    let spheres: String = (0..100).map(|i| format!("s {i} 0 0 0.5\n")).collect();
    let p = write(&d, "spheres.aff", &spheres);
    fails(
        &[
            "render",
            &p,
            "--out",
            o,
            "-W",
            "16",
            "-H",
            "16",
            "--max-memory",
            "24",
        ],
        &["spheres.aff:", "load budget", "--max-memory"],
    );
}

#[test]
fn bad_options() {
    fails(&["render", "cornell", "--width", "0"], &["--width"]);
    fails(&["render", "cornell", "--height", "100000"], &["--height"]);
    fails(&["render", "cornell", "--width", "abc"], &["--width"]);
    fails(&["render", "cornell", "--bounces", "99"], &["--bounces"]);
    fails(
        &["render", "cornell", "--engine", "warp"],
        &["--engine", "warp"],
    );
    fails(&["render", "cornell", "--meshes", "blobs"], &["--meshes"]);
    fails(
        &words("render cornell -e crsh --branching 1"),
        &["--branching"],
    );
    fails(&words("render cornell -e crsh --levels 99"), &["--levels"]);
    fails(
        &words("render cornell -e crsh --pair-budget 10"),
        &["--pair-budget"],
    );
    fails(&words("render cornell -e crsh --hash sha256"), &["--hash"]);
    fails(
        &words("render cornell -e crsh --hash-bits 4,13,9,7"),
        &["--hash-bits", "30 bits"],
    );
    fails(
        &words("render cornell -e crsh --hash-bits 4,13"),
        &["--hash-bits"],
    );
    fails(
        &words("render cornell --engine grid --grid-top-density 0"),
        &["--grid-top-density", "(0, 10000]"],
    );
    fails(
        &["render", "cornell", "--engine", "grid", "--grid-alpha", "2"],
        &["--grid-alpha", "0..=1"],
    );
    fails(
        &words("trace r.rays --scene cornell --repeat 0"),
        &["--repeat"],
    );
    fails(
        &words("trace r.rays --scene cornell --repeat 1001"),
        &["--repeat"],
    );
}

#[test]
fn embree_engine_without_or_with_the_feature() {
    let d = tmp("embree");
    let out = d.join("e.png");
    let args = [
        "render",
        "cornell",
        "--engine",
        "embree",
        "--width",
        "32",
        "--height",
        "24",
        "--out",
        out.to_str().unwrap(),
    ];
    if cfg!(feature = "embree") {
        ok(&args);
        assert!(out.exists());
    } else {
        fails(
            &args,
            &["--engine embree", "--features embree", "libembree-dev"],
        );
    }
}

#[test]
fn degenerate_triangles_are_skipped_and_reported() {
    let d = tmp("deg");
    let p = write(
        &d,
        "deg.obj",
        "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 2 0 0\nf 1 2 3\nf 1 2 4\n",
    );
    let png = d.join("deg.png");
    let out = ok(&[
        "render",
        &p,
        "--width",
        "16",
        "--height",
        "16",
        "--out",
        png.to_str().unwrap(),
    ]);
    assert!(String::from_utf8_lossy(&out.stdout).contains("1 degenerate triangles skipped"));
}

#[test]
fn frames_time_and_budget() {
    let d = tmp("frames");
    std::fs::write(
        d.join("anim.toml"),
        "[camera]\neye = [0, 2, 8]\ntarget = [0, 0, 0]\n[[meshes]]\nshape = \"plane\"\nscale = 5\n[[meshes]]\nshape = \"box\"\n[meshes.animation]\nkeys = [{ t = 0 }, { t = 1, translate = [2, 1, 0], rotate = [0, 90, 0] }]\n",
    )
    .unwrap();
    let scene = d.join("anim.toml");
    let pat = d.join("f%03d.png");
    let csv = d.join("frames.csv");
    let gif = d.join("a.gif");
    ok(&words(&format!("render {} --frames 4 --width 32 --height 24 --engine grid --out {} --frame-csv {} --gif {}", scene.display(), pat.display(), csv.display(), gif.display())));
    for i in 0..4 {
        assert!(d.join(format!("f{i:03}.png")).exists());
    }
    let c = std::fs::read_to_string(&csv).unwrap();
    assert_eq!(c.lines().count(), 5, "{c}");
    assert!(
        c.lines().nth(4).unwrap().starts_with("3,1,"),
        "last frame at t = 1: {c}"
    );
    assert!(std::fs::metadata(&gif).unwrap().len() > 100);
    // The box moves: first and last frames differ; a repeated run is byte-identical.
    let f0 = std::fs::read(d.join("f000.png")).unwrap();
    assert_ne!(f0, std::fs::read(d.join("f003.png")).unwrap());
    let one = d.join("one.png");
    ok(&words(&format!(
        "render {} --time 0 --width 32 --height 24 --engine grid --out {}",
        scene.display(),
        one.display()
    )));
    assert_eq!(std::fs::read(&one).unwrap(), f0, "--time 0 renders frame 0");
    fails(
        &words(&format!(
            "render cornell --frames 3 --out {}",
            pat.display()
        )),
        &["--frames", "not animated"],
    );
    fails(
        &["render", "cornell", "--time", "1"],
        &["--time", "not animated"],
    );
    fails(
        &[
            "render",
            scene.to_str().unwrap(),
            "--frames",
            "3",
            "--out",
            d.join("x.png").to_str().unwrap(),
        ],
        &["--out", "%04d"],
    );
    fails(
        &words(&format!(
            "render {} --frames 3 --fps -2 --out {}",
            scene.display(),
            pat.display()
        )),
        &["--fps"],
    );
    // Table 4 in miniature.
    let o = ok(&words(&format!("bench budget {} --width 32 --height 32 --frames 2 --engines grid,grid2l,obvhs-bvh2 --ms 100,5", scene.display())));
    let md = String::from_utf8_lossy(&o.stdout);
    assert!(
        md.contains("AO spp in 100 ms")
            && md.contains("| grid2l |")
            && md.contains("| obvhs-bvh2 |"),
        "{md}"
    );
    fails(
        &["bench", "budget", "cornell", "--engines", "warp"],
        &["--engines", "warp"],
    );
    fails(&["bench", "budget", "cornell", "--ms", "0"], &["--ms"]);
}

/// `--object-hierarchy` on render and trace: the BVH's build is a pass of the engine build,
/// its counters are in the stats, the image equals the thesis configuration's, and a bad
/// value names the option.
#[test]
fn object_hierarchy_option() {
    let d = tmp("objects");
    let mut images = Vec::new();
    for (k, objects) in ["mesh-spheres", "bvh"].into_iter().enumerate() {
        let (png, json) = (d.join(format!("o{k}.png")), d.join(format!("o{k}.json")));
        let out = ok(&words(&format!(
            "render office --engine crsh --width 40 --height 30 --object-hierarchy {objects} --out {} --stats {}",
            png.display(),
            json.display()
        )));
        let table = String::from_utf8_lossy(&out.stdout);
        let stats = std::fs::read_to_string(&json).unwrap();
        assert_eq!(table.contains("build: object hierarchy"), k == 1, "{table}");
        assert_eq!(stats.contains("ray-box tests"), k == 1, "{stats}");
        images.push(std::fs::read(&png).unwrap());
    }
    assert_eq!(
        images[0], images[1],
        "the same image with either object side"
    );
    fails(
        &words("render office --object-hierarchy octree"),
        &["--object-hierarchy"],
    );
    fails(&words("render office --descent sideways"), &["--descent"]);
}

/// The grid's build passes are in the stats table (indented under "engine build", not added
/// to the total again) and in the JSON; `--grid-subdivision` takes both rules.
#[test]
fn grid_build_passes_in_stats() {
    let d = tmp("gridpasses");
    for sub in ["paper", "adaptive"] {
        let json = d.join(format!("{sub}.json"));
        let out = ok(&[
            "render",
            "stadium",
            "--engine",
            "grid",
            "--grid-subdivision",
            sub,
            "--width",
            "32",
            "--height",
            "24",
            "--bounces",
            "0",
            "--out",
            d.join(format!("{sub}.png")).to_str().unwrap(),
            "--stats",
            json.to_str().unwrap(),
        ]);
        let stdout = String::from_utf8_lossy(&out.stdout);
        let ms = |row: &str| -> f64 {
            let line = stdout
                .lines()
                .find(|l| l.starts_with(&format!("| {row} |")))
                .unwrap_or_else(|| panic!("no row {row}:\n{stdout}"));
            line.split('|').nth(2).unwrap().trim().parse().unwrap()
        };
        let phases = [
            "engine build",
            "rasterize",
            "ray creation",
            "trace",
            "shading",
        ];
        let sum: f64 = phases.iter().map(|p| ms(p)).sum();
        assert!((ms("**total**") - sum).abs() < 0.5, "{stdout}");
        let v: serde_json::Value =
            serde_json::from_str(&std::fs::read_to_string(&json).unwrap()).unwrap();
        let names: Vec<&str> = v["phases"]
            .as_array()
            .unwrap()
            .iter()
            .map(|p| p[0].as_str().unwrap())
            .collect();
        for p in ["top_refs", "octrees", "cells", "merge", "expansion"] {
            assert!(
                names.contains(&format!("  build: {p}").as_str()),
                "{names:?}"
            );
        }
    }
    fails(
        &["render", "cornell", "--grid-subdivision", "dense"],
        &["--grid-subdivision"],
    );
}

#[test]
fn outputs_are_checked_before_work_and_never_clobber_inputs() {
    let d = tmp("outputs");
    let obj = write(&d, "victim.obj", "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n");
    let before = std::fs::read(&obj).unwrap();
    // An output that is an input is refused, and the input stays as it was.
    fails(
        &words(&format!("rays {obj} --width 4 --height 4 --out {obj}")),
        &["--out", "is an input"],
    );
    assert_eq!(std::fs::read(&obj).unwrap(), before);
    let rays = d.join("r.rays");
    ok(&words(&format!(
        "rays cornell --width 4 --height 4 --out {}",
        rays.display()
    )));
    let rays_before = std::fs::read(&rays).unwrap();
    fails(
        &words(&format!(
            "trace {} --scene cornell --out {}",
            rays.display(),
            rays.display()
        )),
        &["--out", "is an input"],
    );
    assert_eq!(std::fs::read(&rays).unwrap(), rays_before);
    // A device is not a ray file (it used to be read without bound).
    fails(
        &["trace", "/dev/zero", "--scene", "cornell"],
        &["/dev/zero", "regular file"],
    );
    // The format is the file name's: PNG bytes are not written to x.jpg.
    fails(
        &words(&format!(
            "render cornell --out {}",
            d.join("x.jpg").display()
        )),
        &["--out", ".png"],
    );
    // Special files are never written (`--out /dev/full` used to exit 0 saying "wrote").
    fails(
        &[
            "rays",
            "cornell",
            "--width",
            "4",
            "--height",
            "4",
            "--out",
            "/dev/full",
        ],
        &["--out", "/dev/full", "regular file"],
    );
    // An unwritable --stats is found before the image is rendered or replaced.
    let png = d.join("keep.png");
    std::fs::write(&png, b"previous image").unwrap();
    fails(
        &words(&format!(
            "render cornell --width 8 --height 8 --out {} --stats {}/s.json",
            png.display(),
            png.display()
        )),
        &["--stats", "cannot make its folder"],
    );
    assert_eq!(std::fs::read(&png).unwrap(), b"previous image");
    // A successful write replaces the file whole and leaves no temporary beside it.
    ok(&words(&format!(
        "render cornell --width 8 --height 8 --out {}",
        png.display()
    )));
    assert!(std::fs::read(&png).unwrap().starts_with(b"\x89PNG"));
    let stray: Vec<_> = std::fs::read_dir(&d)
        .unwrap()
        .filter_map(|e| e.ok())
        .filter(|e| e.file_name().to_string_lossy().ends_with(".tmp"))
        .collect();
    assert!(stray.is_empty(), "temporaries left: {stray:?}");
}

#[test]
fn absurd_sizes_are_refused_before_allocating() {
    // Within the advertised 16384 limit, but far beyond this machine's memory: refused at
    // once by the memory model (these used to abort in the rasterizer and in `rays`).
    let d = tmp("sizes");
    let out = d.join("x.png");
    let t0 = std::time::Instant::now();
    fails(
        &words(&format!(
            "render cornell --width 16384 --height 16384 --out {}",
            out.display()
        )),
        &["--width/--height", "GiB", "--max-memory"],
    );
    fails(
        &words(&format!(
            "rays cornell --width 16384 --height 16384 --out {}",
            d.join("r.rays").display()
        )),
        &["--width/--height/--spp", "--max-memory"],
    );
    assert!(t0.elapsed().as_secs() < 30, "refused before any work");
    assert!(!out.exists());
    // --max-memory is the limit: a 64 × 48 render needs about 1.7 MiB.
    let small = format!(
        "render cornell --width 64 --height 48 --out {}",
        out.display()
    );
    fails(
        &words(&format!("{small} --max-memory 1")),
        &["--max-memory"],
    );
    // CRSH's pairs fit what is left by a lower budget (more batches, the same hits), and
    // the stats say so.
    let o = ok(&words(&format!(
        "{small} -e crsh --max-memory 64 --stats {}",
        d.join("s.json").display()
    )));
    assert!(
        String::from_utf8_lossy(&o.stdout).contains("--pair-budget lowered from 16777216"),
        "{}",
        String::from_utf8_lossy(&o.stdout)
    );
    let v: serde_json::Value =
        serde_json::from_str(&std::fs::read_to_string(d.join("s.json")).unwrap()).unwrap();
    let adapted = &v["engine_adapted"]["pair-budget"];
    assert_eq!(adapted["asked"], 16777216, "{v}");
    assert!(adapted["used"].as_u64().unwrap() < 16777216);
    assert_eq!(v["engine_config"]["pair-budget"], adapted["used"]);
    // The grid's memory model gets what the render leaves: densities in range but beyond
    // 64 MiB are refused as the cells are made, before storing (the bunny at λ = 10⁴ used to
    // take 7 GB and abort), and the message names the options on both sides.
    for g in [
        "--grid-top-density 1000",
        "--grid-top-density 10 --grid-leaf-density 10000",
    ] {
        let office = small.replace("cornell", "office");
        fails(
            &words(&format!("{office} --engine grid {g} --max-memory 64")),
            &["--max-memory", "--grid-top-density", "MiB"],
        );
    }
    ok(&words(&format!("{small} --engine grid --max-memory 64")));
}

#[test]
fn bart_ambient_light_lights_what_the_point_light_does_not() {
    // A quad facing the camera, its point light behind it: black by eq. 3.19 alone; BART's
    // `am` × `fm` ambient shows it. GPU and CPU agree where the GPU runs.
    let d = tmp("ambient");
    let scene = |am: &str| {
        format!(
            "v\nfrom 0 0 5\nat 0 0 0\nup 0 1 0\nangle 40\nhither 1\nresolution 16 16\n\
             b 0 0 0\n{am}l 0 0 -5\nfm 0.5 0.25 1  0.8 0.8 0.8  0 0 0  1 0 1\n\
             p 4\n-1 -1 0\n1 -1 0\n1 1 0\n-1 1 0\n"
        )
    };
    let centre = |aff: &str, name: &str| {
        let p = write(
            &d,
            aff,
            &scene(if aff.contains("am") {
                "am 0.4 0.8 0.2\n"
            } else {
                ""
            }),
        );
        let out = d.join(name);
        ok(&words(&format!(
            "render {p} --engine brute --width 16 --height 16 --bounces 0 --out {}",
            out.display()
        )));
        let img = image::open(&out).unwrap().to_rgb8();
        img.get_pixel(8, 8).0
    };
    assert_eq!(centre("dark.aff", "dark.png"), [0, 0, 0]);
    let lit = centre("am.aff", "am.png");
    // k_a ⊙ L_a = (0.2, 0.2, 0.2) before the display transform: a grey, equal channels.
    assert!(
        lit[0] > 0 && lit[0] == lit[1] && lit[1] == lit[2],
        "{lit:?}"
    );
    // The GPU's shading kernel adds the same term: the same image bytes.
    let gpu = d.join("gpu.png");
    let o = bin()
        .args(words(&format!(
            "render {} --engine crsh --backend gpu --width 16 --height 16 --bounces 0 --out {}",
            d.join("am.aff").display(),
            gpu.display()
        )))
        .output()
        .unwrap();
    let err = String::from_utf8_lossy(&o.stderr);
    assert!(!err.contains("panicked"), "{err}");
    if !o.status.success() {
        testkit::skip("gpu", &err);
        return;
    }
    let cpu = d.join("cpu.png");
    ok(&words(&format!(
        "render {} --engine crsh --width 16 --height 16 --bounces 0 --out {}",
        d.join("am.aff").display(),
        cpu.display()
    )));
    assert_eq!(std::fs::read(&gpu).unwrap(), std::fs::read(&cpu).unwrap());
}

#[test]
fn outside_paths_need_the_option_and_suspicious_tracks_warn() {
    let d = tmp("outside");
    let inner = d.join("scene");
    std::fs::create_dir_all(&inner).unwrap();
    write(&d, "beside.mtl", "newmtl m\nKd 1 0 0\n");
    let obj = write(
        &inner,
        "s.obj",
        "mtllib ../beside.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl m\nf 1 2 3\n",
    );
    let out = d.join("o.png");
    let args = format!(
        "render {obj} --width 16 --height 16 --out {}",
        out.display()
    );
    fails(
        &words(&args),
        &["s.obj", "mtllib '../beside.mtl'", "--allow-outside-paths"],
    );
    assert!(!out.exists());
    ok(&words(&format!("{args} --allow-outside-paths")));
    // A BART track whose key times go back loads, with one warning line naming file:line.
    let aff = write(
        &d,
        "back.aff",
        "a 0 4 5\nv\nfrom 0 0 5\nat 0 0 0\nup 0 1 0\nangle 45\nhither 1\nresolution 16 16\n\
         l 0 5 5\nk m\n{\ntransl 5\n0 0 0 0 0 0 0\n2 1 0 0 0 0 0\n1 2 0 0 0 0 0\n3 0 0 0 0 0 0\n\
         4 1 0 0 0 0 0\n}\nx m\n{\np 3\n0 0 0\n1 0 0\n0 1 0\n}\n",
    );
    let o = ok(&words(&format!(
        "render {aff} --width 16 --height 16 --out {}",
        d.join("b.png").display()
    )));
    let err = String::from_utf8_lossy(&o.stderr);
    let warnings: Vec<&str> = err.lines().filter(|l| l.starts_with("warning:")).collect();
    assert_eq!(warnings.len(), 1, "{err}");
    assert!(warnings[0].contains("back.aff:10:"), "{err}");
}
