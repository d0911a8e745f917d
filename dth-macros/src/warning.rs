//! The engine's warnings as compiler warnings. Stable Rust has no warning API for proc
//! macros, so each is the use of a `#[deprecated]` constant whose note is the message, spanned
//! on the user's token: `warning: use of deprecated constant ...: <message>`. The user's
//! `#[allow(deprecated)]` silences it: on the enclosing function for the expression form, on
//! the declared struct for the item form (its `allow` attributes are copied here).

use dth_symbolic::Warning;
use proc_macro2::TokenStream;
use quote::{quote, quote_spanned};

use crate::parse::Input;

/// One `const _` per warning (of the written-out system, or of the lattice compiled to
/// loops), empty when there are none. rustc underlines the constant's use, one token: the
/// first of what the warning is about (`q` of `q[i]`; stable proc macros cannot join spans).
pub fn warnings(input: &Input, warnings: &[Warning]) -> TokenStream {
    let allows = input.item.iter().flat_map(|header| {
        header
            .attrs
            .iter()
            .filter(|a| a.path().is_ident("allow") || a.path().is_ident("expect"))
    });
    let allows: Vec<_> = allows.collect();
    warnings
        .iter()
        .map(|w| {
            let note = w.to_string();
            let (at, _) = input.body.spans(w.span.range());
            let usage = quote_spanned!(at=> hamiltonian_warning);
            quote! {
                #(#allows)*
                const _: () = {
                    #[deprecated(note = #note)]
                    #[allow(non_upper_case_globals)]
                    const hamiltonian_warning: () = ();
                    #usage
                };
            }
        })
        .collect()
}
