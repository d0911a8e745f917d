//! The Rust code `hamiltonian!` emits for a compiled [`System`]: `impl Hamiltonian<Const<D>> for
//! Name`, one straight-line function per trait method, plain `f64` arithmetic on locals,
//! fixed-size nalgebra types through `::dth::__private`.
//!
//! Behind the `emit` feature (it brings `proc-macro2` and `quote`). It lives here, not in the
//! proc-macro crate, so code other than the macro can produce the same tokens: `dth derive
//! --rust` prints them. The macro stays thin: it parses its input, runs [`crate::compile`],
//! declares the type and calls [`hamiltonian_impl`].
//!
//! [`code`] writes `f64` values as code (constants, and the divided-difference kernels through
//! [`crate::kernel::Scalar`]); this module assembles the methods from the engine's programs;
//! [`lattice`] emits a lattice compiled once per summand ([`crate::looped`]) as loops.
//!
//! ```
//! use dth_symbolic::emit::hamiltonian_impl;
//! use proc_macro2::{Ident, Span};
//!
//! let system = dth_symbolic::compile("p1^2/(2*m) + q1^2/2", &["m"]).unwrap();
//! let name = Ident::new("Oscillator", Span::call_site());
//! let params = [Ident::new("m", Span::call_site())];
//! let code = hamiltonian_impl(&system, &name, &params).to_string();
//! assert!(code.contains("Hamiltonian < :: dth :: __private :: nalgebra :: Const < 2usize >> for Oscillator"));
//! assert!(code.contains("self . m"));
//! ```

pub mod code;
pub mod lattice;

use proc_macro2::{Ident, TokenStream};
use quote::{format_ident, quote};

use crate::solver::structured_newton;
use crate::{Method, Op, Output, Program, System};
use code::{constant, kernel};

/// The implementation `hamiltonian!` emits for `source` when it is a lattice of sums that loop
/// ([`crate::looped`]): `impl Hamiltonian<Const<D>>` as loops over the sites, its code
/// independent of the number of sites. `None` for every other source (and for a lattice without a momentum,
/// or with a summand too long for one loop body): the caller then compiles the source site by
/// site and emits [`hamiltonian_impl`]. The macro and `dth derive --rust` both decide here,
/// so they print the same code.
pub fn looped_source_impl(source: &str, name: &Ident, params: &[Ident]) -> Option<TokenStream> {
    let names: Vec<String> = params.iter().map(Ident::to_string).collect();
    let names: Vec<&str> = names.iter().map(String::as_str).collect();
    // Without a momentum (an error of `looped::compile`, as of the site-by-site path) the flow
    // does not move.
    let looped = crate::looped::loops(source, &names)?;
    lattice::looped_impl(&looped, name, params)
}

/// `impl ::dth::__private::dth_core::Hamiltonian<Const<D>> for #name`, `D` the system's dimension,
/// every method computed by the engine's programs for `system`. `params` are the names of the
/// type's `f64` fields, in the order of the system's parameters (`Op::Param(k)` reads
/// `self.params[k]`); the type itself is declared by the caller.
pub fn hamiltonian_impl(system: &System, name: &Ident, params: &[Ident]) -> TokenStream {
    let d = system.dim();
    let cx = Context {
        name,
        params,
        arithmetic: Arithmetic::Double,
    };
    let nalgebra = quote!(::dth::__private::nalgebra);
    let core = quote!(::dth::__private::dth_core);
    let (td, sep, psi0) = (
        system.time_dependent(),
        system.separable(),
        system.psi_identically_zero(),
    );
    let value = body(&system.program(Method::Value), &cx, |v| {
        let v = &v.value;
        quote!(#v)
    });
    let gradient = body(&system.program(Method::Gradient), &cx, |v| v.gradient(d));
    // One Hessian program: the dense `hessian` and the fused nonzeros below both emit it.
    let hessian_program = system.program(Method::Hessian);
    let hessian = body(&hessian_program, &cx, |v| v.hessian(d));
    let psi = body(&system.program(Method::Psi), &cx, |v| {
        let v = &v.psi;
        quote!(#v)
    });
    let all = body(&system.program(Method::All), &cx, |v| {
        let (g, h, value, psi) = (v.gradient(d), v.hessian(d), &v.value, &v.psi);
        quote!(#core::Derivatives { value: #value, gradient: #g, hessian: #h, psi: #psi })
    });
    // One two-point program, each method keeping only the operations its outputs reach.
    let pair = system.program(Method::DiscreteGradient);
    let gbar = pair.prune(|o| matches!(o, Output::DiscreteGradient(_)));
    let discrete_gradient = body(&gbar, &cx, |v| v.discrete_gradient(d));
    let delta = pair.prune(|o| o == Output::EnergyDifference);
    let energy_difference = body(&delta, &cx, |v| {
        let v = &v.energy_difference;
        quote!(#v)
    });
    let defect = body(&system.program(Method::DiscreteGradientDefect), &cx, |v| {
        v.discrete_gradient_defect(d)
    });
    // The Hessian's nonzeros, upper triangle, in the engine's order: the pattern, and the
    // fused evaluation writing only them.
    let pattern: Vec<(usize, usize)> = system
        .hessian_nonzeros()
        .iter()
        .map(|&(i, j, _)| (i, j))
        .collect();
    let nonzeros = body(&hessian_program, &cx, |v| v.hessian_nonzeros(&pattern));
    let nnz = pattern.len();
    let pattern_rows = pattern.iter().map(|(i, j)| quote!((#i, #j)));
    let diagonal = pattern.iter().filter(|(i, j)| i == j).count();
    let structured = structured_newton(d, nnz, diagonal, sep);
    let source = system_source(system);
    let regularized = system.regularized();
    let start = start_impl(system, &cx);
    let gradient_double_double = double_double_gradient(system, &cx);
    quote! {
        #[doc = #source]
        #[automatically_derived]
        #[allow(unused_variables, clippy::all, clippy::pedantic, clippy::nursery)]
        impl #core::ConstFlags for #name {
            const FLAGS: #core::Flags = #core::Flags::new()
                .with_time_dependent(#td)
                .with_separable(#sep)
                .with_psi_identically_zero(#psi0)
                .with_exact_divided_differences(true)
                .with_structured_newton(#structured)
                .with_regularized(#regularized);
        }

        #[automatically_derived]
        #[allow(unused_variables, clippy::all, clippy::pedantic, clippy::nursery)]
        impl #core::Hamiltonian<#nalgebra::Const<#d>> for #name {
            #[inline]
            fn dim(&self) -> #nalgebra::Const<#d> { #nalgebra::Const }
            #[inline]
            fn flags(&self) -> #core::Flags {
                <Self as #core::ConstFlags>::FLAGS
            }
            #[inline]
            fn hessian_pattern(&self) -> ::core::option::Option<&[(usize, usize)]> {
                const PATTERN: &[(usize, usize)] = &[#(#pattern_rows),*];
                ::core::option::Option::Some(PATTERN)
            }

            #[inline]
            fn value(&self, z: &#nalgebra::SVector<f64, #d>) -> f64 { #value }
            #[inline]
            fn gradient_into(&self, z: &#nalgebra::SVector<f64, #d>, out: &mut #nalgebra::SVector<f64, #d>) {
                *out = { #gradient };
            }
            #[inline]
            fn hessian_into(&self, z: &#nalgebra::SVector<f64, #d>, out: &mut #nalgebra::SMatrix<f64, #d, #d>) {
                *out = { #hessian };
            }
            /// Only the Hessian's nonzero entries, fused, in the order of `hessian_pattern`.
            #[inline]
            fn hessian_nonzeros(&self, z: &#nalgebra::SVector<f64, #d>, values: &mut [f64]) {
                let values = &mut values[..#nnz];
                #nonzeros
            }
            #[inline]
            fn psi(&self, z: &#nalgebra::SVector<f64, #d>) -> f64 { #psi }
            #[inline]
            fn derivatives_into(
                &self,
                z: &#nalgebra::SVector<f64, #d>,
                out: &mut #core::Derivatives<#nalgebra::Const<#d>>,
            ) {
                *out = { #all };
            }
            /// Exact divided differences of `H`, without cancellation (`dth_symbolic::divided`).
            #[inline]
            fn discrete_gradient_into(
                &self,
                z0: &#nalgebra::SVector<f64, #d>,
                z1: &#nalgebra::SVector<f64, #d>,
                out: &mut #nalgebra::SVector<f64, #d>,
            ) {
                let z = z0;
                *out = { #discrete_gradient };
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
            fn discrete_gradient_defect_into(
                &self,
                z0: &#nalgebra::SVector<f64, #d>,
                z1: &#nalgebra::SVector<f64, #d>,
                gbar: &#nalgebra::SVector<f64, #d>,
                out: &mut #nalgebra::SVector<f64, #d>,
            ) {
                let _ = gbar;
                let z = z0;
                *out = { #defect };
            }
            #gradient_double_double
        }

        #start
    }
}

/// For a regularization's `K` ([`System::physical_value`]), the type's inherent
/// `physical_energy` (the physical `H` at `(q, p)` in double-double, rounded once) and
/// `start` (the regularized state of a physical one, `p_t = -physical_energy`, through
/// `dth_core::regularize`): where a Kepler orbit's period follows the start's energy, the plain
/// `f64` sum of `H`'s terms would set it. Empty for any other system.
fn start_impl(system: &System, cx: &Context) -> TokenStream {
    let Some(physical) = system.physical_value() else {
        return TokenStream::new();
    };
    let (name, d, pd) = (cx.name, system.dim(), physical.dim);
    let nalgebra = quote!(::dth::__private::nalgebra);
    let core = quote!(::dth::__private::dth_core);
    // The physical dimension names the map: a plane (Levi-Civita) or space (KS).
    let map = if pd == 4 {
        quote!(LeviCivita)
    } else {
        quote!(KustaanheimoStiefel)
    };
    let cx = Context {
        arithmetic: Arithmetic::DoubleDouble,
        ..*cx
    };
    let energy = body(physical, &cx, |v| {
        let v = &v.value;
        quote!((#v.hi, #v.lo))
    });
    let dd = quote!(::dth::__private::double_double::Dd);
    quote! {
        #[automatically_derived]
        #[allow(unused_variables, clippy::all, clippy::pedantic, clippy::nursery)]
        impl #name {
            /// The physical Hamiltonian `H(q, p)` (before the regularization) at
            /// `z = (q, p)`, in double-double arithmetic rounded once: the energy a regularized
            /// run starts from. (Functions other than square roots and integer or
            /// half-integer powers are evaluated in doubles.)
            pub fn physical_energy(&self, z: &#nalgebra::SVector<f64, #pd>) -> f64 {
                let (hi, lo) = self.physical_energy_double_double(z);
                hi + lo
            }

            /// [`Self::physical_energy`] before its rounding: `(hi, lo)`, the energy
            /// `hi + lo` in double-double.
            pub fn physical_energy_double_double(
                &self,
                z: &#nalgebra::SVector<f64, #pd>,
            ) -> (f64, f64) {
                let z: &[#dd; #pd] = &::core::array::from_fn(|k| #dd::new(z[k]));
                #energy
            }

            /// The regularized start of the physical state `z = (q, p)` at time `t`, with
            /// `p_t = -H(z)` from [`Self::physical_energy`] (so that `K = 0` and the orbit's
            /// period is as accurate as the energy can be).
            ///
            /// # Errors
            /// As `dth::regularize`'s `start`: a value that is not finite, `q` at the centre.
            pub fn start(
                &self,
                z: &#nalgebra::SVector<f64, #pd>,
                t: f64,
            ) -> ::core::result::Result<#nalgebra::SVector<f64, #d>, #core::Error> {
                #core::regularize::#map::start(z, t, self.physical_energy(z))
            }

            /// [`Self::start`] in double-double: the state and its low part, from the
            /// energy in double-double, for a run solved in double-double (`dth::solve`'s
            /// `start_low`, `Dth::with_low`): at e = 0.999 over 100 orbits it ends within
            /// its truncation error where a run from doubles stays 1e-9 off.
            ///
            /// # Errors
            /// As [`Self::start`].
            pub fn start_double_double(
                &self,
                z: &#nalgebra::SVector<f64, #pd>,
                t: f64,
            ) -> ::core::result::Result<
                (#nalgebra::SVector<f64, #d>, #nalgebra::SVector<f64, #d>),
                #core::Error,
            > {
                #core::regularize::#map::start_double_double(
                    z,
                    t,
                    self.physical_energy_double_double(z),
                )
            }
        }
    }
}

/// For a regularization's `K`, the trait's `gradient_double_double_into`: `grad K` at the
/// point `hi + lo` in double-double (the DTH stepper solves a regularized run's steps with it,
/// `dth_core::dth::compensated`). Empty for any other system (the trait's default says it is
/// not provided).
fn double_double_gradient(system: &System, cx: &Context) -> TokenStream {
    if system.physical_value().is_none() {
        return TokenStream::new();
    }
    let d = system.dim();
    let nalgebra = quote!(::dth::__private::nalgebra);
    let dd = quote!(::dth::__private::double_double::Dd);
    let cx = Context {
        arithmetic: Arithmetic::DoubleDouble,
        ..*cx
    };
    let gradient = body(&system.program(Method::Gradient), &cx, |v| {
        let mut entries = vec![cx.arithmetic.zero(); d];
        for (i, e) in &v.gradient {
            entries[*i] = e.clone();
        }
        quote!([#(#entries),*])
    });
    quote! {
        /// `grad K` at `hi + lo`, in double-double arithmetic (see `physical_energy` for what
        /// is carried), as `out_hi + out_lo`.
        #[inline]
        fn gradient_double_double_into(
            &self,
            (hi, lo): (&#nalgebra::SVector<f64, #d>, &#nalgebra::SVector<f64, #d>),
            (out_hi, out_lo): (&mut #nalgebra::SVector<f64, #d>, &mut #nalgebra::SVector<f64, #d>),
        ) -> bool {
            let z: &[#dd; #d] = &::core::array::from_fn(|k| #dd { hi: hi[k], lo: lo[k] });
            let g: [#dd; #d] = { #gradient };
            for (k, x) in g.iter().enumerate() {
                out_hi[k] = x.hi;
                out_lo[k] = x.lo;
            }
            true
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

/// What the emitted code refers to: the type (for the chunk functions' receiver) and the
/// declared parameters; and the arithmetic of its locals.
struct Context<'a> {
    name: &'a Ident,
    params: &'a [Ident],
    arithmetic: Arithmetic,
}

/// The arithmetic of the emitted locals: `f64` (every trait method but one), or
/// double-double for a regularization's start energy ([`start_impl`]) and its gradient in
/// double-double ([`double_double_gradient`]), with the operations of
/// [`Program::run_double_double`] in the same order (the point `z` then an array of `Dd`).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
enum Arithmetic {
    Double,
    DoubleDouble,
}

impl Arithmetic {
    /// The type of a local.
    fn local_type(self) -> TokenStream {
        match self {
            Arithmetic::Double => quote!(f64),
            Arithmetic::DoubleDouble => quote!(::dth::__private::double_double::Dd),
        }
    }

    /// The type of the point `z` the emitted code reads: the method's `&SVector<f64, d>`, or
    /// an array of `Dd` bound from it (with or without low parts).
    fn point_type(self, d: usize) -> TokenStream {
        match self {
            Arithmetic::Double => quote!(&::dth::__private::nalgebra::SVector<f64, #d>),
            Arithmetic::DoubleDouble => quote!(&[::dth::__private::double_double::Dd; #d]),
        }
    }

    /// An output a program does not compute.
    fn zero(self) -> TokenStream {
        match self {
            Arithmetic::Double => quote!(0.0f64),
            Arithmetic::DoubleDouble => quote!(::dth::__private::double_double::Dd::new(0.0f64)),
        }
    }
}

/// The outputs of a program as expressions: a local, a load from the spill array, or `0.0`
/// when not computed.
struct Values {
    value: TokenStream,
    psi: TokenStream,
    energy_difference: TokenStream,
    gradient: Vec<(usize, TokenStream)>,
    hessian: Vec<(usize, usize, TokenStream)>,
    discrete_gradient: Vec<(usize, TokenStream)>,
    discrete_gradient_defect: Vec<(usize, TokenStream)>,
}

/// Matrices up to this dimension are built as one column-major array literal (every entry,
/// zeros included); larger ones as `zeros()` plus a store per nonzero entry, so the emitted
/// code stays linear in the nonzeros.
const LITERAL_MAX_DIM: usize = 8;

/// The most operations emitted into one function. Every `let` opens a lexical scope nested in
/// the previous one, and the compiler walks that nesting recursively: a function of some
/// 2,500 `let`s overflowed rustc's stack while emitting debug information (the dev profile,
/// an FPUT chain of 38 particles), and LLVM's optimisations grow faster than linearly in a
/// function's size. Longer programs are cut into chunks of this many operations, each a
/// function of its own (see [`body`]).
const CHUNK_OPS: usize = 1000;

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

    /// Stores into `values[k]` for the `k`-th entry of `pattern` (`0.0` for an entry the
    /// program does not compute).
    fn hessian_nonzeros(&self, pattern: &[(usize, usize)]) -> TokenStream {
        let stores = pattern.iter().enumerate().map(|(k, &(i, j))| {
            let v = self
                .hessian
                .iter()
                .find(|(a, b, _)| (*a, *b) == (i, j))
                .map_or(quote!(0.0f64), |(_, _, v)| v.clone());
            quote!(values[#k] = #v;)
        });
        quote!(#(#stores)*)
    }

    fn hessian(&self, d: usize) -> TokenStream {
        let nalgebra = quote!(::dth::__private::nalgebra);
        if self.hessian.is_empty() {
            return quote!(#nalgebra::SMatrix::<f64, #d, #d>::zeros());
        }
        if d <= LITERAL_MAX_DIM {
            let mut entries = vec![vec![quote!(0.0f64); d]; d];
            for (i, j, v) in &self.hessian {
                entries[*j][*i] = v.clone();
                entries[*i][*j] = v.clone();
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
fn vector(d: usize, set: &[(usize, TokenStream)]) -> TokenStream {
    let nalgebra = quote!(::dth::__private::nalgebra);
    if d <= LITERAL_MAX_DIM {
        let mut entries = vec![quote!(0.0f64); d];
        for (i, v) in set {
            entries[*i] = v.clone();
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

/// The local holding slot `s`.
fn local(s: u32) -> Ident {
    format_ident!("v{}", s)
}

/// `let vi: f64 = ...;` for operation `i` (or `Dd` in double-double, [`Arithmetic`]);
/// parameters are fields of `receiver`.
fn define(i: usize, op: &Op, cx: &Context, receiver: &TokenStream) -> TokenStream {
    let v = local;
    let lhs = v(i as u32);
    let ty = cx.arithmetic.local_type();
    let double_double = cx.arithmetic == Arithmetic::DoubleDouble;
    // A double read in: exact in double-double.
    let read = |x: TokenStream| {
        if double_double {
            quote!(#ty::new(#x))
        } else {
            x
        }
    };
    let rhs = match *op {
        // Inputs are locals' type already: `z` is an array of `Dd` in double-double (the
        // point may carry low parts).
        Op::Input(k) => {
            let k = k as usize;
            quote!(z[#k])
        }
        Op::Input1(k) => {
            let k = k as usize;
            read(quote!(z1[#k]))
        }
        Op::Param(k) => {
            let p = &cx.params[k as usize];
            read(quote!(#receiver.#p))
        }
        Op::Const(c) => read(constant(c)),
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
        Op::Sqrt(a) if double_double => {
            let a = v(a);
            quote!(#a.sqrt())
        }
        Op::Sqrt(a) => {
            let a = v(a);
            quote!(::core::primitive::f64::sqrt(#a))
        }
        Op::Powf(a, e) if double_double => {
            let (a, e) = (v(a), constant(e));
            quote!(#a.powf(#e))
        }
        Op::Powf(a, e) => {
            let (a, e) = (v(a), constant(e));
            quote!(::core::primitive::f64::powf(#a, #e))
        }
        // Functions and kernels in doubles at their rounded arguments, as the interpreter's
        // double-double run does.
        Op::Call(f, a) if double_double => {
            let (a, f) = (v(a), format_ident!("{}", f.name()));
            quote!(#ty::new(::core::primitive::f64::#f(#a.to_f64())))
        }
        Op::Call(f, a) => {
            let (a, f) = (v(a), format_ident!("{}", f.name()));
            quote!(::core::primitive::f64::#f(#a))
        }
        Op::Kernel(k, a, b) if double_double => {
            let (x, y) = (format_ident!("x"), format_ident!("y"));
            let (a, b, k) = (v(a), v(b), kernel(k, &x, &y));
            quote!({
                let (#x, #y) = (#a.to_f64(), #b.to_f64());
                #ty::new(#k)
            })
        }
        Op::Kernel(k, a, b) => kernel(k, &v(a), &v(b)),
    };
    quote!(let #lhs: #ty = #rhs;)
}

/// The operands an operation reads.
fn operands(op: &Op) -> impl Iterator<Item = u32> {
    let (a, b) = match *op {
        Op::Input(_) | Op::Input1(_) | Op::Param(_) | Op::Const(_) => (None, None),
        Op::Add(a, b) | Op::Sub(a, b) | Op::Mul(a, b) | Op::Div(a, b) | Op::Kernel(_, a, b) => {
            (Some(a), Some(b))
        }
        Op::Neg(a) | Op::Sqrt(a) | Op::Powf(a, _) | Op::Call(_, a) => (Some(a), None),
    };
    a.into_iter().chain(b)
}

/// The program's operations, and `finish` of its outputs (each output an expression).
///
/// Up to [`CHUNK_OPS`] operations, one `let` per operation in the method's body. Beyond, the
/// operations are cut into chunks of [`CHUNK_OPS`], each emitted as a nested `#[inline(never)]`
/// function: a slot read by a later chunk or by an output is stored into a spill array (on the
/// stack, one `f64` per such slot) where it is defined and loaded once into a local by each
/// later chunk that reads it; the outputs are read from the spill array. The arithmetic is the
/// same operations in the same order, so the results are bit-identical to the unchunked form.
fn body(program: &Program, cx: &Context, finish: impl Fn(&Values) -> TokenStream) -> TokenStream {
    let chunked = program.ops.len() > CHUNK_OPS;
    let chunk_of = |s: u32| s as usize / CHUNK_OPS;
    // The spill index of each slot read outside its chunk (chunked form only).
    let mut spill: Vec<Option<usize>> = vec![None; program.ops.len()];
    let mut spilled = 0;
    if chunked {
        let mut mark = |s: u32| {
            if spill[s as usize].is_none() {
                spill[s as usize] = Some(spilled);
                spilled += 1;
            }
        };
        for (i, op) in program.ops.iter().enumerate() {
            for a in operands(op) {
                if chunk_of(a) != i / CHUNK_OPS {
                    mark(a);
                }
            }
        }
        for &(_, s) in &program.outputs {
            mark(s);
        }
    }
    let output = |s: u32| match spill[s as usize] {
        Some(k) if chunked => quote!(spill[#k]),
        _ => {
            let v = local(s);
            quote!(#v)
        }
    };
    let zero = cx.arithmetic.zero();
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
        let e = output(s);
        match out {
            Output::Value => values.value = e,
            Output::Psi => values.psi = e,
            Output::Gradient(i) => values.gradient.push((i, e)),
            Output::Hessian(i, j) => values.hessian.push((i, j, e)),
            Output::DiscreteGradient(i) => values.discrete_gradient.push((i, e)),
            Output::DiscreteGradientDefect(i) => values.discrete_gradient_defect.push((i, e)),
            Output::EnergyDifference => values.energy_difference = e,
        }
    }
    let out = finish(&values);
    if !chunked {
        let receiver = quote!(self);
        let lets = program
            .ops
            .iter()
            .enumerate()
            .map(|(i, op)| define(i, op, cx, &receiver));
        return quote! {
            let _ = z;
            #(#lets)*
            #out
        };
    }
    let name = cx.name;
    let d = program.dim;
    let nalgebra = quote!(::dth::__private::nalgebra);
    let two_point = program.ops.iter().any(|op| matches!(op, Op::Input1(_)));
    let (z1_param, z1_arg) = if two_point {
        (quote!(z1: &#nalgebra::SVector<f64, #d>,), quote!(z1,))
    } else {
        (quote!(), quote!())
    };
    let z_type = cx.arithmetic.point_type(d);
    let receiver = quote!(this);
    let mut chunks = Vec::new();
    let mut calls = Vec::new();
    for (c, ops) in program.ops.chunks(CHUNK_OPS).enumerate() {
        let first = c * CHUNK_OPS;
        let mut loaded: Vec<u32> = ops
            .iter()
            .flat_map(operands)
            .filter(|&a| chunk_of(a) != c)
            .collect();
        loaded.sort_unstable();
        loaded.dedup();
        let ty = cx.arithmetic.local_type();
        let loads = loaded.iter().map(|&a| {
            let (v, k) = (local(a), spill[a as usize]);
            quote!(let #v: #ty = spill[#k];)
        });
        let lets = ops.iter().enumerate().map(|(i, op)| {
            let i = first + i;
            let def = define(i, op, cx, &receiver);
            match spill[i] {
                Some(k) => {
                    let v = local(i as u32);
                    quote!(#def spill[#k] = #v;)
                }
                None => def,
            }
        });
        let f = format_ident!("chunk{}", c);
        chunks.push(quote! {
            #[inline(never)]
            fn #f(
                this: &#name,
                z: #z_type,
                #z1_param
                spill: &mut [#ty; #spilled],
            ) {
                let _ = (this, z);
                #(#loads)*
                #(#lets)*
            }
        });
        calls.push(quote!(#f(self, z, #z1_arg &mut spill);));
    }
    let zero = cx.arithmetic.zero();
    quote! {
        #(#chunks)*
        let mut spill = [#zero; #spilled];
        #(#calls)*
        #out
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use proc_macro2::Span;

    fn emitted(system: &System) -> String {
        let name = Ident::new("K", Span::call_site());
        hamiltonian_impl(system, &name, &[]).to_string()
    }

    /// A regularization's type gains `physical_energy` (its physical `H` in double-double, on
    /// the physical dimension: 4 in the plane, 6 in space) and `start` through the map of its
    /// dimension; any other type gains neither.
    #[test]
    fn only_a_regularization_emits_its_start() {
        let kepler = "p1^2 + p2^2 - (q1^2 + q2^2)^(-1/2)";
        let plane = emitted(&crate::regularize::levi_civita(kepler, &[]).unwrap());
        assert!(plane.contains("pub fn physical_energy (& self , z : & :: dth :: __private :: nalgebra :: SVector < f64 , 4usize >)"), "{plane}");
        assert!(plane.contains("double_double :: Dd :: new (z [k])"));
        assert!(plane
            .contains("regularize :: LeviCivita :: start (z , t , self . physical_energy (z))"));
        // The start in double-double, and K's gradient in double-double for its runs.
        assert!(plane.contains("regularize :: LeviCivita :: start_double_double"));
        assert!(plane.contains("fn gradient_double_double_into"), "{plane}");
        let space = emitted(
            &crate::regularize::kustaanheimo_stiefel(
                "p1^2 + p2^2 + p3^2 - (q1^2 + q2^2 + q3^2)^(-1/2)",
                &[],
            )
            .unwrap(),
        );
        assert!(space.contains("SVector < f64 , 6usize >) -> f64"));
        assert!(space.contains("regularize :: KustaanheimoStiefel :: start"));
        assert!(space.contains("fn gradient_double_double_into"));
        let plain = emitted(&crate::compile(kepler, &[]).unwrap());
        assert!(!plain.contains("physical_energy") && !plain.contains("double_double"));
    }
}
