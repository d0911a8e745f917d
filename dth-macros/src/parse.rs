//! Reads the macro input: `hamiltonian!(expr)` or
//! `hamiltonian! { #[attrs] pub struct Name { a: f64, .. } = expr }`, and maps the expression's
//! tokens to a source string, remembering which byte range each token became.

use std::ops::Range;

use proc_macro2::{Delimiter, Span, TokenStream, TokenTree};
use syn::parse::{Parse, ParseStream};
use syn::{Attribute, Ident, Token, Type, Visibility};

/// The whole input.
pub struct Input {
    /// The item form's header, if any.
    pub item: Option<Header>,
    /// The Hamiltonian.
    pub body: Body,
}

/// `#[attrs] vis struct Name { params }`.
pub struct Header {
    /// The attributes passed to the struct (without `#[regularize(..)]`).
    pub attrs: Vec<Attribute>,
    /// `#[regularize(levi_civita)]` or `#[regularize(kustaanheimo_stiefel)]`: the type is the
    /// regularized `K` of the expression.
    pub regularize: Option<Regularize>,
    pub vis: Visibility,
    pub ident: Ident,
    pub params: Vec<Param>,
    /// `false` for `struct Name = ...`, declared as a unit struct.
    pub braced: bool,
    /// Mistakes after the name. The header is still read as far as it goes, so the fallback
    /// declares the type (with every parameter name read) and these are the only errors.
    pub errors: Vec<syn::Error>,
    /// Names of parameters whose declaration did not parse: declared by the fallback only.
    pub unparsed: Vec<Ident>,
    /// The fields of a tuple struct `Name(..)` (an error): the fallback declares them as
    /// written, so code constructing the type adds no error.
    pub tuple: Option<syn::FieldsUnnamed>,
}

/// A regularization the item form asks for with `#[regularize(..)]`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Regularize {
    /// Levi-Civita (`dth_symbolic::regularize::levi_civita`).
    LeviCivita,
    /// Kustaanheimo-Stiefel (`dth_symbolic::regularize::kustaanheimo_stiefel`).
    KustaanheimoStiefel,
}

/// One declared parameter `vis name: ty`.
pub struct Param {
    pub attrs: Vec<Attribute>,
    pub vis: Visibility,
    pub ident: Ident,
    pub ty: Type,
}

/// The expression as the engine sees it, and the way back to tokens.
pub struct Body {
    /// The expression tokens joined by spaces.
    pub source: String,
    /// Each token's byte range in `source` and its span, in order.
    pub tokens: Vec<(Range<usize>, Span)>,
    /// Problems found while flattening (`[]` or `{}` used for grouping).
    pub errors: Vec<syn::Error>,
    /// The last token pushed was a punctuation joined to the next one (`.` of `..`, `<` of
    /// `<=`): the next token follows without a space, so the engine reads one operator.
    joint: bool,
}

impl Parse for Input {
    fn parse(input: ParseStream) -> syn::Result<Self> {
        let item = if input.peek(Token![#]) || input.peek(Token![pub]) || input.peek(Token![struct])
        {
            Some(header(input)?)
        } else {
            None
        };
        let mut rest: Vec<TokenTree> = input.parse::<TokenStream>()?.into_iter().collect();
        if item.is_some() && matches!(rest.last(), Some(TokenTree::Punct(p)) if p.as_char() == ';')
        {
            rest.pop();
        }
        let mut body = Body {
            source: String::new(),
            tokens: Vec::new(),
            errors: Vec::new(),
            joint: false,
        };
        body.flatten(rest);
        Ok(Input { item, body })
    }
}

/// The header. Only a header without a name is an error here (there is nothing to declare);
/// after the name, mistakes are collected in [`Header::errors`] and reading goes on where it
/// can, the rest of the input becoming the body.
fn header(input: ParseStream) -> syn::Result<Header> {
    let mut attrs = input.call(Attribute::parse_outer)?;
    let mut errors = Vec::new();
    let mut regularize = None;
    attrs.retain(|a| {
        if !a.path().is_ident("regularize") {
            return true;
        }
        match a.parse_args::<Ident>() {
            Ok(name) if name == "levi_civita" => regularize = Some(Regularize::LeviCivita),
            Ok(name) if name == "kustaanheimo_stiefel" => {
                regularize = Some(Regularize::KustaanheimoStiefel)
            }
            Ok(name) => errors.push(syn::Error::new(
                name.span(),
                format!(
                    "unknown regularization `{name}`: the ones there are, `levi_civita` (planar) and `kustaanheimo_stiefel` (spatial)"
                ),
            )),
            Err(_) => errors.push(syn::Error::new_spanned(
                a,
                "expected `#[regularize(levi_civita)]` or `#[regularize(kustaanheimo_stiefel)]`",
            )),
        }
        false
    });
    let vis: Visibility = input.parse()?;
    input.parse::<Token![struct]>()?;
    let ident: Ident = input
        .parse()
        .map_err(|e| syn::Error::new(e.span(), "expected the type's name after `struct`"))?;
    let mut header = Header {
        attrs,
        regularize,
        vis,
        ident,
        params: Vec::new(),
        braced: false,
        errors,
        unparsed: Vec::new(),
        tuple: None,
    };
    if input.peek(Token![<]) {
        header.errors.push(input.error("a Hamiltonian type takes no generic parameters: declare named `f64` parameters in `{ ... }`"));
        // Read past the generics, so the parameters are still declared.
        if input.parse::<syn::Generics>().is_err() {
            return Ok(header);
        }
    }
    if input.peek(syn::token::Brace) {
        header.braced = true;
        let content;
        syn::braced!(content in input);
        params(&content, &mut header);
    } else if input.peek(syn::token::Paren) {
        header.errors.push(input.error("expected named parameters `{ name: f64, ... }`: tuple structs cannot name their parameters in the Hamiltonian"));
        match input.parse::<syn::FieldsUnnamed>() {
            Ok(fields) => header.tuple = Some(fields),
            Err(_) => return Ok(header),
        }
    }
    if let Err(e) = input.parse::<Token![=]>() {
        header.errors.push(syn::Error::new(
            e.span(),
            "expected `=` and the Hamiltonian: the item form is `struct Name { param: f64, .. } = <Hamiltonian>`",
        ));
    }
    Ok(header)
}

/// The parameters `vis name: ty, ..`. A declaration that does not parse is an error in
/// `header.errors` (its name, if read, goes to `header.unparsed`), and reading resumes after
/// the next comma.
fn params(content: ParseStream, header: &mut Header) {
    while !content.is_empty() {
        let mut name = None;
        let param = (|| {
            let attrs = content.call(Attribute::parse_outer)?;
            let vis: Visibility = content.parse()?;
            let ident: Ident = content.parse()?;
            name = Some(ident.clone());
            content.parse::<Token![:]>().map_err(|e| {
                syn::Error::new(
                    e.span(),
                    "expected `:` and the type after the parameter's name: parameters are declared `name: f64`",
                )
            })?;
            let ty: Type = content.parse()?;
            if !content.is_empty() {
                content.parse::<Token![,]>()?;
            }
            Ok(Param {
                attrs,
                vis,
                ident,
                ty,
            })
        })();
        match param {
            Ok(p) => header.params.push(p),
            Err(e) => {
                header.errors.push(e);
                header.unparsed.extend(name);
                // Skip to the next parameter; every token is consumed (syn rejects leftovers).
                while !content.is_empty() && !content.peek(Token![,]) {
                    let _ = content.parse::<TokenTree>();
                }
                let _ = content.parse::<Option<Token![,]>>();
            }
        }
    }
}

impl Body {
    fn push(&mut self, text: &str, span: Span) {
        if !self.source.is_empty() && !self.joint {
            self.source.push(' ');
        }
        self.joint = false;
        let start = self.source.len();
        self.source.push_str(text);
        self.tokens.push((start..self.source.len(), span));
    }

    fn flatten(&mut self, tokens: impl IntoIterator<Item = TokenTree>) {
        for tt in tokens {
            match tt {
                TokenTree::Ident(i) => self.push(&i.to_string(), i.span()),
                TokenTree::Punct(p) => {
                    self.push(&p.as_char().to_string(), p.span());
                    self.joint = p.spacing() == proc_macro2::Spacing::Joint;
                }
                TokenTree::Literal(l) => self.push(&l.to_string(), l.span()),
                TokenTree::Group(g) => {
                    // Brackets and braces go to the engine as written: it owns the grammar and
                    // its errors (the same ones for text given at run time).
                    let ((open, close), (l, r)) = match g.delimiter() {
                        Delimiter::Parenthesis => ((g.span_open(), g.span_close()), ("(", ")")),
                        // An invisible group comes from a `macro_rules!` fragment: it is one operand.
                        Delimiter::None => ((g.span(), g.span()), ("(", ")")),
                        Delimiter::Bracket => ((g.span_open(), g.span_close()), ("[", "]")),
                        Delimiter::Brace => ((g.span_open(), g.span_close()), ("{", "}")),
                    };
                    self.push(l, open);
                    self.flatten(g.stream());
                    self.push(r, close);
                }
            }
        }
    }

    /// A `syn::Error` covering the tokens that produced `bytes` of the source.
    pub fn error(&self, bytes: Range<usize>, message: impl std::fmt::Display) -> syn::Error {
        let (first, last) = self.spans(bytes);
        // `new_spanned` underlines from the first token's start to the last one's end.
        let mut range = TokenStream::new();
        range.extend([
            TokenTree::Ident(Ident::new("first", first)),
            TokenTree::Ident(Ident::new("last", last)),
        ]);
        syn::Error::new_spanned(range, message)
    }

    /// The spans of the first and last tokens that overlap the source bytes `bytes`.
    pub fn spans(&self, bytes: Range<usize>) -> (Span, Span) {
        let hit =
            |r: &Range<usize>| r.start < bytes.end.max(bytes.start + 1) && bytes.start < r.end;
        let first = self.tokens.iter().position(|(r, _)| hit(r));
        let last = self.tokens.iter().rposition(|(r, _)| hit(r));
        match (first, last) {
            (Some(f), Some(l)) => (self.tokens[f].1, self.tokens[l].1),
            // An empty range at the end (e.g. a missing operand): the last token.
            _ => match self.tokens.last() {
                Some((_, s)) => (*s, *s),
                None => (Span::call_site(), Span::call_site()),
            },
        }
    }
}
