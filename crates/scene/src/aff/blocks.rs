//! The AFF entities with a block of their own: `m` triangle meshes (vertices, normals,
//! texture coordinates, per-corner indices) and `k` keyframe tracks (translation, rotation,
//! scale, visibility), read into the [`Parser`].

use super::axis_angle;
use super::lex::Cursor;
use super::{Builder, Parser, MAX_COUNT};
use crate::anim::{Interp, RotKey, Track, VecKey};
use crate::error::SceneError;
use geom::Vec3;

impl Parser {
    pub(super) fn mesh(&mut self, c: &mut Cursor, label: &str, mat: u32) -> Result<(), SceneError> {
        c.expect("vertices")?;
        let nv = c.count("vertex count", MAX_COUNT)?;
        let mut pos = Vec::with_capacity(c.capacity(nv, 3));
        for _ in 0..nv {
            pos.push(c.vec3("mesh vertex")?);
        }
        let mut normals: Vec<Vec3> = Vec::new();
        let mut ntex = 0usize;
        loop {
            match c.peek() {
                Some("normals") => {
                    c.pos += 1;
                    let n = c.count("normal count", MAX_COUNT)?;
                    for _ in 0..n {
                        normals.push(c.vec3("mesh normal")?);
                    }
                }
                Some("texturecoords") => {
                    c.pos += 1;
                    ntex = c.count("texture coordinate count", MAX_COUNT)?;
                    c.word("texture name")?;
                    for _ in 0..ntex {
                        c.num("texture u")?;
                        c.num("texture v")?;
                    }
                }
                _ => break,
            }
        }
        c.expect("triangles")?;
        let nt = c.count("triangle count", MAX_COUNT)?;
        let mut b = Builder {
            name: format!("{label} mesh #{}", self.meshes.len()),
            ..Default::default()
        };
        for _ in 0..nt {
            let line = c.line();
            let mut idx = [0usize; 3];
            for v in &mut idx {
                *v = c.count("vertex index", MAX_COUNT)?;
            }
            let mut nidx = None;
            if !normals.is_empty() {
                let mut n = [0usize; 3];
                for v in &mut n {
                    *v = c.count("normal index", MAX_COUNT)?;
                }
                nidx = Some(n);
            }
            if ntex > 0 {
                for _ in 0..3 {
                    c.count("texture index", MAX_COUNT)?;
                }
            }
            let bad =
                idx.iter().find(|&&i| i >= nv).copied().or_else(|| {
                    nidx.and_then(|n| n.iter().find(|&&i| i >= normals.len()).copied())
                });
            if let Some(i) = bad {
                return Err(SceneError::Parse {
                    path: c.path.to_path_buf(),
                    line,
                    msg: format!(
                        "mesh index {i} out of range ({nv} vertices, {} normals)",
                        normals.len()
                    ),
                });
            }
            let p = idx.map(|i| pos[i]);
            b.add_tri(p, nidx.map(|n| n.map(|i| normals[i])), mat);
        }
        self.push_mesh(b, None);
        Ok(())
    }

    pub(super) fn keys(&mut self, c: &mut Cursor) -> Result<(), SceneError> {
        let start = c.line();
        let name = c.word("keyframe name")?;
        c.expect("{")?;
        let mut tr = Track {
            name: name.clone(),
            translation: vec![],
            rotation: vec![],
            scale: vec![],
            interp: Interp::KochanekBartels,
            looping: false,
        };
        loop {
            let line = c.line();
            let w = c.word("'transl', 'rot', 'scale', 'visibility' or '}'")?;
            match w.as_str() {
                "}" => break,
                "transl" | "scale" => {
                    let n = c.count("key count", 1 << 20)?;
                    let mut v = Vec::with_capacity(c.capacity(n, 7));
                    for _ in 0..n {
                        let t = c.num("key time")?;
                        let x = c.vec3(&w)?;
                        let tcb = [c.num("tension")?, c.num("continuity")?, c.num("bias")?];
                        v.push(VecKey { t, v: x, tcb });
                    }
                    if w == "transl" {
                        tr.translation = v;
                    } else {
                        tr.scale = v;
                    }
                }
                "rot" => {
                    let n = c.count("key count", 1 << 20)?;
                    for _ in 0..n {
                        let t = c.num("key time")?;
                        let axis = c.vec3("rotation axis")?;
                        let deg = c.num("rotation angle")?;
                        let tcb = [c.num("tension")?, c.num("continuity")?, c.num("bias")?];
                        tr.rotation.push(RotKey {
                            t,
                            q: axis_angle(axis, deg),
                            tcb,
                        });
                    }
                }
                "visibility" => {
                    let n = c.count("key count", 1 << 20)?;
                    for _ in 0..n {
                        c.num("key time")?;
                        c.num("visibility")?;
                    }
                }
                other => {
                    return Err(SceneError::Parse {
                        path: c.path.to_path_buf(),
                        line,
                        msg: format!("unknown keyframe channel '{other}' in 'k {name}'"),
                    })
                }
            }
        }
        for (channel, keys) in [
            (
                "transl",
                tr.translation.iter().map(|k| k.t).collect::<Vec<_>>(),
            ),
            ("rot", tr.rotation.iter().map(|k| k.t).collect()),
            ("scale", tr.scale.iter().map(|k| k.t).collect()),
        ] {
            // Equal times occur in BART Kitchen (the toy car's wheels): the later key wins
            // from that instant on. Published files also hold tracks whose times go back
            // (0 … 48, then 42 … 50); BART's reference code takes them as they are, and so
            // do we (`anim`: the first segment in file order whose end time exceeds t).
            if let Some(k) = keys.windows(2).position(|w| w[1] < w[0]) {
                self.warnings.push(format!(
                    "{}:{start}: keyframes of '{name}', '{channel}': key {} at time {} comes \
                     after time {}; evaluated as BART's reference code does (segments in file order)",
                    c.path.display(),
                    k + 2,
                    keys[k + 1],
                    keys[k],
                ));
            }
        }
        match self.tracks.iter_mut().find(|t| t.name == name) {
            Some(t) => *t = tr,
            None => self.tracks.push(tr),
        }
        Ok(())
    }
}
