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

/// Run the kernel `$kernel` (an `#[inline(always)]` function written as branch-free lane
/// loops) in the build `$isa` names: the macro declares the kernel's AVX-512 and AVX2
/// builds (`#[target_feature]` wrappers with the parameters as listed) and calls the one
/// asked for, or the portable build. It asserts that the CPU runs that build, which is what
/// makes calling a `target_feature` function sound.
///
/// ```ignore
/// geom::dispatch_isa!(isa, group(s: &Surfaces, first: usize, out: &mut [Vec3]))
/// geom::dispatch_isa!(isa, cull(view: &View, tris: &[[Vec3; 3]]) -> Verdicts)
/// ```
#[macro_export]
macro_rules! dispatch_isa {
    ($isa:expr, $kernel:ident($($arg:ident: $ty:ty),* $(,)?) $(-> $ret:ty)?) => {{
        let isa: $crate::Isa = $isa;
        assert!(isa.available(), "{isa:?} on this CPU");
        #[cfg(target_arch = "x86_64")]
        #[target_feature(enable = "avx512f,avx512vl,avx2,popcnt")]
        unsafe fn avx512($($arg: $ty),*) $(-> $ret)? {
            $kernel($($arg),*)
        }
        #[cfg(target_arch = "x86_64")]
        #[target_feature(enable = "avx2,popcnt")]
        unsafe fn avx2($($arg: $ty),*) $(-> $ret)? {
            $kernel($($arg),*)
        }
        match isa {
            #[cfg(target_arch = "x86_64")]
            // SAFETY: asserted above: the CPU has AVX-512 F and VL, AVX2 and POPCNT.
            $crate::Isa::Avx512 => unsafe { avx512($($arg),*) },
            #[cfg(target_arch = "x86_64")]
            // SAFETY: asserted above: the CPU has AVX2 and POPCNT.
            $crate::Isa::Avx2 => unsafe { avx2($($arg),*) },
            _ => $kernel($($arg),*),
        }
    }};
}
