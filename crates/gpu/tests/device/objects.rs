//! The object tree built on the device (`gpu::bvh::objects`) against the CPU's LBVH
//! (`accel::bvh::objects::build` with `ObjectBuilder::Lbvh`): every array bit for bit, on the
//! built-in scenes, random soups (with and without the mesh spheres), a scene of one and of
//! two triangles, and the shared real scenes; the single-ray path's box nodes and triangles
//! in leaf order included.

use accel::bvh::objects::{build, Bounds, BoxNode, ObjectTree, Parts};
use accel::bvh::ObjectBuilder;
use geom::{Aabb, Vec3};
use gpu::Gpu;
use scene::{builtin, Geometry};

fn gpu() -> Option<Gpu> {
    testkit::or_skip(Gpu::new(), "gpu")
}

fn vbits(v: Vec3) -> [u32; 3] {
    [v.x.to_bits(), v.y.to_bits(), v.z.to_bits()]
}

fn box_bits(b: &Aabb) -> [[u32; 3]; 2] {
    [vbits(b.min), vbits(b.max)]
}

fn bounds_bits(b: &Bounds) -> ([u32; 3], u32, [[u32; 3]; 2]) {
    (
        vbits(b.sphere.center),
        b.sphere.radius.to_bits(),
        box_bits(&b.bbox),
    )
}

/// Every array the device builds, compared with the CPU's, naming the first difference.
fn same(what: &str, cpu: &ObjectTree, dev: &ObjectTree) {
    assert_eq!(cpu.root, dev.root, "{what}: root");
    assert_eq!(cpu.tri_order, dev.tri_order, "{what}: leaf order");
    assert_eq!(cpu.child, dev.child, "{what}: children");
    assert_eq!(cpu.range, dev.range, "{what}: ranges");
    assert_eq!(cpu.depth, dev.depth, "{what}: depth");
    assert_eq!(cpu.leaf.len(), dev.leaf.len(), "{what}: leaves");
    for (i, (a, b)) in cpu.leaf.iter().zip(&dev.leaf).enumerate() {
        assert_eq!(bounds_bits(a), bounds_bits(b), "{what}: leaf {i}");
    }
    assert_eq!(cpu.node.len(), dev.node.len(), "{what}: nodes");
    for (i, (a, b)) in cpu.node.iter().zip(&dev.node).enumerate() {
        assert_eq!(bounds_bits(a), bounds_bits(b), "{what}: node {i}");
    }
    for (i, (a, b)) in cpu.child_box.iter().zip(&dev.child_box).enumerate() {
        assert_eq!(
            box_bits(&a[0]),
            box_bits(&b[0]),
            "{what}: node {i}'s left box"
        );
        assert_eq!(
            box_bits(&a[1]),
            box_bits(&b[1]),
            "{what}: node {i}'s right box"
        );
    }
    // The single-ray path's records.
    let tri_bits = |t: &[Vec3; 3]| t.map(vbits);
    assert_eq!(
        (0..cpu.tri_order.len())
            .map(|p| tri_bits(&cpu.leaf_tri(p)))
            .collect::<Vec<_>>(),
        (0..dev.tri_order.len())
            .map(|p| tri_bits(&dev.leaf_tri(p)))
            .collect::<Vec<_>>(),
        "{what}: triangles in leaf order"
    );
    assert_eq!(cpu.boxes.len(), dev.boxes.len(), "{what}: box nodes");
    for (i, (a, b)) in cpu.boxes.iter().zip(&dev.boxes).enumerate() {
        let lanes = |n: &BoxNode| {
            (
                n.min.map(|k| k.map(f32::to_bits)),
                n.max.map(|k| k.map(f32::to_bits)),
                n.child,
                n.count,
                n.leaves,
                n.ntri,
            )
        };
        assert_eq!(lanes(a), lanes(b), "{what}: box node {i}");
    }
}

fn check(g: &Gpu, what: &str, geo: &Geometry) {
    let parts = Parts::ALL;
    for mesh_spheres in [true, false] {
        let ms = mesh_spheres.then_some(&geo.mesh_sphere[..]);
        let cpu = build(&geo.tris, &geo.mesh_first, ms, ObjectBuilder::Lbvh, parts);
        let (dev, _) = gpu::bvh::objects::tree_of(g, geo, mesh_spheres);
        same(&format!("{what} (mesh spheres {mesh_spheres})"), &cpu, &dev);
    }
}

#[test]
fn device_lbvh_is_the_cpus() {
    let Some(g) = gpu() else { return };
    for name in builtin::NAMES {
        let geo = Geometry::from_scene(&builtin::by_name(name).unwrap());
        check(&g, name, &geo);
    }
    // Many triangles and meshes (keys of more than 32 bits), and duplicate keys.
    for (n, seed) in [(20_000, 1), (3_000, 7)] {
        check(
            &g,
            &format!("soup {n}"),
            &Geometry::from_scene(&builtin::soup(n, seed)),
        );
    }
    // One triangle (a leaf root) and two (one inner node).
    let mut geo = Geometry::from_scene(&builtin::by_name("cornell").unwrap());
    for n in [2usize, 1] {
        geo.tris.truncate(n);
        geo.mesh_first = vec![0, n as u32];
        geo.mesh_sphere.truncate(1);
        check(&g, &format!("{n} triangles"), &geo);
    }
}

#[test]
fn device_lbvh_on_real_scenes() {
    let Some(dir) = testkit::scenes() else { return };
    let Some(g) = gpu() else { return };
    for rel in ["dabrovic-sponza/sponza.obj", "bart-kitchen/aff/kitchen.aff"] {
        let path = dir.join(rel);
        if !path.exists() {
            testkit::skip("scenes", format!("{} not present", path.display()));
            return;
        }
        let s = scene::load(path.to_str().unwrap(), &Default::default()).unwrap();
        check(&g, rel, &Geometry::from_scene(&s));
    }
}
