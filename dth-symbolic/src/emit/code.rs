//! `f64` values as code: constants, and the divided-difference kernels. [`crate::kernel`]
//! writes each kernel's formula once over a `Scalar`; `Code` is the `Scalar` whose
//! operations are Rust expressions, so the generated code performs the interpreter's `f64`
//! operations in the same order.

use std::ops::{Add, Div, Mul, Neg, Sub};

use proc_macro2::{Ident, Literal, TokenStream};
use quote::{format_ident, quote};

use crate::kernel::{Compare, Math, Scalar};
use crate::Kernel;

/// `k(x, y)` inline, for the locals `x` and `y`.
pub fn kernel(k: Kernel, x: &Ident, y: &Ident) -> TokenStream {
    k.build(Code::atom(quote!(#x)), Code::atom(quote!(#y)))
        .tokens
}

/// An `f64` literal; negative values as a negated literal. The engine folds no constant to
/// infinity or NaN (an overflow is a spanned error there), but should one reach this point it
/// is written as the named constant: `Literal::f64_suffixed` would panic the macro.
pub fn constant(c: f64) -> TokenStream {
    if c.is_nan() {
        return quote!(::core::primitive::f64::NAN);
    }
    if c.is_infinite() {
        return if c > 0.0 {
            quote!(::core::primitive::f64::INFINITY)
        } else {
            quote!(::core::primitive::f64::NEG_INFINITY)
        };
    }
    let lit = Literal::f64_suffixed(c.abs());
    if c.is_sign_negative() {
        quote!(-#lit)
    } else {
        quote!(#lit)
    }
}

/// An `f64` expression.
#[derive(Clone)]
struct Code {
    tokens: TokenStream,
    /// Whether it needs parentheses as an operand (an operator, `if` or block at the top).
    compound: bool,
}

impl Code {
    fn atom(tokens: TokenStream) -> Code {
        Code {
            tokens,
            compound: false,
        }
    }

    fn compound(tokens: TokenStream) -> Code {
        Code {
            tokens,
            compound: true,
        }
    }

    /// The tokens, parenthesized if needed, for use as an operand.
    fn operand(&self) -> TokenStream {
        let t = &self.tokens;
        if self.compound {
            quote!((#t))
        } else {
            quote!(#t)
        }
    }
}

/// `impl std::ops::Op for Code`, writing `a op b`.
macro_rules! operator {
    ($($trait:ident $method:ident $op:tt),*) => {$(
        impl $trait for Code {
            type Output = Code;
            fn $method(self, other: Code) -> Code {
                let (a, b) = (self.operand(), other.operand());
                Code::compound(quote!(#a $op #b))
            }
        }
    )*};
}

operator!(Add add +, Sub sub -, Mul mul *, Div div /);

impl Neg for Code {
    type Output = Code;
    fn neg(self) -> Code {
        let a = self.operand();
        Code::compound(quote!(-#a))
    }
}

impl Scalar for Code {
    type Condition = TokenStream;

    fn constant(c: f64) -> Code {
        let lit = constant(c);
        if c.is_sign_negative() && c.is_finite() {
            Code::compound(lit)
        } else {
            Code::atom(lit)
        }
    }

    fn call(f: Math, [x, y]: [Code; 2]) -> Code {
        let name = format_ident!("{}", f.name());
        let x = &x.tokens;
        let args = match f {
            Math::Atan2 | Math::Max => {
                let y = &y.tokens;
                quote!(#x, #y)
            }
            _ => quote!(#x),
        };
        Code::atom(quote!(::core::primitive::f64::#name(#args)))
    }

    fn compare(self, op: Compare, other: Code) -> TokenStream {
        let (a, b) = (self.operand(), other.operand());
        match op {
            Compare::Eq => quote!(#a == #b),
            Compare::Lt => quote!(#a < #b),
            Compare::Le => quote!(#a <= #b),
            Compare::Gt => quote!(#a > #b),
        }
    }

    fn and(a: TokenStream, b: TokenStream) -> TokenStream {
        quote!(#a && #b)
    }

    fn select(
        condition: TokenStream,
        then: impl FnOnce() -> Code,
        otherwise: impl FnOnce() -> Code,
    ) -> Code {
        let (a, b) = (then().tokens, otherwise().tokens);
        Code::compound(quote!(if #condition { #a } else { #b }))
    }

    fn share(self, name: &'static str, body: impl FnOnce(Code) -> Code) -> Code {
        let name = format_ident!("{}", name);
        let value = &self.tokens;
        let body = body(Code::atom(quote!(#name))).tokens;
        Code::compound(quote! {{
            let #name: f64 = #value;
            #body
        }})
    }
}
