//! `rayspace view`: an interactive window on a scene. Every frame is the renderer's own:
//! the rasterized G-buffer (thesis §3.1), secondary rays traced by the chosen engine and
//! backend, Blinn-Phong shading; keys switch the engine, the backend, the bounces and the
//! buffer shown (shaded, normals, ray kinds, tests per pixel), play and scrub BART
//! animations (rebuilding the engine every frame, as the papers' dynamic scenes do), and an
//! overlay shows the frame and phase times, tests and % of brute force.
//!
//! [`session`] is the state and the frame without a window (tested headless);
//! [`window`] is winit + wgpu around it; [`overlay`] draws the text.

pub mod overlay;
pub mod session;
pub mod window;
