//! Parallel OBJ parsing for large files (hundreds of MB: a 2 M-triangle hairball is 77 MB),
//! with the same result as the sequential path (`tobj` with [`crate::obj::TOBJ_OPTIONS`] after
//! [`crate::obj::validate_obj`]):
//! the same models (split at `o`/`g` and at material changes), the same vertices in the same
//! order (one per distinct `v/vt/vn` triple of a model, in order of first use), the same fan
//! triangulation, and the same first error with its line number.
//!
//! Three passes over the text, cut into chunks at line ends:
//! 1. (parallel) per chunk, its lines and its `v`, `vt`, `vn` and face-triangle counts;
//! 2. (parallel) per chunk, knowing what came before it (scanned counts), every line checked
//!    and parsed: coordinates into the chunk's arrays, faces as resolved index triples, and
//!    the names, libraries and materials in order;
//! 3. (in order) the events replayed as `tobj` does: libraries loaded when named, models cut,
//!    each model's triples numbered in order of first use (a dense table per position, a
//!    hash map only for a position used with several texture/normal indices).

use crate::error::SceneError;
use rayon::prelude::*;
use std::collections::HashMap;
use std::path::Path;

/// Files from this size on take the parallel path.
pub const PARALLEL_BYTES: usize = 4 << 20;

/// A chunk's target size.
const CHUNK_BYTES: usize = 1 << 20;

const MISSING: u32 = u32::MAX;

/// Counts of one chunk (pass 1), and of everything before it after the scan.
#[derive(Clone, Copy, Default, Debug)]
struct Counts {
    lines: usize,
    v: i64,
    vt: i64,
    vn: i64,
    tris: u64,
}

impl Counts {
    fn add(self, o: Counts) -> Counts {
        Counts {
            lines: self.lines + o.lines,
            v: self.v + o.v,
            vt: self.vt + o.vt,
            vn: self.vn + o.vn,
            tris: self.tris + o.tris,
        }
    }
}

/// What a chunk holds, in file order (pass 2).
enum Event {
    Name(String),
    Mtllib(String),
    Usemtl(String),
    /// Triangulated face vertices `[start, end)` of the chunk's `faces`.
    Faces(usize, usize),
}

#[derive(Default)]
struct Chunk {
    pos: Vec<f32>,
    nrm: Vec<f32>,
    /// (v, vt, vn), 0-based file-wide, `MISSING` where absent: three per triangle.
    faces: Vec<[u32; 3]>,
    events: Vec<Event>,
}

/// The text cut at line ends into pieces of about `target` bytes.
fn cut(text: &str, target: usize) -> Vec<&str> {
    let b = text.as_bytes();
    let mut out = Vec::new();
    let mut start = 0;
    while start < b.len() {
        let mut end = (start + target).min(b.len());
        while end < b.len() && b[end - 1] != b'\n' {
            end += 1;
        }
        out.push(&text[start..end]);
        start = end;
    }
    out
}

fn key_of(line: &str) -> Option<&str> {
    line.split('#')
        .next()
        .unwrap_or("")
        .split_whitespace()
        .next()
}

/// Pass 1: a chunk's counts (as `validate_obj` counts: `f` faces of 3 or more vertices).
fn count(chunk: &str) -> Counts {
    let mut c = Counts::default();
    for line in chunk.lines() {
        c.lines += 1;
        match key_of(line) {
            Some("v") => c.v += 1,
            Some("vt") => c.vt += 1,
            Some("vn") => c.vn += 1,
            Some("f") => {
                let n = line
                    .split('#')
                    .next()
                    .unwrap_or("")
                    .split_whitespace()
                    .count()
                    - 1;
                if n >= 3 {
                    c.tris += n as u64 - 2;
                }
            }
            _ => {}
        }
    }
    c
}

/// The errors, as the sequential path words them.
struct Errs<'a> {
    path: &'a Path,
}

impl Errs<'_> {
    fn line(&self, line: usize, msg: String) -> SceneError {
        SceneError::Parse {
            path: self.path.to_path_buf(),
            line,
            msg,
        }
    }
    fn tobj(&self, e: tobj::LoadError) -> SceneError {
        SceneError::invalid(self.path, format!("OBJ parse error: {e}"))
    }
}

/// Pass 2: one chunk, `before` the counts of the chunks before it. Errors come as
/// (line, error) so that the earliest in the file wins; `validate_obj`'s checks run on
/// every line, `tobj`'s after them (a line that passes the first may fail the second).
fn parse_chunk(
    chunk: &str,
    before: Counts,
    e: &Errs,
    sb: &crate::io::Sandbox,
) -> Result<Chunk, (usize, SceneError)> {
    let mut out = Chunk::default();
    let (mut nv, mut nvt, mut nvn, mut tris) = (before.v, before.vt, before.vn, before.tris);
    let mut verts: Vec<[u32; 3]> = Vec::with_capacity(8);
    let mut faces_from = 0;
    for (i, raw) in chunk.lines().enumerate() {
        let line_no = before.lines + i + 1;
        let fail = |err: SceneError| (line_no, err);
        // validate_obj's view: comments cut.
        let clean = raw.split('#').next().unwrap_or("").trim();
        let mut it = clean.split_whitespace();
        let Some(key) = it.next() else { continue };
        // tobj's view: the whole line, `#` only as the first word.
        let mut words = raw.split_whitespace();
        let first = words.next();
        if first == Some("#") {
            continue;
        }
        match key {
            "v" | "vn" => {
                let vals: Vec<&str> = it.collect();
                if vals.len() < 3 {
                    let msg = format!("'{key}' needs 3 numbers, found {}", vals.len());
                    return Err(fail(e.line(line_no, msg)));
                }
                let mut xyz = [0f32; 3];
                for (k, s) in vals[..3].iter().enumerate() {
                    match s.parse::<f32>() {
                        Ok(f) if f.is_finite() => xyz[k] = f,
                        Ok(_) => {
                            return Err(fail(
                                e.line(line_no, format!("non-finite coordinate '{s}'")),
                            ))
                        }
                        Err(_) => {
                            return Err(fail(e.line(line_no, format!("'{s}' is not a number"))))
                        }
                    }
                }
                let rest: Vec<&str> = words.skip(3).collect();
                if key == "v" {
                    nv += 1;
                    match rest.len() {
                        0 | 3 => {}
                        1 => {
                            let w: f32 = rest[0]
                                .parse()
                                .map_err(|_| fail(e.tobj(tobj::LoadError::PositionParseError)))?;
                            if w == 0.0 {
                                return Err(fail(e.tobj(tobj::LoadError::ScalingByZeroError)));
                            }
                            xyz = xyz.map(|c| c / w);
                        }
                        _ => return Err(fail(e.tobj(tobj::LoadError::ColorParseError))),
                    }
                    out.pos.extend_from_slice(&xyz);
                } else {
                    nvn += 1;
                    out.nrm.extend_from_slice(&xyz);
                }
            }
            "vt" => {
                nvt += 1;
                let ok = words.take(2).filter(|s| s.parse::<f32>().is_ok()).count() == 2;
                if !ok {
                    return Err(fail(e.tobj(tobj::LoadError::TexcoordParseError)));
                }
            }
            "f" | "l" => {
                let is_f = key == "f";
                // validate_obj checks `f` lines without their comment; tobj reads every
                // word of `f` and `l` lines (a `#` fails its index parse).
                let list: Vec<&str> = if is_f { it.collect() } else { words.collect() };
                if is_f {
                    if list.len() < 3 {
                        let msg = format!("a face needs at least 3 vertices, found {}", list.len());
                        return Err(fail(e.line(line_no, msg)));
                    }
                    tris += list.len() as u64 - 2;
                    sb.admit_triangles(e.path, Some(line_no), tris)
                        .map_err(fail)?;
                }
                verts.clear();
                let mut tobj_fails = is_f && raw.contains('#') && !clean.is_empty();
                let mut out_of_range = false;
                for v in &list {
                    let mut idx = [MISSING; 3];
                    for (slot, s) in v.split('/').enumerate() {
                        if s.is_empty() && slot > 0 {
                            continue;
                        }
                        let count = [nv, nvt, nvn][slot.min(2)];
                        let Ok(x) = s.parse::<i64>() else {
                            if is_f {
                                return Err(fail(e.line(line_no, format!("bad face index '{v}'"))));
                            }
                            return Err(fail(e.tobj(tobj::LoadError::FaceParseError)));
                        };
                        let resolved = if x < 0 { count + x + 1 } else { x };
                        if x == 0 || resolved < 1 || resolved > count {
                            if is_f {
                                let what = ["vertex", "texture coordinate", "normal"][slot.min(2)];
                                let msg = format!("face {what} index {x} out of range (1..={count} defined so far)");
                                return Err(fail(e.line(line_no, msg)));
                            }
                            out_of_range = true;
                        }
                        if slot > 2 {
                            tobj_fails = true;
                        } else {
                            idx[slot] = (resolved - 1) as u32;
                        }
                    }
                    verts.push(idx);
                }
                if tobj_fails {
                    return Err(fail(e.tobj(tobj::LoadError::FaceParseError)));
                }
                // Points and lines are not loaded; polygons become fans, as tobj makes them.
                if verts.len() >= 3 {
                    if out_of_range {
                        return Err(fail(e.tobj(tobj::LoadError::FaceVertexOutOfBounds)));
                    }
                    for k in 2..verts.len() {
                        out.faces
                            .extend_from_slice(&[verts[0], verts[k - 1], verts[k]]);
                    }
                }
            }
            "o" | "g" | "mtllib" | "usemtl" => {
                // tobj reads these from its own (uncut) line.
                if out.faces.len() > faces_from {
                    out.events.push(Event::Faces(faces_from, out.faces.len()));
                    faces_from = out.faces.len();
                }
                // As tobj cuts them: after the line's first character, or its first space
                // (so a line indented by spaces keeps its keyword in the name).
                let first_len = raw.chars().next().map_or(0, char::len_utf8);
                match first {
                    Some("o") | Some("g") => {
                        let mut name = raw[first_len..].trim().to_owned();
                        if name.is_empty() {
                            name = "unnamed_object".to_owned();
                        }
                        out.events.push(Event::Name(name));
                    }
                    Some("mtllib") => {
                        let lib = raw.split_once(' ').unwrap_or_default().1.trim();
                        out.events.push(Event::Mtllib(lib.to_owned()));
                    }
                    Some("usemtl") => {
                        let name = raw.split_once(' ').unwrap_or_default().1.trim();
                        if name.is_empty() {
                            return Err(fail(e.tobj(tobj::LoadError::MaterialParseError)));
                        }
                        out.events.push(Event::Usemtl(name.to_owned()));
                    }
                    _ => {} // e.g. `g#x`: a comment to validate_obj, a word to tobj.
                }
            }
            _ => {}
        }
    }
    if out.faces.len() > faces_from {
        out.events.push(Event::Faces(faces_from, out.faces.len()));
    }
    Ok(out)
}

/// One model's vertices numbered in order of first use (pass 3).
struct Numbering {
    /// Per position: the model that last used it, its (vt, vn) and its vertex.
    slot: Vec<(u32, u32, u32, u32)>,
    /// Triples whose position was first used with other (vt, vn).
    others: HashMap<[u32; 3], u32>,
    model: u32,
}

/// The OBJ text's models and materials, as `tobj::load_obj_buf` (triangulated, single index,
/// points and lines ignored) returns them after `validate_obj` accepted the text.
#[allow(clippy::type_complexity)]
pub fn load(
    text: &str,
    path: &Path,
    sb: &crate::io::Sandbox,
    load_mtl: &dyn Fn(&Path) -> tobj::MTLLoadResult,
) -> Result<
    (
        Vec<tobj::Model>,
        Result<Vec<tobj::Material>, tobj::LoadError>,
    ),
    SceneError,
> {
    load_in_chunks(text, path, sb, load_mtl, CHUNK_BYTES)
}

#[allow(clippy::type_complexity)]
fn load_in_chunks(
    text: &str,
    path: &Path,
    sb: &crate::io::Sandbox,
    load_mtl: &dyn Fn(&Path) -> tobj::MTLLoadResult,
    chunk_bytes: usize,
) -> Result<
    (
        Vec<tobj::Model>,
        Result<Vec<tobj::Material>, tobj::LoadError>,
    ),
    SceneError,
> {
    let chunks = cut(text, chunk_bytes);
    let counts: Vec<Counts> = chunks.par_iter().map(|c| count(c)).collect();
    let mut before = Vec::with_capacity(counts.len());
    let mut acc = Counts::default();
    for c in &counts {
        before.push(acc);
        acc = acc.add(*c);
    }
    let errs = Errs { path };
    let parsed: Vec<Result<Chunk, (usize, SceneError)>> = chunks
        .par_iter()
        .zip(before.par_iter())
        .map(|(c, b)| parse_chunk(c, *b, &errs, sb))
        .collect();
    // The first error in the file, as a sequential reading meets it.
    let mut ok = Vec::with_capacity(parsed.len());
    for p in parsed {
        ok.push(p.map_err(|(_, e)| e)?);
    }
    // Every chunk's coordinates in one array each, in file order.
    let pos: Vec<f32> = ok.iter().flat_map(|c| c.pos.iter().copied()).collect();
    let nrm: Vec<f32> = ok.iter().flat_map(|c| c.nrm.iter().copied()).collect();
    let mut num = Numbering {
        slot: vec![(MISSING, 0, 0, 0); pos.len() / 3],
        others: HashMap::new(),
        model: 0,
    };
    // Pass 3: tobj's state machine over the events.
    let mut models = Vec::new();
    let mut materials: Vec<tobj::Material> = Vec::new();
    let mut mat_map: HashMap<String, usize> = HashMap::new();
    let mut mtlerr = None;
    let mut name = "unnamed_object".to_owned(); // tobj's name before any `o`/`g`
    let mut mat_id: Option<usize> = None;
    let mut faces: Vec<&[[u32; 3]]> = Vec::new();
    let mut pop = |faces: &mut Vec<&[[u32; 3]]>, name: &str, mat_id, num: &mut Numbering| {
        models.push(tobj::Model::new(
            export(faces, &pos, &nrm, mat_id, num),
            name.to_owned(),
        ));
        faces.clear();
    };
    for c in &ok {
        for ev in &c.events {
            match ev {
                Event::Faces(a, b) => faces.push(&c.faces[*a..*b]),
                Event::Name(n) => {
                    if !faces.is_empty() {
                        pop(&mut faces, &name, mat_id, &mut num);
                    }
                    name = n.clone();
                }
                Event::Mtllib(lib) => match load_mtl(Path::new(lib)) {
                    Ok((mut mats, map)) => {
                        let offset = materials.len();
                        materials.append(&mut mats);
                        for (k, v) in map {
                            mat_map.insert(k, v + offset);
                        }
                    }
                    Err(e) => mtlerr = Some(e),
                },
                Event::Usemtl(m) => {
                    let new = mat_map.get(m).copied();
                    if mat_id != new && !faces.is_empty() {
                        pop(&mut faces, &name, mat_id, &mut num);
                    }
                    mat_id = new;
                }
            }
        }
    }
    pop(&mut faces, &name, mat_id, &mut num);
    let mats = if !materials.is_empty() {
        Ok(materials)
    } else if let Some(e) = mtlerr {
        Err(e)
    } else {
        Ok(Vec::new())
    };
    Ok((models, mats))
}

/// One model: its triples numbered in order of first use, with their coordinates.
fn export(
    faces: &[&[[u32; 3]]],
    pos: &[f32],
    nrm: &[f32],
    mat_id: Option<usize>,
    num: &mut Numbering,
) -> tobj::Mesh {
    num.model += 1;
    let Numbering {
        slot,
        others,
        model,
    } = num;
    let model = *model;
    others.clear();
    let n: usize = faces.iter().map(|f| f.len()).sum();
    let mut mesh = tobj::Mesh {
        material_id: mat_id,
        indices: Vec::with_capacity(n),
        ..Default::default()
    };
    let mut next = 0u32;
    for f in faces {
        for t in f.iter() {
            let [v, vt, vn] = *t;
            let s = &mut slot[v as usize];
            let found = if s.0 != model {
                *s = (model, vt, vn, next);
                None
            } else if (s.1, s.2) == (vt, vn) {
                Some(s.3)
            } else {
                match others.get(t) {
                    Some(&i) => Some(i),
                    None => {
                        others.insert(*t, next);
                        None
                    }
                }
            };
            let i = found.unwrap_or_else(|| {
                let p = 3 * v as usize;
                mesh.positions.extend_from_slice(&pos[p..p + 3]);
                if !nrm.is_empty() && vn != MISSING {
                    let q = 3 * vn as usize;
                    mesh.normals.extend_from_slice(&nrm[q..q + 3]);
                }
                next += 1;
                next - 1
            });
            mesh.indices.push(i);
        }
    }
    mesh
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The parallel path (in chunks of a few bytes, so every line boundary is a chunk
    /// boundary somewhere) against tobj: the same models, vertices, normals and indices.
    fn same_as_tobj(text: &str) {
        let path = Path::new("t.obj");
        let sb = crate::io::Sandbox::for_scene(path, false);
        let no_mtl = |_: &Path| -> tobj::MTLLoadResult { Err(tobj::LoadError::OpenFileFailed) };
        let opts = crate::obj::TOBJ_OPTIONS;
        let (want, _) = tobj::load_obj_buf(&mut text.as_bytes(), &opts, no_mtl).unwrap();
        for chunk in [7, 64, 1 << 20] {
            let (got, _) = load_in_chunks(text, path, &sb, &no_mtl, chunk).unwrap();
            assert_eq!(got.len(), want.len(), "models, chunk {chunk}");
            for (g, w) in got.iter().zip(&want) {
                assert_eq!(g.name, w.name);
                assert_eq!(g.mesh.material_id, w.mesh.material_id);
                assert_eq!(g.mesh.positions, w.mesh.positions, "{}", g.name);
                assert_eq!(g.mesh.normals, w.mesh.normals, "{}", g.name);
                assert_eq!(g.mesh.indices, w.mesh.indices, "{}", g.name);
            }
        }
    }

    #[test]
    fn equals_tobj_on_groups_polygons_relative_indices_and_mixed_triples() {
        same_as_tobj(
            "# test\nv 0 0 0\nv 1 0 0\nv 1 1 0\nv 0 1 0 2\nvt 0 0\nvt 1 0\nvn 0 0 1\nvn 0 0 -1\n\
             g a\nf 1 2 3\nf 1/1/1 3/2/1 4/1/2 2\nf -4 -3 -2 -1\nusemtl m\nf 1//2 2//2 3//1\n\
             o\nf 2 3 4\ng b c # named\nl 1 2 3 4\nl 1 2\nf 4/2 3/1 2/2\n  g  indented\nf 1 2 3\n\
             \tusemtl m\nf 3 2 1\n",
        );
    }

    #[test]
    fn equals_tobj_on_the_shared_scenes() {
        let Some(dir) = testkit::scenes() else {
            return;
        };
        for rel in [
            "dabrovic-sponza/sponza.obj",
            "conference/conference.obj",
            "bart-kitchen/kitchen.obj",
            "bart-museum/museum5.obj",
            "stanford-bunny/stanford-bunny.obj",
            "cornell-box/CornellBox-Original.obj",
        ] {
            let path = dir.join(rel);
            if !path.exists() {
                testkit::skip("scenes", format!("{} not present", path.display()));
                continue;
            }
            let text = std::fs::read_to_string(&path).unwrap();
            let base = path.parent().unwrap().to_path_buf();
            let mtl = |p: &Path| tobj::load_mtl(base.join(p));
            let opts = crate::obj::TOBJ_OPTIONS;
            let (want, wm) = tobj::load_obj_buf(&mut text.as_bytes(), &opts, mtl).unwrap();
            let sb = crate::io::Sandbox::for_scene(&path, false);
            let (got, gm) = load_in_chunks(&text, &path, &sb, &mtl, 64 << 10).unwrap();
            assert_eq!(got.len(), want.len(), "{rel}: models");
            assert_eq!(gm.map(|m| m.len()).ok(), wm.map(|m| m.len()).ok(), "{rel}");
            for (g, w) in got.iter().zip(&want) {
                assert_eq!((&g.name, g.mesh.material_id), (&w.name, w.mesh.material_id));
                assert_eq!(g.mesh.positions, w.mesh.positions, "{rel} {}", g.name);
                assert_eq!(g.mesh.normals, w.mesh.normals, "{rel} {}", g.name);
                assert_eq!(g.mesh.indices, w.mesh.indices, "{rel} {}", g.name);
            }
        }
    }

    #[test]
    fn errors_name_the_same_line_as_the_sequential_path() {
        let path = Path::new("t.obj");
        let sb = crate::io::Sandbox::for_scene(path, false);
        let no_mtl = |_: &Path| -> tobj::MTLLoadResult { Err(tobj::LoadError::OpenFileFailed) };
        for text in [
            "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2 9\n",
            "v 0 0 0\nv 1 0\n",
            "v 0 0 0\nv 1 0 nan\n",
            "v 0 0 0\nv 1 1 1\nv 2 2 2\nf 1 2\n",
            "v 0 0 0\nv 1 1 1 0\n",
            "v 0 0 0\nvt x 1\n",
            "v 0 0 0\nf 1 1 a\n",
            "v 0 0 0\nv 1 1 1\nv 2 2 2\nf 1 2 3 # c\n",
            "v 0 0 0\nv 1 1 1\nv 2 2 2\nf 1/1/1/1 2 3\n",
            "v 0 0 0\nv 1 1 1\nv 2 2 2\nl 1 2 7\n",
            "v 0 0 0\nv 1 1 1\nv 2 2 2\nv 1 2 3 # c\n",
        ] {
            let want = crate::obj::validate_obj(text, path, &sb)
                .err()
                .map(|e| e.to_string());
            for chunk in [5, 1 << 20] {
                let got = load_in_chunks(text, path, &sb, &no_mtl, chunk)
                    .err()
                    .map(|e| e.to_string());
                match &want {
                    Some(w) => assert_eq!(got.as_ref(), Some(w), "{text:?}"),
                    None => assert!(got.is_some(), "{text:?}: tobj's error"),
                }
            }
        }
    }
}
