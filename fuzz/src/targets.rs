//! The loaders under test, each with its files, seeds and oracle.
//!
//! Seeds are small valid inputs written here (covering each format's features), the
//! hostile inputs of issue 14, and, when the shared scenes are present, pieces of the real
//! files (whole small BART files, the first 4 KiB of the large OBJs, every MTL), with the
//! names of the files they reference rewritten to the companions the fuzzer provides.

use crate::mutate::Kind;
use std::path::Path;
use trace::{Hit, RayBatch, RayKind, TraceMode};

/// What one load came to.
pub enum Outcome {
    /// Loaded, and the result passed its checks.
    Accepted,
    /// Refused with an error (the loader's job on bad input).
    Rejected,
    /// Loaded, but the result is wrong (e.g. non-finite geometry): a finding.
    Wrong(String),
}

/// A loader under test.
pub struct Target {
    /// Its name on the command line.
    pub name: &'static str,
    /// Its files, the loaded one first, with how each is mutated.
    pub files: Vec<(&'static str, Kind)>,
    /// Seeds: one content per file.
    pub seeds: Vec<Vec<Vec<u8>>>,
    /// Load the first file (in a directory holding all of them).
    pub load: fn(&Path) -> Outcome,
}

/// Every target's name.
pub const NAMES: &[&str] = &["obj", "gltf", "glb", "toml", "aff", "rays", "hits"];

/// A scene loader's oracle: errors are fine; a loaded scene must give finite triangles at
/// every sampled time of its animation (a NaN there would be a silently wrong answer).
/// The loaders' memory budget under fuzzing (the CLI derives it from `--max-memory`): a
/// quarter of [`crate::alloc::SOFT_CAP`], so that the largest scene a load may make stays
/// well below what counts as a finding.
pub const LOAD_BUDGET: u64 = (crate::alloc::SOFT_CAP / 4) as u64;

fn load_scene(p: &Path) -> Outcome {
    let opts = scene::LoadOptions::default().for_memory(LOAD_BUDGET);
    let Ok(s) = scene::load(&p.to_string_lossy(), &opts) else {
        return Outcome::Rejected;
    };
    let times = s
        .animation
        .as_ref()
        .map(|a| a.frame_times(3))
        .unwrap_or_else(|| vec![0.0]);
    for t in times {
        // A transform may be singular at some time (a mesh scaled to nothing: no area, no
        // hits); a non-finite vertex is what must never appear.
        let at = s.at_time(t);
        let g = scene::Geometry::from_scene(&at);
        if let Some(tri) = g.tris.iter().find(|t| !t.iter().all(|v| v.is_finite())) {
            return Outcome::Wrong(format!("non-finite triangle {tri:?} at time {t}"));
        }
    }
    Outcome::Accepted
}

fn load_rays(p: &Path) -> Outcome {
    match render::rayfile::read_rays(p, RayKind::Primary) {
        Err(_) => Outcome::Rejected,
        Ok(b) => match b.validate() {
            Ok(()) => Outcome::Accepted,
            Err(e) => Outcome::Wrong(format!("read, but invalid: {e}")),
        },
    }
}

fn load_hits(p: &Path) -> Outcome {
    match render::rayfile::read_hits(p) {
        Err(_) => Outcome::Rejected,
        Ok(_) => Outcome::Accepted,
    }
}

const TRI: &str = "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n";

const MTL: &str = "newmtl red\nKa 0.1 0 0\nKd 1 0 0\nKs 0.5 0.5 0.5\nNs 32\nillum 2\n\
newmtl glass\nKd 0.1 0.1 0.1\nillum 7\nNi 1.5\nTf 0.9 0.9 0.9\nd 0.5\n\
newmtl mirror\nKs 0.9 0.9 0.9\nillum 3\nKe 0 0 0\n";

const OBJ: &[&str] = &[
    TRI,
    "mtllib scene.mtl\no box\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0\nvt 0 0\nvt 1 0\nvt 1 1\n\
     vn 0 0 1\nusemtl red\nf 1/1/1 2/2/1 3/3/1 4/1/1\ng second\nusemtl glass\nf -4 -3 -2\n\
     usemtl mirror\nf 1//1 3//1 4//1\n",
    "# comment\r\nv 0 0 0\r\nv 1 0 0\r\nv 0 1 0\r\nv 0 0 1\r\nf 1 2 3 4\r\nl 1 2\r\np 3\r\n",
    "\u{feff}v 1e3 0 0\nv 0 1e3 0\nv 0 0 1e3\ns 1\nf 1 2 3\n",
];

const AFF: &[&str] = &[
    "v\nfrom 0 0 5\nat 0 0 0\nup 0 1 0\nangle 45\nhither 0.1\nresolution 64 64\n\
     b 0.1 0.1 0.1\nam 0.2 0.2 0.2\nl 0 4 4 1 1 1\nla lamp 1 4 4\n\
     fm 0.1 0.1 0.1 0.8 0.2 0.2 0.5 0.5 0.5 20 0 1\n\
     p 3\n0 0 0\n1 0 0\n0 1 0\npp 3\n0 0 1 0 0 1\n1 0 1 0 0 1\n0 1 1 0 0 1\n\
     f 0.5 0.5 0.5 0.8 0.2 10 0.5 1.5\ns 0 0 -2 0.5\nc 0 0 0 0.5 0 1 0 0.2\n\
     i 0 inc.aff\n",
    "a 0 2 10\nv\nfrom 0 0 5\nat 0 0 0\nup 0 1 0\nangle 45\nhither 1\nresolution 32 32\n\
     l 0 5 5\nk spin\n{\ntransl 4\n0 0 0 0 0 0 0\n1 1 0 0 0 0 0\n2 2 0 0 0 0 0\n3 0 0 0 0 0 0\n\
     rot 4\n0 0 1 0 0 0 0 0\n1 0 1 0 90 0 0 0\n0.5 0 1 0 180 0 0 0\n3 0 1 0 270 0 0 0\n\
     scale 1\n0 1 1 1 0 0 0\n}\nx spin\n{\np 3\n0 0 0\n1 0 0\n0 1 0\n}\n\
     xs 2 2 2 0 1 0 30 1 1 1\n{\ni 0 inc.aff\n}\n",
    "tpa 3\n0\n0 0 0\n1 0 0\n0 1 0\n1\n0 0 1\n1 0 1\n0 1 1\n2\n0 0 0\n1 0 0\n0 1 0\n\
     m 4\n0 0 0\n1 0 0\n1 1 0\n0 1 0\n2 0\n0 1 2\n0 2 3\n",
    "tt tex\n0 0 0 0 0\n1 0 0 1 0\n0 1 0 0 1\nttp tex\n0 0 0 0 0 1 0 0\n1 0 0 0 0 1 1 0\n0 1 0 0 0 1 0 1\n",
];

const INC_AFF: &str = "p 3\n0 0 -1\n1 0 -1\n0 1 -1\n";

const TOML: &[&str] = &[
    "background = [0.1, 0.1, 0.15]\nambient = [0.1, 0.1, 0.1]\n[camera]\neye = [0, 1, 5]\n\
     target = [0, 0, 0]\nfov = 45\n[[lights]]\nposition = [2, 4, 3]\ncolor = [1, 1, 1]\n\
     intensity = 1.0\nattenuation = [1, 0, 0]\n[[meshes]]\nfile = \"tri.obj\"\nsplit = \"groups\"\n\
     translate = [0, 0, 0]\nrotate = [0, 45, 0]\nscale = 1.0\n\
     material = { diffuse = [0.8, 0.2, 0.2], reflectivity = 0.3, ambient = [1, 1, 1] }\n",
    "[[meshes]]\nshape = \"sphere\"\n[meshes.animation]\nloop = true\nkeys = [\n\
     { t = 0, translate = [0, 0, 0], rotate = [0, 0, 0], scale = 1 },\n\
     { t = 2, translate = [1, 0, 0], rotate = [0, 180, 0] },\n]\n[[meshes]]\nshape = \"box\"\n\
     scale = [1, 2, 3]\n[[meshes]]\nshape = \"torus\"\n[animation]\nstart = 0\nend = 2\n",
    "[[meshes]]\nbuiltin = \"cornell\"\n[[meshes]]\nshape = \"plane\"\n",
    "[[meshes]]\nsequence = \"tri%d.obj\"\nframes = 2\nfps = 24\n",
];

/// A minimal glTF: one indexed triangle with a material, a camera, a node tree; `uri` is
/// where its buffer is (a `data:` URI or a file).
fn gltf(uri: &str) -> String {
    format!(
        r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[0]}}],
"nodes":[{{"children":[1],"translation":[0,0,0]}},{{"mesh":0,"rotation":[0,0,0,1],"scale":[1,1,1]}},{{"camera":0,"translation":[0,0,3]}}],
"cameras":[{{"type":"perspective","perspective":{{"yfov":0.8,"znear":0.1}}}}],
"meshes":[{{"primitives":[{{"attributes":{{"POSITION":0}},"indices":1,"material":0}}]}}],
"materials":[{{"pbrMetallicRoughness":{{"baseColorFactor":[1,0,0,1],"metallicFactor":0.5,"roughnessFactor":0.5}},"emissiveFactor":[0,0,0]}}],
"buffers":[{{"byteLength":44,"uri":"{uri}"}}],
"bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":36}},{{"buffer":0,"byteOffset":36,"byteLength":6}}],
"accessors":[{{"bufferView":0,"componentType":5126,"count":3,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}},
{{"bufferView":1,"componentType":5123,"count":3,"type":"SCALAR"}}]}}"#
    )
}

/// The 44 bytes of that buffer: three vertices and three u16 indices (padded).
fn gltf_bin() -> Vec<u8> {
    let mut b = Vec::new();
    for v in [0f32, 0., 0., 1., 0., 0., 0., 1., 0.] {
        b.extend_from_slice(&v.to_le_bytes());
    }
    for i in [0u16, 1, 2, 0] {
        b.extend_from_slice(&i.to_le_bytes());
    }
    b.extend_from_slice(&[0; 4]);
    b
}

/// A GLB (binary glTF) of the same triangle.
fn glb() -> Vec<u8> {
    let json = gltf("x").replace(r#","uri":"x""#, "");
    let mut j = json.into_bytes();
    while j.len() & 3 != 0 {
        j.push(b' ');
    }
    let bin = gltf_bin();
    let total = 12 + 8 + j.len() + 8 + bin.len();
    let mut out = Vec::new();
    out.extend_from_slice(b"glTF");
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&(total as u32).to_le_bytes());
    out.extend_from_slice(&(j.len() as u32).to_le_bytes());
    out.extend_from_slice(b"JSON");
    out.extend_from_slice(&j);
    out.extend_from_slice(&(bin.len() as u32).to_le_bytes());
    out.extend_from_slice(b"BIN\0");
    out.extend_from_slice(&bin);
    out
}

fn ray_file() -> Vec<u8> {
    let mut b = RayBatch::default();
    for k in 0..3 {
        let r = geom::Ray::new(
            geom::Vec3::new(k as f32, 0.5, 2.0),
            geom::Vec3::new(0.0, 0.1, -1.0),
            0.0,
            f32::INFINITY,
        );
        b.push(r, RayKind::Primary, k, 0, geom::Vec3::ONE, 0);
    }
    via_file(|p| render::rayfile::write_rays(p, &b))
}

fn hit_file(mode: TraceMode) -> Vec<u8> {
    let hits = [
        Hit::MISS,
        Hit {
            tri: 3,
            t: 1.5,
            u: 0.25,
            v: 0.5,
        },
    ];
    via_file(|p| render::rayfile::write_hits(p, &hits, mode))
}

/// The bytes a writer that takes a path makes.
fn via_file(write: impl FnOnce(&Path) -> Result<(), render::rayfile::RayFileError>) -> Vec<u8> {
    let d = std::env::temp_dir().join(format!("rayspace-fuzz-seed-{}", std::process::id()));
    std::fs::create_dir_all(&d).expect("temp dir");
    let p = d.join("seed.bin");
    write(&p).expect("seed writes");
    let b = std::fs::read(&p).expect("seed reads");
    let _ = std::fs::remove_dir_all(&d);
    b
}

/// Rewrite what a real file references to the fuzzer's companions.
fn relink(text: &str, keyword: &str, to: &str) -> String {
    text.lines()
        .map(|l| {
            let t = l.trim_start();
            if t.starts_with(keyword) {
                match keyword {
                    "i " => format!("i 0 {to}"),
                    _ => format!("{keyword}{to}"),
                }
            } else {
                l.to_string()
            }
        })
        .collect::<Vec<_>>()
        .join("\n")
}

/// The first `n` bytes of a file, cut at a line end.
fn head(p: &Path, n: usize) -> Option<String> {
    let b = std::fs::read(p).ok()?;
    let cut = b[..b.len().min(n)].iter().rposition(|&c| c == b'\n')? + 1;
    Some(String::from_utf8_lossy(&b[..cut]).into_owned())
}

/// Pieces of the shared real scenes, when present: (OBJ heads, MTLs, small AFF files).
fn real(scenes: Option<&Path>) -> (Vec<String>, Vec<String>, Vec<String>) {
    let (mut objs, mut mtls, mut affs) = (vec![], vec![], vec![]);
    let Some(d) = scenes else {
        return (objs, mtls, affs);
    };
    let mut files: Vec<std::path::PathBuf> = std::fs::read_dir(d)
        .into_iter()
        .flatten()
        .flatten()
        .flat_map(|e| {
            let p = e.path();
            let mut v = vec![p.clone()];
            for sub in [p.clone(), p.join("aff")] {
                if let Ok(r) = std::fs::read_dir(&sub) {
                    v.extend(r.flatten().map(|e| e.path()));
                }
            }
            v
        })
        .collect();
    files.sort();
    for p in files {
        let ext = p.extension().and_then(|e| e.to_str()).unwrap_or("");
        let small = std::fs::metadata(&p)
            .map(|m| m.len() <= 6 << 10)
            .unwrap_or(false);
        match ext {
            "obj" => objs.extend(head(&p, 4 << 10).map(|t| relink(&t, "mtllib ", "scene.mtl"))),
            "mtl" => mtls.extend(std::fs::read_to_string(&p).ok()),
            "aff" if small => affs.extend(
                std::fs::read_to_string(&p)
                    .ok()
                    .map(|t| relink(&t, "i ", "inc.aff")),
            ),
            _ => {}
        }
    }
    (objs, mtls, affs)
}

/// Every target, seeded (with the shared scenes' pieces when `scenes` is given).
pub fn all(scenes: Option<&Path>) -> Vec<Target> {
    let (real_objs, real_mtls, real_affs) = real(scenes);
    let b = |s: &str| s.as_bytes().to_vec();
    let mut obj_seeds: Vec<Vec<Vec<u8>>> = OBJ.iter().map(|o| vec![b(o), b(MTL)]).collect();
    obj_seeds.extend(real_objs.iter().map(|o| vec![b(o), b(MTL)]));
    obj_seeds.extend(real_mtls.iter().map(|m| vec![b(OBJ[1]), b(m)]));
    let data_uri = format!(
        "data:application/octet-stream;base64,{}",
        base64::encode(gltf_bin())
    );
    let mut aff_seeds: Vec<Vec<Vec<u8>>> = AFF.iter().map(|a| vec![b(a), b(INC_AFF)]).collect();
    aff_seeds.extend(real_affs.iter().map(|a| vec![b(a), b(INC_AFF)]));
    // Hostile seeds of issue 14: a node cycle, an include of itself, a BOM.
    let cyclic = gltf(&data_uri).replace(r#"{"mesh":0,"#, r#"{"children":[0],"mesh":0,"#);
    let bench_tomls = [
        include_str!("../../bench/scenes/sponza.toml"),
        include_str!("../../bench/scenes/conference.toml"),
        include_str!("../../bench/scenes/kitchen.toml"),
    ];
    let mut toml_seeds: Vec<Vec<Vec<u8>>> = TOML.iter().map(|t| vec![b(t), b(TRI)]).collect();
    toml_seeds.extend(
        bench_tomls
            .iter()
            .map(|t| vec![b(&relink(t, "file", " = \"tri.obj\"")), b(TRI)]),
    );
    vec![
        Target {
            name: "obj",
            files: vec![("scene.obj", Kind::Text), ("scene.mtl", Kind::Text)],
            seeds: obj_seeds,
            load: load_scene,
        },
        Target {
            name: "gltf",
            files: vec![("scene.gltf", Kind::Json), ("scene.bin", Kind::Binary)],
            seeds: vec![
                vec![b(&gltf(&data_uri)), gltf_bin()],
                vec![b(&gltf("scene.bin")), gltf_bin()],
                vec![b(&cyclic), gltf_bin()],
            ],
            load: load_scene,
        },
        Target {
            name: "glb",
            files: vec![("scene.glb", Kind::Binary)],
            seeds: vec![vec![glb()]],
            load: load_scene,
        },
        Target {
            name: "toml",
            files: vec![("scene.toml", Kind::Text), ("tri.obj", Kind::Text)],
            seeds: toml_seeds,
            load: load_scene,
        },
        Target {
            name: "aff",
            files: vec![("scene.aff", Kind::Text), ("inc.aff", Kind::Text)],
            seeds: {
                let mut s = aff_seeds;
                s.push(vec![b("i 0 inc.aff\ni 0 inc.aff\n"), b("i 0 scene.aff\n")]);
                s
            },
            load: load_scene,
        },
        Target {
            name: "rays",
            files: vec![("scene.rays", Kind::Binary)],
            seeds: vec![
                vec![ray_file()],
                vec![vec![0u8; 48]],
                vec![ray_file()[..24].to_vec()],
            ],
            load: load_rays,
        },
        Target {
            name: "hits",
            files: vec![("scene.hits", Kind::Binary)],
            seeds: vec![
                vec![hit_file(TraceMode::Closest)],
                vec![hit_file(TraceMode::Any)],
            ],
            load: load_hits,
        },
    ]
}
