//! The engine's warnings as compiler warnings. Stable Rust has no warning API for proc
//! macros, so each is the use of a `#[deprecated]` constant, spanned on the user's token. rustc
//! words it ``warning: use of deprecated constant `_::NAME`: NOTE``; the name says what
//! looks wrong (`position_without_momentum`, `misnumbered_index`) and the note starts with
//! [`NOTE`], which says it is the macro's warning and how to silence it, then the message:
//!
//! ```text
//! warning: use of deprecated constant `_::position_without_momentum`: a warning from
//! `hamiltonian!`, not a deprecation (`#[allow(deprecated)]` silences it): `q2` appears
//! without `p2`: ...
//! ```
//!
//! The user's `#[allow(deprecated)]` silences it: on the enclosing function for the expression
//! form, on the declared struct for the item form (its `allow` attributes are copied here).

use dth_symbolic::{Warning, WarningKind};
use proc_macro2::{Ident, TokenStream};
use quote::{quote, quote_spanned};

use crate::parse::Input;

/// What each warning's note says before the engine's message (tests find the message after
/// it).
pub const NOTE: &str =
    "a warning from `hamiltonian!`, not a deprecation (`#[allow(deprecated)]` silences it): ";

/// The constant's name, which rustc prints: what looks wrong.
fn name(kind: &WarningKind) -> &'static str {
    match kind {
        WarningKind::FrozenCoordinate { .. } | WarningKind::FrozenCoordinates { .. } => {
            "position_without_momentum"
        }
        WarningKind::Misnumbered { .. } | WarningKind::MisnumberedMomenta { .. } => {
            "misnumbered_index"
        }
        _ => "suspicious_hamiltonian",
    }
}

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
            let note = format!("{NOTE}{w}");
            let (at, _) = input.body.spans(w.span.range());
            let constant = Ident::new(name(&w.kind), at);
            let usage = quote_spanned!(at=> #constant);
            quote! {
                #(#allows)*
                const _: () = {
                    #[deprecated(note = #note)]
                    #[allow(non_upper_case_globals)]
                    const #constant: () = ();
                    #usage
                };
            }
        })
        .collect()
}
