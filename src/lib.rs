//! rayspace as a library: the engine registry ([`engines`]) and the papers' evaluations
//! ([`bench`](mod@bench)), shared by the `rayspace` command line and the bindings.

pub mod bench;
pub mod engines;
