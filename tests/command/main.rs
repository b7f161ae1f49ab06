//! The `rayspace` command line as a user runs it (the binary, its report and its viewer): one
//! test binary.

mod bench;
mod cli;
mod common;
mod engines;
mod examples;
mod first_hour;
mod gpu;
mod hostile;
mod looks;
mod paths;
mod rays;
mod readme;
mod report;
mod scale;
mod view;
