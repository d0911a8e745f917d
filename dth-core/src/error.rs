//! The crate's one error type.

use thiserror::Error;

/// Everything that can go wrong in `dth-core`. Variants carry the data needed to act on them;
/// match on variants (`matches!`), never on the message text.
#[derive(Debug, Clone, PartialEq, Error)]
#[non_exhaustive]
pub enum Error {
    /// An option is outside its valid range.
    #[error("invalid option `{name}` = {value}: {reason}")]
    InvalidOption {
        /// Option name, as in the options struct.
        name: &'static str,
        /// The rejected value.
        value: f64,
        /// The rule it breaks.
        reason: &'static str,
    },
    /// An initial state component (or parameter) is NaN or infinite.
    #[error("initial state component {index} is not finite ({value})")]
    NonFiniteInitialState {
        /// Index into `z`.
        index: usize,
        /// The offending value.
        value: f64,
    },
}
