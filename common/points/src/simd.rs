//! Run-time choice of instruction set for the vectorised kernels.
//!
//! The workspace builds for baseline x86-64 (SSE2). The hot loops are written as plain
//! element-wise loops that the compiler vectorises; [`avx2_dispatch!`] compiles such a
//! function twice, once with AVX2 enabled (twice the lanes), and picks that copy when the
//! CPU has AVX2. Results are identical: the integer arithmetic is the same, only the
//! register width changes.

/// Defines `fn $name(args) -> ret { body }` that runs an AVX2-compiled copy of `body`
/// when the CPU supports AVX2, the baseline copy otherwise.
macro_rules! avx2_dispatch {
    ($(#[$meta:meta])* $vis:vis fn $name:ident($($arg:ident : $ty:ty),* $(,)?) $(-> $ret:ty)? $body:block) => {
        $(#[$meta])*
        $vis fn $name($($arg: $ty),*) $(-> $ret)? {
            #[cfg(target_arch = "x86_64")]
            {
                #[target_feature(enable = "avx2")]
                fn avx2($($arg: $ty),*) $(-> $ret)? $body
                if std::arch::is_x86_feature_detected!("avx2") {
                    // SAFETY: the CPU supports AVX2, checked just above.
                    return unsafe { avx2($($arg),*) };
                }
            }
            $body
        }
    };
}

pub(crate) use avx2_dispatch;
