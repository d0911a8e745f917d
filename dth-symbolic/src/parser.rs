//! Parser: tokens to a syntax tree with spans (precedence climbing).
//!
//! ```text
//! source  := expr ('where' decl (',' decl)*)?
//! decl    := name '=' expr                     a named size, `N = 64`
//!          | index ('=' index)* '=' expr       a boundary, `q[0] = q[N+1] = 0`, `q[N+1] = q[1]`
//! expr    := term (('+' | '-') term)*
//! term    := unary (('*' | '/') unary)*
//! unary   := ('-' | '+') unary | power
//! power   := atom ('^' unary)?          right-associative; binds tighter than unary minus
//! atom    := number | name | name '(' expr ')' | '(' expr ')' | index | sum
//! index   := ('q' | 'p') '[' expr ']'
//! sum     := 'sum' '(' range ',' expr ')'
//! range   := name '=' expr '..' expr                     both ends included
//!          | expr ('<=' | '<') name '<' name ('<=' | '<') expr    all pairs
//! ```
//!
//! Three mistakes are read as what they most likely mean, reported, and parsing goes on (so
//! the rest of the expression is still checked): `sin q1` as `sin(q1)`, `p1**2` as `p1^2`,
//! and a call with several arguments `cos(q1, q2)`, kept whole for the builder to report.

use crate::error::{Error, ErrorKind};
use crate::lexer::{Token, TokenKind};
use crate::span::Span;

/// A binary operator.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum BinOp {
    /// `+`
    Add,
    /// `-`
    Sub,
    /// `*`
    Mul,
    /// `/`
    Div,
    /// `^`
    Pow,
}

/// A syntax-tree node.
#[derive(Clone, Debug, PartialEq)]
pub enum Ast {
    /// A numeric literal (text at `span`).
    Number(Span),
    /// A name (text at `span`).
    Name(Span),
    /// `name(arg)`.
    Call {
        /// The function name.
        name: Span,
        /// The argument.
        arg: Box<Ast>,
        /// Arguments after the first (an error for every function of the grammar).
        extra: Vec<Ast>,
        /// From the name to the `)`.
        span: Span,
    },
    /// `-x` (or `+x`, `negate: false`).
    Unary {
        /// `true` for `-`.
        negate: bool,
        /// The operand.
        arg: Box<Ast>,
        /// From the sign to the end of the operand.
        span: Span,
    },
    /// `first op x op x ...` at one precedence level (`+ -` or `* /`), left to right. Kept
    /// flat so a long sum neither recurses deeply nor rebuilds its prefix at every term.
    Chain {
        /// The first operand.
        first: Box<Ast>,
        /// Each operator, its token and its right operand.
        rest: Vec<(BinOp, Span, Ast)>,
    },
    /// `lhs ^ rhs` (the only binary node: `^` is right-associative).
    Binary {
        /// The operator.
        op: BinOp,
        /// The operator's token.
        op_span: Span,
        /// Left operand.
        lhs: Box<Ast>,
        /// Right operand.
        rhs: Box<Ast>,
    },
    /// `( inner )`: kept so errors on a group cover its parentheses.
    Paren {
        /// The contents.
        inner: Box<Ast>,
        /// From `(` to `)`.
        span: Span,
    },
    /// `name[index]`, an indexed variable (`q[i + 1]`).
    Index {
        /// The variable's letter.
        name: Span,
        /// The index, an integer expression.
        index: Box<Ast>,
        /// From the name to the `]`.
        span: Span,
    },
    /// `sum(range, body)`.
    Sum {
        /// The indices and their ranges.
        range: Box<Range>,
        /// The summand.
        body: Box<Ast>,
        /// From `sum` to the `)`.
        span: Span,
    },
    /// `body where decls`: only at the root.
    Where {
        /// The Hamiltonian.
        body: Box<Ast>,
        /// The declarations, in order.
        decls: Vec<Decl>,
    },
}

/// The range of a [`Ast::Sum`].
#[derive(Clone, Debug, PartialEq)]
pub enum Range {
    /// `i = lo..hi`, both ends included.
    Single {
        /// The index's name.
        index: Span,
        /// The first value.
        lo: Ast,
        /// The last value.
        hi: Ast,
    },
    /// `lo <= i < j <= hi`: every pair (`<` for a strict bound).
    Pairs {
        /// The lower bound.
        lo: Ast,
        /// `true` for `lo < i`.
        lo_strict: bool,
        /// The first index's name.
        i: Span,
        /// The second index's name.
        j: Span,
        /// `true` for `j < hi`.
        hi_strict: bool,
        /// The upper bound.
        hi: Ast,
    },
}

impl Range {
    /// From the first to the last token of the range.
    pub fn span(&self) -> Span {
        match self {
            Range::Single { index, hi, .. } => index.to(hi.span()),
            Range::Pairs { lo, hi, .. } => lo.span().to(hi.span()),
        }
    }
}

/// A declaration after `where`.
#[derive(Clone, Debug, PartialEq)]
pub enum Decl {
    /// `name = value`: a named integer (a size).
    Constant {
        /// The name.
        name: Span,
        /// Its value, an integer expression.
        value: Ast,
    },
    /// `q[a] = q[b] = value`: the variables at the indices outside the lattice, as a value
    /// (`0`: a fixed end) or a variable of the lattice (`q[1]`: periodic).
    Boundary {
        /// The indexed variables defined (each an [`Ast::Index`] when well formed).
        targets: Vec<Ast>,
        /// What they stand for.
        value: Ast,
    },
}

impl Ast {
    /// The source range of the whole node.
    pub fn span(&self) -> Span {
        match self {
            Ast::Number(s) | Ast::Name(s) => *s,
            Ast::Call { span, .. }
            | Ast::Unary { span, .. }
            | Ast::Paren { span, .. }
            | Ast::Index { span, .. }
            | Ast::Sum { span, .. } => *span,
            Ast::Where { body, decls } => match decls.last() {
                Some(Decl::Constant { value, .. } | Decl::Boundary { value, .. }) => {
                    body.span().to(value.span())
                }
                None => body.span(),
            },
            Ast::Binary { lhs, rhs, .. } => lhs.span().to(rhs.span()),
            Ast::Chain { first, rest } => match rest.last() {
                Some((_, _, last)) => first.span().to(last.span()),
                None => first.span(),
            },
        }
    }
}

struct Parser<'a> {
    src: &'a str,
    tokens: &'a [Token],
    pos: usize,
    depth: usize,
    /// Mistakes read past (see the module docs).
    errors: Vec<Error>,
}

/// Nesting beyond this is rejected rather than risking the stack.
const MAX_DEPTH: usize = 256;

/// Parses a whole expression: the tree (`None` after a syntax error that stops the parse,
/// as later ones would be cascades) and the errors, in source order.
pub fn parse(src: &str, tokens: &[Token]) -> (Option<Ast>, Vec<Error>) {
    if tokens.is_empty() {
        return (
            None,
            vec![Error::new(ErrorKind::Empty, Span::new(0, src.len()))],
        );
    }
    let mut p = Parser {
        src,
        tokens,
        pos: 0,
        depth: 0,
        errors: Vec::new(),
    };
    let result = p
        .expr()
        .and_then(|ast| p.source(ast))
        .and_then(|ast| match p.peek() {
            None => Ok(ast),
            Some(t) if t.kind == TokenKind::RParen => {
                Err(Error::new(ErrorKind::UnmatchedParen, t.span))
            }
            Some(t) => Err(p.unexpected(t)),
        });
    let mut errors = p.errors;
    let ast = match result {
        Ok(ast) => Some(ast),
        Err(e) => {
            errors.push(e);
            None
        }
    };
    errors.sort_by_key(|e| e.span.start);
    (ast, errors)
}

/// `true` for the names of the grammar's functions.
fn is_function(name: &str) -> bool {
    crate::error::FUNCTIONS.split(", ").any(|f| f == name)
}

/// `ast` as an operand of `^` in a suggestion: parenthesized unless it is a single operand.
pub(crate) fn operand_text(src: &str, ast: &Ast) -> String {
    let text = &src[ast.span().range()];
    match ast {
        Ast::Number(_)
        | Ast::Name(_)
        | Ast::Call { .. }
        | Ast::Paren { .. }
        | Ast::Index { .. }
        | Ast::Sum { .. } => text.to_string(),
        _ => format!("({text})"),
    }
}

impl<'a> Parser<'a> {
    fn peek(&self) -> Option<Token> {
        self.tokens.get(self.pos).copied()
    }

    fn text(&self, s: Span) -> &'a str {
        &self.src[s.range()]
    }

    /// The error for `t` where an operator or the end was expected.
    fn unexpected(&self, t: Token) -> Error {
        if t.kind == TokenKind::Comma {
            return Error::new(ErrorKind::StrayComma, t.span);
        }
        Error::new(
            ErrorKind::ExpectedOperator {
                found: self.text(t.span).to_string(),
            },
            t.span,
        )
    }

    fn eat(&mut self, kind: TokenKind) -> Option<Token> {
        match self.peek() {
            Some(t) if t.kind == kind => {
                self.pos += 1;
                Some(t)
            }
            _ => None,
        }
    }

    /// `expr where decl, ..`: the declarations after the Hamiltonian `body`, if any.
    fn source(&mut self, body: Ast) -> Result<Ast, Error> {
        match self.peek() {
            Some(t) if t.kind == TokenKind::Ident && self.text(t.span) == "where" => self.pos += 1,
            _ => return Ok(body),
        }
        let mut decls = Vec::new();
        loop {
            let mut parts = vec![self.expr()?];
            if self.peek().map(|t| t.kind) != Some(TokenKind::Eq) {
                let at = self.peek().map_or(parts[0].span(), |t| t.span);
                return Err(Error::new(ErrorKind::Declaration, at));
            }
            while self.eat(TokenKind::Eq).is_some() {
                parts.push(self.expr()?);
            }
            let value = parts.pop().unwrap_or(Ast::Number(Span::default()));
            decls.push(match (&parts[..], parts.first()) {
                ([_], Some(Ast::Name(name))) => Decl::Constant { name: *name, value },
                _ => Decl::Boundary {
                    targets: parts,
                    value,
                },
            });
            if self.eat(TokenKind::Comma).is_none() {
                break;
            }
        }
        Ok(Ast::Where {
            body: Box::new(body),
            decls,
        })
    }

    fn expr(&mut self) -> Result<Ast, Error> {
        self.chain(Self::term, |kind| match kind {
            TokenKind::Plus => Some(BinOp::Add),
            TokenKind::Minus => Some(BinOp::Sub),
            _ => None,
        })
    }

    fn term(&mut self) -> Result<Ast, Error> {
        self.chain(Self::unary, |kind| match kind {
            TokenKind::Star => Some(BinOp::Mul),
            TokenKind::Slash => Some(BinOp::Div),
            _ => None,
        })
    }

    /// `operand (op operand)*` for one precedence level (`expr`: `+ -`, `term`: `* /`), left to
    /// right: the lone operand, or one `Ast::Chain` of them.
    fn chain(
        &mut self,
        operand: fn(&mut Self) -> Result<Ast, Error>,
        op_of: fn(TokenKind) -> Option<BinOp>,
    ) -> Result<Ast, Error> {
        let first = operand(self)?;
        let mut rest = Vec::new();
        while let Some(t) = self.peek() {
            let Some(op) = op_of(t.kind) else { break };
            self.pos += 1;
            rest.push((op, t.span, operand(self)?));
        }
        Ok(if rest.is_empty() {
            first
        } else {
            Ast::Chain {
                first: Box::new(first),
                rest,
            }
        })
    }

    /// Every level of nesting (parentheses, signs, exponents) passes here: the depth limit.
    fn unary(&mut self) -> Result<Ast, Error> {
        self.depth += 1;
        if self.depth > MAX_DEPTH {
            let span = self
                .peek()
                .map_or(Span::new(self.src.len(), self.src.len()), |t| t.span);
            return Err(Error::new(ErrorKind::TooDeep, span));
        }
        let r = self.signed();
        self.depth -= 1;
        r
    }

    fn signed(&mut self) -> Result<Ast, Error> {
        if let Some(t) = self.peek() {
            if matches!(t.kind, TokenKind::Minus | TokenKind::Plus) {
                self.pos += 1;
                let arg = self.unary()?;
                let span = t.span.to(arg.span());
                return Ok(Ast::Unary {
                    negate: t.kind == TokenKind::Minus,
                    arg: Box::new(arg),
                    span,
                });
            }
        }
        self.power()
    }

    fn power(&mut self) -> Result<Ast, Error> {
        let base = self.atom()?;
        let op_span = match (self.peek(), self.tokens.get(self.pos + 1)) {
            (Some(t), _) if t.kind == TokenKind::Caret => t.span,
            // `**`: read as `^` and reported.
            (Some(a), Some(b)) if a.kind == TokenKind::Star && b.kind == TokenKind::Star => {
                a.span.to(b.span)
            }
            _ => return Ok(base),
        };
        let double_star = self.tokens[self.pos].kind == TokenKind::Star;
        self.pos += if double_star { 2 } else { 1 };
        let exp = self.unary()?;
        if double_star {
            let power = format!(
                "{}^{}",
                operand_text(self.src, &base),
                operand_text(self.src, &exp)
            );
            self.errors
                .push(Error::new(ErrorKind::DoubleStar { power }, op_span));
        }
        Ok(Ast::Binary {
            op: BinOp::Pow,
            op_span,
            lhs: Box::new(base),
            rhs: Box::new(exp),
        })
    }

    fn atom(&mut self) -> Result<Ast, Error> {
        let Some(t) = self.peek() else {
            // At the end: point at the last token (the dangling operator).
            let span = self.tokens.last().map_or(Span::default(), |t| t.span);
            return Err(Error::new(ErrorKind::ExpectedOperand { found: None }, span));
        };
        self.pos += 1;
        match t.kind {
            TokenKind::Number => Ok(Ast::Number(t.span)),
            TokenKind::Ident if self.peek().map(|n| n.kind) == Some(TokenKind::LBracket) => {
                self.pos += 1;
                let index = self.expr()?;
                let close = self.close_bracket()?;
                Ok(Ast::Index {
                    name: t.span,
                    index: Box::new(index),
                    span: t.span.to(close),
                })
            }
            TokenKind::Ident
                if self.text(t.span) == "sum"
                    && self.peek().map(|n| n.kind) == Some(TokenKind::LParen) =>
            {
                let open = self.eat(TokenKind::LParen).map_or(t.span, |o| o.span);
                let range = self.range()?;
                match self.peek() {
                    Some(c) if c.kind == TokenKind::Comma => self.pos += 1,
                    Some(c) => return Err(Error::new(ErrorKind::SumRange, c.span)),
                    None => return Err(Error::new(ErrorKind::UnclosedParen, open)),
                }
                let body = self.expr()?;
                let close = self.close(open)?;
                Ok(Ast::Sum {
                    range: Box::new(range),
                    body: Box::new(body),
                    span: t.span.to(close),
                })
            }
            TokenKind::LBracket => {
                // Brackets used for grouping: reported over the group, read as parentheses.
                let inner = self.expr()?;
                let close = self.close_bracket()?;
                let span = t.span.to(close);
                self.errors.push(Error::new(ErrorKind::Brackets, span));
                Ok(Ast::Paren {
                    inner: Box::new(inner),
                    span,
                })
            }
            TokenKind::Ident => {
                if let Some(open) = self.eat(TokenKind::LParen) {
                    let arg = self.expr()?;
                    let mut extra = Vec::new();
                    while self.eat(TokenKind::Comma).is_some() {
                        extra.push(self.expr()?);
                    }
                    let close = self.close(open.span)?;
                    Ok(Ast::Call {
                        name: t.span,
                        arg: Box::new(arg),
                        extra,
                        span: t.span.to(close),
                    })
                } else if is_function(self.text(t.span))
                    && self
                        .peek()
                        .is_some_and(|n| matches!(n.kind, TokenKind::Ident | TokenKind::Number))
                {
                    // `sin q1`: read as `sin(q1)` (the operand with its power, `sin q1^2` as
                    // `sin(q1^2)`) and reported.
                    let arg = self.unary()?;
                    self.errors.push(Error::new(
                        ErrorKind::CallWithoutParens {
                            name: self.text(t.span).to_string(),
                            arg: self.text(arg.span()).to_string(),
                        },
                        t.span,
                    ));
                    let span = t.span.to(arg.span());
                    Ok(Ast::Call {
                        name: t.span,
                        arg: Box::new(arg),
                        extra: Vec::new(),
                        span,
                    })
                } else {
                    Ok(Ast::Name(t.span))
                }
            }
            TokenKind::LParen => {
                let inner = self.expr()?;
                let close = self.close(t.span)?;
                Ok(Ast::Paren {
                    inner: Box::new(inner),
                    span: t.span.to(close),
                })
            }
            _ => Err(Error::new(
                ErrorKind::ExpectedOperand {
                    found: Some(self.text(t.span).to_string()),
                },
                t.span,
            )),
        }
    }

    /// A sum's range: `i = lo..hi` or `lo <= i < j <= hi`.
    fn range(&mut self) -> Result<Range, Error> {
        let ident = |p: &mut Self| match p.peek() {
            Some(t) if t.kind == TokenKind::Ident => {
                p.pos += 1;
                Ok(t.span)
            }
            Some(t) => Err(Error::new(ErrorKind::SumRange, t.span)),
            None => Err(Error::new(ErrorKind::SumRange, p.end())),
        };
        let expect = |p: &mut Self, kinds: &[TokenKind]| match p.peek() {
            Some(t) if kinds.contains(&t.kind) => {
                p.pos += 1;
                Ok(t.kind)
            }
            Some(t) => Err(Error::new(ErrorKind::SumRange, t.span)),
            None => Err(Error::new(ErrorKind::SumRange, p.end())),
        };
        let single = matches!(
            (self.peek(), self.tokens.get(self.pos + 1)),
            (Some(a), Some(b)) if a.kind == TokenKind::Ident && b.kind == TokenKind::Eq
        );
        if single {
            let index = ident(self)?;
            expect(self, &[TokenKind::Eq])?;
            let lo = self.expr()?;
            expect(self, &[TokenKind::DotDot])?;
            let hi = self.expr()?;
            return Ok(Range::Single { index, lo, hi });
        }
        let lo = self.expr()?;
        let lo_strict = expect(self, &[TokenKind::Le, TokenKind::Lt])? == TokenKind::Lt;
        let i = ident(self)?;
        expect(self, &[TokenKind::Lt])?;
        let j = ident(self)?;
        let hi_strict = expect(self, &[TokenKind::Le, TokenKind::Lt])? == TokenKind::Lt;
        let hi = self.expr()?;
        Ok(Range::Pairs {
            lo,
            lo_strict,
            i,
            j,
            hi_strict,
            hi,
        })
    }

    /// An empty span at the end of the source.
    fn end(&self) -> Span {
        self.tokens.last().map_or(Span::default(), |t| t.span)
    }

    fn close_bracket(&mut self) -> Result<Span, Error> {
        match self.peek() {
            Some(t) if t.kind == TokenKind::RBracket => {
                self.pos += 1;
                Ok(t.span)
            }
            None => Err(Error::new(ErrorKind::UnclosedParen, self.end())),
            Some(t) => Err(self.unexpected(t)),
        }
    }

    fn close(&mut self, open: Span) -> Result<Span, Error> {
        match self.peek() {
            Some(t) if t.kind == TokenKind::RParen => {
                self.pos += 1;
                Ok(t.span)
            }
            None => Err(Error::new(ErrorKind::UnclosedParen, open)),
            Some(t) => Err(self.unexpected(t)),
        }
    }
}
