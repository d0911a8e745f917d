//! Emits `impl Hamiltonian<D>`: one straight-line function per trait method, plain `f64`
//! arithmetic on locals, fixed-size nalgebra types through `::dth::__private`.

use dth_symbolic::{defect, Kernel, Method, Op, Output, Program, System};
use proc_macro2::{Literal, TokenStream};
use quote::{format_ident, quote};
use syn::Ident;

use crate::check;
use crate::fallback;
use crate::parse::Input;

/// The expansion of the whole macro: the implementation, or the errors and a stub.
pub fn expand(input: Input) -> TokenStream {
    let mut errors = input.body.errors.clone();
    let params = check::params(&input, &mut errors);
    let system = check::system(&input, &params, &mut errors);
    match (check::combine(errors), system) {
        (None, Some(system)) => implementation(&input, &params, &system),
        (error, _) => fallback::stub(&input, error.map(|e| e.to_compile_error())),
    }
}

/// The type declaration and its implementation.
fn implementation(input: &Input, params: &[Ident], system: &System) -> TokenStream {
    let (decl, name) = fallback::declaration(input, params);
    let imp = imp(&name, params, system);
    match &input.item {
        Some(_) => quote! {
            #decl
            const _: () = { #imp };
        },
        None => quote! {{
            #decl
            #imp
            #name
        }},
    }
}

fn imp(name: &Ident, params: &[Ident], system: &System) -> TokenStream {
    let d = system.dim();
    let nalgebra = quote!(::dth::__private::nalgebra);
    let core = quote!(::dth::__private::dth_core);
    let (td, sep, psi0) = (
        system.time_dependent(),
        system.separable(),
        system.psi_identically_zero(),
    );
    let value = body(&system.program(Method::Value), params, |v| {
        let v = &v.value;
        quote!(#v)
    });
    let gradient = body(&system.program(Method::Gradient), params, |v| v.gradient(d));
    let hessian = body(&system.program(Method::Hessian), params, |v| v.hessian(d));
    let psi = body(&system.program(Method::Psi), params, |v| {
        let v = &v.psi;
        quote!(#v)
    });
    let all = body(&system.program(Method::All), params, |v| {
        let (g, h, value, psi) = (v.gradient(d), v.hessian(d), &v.value, &v.psi);
        quote!(#core::Derivatives { value: #value, gradient: #g, hessian: #h, psi: #psi })
    });
    // One two-point program, each method keeping only the operations its outputs reach.
    let pair = system.program(Method::DiscreteGradient);
    let gbar = pair.prune(|o| matches!(o, Output::DiscreteGradient(_)));
    let discrete_gradient = body(&gbar, params, |v| v.discrete_gradient(d));
    let delta = pair.prune(|o| o == Output::EnergyDifference);
    let energy_difference = body(&delta, params, |v| {
        let v = &v.energy_difference;
        quote!(#v)
    });
    let defect = body(
        &system.program(Method::DiscreteGradientDefect),
        params,
        |v| v.discrete_gradient_defect(d),
    );
    let source = system_source(system);
    quote! {
        #[doc = #source]
        #[allow(unused_variables, clippy::all, clippy::pedantic, clippy::nursery)]
        impl #core::Hamiltonian<#d> for #name {
            const TIME_DEPENDENT: bool = #td;
            const SEPARABLE: bool = #sep;
            const PSI_IDENTICALLY_ZERO: bool = #psi0;
            const EXACT_DIVIDED_DIFFERENCES: bool = true;

            #[inline]
            fn value(&self, z: &#nalgebra::SVector<f64, #d>) -> f64 { #value }
            #[inline]
            fn gradient(&self, z: &#nalgebra::SVector<f64, #d>) -> #nalgebra::SVector<f64, #d> { #gradient }
            #[inline]
            fn hessian(&self, z: &#nalgebra::SVector<f64, #d>) -> #nalgebra::SMatrix<f64, #d, #d> { #hessian }
            #[inline]
            fn psi(&self, z: &#nalgebra::SVector<f64, #d>) -> f64 { #psi }
            #[inline]
            fn derivatives(&self, z: &#nalgebra::SVector<f64, #d>) -> #core::Derivatives<#d> { #all }
            /// Exact divided differences of `H`, without cancellation (`dth_symbolic::divided`).
            #[inline]
            fn discrete_gradient(
                &self,
                z0: &#nalgebra::SVector<f64, #d>,
                z1: &#nalgebra::SVector<f64, #d>,
            ) -> #nalgebra::SVector<f64, #d> {
                let z = z0;
                #discrete_gradient
            }
            /// `H(z1) - H(z0)` by exact divided differences, without cancellation.
            #[inline]
            fn energy_difference(
                &self,
                z0: &#nalgebra::SVector<f64, #d>,
                z1: &#nalgebra::SVector<f64, #d>,
            ) -> f64 {
                let z = z0;
                #energy_difference
            }
            /// `grad H(z0) + grad H(z1) - 2 gbar(z0, z1)` without cancellation
            /// (`dth_symbolic::defect`); `gbar` is recomputed inside, not read.
            #[inline]
            fn discrete_gradient_defect(
                &self,
                z0: &#nalgebra::SVector<f64, #d>,
                z1: &#nalgebra::SVector<f64, #d>,
                gbar: &#nalgebra::SVector<f64, #d>,
            ) -> #nalgebra::SVector<f64, #d> {
                let _ = gbar;
                let z = z0;
                #defect
            }
        }
    }
}

fn system_source(system: &System) -> String {
    format!(
        " `H = {}` (D = {})",
        system.expr(system.value()),
        system.dim()
    )
}

/// The outputs of a program as expressions: a local, or `0.0` when not computed.
struct Values {
    value: TokenStream,
    psi: TokenStream,
    energy_difference: TokenStream,
    gradient: Vec<(usize, Ident)>,
    hessian: Vec<(usize, usize, Ident)>,
    discrete_gradient: Vec<(usize, Ident)>,
    discrete_gradient_defect: Vec<(usize, Ident)>,
}

/// Matrices up to this dimension are built as one column-major array literal (every entry,
/// zeros included); larger ones as `zeros()` plus a store per nonzero entry, so the emitted
/// code stays linear in the nonzeros.
const LITERAL_MAX_DIM: usize = 8;

impl Values {
    fn discrete_gradient(&self, d: usize) -> TokenStream {
        vector(d, &self.discrete_gradient)
    }

    fn discrete_gradient_defect(&self, d: usize) -> TokenStream {
        vector(d, &self.discrete_gradient_defect)
    }

    fn gradient(&self, d: usize) -> TokenStream {
        vector(d, &self.gradient)
    }

    fn hessian(&self, d: usize) -> TokenStream {
        let nalgebra = quote!(::dth::__private::nalgebra);
        if self.hessian.is_empty() {
            return quote!(#nalgebra::SMatrix::<f64, #d, #d>::zeros());
        }
        if d <= LITERAL_MAX_DIM {
            let mut entries = vec![vec![quote!(0.0f64); d]; d];
            for (i, j, v) in &self.hessian {
                entries[*j][*i] = quote!(#v);
                entries[*i][*j] = quote!(#v);
            }
            let columns = entries.iter().map(|c| quote!([#(#c),*]));
            return quote! {
                #nalgebra::SMatrix::<f64, #d, #d>::from_array_storage(
                    #nalgebra::ArrayStorage([#(#columns),*])
                )
            };
        }
        let set = self.hessian.iter().map(|(i, j, v)| {
            if i == j {
                quote!(h[(#i, #i)] = #v;)
            } else {
                quote!(h[(#i, #j)] = #v; h[(#j, #i)] = #v;)
            }
        });
        quote! {{
            let mut h = #nalgebra::SMatrix::<f64, #d, #d>::zeros();
            #(#set)*
            h
        }}
    }
}

/// A vector of dimension `d` with the entries `set` (the others zero): an array literal up to
/// [`LITERAL_MAX_DIM`], `zeros()` plus stores beyond.
fn vector(d: usize, set: &[(usize, Ident)]) -> TokenStream {
    let nalgebra = quote!(::dth::__private::nalgebra);
    if d <= LITERAL_MAX_DIM {
        let mut entries = vec![quote!(0.0f64); d];
        for (i, v) in set {
            entries[*i] = quote!(#v);
        }
        return quote! {
            #nalgebra::SVector::<f64, #d>::from_array_storage(#nalgebra::ArrayStorage([[#(#entries),*]]))
        };
    }
    let set = set.iter().map(|(i, v)| quote!(g[#i] = #v;));
    quote! {{
        let mut g = #nalgebra::SVector::<f64, #d>::zeros();
        #(#set)*
        g
    }}
}

/// `let`s for the program's operations, then `finish` of its outputs.
fn body(
    program: &Program,
    params: &[Ident],
    finish: impl Fn(&Values) -> TokenStream,
) -> TokenStream {
    let v = |s: u32| format_ident!("v{}", s);
    let lets = program.ops.iter().enumerate().map(|(i, op)| {
        let lhs = v(i as u32);
        let rhs = match *op {
            Op::Input(k) => {
                let k = k as usize;
                quote!(z[#k])
            }
            Op::Input1(k) => {
                let k = k as usize;
                quote!(z1[#k])
            }
            Op::Param(k) => {
                let p = &params[k as usize];
                quote!(self.#p)
            }
            Op::Const(c) => constant(c),
            Op::Add(a, b) => {
                let (a, b) = (v(a), v(b));
                quote!(#a + #b)
            }
            Op::Sub(a, b) => {
                let (a, b) = (v(a), v(b));
                quote!(#a - #b)
            }
            Op::Mul(a, b) => {
                let (a, b) = (v(a), v(b));
                quote!(#a * #b)
            }
            Op::Div(a, b) => {
                let (a, b) = (v(a), v(b));
                quote!(#a / #b)
            }
            Op::Neg(a) => {
                let a = v(a);
                quote!(-#a)
            }
            Op::Sqrt(a) => {
                let a = v(a);
                quote!(::core::primitive::f64::sqrt(#a))
            }
            Op::Powf(a, e) => {
                let (a, e) = (v(a), constant(e));
                quote!(::core::primitive::f64::powf(#a, #e))
            }
            Op::Call(f, a) => {
                let (a, f) = (v(a), format_ident!("{}", f.name()));
                quote!(::core::primitive::f64::#f(#a))
            }
            Op::Kernel(k, a, b) => kernel(k, &v(a), &v(b)),
        };
        quote!(let #lhs: f64 = #rhs;)
    });
    let zero = quote!(0.0f64);
    let mut values = Values {
        value: zero.clone(),
        psi: zero.clone(),
        energy_difference: zero,
        gradient: Vec::new(),
        hessian: Vec::new(),
        discrete_gradient: Vec::new(),
        discrete_gradient_defect: Vec::new(),
    };
    for &(out, s) in &program.outputs {
        match out {
            Output::Value => {
                let s = v(s);
                values.value = quote!(#s);
            }
            Output::Psi => {
                let s = v(s);
                values.psi = quote!(#s);
            }
            Output::Gradient(i) => values.gradient.push((i, v(s))),
            Output::Hessian(i, j) => values.hessian.push((i, j, v(s))),
            Output::DiscreteGradient(i) => values.discrete_gradient.push((i, v(s))),
            Output::DiscreteGradientDefect(i) => {
                values.discrete_gradient_defect.push((i, v(s)));
            }
            Output::EnergyDifference => {
                let s = v(s);
                values.energy_difference = quote!(#s);
            }
        }
    }
    let out = finish(&values);
    quote! {
        let _ = z;
        #(#lets)*
        #out
    }
}

/// A divided-difference kernel `k(x, y)` inline, the same formulas as `Kernel::apply` (a test
/// compares the two).
fn kernel(k: Kernel, x: &Ident, y: &Ident) -> TokenStream {
    let f = quote!(::core::primitive::f64);
    let switch = constant(defect::SERIES_SWITCH);
    // `(1 - 1/a) + e^(-2a) (1 + 1/a)`, as `dth_symbolic::defect`.
    let scaled_c = quote! {
        (|a: f64| (1.0 - 1.0 / a) + #f::exp(-2.0 * a) * (1.0 + 1.0 / a))
    };
    let series_or = |k: Kernel, x: &Ident, closed: TokenStream| {
        let c = series_tokens(&defect::series(k), &format_ident!("x"));
        quote! {{
            let x: f64 = #x;
            if #f::abs(x) < #switch { #c } else { #closed }
        }}
    };
    let quotient = |g: TokenStream| {
        quote! {{
            let x: f64 = #x;
            if x == 0.0 { 1.0 } else { #f::#g(x) / x }
        }}
    };
    match k {
        Kernel::ExpRatio => quote! {{
            let (x, y): (f64, f64) = (#x, #y);
            if x == 0.0 {
                #f::exp(y)
            } else if x < 0.0 {
                #f::exp(y) * (#f::exp_m1(x) / x)
            } else {
                #f::exp(y + x) * (#f::exp_m1(-x) / -x)
            }
        }},
        Kernel::Sinc => quotient(quote!(sin)),
        Kernel::Sinhc => quotient(quote!(sinh)),
        Kernel::LnRatio => quote! {{
            let (x, y): (f64, f64) = (#x, #y);
            let u = x / y;
            if u == 0.0 { 1.0 / y } else { #f::ln_1p(u) / x }
        }},
        Kernel::AtanRatio => quote! {{
            let (x, y): (f64, f64) = (#x, #y);
            if x == 0.0 { 1.0 / y } else { #f::atan2(x, y) / x }
        }},
        Kernel::TanhRatio => quote! {{
            let (x, y): (f64, f64) = (#x, #y);
            if #f::abs(x) > 700.0 {
                (#f::tanh(y + x) - #f::tanh(y)) / x
            } else {
                let s = if x == 0.0 { 1.0 } else { #f::sinh(x) / x };
                s / (#f::cosh(y) * #f::cosh(y + x))
            }
        }},
        Kernel::CosMinusSinc => series_or(k, x, quote!(#f::cos(x) - #f::sin(x) / x)),
        Kernel::CoshMinusSinhc => series_or(
            k,
            x,
            quote!(0.5 * #f::exp(#f::abs(x)) * #scaled_c(#f::abs(x))),
        ),
        Kernel::SincMinusOne => series_or(k, x, quote!(#f::sin(x) / x - 1.0)),
        Kernel::SinhcMinusOne => series_or(k, x, quote!(#f::sinh(x) / x - 1.0)),
        Kernel::ExpDefect => {
            let c = series_tokens(&defect::series(Kernel::CoshMinusSinhc), &format_ident!("h"));
            quote! {{
                let (x, y): (f64, f64) = (#x, #y);
                let h = 0.5 * x;
                if #f::abs(h) < #switch {
                    2.0 * #f::exp(y + h) * #c
                } else {
                    #f::exp(y + #f::max(x, 0.0)) * #scaled_c(#f::abs(h))
                }
            }}
        }
        Kernel::TanhDefect => {
            let (xi, yi) = (format_ident!("x"), format_ident!("y"));
            let sinhc_m1 = kernel(Kernel::SinhcMinusOne, &xi, &xi);
            let ratio = kernel(Kernel::TanhRatio, &xi, &yi);
            quote! {{
                let (x, y): (f64, f64) = (#x, #y);
                let m = y + 0.5 * x;
                let (s0, s1) = (1.0 / #f::cosh(y), 1.0 / #f::cosh(y + x));
                if #f::abs(x) <= 700.0 && #f::abs(m) <= 350.0 {
                    let q = 2.0 * #f::sinh(m) * s0 * #f::sinh(0.5 * x) * s1;
                    q * q - 2.0 * #sinhc_m1 * s0 * s1
                } else {
                    s0 * s0 + s1 * s1 - 2.0 * #ratio
                }
            }}
        }
        Kernel::PowDefect(r) => {
            let big = constant(r.abs().max((r - 2.0).abs()));
            let n = series_tokens(&defect::pow_series(r), &format_ident!("u"));
            let (c1, c2, rr, r2, r1) = (
                constant(0.5 * (r - 2.0)),
                constant(0.5 * r),
                constant(r),
                constant(r - 2.0),
                constant(r - 1.0),
            );
            quote! {{
                let (x, y): (f64, f64) = (#x, #y);
                let u = 0.5 * #f::ln_1p(x / y);
                let ratio = if #big * #f::abs(u) < #switch {
                    let s = if u == 0.0 { 1.0 } else { #f::sinh(u) / u };
                    (#n) / s
                } else {
                    (#c1 * #f::sinh(#rr * u) - #c2 * #f::sinh(#r2 * u)) / #f::sinh(u)
                };
                2.0 * #f::exp(#r1 * u) * ratio
            }}
        }
        Kernel::PowRatio(r) => {
            let r = constant(r);
            quote! {{
                let (x, y): (f64, f64) = (#x, #y);
                let u = x / y;
                if u == 0.0 { #r / y } else { #f::exp_m1(#r * #f::ln_1p(u)) / x }
            }}
        }
    }
}

/// `sum_k c_k x^(2k)` by Horner's rule in `x^2`, the operations of
/// `dth_symbolic::defect::even_series` in the same order.
fn series_tokens(c: &[f64; defect::SERIES_TERMS], x: &Ident) -> TokenStream {
    let last = constant(c[defect::SERIES_TERMS - 1]);
    let steps = c[..defect::SERIES_TERMS - 1].iter().rev().map(|&ck| {
        let ck = constant(ck);
        quote!(let p = p * x2 + #ck;)
    });
    quote! {{
        let x2: f64 = #x * #x;
        let p: f64 = #last;
        #(#steps)*
        p * x2
    }}
}

/// An `f64` literal; negative values as a negated literal.
fn constant(c: f64) -> TokenStream {
    let lit = Literal::f64_suffixed(c.abs());
    if c.is_sign_negative() {
        quote!(-#lit)
    } else {
        quote!(#lit)
    }
}
