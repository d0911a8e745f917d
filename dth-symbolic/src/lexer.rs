//! Lexer: `&str` to tokens with byte spans. Every bad character is reported, not just the first.

use crate::error::{Error, ErrorKind};
use crate::span::Span;

/// The kind of a token; its text is `&source[span]`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum TokenKind {
    /// A numeric literal (validated later, so its errors carry its span).
    Number,
    /// A name: variable, parameter, function or `pi`.
    Ident,
    /// `+`
    Plus,
    /// `-`
    Minus,
    /// `*`
    Star,
    /// `/`
    Slash,
    /// `^`
    Caret,
    /// `(`
    LParen,
    /// `)`
    RParen,
    /// `,`: separates a sum's range from its summand and the declarations after `where`; no
    /// function takes two arguments, but `cos(q1, q2)` and `pow(q1, 2)` are read so their
    /// errors can say what to write instead.
    Comma,
    /// `[`: an index, `q[i + 1]` (the parser reports one used for grouping).
    LBracket,
    /// `]`
    RBracket,
    /// `=`: a sum's index takes its range, a constant or a boundary its value.
    Eq,
    /// `<`: the pairs `i < j` of a sum over pairs.
    Lt,
    /// `<=`: the bounds of a sum over pairs, `1 <= i < j <= N`.
    Le,
    /// `..`: an index range, `1..N` (both ends included).
    DotDot,
}

/// A token and its byte range.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Token {
    /// What it is.
    pub kind: TokenKind,
    /// Where it is.
    pub span: Span,
}

/// Splits `src` into tokens, accumulating one error per unexpected character.
pub fn lex(src: &str) -> (Vec<Token>, Vec<Error>) {
    let bytes = src.as_bytes();
    let mut tokens = Vec::new();
    let mut errors = Vec::new();
    // The closing brackets of the groups reported so far.
    let mut closers = Vec::new();
    let mut i = 0;
    while i < bytes.len() {
        let c = bytes[i];
        let start = i;
        let single = match c {
            b'+' => Some(TokenKind::Plus),
            b'-' => Some(TokenKind::Minus),
            b'*' => Some(TokenKind::Star),
            b'/' => Some(TokenKind::Slash),
            b'^' => Some(TokenKind::Caret),
            b'(' => Some(TokenKind::LParen),
            b')' => Some(TokenKind::RParen),
            b',' => Some(TokenKind::Comma),
            b'[' => Some(TokenKind::LBracket),
            b']' => Some(TokenKind::RBracket),
            b'=' => Some(TokenKind::Eq),
            b'<' if bytes.get(i + 1) == Some(&b'=') => Some(TokenKind::Le),
            b'<' => Some(TokenKind::Lt),
            b'.' if bytes.get(i + 1) == Some(&b'.') => Some(TokenKind::DotDot),
            _ => None,
        };
        if let Some(kind) = single {
            i += if matches!(kind, TokenKind::Le | TokenKind::DotDot) {
                2
            } else {
                1
            };
            tokens.push(Token {
                kind,
                span: Span::new(start, i),
            });
        } else if c.is_ascii_whitespace() {
            i += 1;
        } else if c.is_ascii_digit() {
            // Digits, a fraction, an exponent with its sign; then any letters glued on (a
            // suffix, `2q1`) so the whole run is reported as one invalid number.
            i += 1;
            while i < bytes.len() {
                let b = bytes[i];
                if b == b'.' && bytes.get(i + 1) == Some(&b'.') {
                    // `1..N`: the number ends before the range.
                    break;
                }
                let exp_sign = (b == b'+' || b == b'-')
                    && matches!(bytes[i - 1], b'e' | b'E')
                    && bytes[start..i - 1]
                        .iter()
                        .all(|d| d.is_ascii_digit() || *d == b'.');
                if b.is_ascii_alphanumeric() || b == b'.' || b == b'_' || exp_sign {
                    i += 1;
                } else {
                    break;
                }
            }
            tokens.push(Token {
                kind: TokenKind::Number,
                span: Span::new(start, i),
            });
        } else if c.is_ascii_alphabetic() || c == b'_' {
            while i < bytes.len() && (bytes[i].is_ascii_alphanumeric() || bytes[i] == b'_') {
                i += 1;
            }
            tokens.push(Token {
                kind: TokenKind::Ident,
                span: Span::new(start, i),
            });
        } else if c == b'{' {
            // A group in braces: one error over the whole group (what `hamiltonian!`, which
            // sees one Rust group, reports), read on as parenthesized.
            let close = group_end(bytes, i);
            let end = close.map_or(i + 1, |j| j + 1);
            errors.push(Error::new(ErrorKind::Brackets, Span::new(start, end)));
            closers.extend(close);
            i += 1;
            tokens.push(Token {
                kind: TokenKind::LParen,
                span: Span::new(start, i),
            });
        } else if closers.contains(&i) {
            i += 1;
            tokens.push(Token {
                kind: TokenKind::RParen,
                span: Span::new(start, i),
            });
        } else if c == b'"' {
            // A string literal: one error over all of it, as on the one Rust token the macro
            // sees, not one per quote.
            i = src[i + 1..].find('"').map_or(bytes.len(), |k| i + k + 2);
            errors.push(Error::new(
                ErrorKind::UnexpectedChar { ch: '"' },
                Span::new(start, i),
            ));
        } else {
            let ch = src[i..].chars().next().unwrap_or('?');
            i += ch.len_utf8();
            errors.push(Error::new(
                ErrorKind::UnexpectedChar { ch },
                Span::new(start, i),
            ));
        }
    }
    (tokens, errors)
}

/// The index of the bracket closing the one at `open`, counting every kind of bracket.
fn group_end(bytes: &[u8], open: usize) -> Option<usize> {
    let mut depth = 0usize;
    for (j, &b) in bytes.iter().enumerate().skip(open) {
        match b {
            b'(' | b'[' | b'{' => depth += 1,
            b')' | b']' | b'}' => {
                depth -= 1;
                if depth == 0 {
                    return Some(j);
                }
            }
            _ => {}
        }
    }
    None
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn scientific_literals_are_one_token() {
        let (t, e) = lex("2.5e-3*q1^-2");
        assert!(e.is_empty());
        assert_eq!(
            t[0],
            Token {
                kind: TokenKind::Number,
                span: Span::new(0, 6)
            }
        );
        assert_eq!(t.len(), 6);
    }

    #[test]
    fn a_brace_group_and_a_string_are_one_error_each() {
        let (t, e) = lex("p1^2 + {q1 + {q2}}^2 + \"q1\" + q2}");
        let spans: Vec<(ErrorKind, Span)> = e.into_iter().map(|e| (e.kind, e.span)).collect();
        assert_eq!(
            spans,
            vec![
                (ErrorKind::Brackets, Span::new(7, 18)),
                (ErrorKind::Brackets, Span::new(13, 17)),
                (ErrorKind::UnexpectedChar { ch: '"' }, Span::new(23, 27)),
                (ErrorKind::UnexpectedChar { ch: '}' }, Span::new(32, 33)),
            ]
        );
        // The groups read as parentheses.
        let parens = t.iter().filter(|t| t.kind == TokenKind::LParen).count();
        assert_eq!(
            parens,
            t.iter().filter(|t| t.kind == TokenKind::RParen).count()
        );
        assert_eq!(parens, 2);
    }

    #[test]
    fn ranges_comparisons_and_indices_are_tokens() {
        let (t, e) = lex("sum(1 <= i < j <= 10, q[i]) where N = 2..3");
        assert!(e.is_empty());
        let kinds: Vec<TokenKind> = t.iter().map(|t| t.kind).collect();
        use TokenKind::*;
        assert_eq!(
            kinds,
            [
                Ident, LParen, Number, Le, Ident, Lt, Ident, Le, Number, Comma, Ident, LBracket,
                Ident, RBracket, RParen, Ident, Ident, Eq, Number, DotDot, Number
            ]
        );
        // `1..N` is the literal `1`, not `1.` followed by `.N`.
        assert_eq!(t[18].span, Span::new(38, 39));
    }

    #[test]
    fn every_bad_character_is_reported() {
        let (_, e) = lex("q1 $ p1 # 2");
        assert_eq!(e.len(), 2);
        assert_eq!(e[1].span, Span::new(8, 9));
    }
}
