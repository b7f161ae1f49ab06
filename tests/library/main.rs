//! The library's renders: determinism, the rasterizer against traced primaries, real scenes:
//! one test binary.

mod determinism;
mod raster_agreement;
mod real_scenes;
