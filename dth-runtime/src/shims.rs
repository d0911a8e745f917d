//! The functions compiled code calls: `extern "C"` wrappers of the very Rust functions the
//! interpreter calls (`Func::apply`, `f64::powf`, `Kernel::apply`), so a call in compiled code
//! returns the interpreter's bits.
//!
//! Square roots and arithmetic are instructions (correctly rounded, like Rust's); everything
//! transcendental comes through here.

use dth_symbolic::{Func, Kernel};

/// The symbol and address of the shim of `f`.
pub fn func(f: Func) -> (&'static str, *const u8) {
    macro_rules! shim {
        ($name:literal, $f:expr) => {{
            extern "C" fn call(x: f64) -> f64 {
                $f.apply(x)
            }
            ($name, call as extern "C" fn(f64) -> f64 as *const u8)
        }};
    }
    match f {
        Func::Sin => shim!("dth_sin", Func::Sin),
        Func::Cos => shim!("dth_cos", Func::Cos),
        Func::Tan => shim!("dth_tan", Func::Tan),
        Func::Exp => shim!("dth_exp", Func::Exp),
        Func::Ln => shim!("dth_ln", Func::Ln),
        Func::Sinh => shim!("dth_sinh", Func::Sinh),
        Func::Cosh => shim!("dth_cosh", Func::Cosh),
        Func::Tanh => shim!("dth_tanh", Func::Tanh),
        Func::Atan => shim!("dth_atan", Func::Atan),
    }
}

/// `x.powf(e)`.
extern "C" fn powf(x: f64, e: f64) -> f64 {
    x.powf(e)
}

/// The symbol and address of the `powf` shim, `(x, e) -> x^e`.
pub fn pow() -> (&'static str, *const u8) {
    (
        "dth_powf",
        powf as extern "C" fn(f64, f64) -> f64 as *const u8,
    )
}

/// `kernel.apply(x, y)` for the kernel at address `kernel`.
///
/// # Safety
///
/// `kernel` is the address of a live [`Kernel`]: compiled code passes the address of one
/// held by the code's owner ([`crate::jit::Code`]), which outlives the code.
unsafe extern "C" fn kernel(kernel: usize, x: f64, y: f64) -> f64 {
    // SAFETY: see the function's contract.
    let k = unsafe { &*(kernel as *const Kernel) };
    k.apply(x, y)
}

/// The symbol and address of the kernel shim, `(address of a Kernel, x, y) -> k(x, y)`.
pub fn kernels() -> (&'static str, *const u8) {
    (
        "dth_kernel",
        kernel as unsafe extern "C" fn(usize, f64, f64) -> f64 as *const u8,
    )
}
