//! The `hamiltonian!` proc macro. Use it through the `dth` crate, which documents the grammar.

use proc_macro::TokenStream;

/// See `dth::hamiltonian!`.
#[proc_macro]
pub fn hamiltonian(input: TokenStream) -> TokenStream {
    let input = proc_macro2::TokenStream::from(input);
    syn::Error::new_spanned(input, "hamiltonian! is not implemented yet")
        .into_compile_error()
        .into()
}
