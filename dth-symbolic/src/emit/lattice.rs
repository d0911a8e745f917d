//! The code of a lattice compiled once per summand ([`crate::looped`]): every method loops
//! over the sites, runs the summand's straight-line program on the local coordinates it reads
//! and scatters the results, so the emitted code does not grow with the number of sites.
//!
//! A nested sum (over pairs, nested or strided, [`crate::looped::nested`]) is a loop over its
//! index tuples `(i, j)`, every index affine in them; a sum over pairs writes its Hessian
//! entries into its dense block, at the block's position of the row and column.
//!
//! The Hessian's pattern is emitted as runs along its diagonals (the private module
//! `looped::diagonals`), which `hessian_pattern` expands once, at its first call, into a
//! `static`; the position each (sum, site, summand entry) writes to is arithmetic on the
//! site, listed only at the sites that reach a boundary. Neither the code nor the compiler's
//! work on it grows with `N`: a constant pattern would make every build of the user's crate
//! write out its `3N - 1` entries in the constant evaluator (which grew the build by about
//! 0.3 s in dev and 0.8 s in release at `N = 4096`, docs/performance.md).

use proc_macro2::{Ident, TokenStream};
use quote::quote;

use super::{body, Arithmetic, Context, Values, CHUNK_OPS};
use crate::looped::diagonals::{layout, Place};
use crate::looped::{Looped, Site};
use crate::{Method, Output, Program};

/// Each of `programs` keeping only the operations the outputs `keep` holds reach.
fn pruned(programs: &[Program], keep: fn(Output) -> bool) -> Vec<Program> {
    programs.iter().map(|p| p.prune(keep)).collect()
}

/// `impl Hamiltonian<Const<D>>` for a looped lattice, or `None` when a summand's program is
/// too long for one loop body (the caller emits the site-by-site code instead).
pub fn looped_impl(looped: &Looped, name: &Ident, params: &[Ident]) -> Option<TokenStream> {
    let cx = Context {
        name,
        params,
        arithmetic: Arithmetic::Double,
    };
    let programs = |m: Method| -> Vec<Program> {
        looped.sums.iter().map(|s| s.summand().program(m)).collect()
    };
    let (value_p, gradient_p, hessian_p, pair_p, defect_p) = (
        programs(Method::Value),
        programs(Method::Gradient),
        programs(Method::Hessian),
        programs(Method::DiscreteGradient),
        programs(Method::DiscreteGradientDefect),
    );
    // One loop body each: the rule is `Looped::fits_one_body`, shared with the JIT.
    const _: () = assert!(CHUNK_OPS == crate::looped::MAX_BODY_OPS);
    if !looped.fits_one_body() {
        return None;
    }
    let n = looped.n;
    let d = 2 * n;
    let n_i64 = n as i64;
    let nalgebra = quote!(::dth::__private::nalgebra);
    let core = quote!(::dth::__private::dth_core);
    let (separable, psi0) = looped.flags();
    let layout = layout(looped);
    let nnz = layout.nnz;
    let structured = crate::solver::structured_newton(d, nnz, layout.diagonal, separable);

    // Where letter[k] lives: the lattice, or a boundary (periodic: a site; fixed: a value).
    let arms = looped.boundaries.iter().map(|&(letter, k, site)| {
        let q = letter == 'q';
        match site {
            Site::Var(a) => {
                quote!(if q == #q && k == #k { return ::core::option::Option::Some(#a); })
            }
            Site::Const(_) => {
                quote!(if q == #q && k == #k { return ::core::option::Option::None; })
            }
        }
    });
    let fixed = looped.boundaries.iter().filter_map(|&(letter, k, site)| {
        let q = letter == 'q';
        match site {
            Site::Const(v) => {
                let v = super::code::constant(v);
                Some(quote!(if q == #q && k == #k { return #v; }))
            }
            Site::Var(_) => None,
        }
    });
    let helpers = quote! {
        /// The position in `z` of `q[k]` (`q`) or `p[k]`; `None` at a fixed boundary.
        #[allow(dead_code)]
        const fn site(q: bool, k: i64) -> ::core::option::Option<usize> {
            if k >= 1 && k <= #n_i64 {
                return ::core::option::Option::Some(if q { (k - 1) as usize } else { #n + (k - 1) as usize });
            }
            #(#arms)*
            ::core::option::Option::None
        }
        /// The value of a fixed boundary.
        #[allow(dead_code)]
        const fn fixed(q: bool, k: i64) -> f64 {
            #(#fixed)*
            0.0
        }
    };

    // The pattern: its runs, expanded at run time (see the module docs).
    let runs = layout
        .runs
        .iter()
        .map(|&(a, b, len)| quote!((#a, #b, #len)));
    let nruns = layout.runs.len();
    let blocks = layout.blocks.iter().map(|b| {
        let (first, len) = (b.first, b.len);
        quote!((#first, #len))
    });
    let nblocks = layout.blocks.len();
    let pattern = quote! {
        /// Runs along the Hessian's diagonals: `(a, b, len)` holds `(a + k, b + k)`, `k < len`.
        #[doc(hidden)]
        const __DTH_HESSIAN_RUNS: [(usize, usize, usize); #nruns] = [#(#runs),*];
        /// Dense blocks after the runs: `(first, len)` holds every `(a, b)`, `a <= b`, of
        /// `first..first + len`, diagonal by diagonal.
        #[doc(hidden)]
        const __DTH_HESSIAN_BLOCKS: [(usize, usize); #nblocks] = [#(#blocks),*];
        /// The pattern, the runs one after the other, then the blocks, expanded once, at the
        /// first call.
        #[doc(hidden)]
        fn __dth_hessian_pattern() -> &'static [(usize, usize)] {
            static PATTERN: ::std::sync::OnceLock<::std::vec::Vec<(usize, usize)>> =
                ::std::sync::OnceLock::new();
            PATTERN.get_or_init(|| {
                let mut out = ::std::vec::Vec::with_capacity(#nnz);
                for &(a, b, len) in Self::__DTH_HESSIAN_RUNS.iter() {
                    out.extend((0..len).map(|k| (a + k, b + k)));
                }
                for &(first, len) in Self::__DTH_HESSIAN_BLOCKS.iter() {
                    for o in 0..len {
                        out.extend((0..len - o).map(|r| (first + r, first + r + o)));
                    }
                }
                out
            })
        }
    };
    // Where a summand entry lands at site `i`: `base + i` inside, listed sites at the edges.
    let position = |place: &Place| {
        let inside = place
            .interior
            .map(|(lo, hi, base)| quote!(#lo..=#hi => (#base + i) as usize,));
        let edges = place.edges.iter().map(|&(i, at)| quote!(#i => #at,));
        quote!(match i { #inside #(#edges)* _ => usize::MAX })
    };

    // One loop per sum: the local coordinates read from `zg` (and `zg1`), the program, and
    // `scatter` of its outputs.
    let loops = |programs: &[Program],
                 two_point: bool,
                 scatter: &dyn Fn(usize, &Values) -> TokenStream|
     -> TokenStream {
        let sums = looped
            .sums
            .iter()
            .zip(programs)
            .enumerate()
            .map(|(k, (s, program))| {
                let (lo, hi) = (s.lo, s.hi);
                let locals = load_locals(s.local_dim, two_point, |l, zg| {
                    let &(letter, c, _) = s.slots.iter().find(|&&(_, _, local)| local == l)?;
                    let q = letter == 'q';
                    Some(quote! {
                        match site(#q, i + #c) {
                            ::core::option::Option::Some(a) => #zg[a],
                            ::core::option::Option::None => fixed(#q, i + #c),
                        }
                    })
                });
                let code = body(program, &cx, |v| scatter(k, v));
                quote! {
                    let mut i: i64 = #lo;
                    while i <= #hi {
                        #locals
                        { #code }
                        i += 1;
                    }
                }
            });
        quote!(#(#sums)*)
    };
    // The global position of the slot holding local coordinate `l`, as `Option<usize>`.
    let slot_site = |k: usize, l: usize| -> Option<TokenStream> {
        let s = &looped.sums[k];
        s.slots
            .iter()
            .find(|&&(_, _, local)| local == l)
            .map(|&(letter, c, _)| {
                let q = letter == 'q';
                quote!(site(#q, i + #c))
            })
    };
    let scatter_vector = |k: usize, entries: &[(usize, TokenStream)], target: TokenStream| {
        let adds = entries.iter().filter_map(|(l, e)| {
            let at = slot_site(k, *l)?;
            Some(quote! {
                if let ::core::option::Option::Some(a) = #at { #target[a] += #e; }
            })
        });
        quote!({ #(#adds)* })
    };

    // The nested sums: loops over their index tuples `(i, j)`, every index affine in them.
    let nested_programs = |m: Method| -> Vec<Program> {
        looped
            .nested
            .iter()
            .map(|s| s.summand().program(m))
            .collect()
    };
    let index = |slot: &crate::looped::nested::NestedSlot| {
        let shift = if slot.letter == 'q' { 0 } else { n_i64 };
        let [a, b] = slot.coef;
        let c = slot.offset - 1 + shift;
        quote!(((#a * i + #b * j + #c) as usize))
    };
    let nested_loops = |programs: &[Program],
                        two_point: bool,
                        scatter: &dyn Fn(usize, &Values) -> TokenStream|
     -> TokenStream {
        let sums = looped
            .nested
            .iter()
            .zip(programs)
            .enumerate()
            .map(|(k, (s, program))| {
                let (lo, hi) = s.tuples.outer;
                let locals = load_locals(s.local_dim, two_point, |l, zg| {
                    let at = index(s.slots.iter().find(|slot| slot.local == l)?);
                    Some(quote!(#zg[#at]))
                });
                let code = body(program, &cx, |v| scatter(k, v));
                let (jlo, jhi) = match s.tuples.inner {
                    Some([(al, bl), (ah, bh)]) => (quote!(#al * i + #bl), quote!(#ah * i + #bh)),
                    None => (quote!(0i64), quote!(0i64)),
                };
                quote! {
                    let mut i: i64 = #lo;
                    while i <= #hi {
                        let (mut j, last): (i64, i64) = (#jlo, #jhi);
                        while j <= last {
                            #locals
                            { #code }
                            j += 1;
                        }
                        i += 1;
                    }
                }
            });
        quote!(#(#sums)*)
    };
    let nested_vector = |k: usize, entries: &[(usize, TokenStream)], target: TokenStream| {
        let s = &looped.nested[k];
        let adds = entries.iter().filter_map(|(l, e)| {
            let slot = s.slots.iter().find(|slot| slot.local == *l)?;
            let at = index(slot);
            Some(quote!(#target[#at] += #e;))
        });
        quote!({ #(#adds)* })
    };
    let nested_value = nested_loops(&nested_programs(Method::Value), false, &|_, v| {
        let e = &v.value;
        quote!({ acc += #e; })
    });
    let nested_gradient = nested_loops(&nested_programs(Method::Gradient), false, &|k, v| {
        nested_vector(k, &v.gradient, quote!(g))
    });
    let nested_nonzeros = nested_loops(&nested_programs(Method::Hessian), false, &|k, v| {
        let s = &looped.nested[k];
        let writes = s.pattern.iter().enumerate().filter_map(|(idx, &(r, t))| {
            let (sr, st) = (&s.slots[r], &s.slots[t]);
            let (a, b) = (sr.local.min(st.local), sr.local.max(st.local));
            let e = v
                .hessian
                .iter()
                .find(|(i, j, _)| (*i, *j) == (a, b))
                .map_or(quote!(0.0f64), |(_, _, e)| e.clone());
            let place = &layout.nested[k][idx];
            let at = match (place.block, place.interior) {
                (Some(block), _) => {
                    let block = layout.blocks[block];
                    let (x, y) = (index(sr), index(st));
                    let len = block.len;
                    let shift = block.start as i64 - block.first as i64;
                    quote! {{
                        let (x, y) = (#x, #y);
                        let (lo, hi) = (x.min(y), x.max(y));
                        let o = hi - lo;
                        (#shift + (o * #len) as i64 - ((o * o.saturating_sub(1)) / 2) as i64 + lo as i64) as usize
                    }}
                }
                (None, Some((_, _, base))) => {
                    let stride = place.stride;
                    quote!(((#base + #stride * i) as usize))
                }
                (None, None) => return None,
            };
            Some(quote!(values[#at] += #e;))
        });
        quote!({ #(#writes)* })
    });
    let nested_pair = nested_programs(Method::DiscreteGradient);
    let nested_discrete_gradient = nested_loops(
        &pruned(&nested_pair, |o| matches!(o, Output::DiscreteGradient(_))),
        true,
        &|k, v| nested_vector(k, &v.discrete_gradient, quote!(g)),
    );
    let nested_energy_difference = nested_loops(
        &pruned(&nested_pair, |o| o == Output::EnergyDifference),
        true,
        &|_, v| {
            let e = &v.energy_difference;
            quote!({ acc += #e; })
        },
    );
    let nested_defect = nested_loops(
        &nested_programs(Method::DiscreteGradientDefect),
        true,
        &|k, v| nested_vector(k, &v.discrete_gradient_defect, quote!(g)),
    );

    let value = loops(&value_p, false, &|_, v| {
        let e = &v.value;
        quote!({ acc += #e; })
    });
    let gradient = loops(&gradient_p, false, &|k, v| {
        scatter_vector(k, &v.gradient, quote!(g))
    });
    let nonzeros = loops(&hessian_p, false, &|k, v| {
        let s = &looped.sums[k];
        let writes = s.pattern.iter().enumerate().map(|(idx, &(r, t))| {
            let (lr, lt) = (s.slots[r].2, s.slots[t].2);
            let (a, b) = (lr.min(lt), lr.max(lt));
            let e = v
                .hessian
                .iter()
                .find(|(i, j, _)| (*i, *j) == (a, b))
                .map_or(quote!(0.0f64), |(_, _, e)| e.clone());
            let (site_r, site_t) = (
                slot_site(k, lr).unwrap_or(quote!(::core::option::Option::None)),
                slot_site(k, lt).unwrap_or(quote!(::core::option::Option::None)),
            );
            let distinct = r != t;
            let at = position(&layout.places[k][idx]);
            quote! {
                let at: usize = #at;
                if at != usize::MAX {
                    // Two slots on one particle (a ring of two): the mixed entry counts twice.
                    let twice = #distinct && #site_r == #site_t;
                    values[at] += if twice { 2.0 * #e } else { #e };
                }
            }
        });
        quote!({ #(#writes)* })
    });
    let discrete_gradient = loops(
        &pruned(&pair_p, |o| matches!(o, Output::DiscreteGradient(_))),
        true,
        &|k, v| scatter_vector(k, &v.discrete_gradient, quote!(g)),
    );
    let energy_difference = loops(
        &pruned(&pair_p, |o| o == Output::EnergyDifference),
        true,
        &|_, v| {
            let e = &v.energy_difference;
            quote!({ acc += #e; })
        },
    );
    let defect = loops(&defect_p, true, &|k, v| {
        scatter_vector(k, &v.discrete_gradient_defect, quote!(g))
    });
    let source = format!(" A lattice of {n} sites compiled in loops (D = {d})");
    Some(quote! {
            #[doc = #source]
            #[automatically_derived]
            #[allow(unused_variables, unused_mut, unused_assignments, unused_parens, clippy::all, clippy::pedantic, clippy::nursery)]
            impl #name {
                #pattern
                #[doc(hidden)]
                const __DTH_STRUCTURED_NEWTON: bool = #structured;
            }

        #[automatically_derived]
        impl #core::ConstFlags for #name {
            const FLAGS: #core::Flags = #core::Flags::new()
                .with_separable(#separable)
                .with_psi_identically_zero(#psi0)
                .with_exact_divided_differences(true)
                .with_structured_newton(Self::__DTH_STRUCTURED_NEWTON);
        }

        #[doc = #source]
        #[automatically_derived]
        #[allow(unused_variables, unused_mut, unused_assignments, unused_parens, clippy::all, clippy::pedantic, clippy::nursery)]
        impl #core::Hamiltonian<#nalgebra::Const<#d>> for #name {
                #[inline]
                fn dim(&self) -> #nalgebra::Const<#d> {
                    #nalgebra::Const
                }
            #[inline]
            fn flags(&self) -> #core::Flags {
                <Self as #core::ConstFlags>::FLAGS
            }
                #[inline]
                fn hessian_pattern(&self) -> ::core::option::Option<&[(usize, usize)]> {
                    ::core::option::Option::Some(Self::__dth_hessian_pattern())
                }
    #[inline]
                fn value(&self, z: &#nalgebra::SVector<f64, #d>) -> f64 {
                    #helpers
                    let zg = z;
                    let mut acc = 0.0f64;
                    #value
                    #nested_value
                    acc
                }
                #[inline]
                fn gradient_into(&self, z: &#nalgebra::SVector<f64, #d>, out: &mut #nalgebra::SVector<f64, #d>) {
                    #helpers
                    let zg = z;
                    let g = out;
                    g.fill(0.0);
                    #gradient
                    #nested_gradient
                }
                #[inline]
                fn hessian_into(&self, z: &#nalgebra::SVector<f64, #d>, out: &mut #nalgebra::SMatrix<f64, #d, #d>) {
                    let pattern = Self::__dth_hessian_pattern();
                    let mut values = [0.0f64; #nnz];
                    self.hessian_nonzeros(z, &mut values);
                    let h = out;
                    h.fill(0.0);
                    for (&(a, b), &v) in pattern.iter().zip(values.iter()) {
                        h[(a, b)] = v;
                        h[(b, a)] = v;
                    }
                }
                /// Only the Hessian's nonzero entries, in the order of `hessian_pattern`.
                #[inline]
                fn hessian_nonzeros(&self, z: &#nalgebra::SVector<f64, #d>, values: &mut [f64]) {
                    #helpers
                    let zg = z;
                    let values = &mut values[..#nnz];
                    for v in values.iter_mut() {
                        *v = 0.0;
                    }
                    #nonzeros
                    #nested_nonzeros
                }
                #[inline]
                fn psi(&self, z: &#nalgebra::SVector<f64, #d>) -> f64 {
                    let pattern = Self::__dth_hessian_pattern();
                    let g = self.gradient(z);
                    let mut values = [0.0f64; #nnz];
                    self.hessian_nonzeros(z, &mut values);
                    let w = |i: usize| if i < #n { g[i + #n] } else { -g[i - #n] };
                    let mut psi = 0.0f64;
                    for (&(a, b), &v) in pattern.iter().zip(values.iter()) {
                        psi += if a == b { v * w(a) * w(a) } else { 2.0 * v * w(a) * w(b) };
                    }
                    psi
                }
                #[inline]
                fn derivatives_into(
                    &self,
                    z: &#nalgebra::SVector<f64, #d>,
                    out: &mut #core::Derivatives<#nalgebra::Const<#d>>,
                ) {
                    out.value = self.value(z);
                    self.gradient_into(z, &mut out.gradient);
                    self.hessian_into(z, &mut out.hessian);
                    out.psi = self.psi(z);
                }
                /// Exact divided differences of `H`, without cancellation, summand by summand.
                #[inline]
                fn discrete_gradient_into(
                    &self,
                    z0: &#nalgebra::SVector<f64, #d>,
                    z1: &#nalgebra::SVector<f64, #d>,
                    out: &mut #nalgebra::SVector<f64, #d>,
                ) {
                    #helpers
                    let (zg, zg1) = (z0, z1);
                    let g = out;
                    g.fill(0.0);
                    #discrete_gradient
                    #nested_discrete_gradient
                }
                /// `H(z1) - H(z0)` by exact divided differences, without cancellation.
                #[inline]
                fn energy_difference(
                    &self,
                    z0: &#nalgebra::SVector<f64, #d>,
                    z1: &#nalgebra::SVector<f64, #d>,
                ) -> f64 {
                    #helpers
                    let (zg, zg1) = (z0, z1);
                    let mut acc = 0.0f64;
                    #energy_difference
                    #nested_energy_difference
                    acc
                }
                /// `grad H(z0) + grad H(z1) - 2 gbar(z0, z1)` without cancellation; `gbar` is
                /// recomputed inside, not read.
                #[inline]
                fn discrete_gradient_defect_into(
                    &self,
                    z0: &#nalgebra::SVector<f64, #d>,
                    z1: &#nalgebra::SVector<f64, #d>,
                    gbar: &#nalgebra::SVector<f64, #d>,
                    out: &mut #nalgebra::SVector<f64, #d>,
                ) {
                    #helpers
                    let _ = gbar;
                    let (zg, zg1) = (z0, z1);
                    let g = out;
                    g.fill(0.0);
                    #defect
                    #nested_defect
                }
            }
        })
}

/// `let z = [..];` (and `let z1 = [..];` for a two-point method): a summand's `local_dim` local
/// coordinates loaded from the global state `zg` (and `zg1`); `entry(l, zg)` loads local
/// coordinate `l`, `None` where the summand does not use it (loaded as 0).
fn load_locals(
    local_dim: usize,
    two_point: bool,
    entry: impl Fn(usize, &TokenStream) -> Option<TokenStream>,
) -> TokenStream {
    let load = |zg: TokenStream| {
        let entries = (0..local_dim).map(|l| entry(l, &zg).unwrap_or_else(|| quote!(0.0f64)));
        quote!([#(#entries),*])
    };
    let z = load(quote!(zg));
    let z1 = if two_point {
        let z1 = load(quote!(zg1));
        quote!(let z1: [f64; #local_dim] = #z1;)
    } else {
        quote!()
    };
    quote! {
        let z: [f64; #local_dim] = #z;
        #z1
    }
}
