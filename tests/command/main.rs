//! The `rayspace` command line as a user runs it (the binary, its report and its viewer): one
//! test binary.

mod cli;
mod first_hour;
mod paths;
mod readme;
mod report;
mod scale;
mod view;
