//! The rules of the item form, and the engine's verdict on the expression, as `syn` errors.
//! Every independent error is collected and combined once.

use dth_symbolic::System;
use syn::{Ident, Type};

use crate::parse::{Input, Regularize};

/// The declared parameters that passed their checks (each name once).
pub fn params(input: &Input, errors: &mut Vec<syn::Error>) -> Vec<Ident> {
    let mut ok: Vec<Ident> = Vec::new();
    let Some(header) = &input.item else { return ok };
    for p in &header.params {
        // Parameters are read at run time as plain numbers: anything but `f64` would need
        // conversions the generated arithmetic cannot see.
        if !is_f64(&p.ty) {
            errors.push(syn::Error::new_spanned(
                &p.ty,
                format!("parameter `{}` must have type `f64`", p.ident),
            ));
        }
        let name = p.ident.to_string();
        // A parameter named like a variable, `pi` or a function would be ambiguous.
        if let Some(reason) = dth_symbolic::reserved_name(&name) {
            errors.push(syn::Error::new(
                p.ident.span(),
                format!("parameter `{name}` {reason}: parameters need their own names"),
            ));
        } else if ok.contains(&p.ident) {
            errors.push(syn::Error::new(
                p.ident.span(),
                format!("parameter `{name}` is declared twice"),
            ));
        } else {
            ok.push(p.ident.clone());
        }
    }
    ok
}

fn is_f64(ty: &Type) -> bool {
    matches!(ty, Type::Path(p) if p.qself.is_none() && p.path.is_ident("f64"))
}

/// Compiles the expression; engine errors land on the tokens they came from.
pub fn system(input: &Input, params: &[Ident], errors: &mut Vec<syn::Error>) -> Option<System> {
    let names: Vec<String> = params.iter().map(|p| p.to_string()).collect();
    let names: Vec<&str> = names.iter().map(String::as_str).collect();
    let body = &input.body;
    let regularize = input.item.as_ref().and_then(|h| h.regularize);
    let compiled = match regularize {
        Some(Regularize::LeviCivita) => dth_symbolic::regularize::levi_civita(&body.source, &names),
        Some(Regularize::KustaanheimoStiefel) => {
            dth_symbolic::regularize::kustaanheimo_stiefel(&body.source, &names)
        }
        None => dth_symbolic::compile(&body.source, &names),
    };
    match compiled {
        Ok(system) => Some(system),
        Err(engine) => {
            errors.extend(engine.0.iter().map(|e| body.error(e.span.range(), e)));
            None
        }
    }
}

/// All errors as one.
pub fn combine(errors: Vec<syn::Error>) -> Option<syn::Error> {
    errors.into_iter().reduce(|mut a, b| {
        a.combine(b);
        a
    })
}
