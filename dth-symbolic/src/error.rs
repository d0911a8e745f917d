//! Errors, each with the span of the smallest offending piece of source and the rule it breaks.

use std::fmt;

use crate::number::Fault;
use crate::span::Span;

/// The function names of the grammar, in the order the error messages list them.
pub const FUNCTIONS: &str = "sin, cos, tan, exp, ln, sqrt, sinh, cosh, tanh, atan";

/// What is wrong.
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub enum ErrorKind {
    /// The source holds no expression.
    Empty,
    /// A character outside the grammar.
    UnexpectedChar {
        /// The character.
        ch: char,
    },
    /// A numeric literal outside the grammar (`2f64`, `2q1`).
    InvalidNumber {
        /// The literal as written.
        text: String,
    },
    /// A literal larger than `f64::MAX`.
    LiteralOverflow {
        /// The literal as written.
        text: String,
    },
    /// A nonzero literal that rounds to zero.
    LiteralUnderflow {
        /// The literal as written.
        text: String,
    },
    /// A token where an operand was expected.
    ExpectedOperand {
        /// The token found (`None` at the end of input).
        found: Option<String>,
    },
    /// A token where an operator or the end was expected (`q1 q2`, `2(q1)`).
    ExpectedOperator {
        /// The token found.
        found: String,
    },
    /// A `(` without its `)`.
    UnclosedParen,
    /// A `)` without its `(`.
    UnmatchedParen,
    /// Parentheses or signs nested deeper than the parser allows.
    TooDeep,
    /// A name that is not a variable, `t`, `pi` or a declared parameter.
    UnknownVariable {
        /// The name.
        name: String,
    },
    /// `q0`, `p0`, or an index with a leading zero.
    BadIndex {
        /// The name.
        name: String,
    },
    /// An index beyond [`crate::MAX_INDEX`].
    IndexTooLarge {
        /// The name.
        name: String,
    },
    /// A call of an unknown function.
    UnknownFunction {
        /// The name.
        name: String,
    },
    /// A variable or parameter followed by `(`.
    NotAFunction {
        /// The name.
        name: String,
    },
    /// A function name without `(...)`.
    FunctionWithoutCall {
        /// The name.
        name: String,
    },
    /// A function name followed by an operand without parentheses (`sin q1`).
    CallWithoutParens {
        /// The function name.
        name: String,
        /// The operand as written.
        arg: String,
    },
    /// `**` (a power in other languages).
    DoubleStar {
        /// The power as the grammar writes it (`p1^2`).
        power: String,
    },
    /// A function of the grammar called with more than one argument (`cos(q1, q2)`).
    TooManyArguments {
        /// The name.
        name: String,
        /// How many arguments were written.
        found: usize,
    },
    /// `pow(a, b)`.
    PowFunction {
        /// The power as the grammar writes it (`q1^2`).
        power: String,
    },
    /// `e`, which is not a name of the grammar (`e^q1` is `exp(q1)`).
    EulerNumber {
        /// The exponent as written, when `e` is raised to one.
        exponent: Option<String>,
    },
    /// A `,` outside a function call's parentheses.
    StrayComma,
    /// `[ ]` or `{ }` used for grouping (the span covers the group).
    Brackets,
    /// After `where`, something that is neither `name = value` nor a boundary `q[k] = ...`.
    Declaration,
    /// A sum whose range is not `i = lo..hi` or `lo <= i < j <= hi` (at the offending token).
    SumRange,
    /// An index whose sites include none (`i = 5..4`, or pairs in `1 <= i < j <= 1`).
    EmptySum {
        /// The range as written.
        range: String,
    },
    /// An indexed variable whose index falls outside the lattice `1..n` with no boundary
    /// declared there.
    IndexOutOfRange {
        /// The access as written, `q[i+1]`.
        access: String,
        /// The letter, `'q'` or `'p'`.
        letter: char,
        /// The index it reaches.
        site: i64,
        /// The summation indices' values there, `i = 64` (empty outside sums).
        at: String,
        /// The lattice's last site (the largest upper bound of the sums), if there are sums.
        last: Option<i64>,
    },
    /// A name in an index that no enclosing sum binds and no declaration after `where` names.
    UnboundIndex {
        /// The name.
        name: String,
        /// The indices bound where it is used (empty outside sums).
        bound: String,
    },
    /// An index, a bound or a declared size that is not an integer expression (a parameter, a
    /// decimal, a function, a division).
    NotAnIndex {
        /// The offending piece as written.
        text: String,
    },
    /// `x[i]` for a name other than `q` and `p`.
    IndexedName {
        /// The name.
        name: String,
    },
    /// A written-out `q<k>` or `p<k>` beyond the lattice the sums index: it would add
    /// coordinates the sums never touch.
    MixedIndexing {
        /// The name as written.
        name: String,
        /// The lattice's last site.
        last: i64,
    },
    /// A boundary `q[k] = ...` that cannot be one (inside the lattice, declared twice, or
    /// defined by another boundary).
    BadBoundary {
        /// The variable, `q[0]`.
        name: String,
        /// Why.
        reason: String,
    },
    /// A summation index or declared size whose name cannot be used.
    BadIndexName {
        /// The name.
        name: String,
        /// Why (`"is declared twice"`, `"is a name of the grammar"`, ...).
        reason: &'static str,
    },
    /// A sum whose range, or a lattice whose last site, exceeds what can be compiled: more
    /// than [`crate::MAX_INDEX`] sites written out site by site, or more than
    /// [`crate::MAX_SITES`] compiled to loops. At the bound's value (the declared
    /// size's, for `1..N`).
    LatticeTooLarge {
        /// The number of sites the range or the lattice has.
        sites: i128,
        /// The bound it exceeds: [`crate::MAX_SITES`], or [`crate::MAX_INDEX`] for sums
        /// written out site by site.
        limit: usize,
    },
    /// The value and its derivatives exceed [`crate::MAX_SIZE`].
    TooLarge {
        /// The bound.
        limit: usize,
    },
    /// Constant folding failed (division by zero, `ln(-1)`, overflow).
    Fault(Fault),
    /// A declared parameter name that cannot be used.
    BadParameter {
        /// The name.
        name: String,
        /// Why (`"is declared twice"`, `"is a function of the grammar"`, ...).
        reason: &'static str,
    },
    /// A regularization ([`crate::regularize`]) that does not apply to this Hamiltonian.
    CannotRegularize {
        /// The regularization (`"levi-civita"`).
        name: &'static str,
        /// Why, lowercase (`"the Hamiltonian is not planar (...)"`).
        reason: &'static str,
    },
    /// A function of a system's state (an event's condition) names a coordinate the system
    /// does not have.
    NotInSystem {
        /// The name (`q3`).
        name: String,
        /// The system's degrees of freedom.
        n: u32,
    },
    /// `H` uses no momentum `p1..pN`: the flow would not move `q`.
    NoMomentum,
    /// `H` uses no variable at all.
    ConstantHamiltonian,
    /// Neither `q<i>` nor `p<i>` is written, yet a larger index sets `n` (`p1^2 + p3^2`): a
    /// coordinate pair with no part in `H` is almost always a misnumbering.
    SkippedIndex {
        /// The index that appears nowhere.
        missing: u32,
        /// The variable with the largest index, which sets `n`: `'q'` or `'p'` ...
        largest: char,
        /// ... and that index, `n`.
        n: u32,
    },
    /// [`ErrorKind::SkippedIndex`] for a run of consecutive indices `first..=last` (a lattice
    /// whose sums leave sites out): one error for the run, not one per index.
    SkippedIndices {
        /// The first index that appears nowhere.
        first: u32,
        /// The last, `> first`.
        last: u32,
        /// The variable with the largest index, which sets `n`: `'q'` or `'p'` ...
        largest: char,
        /// ... and that index, `n`.
        n: u32,
    },
}

/// One error: what, and where in the source.
#[derive(Clone, Debug, PartialEq)]
pub struct Error {
    /// What is wrong.
    pub kind: ErrorKind,
    /// Where: bytes of the source.
    pub span: Span,
}

impl Error {
    /// An error of `kind` at `span`.
    pub fn new(kind: ErrorKind, span: Span) -> Self {
        Error { kind, span }
    }
}

impl fmt::Display for Error {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        use ErrorKind::*;
        match &self.kind {
            Empty => f.write_str(
                "empty Hamiltonian: expected an expression in q1..qN, p1..pN (and t, parameters)",
            ),
            UnexpectedChar { ch: 'π' } => f.write_str(
                "unexpected `π`: names are ASCII, the constant is written `pi`",
            ),
            UnexpectedChar { ch } => match greek_name(*ch) {
                Some(name) => write!(
                    f,
                    "unexpected `{ch}`: names are ASCII: write `{name}` and declare it as a parameter (`struct H {{ {name}: f64 }} = ...`)"
                ),
                None => write!(
                    f,
                    "unexpected `{ch}`: the grammar has numbers, names, `+ - * / ^` and parentheses"
                ),
            },
            InvalidNumber { text } => invalid_number(f, text),
            LiteralOverflow { text } => {
                write!(f, "literal `{text}` overflows f64 (largest is about 1.8e308)")
            }
            LiteralUnderflow { text } => write!(
                f,
                "literal `{text}` is nonzero but rounds to zero in f64 (smallest is about 4.9e-324)"
            ),
            ExpectedOperand { found: Some(t) } => write!(
                f,
                "expected an operand (a number, variable, function call or `(`), found `{t}`"
            ),
            ExpectedOperand { found: None } => f.write_str(
                "expected an operand (a number, variable, function call or `(`) at the end of the expression",
            ),
            ExpectedOperator { found } => write!(
                f,
                "expected an operator (`+ - * / ^`) or the end, found `{found}`: multiplication needs an explicit `*`"
            ),
            UnclosedParen => f.write_str("unclosed `(`: expected a matching `)`"),
            UnmatchedParen => f.write_str("unmatched `)`"),
            TooDeep => f.write_str("expression nested too deeply (more than 256 levels)"),
            UnknownVariable { name } => write!(
                f,
                "unknown variable `{name}`: expected q1..qN, p1..pN, t, or a declared parameter"
            ),
            BadIndex { name } => write!(
                f,
                "bad index in `{name}`: coordinates are numbered from 1 without leading zeros (q1..qN, p1..pN)"
            ),
            IndexTooLarge { name } => write!(
                f,
                "index in `{name}` is too large: at most {} degrees of freedom are supported",
                crate::MAX_INDEX
            ),
            UnknownFunction { name } if name == "log" => write!(
                f,
                "unknown function `log`: the natural logarithm is `ln` (functions: {FUNCTIONS})"
            ),
            UnknownFunction { name } if name == "pow" => f.write_str(
                "unknown function `pow`: powers are written with `^`, as in `q1^2`",
            ),
            UnknownFunction { name } => {
                write!(f, "unknown function `{name}`: expected one of {FUNCTIONS}")
            }
            NotAFunction { name } => write!(
                f,
                "`{name}` is not a function: multiplication needs an explicit `*` (`{name}*(...)`)"
            ),
            FunctionWithoutCall { name } => {
                write!(f, "`{name}` is a function: call it with parentheses, `{name}(...)`")
            }
            CallWithoutParens { name, arg } => write!(
                f,
                "`{name}` is a function: its argument goes in parentheses, `{name}({arg})`"
            ),
            DoubleStar { power } => write!(
                f,
                "`**` is not an operator: powers are written with `^`, as in `{power}`"
            ),
            TooManyArguments { name, found } => {
                write!(f, "`{name}` takes one argument, found {found}")
            }
            PowFunction { power } => write!(
                f,
                "unknown function `pow`: powers are written with `^`, as in `{power}`"
            ),
            EulerNumber { exponent } => write!(
                f,
                "unknown variable `e`: Euler's number is not a name of the grammar, the exponential is `exp({})`",
                exponent.as_deref().unwrap_or("1")
            ),
            Brackets => f.write_str(
                "use parentheses `( )` for grouping: brackets and braces are not part of the grammar",
            ),
            Declaration => f.write_str(
                "expected a declaration after `where`: a size `N = 64` or a boundary `q[0] = 0`, `q[N+1] = q[1]`",
            ),
            SumRange => f.write_str(
                "expected a sum's range and then `,` and the summand: `sum(i = 1..N, ...)` or, over pairs, `sum(1 <= i < j <= N, ...)`",
            ),
            EmptySum { range } => write!(
                f,
                "sum over an empty range: `{range}` has no terms (ranges include both ends)"
            ),
            IndexOutOfRange {
                access,
                letter,
                site,
                at,
                last,
            } => {
                let at = if at.is_empty() {
                    String::new()
                } else {
                    format!(" at `{at}`")
                };
                let lattice = match last {
                    Some(n) => format!("the lattice's sites are 1..{n} (the sums' largest bound)"),
                    None => "indices start at 1".to_string(),
                };
                let (fixed, periodic) = match last {
                    Some(n) if *site > *n => (format!("{letter}[{site}] = 0"), format!("{letter}[{site}] = {letter}[{}]", site - n)),
                    Some(n) => (format!("{letter}[{site}] = 0"), format!("{letter}[{site}] = {letter}[{}]", site + n)),
                    None => (format!("{letter}[{site}] = 0"), String::new()),
                };
                write!(f, "index out of range: `{access}` is `{letter}[{site}]`{at}, but {lattice}; declare a boundary after `where`: `{fixed}` (fixed end)")?;
                if periodic.is_empty() {
                    Ok(())
                } else {
                    write!(f, " or `{periodic}` (periodic)")
                }
            }
            UnboundIndex { name, bound } if bound.is_empty() => write!(
                f,
                "unbound index `{name}`: no `sum` binds it and no `where {name} = ...` declares it"
            ),
            UnboundIndex { name, bound } => write!(
                f,
                "unbound index `{name}`: the indices bound here are {bound}, and no `where {name} = ...` declares it"
            ),
            NotAnIndex { text } => write!(
                f,
                "`{text}` is not an integer: indices, ranges and sizes are integers built from literals, summation indices, declared sizes and `+ - *`"
            ),
            IndexedName { name } => write!(
                f,
                "`{name}` cannot be indexed: the indexed variables are `q[i]` and `p[i]`"
            ),
            MixedIndexing { name, last } => write!(
                f,
                "`{name}` is beyond the lattice 1..{last} of the sums: a written-out coordinate must be one of the sums' sites (write `q[k]` inside the sums' range)"
            ),
            BadBoundary { name, reason } => write!(f, "boundary `{name}` {reason}"),
            BadIndexName { name, reason } => write!(f, "index or size `{name}` {reason}"),
            StrayComma => f.write_str(
                "unexpected `,`: a Hamiltonian is one expression and every function takes one argument",
            ),
            LatticeTooLarge { sites, limit } if *limit == crate::MAX_INDEX => write!(
                f,
                "lattice too large: {sites} sites, at most {limit} when the sums are written out site by site, as these are; sums that compile to loops allow {} (single-index sums of `q[i + c]`, `p[i + c]`, added, with fixed or periodic boundaries)",
                crate::MAX_SITES
            ),
            LatticeTooLarge { sites, limit } => write!(
                f,
                "lattice too large: {sites} sites, at most {limit} are supported (the generated type keeps phase-space vectors of 2 numbers per site and the Hessian's nonzeros on the stack)"
            ),
            TooLarge { limit } => write!(
                f,
                "the derivatives of this Hamiltonian are too large: more than {limit} expression nodes and operands (value, gradient, Hessian and Psi); the bound keeps compile time and generated code in check"
            ),
            Fault(fault) => write!(f, "{fault}"),
            CannotRegularize { name, reason } => {
                write!(f, "cannot regularize with {name}: {reason}")
            }
            NotInSystem { name, n } => write!(
                f,
                "`{name}` is not a coordinate of this system: it has q1..q{n}, p1..p{n} and t"
            ),
            // A repeated name is not a bad name: nothing to add.
            BadParameter { name, reason } if *reason == "is declared twice" => {
                write!(f, "parameter `{name}` {reason}")
            }
            BadParameter { name, reason } => write!(
                f,
                "parameter `{name}` {reason}: parameters need their own names"
            ),
            NoMomentum => f.write_str(
                "the Hamiltonian does not depend on any momentum p1..pN (after simplification): its flow would not move q",
            ),
            ConstantHamiltonian => f.write_str(
                "the Hamiltonian is constant (after simplification): it must depend on q1..qN, p1..pN",
            ),
            SkippedIndex { missing, largest, n } => write!(
                f,
                "neither `q{missing}` nor `p{missing}` appears, yet `{largest}{n}` makes the system's degrees of freedom 1..{n}: number the coordinates without gaps"
            ),
            SkippedIndices {
                first,
                last,
                largest,
                n,
            } => write!(
                f,
                "no `q` nor `p` of the indices {first}..{last} appears, yet `{largest}{n}` makes the system's degrees of freedom 1..{n}: number the coordinates without gaps"
            ),
        }
    }
}

impl std::error::Error for Error {}

/// The message of [`ErrorKind::InvalidNumber`]: what the literal's mistake most likely is.
fn invalid_number(f: &mut fmt::Formatter<'_>, text: &str) -> fmt::Result {
    const PLAIN: &str = "number literals are plain decimals like `2.0` or `1000`";
    if text.contains('_') {
        return write!(
            f,
            "invalid number `{text}`: {PLAIN}, without `_` (write `{}`)",
            text.replace('_', "")
        );
    }
    // The numeric prefix: digits, a fraction, an exponent.
    let end = text
        .char_indices()
        .find(|&(i, c)| {
            !(c.is_ascii_digit()
                || c == '.'
                || (matches!(c, 'e' | 'E')
                    && text[i + 1..]
                        .starts_with(|d: char| d.is_ascii_digit() || d == '-' || d == '+'))
                || (matches!(c, '-' | '+') && i > 0 && text[..i].ends_with(['e', 'E'])))
        })
        .map_or(text.len(), |(i, _)| i);
    let (number, rest) = text.split_at(end);
    const SUFFIXES: [&str; 14] = [
        "f32", "f64", "i8", "i16", "i32", "i64", "i128", "isize", "u8", "u16", "u32", "u64",
        "u128", "usize",
    ];
    if !number.is_empty() && SUFFIXES.contains(&rest) {
        return write!(
            f,
            "invalid number `{text}`: {PLAIN}, without a type suffix (write `{number}`)"
        );
    }
    if !number.is_empty() && !rest.is_empty() && rest.starts_with(|c: char| c.is_ascii_alphabetic())
    {
        return write!(
            f,
            "invalid number `{text}`: multiplication needs an explicit `*` (write `{number}*{rest}`)"
        );
    }
    write!(
        f,
        "invalid number `{text}`: {PLAIN}, or scientific like `1e-3`"
    )
}

/// The ASCII name of a Greek letter, for the hint on `ω` and the like.
fn greek_name(ch: char) -> Option<&'static str> {
    const NAMES: [&str; 25] = [
        "alpha", "beta", "gamma", "delta", "epsilon", "zeta", "eta", "theta", "iota", "kappa",
        "lambda", "mu", "nu", "xi", "omicron", "pi", "rho", "sigma", "sigma", "tau", "upsilon",
        "phi", "chi", "psi", "omega",
    ];
    // Lower case U+03B1..U+03C9 (with final sigma U+03C2); upper case U+0391..U+03A9 has a
    // gap at U+03A2 where the final sigma would be.
    let k = match ch {
        'α'..='ω' => ch as u32 - 'α' as u32,
        'Α'..='Ω' if ch != '\u{3a2}' => ch as u32 - 'Α' as u32,
        'ϑ' => 7,
        'ϕ' => 21,
        'ϵ' => 4,
        'ϖ' => 15,
        'ϱ' => 16,
        _ => return None,
    };
    // `Π` and `ϖ` are not `pi`, and `pi` cannot be a parameter: no hint for them.
    NAMES.get(k as usize).copied().filter(|&n| n != "pi")
}

/// All the independent errors found in one source, in source order.
///
/// Displayed one after the other, each with where it is: the bytes of the source, or, for
/// a bad parameter name, the parameter list (which is not part of the source).
#[derive(Clone, Debug, PartialEq)]
pub struct Errors(pub Vec<Error>);

impl fmt::Display for Errors {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for (i, e) in self.0.iter().enumerate() {
            if i > 0 {
                f.write_str("; ")?;
            }
            match e.kind {
                ErrorKind::BadParameter { .. } => write!(f, "{e} (in the parameter list)")?,
                _ => write!(f, "{e} (bytes {}..{})", e.span.start, e.span.end)?,
            }
        }
        Ok(())
    }
}

impl std::error::Error for Errors {}

/// Something legal but easily a mistake, with the span it concerns. A Hamiltonian with
/// warnings compiles; the macro shows them as compiler warnings, the command line prints them.
#[derive(Clone, Debug, PartialEq)]
pub struct Warning {
    /// What is suspicious.
    pub kind: WarningKind,
    /// Where: bytes of the source.
    pub span: Span,
}

/// What a [`Warning`] is about.
#[derive(Clone, Debug, PartialEq)]
#[non_exhaustive]
pub enum WarningKind {
    /// `q<i>` is written but `p<i>` is not: `q<i>` never moves (`dH/dp<i> = 0`) and `p<i>`
    /// only drifts, so `q<i>` acts as a constant that is better declared as a parameter.
    FrozenCoordinate {
        /// The index.
        index: u32,
    },
    /// `p<i>` is written without `q<i>` while some `q<j>` is written without `p<j>`: alone,
    /// a momentum without its position is a cyclic coordinate (an angle, a free particle) and
    /// no warning; beside a frozen position it looks like a misnumbering.
    Misnumbered {
        /// The momentum's index `i`.
        momentum: u32,
        /// The index `j` of the first position without its momentum.
        position: u32,
    },
    /// [`WarningKind::FrozenCoordinate`] for the consecutive indices `first..=last` one access
    /// of a sum reaches (`q[i]` over sites no `p[i]` reaches): one warning for the run.
    FrozenCoordinates {
        /// The first index.
        first: u32,
        /// The last, `> first`.
        last: u32,
    },
    /// [`WarningKind::Misnumbered`] for the consecutive momenta `first..=last` one access of
    /// a sum reaches.
    MisnumberedMomenta {
        /// The first momentum's index.
        first: u32,
        /// The last, `> first`.
        last: u32,
        /// The index `j` of the first position without its momentum.
        position: u32,
    },
}

impl fmt::Display for Warning {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self.kind {
            WarningKind::FrozenCoordinate { index: i } => write!(
                f,
                "`q{i}` appears without `p{i}`: `q{i}` never moves (dH/dp{i} = 0) and `p{i}` only drifts; a constant is better declared as a parameter"
            ),
            WarningKind::Misnumbered {
                momentum: i,
                position: j,
            } => write!(
                f,
                "`p{i}` appears without `q{i}` while `q{j}` appears without `p{j}`: is an index misnumbered?"
            ),
            WarningKind::FrozenCoordinates { first, last } => write!(
                f,
                "`q{first}`..`q{last}` appear without `p{first}`..`p{last}`: they never move (dH/dp = 0) and their momenta only drift; constants are better declared as parameters"
            ),
            WarningKind::MisnumberedMomenta {
                first,
                last,
                position: j,
            } => write!(
                f,
                "`p{first}`..`p{last}` appear without `q{first}`..`q{last}` while `q{j}` appears without `p{j}`: is an index misnumbered?"
            ),
        }
    }
}

/// Why [`crate::Program::eval`] could not run.
#[derive(Clone, Debug, PartialEq, Eq)]
#[non_exhaustive]
pub enum EvalError {
    /// `z` or `params` has the wrong length.
    WrongLength {
        /// `"z"` or `"params"`.
        what: &'static str,
        /// The length the program needs.
        expected: usize,
        /// The length given.
        found: usize,
    },
}

impl fmt::Display for EvalError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            EvalError::WrongLength {
                what,
                expected,
                found,
            } => {
                write!(
                    f,
                    "`{what}` has length {found}, the program needs {expected}"
                )
            }
        }
    }
}

impl std::error::Error for EvalError {}
