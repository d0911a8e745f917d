//! Emits `impl Hamiltonian<D>`: one straight-line function per trait method, plain `f64`
//! arithmetic on locals, fixed-size nalgebra types through `::dth::__private`.

use dth_symbolic::{Method, Op, Output, Program, System};
use proc_macro2::TokenStream;
use quote::{format_ident, quote};
use syn::Ident;

use crate::check;
use crate::code::{constant, kernel};
use crate::fallback;
use crate::parse::Input;
use crate::warning::warnings;

/// The expansion of the whole macro: the implementation, or the errors and a stub. A broken
/// item header is reported alone: the body's extent is uncertain then, so it is not compiled.
pub fn expand(input: Input) -> TokenStream {
    if let Some(header) = &input.item {
        if let Some(error) = check::combine(header.errors.clone()) {
            return fallback::stub(&input, Some(error.to_compile_error()));
        }
    }
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
    let warnings = warnings(input, system);
    match &input.item {
        Some(_) => quote! {
            #decl
            const _: () = { #imp };
            #warnings
        },
        None => quote! {{
            #decl
            #imp
            #warnings
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
        #[automatically_derived]
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
