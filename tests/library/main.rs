//! The library's renders: determinism, generated scenes, the rasterizer against traced primaries, real scenes:
//! one test binary.

mod determinism;
mod generated;
mod raster_agreement;
mod real_scenes;
mod roster;
