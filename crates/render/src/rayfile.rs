//! Ray and hit files, so the same rays can be traced by every engine (and by peers).
//!
//! ## Ray file, version 2 (all little-endian)
//! ```text
//! offset  size  field
//! 0       8     magic "RSRAYS\0\0"
//! 8       4     version (u32) = 2
//! 12      4     layout (u32) = 0: per ray origin xyz, direction xyz, t_min, t_max (8 × f32)
//! 16      8     ray count (u64)
//! 24      8     the scene's content hash (u64, `Geometry::content_hash`; 0: not recorded)
//! 32      4     length L of the scene's name (u32, at most 255; 0: not recorded)
//! 36      4     zero
//! 40      L'    the scene's name (UTF-8), zero-padded to L' = L rounded up to 8 bytes
//! 40+L'   32·n  rays
//! ```
//! Version 1 (written before the scene was recorded) is version 2 without the bytes 24..40+L':
//! the rays follow the count at offset 24; it is still read. hagrid's headerless files
//! (6 × f32 per ray: origin, direction; t in [0, ∞)) are read too: a file without the magic
//! whose size is a multiple of 24 bytes ([`RayFormat::Hagrid`]; the reader says which it
//! took, so a tool can tell the user).
//!
//! ## Hit file, version 1
//! ```text
//! 0       8     magic "RSHITS\0\0"
//! 8       4     version (u32) = 1
//! 12      4     mode (u32): 0 closest hit, 1 any hit
//! 16      8     ray count (u64)
//! 24      16·n  per ray: triangle id (u32, 0xFFFFFFFF = miss), t, u, v (f32)
//! ```
//! Closest-hit records are bit-identical across rayspace engines (one shared kernel and tie
//! rule); any-hit records agree on hit/miss, while which occluder is recorded may differ.

use geom::{Ray, Vec3};
use std::path::Path;
use trace::batch::{Hit, RayBatch, RayKind};
use trace::tracer::TraceMode;

/// Why a ray or hit file could not be read or written.
#[derive(Debug, thiserror::Error)]
pub enum RayFileError {
    /// The file could not be read.
    #[error(transparent)]
    Read(#[from] scene::SceneError),
    /// The file is not a ray (hit) file, or a damaged one.
    #[error("{}: {msg}", .path.display())]
    Format {
        /// The file.
        path: std::path::PathBuf,
        /// What is wrong with it.
        msg: String,
    },
    /// The file could not be written.
    #[error(transparent)]
    Write(#[from] crate::output::OutputError),
}

const RAY_MAGIC: &[u8; 8] = b"RSRAYS\0\0";
const HIT_MAGIC: &[u8; 8] = b"RSHITS\0\0";
const HEADER: usize = 24;

fn f32s(b: &[u8]) -> impl Iterator<Item = f32> + '_ {
    b.chunks_exact(4)
        .map(|c| f32::from_le_bytes([c[0], c[1], c[2], c[3]]))
}

/// The scene a ray file was made for (version 2's header): its name and content hash.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct SceneTag {
    /// The scene's name (at most 255 bytes are kept).
    pub name: String,
    /// [`scene::Geometry::content_hash`] of its triangles.
    pub hash: u64,
}

impl SceneTag {
    /// The tag of a scene named `name` whose triangles are `geo`.
    pub fn of(name: &str, geo: &scene::Geometry) -> SceneTag {
        let mut name = name.to_string();
        while name.len() > 255 {
            name.pop();
        }
        SceneTag {
            name,
            hash: geo.content_hash(),
        }
    }
}

/// Which layout a ray file is read as.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[cfg_attr(feature = "clap", derive(clap::ValueEnum))]
pub enum RayFormat {
    /// rayspace's own (`RSRAYS`, versions 1 and 2).
    Rayspace,
    /// hagrid's headerless 6 × f32 per ray.
    Hagrid,
}

/// A ray file as read: its rays, the layout it was read as, and (version 2) its scene.
#[derive(Clone, Debug)]
pub struct RayFile {
    /// The rays.
    pub rays: RayBatch,
    /// The layout the file was read as.
    pub format: RayFormat,
    /// The scene the rays were made for, when the file records it.
    pub scene: Option<SceneTag>,
}

/// Write `rays` (origin, direction, t range) as a version-2 ray file that records no scene.
pub fn write_rays(path: &Path, rays: &RayBatch) -> Result<(), RayFileError> {
    write_rays_for(path, rays, None)
}

/// Write `rays` as a version-2 ray file recording `scene`, the scene they were made for.
pub fn write_rays_for(
    path: &Path,
    rays: &RayBatch,
    scene: Option<&SceneTag>,
) -> Result<(), RayFileError> {
    let (hash, name) = scene.map_or((0, ""), |t| (t.hash, t.name.as_str()));
    let name = &name.as_bytes()[..name.len().min(255)];
    let padded = name.len().div_ceil(8) * 8;
    let mut out = Vec::with_capacity(HEADER + 16 + padded + 32 * rays.len());
    out.extend_from_slice(RAY_MAGIC);
    out.extend_from_slice(&2u32.to_le_bytes());
    out.extend_from_slice(&0u32.to_le_bytes());
    out.extend_from_slice(&(rays.len() as u64).to_le_bytes());
    out.extend_from_slice(&hash.to_le_bytes());
    out.extend_from_slice(&(name.len() as u32).to_le_bytes());
    out.extend_from_slice(&0u32.to_le_bytes());
    out.extend_from_slice(name);
    out.resize(HEADER + 16 + padded, 0);
    for i in 0..rays.len() {
        let r = rays.ray(i);
        for v in [
            r.org.x, r.org.y, r.org.z, r.dir.x, r.dir.y, r.dir.z, r.t_min, r.t_max,
        ] {
            out.extend_from_slice(&v.to_le_bytes());
        }
    }
    Ok(crate::output::write_atomic(path, &out)?)
}

/// Read a ray file of either version or a headerless hagrid file ([`read_ray_file`]
/// detecting the layout), returning its rays.
pub fn read_rays(path: &Path, kind: RayKind) -> Result<RayBatch, RayFileError> {
    Ok(read_ray_file(path, kind, None)?.rays)
}

/// Read a ray file: rayspace's (versions 1 and 2) when it starts with the magic, else
/// hagrid's headerless rays; `force` reads it as the one layout or fails. Rays are checked
/// (finite origin, finite non-zero direction, t_min ≤ t_max).
pub fn read_ray_file(
    path: &Path,
    kind: RayKind,
    force: Option<RayFormat>,
) -> Result<RayFile, RayFileError> {
    let bytes = scene::io::read_file(path)?;
    let bad = |msg: String| RayFileError::Format {
        path: path.to_path_buf(),
        msg,
    };
    let magic = bytes.len() >= 8 && &bytes[..8] == RAY_MAGIC;
    let format = match force {
        Some(f) => f,
        None if magic => RayFormat::Rayspace,
        None => RayFormat::Hagrid,
    };
    let mut rays = Vec::new();
    let mut tag = None;
    if format == RayFormat::Rayspace {
        if !magic {
            return Err(bad(format!(
                "not a rayspace ray file (its magic is {:?}, not {:?})",
                String::from_utf8_lossy(&bytes[..8.min(bytes.len())]),
                String::from_utf8_lossy(RAY_MAGIC)
            )));
        }
        if bytes.len() < HEADER {
            return Err(bad("truncated header".into()));
        }
        let u32_at = |o: usize| u32::from_le_bytes(bytes[o..o + 4].try_into().unwrap());
        let version = u32_at(8);
        let layout = u32_at(12);
        let n = u64::from_le_bytes(bytes[16..24].try_into().unwrap());
        if !(version == 1 || version == 2) || layout != 0 {
            return Err(bad(format!(
                "unsupported ray file version {version} / layout {layout}"
            )));
        }
        let mut start = HEADER;
        if version == 2 {
            if bytes.len() < HEADER + 16 {
                return Err(bad("truncated header".into()));
            }
            let hash = u64::from_le_bytes(bytes[24..32].try_into().unwrap());
            let len = u32_at(32) as usize;
            if len > 255 {
                return Err(bad(format!("scene name of {len} bytes (at most 255)")));
            }
            start = HEADER + 16 + len.div_ceil(8) * 8;
            if bytes.len() < start {
                return Err(bad("truncated header".into()));
            }
            let name = std::str::from_utf8(&bytes[HEADER + 16..HEADER + 16 + len])
                .map_err(|_| bad("the scene's name is not UTF-8".into()))?;
            if hash != 0 || len != 0 {
                tag = Some(SceneTag {
                    name: name.to_string(),
                    hash,
                });
            }
        }
        let need = (n as u128) * 32 + start as u128;
        if need != bytes.len() as u128 {
            return Err(bad(format!(
                "header says {n} rays ({need} bytes) but the file has {} bytes",
                bytes.len()
            )));
        }
        let v: Vec<f32> = f32s(&bytes[start..]).collect();
        for c in v.chunks_exact(8) {
            rays.push(Ray::new(
                Vec3::new(c[0], c[1], c[2]),
                Vec3::new(c[3], c[4], c[5]),
                c[6],
                c[7],
            ));
        }
    } else {
        // A word of letters where hagrid has its first origin coordinate is a file with a
        // wrong or damaged magic, not hagrid rays (an f32 whose four bytes are all ASCII
        // letters or digits is no plausible coordinate), unless the user says it is.
        if force.is_none()
            && bytes.len() >= 4
            && bytes[..4].iter().all(|b| b.is_ascii_alphanumeric())
        {
            return Err(bad(format!(
                "magic {:?} is not a rayspace ray file's ({:?}), and the file is not hagrid rays",
                String::from_utf8_lossy(&bytes[..8.min(bytes.len())]),
                String::from_utf8_lossy(RAY_MAGIC)
            )));
        }
        if bytes.is_empty() || bytes.len() % 24 != 0 {
            return Err(bad(format!("not a rayspace ray file and {} bytes is not a whole number of 6 × f32 (hagrid) rays", bytes.len())));
        }
        let v: Vec<f32> = f32s(&bytes).collect();
        for c in v.chunks_exact(6) {
            rays.push(Ray::new(
                Vec3::new(c[0], c[1], c[2]),
                Vec3::new(c[3], c[4], c[5]),
                0.0,
                f32::INFINITY,
            ));
        }
    }
    let batch = RayBatch::from_rays(&rays, kind);
    batch.validate().map_err(|e| bad(e.to_string()))?;
    Ok(RayFile {
        rays: batch,
        format,
        scene: tag,
    })
}

/// Write one record per ray.
pub fn write_hits(path: &Path, hits: &[Hit], mode: TraceMode) -> Result<(), RayFileError> {
    let mut out = Vec::with_capacity(HEADER + 16 * hits.len());
    out.extend_from_slice(HIT_MAGIC);
    out.extend_from_slice(&1u32.to_le_bytes());
    out.extend_from_slice(&(if mode == TraceMode::Any { 1u32 } else { 0 }).to_le_bytes());
    out.extend_from_slice(&(hits.len() as u64).to_le_bytes());
    for h in hits {
        out.extend_from_slice(&h.tri.to_le_bytes());
        for v in [h.t, h.u, h.v] {
            out.extend_from_slice(&v.to_le_bytes());
        }
    }
    Ok(crate::output::write_atomic(path, &out)?)
}

/// Read a hit file.
pub fn read_hits(path: &Path) -> Result<(Vec<Hit>, TraceMode), RayFileError> {
    let bytes = scene::io::read_file(path)?;
    let bad = |msg: &str| RayFileError::Format {
        path: path.to_path_buf(),
        msg: msg.to_string(),
    };
    if bytes.len() < HEADER || &bytes[..8] != HIT_MAGIC {
        return Err(bad("not a rayspace hit file"));
    }
    let mode = if u32::from_le_bytes(bytes[12..16].try_into().unwrap()) == 1 {
        TraceMode::Any
    } else {
        TraceMode::Closest
    };
    let n = u64::from_le_bytes(bytes[16..24].try_into().unwrap());
    if (n as u128) * 16 + HEADER as u128 != bytes.len() as u128 {
        return Err(bad("size does not match the ray count"));
    }
    let hits = bytes[HEADER..]
        .chunks_exact(16)
        .map(|c| {
            let f = |k: usize| f32::from_le_bytes(c[k..k + 4].try_into().unwrap());
            Hit {
                tri: u32::from_le_bytes(c[..4].try_into().unwrap()),
                t: f(4),
                u: f(8),
                v: f(12),
            }
        })
        .collect();
    Ok((hits, mode))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn roundtrip_and_hagrid() {
        let d = std::env::temp_dir().join(format!("rayspace-rayfile-{}", std::process::id()));
        std::fs::create_dir_all(&d).unwrap();
        let rays = vec![
            Ray::new(
                Vec3::new(1.0, 2.0, 3.0),
                Vec3::new(0.0, -0.0, 1.0),
                0.5,
                7.0,
            ),
            Ray::new(Vec3::ZERO, Vec3::X, 0.0, f32::INFINITY),
        ];
        let b = RayBatch::from_rays(&rays, RayKind::Primary);
        let p = d.join("r.rays");
        write_rays(&p, &b).unwrap();
        let r = read_rays(&p, RayKind::Primary).unwrap();
        assert_eq!((0..2).map(|i| r.ray(i)).collect::<Vec<_>>(), rays);
        assert!(r.dir[0].y.is_sign_negative(), "-0.0 survives");
        // hagrid: 6 floats per ray, no header.
        let h = d.join("h.bin");
        let mut bytes = Vec::new();
        for v in [1.0f32, 2.0, 3.0, 0.0, 1.0, 0.0] {
            bytes.extend_from_slice(&v.to_le_bytes());
        }
        std::fs::write(&h, &bytes).unwrap();
        let r = read_rays(&h, RayKind::Primary).unwrap();
        assert_eq!(
            r.ray(0),
            Ray::new(Vec3::new(1.0, 2.0, 3.0), Vec3::Y, 0.0, f32::INFINITY)
        );
        // Truncated and malformed files are errors naming the file.
        std::fs::write(&h, &bytes[..20]).unwrap();
        assert!(read_rays(&h, RayKind::Primary)
            .unwrap_err()
            .to_string()
            .contains("h.bin"));
        let mut bad = std::fs::read(&p).unwrap();
        bad.truncate(40);
        std::fs::write(&p, &bad).unwrap();
        assert!(read_rays(&p, RayKind::Primary)
            .unwrap_err()
            .to_string()
            .contains("header says"));
        // A wrong magic is not read as hagrid rays, even when the size would fit.
        write_rays(&d.join("w.rays"), &b).unwrap();
        let mut wrong = std::fs::read(d.join("w.rays")).unwrap();
        wrong[..8].copy_from_slice(b"RSRAYX\0\0");
        wrong.truncate(72);
        std::fs::write(d.join("w.rays"), &wrong).unwrap();
        let e = read_rays(&d.join("w.rays"), RayKind::Primary)
            .unwrap_err()
            .to_string();
        assert!(e.contains("w.rays") && e.contains("magic"), "{e}");
        let mut nan = bytes.clone();
        nan[12..16].copy_from_slice(&f32::NAN.to_le_bytes());
        std::fs::write(&h, &nan).unwrap();
        assert!(read_rays(&h, RayKind::Primary).is_err());
        // Version 2 records the scene; version 1 files are still read.
        let tag = SceneTag {
            name: "office".into(),
            hash: 0x0123_4567_89ab_cdef,
        };
        write_rays_for(&p, &b, Some(&tag)).unwrap();
        let f = read_ray_file(&p, RayKind::Primary, None).unwrap();
        assert_eq!((f.scene, f.format), (Some(tag), RayFormat::Rayspace));
        assert_eq!(f.rays.ray(1), rays[1]);
        let v2 = std::fs::read(&p).unwrap();
        let mut v1 = v2[..24].to_vec();
        v1[8..12].copy_from_slice(&1u32.to_le_bytes());
        v1.extend_from_slice(&v2[v2.len() - 64..]);
        std::fs::write(&p, &v1).unwrap();
        let f = read_ray_file(&p, RayKind::Primary, None).unwrap();
        assert_eq!(f.scene, None);
        assert_eq!(f.rays.ray(0), rays[0]);
        // Forced layouts: rayspace refuses a headerless file; hagrid reads 24-byte records.
        assert!(
            read_ray_file(&h, RayKind::Primary, Some(RayFormat::Rayspace))
                .unwrap_err()
                .to_string()
                .contains("not a rayspace ray file")
        );
        std::fs::write(&h, &bytes).unwrap();
        let f = read_ray_file(&h, RayKind::Primary, None).unwrap();
        assert_eq!(f.format, RayFormat::Hagrid);
        // Hits.
        let hits = vec![
            Hit {
                tri: 3,
                t: 1.5,
                u: 0.25,
                v: 0.5,
            },
            Hit::MISS,
        ];
        let hp = d.join("x.hits");
        write_hits(&hp, &hits, TraceMode::Closest).unwrap();
        assert_eq!(read_hits(&hp).unwrap(), (hits, TraceMode::Closest));
    }
}
