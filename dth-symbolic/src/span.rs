//! Byte ranges into the source text.

use std::ops::Range;

/// A byte range `start..end` into the source text of a Hamiltonian.
///
/// The engine works on `&str`; the proc macro records which token produced which range and maps
/// an error's span back onto the user's tokens.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct Span {
    /// First byte.
    pub start: usize,
    /// One past the last byte.
    pub end: usize,
}

impl Span {
    /// The span `start..end`.
    pub const fn new(start: usize, end: usize) -> Self {
        Span { start, end }
    }

    /// The smallest span covering both.
    pub fn to(self, other: Span) -> Span {
        Span::new(self.start.min(other.start), self.end.max(other.end))
    }

    /// As a `Range` for slicing the source.
    pub fn range(self) -> Range<usize> {
        self.start..self.end
    }
}
