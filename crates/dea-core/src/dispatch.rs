//! The one place where a kernel is entered in a compilation for the processor's instruction
//! set (design rule "one dispatch", docs/performance.md): [`Compilation`] says which
//! instruction sets this processor runs, [`in_compilation`] runs a kernel compiled for one,
//! and [`prefetch`] is the memory hint the sweeps use. Every compilation of a kernel gives
//! the same bits; the tests of each kernel run every compilation the processor has.

/// Asks the memory system for the value at `index` of the array at `base` (a hint: no
/// effect on any result).
#[inline(always)]
pub fn prefetch<T>(base: *const T, index: usize) {
    // SAFETY: a prefetch reads nothing and cannot fault at any address, so the index is not
    // checked against the array here (the value's load, if any, is)
    #[cfg(target_arch = "x86_64")]
    unsafe {
        std::arch::x86_64::_mm_prefetch::<{ std::arch::x86_64::_MM_HINT_T0 }>(base.wrapping_add(index).cast())
    };
}

/// The instruction sets a kernel is compiled for. Each runs the same source, so the same
/// operations in the same order (Rust never fuses a multiply–add): the same bits.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Compilation {
    /// the target's baseline instruction set (SSE2 on x86-64)
    Baseline,
    /// VEX's three operands spare SSE's register copies: 11 % fewer instructions in the
    /// fibre-contact sweep on the bench yarn
    Avx2,
    /// AVX-512's 32 vector registers spare most of the sweep's spills: about 5 % less time
    /// on the bench yarn
    Avx512,
}

impl Compilation {
    /// Whether this processor runs it (std caches the answers).
    pub fn runs(self) -> bool {
        #[cfg(target_arch = "x86_64")]
        return match self {
            Self::Baseline => true,
            Self::Avx2 => crate::lanes::available(),
            Self::Avx512 => crate::lanes::available() && is_x86_feature_detected!("avx512f"),
        };
        #[cfg(not(target_arch = "x86_64"))]
        return self == Self::Baseline;
    }

    /// The widest compilation this processor runs.
    pub fn widest() -> Self {
        [Self::Avx512, Self::Avx2].into_iter().find(|c| c.runs()).unwrap_or(Self::Baseline)
    }
}

/// Runs `kernel` compiled for `compilation`, which the processor must run: the kernel, an
/// `#[inline(always)]` closure (a plain one is not inlined, and runs the baseline
/// compilation), is inlined into a function of that compilation's target features. A kernel
/// takes the arrays it loops over apart into slices at its start: read through the captured
/// references, the fibre-contact sweep's lists cost 139 instructions per touching entry
/// against 133 (design rule "kernels take their arrays apart", docs/performance.md).
#[inline(always)]
pub fn in_compilation<R>(compilation: Compilation, kernel: impl FnOnce() -> R) -> R {
    #[cfg(target_arch = "x86_64")]
    match compilation {
        Compilation::Avx2 => {
            #[target_feature(enable = "avx2")]
            fn avx2<R>(kernel: impl FnOnce() -> R) -> R {
                kernel()
            }
            // SAFETY: the caller has checked that the processor runs AVX2
            return unsafe { avx2(kernel) };
        }
        Compilation::Avx512 => {
            #[target_feature(enable = "avx2,avx512f")]
            fn avx512<R>(kernel: impl FnOnce() -> R) -> R {
                kernel()
            }
            // SAFETY: the caller has checked that the processor runs AVX2 and AVX-512F
            return unsafe { avx512(kernel) };
        }
        Compilation::Baseline => {}
    }
    #[cfg(not(target_arch = "x86_64"))]
    let _ = compilation;
    kernel()
}

impl Compilation {
    /// Every compilation this processor runs, narrowest first (for tests that compare them).
    pub fn all_that_run() -> Vec<Self> {
        [Self::Baseline, Self::Avx2, Self::Avx512].into_iter().filter(|c| c.runs()).collect()
    }
}

/// Runs `$kernel`, a call of a kernel in AVX2 lanes (a `#[target_feature(enable = "avx2")]`
/// function of [`crate::lanes`]' types), when this processor runs AVX2: `Some` of what it
/// returns, else `None`, and the caller's scalar code does the work. With [`in_compilation`],
/// the one place a kernel compiled for the processor is entered.
#[macro_export]
macro_rules! in_avx2_lanes {
    ($kernel:expr) => {{
        #[cfg(target_arch = "x86_64")]
        let result = if $crate::dispatch::Compilation::Avx2.runs() {
            // SAFETY: the processor runs AVX2, the only target feature of the lanes' kernels
            #[allow(clippy::macro_metavars_in_unsafe)]
            Some(unsafe { $kernel })
        } else {
            None
        };
        #[cfg(not(target_arch = "x86_64"))]
        let result = None;
        result
    }};
}
