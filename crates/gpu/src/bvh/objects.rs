//! The object tree built on the device, the twin of `crates/accel/src/bvh/objects.rs`'s LBVH
//! (Karras 2012, §3–4; boxes bottom up as Apetrei 2014): every pass a kernel of
//! `objects.wgsl`, the keys sorted by [`Exec::sort_pairs_all`], and the result the CPU's
//! [`accel::bvh::objects::build`] with [`accel::bvh::ObjectBuilder::Lbvh`] bit for bit:
//! children, key ranges, triangles in leaf order, depth, the inner nodes' and leaves' bounds (spheres and grown
//! boxes) and the children's boxes side by side (tests compare every array).
//!
//! Nothing is read back: the key layout ([`KeyBits`]) follows from the triangle and mesh
//! counts the host knows, the scene and centroid boxes are reduced on the device, and the
//! sort runs every digit instead of reading back which digits vary. The triangle spheres
//! come with the scene's upload ([`SceneArrays`]). The collapsed records (the dual
//! traversal's 8-wide nodes, the single-ray path's box nodes) are not built here.

use crate::device::Gpu;
use crate::kernels::params::{ObjNodesParams, ObjTrisParams, PermuteParams};
use crate::kernels::{launch, Exec};
use accel::bvh::objects::{Bounds, BoxNode, KeyBits, ObjectTree, LEAF};
use geom::{Aabb, Sphere, Vec3};
use scene::Geometry;
use std::time::Instant;

/// What the build reads: the scene's buffers as the engine uploads them.
pub struct TreeInput<'a> {
    /// Triangles (3 × vec4 each).
    pub tris: &'a wgpu::Buffer,
    /// Their bounding spheres (`Sphere::of_triangle`: centre, radius).
    pub tri_sphere: &'a wgpu::Buffer,
    /// Each triangle's mesh.
    pub tri_mesh: &'a wgpu::Buffer,
    /// The mesh spheres a node holding exactly one mesh may take (thesis §3.2.2), or none.
    pub mesh_sphere: Option<&'a wgpu::Buffer>,
    /// First triangle of each mesh, and one past the last.
    pub mesh_first: &'a [u32],
    /// Make the single-ray path's box nodes and its triangles in leaf order (else those two
    /// buffers are left empty: the dual traversal reads the binary tree only, and the box
    /// nodes are its largest array, 256 bytes per inner node).
    pub single: bool,
}

/// The scene's per-triangle and per-mesh arrays in the layouts the kernels read: triangles
/// (3 × vec4), their spheres and the mesh spheres (centre, radius), each triangle's mesh.
pub struct SceneArrays {
    /// Triangles, 3 × vec4 (xyz, 0) each.
    pub tris: Vec<[f32; 4]>,
    /// Per triangle its sphere ([`Sphere::of_triangle`]: centre, radius).
    pub spheres: Vec<[f32; 4]>,
    /// Per triangle its mesh.
    pub tri_mesh: Vec<u32>,
    /// Per mesh its sphere (thesis §3.2.2).
    pub meshes: Vec<[f32; 4]>,
}

impl SceneArrays {
    /// The arrays of `geo`.
    pub fn of(geo: &scene::Geometry) -> SceneArrays {
        let v4 = |s: &Sphere| [s.center.x, s.center.y, s.center.z, s.radius];
        let nm = geo.mesh_first.len().saturating_sub(1);
        let mut tri_mesh = vec![0u32; geo.tris.len()];
        for m in 0..nm {
            for t in geo.mesh_first[m]..geo.mesh_first[m + 1] {
                tri_mesh[t as usize] = m as u32;
            }
        }
        SceneArrays {
            tris: geo
                .tris
                .iter()
                .flat_map(|t| t.map(|v| [v.x, v.y, v.z, 0.0]))
                .collect(),
            spheres: geo
                .tris
                .iter()
                .map(|t| v4(&Sphere::of_triangle(t[0], t[1], t[2])))
                .collect(),
            tri_mesh,
            meshes: geo.mesh_sphere.iter().map(v4).collect(),
        }
    }
}

/// The tree on the device (layouts as `objects.wgsl` writes them).
pub struct DeviceTree {
    /// Triangles (leaves); inner nodes are one fewer.
    pub leaves: u32,
    /// Per inner node its children (`LEAF | triangle` for a leaf), as `vec2<u32>`.
    pub child: wgpu::Buffer,
    /// Per inner node its leaves' range `[lo, hi]` of [`DeviceTree::order`].
    pub range: wgpu::Buffer,
    /// Per inner node its bounds: sphere, grown box min, grown box max (3 × vec4).
    pub node: wgpu::Buffer,
    /// Per inner node its two children's grown boxes (min, max, min, max: 4 × vec4).
    pub child_box: wgpu::Buffer,
    /// Per triangle its bounds: sphere, grown box min, grown box max (3 × vec4).
    pub leaf: wgpu::Buffer,
    /// The triangles in leaf order.
    pub order: wgpu::Buffer,
    /// Per inner node its exact box and depth (8 words: min xyz, depth, max xyz, 0).
    pub exact: wgpu::Buffer,
    /// The single-ray path's box nodes, [`BOX_WORDS`] words each, at their binary inner
    /// node's index (`objects.wgsl`: lane minima, maxima, references, count, leaf-lane bits,
    /// triangles per lane).
    pub boxes: wgpu::Buffer,
    /// The triangles in leaf order (3 × vec4 each).
    pub leaf_tris: wgpu::Buffer,
}

/// Words of one box node on the device.
pub const BOX_WORDS: u64 = 64;

/// Build the tree over `inp`'s `n` triangles on the device (recorded on `ex`; nothing is
/// submitted or read back).
pub fn build(ex: &mut Exec, inp: &TreeInput, n: u32) -> DeviceTree {
    let g = ex.g;
    let nu = n as u64;
    let inner = nu.saturating_sub(1);
    let kb = KeyBits::new(n as usize, inp.mesh_first.len().saturating_sub(1));
    let tp = ObjTrisParams {
        triangles: n,
        axis_bits: kb.axis_bits,
        code_bits: kb.code_bits,
    };
    let tbox = g.storage("object triangle boxes", nu * 32);
    let bounds = g.upload(
        "object bounds",
        &[[u32::MAX; 3], [0; 3], [u32::MAX; 3], [0; 3]],
    );
    ex.run(
        launch::ObjBoxes {
            o_tris: inp.tris,
            o_tbox: &tbox,
            o_bounds: &bounds,
        },
        tp,
        nu,
        256,
    );
    let leaf = g.storage("object leaf bounds", nu * 48);
    ex.run(
        launch::ObjLeaves {
            o_tbox: &tbox,
            o_bounds: &bounds,
            o_leaf: &leaf,
            o_tri_sphere: inp.tri_sphere,
        },
        tp,
        nu,
        256,
    );
    let mut tree = DeviceTree {
        leaves: n,
        child: g.storage("object children", inner * 8),
        range: g.storage("object ranges", inner * 8),
        node: g.storage("object node bounds", inner * 48),
        child_box: g.storage("object children's boxes", inner * 64),
        leaf,
        order: g.storage("object leaf order", nu * 4),
        exact: g.storage("object exact boxes", inner * 32),
        boxes: g.storage(
            "object box nodes",
            inp.single as u64 * inner * BOX_WORDS * 4,
        ),
        leaf_tris: g.storage("object leaf triangles", inp.single as u64 * nu * 48),
    };
    let np = ObjNodesParams {
        leaves: n,
        mesh_spheres: inp.mesh_sphere.is_some() as u32,
    };
    let pos = g.storage("object leaf positions", nu * 4);
    let positions = |ex: &mut Exec, tree: &DeviceTree| {
        ex.run(
            launch::ObjPositions {
                o_tris: inp.tris,
                o_order: &tree.order,
                o_pos: &pos,
                o_leaf_tris: &tree.leaf_tris,
            },
            np,
            nu,
            256,
        )
    };
    if n < 2 {
        // A lone triangle is the root; with none, nothing is traversed.
        if n == 1 {
            tree.order = ex.iota(1);
            if inp.single {
                positions(ex, &tree);
            }
        }
        return tree;
    }
    // Keys, sorted with the triangle ids: the low words, then (stably) the high words.
    let lo = g.storage("object keys (low)", nu * 4);
    let hi = g.storage("object keys (high)", nu * 4);
    let lo_copy = g.storage("object keys (low, unsorted)", nu * 4);
    ex.run(
        launch::ObjKeys {
            o_tbox: &tbox,
            o_bounds: &bounds,
            o_tri_mesh: inp.tri_mesh,
            o_key_lo: &lo,
            o_key_hi: &hi,
            o_key_lo_copy: &lo_copy,
        },
        tp,
        nu,
        256,
    );
    let bits = kb.code_bits + kb.mesh_bits;
    let order = ex.iota(nu);
    ex.sort_pairs_all(&lo, &order, nu, bits.min(32));
    let gather = |ex: &mut Exec, what: &str, src: &wgpu::Buffer, by: &wgpu::Buffer| {
        let out = g.storage(what, nu * 4);
        ex.run(
            launch::Gather {
                x_a: by,
                x_b: src,
                y_a: &out,
            },
            PermuteParams { n, value: 0 },
            nu,
            256,
        );
        out
    };
    let hi = if bits > 32 {
        let hs = gather(ex, "object keys (high, by low)", &hi, &order);
        ex.sort_pairs_all(&hs, &order, nu, bits - 32);
        // The low words in the final order (the first sort's are ordered by them alone).
        let ls = gather(ex, "object keys (low, sorted)", &lo_copy, &order);
        ex.copy(&ls, 0, &lo, nu * 4);
        hs
    } else {
        hi
    };
    let parent = g.storage("object parents", (inner + nu) * 4);
    ex.run(
        launch::ObjNodes {
            o_key_lo: &lo,
            o_key_hi: &hi,
            o_order: &order,
            o_child: &tree.child,
            o_range: &tree.range,
            o_parent: &parent,
        },
        np,
        inner,
        256,
    );
    let arrived = g.storage("object arrivals", inner * 4);
    ex.clear(&arrived);
    ex.run(
        launch::ObjClimb {
            o_tbox: &tbox,
            o_child: &tree.child,
            o_parent: &parent,
            o_arrived: &arrived,
            o_nbox: &tree.exact,
        },
        np,
        nu,
        256,
    );
    let mesh_first = g.upload("object mesh starts", inp.mesh_first);
    let unused;
    let mesh_sphere = match inp.mesh_sphere {
        Some(b) => b,
        None => {
            unused = g.storage("unused", 16);
            &unused
        }
    };
    ex.run(
        launch::ObjFinish {
            o_tbox: &tbox,
            o_bounds: &bounds,
            o_tri_mesh: inp.tri_mesh,
            o_order: &order,
            o_child: &tree.child,
            o_range: &tree.range,
            o_nbox: &tree.exact,
            o_node: &tree.node,
            o_child_box: &tree.child_box,
            o_mesh_sphere: mesh_sphere,
            o_mesh_first: &mesh_first,
        },
        np,
        inner,
        256,
    );
    tree.order = order;
    if !inp.single {
        return tree;
    }
    positions(ex, &tree);
    ex.run(
        launch::ObjBoxNodes {
            o_child: &tree.child,
            o_range: &tree.range,
            o_node: &tree.node,
            o_leaf: &tree.leaf,
            o_pos: &pos,
            o_boxes: &tree.boxes,
        },
        np,
        inner,
        256,
    );
    tree
}

fn bounds_of(w: &[[f32; 4]]) -> Bounds {
    let v = |a: [f32; 4]| Vec3::new(a[0], a[1], a[2]);
    Bounds {
        sphere: Sphere::new(v(w[0]), w[0][3]),
        bbox: Aabb::new(v(w[1]), v(w[2])),
    }
}

/// The device's box nodes (stored at their binary node's index) as the CPU numbers them:
/// the root's first, then level by level, each level's in the order their references appear
/// (lane order within node order), references rewritten to those numbers and leaf lanes to
/// the box order's positions ([`accel::bvh::objects::number_level`], as
/// `rsh::objects::boxes::collapse_boxes`). Also returns, per box-order position, the binary
/// leaf position it came from.
fn box_nodes(words: &[u32]) -> (Vec<BoxNode>, Vec<u32>) {
    let w = BOX_WORDS as usize;
    let mut out = Vec::new();
    let mut src = Vec::new();
    let mut heads = vec![0u32];
    if words.is_empty() {
        return (out, src);
    }
    let mut at = 0u32;
    while !heads.is_empty() {
        let base = out.len();
        for &h in &heads {
            let r = &words[h as usize * w..(h as usize + 1) * w];
            let f = |i: usize| f32::from_bits(r[i]);
            out.push(BoxNode {
                min: std::array::from_fn(|k| std::array::from_fn(|i| f(8 * k + i))),
                max: std::array::from_fn(|k| std::array::from_fn(|i| f(24 + 8 * k + i))),
                child: std::array::from_fn(|i| r[48 + i]),
                count: r[56],
                leaves: r[57],
                ntri: std::array::from_fn(|i| (r[58] >> (4 * i) & 15) as u8),
            });
        }
        let next = out.len() as u32;
        accel::bvh::objects::number_level(&mut out[base..], next, &mut heads, &mut at, |lo, k| {
            src.extend(lo..lo + k)
        });
    }
    (out, src)
}

impl DeviceTree {
    /// The tree read back as the CPU's [`ObjectTree`] (its root, children, ranges, depth,
    /// leaf order, bounds, the single-ray path's box nodes and triangles; the dual
    /// traversal's collapsed nodes left empty). For tests and tools; a tree built without
    /// [`TreeInput::single`] has no box nodes to read.
    pub fn read(&self, ex: &mut Exec) -> ObjectTree {
        let n = self.leaves as usize;
        let inner = n.saturating_sub(1);
        let leaf: Vec<[f32; 4]> = ex.read(&self.leaf, 3 * n);
        let mut t = ObjectTree {
            root: if n < 2 { LEAF } else { 0 },
            leaf: leaf.chunks(3).map(bounds_of).collect(),
            ..Default::default()
        };
        if n < 2 {
            // (The device keeps the lone triangle in `leaf_tris`; the CPU reads the scene's.)
            return t;
        }
        // (The triangles in binary leaf order: laid out by box node below.)
        let lt: Vec<[f32; 4]> = ex.read(&self.leaf_tris, 3 * n);
        let v3 = |a: &[f32]| Vec3::new(a[0], a[1], a[2]);
        t.child = ex.read(&self.child, inner);
        t.range = ex.read(&self.range, inner);
        let node: Vec<[f32; 4]> = ex.read(&self.node, 3 * inner);
        t.node = node.chunks(3).map(bounds_of).collect();
        let cb: Vec<[f32; 4]> = ex.read(&self.child_box, 4 * inner);
        t.child_box = cb
            .chunks(4)
            .map(|c| {
                [
                    Aabb::new(v3(&c[0]), v3(&c[1])),
                    Aabb::new(v3(&c[2]), v3(&c[3])),
                ]
            })
            .collect();
        t.tri_order = ex.read(&self.order, n);
        t.depth = ex.read::<u32>(&self.exact, 4)[3];
        let words: Vec<u32> = ex.read(&self.boxes, inner * BOX_WORDS as usize);
        let src;
        (t.boxes, src) = box_nodes(&words);
        // The triangles in the box order, from their binary leaf positions.
        t.leaf_ids = src.iter().map(|&q| t.tri_order[q as usize]).collect();
        t.leaf_tris = accel::bvh::objects::leaf_blocks(n, |p| {
            let q = src[p] as usize;
            let c = &lt[3 * q..3 * q + 3];
            [0, 1, 2].map(|k| Vec3::new(c[k][0], c[k][1], c[k][2]))
        });
        t
    }
}

/// The tree over `geo` built on `g` and read back, with the build's seconds (its kernels
/// submitted and waited for; the scene's upload and the read-back not counted). With
/// `mesh_spheres`, nodes may take their mesh's sphere, as [`accel::bvh::objects::build`]'s
/// `mesh_spheres`. For tests, benchmarks and tools; an engine keeps the tree on the device.
pub fn tree_of(g: &Gpu, geo: &Geometry, mesh_spheres: bool) -> (ObjectTree, f64) {
    let k = g.kernels();
    let mut ex = Exec::new(g, &k);
    let a = SceneArrays::of(geo);
    let (tris, spheres, tri_mesh, meshes) = (
        g.upload("triangles", &a.tris),
        g.upload("triangle spheres", &a.spheres),
        g.upload("triangle meshes", &a.tri_mesh),
        g.upload("mesh spheres", &a.meshes),
    );
    ex.finish();
    let t0 = Instant::now();
    let inp = TreeInput {
        tris: &tris,
        tri_sphere: &spheres,
        tri_mesh: &tri_mesh,
        mesh_sphere: mesh_spheres.then_some(&meshes),
        mesh_first: &geo.mesh_first,
        single: true,
    };
    let d = build(&mut ex, &inp, geo.tris.len() as u32);
    ex.finish();
    let secs = t0.elapsed().as_secs_f64();
    (d.read(&mut ex), secs)
}
