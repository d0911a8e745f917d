//! The `hamiltonian!` proc macro. Use it through the `dth` crate, which documents the grammar.
//!
//! Routing only: `parse` reads the input (expression or item form) and maps the expression's
//! tokens to a source string for the engine, `check` runs the engine and the item-form rules,
//! `expand` emits the trait implementation, `fallback` emits a stub beside the errors.

use proc_macro::TokenStream;

mod check;
mod code;
mod expand;
mod fallback;
mod parse;

/// Generates a type implementing `dth::Hamiltonian<D>` from a Hamiltonian written as a math
/// literal, with exact compiled derivatives. The grammar is documented in the `Grammar`
/// section of the `dth` crate.
#[proc_macro]
pub fn hamiltonian(input: TokenStream) -> TokenStream {
    syn::parse::<parse::Input>(input)
        .map(expand::expand)
        .unwrap_or_else(syn::Error::into_compile_error)
        .into()
}
