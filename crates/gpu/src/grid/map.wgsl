// The voxel map's entry layout and lookup (accel/src/grid/voxelmap.rs, `Grid::lookup`),
// shared by the kernels that look voxels up (traverse, merge, expand): each module defines
// `map_entry(i)`, the map binding it reads, and passes its parameters' shift (of a voxel
// coordinate to its top cell) and top-grid dimensions.

// An entry is a cell, or NODE | log2 of the block's resolution << 27 | first.
const NODE: u32 = 0x80000000u;
const LOG_DIM_SHIFT: u32 = 28u; // voxelmap::LOG_DIM_SHIFT
const INDEX: u32 = 0x0fffffffu; // voxelmap::INDEX

// The top cell's entry, then one entry per block below it.
fn lookup(v: vec3<u32>, shift: u32, td: vec3<u32>) -> u32 {
    var s = shift;
    let t = v >> vec3<u32>(s);
    var e = map_entry(t.x + td.x * (t.y + td.y * t.z));
    while (e & NODE) != 0u {
        let k = (e >> LOG_DIM_SHIFT) & 0x7u; // voxelmap::LOG_DIM_MASK
        s -= k;
        let m = (1u << k) - 1u;
        let i = ((v.x >> s) & m) | (((v.y >> s) & m) << k) | (((v.z >> s) & m) << (2u * k));
        e = map_entry((e & INDEX) + i);
    }
    return e;
}
