//! glTF 2.0 loading (`.gltf` with external or embedded buffers, `.glb`) through the `gltf` crate.
//!
//! Every mesh instance in the default scene becomes one of our meshes, with the node's world
//! transform. Materials map from metallic–roughness to Blinn-Phong:
//! diffuse = base·(1 − metallic), specular = lerp(0.04, base, metallic),
//! shininess = 2/α² − 2 with α = roughness² (the Beckmann–Phong correspondence),
//! reflectivity = metallic·(1 − roughness); blended alpha becomes transparency.
//! A perspective camera in the file is used; otherwise the camera frames the bounds.

use crate::error::Invalid;
use crate::error::SceneError;
use crate::model::{smooth_normals, LoadReport, Material, Mesh, Scene};
use crate::obj::auto_camera_and_light;
use geom::{Mat4, Vec3};
use std::collections::HashMap;
use std::path::Path;

fn convert(m: &gltf::Material) -> Material {
    let pbr = m.pbr_metallic_roughness();
    let [r, g, b, a] = pbr.base_color_factor();
    let base = Vec3::new(r, g, b);
    let metallic = pbr.metallic_factor().clamp(0.0, 1.0);
    let rough = pbr.roughness_factor().clamp(0.0, 1.0);
    let alpha = (rough * rough).max(1e-3);
    let transparency = if m.alpha_mode() == gltf::material::AlphaMode::Blend {
        (1.0 - a).clamp(0.0, 1.0)
    } else {
        0.0
    };
    Material {
        name: m.name().unwrap_or("gltf-material").to_string(),
        diffuse: base * (1.0 - metallic),
        specular: Vec3::splat(0.04).lerp(base, metallic),
        shininess: (2.0 / (alpha * alpha) - 2.0).clamp(1.0, 2048.0),
        reflectivity: metallic * (1.0 - rough),
        transparency,
        ior: if transparency > 0.0 { 1.5 } else { 1.0 },
        emission: Vec3::from_array(m.emissive_factor()),
        // glTF has no ambient colour; under a TOML scene's ambient light the diffuse
        // albedo reflects it (the usual convention).
        ambient: base * (1.0 - metallic),
    }
}

/// Load a glTF 2.0 scene (`.gltf` or `.glb`): its meshes with their node transforms and
/// materials; errors name the file.
pub fn load_gltf_scene(path: &Path) -> Result<Scene, SceneError> {
    load_gltf_scene_in(path, &crate::io::Sandbox::for_scene(path, false))
}

/// What the `gltf` crate's validation assumes before it checks it: every primitive's
/// POSITION accessor exists (its validation hook indexes the accessor list directly and
/// panicked on a missing one, found by fuzzing). A file that is not JSON is left to the
/// crate's own error.
fn precheck(bytes: &[u8]) -> Result<(), Invalid> {
    let json: std::borrow::Cow<[u8]> = if bytes.starts_with(b"glTF") {
        match gltf::Glb::from_slice(bytes) {
            Ok(g) => g.json,
            Err(_) => return Ok(()),
        }
    } else {
        bytes.into()
    };
    // The crate's own parser without its validation, so that both see the same document.
    let Ok(root) = gltf::json::deserialize::from_slice::<gltf::json::Root>(&json) else {
        return Ok(());
    };
    let accessors = root.accessors.len();
    for (m, mesh) in root.meshes.iter().enumerate() {
        for (p, prim) in mesh.primitives.iter().enumerate() {
            for (name, a) in &prim.attributes {
                if a.value() >= accessors {
                    let name = match name {
                        gltf::json::validation::Checked::Valid(s) => s.to_string(),
                        gltf::json::validation::Checked::Invalid => "an invalid".into(),
                    };
                    return Err(Invalid::from(format!(
                        "mesh {m} primitive {p}: {name} accessor {} does not exist ({accessors} accessors)",
                        a.value()
                    )));
                }
            }
        }
    }
    Ok(())
}

/// Decode a relative URI's `%XX` escapes (RFC 3986); `None` when an escape is malformed or
/// the result is not UTF-8 (where the `gltf` crate's own import would panic).
fn percent_decode(uri: &str) -> Option<String> {
    let b = uri.as_bytes();
    let mut out = Vec::with_capacity(b.len());
    let mut i = 0;
    while i < b.len() {
        if b[i] == b'%' {
            let hex = std::str::from_utf8(b.get(i + 1..i + 3)?).ok()?;
            out.push(u8::from_str_radix(hex, 16).ok()?);
            i += 3;
        } else {
            out.push(b[i]);
            i += 1;
        }
    }
    String::from_utf8(out).ok()
}

/// The buffers' bytes: the GLB blob and `data:` URIs as the `gltf` crate decodes them;
/// files (relative or `file:` URIs) inside the sandbox, through the bounded reader.
fn import_buffers(
    document: &gltf::Document,
    path: &Path,
    mut blob: Option<Vec<u8>>,
    sb: &crate::io::Sandbox,
) -> Result<Vec<gltf::buffer::Data>, SceneError> {
    let bad = |i: usize, msg: String| SceneError::invalid(path, format!("buffer {i}: {msg}"));
    let mut out = Vec::new();
    for b in document.buffers() {
        let i = b.index();
        let mut bytes = match b.source() {
            gltf::buffer::Source::Uri(uri) if !uri.starts_with("data:") => {
                let name = if let Some(rest) = uri.strip_prefix("file://") {
                    rest.to_string()
                } else if let Some(rest) = uri.strip_prefix("file:") {
                    rest.to_string()
                } else if uri.contains(':') {
                    return Err(bad(i, format!("unsupported URI scheme in '{uri}'")));
                } else {
                    percent_decode(uri).ok_or_else(|| bad(i, format!("malformed URI '{uri}'")))?
                };
                let p = sb.resolve(path, &format!("buffer {i} uri"), &name)?;
                sb.read_file(&p)?
            }
            source => {
                gltf::buffer::Data::from_source_and_blob(source, None, &mut blob)
                    .map_err(|e| bad(i, e.to_string()))?
                    .0
            }
        };
        if bytes.len() < b.length() {
            return Err(bad(
                i,
                format!("{} bytes, but byteLength says {}", bytes.len(), b.length()),
            ));
        }
        // As the `gltf` crate does: accessors may read to a 4-byte boundary.
        bytes.resize(bytes.len().next_multiple_of(4), 0);
        out.push(gltf::buffer::Data(bytes));
    }
    Ok(out)
}

/// Why an accessor cannot be read from its buffers (glTF §3.6.2).
#[derive(Debug, thiserror::Error)]
enum AccessorError {
    /// Its buffer view reaches past the end of its buffer.
    #[error("accessor {accessor}: buffer view {view} (bytes {start}..{end}) runs past the end of buffer {buffer} ({have} bytes)")]
    ViewPastBuffer {
        accessor: usize,
        view: usize,
        start: u64,
        end: u64,
        buffer: usize,
        have: u64,
    },
    /// Its elements reach past the end of its buffer view.
    #[error("accessor {accessor} ({count} elements of {size} bytes) needs {end} bytes of buffer view {view}, which has {len}")]
    ElementsPastView {
        accessor: usize,
        count: u64,
        size: u64,
        end: u64,
        view: usize,
        len: u64,
    },
}

/// Why accessor `acc` cannot be read from `buffers` (`Ok`: it can): its elements must lie
/// within its buffer view, and the view within its buffer (glTF §3.6.2).
fn check_accessor(
    acc: &gltf::Accessor,
    buffers: &[gltf::buffer::Data],
) -> Result<(), AccessorError> {
    let Some(view) = acc.view() else {
        // A sparse-only accessor has no view: the reader makes its zeros itself.
        return Ok(());
    };
    let buf = view.buffer();
    let have = buffers.get(buf.index()).map_or(0, |d| d.0.len()) as u64;
    let (start, len) = (view.offset() as u64, view.length() as u64);
    if start + len > have {
        return Err(AccessorError::ViewPastBuffer {
            accessor: acc.index(),
            view: view.index(),
            start,
            end: start + len,
            buffer: buf.index(),
            have,
        });
    }
    let count = acc.count() as u64;
    if count > 0 {
        let size = acc.size() as u64;
        let stride = view.stride().map_or(size, |s| s as u64);
        let end = acc.offset() as u64 + (count - 1) * stride + size;
        if end > len {
            return Err(AccessorError::ElementsPastView {
                accessor: acc.index(),
                count,
                size,
                end,
                view: view.index(),
                len,
            });
        }
    }
    Ok(())
}

/// [`load_gltf_scene`] with the buffer files it references confined to `sb`.
pub fn load_gltf_scene_in(path: &Path, sb: &crate::io::Sandbox) -> Result<Scene, SceneError> {
    let t0 = std::time::Instant::now();
    let bad = |msg: String| SceneError::invalid(path, msg);
    if !path.exists() {
        return Err(SceneError::Io {
            path: path.to_path_buf(),
            cause: std::io::Error::new(std::io::ErrorKind::NotFound, "no such file"),
        });
    }
    // Read through the bounded reader and parse from memory: `Gltf::open` trusts a GLB
    // header's length and allocates it (a 3 GB request from a 100-byte file, found by
    // fuzzing); `from_slice` checks lengths against the bytes there are.
    let bytes = sb.read_file(path)?;
    precheck(&bytes).map_err(|e| bad(format!("glTF: {e}")))?;
    let gltf::Gltf { document, blob } =
        gltf::Gltf::from_slice(&bytes).map_err(|e| bad(format!("glTF: {e}")))?;
    drop(bytes);
    let buffers = import_buffers(&document, path, blob, sb)?;
    let mut report = LoadReport {
        source: Some(path.to_path_buf()),
        ..Default::default()
    };
    let mut materials = vec![Material::default()];
    let mut mat_ids: HashMap<Option<usize>, u32> = HashMap::new();
    let mut meshes = Vec::new();
    // Triangles made so far: a mesh instanced by many nodes is made once per node.
    let mut triangles = 0u64;
    let mut camera = None;
    let gscene = document
        .default_scene()
        .or_else(|| document.scenes().next())
        .ok_or_else(|| bad("glTF file has no scene".into()))?;
    let mut stack: Vec<(gltf::Node, Mat4)> = gscene.nodes().map(|n| (n, Mat4::IDENTITY)).collect();
    // glTF nodes form trees (§5.25: a node has at most one parent, no cycles); a node met
    // twice is a cycle or a shared child, which would otherwise be walked forever.
    let mut seen = vec![false; document.nodes().len()];
    while let Some((node, parent)) = stack.pop() {
        if std::mem::replace(&mut seen[node.index()], true) {
            return Err(bad(format!(
                "node {} is reached twice: the node hierarchy has a cycle or a shared child",
                node.index()
            )));
        }
        let world = parent * Mat4::from_cols_array_2d(&node.transform().matrix());
        for c in node.children() {
            stack.push((c, world));
        }
        if let (Some(cam), None) = (node.camera(), &camera) {
            if let gltf::camera::Projection::Perspective(p) = cam.projection() {
                let eye = world.transform_point3(Vec3::ZERO);
                let fwd = world.transform_vector3(-Vec3::Z).normalize_or(-Vec3::Z);
                let up = world.transform_vector3(Vec3::Y).normalize_or(Vec3::Y);
                camera = Some(crate::Camera {
                    eye,
                    target: eye + fwd,
                    up,
                    vfov: p.yfov().to_degrees(),
                });
            }
        }
        let Some(mesh) = node.mesh() else { continue };
        for (pi, prim) in mesh.primitives().enumerate() {
            let what = format!("mesh '{}' primitive {pi}", mesh.name().unwrap_or("?"));
            if prim.mode() != gltf::mesh::Mode::Triangles {
                report.notes.push(format!(
                    "{what}: mode {:?} skipped (only triangles are rendered)",
                    prim.mode()
                ));
                continue;
            }
            // Counted from the accessors, before anything is read or allocated.
            let count = match prim.indices() {
                Some(a) => a.count(),
                None => prim
                    .get(&gltf::Semantic::Positions)
                    .map_or(0, |a| a.count()),
            };
            triangles += count as u64 / 3;
            sb.admit_triangles(path, None, triangles)?;
            // Every accessor the primitive reads lies within its buffer view, and every view
            // within its buffer: the reader would otherwise return nothing (once reported as
            // "no positions" for a view past its buffer's end).
            let accessors = prim
                .get(&gltf::Semantic::Positions)
                .map(|a| ("position", a))
                .into_iter()
                .chain(prim.get(&gltf::Semantic::Normals).map(|a| ("normal", a)))
                .chain(prim.indices().map(|a| ("index", a)));
            for (role, acc) in accessors {
                check_accessor(&acc, &buffers).map_err(|e| bad(format!("{what}: {role} {e}")))?;
            }
            let reader = prim.reader(|b| buffers.get(b.index()).map(|d| &d.0[..]));
            let pos: Vec<Vec3> = reader
                .read_positions()
                .ok_or_else(|| bad(format!("{what}: no positions")))?
                .map(Vec3::from_array)
                .collect();
            if let Some(p) = pos.iter().find(|p| !geom::finite3(**p)) {
                return Err(bad(format!("{what}: non-finite vertex {p}")));
            }
            // Indices are unsigned integers (§3.7.2.1); the `gltf` crate's reader reaches
            // `unreachable!` on any other type (found by fuzzing).
            if let Some(acc) = prim.indices() {
                use gltf::accessor::DataType;
                if !matches!(
                    acc.data_type(),
                    DataType::U8 | DataType::U16 | DataType::U32
                ) || acc.dimensions() != gltf::accessor::Dimensions::Scalar
                {
                    return Err(bad(format!(
                        "{what}: index accessor {} is not unsigned scalars",
                        acc.index()
                    )));
                }
            }
            // An index accessor that does not fit its buffer is an error, not a reason to
            // draw the vertices unindexed.
            let idx: Vec<u32> = match (prim.indices(), reader.read_indices()) {
                (Some(acc), Some(i)) => {
                    let v: Vec<u32> = i.into_u32().collect();
                    if v.len() != acc.count() {
                        return Err(bad(format!(
                            "{what}: index accessor {} has {} of its {} indices in its buffer",
                            acc.index(),
                            v.len(),
                            acc.count()
                        )));
                    }
                    v
                }
                (Some(acc), None) => {
                    return Err(bad(format!(
                        "{what}: index accessor {} ({} indices) does not fit its buffer",
                        acc.index(),
                        acc.count()
                    )))
                }
                (None, _) => (0..pos.len() as u32).collect(),
            };
            if let Some(i) = idx.iter().find(|&&i| i as usize >= pos.len()) {
                return Err(bad(format!(
                    "{what}: index {i} out of range ({} vertices)",
                    pos.len()
                )));
            }
            let tris: Vec<[u32; 3]> = idx.chunks_exact(3).map(|c| [c[0], c[1], c[2]]).collect();
            let normals = match reader.read_normals() {
                Some(n) => n
                    .map(|v| Vec3::from_array(v).normalize_or(Vec3::Y))
                    .collect::<Vec<_>>(),
                None => {
                    report.normals_computed += pos.len();
                    smooth_normals(&pos, &tris)
                }
            };
            if normals.len() != pos.len() {
                return Err(bad(format!(
                    "{what}: {} normals for {} vertices",
                    normals.len(),
                    pos.len()
                )));
            }
            let mat = *mat_ids.entry(prim.material().index()).or_insert_with(|| {
                match prim.material().index() {
                    None => 0,
                    Some(_) => {
                        materials.push(convert(&prim.material()));
                        materials.len() as u32 - 1
                    }
                }
            });
            let mut m = Mesh::new(
                format!("{}#{pi}", mesh.name().unwrap_or("mesh")),
                pos,
                tris,
                mat,
            );
            m.normals = normals;
            m.transform = world;
            report.degenerate_skipped += m.remove_degenerate();
            if !m.triangles.is_empty() {
                meshes.push(m);
            }
        }
    }
    report.load_seconds = t0.elapsed().as_secs_f64();
    let mut scene = Scene::from_file(path, meshes, materials, report);
    auto_camera_and_light(&mut scene);
    if let Some(c) = camera {
        scene.camera = c;
    }
    Ok(scene)
}

#[cfg(test)]
pub(crate) mod tests {
    use super::*;

    /// A minimal glTF with one quad (two triangles, indexed, embedded base64 buffer), a node
    /// transform (translation by (0, 0, −5)) and a metallic material.
    pub fn quad_gltf() -> String {
        let mut bytes = Vec::new();
        for p in [
            [0.0f32, 0.0, 0.0],
            [1.0, 0.0, 0.0],
            [1.0, 1.0, 0.0],
            [0.0, 1.0, 0.0],
        ] {
            for v in p {
                bytes.extend_from_slice(&v.to_le_bytes());
            }
        }
        for i in [0u16, 1, 2, 0, 2, 3] {
            bytes.extend_from_slice(&i.to_le_bytes());
        }
        let b64 = base64::encode(&bytes);
        format!(
            r#"{{"asset":{{"version":"2.0"}},"scene":0,"scenes":[{{"nodes":[0]}}],
            "nodes":[{{"mesh":0,"translation":[0,0,-5]}}],
            "meshes":[{{"name":"quad","primitives":[{{"attributes":{{"POSITION":0}},"indices":1,"material":0}}]}}],
            "materials":[{{"name":"metal","pbrMetallicRoughness":{{"baseColorFactor":[1,0.5,0.2,1],"metallicFactor":1.0,"roughnessFactor":0.2}}}}],
            "accessors":[
              {{"bufferView":0,"componentType":5126,"count":4,"type":"VEC3","min":[0,0,0],"max":[1,1,0]}},
              {{"bufferView":1,"componentType":5123,"count":6,"type":"SCALAR"}}],
            "bufferViews":[{{"buffer":0,"byteOffset":0,"byteLength":48}},{{"buffer":0,"byteOffset":48,"byteLength":12}}],
            "buffers":[{{"byteLength":60,"uri":"data:application/octet-stream;base64,{b64}"}}]}}"#
        )
    }

    #[test]
    fn an_index_accessor_beyond_its_buffer_is_an_error() {
        let d = std::env::temp_dir().join(format!("rayspace-gltf-idx-{}", std::process::id()));
        std::fs::create_dir_all(&d).unwrap();
        let p = d.join("long.gltf");
        let g = quad_gltf().replace(
            r#""count":6,"type":"SCALAR""#,
            r#""count":600,"type":"SCALAR""#,
        );
        assert_ne!(g, quad_gltf());
        std::fs::write(&p, g).unwrap();
        let e = load_gltf_scene(&p).unwrap_err().to_string();
        assert!(
            e.contains("long.gltf") && e.contains("index accessor"),
            "{e}"
        );
    }

    #[test]
    fn loads_quad_with_transform_and_material() {
        let d = std::env::temp_dir().join(format!("rayspace-gltf-{}", std::process::id()));
        std::fs::create_dir_all(&d).unwrap();
        let p = d.join("quad.gltf");
        std::fs::write(&p, quad_gltf()).unwrap();
        let s = load_gltf_scene(&p).unwrap();
        s.validate().unwrap();
        assert_eq!(s.triangle_count(), 2);
        let b = s.bounds();
        assert!((b.min.z + 5.0).abs() < 1e-6 && (b.max.x - 1.0).abs() < 1e-6);
        let m = &s.materials[s.meshes[0].materials[0] as usize];
        assert_eq!(m.name, "metal");
        assert!(m.diffuse.length() < 1e-6, "fully metallic: no diffuse");
        assert!(m.reflectivity > 0.7 && m.shininess > 100.0);
        // Malformed files name the file.
        let bad = d.join("bad.gltf");
        std::fs::write(&bad, "{\"asset\": ").unwrap();
        let e = crate::load(bad.to_str().unwrap(), &Default::default())
            .unwrap_err()
            .to_string();
        assert!(e.contains("bad.gltf"), "{e}");
    }
}
