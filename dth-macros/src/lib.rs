//! The `hamiltonian!` proc macro. Use it through the `dth` crate, which documents the grammar.
//!
//! `lib.rs` only routes. The stages, each importing only from those before it:
//!
//! 1. `parse`: reads the input (expression or item form) and maps the expression's tokens to a
//!    source string for the engine; a broken item header is kept as far as it was read.
//! 2. `check`: runs the engine (`dth_symbolic`) and the item form's rules, collecting every
//!    error.
//! 3. `fallback`: the declared type and a stub implementation, emitted beside the errors.
//! 4. `warning`: the engine's warnings (legal but suspicious input) as compiler warnings.
//! 5. `expand`: the declaration, the trait implementation and the warnings. The
//!    implementation's code is written by the engine's emitter (`dth_symbolic::emit`, a plain
//!    library so other tools print the same code).

use proc_macro::TokenStream;

mod check;
mod expand;
mod fallback;
mod parse;
mod warning;

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
