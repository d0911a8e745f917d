//! Every structural error of a scene file at once: serde stops at the first unknown key,
//! wrong type or missing key, so [`read`] removes the entry it stopped at from the parsed
//! document and reads it again, until the document reads or an error has no entry to remove.
//!
//! The tables an entry was removed from are returned too: a later complaint about such a
//! table as a whole (a key it now lacks, reported at the table's header) follows from the
//! error already reported, and the caller drops it (one error, not a cascade of them).

use std::ops::Range;

use serde::Deserialize;
use toml::de::{DeTable, DeValue};

use super::raw::RawScene;

/// The most structural errors reported for one file (each costs one more reading of it).
const MAX_ERRORS: usize = 64;

/// What reading a scene's structure found.
pub(super) struct Structure {
    /// The scene as written, less the entries with errors; `None` when the file is not TOML,
    /// or an error had no entry to remove (a key missing from a table).
    pub(super) raw: Option<RawScene>,
    /// Every structural error (span, serde's message).
    pub(super) errors: Vec<(Range<usize>, String)>,
    /// The spans of the tables (their headers, or the inline tables) an entry was removed
    /// from.
    pub(super) touched: Vec<Range<usize>>,
}

/// Reads `text` into a [`RawScene`], collecting every structural error (see the module docs).
pub(super) fn read(text: &str) -> Structure {
    let mut doc = match DeTable::parse(text) {
        Ok(doc) => doc,
        Err(e) => {
            return Structure {
                raw: None,
                errors: vec![(e.span().unwrap_or(0..0), e.message().trim().to_string())],
                touched: Vec::new(),
            }
        }
    };
    let mut errors = Vec::new();
    let mut touched: Vec<Range<usize>> = Vec::new();
    while errors.len() < MAX_ERRORS {
        let e = match RawScene::deserialize(toml::de::Deserializer::from(doc.clone())) {
            Ok(raw) => {
                return Structure {
                    raw: Some(raw),
                    errors,
                    touched,
                }
            }
            Err(e) => e,
        };
        let span = e.span().unwrap_or(0..0);
        if touched.iter().any(|t| t.start == span.start) {
            // A key missing from a table an entry was removed from: a consequence.
            break;
        }
        errors.push((span.clone(), e.message().trim().to_string()));
        let root = doc.span();
        match remove_at(doc.get_mut(), root, span.start) {
            Some(table) => touched.push(table),
            None => break,
        }
    }
    Structure {
        raw: None,
        errors,
        touched,
    }
}

/// Removes from `table` (spanned `span`), or a table within it, the entry at byte `offset`:
/// the one whose key holds it, or whose value holds it (a value that is not a table); returns
/// the span of the table it was removed from. `None` when no entry is there (an error about a
/// table as a whole).
fn remove_at(table: &mut DeTable<'_>, span: Range<usize>, offset: usize) -> Option<Range<usize>> {
    let mut hit = None;
    for (key, value) in table.iter_mut() {
        if key.span().contains(&offset) {
            hit = Some(key.clone());
            break;
        }
        let value_span = value.span();
        match value.get_mut() {
            DeValue::Table(inner) => {
                if let Some(found) = remove_at(inner, value_span, offset) {
                    return Some(found);
                }
            }
            DeValue::Array(items) => {
                let mut of_tables = false;
                for item in items.iter_mut() {
                    let item_span = item.span();
                    if let DeValue::Table(inner) = item.get_mut() {
                        of_tables = true;
                        if let Some(found) = remove_at(inner, item_span, offset) {
                            return Some(found);
                        }
                    }
                }
                if !of_tables && value_span.contains(&offset) {
                    hit = Some(key.clone());
                    break;
                }
            }
            _ if value_span.contains(&offset) => {
                hit = Some(key.clone());
                break;
            }
            _ => {}
        }
    }
    table.remove(&hit?);
    Some(span)
}
