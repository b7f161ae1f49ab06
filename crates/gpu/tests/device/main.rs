//! The GPU backend against the CPU, on lavapipe or a real device: one test binary, a module per
//! pass family (CRSH/RAH agreement, whole frames, the grid's traversal and build, the
//! primitives, the rasterizer and stages).

mod agreement;
mod common;
mod dual;
mod frame;
mod grid;
mod grid_build;
mod objects;
mod primitives;
mod raster;
mod single;
