//! Where each byte of a TOML string's value comes from in the file, so that an error the
//! symbolic engine reports at a byte of the decoded expression is shown at the character the
//! user wrote (`file:line:column` inside the string).
//!
//! The four TOML string forms are decoded as TOML 1.1 (the `toml` crate's) decodes them:
//!
//! - basic `"..."`: escapes `\b \t \n \f \r \e \" \\ \xHH \uHHHH \UHHHHHHHH`; every byte an
//!   escape produces maps to its backslash;
//! - literal `'...'`: no escapes, one byte for one byte;
//! - multi-line basic `"""..."""`: a newline right after the opening delimiter is dropped,
//!   escapes as in a basic string, and a line-ending backslash drops the newline and every
//!   space, tab and newline after it (a line continuation);
//! - multi-line literal `'''...'''`: the first newline dropped, no escapes.
//!
//! [`StringPositions::new`] decodes the literal as written in the file and returns `None`
//! unless the result is the value the TOML parser produced (which then cannot be
//! mis-mapped): the caller falls back to the string's opening quote.

use std::ops::Range;

/// The file offset of each byte of a TOML string's value.
#[derive(Debug, Clone, PartialEq, Eq)]
pub(super) struct StringPositions {
    /// `offsets[i]`: the file offset of the character that produced byte `i` of the value;
    /// one more entry, the offset of the closing delimiter, for a position at the end.
    offsets: Vec<usize>,
}

impl StringPositions {
    /// The positions of the string literal at `span` of `text` (quotes included, as the TOML
    /// parser's spans are), checked to decode to `value`.
    pub(super) fn new(text: &str, span: Range<usize>, value: &str) -> Option<Self> {
        let (decoded, offsets) = decode(text, span)?;
        (decoded == value).then_some(StringPositions { offsets })
    }

    /// The file offset of byte `byte` of the value (the closing delimiter's at or past its
    /// end).
    pub(super) fn offset(&self, byte: usize) -> usize {
        self.offsets[byte.min(self.offsets.len() - 1)]
    }

    /// The file range of the value's bytes `range`.
    pub(super) fn range(&self, range: Range<usize>) -> Range<usize> {
        self.offset(range.start)..self.offset(range.end).max(self.offset(range.start))
    }
}

/// Decodes the TOML string literal `text[span]`: its value and, per byte of it, the file
/// offset it comes from (plus the closing delimiter's). `None` when `span` is not a string
/// literal or holds an escape TOML does not have.
fn decode(text: &str, span: Range<usize>) -> Option<(String, Vec<usize>)> {
    let raw = text.get(span.clone())?;
    let (delimiter, escapes) = if raw.starts_with("\"\"\"") {
        (3, true)
    } else if raw.starts_with("'''") {
        (3, false)
    } else if raw.starts_with('"') {
        (1, true)
    } else if raw.starts_with('\'') {
        (1, false)
    } else {
        return None;
    };
    if raw.len() < 2 * delimiter {
        return None;
    }
    let mut start = span.start + delimiter;
    let end = span.end - delimiter;
    if delimiter == 3 {
        // A newline right after the opening delimiter is not part of the value.
        let body = text.get(start..end)?;
        if body.starts_with('\n') {
            start += 1;
        } else if body.starts_with("\r\n") {
            start += 2;
        }
    }
    let body = text.get(start..end)?;
    let mut value = String::with_capacity(body.len());
    let mut offsets = Vec::with_capacity(body.len() + 1);
    let mut push = |c: char, at: usize| {
        offsets.extend(std::iter::repeat_n(at, c.len_utf8()));
        value.push(c);
    };
    let mut chars = body.char_indices().peekable();
    while let Some((i, c)) = chars.next() {
        let at = start + i;
        if c != '\\' || !escapes {
            push(c, at);
            continue;
        }
        let (_, e) = chars.next()?;
        let mut hex = |digits: usize| -> Option<char> {
            let mut code = 0u32;
            for _ in 0..digits {
                code = code * 16 + chars.next()?.1.to_digit(16)?;
            }
            char::from_u32(code)
        };
        let decoded = match e {
            'b' => '\u{8}',
            't' => '\t',
            'n' => '\n',
            'f' => '\u{c}',
            'r' => '\r',
            'e' => '\u{1b}',
            '"' => '"',
            '\\' => '\\',
            'x' => hex(2)?,
            'u' => hex(4)?,
            'U' => hex(8)?,
            // A line continuation (multi-line basic strings): the backslash, the rest of the
            // line and every space, tab and newline up to the next character are dropped.
            ' ' | '\t' | '\n' | '\r' if delimiter == 3 => {
                while chars
                    .next_if(|&(_, c)| matches!(c, ' ' | '\t' | '\n' | '\r'))
                    .is_some()
                {}
                continue;
            }
            _ => return None,
        };
        push(decoded, at);
    }
    offsets.push(end);
    Some((value, offsets))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Parses `key = LITERAL` with the `toml` crate and maps the value's bytes back.
    fn positions(literal: &str) -> (String, String, StringPositions) {
        #[derive(serde::Deserialize)]
        struct Doc {
            key: toml::Spanned<String>,
        }
        let text = format!("key = {literal}\n");
        let doc: Doc = toml::from_str(&text).unwrap();
        let value = doc.key.get_ref().clone();
        let map = StringPositions::new(&text, doc.key.span(), &value)
            .unwrap_or_else(|| panic!("{literal}: not decoded to {value:?}"));
        (text, value, map)
    }

    /// The file text each byte of the value maps to, starting there.
    fn at(text: &str, map: &StringPositions, byte: usize) -> String {
        text[map.offset(byte)..].chars().take(6).collect()
    }

    #[test]
    fn basic_strings_map_escapes_to_their_backslash() {
        let (text, value, map) = positions(r#""a\"b\\c\u00e9d\te\U0001F600f\x41g""#);
        assert_eq!(value, "a\"b\\céd\te😀fAg");
        let byte = |s: &str| value.find(s).unwrap();
        assert_eq!(at(&text, &map, byte("a")), "a\\\"b\\\\");
        assert_eq!(at(&text, &map, byte("\"")), "\\\"b\\\\c");
        assert_eq!(at(&text, &map, byte("b")), "b\\\\c\\u");
        assert_eq!(at(&text, &map, byte("c")), "c\\u00e");
        // Both bytes of `é` come from its escape.
        assert_eq!(at(&text, &map, byte("é")), "\\u00e9");
        assert_eq!(at(&text, &map, byte("é") + 1), "\\u00e9");
        assert_eq!(at(&text, &map, byte("d")), "d\\te\\U");
        assert_eq!(at(&text, &map, byte("😀") + 3), "\\U0001");
        assert_eq!(at(&text, &map, byte("f")), "f\\x41g");
        assert_eq!(at(&text, &map, byte("A")), "\\x41g\"");
        assert_eq!(at(&text, &map, byte("g")), "g\"\n");
        // The end maps to the closing quote.
        assert_eq!(at(&text, &map, value.len()), "\"\n");
    }

    #[test]
    fn literal_strings_map_byte_for_byte() {
        let (text, value, map) = positions(r"'p1^2 + \q1 é'");
        assert_eq!(value, r"p1^2 + \q1 é");
        for (i, _) in value.char_indices() {
            assert_eq!(
                text[map.offset(i)..].chars().next(),
                value[i..].chars().next()
            );
        }
        let (text, value, map) = positions("'''\np1^2\n  + q1'''");
        assert_eq!(value, "p1^2\n  + q1");
        let q = value.find("q1").unwrap();
        assert_eq!(crate::scene::line_col(&text, map.offset(q)), (3, 5));
    }

    #[test]
    fn multi_line_basic_strings_drop_the_first_newline_and_continuations() {
        let literal = "\"\"\"\n  p1^2 \\\n     + q1\\\t\n\n\t + \\\"x\\\" \"\" \"\"\"";
        let (text, value, map) = positions(literal);
        assert_eq!(value, "  p1^2 + q1+ \"x\" \"\" ");
        let byte = |s: &str| value.find(s).unwrap();
        assert_eq!(
            crate::scene::line_col(&text, map.offset(byte("p1"))),
            (2, 3)
        );
        assert_eq!(
            crate::scene::line_col(&text, map.offset(byte("+ q1"))),
            (3, 6)
        );
        assert_eq!(
            crate::scene::line_col(&text, map.offset(byte("+ \""))),
            (5, 3)
        );
        assert_eq!(at(&text, &map, byte("x")), "x\\\" \"\"");
        // CRLF line ends: the first one dropped, the others kept.
        let (text, value, map) = positions("\"\"\"\r\np1^2\r\n+ q1\"\"\"");
        assert_eq!(value, "p1^2\r\n+ q1");
        assert_eq!(
            crate::scene::line_col(&text, map.offset(byte_of(&value, "q1"))),
            (3, 3)
        );
    }

    fn byte_of(value: &str, s: &str) -> usize {
        value.find(s).unwrap()
    }

    #[test]
    fn a_value_that_is_not_the_literal_is_refused() {
        let text = "key = \"abc\"\n";
        assert!(StringPositions::new(text, 6..11, "abc").is_some());
        assert!(StringPositions::new(text, 6..11, "abd").is_none());
        assert!(StringPositions::new(text, 0..3, "key").is_none());
    }
}
