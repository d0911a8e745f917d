//! The expression arena: a flat, hash-consed `Vec<Node>` with children before parents.
//!
//! Building a node that already exists returns the existing [`Id`], so every distinct
//! subexpression of the value, gradient, Hessian and Psi exists once: common-subexpression
//! elimination is free. Nodes are only created through the simplifying constructors in
//! [`crate::simplify`], so every node is in canonical form (sums and products flattened, their
//! operands sorted by `Id`, constants folded).

use std::collections::HashMap;

use crate::number::Num;
use crate::span::Span;

/// Index of a node in its [`Arena`]; children always have smaller ids than their parents.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub struct Id(pub(crate) u32);

impl Id {
    /// The index into the arena.
    pub fn index(self) -> usize {
        self.0 as usize
    }
}

/// A variable of the phase space, or a run-time parameter.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, PartialOrd, Ord)]
pub enum Var {
    /// Position `q_i`, `i >= 1`.
    Q(u32),
    /// Momentum `p_i`, `i >= 1`.
    P(u32),
    /// Time `t` (makes the Hamiltonian time-dependent).
    T,
    /// The momentum `p_t` conjugate to `t` in the extended phase space.
    Pt,
    /// The `k`-th declared parameter (a constant for differentiation, read at run time).
    Param(u32),
}

/// An elementary function of the grammar (`sqrt` is the power `1/2`).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum Func {
    /// `sin`
    Sin,
    /// `cos`
    Cos,
    /// `tan`
    Tan,
    /// `exp`
    Exp,
    /// `ln` (natural logarithm)
    Ln,
    /// `sinh`
    Sinh,
    /// `cosh`
    Cosh,
    /// `tanh`
    Tanh,
    /// `atan`
    Atan,
}

impl Func {
    /// The name in the grammar (and of the `f64` method).
    pub fn name(self) -> &'static str {
        match self {
            Func::Sin => "sin",
            Func::Cos => "cos",
            Func::Tan => "tan",
            Func::Exp => "exp",
            Func::Ln => "ln",
            Func::Sinh => "sinh",
            Func::Cosh => "cosh",
            Func::Tanh => "tanh",
            Func::Atan => "atan",
        }
    }

    /// Evaluates with the `f64` method of the same name.
    pub fn apply(self, x: f64) -> f64 {
        match self {
            Func::Sin => x.sin(),
            Func::Cos => x.cos(),
            Func::Tan => x.tan(),
            Func::Exp => x.exp(),
            Func::Ln => x.ln(),
            Func::Sinh => x.sinh(),
            Func::Cosh => x.cosh(),
            Func::Tanh => x.tanh(),
            Func::Atan => x.atan(),
        }
    }

    /// All functions, for name lookup.
    pub const ALL: [Func; 9] = [
        Func::Sin,
        Func::Cos,
        Func::Tan,
        Func::Exp,
        Func::Ln,
        Func::Sinh,
        Func::Cosh,
        Func::Tanh,
        Func::Atan,
    ];
}

/// One node. Sums and products are n-ary with operands sorted by id and at most one constant;
/// powers have a constant exponent (a variable exponent is rewritten as `exp(b ln a)`).
#[derive(Clone, Debug, PartialEq, Eq, Hash)]
pub enum Node {
    /// A constant.
    Num(Num),
    /// A variable or parameter.
    Var(Var),
    /// A sum of at least two terms.
    Add(Box<[Id]>),
    /// A product of at least two factors.
    Mul(Box<[Id]>),
    /// `base ^ exponent`, exponent neither 0 nor 1.
    Pow(Id, Num),
    /// `f(x)`.
    Func(Func, Id),
}

/// Number of 64-bit words of a [`VarSet`]: one bit per phase-space variable `q1..q512`,
/// `p1..p512`, `t`, `p_t` (see [`VarSet::bit`]).
const WORDS: usize = (2 * crate::MAX_INDEX + 2).div_ceil(64);

/// The phase-space variables a node depends on, as a bitset (parameters are constants for
/// differentiation and have no bit). Computed once per node when it is interned, from its
/// children's sets, so asking "does this node depend on `x`?" costs one bit test: it lets
/// differentiation return `0` without walking a subtree, and the Hessian visit only the pairs
/// that can be nonzero.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct VarSet([u64; WORDS]);

impl VarSet {
    /// The bit of `v`: `t` 0, `p_t` 1, `q_i` `2i`, `p_i` `2i + 1`; `None` for parameters.
    pub fn bit(v: Var) -> Option<usize> {
        match v {
            Var::T => Some(0),
            Var::Pt => Some(1),
            Var::Q(i) => Some(2 * i as usize),
            Var::P(i) => Some(2 * i as usize + 1),
            Var::Param(_) => None,
        }
    }

    /// `true` when `v` is in the set.
    pub fn contains(&self, v: Var) -> bool {
        Self::bit(v).is_some_and(|b| b < 64 * WORDS && self.0[b / 64] >> (b % 64) & 1 == 1)
    }

    /// `true` when no variable is in the set.
    pub fn is_empty(&self) -> bool {
        self.0.iter().all(|&w| w == 0)
    }

    fn insert(&mut self, v: Var) {
        if let Some(b) = Self::bit(v).filter(|&b| b < 64 * WORDS) {
            self.0[b / 64] |= 1 << (b % 64);
        }
    }

    fn union(&mut self, other: &VarSet) {
        for (a, b) in self.0.iter_mut().zip(other.0.iter()) {
            *a |= b;
        }
    }
}

/// The arena of hash-consed nodes, with the source span of each node.
#[derive(Clone, Debug, Default)]
pub struct Arena {
    nodes: Vec<Node>,
    spans: Vec<Span>,
    deps: Vec<VarSet>,
    index: HashMap<Node, Id>,
    params: Vec<String>,
    /// Span given to nodes created from now on (the builder sets it to the AST node being
    /// built; differentiation sets it to the node being differentiated, so derivatives inherit).
    pub(crate) span: Span,
    /// Derivative rules applied so far ([`Arena::diff`] on a node that depends on the
    /// variable): the engine's work, which tests check grows linearly.
    pub(crate) diff_work: usize,
    /// Nodes plus their children, summed: the memory the expressions take, in `Id`s.
    size: usize,
}

impl Arena {
    /// An empty arena whose `Var::Param(k)` is named `params[k]`.
    pub fn new(params: &[&str]) -> Self {
        Arena {
            params: params.iter().map(|s| s.to_string()).collect(),
            ..Default::default()
        }
    }

    /// The node `id`.
    pub fn node(&self, id: Id) -> &Node {
        &self.nodes[id.index()]
    }

    /// The phase-space variables `id` depends on.
    pub fn deps(&self, id: Id) -> &VarSet {
        &self.deps[id.index()]
    }

    /// `true` when `id` depends on the variable `x` (always `false` for a parameter).
    pub fn depends_on(&self, id: Id, x: Var) -> bool {
        self.deps[id.index()].contains(x)
    }

    /// Derivative rules applied so far by [`Arena::diff`] (nodes visited that depend on the
    /// variable): a deterministic measure of the engine's work.
    pub fn diff_work(&self) -> usize {
        self.diff_work
    }

    /// The source span of the node `id` (of the first place it was built from).
    pub fn span(&self, id: Id) -> Span {
        self.spans[id.index()]
    }

    /// Nodes plus their children, summed over the distinct nodes: the arena's memory in
    /// `Id`s, and the bound [`crate::compile`] keeps ([`crate::MAX_SIZE`]).
    pub fn size(&self) -> usize {
        self.size
    }

    /// Every node's id, in the order built (children before their parents).
    pub fn ids(&self) -> impl Iterator<Item = Id> {
        (0..self.nodes.len() as u32).map(Id)
    }

    /// Number of distinct nodes.
    pub fn len(&self) -> usize {
        self.nodes.len()
    }

    /// `true` when empty.
    pub fn is_empty(&self) -> bool {
        self.nodes.is_empty()
    }

    /// The declared parameter names.
    pub fn params(&self) -> &[String] {
        &self.params
    }

    /// The constant value of `id`, if it is a constant.
    pub fn as_num(&self, id: Id) -> Option<Num> {
        match self.node(id) {
            Node::Num(n) => Some(*n),
            _ => None,
        }
    }

    /// `true` when `id` is the constant 0.
    pub fn is_zero(&self, id: Id) -> bool {
        self.as_num(id).is_some_and(Num::is_zero)
    }

    /// Returns the id of `node`, creating it if new. Callers guarantee canonical form.
    pub(crate) fn intern(&mut self, node: Node) -> Id {
        if let Some(&id) = self.index.get(&node) {
            return id;
        }
        let id = Id(u32::try_from(self.nodes.len()).expect("arena exceeds u32::MAX nodes"));
        let mut deps = VarSet::default();
        match &node {
            Node::Num(_) => {}
            Node::Var(v) => deps.insert(*v),
            Node::Add(c) | Node::Mul(c) => c.iter().for_each(|c| deps.union(&self.deps[c.index()])),
            Node::Pow(b, _) | Node::Func(_, b) => deps = self.deps[b.index()],
        }
        self.size += 1 + match &node {
            Node::Num(_) | Node::Var(_) => 0,
            Node::Add(c) | Node::Mul(c) => c.len(),
            Node::Pow(..) | Node::Func(..) => 1,
        };
        self.deps.push(deps);
        self.nodes.push(node.clone());
        self.spans.push(self.span);
        self.index.insert(node, id);
        id
    }

    /// The children of `id`.
    pub fn children(&self, id: Id) -> Vec<Id> {
        match self.node(id) {
            Node::Num(_) | Node::Var(_) => Vec::new(),
            Node::Add(c) | Node::Mul(c) => c.to_vec(),
            Node::Pow(b, _) | Node::Func(_, b) => vec![*b],
        }
    }

    /// The variables `id` depends on (parameters included), sorted.
    pub fn vars(&self, id: Id) -> Vec<Var> {
        let mut seen = vec![false; id.index() + 1];
        seen[id.index()] = true;
        let mut out = Vec::new();
        // Children have smaller ids: one downward sweep visits each reachable node once.
        for i in (0..=id.index()).rev() {
            if !seen[i] {
                continue;
            }
            let node = Id(i as u32);
            if let Node::Var(v) = self.node(node) {
                out.push(*v);
            }
            for c in self.children(node) {
                seen[c.index()] = true;
            }
        }
        out.sort();
        out
    }
}
