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
