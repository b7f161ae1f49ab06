//! OBJ + MTL loading through `tobj`, with a validation pre-pass for line-numbered errors.
//!
//! `tobj` triangulates polygons, resolves negative (relative) indices and accepts CRLF, but its
//! errors carry no line number and it happily parses `nan`/`inf` coordinates. The pre-pass
//! ([`validate_obj`]) reads the file once more to report `file:line: what` for malformed
//! vertices, non-finite coordinates and out-of-range face indices.

use crate::error::Invalid;
use crate::error::SceneError;
use crate::model::{smooth_normals, LoadReport, Material, Mesh, Scene};
use crate::MeshSplit;
use geom::Vec3;
use std::path::Path;

/// Check every `v`, `vn` and `f` line of an OBJ text; `path` is only used in errors.
///
/// Faces count against `sb`'s triangle budget (as triangulated), checked at the face that
/// passes it, before the parser allocates anything.
pub fn validate_obj(text: &str, path: &Path, sb: &crate::io::Sandbox) -> Result<(), SceneError> {
    let (mut nv, mut nvt, mut nvn) = (0i64, 0i64, 0i64);
    let mut triangles = 0u64;
    let err = |line: usize, msg: String| SceneError::Parse {
        path: path.to_path_buf(),
        line,
        msg,
    };
    for (i, raw) in text.lines().enumerate() {
        let line_no = i + 1;
        let line = raw.split('#').next().unwrap_or("").trim();
        let mut it = line.split_whitespace();
        let Some(key) = it.next() else { continue };
        match key {
            "v" | "vn" => {
                let vals: Vec<&str> = it.collect();
                if vals.len() < 3 {
                    return Err(err(
                        line_no,
                        format!("'{key}' needs 3 numbers, found {}", vals.len()),
                    ));
                }
                for s in &vals[..3] {
                    match s.parse::<f32>() {
                        Ok(f) if f.is_finite() => {}
                        Ok(_) => return Err(err(line_no, format!("non-finite coordinate '{s}'"))),
                        Err(_) => return Err(err(line_no, format!("'{s}' is not a number"))),
                    }
                }
                if key == "v" {
                    nv += 1
                } else {
                    nvn += 1
                }
            }
            "vt" => nvt += 1,
            "f" => {
                let verts: Vec<&str> = it.collect();
                if verts.len() < 3 {
                    return Err(err(
                        line_no,
                        format!("a face needs at least 3 vertices, found {}", verts.len()),
                    ));
                }
                triangles += verts.len() as u64 - 2;
                sb.admit_triangles(path, Some(line_no), triangles)?;
                for v in verts {
                    for (slot, s) in v.split('/').enumerate() {
                        if s.is_empty() && slot > 0 {
                            continue;
                        }
                        let count = [nv, nvt, nvn][slot.min(2)];
                        let idx: i64 = s
                            .parse()
                            .map_err(|_| err(line_no, format!("bad face index '{v}'")))?;
                        let resolved = if idx < 0 { count + idx + 1 } else { idx };
                        if idx == 0 || resolved < 1 || resolved > count {
                            let what = ["vertex", "texture coordinate", "normal"][slot.min(2)];
                            return Err(err(line_no, format!("face {what} index {idx} out of range (1..={count} defined so far)")));
                        }
                    }
                }
            }
            _ => {}
        }
    }
    Ok(())
}

/// How tobj reads an OBJ here (and what `objfast` reproduces): polygons triangulated, one
/// index per distinct `v/vt/vn` triple, points and lines left out.
pub const TOBJ_OPTIONS: tobj::LoadOptions = tobj::LoadOptions {
    triangulate: true,
    single_index: true,
    ignore_points: true,
    ignore_lines: true,
};

/// Map an MTL material to ours. `illum` 3/5 → mirror; 4/6/7 → refractive with `Ni`
/// (`Ni 0`, BART's convention for opaque, stays opaque).
pub fn convert_material(m: &tobj::Material) -> Result<Material, Invalid> {
    check_mtl(m)?;
    let v = |a: Option<[f32; 3]>, d: f32| a.map(Vec3::from_array).unwrap_or(Vec3::splat(d));
    let diffuse = v(m.diffuse, 0.7);
    let specular = v(m.specular, 0.0);
    let shininess = m.shininess.unwrap_or(16.0).clamp(1.0, 10_000.0);
    let ior = m.optical_density.unwrap_or(1.0);
    let illum = m.illumination_model.unwrap_or(2);
    let mut out = Material {
        name: m.name.clone(),
        diffuse,
        specular,
        shininess,
        emission: v(m.emissive, 0.0),
        // Ka is lit only by a scene's ambient light (a TOML scene's `ambient`), so a bare
        // OBJ renders by eq. 3.19 exactly whatever its Ka.
        ambient: v(m.ambient, 0.0),
        ..Default::default()
    };
    let spec_level = specular.max_element().clamp(0.0, 1.0);
    match illum {
        3 | 5 => out.reflectivity = if spec_level > 0.0 { spec_level } else { 0.8 },
        4 | 6 | 7 if ior > 0.0 => {
            // Transmittance from Tf when present, else from the dissolve.
            let tf = m
                .unknown_param
                .get("Tf")
                .and_then(|s| {
                    let f: Vec<f32> = s
                        .split_whitespace()
                        .filter_map(|x| x.parse().ok())
                        .collect();
                    (!f.is_empty()).then(|| f.iter().sum::<f32>() / f.len() as f32)
                })
                .unwrap_or(1.0 - m.dissolve.unwrap_or(0.0).min(1.0));
            out.transparency = if tf > 0.0 { tf.min(1.0) } else { 0.9 };
            out.ior = ior;
            out.reflectivity = spec_level.min(1.0 - out.transparency).max(0.0);
        }
        _ => {}
    }
    Ok(out)
}

/// `Ka`/`Kd`/`Ks`/`Ke` need three numbers: `tobj` unwraps a shorter list (a panic, found
/// by fuzzing), so such a line is an error naming the library's file and line here.
fn check_mtl_colours(text: &str, path: &Path) -> Result<(), SceneError> {
    for (i, line) in text.lines().enumerate() {
        let mut w = line.split_whitespace();
        if let Some(key @ ("Ka" | "Kd" | "Ks" | "Ke")) = w.next() {
            if w.take(3).filter(|x| x.parse::<f32>().is_ok()).count() < 3 {
                return Err(SceneError::Parse {
                    path: path.to_path_buf(),
                    line: i + 1,
                    msg: format!("{key} needs three numbers (r g b)"),
                });
            }
        }
    }
    Ok(())
}

/// The MTL values as written, before conversion clamps or defaults them: a NaN `Tf` would
/// otherwise become transparency 0.9, a negative `Ns` shininess 1.
fn check_mtl(m: &tobj::Material) -> Result<(), Invalid> {
    let bad =
        |what: &str, v: String| Err(Invalid::from(format!("material '{}': {what} {v}", m.name)));
    for (what, c) in [
        ("Ka", m.ambient),
        ("Kd", m.diffuse),
        ("Ks", m.specular),
        ("Ke", m.emissive),
    ] {
        if let Some(c) = c {
            if !c.iter().all(|x| x.is_finite() && *x >= 0.0) {
                return bad(what, format!("{c:?} must be finite and non-negative"));
            }
        }
    }
    for (what, v) in [("Ns", m.shininess), ("Ni", m.optical_density)] {
        if let Some(v) = v {
            if !(v.is_finite() && v >= 0.0) {
                return bad(what, format!("{v} must be finite and non-negative"));
            }
        }
    }
    if let Some(d) = m.dissolve {
        if !(0.0..=1.0).contains(&d) {
            return bad("d", format!("{d} must be in [0, 1]"));
        }
    }
    if let Some(tf) = m.unknown_param.get("Tf") {
        for x in tf.split_whitespace() {
            if !x.parse::<f32>().is_ok_and(|f| (0.0..=1.0).contains(&f)) {
                return bad("Tf", format!("'{x}' must be a number in [0, 1]"));
            }
        }
    }
    Ok(())
}

/// Load an OBJ (and its MTL files) as meshes split as asked. The meshes' materials index into
/// the returned material list.
pub fn load_obj_meshes(
    path: &Path,
    split: MeshSplit,
    report: &mut LoadReport,
    sb: &crate::io::Sandbox,
) -> Result<(Vec<Mesh>, Vec<Material>), SceneError> {
    let text = sb.read_text(path)?;
    // Large files are checked and parsed in parallel (`objfast`, the same result); small
    // ones by `validate_obj` and tobj.
    let parallel = text.len() >= crate::objfast::PARALLEL_BYTES;
    if !parallel {
        validate_obj(&text, path, sb)?;
    }
    let mtl_errors = std::cell::RefCell::new(Vec::new());
    let refused = std::cell::RefCell::new(None);
    let seen = std::cell::RefCell::new(std::collections::HashSet::new());
    let load_mtl = |p: &Path| {
        // Inside the sandbox and through our bounded reader: `mtllib /etc/passwd` is
        // refused unread, `mtllib /dev/zero` is refused, not read forever.
        // A missing library is common in real data (a note, defaults used); one outside
        // the sandbox is an error.
        let full = match sb.resolve(path, "mtllib", &p.to_string_lossy()) {
            Ok(f) => f,
            Err(e @ SceneError::Outside { .. }) => {
                refused.borrow_mut().get_or_insert(e);
                return Err(tobj::LoadError::OpenFileFailed);
            }
            Err(e) => {
                mtl_errors.borrow_mut().push(e.to_string());
                return Err(tobj::LoadError::OpenFileFailed);
            }
        };
        // A library named again adds nothing (its names are already known): 5,000
        // `mtllib` lines of one 90 KB file took 7 s before (found by fuzzing).
        if !seen.borrow_mut().insert(full.clone()) {
            return Ok((Vec::new(), Default::default()));
        }
        let r = match sb.read_text(&full) {
            Ok(t) => match check_mtl_colours(&t, &full) {
                Ok(()) => tobj::load_mtl_buf(&mut t.as_bytes()),
                Err(e) => {
                    refused.borrow_mut().get_or_insert(e);
                    return Err(tobj::LoadError::MaterialParseError);
                }
            },
            Err(e) => {
                mtl_errors.borrow_mut().push(e.to_string());
                return Err(tobj::LoadError::OpenFileFailed);
            }
        };
        if let Err(e) = &r {
            mtl_errors
                .borrow_mut()
                .push(format!("{}: {e}", full.display()));
        }
        r
    };
    let (models, mats) = if parallel {
        crate::objfast::load(&text, path, sb, &load_mtl)?
    } else {
        tobj::load_obj_buf(&mut text.as_bytes(), &TOBJ_OPTIONS, load_mtl)
            .map_err(|e| SceneError::invalid(path, format!("OBJ parse error: {e}")))?
    };
    if let Some(e) = refused.into_inner() {
        return Err(e);
    }
    for e in mtl_errors.into_inner() {
        report
            .notes
            .push(format!("material library not loaded ({e}); using defaults"));
    }
    let tmats = mats.unwrap_or_default();
    let mut materials: Vec<Material> = tmats
        .iter()
        .map(convert_material)
        .collect::<Result<_, _>>()
        .map_err(|e| SceneError::invalid(path, e.0))?;
    let default_id = materials.len() as u32;
    materials.push(Material::default());

    // Group tobj's models (one per group × material run) into our meshes.
    let mut meshes: Vec<Mesh> = Vec::new();
    let mut key_of_last: Option<String> = None;
    let mut index_of_key: std::collections::HashMap<String, usize> = Default::default();
    for model in &models {
        let m = &model.mesh;
        let mat = m
            .material_id
            .map(|i| i as u32)
            .filter(|&i| (i as usize) < tmats.len())
            .unwrap_or(default_id);
        let key = match split {
            MeshSplit::Groups => model.name.clone(),
            MeshSplit::Materials => materials[mat as usize].name.clone(),
            MeshSplit::Single => String::new(),
        };
        let idx = match split {
            // Consecutive models of the same group (split by `usemtl`) form one mesh.
            MeshSplit::Groups if key_of_last.as_deref() == Some(key.as_str()) => meshes.len() - 1,
            MeshSplit::Groups => {
                meshes.push(empty_mesh(&key));
                meshes.len() - 1
            }
            _ => *index_of_key.entry(key.clone()).or_insert_with(|| {
                meshes.push(empty_mesh(if key.is_empty() { "all" } else { &key }));
                meshes.len() - 1
            }),
        };
        key_of_last = Some(key);
        let out = &mut meshes[idx];
        let off = out.positions.len() as u32;
        let pos: Vec<Vec3> = m
            .positions
            .chunks_exact(3)
            .map(|c| Vec3::new(c[0], c[1], c[2]))
            .collect();
        let nrm: Vec<Vec3> = if m.normals.len() == m.positions.len() {
            m.normals
                .chunks_exact(3)
                .map(|c| Vec3::new(c[0], c[1], c[2]).normalize_or_zero())
                .collect()
        } else {
            Vec::new()
        };
        let tris: Vec<[u32; 3]> = m
            .indices
            .chunks_exact(3)
            .map(|c| [c[0], c[1], c[2]])
            .collect();
        // Normals: from the file when every vertex has one, else smooth normals of this part.
        let part_normals = if nrm.len() == pos.len() && nrm.iter().all(|n| *n != Vec3::ZERO) {
            nrm
        } else {
            report.normals_computed += pos.len();
            smooth_normals(&pos, &tris)
        };
        out.positions.extend(pos);
        out.normals.extend(part_normals);
        for t in tris {
            out.triangles.push(t.map(|i| i + off));
            out.materials.push(mat);
        }
    }
    for m in &mut meshes {
        report.degenerate_skipped += m.remove_degenerate();
    }
    meshes.retain(|m| !m.triangles.is_empty());
    Ok((meshes, materials))
}

fn empty_mesh(name: &str) -> Mesh {
    Mesh::new(name, Vec::new(), Vec::new(), 0)
}

/// A bare OBJ becomes a scene with an automatic camera framing its bounds and one light.
pub fn load_obj_scene(path: &Path, split: MeshSplit) -> Result<Scene, SceneError> {
    load_obj_scene_in(path, split, &crate::io::Sandbox::for_scene(path, false))
}

/// [`load_obj_scene`] with the files it references confined to `sb`.
pub fn load_obj_scene_in(
    path: &Path,
    split: MeshSplit,
    sb: &crate::io::Sandbox,
) -> Result<Scene, SceneError> {
    let t0 = std::time::Instant::now();
    let mut report = LoadReport {
        source: Some(path.to_path_buf()),
        ..Default::default()
    };
    let (meshes, materials) = load_obj_meshes(path, split, &mut report, sb)?;
    report.load_seconds = t0.elapsed().as_secs_f64();
    let mut scene = Scene::from_file(path, meshes, materials, report);
    auto_camera_and_light(&mut scene);
    Ok(scene)
}

/// The automatic camera and light ([`crate::autocam::auto_camera_and_light`]).
pub use crate::autocam::auto_camera_and_light;

#[cfg(test)]
mod tests {
    use super::*;

    fn write(dir: &Path, name: &str, text: &str) -> std::path::PathBuf {
        let p = dir.join(name);
        std::fs::write(&p, text).unwrap();
        p
    }

    fn tmpdir(tag: &str) -> std::path::PathBuf {
        let d = std::env::temp_dir().join(format!("rayspace-obj-{tag}-{}", std::process::id()));
        std::fs::create_dir_all(&d).unwrap();
        d
    }

    #[test]
    fn groups_materials_single_and_quirks() {
        let d = tmpdir("split");
        write(&d, "m.mtl", "newmtl red\r\nKd 1 0 0\r\nillum 2\r\nnewmtl mirror\r\nKd 0.1 0.1 0.1\r\nKs 0.9 0.9 0.9\r\nillum 3\r\nnewmtl glass\r\nillum 7\r\nNi 1.5\r\nTf 0.9 0.9 0.9\r\nnewmtl opaque\r\nillum 7\r\nNi 0\r\n");
        // CRLF, tabs, a quad, negative indices, two groups, three materials.
        let obj = "mtllib m.mtl\r\ng first\r\nv\t0 0 0\r\nv 1 0 0\r\nv 1 1 0\r\nv 0 1 0\r\nusemtl red\r\nf 1 2 3 4\r\nusemtl mirror\r\nf -4 -2 -1\r\ng second\r\nv 0 0 1\r\nv 1 0 1\r\nv 1 1 1\r\nusemtl glass\r\nf -3 -2 -1\r\nusemtl opaque\r\nf 5 7 6\r\n";
        let p = write(&d, "s.obj", obj);
        let mut r = LoadReport::default();
        let sb = crate::io::Sandbox::for_scene(&p, false);
        let (m, mats) = load_obj_meshes(&p, MeshSplit::Groups, &mut r, &sb).unwrap();
        assert_eq!(m.len(), 2);
        assert_eq!(m[0].triangles.len(), 3);
        assert_eq!(m[1].triangles.len(), 2);
        let (m, _) = load_obj_meshes(&p, MeshSplit::Materials, &mut r, &sb).unwrap();
        assert_eq!(m.len(), 4);
        let (m, _) = load_obj_meshes(&p, MeshSplit::Single, &mut r, &sb).unwrap();
        assert_eq!(m.len(), 1);
        assert_eq!(m[0].triangles.len(), 5);
        let by = |n: &str| mats.iter().find(|x| x.name == n).unwrap().clone();
        assert!(by("mirror").reflectivity > 0.5);
        assert_eq!(by("red").reflectivity, 0.0);
        assert!(by("glass").transparency > 0.8 && (by("glass").ior - 1.5).abs() < 1e-6);
        assert_eq!(by("opaque").transparency, 0.0, "Ni 0 means opaque");
        // Normals were computed (the file has none).
        assert!(r.normals_computed > 0);
    }

    #[test]
    fn line_numbered_errors() {
        let d = tmpdir("errors");
        let cases = [
            (
                "v 0 0 0\nv 1 0 0\nv 0 nan 0\nf 1 2 3\n",
                ":3:",
                "non-finite",
            ),
            ("v 0 0 0\nv 1 0 inf\n", ":2:", "non-finite"),
            (
                "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4\n",
                ":4:",
                "out of range",
            ),
            ("v 0 0 0\nv 1 0 0\nf 1 2\n", ":3:", "at least 3"),
            ("v 0 0\n", ":1:", "needs 3"),
            ("v 0 0 zero\n", ":1:", "not a number"),
            (
                "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 -5\n",
                ":4:",
                "out of range",
            ),
            (
                "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 x 3\n",
                ":4:",
                "bad face index",
            ),
        ];
        for (i, (text, line, what)) in cases.iter().enumerate() {
            let p = write(&d, &format!("bad{i}.obj"), text);
            let e = load_obj_scene(&p, MeshSplit::Groups)
                .unwrap_err()
                .to_string();
            assert!(
                e.contains(&format!("bad{i}.obj{line}")) && e.contains(what),
                "case {i}: {e}"
            );
        }
    }

    #[test]
    fn degenerate_triangles_are_skipped_and_counted() {
        let d = tmpdir("degenerate");
        let p = write(
            &d,
            "deg.obj",
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nv 2 0 0\nf 1 2 3\nf 1 2 4\nf 1 1 3\n",
        );
        let s = load_obj_scene(&p, MeshSplit::Groups).unwrap();
        assert_eq!(s.triangle_count(), 1);
        assert_eq!(s.report.degenerate_skipped, 2);
        // Only degenerate triangles: an empty scene is an error naming the file.
        let p = write(&d, "alldeg.obj", "v 0 0 0\nv 1 0 0\nv 2 0 0\nf 1 2 3\n");
        let e = crate::load(p.to_str().unwrap(), &Default::default())
            .unwrap_err()
            .to_string();
        assert!(
            e.contains("alldeg.obj") && e.contains("no triangles") && e.contains("1 degenerate"),
            "{e}"
        );
    }
}
