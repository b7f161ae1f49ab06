//! Which instruction set a kernel with several builds runs: the scalar source, or the same
//! source compiled for AVX2 or AVX-512 (`#[target_feature]`), chosen at run time. Every
//! build computes the same IEEE operations in the same order (Rust never fuses a multiply
//! and an add on its own), so all of them give the same bits; each kernel's tests compare
//! them.

/// A build of a multi-versioned kernel.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Isa {
    /// The portable build (x86-64's baseline SSE2, or any other target).
    Scalar,
    /// Compiled for AVX2 (and POPCNT): 8 lanes of f32 per vector.
    Avx2,
    /// Compiled for AVX-512 (F, VL) on top of AVX2: 16 lanes and 32 vector registers.
    Avx512,
}

impl Isa {
    /// The widest this CPU runs.
    pub fn best() -> Isa {
        #[cfg(target_arch = "x86_64")]
        {
            use std::arch::is_x86_feature_detected as has;
            if has!("avx512f") && has!("avx512vl") && has!("avx2") && has!("popcnt") {
                return Isa::Avx512;
            }
            if has!("avx2") && has!("popcnt") {
                return Isa::Avx2;
            }
        }
        Isa::Scalar
    }

    /// Whether this CPU runs it.
    pub fn available(self) -> bool {
        matches!(
            (self, Isa::best()),
            (Isa::Scalar, _) | (Isa::Avx2, Isa::Avx2 | Isa::Avx512) | (Isa::Avx512, Isa::Avx512)
        )
    }

    /// The builds this CPU runs, narrowest first (what the bit-for-bit tests compare).
    pub fn all_available() -> Vec<Isa> {
        [Isa::Scalar, Isa::Avx2, Isa::Avx512]
            .into_iter()
            .filter(|i| i.available())
            .collect()
    }
}

/// For tests that compare every build with the scalar one (`what` names the test): the
/// builds this CPU runs. A build it lacks is a comparison that did not happen: said on
/// stderr as `SKIPPED: why`, or, where `RAYSPACE_REQUIRE` lists it (`avx2`, `avx512`; CI
/// sets it from the CPU), a panic. This is `testkit::skip`'s rule, for the crates below
/// `testkit` (which depends on them).
#[doc(hidden)]
pub fn builds_for_tests(what: &str) -> Vec<Isa> {
    for (isa, need) in [(Isa::Avx2, "avx2"), (Isa::Avx512, "avx512")] {
        if isa.available() {
            continue;
        }
        let required = std::env::var("RAYSPACE_REQUIRE")
            .unwrap_or_default()
            .split(',')
            .any(|r| r.trim() == need || r.trim() == "all");
        let why = format!("{what}: this CPU lacks {isa:?}, so that build is not compared");
        if required {
            panic!("RAYSPACE_REQUIRE lists '{need}', but this test cannot run: {why}");
        }
        eprintln!("SKIPPED: {why}");
    }
    Isa::all_available()
}
