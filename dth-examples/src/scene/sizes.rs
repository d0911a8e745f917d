//! `[system] sizes = { N = 4096 }`: the sizes of a Hamiltonian given as text, set in the
//! scene so that one text serves every size.
//!
//! A size the text declares after `where` (`where N = 32, q[0] = q[N+1] = 0`) takes the
//! scene's value in place of the text's; a size the text uses but does not declare is
//! declared with it (`where` added when the text has none). A name the text does not use at
//! all is an error at its key. The engine then reads the text as written with these values,
//! so every rule and limit is the engine's: a size beyond what the lattice allows
//! (`dth_symbolic::MAX_SITES` sites for sums that loop) is the engine's one error, reported at
//! the size's value in the scene.

use std::collections::BTreeMap;
use std::ops::Range;

use dth_symbolic::lexer::{lex, TokenKind};
use dth_symbolic::parser::{parse, Ast, Decl};
use toml::Spanned;

use super::members::Errors;

/// One change to the text: `original` (empty for an insertion) became `text`, for the size
/// whose value is at `value` in the scene file.
#[derive(Debug, Clone)]
struct Edit {
    original: Range<usize>,
    text: String,
    value: Range<usize>,
}

/// A text with the scene's sizes in it, and where each of its bytes came from.
#[derive(Debug, Clone)]
pub(super) struct Sized {
    /// The text the engine reads.
    pub source: String,
    /// The changes, in the order of the original text.
    edits: Vec<Edit>,
}

/// Where a byte range of [`Sized::source`] came from.
#[derive(Debug, Clone, PartialEq)]
pub(super) enum Origin {
    /// The original text's bytes.
    Text(Range<usize>),
    /// A size's value set by the scene: its place in the scene file.
    Scene(Range<usize>),
}

impl Sized {
    /// Where `range` of [`Sized::source`] came from: an error inside a size the scene set is
    /// about the scene's value.
    pub(super) fn origin(&self, range: Range<usize>) -> Origin {
        let mut shift: isize = 0;
        let back = |x: usize, shift: isize| (x as isize - shift).max(0) as usize;
        for e in &self.edits {
            let start = (e.original.start as isize + shift) as usize;
            let end = start + e.text.len();
            if range.start < start {
                break;
            }
            if range.start < end {
                return Origin::Scene(e.value.clone());
            }
            shift += e.text.len() as isize - e.original.len() as isize;
        }
        Origin::Text(back(range.start, shift)..back(range.end, shift).max(back(range.start, shift)))
    }
}

/// `source` with the sizes `sizes` (the scene's `[system] sizes`), or `None` with the errors
/// (file ranges) pushed to `errors`. No sizes: the text as it is.
pub(super) fn apply(
    source: &str,
    sizes: &BTreeMap<Spanned<String>, Spanned<i64>>,
    errors: &mut Errors,
) -> Option<Sized> {
    let mut sized = Sized {
        source: source.to_string(),
        edits: Vec::new(),
    };
    if sizes.is_empty() {
        return Some(sized);
    }
    let (tokens, _) = lex(source);
    let (ast, _) = parse(source, &tokens);
    // The declared sizes (name -> value range), and where a new declaration goes.
    let mut declared: Vec<(String, Range<usize>)> = Vec::new();
    let mut insert_at = None;
    if let Some(Ast::Where { decls, .. }) = &ast {
        for d in decls {
            if let Decl::Constant { name, value } = d {
                declared.push((source[name.range()].to_string(), value.span().range()));
            }
        }
        // Just after the word `where`: before any boundary that uses the size.
        insert_at = tokens
            .iter()
            .find(|t| t.kind == TokenKind::Ident && &source[t.span.range()] == "where")
            .map(|t| t.span.end);
    }
    let used = |name: &str| {
        tokens
            .iter()
            .any(|t| t.kind == TokenKind::Ident && &source[t.span.range()] == name)
    };
    let mut ok = true;
    let mut new_decls = Vec::new();
    for (name, value) in sizes {
        let (name_str, v) = (name.get_ref().as_str(), *value.get_ref());
        if v < 0 {
            errors.push((
                value.span(),
                format!("size `{name_str}` = {v}: a size is a whole number, 0 or more"),
            ));
            ok = false;
            continue;
        }
        match declared.iter().find(|(n, _)| n == name_str) {
            Some((_, range)) => sized.edits.push(Edit {
                original: range.clone(),
                text: v.to_string(),
                value: value.span(),
            }),
            None if used(name_str) => new_decls.push((name_str, v, value.span())),
            None => {
                let names: Vec<String> = declared.iter().map(|(n, _)| format!("`{n}`")).collect();
                errors.push((
                    name.span(),
                    format!(
                        "size `{name_str}` is not a name the Hamiltonian uses: {}",
                        if names.is_empty() {
                            "it declares no size (`where N = ..`)".to_string()
                        } else {
                            format!("it declares {}", names.join(", "))
                        }
                    ),
                ));
                ok = false;
            }
        }
    }
    if !ok {
        return None;
    }
    for (k, (name, v, value)) in new_decls.into_iter().enumerate() {
        let (at, text) = match insert_at {
            Some(at) => (at, format!(" {name} = {v},")),
            None if k == 0 => (source.len(), format!(" where {name} = {v}")),
            None => (source.len(), format!(", {name} = {v}")),
        };
        sized.edits.push(Edit {
            original: at..at,
            text,
            value,
        });
    }
    // Stable: insertions at one place stay in the order made.
    sized.edits.sort_by_key(|e| e.original.start);
    let mut out = String::with_capacity(source.len() + 16);
    let mut from = 0;
    for e in &sized.edits {
        out.push_str(&source[from..e.original.start]);
        out.push_str(&e.text);
        from = e.original.end;
    }
    out.push_str(&source[from..]);
    sized.source = out;
    Some(sized)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// The `[system]` table's `sizes` of a scene line, with the line itself (the spans are
    /// byte ranges of it).
    fn sizes(line: &str) -> BTreeMap<Spanned<String>, Spanned<i64>> {
        #[derive(serde::Deserialize)]
        struct T {
            sizes: BTreeMap<Spanned<String>, Spanned<i64>>,
        }
        toml::from_str::<T>(line).unwrap().sizes
    }

    const CHAIN: &str = "sum(i = 1..N, p[i]^2/2) + sum(i = 0..N, (q[i+1] - q[i])^2/2) where N = 32, q[0] = q[N+1] = 0";

    #[test]
    fn a_declared_size_takes_the_scenes_value() {
        let mut errors = Vec::new();
        let line = "sizes = { N = 4096 }";
        let s = apply(CHAIN, &sizes(line), &mut errors).unwrap();
        assert!(errors.is_empty(), "{errors:?}");
        assert_eq!(s.source, CHAIN.replace("N = 32", "N = 4096"));
        // The new value's bytes are the scene's; text after it maps back to the original.
        let at = s.source.find("4096").unwrap();
        assert_eq!(s.origin(at..at + 4), Origin::Scene(14..18));
        let q0 = s.source.find("q[0]").unwrap();
        assert_eq!(
            s.origin(q0..q0 + 4),
            Origin::Text(CHAIN.find("q[0]").unwrap()..CHAIN.find("q[0]").unwrap() + 4)
        );
        // Before the edit, nothing moves.
        assert_eq!(s.origin(0..3), Origin::Text(0..3));
    }

    #[test]
    fn a_used_size_the_text_does_not_declare_is_declared() {
        let mut errors = Vec::new();
        let text = "sum(i = 1..N, p[i]^2/2 + q[i]^2/2)";
        let s = apply(text, &sizes("sizes = { N = 5 }"), &mut errors).unwrap();
        assert_eq!(s.source, format!("{text} where N = 5"));
        let with_where = "sum(i = 1..N, p[i]^2/2 + q[i]^2/2) where q[0] = 0";
        let s = apply(with_where, &sizes("sizes = { N = 5 }"), &mut errors).unwrap();
        assert_eq!(
            s.source,
            "sum(i = 1..N, p[i]^2/2 + q[i]^2/2) where N = 5, q[0] = 0"
        );
        assert!(errors.is_empty(), "{errors:?}");
        // The text read with it is the engine's lattice of 5 sites.
        let h = dth::runtime::RuntimeHamiltonian::new(&s.source, &[]).unwrap();
        assert_eq!(h.dimension(), 10);
    }

    #[test]
    fn an_unused_or_negative_size_is_an_error_at_its_key_or_value() {
        let mut errors = Vec::new();
        let line = "sizes = { M = 4, N = -1 }";
        assert!(apply(CHAIN, &sizes(line), &mut errors).is_none());
        assert_eq!(errors.len(), 2, "{errors:?}");
        assert_eq!(errors[0].0, 10..11, "{errors:?}");
        assert!(errors[0]
            .1
            .contains("`M` is not a name the Hamiltonian uses: it declares `N`"));
        assert_eq!(errors[1].0, 21..23, "{errors:?}");
        assert!(errors[1].1.contains("0 or more"), "{errors:?}");
    }

    #[test]
    fn no_sizes_leave_the_text_as_it_is() {
        let mut errors = Vec::new();
        let s = apply(CHAIN, &BTreeMap::new(), &mut errors).unwrap();
        assert_eq!(s.source, CHAIN);
        assert_eq!(s.origin(5..9), Origin::Text(5..9));
    }
}
