//! The object-tree walk, the irregular grid and the peers against brute force: one test
//! binary.

mod bvh;
mod grid;
mod peers;
