//! The loaders on real, animated and hostile files: one test binary, a module per concern.

mod aff;
mod hostile;
mod real_scenes;
mod toml_animation;
