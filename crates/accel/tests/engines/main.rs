//! The irregular grid and the peers against brute force: one test binary.

mod grid;
mod peers;
