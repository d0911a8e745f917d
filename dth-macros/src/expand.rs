//! The whole expansion: the declared type, its `impl Hamiltonian<Const<D>>` (written by the engine's
//! emitter, `dth_symbolic::emit`) and the warnings; or the errors beside a stub.

use dth_symbolic::emit::{hamiltonian_impl, looped_source_impl};
use dth_symbolic::{System, Warning};
use proc_macro2::TokenStream;
use quote::quote;
use syn::Ident;

use crate::check;
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
    // A lattice of sums is emitted as loops, its code independent of the number of sites (a
    // regularized Hamiltonian is planar: never a lattice).
    let regularized = input.item.as_ref().is_some_and(|h| h.regularize.is_some());
    if errors.is_empty() && !regularized {
        let (decl, name) = fallback::declaration(&input, &params);
        if let Some(imp) = looped_source_impl(&input.body.source, &name, &params) {
            let warnings = warnings(&input, &looped_warnings(&input, &params));
            return wrap(&input, decl, name, imp, warnings);
        }
    }
    let system = check::system(&input, &params, &mut errors);
    match (check::combine(errors), system) {
        (None, Some(system)) => implementation(&input, &params, &system),
        (error, _) => fallback::stub(&input, error.map(|e| e.to_compile_error())),
    }
}

/// The type declaration and its implementation.
fn implementation(input: &Input, params: &[Ident], system: &System) -> TokenStream {
    let (decl, name) = fallback::declaration(input, params);
    let imp = hamiltonian_impl(system, &name, params);
    let warnings = warnings(input, system.warnings());
    wrap(input, decl, name, imp, warnings)
}

/// The warnings of a lattice compiled to loops: the written-out path's, decided on the
/// ranges (`looped_source_impl` compiled it already; compiling again costs what the loops'
/// engine costs, the same at any number of sites).
fn looped_warnings(input: &Input, params: &[Ident]) -> Vec<Warning> {
    let names: Vec<String> = params.iter().map(Ident::to_string).collect();
    let names: Vec<&str> = names.iter().map(String::as_str).collect();
    dth_symbolic::looped::compile(&input.body.source, &names)
        .map(|l| l.warnings().to_vec())
        .unwrap_or_default()
}

/// The declaration, the implementation and the warnings, as an item or an expression.
fn wrap(
    input: &Input,
    decl: TokenStream,
    name: Ident,
    imp: TokenStream,
    warnings: TokenStream,
) -> TokenStream {
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
