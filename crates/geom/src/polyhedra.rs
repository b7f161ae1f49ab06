//! Regular polyhedra as index tables, shared by the tessellators (`scene::shapes`) and the
//! tests that need a closed mesh.

use crate::Vec3;

/// The icosahedron with vertices (0, ±1, ±φ) and its cyclic permutations (φ the golden
/// ratio, so the vertices lie on a sphere of radius √(1 + φ²), not normalized), and its 20
/// faces, counter-clockwise seen from outside.
pub fn icosahedron() -> ([Vec3; 12], [[u32; 3]; 20]) {
    let t = (1.0 + 5.0f32.sqrt()) / 2.0;
    let v = [
        (-1.0, t, 0.0),
        (1.0, t, 0.0),
        (-1.0, -t, 0.0),
        (1.0, -t, 0.0),
        (0.0, -1.0, t),
        (0.0, 1.0, t),
        (0.0, -1.0, -t),
        (0.0, 1.0, -t),
        (t, 0.0, -1.0),
        (t, 0.0, 1.0),
        (-t, 0.0, -1.0),
        (-t, 0.0, 1.0),
    ]
    .map(|(x, y, z)| Vec3::new(x, y, z));
    let f = [
        [0, 11, 5],
        [0, 5, 1],
        [0, 1, 7],
        [0, 7, 10],
        [0, 10, 11],
        [1, 5, 9],
        [5, 11, 4],
        [11, 10, 2],
        [10, 7, 6],
        [7, 1, 8],
        [3, 9, 4],
        [3, 4, 2],
        [3, 2, 6],
        [3, 6, 8],
        [3, 8, 9],
        [4, 9, 5],
        [2, 4, 11],
        [6, 2, 10],
        [8, 6, 7],
        [9, 8, 1],
    ];
    (v, f)
}
