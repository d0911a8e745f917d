//! A lattice compiled in loops ([`dth_symbolic::looped`]) as plans the JIT and the interpreter
//! both run: per function ([`LoopFunction`]), per sum, the summand's program and where, at each
//! site, it reads its local coordinates and adds its outputs.
//!
//! The plans mirror the code `hamiltonian!` emits for the same lattice
//! (`dth_symbolic::emit::lattice`): the same summand programs, sums in order, sites in order,
//! and the outputs added in the emitted order (`acc += e` for a value, `g[a] += e` for a
//! gradient in the program's output order, `values[at] += e` for the Hessian's nonzeros in the
//! summand's pattern order, `2 e` where two slots are one variable), so the results are the
//! macro's bits. The Hessian's pattern and the position each (sum, entry, site) writes to are
//! the macro's layout ([`dth_symbolic::looped::diagonals`]).
//!
//! A sum's sites are cut into its interior, where every slot `q[i + c]` is a variable of the
//! lattice (`1 <= i + c <= N`), and the few sites at its ends, which reach a boundary. In the
//! interior every address is the site plus a constant, so one plan, relative to the site,
//! serves the whole interior (one loop); each end site has a plan of its own, with absolute
//! addresses. How many end sites there are depends on the offsets and the boundaries, not on
//! `N`, so the plans, and the code compiled from them, do not grow with the lattice.
//!
//! A nested sum (over pairs, nested or strided, [`dth_symbolic::looped::nested`]) is one plan
//! ([`NestedPlan`]) for all its index tuples: every address is affine in the indices `(i, j)`
//! (`z[3 j - 3]`), and a Hessian entry of a sum over pairs lands in its dense block at
//! [`Block::position`] of its row and column, computed in the loop.

use dth_symbolic::looped::diagonals::{layout, Block, Layout};
use dth_symbolic::looped::nested::{NestedSlot, Tuples};
use dth_symbolic::looped::{Looped, Site};
use dth_symbolic::{Method, Output, Program};

use crate::error::RuntimeError;

/// A function of a looped lattice computed by loops over its sites. The dense Hessian, Psi and
/// the fused derivatives are assembled from these, as the macro's looped types assemble them.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum LoopFunction {
    /// `H(z)`.
    Value,
    /// `grad H(z)`.
    Gradient,
    /// The Hessian's nonzeros, in the order of the pattern.
    HessianNonzeros,
    /// The exact discrete gradient.
    DiscreteGradient,
    /// `H(z1) - H(z0)` without cancellation.
    EnergyDifference,
    /// `grad H(z0) + grad H(z1) - 2 gbar(z0, z1)` without cancellation.
    DiscreteGradientDefect,
}

impl LoopFunction {
    /// Every looped function, in the order [`crate::RuntimeHamiltonian`] compiles them.
    pub const ALL: [LoopFunction; 6] = [
        LoopFunction::Value,
        LoopFunction::Gradient,
        LoopFunction::HessianNonzeros,
        LoopFunction::DiscreteGradient,
        LoopFunction::EnergyDifference,
        LoopFunction::DiscreteGradientDefect,
    ];

    /// The name of the trait method (as [`crate::Function::name`]).
    pub fn name(self) -> &'static str {
        match self {
            LoopFunction::Value => "value",
            LoopFunction::Gradient => "gradient",
            LoopFunction::HessianNonzeros => "hessian",
            LoopFunction::DiscreteGradient => "discrete_gradient",
            LoopFunction::EnergyDifference => "energy_difference",
            LoopFunction::DiscreteGradientDefect => "discrete_gradient_defect",
        }
    }

    /// `true` for the functions of two points.
    pub fn two_point(self) -> bool {
        matches!(
            self,
            LoopFunction::DiscreteGradient
                | LoopFunction::EnergyDifference
                | LoopFunction::DiscreteGradientDefect
        )
    }

    /// `true` when the function is one value, accumulated over the sites.
    pub fn scalar(self) -> bool {
        matches!(self, LoopFunction::Value | LoopFunction::EnergyDifference)
    }

    /// The output a scalar function ([`LoopFunction::scalar`]) adds up.
    fn scalar_output(self) -> Output {
        if self == LoopFunction::Value {
            Output::Value
        } else {
            Output::EnergyDifference
        }
    }

    /// The summand output this function adds up, for the vector functions: `Some(k)` of
    /// output `k` of the local coordinates.
    fn local_output(self, o: Output) -> Option<usize> {
        match (self, o) {
            (LoopFunction::Gradient, Output::Gradient(l))
            | (LoopFunction::DiscreteGradient, Output::DiscreteGradient(l))
            | (LoopFunction::DiscreteGradientDefect, Output::DiscreteGradientDefect(l)) => Some(l),
            _ => None,
        }
    }

    /// The summand program of `system` this function runs, pruned to the outputs it adds up
    /// (pruning drops operations, never changes those kept).
    fn program(self, system: &dth_symbolic::System) -> Program {
        let method = match self {
            LoopFunction::Value => Method::Value,
            LoopFunction::Gradient => Method::Gradient,
            LoopFunction::HessianNonzeros => Method::Hessian,
            LoopFunction::DiscreteGradient | LoopFunction::EnergyDifference => {
                Method::DiscreteGradient
            }
            LoopFunction::DiscreteGradientDefect => Method::DiscreteGradientDefect,
        };
        system.program(method).prune(|o| match self {
            LoopFunction::Value => o == Output::Value,
            LoopFunction::EnergyDifference => o == Output::EnergyDifference,
            LoopFunction::HessianNonzeros => matches!(o, Output::Hessian(..)),
            _ => self.local_output(o).is_some(),
        })
    }
}

/// Where a local coordinate is read at a site.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Load {
    /// `z[index]` (of `z1` for a two-point program's second point), the index relative to the
    /// site in a loop's plan.
    Z(i64),
    /// A fixed boundary's value, or `0` for a local coordinate no slot reads.
    Const(f64),
}

/// Where one output is added.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Target {
    /// The function's one value (`acc += e`).
    Acc,
    /// `out[index]`, the index relative to the site in a loop's plan.
    Out(i64),
}

/// One addition at a site: `target += e` (`2 e` when `twice`), `e` the summand's output
/// `source`, or `0` when the program does not compute it.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Store {
    /// The summand's output.
    pub source: Option<Output>,
    /// Where it is added.
    pub target: Target,
    /// Two slots of the entry are one variable (a ring of two): the entry counts twice.
    pub twice: bool,
}

/// What happens at one site (or at every site of a loop, relative to the site).
#[derive(Clone, Debug, PartialEq)]
pub struct SitePlan {
    /// Per local coordinate of the summand.
    pub loads: Vec<Load>,
    /// The additions, in the order the macro's code makes them.
    pub stores: Vec<Store>,
}

impl SitePlan {
    /// The plan moved by `-shift`: every index of `z` and `out` less `shift`.
    fn shifted(&self, shift: i64) -> SitePlan {
        SitePlan {
            loads: self
                .loads
                .iter()
                .map(|l| match *l {
                    Load::Z(k) => Load::Z(k - shift),
                    c => c,
                })
                .collect(),
            stores: self
                .stores
                .iter()
                .map(|s| Store {
                    target: match s.target {
                        Target::Out(k) => Target::Out(k - shift),
                        Target::Acc => Target::Acc,
                    },
                    ..*s
                })
                .collect(),
        }
    }
}

/// Sites `first..=last` run `plan`: relative to the site when `relative` (a loop), else
/// `first == last` and the addresses are absolute.
#[derive(Clone, Debug, PartialEq)]
pub struct Segment {
    /// The first site.
    pub first: i64,
    /// The last site.
    pub last: i64,
    /// `true` for the interior's loop.
    pub relative: bool,
    /// What happens at each site.
    pub plan: SitePlan,
}

/// One sum of one function: its program and its segments, in the order of the sites.
#[derive(Clone, Debug)]
pub struct SumPlan {
    /// The summand's program, in its local coordinates.
    pub program: Program,
    /// The sites, cut into the interior's loop and the end sites.
    pub segments: Vec<Segment>,
}

/// An index affine in a nested sum's indices: `coef[0] i + coef[1] j + offset`.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Affine {
    /// The coefficients of the outer and the inner index.
    pub coef: [i64; 2],
    /// The constant.
    pub offset: i64,
}

impl Affine {
    /// Its value at the indices `at = [i, j]`.
    pub fn at(&self, at: [i64; 2]) -> i64 {
        self.coef[0] * at[0] + self.coef[1] * at[1] + self.offset
    }

    /// The position in `z` of a slot of a lattice of `n` sites.
    fn of(slot: &NestedSlot, n: usize) -> Affine {
        let shift = if slot.letter == 'q' { 0 } else { n as i64 };
        Affine {
            coef: slot.coef,
            offset: slot.offset - 1 + shift,
        }
    }
}

/// Where a local coordinate of a nested sum is read at a tuple.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum TupleLoad {
    /// `z[index]` (of `z1` for a two-point program's second point).
    Z(Affine),
    /// `0` for a local coordinate no slot reads.
    Const(f64),
}

/// Where one output of a nested sum is added at a tuple.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum TupleTarget {
    /// The function's one value.
    Acc,
    /// `out[index]`.
    Out(Affine),
    /// `out[block.position(a, b)]`: an entry of a dense block of the Hessian.
    Block {
        /// The block.
        block: Block,
        /// The entry's row and column (either order).
        a: Affine,
        /// See `a`.
        b: Affine,
    },
}

/// One addition at a tuple: `target += e`, `e` the summand's output `source` (`0` when the
/// program does not compute it).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct TupleStore {
    /// The summand's output.
    pub source: Option<Output>,
    /// Where it is added.
    pub target: TupleTarget,
}

/// One nested sum ([`dth_symbolic::looped::nested`]) of one function: its program, its index
/// tuples and what happens at each, relative to the indices.
#[derive(Clone, Debug)]
pub struct NestedPlan {
    /// The summand's program, in its local coordinates.
    pub program: Program,
    /// The index tuples.
    pub tuples: Tuples,
    /// Per local coordinate of the summand.
    pub loads: Vec<TupleLoad>,
    /// The additions, in the order the macro's code makes them.
    pub stores: Vec<TupleStore>,
}

/// One function of the lattice: its sums in order.
#[derive(Clone, Debug)]
pub struct LoopCode {
    /// Which function.
    pub function: LoopFunction,
    /// The sums over sites, in the order written.
    pub sums: Vec<SumPlan>,
    /// The nested sums, in the order written, after the sums over sites.
    pub nested: Vec<NestedPlan>,
    /// The lattice's dimension `D` (every `z` index is below it).
    pub dim: usize,
    /// The length of the output buffer: 1, `D` or the number of nonzeros.
    pub len: usize,
    /// The number of parameters.
    pub params: usize,
}

/// The lattice's plans for every [`LoopFunction`], its pattern and its layout.
#[derive(Clone, Debug)]
pub struct LatticePlan {
    /// One per [`LoopFunction::ALL`], in that order.
    pub functions: Vec<LoopCode>,
    /// The Hessian's nonzeros, upper triangle, the macro's order (its runs expanded, then its
    /// dense blocks).
    pub pattern: Vec<(usize, usize)>,
    /// The pattern as the macro lays it out (runs along the diagonals).
    pub layout: Layout,
}

impl LatticePlan {
    /// The plans of `looped` with `params` parameters. An index that would leave its buffer is
    /// [`RuntimeError::MalformedProgram`] (the plans are built so it cannot happen; compiled
    /// code trusts them).
    pub fn new(looped: &Looped, params: usize) -> Result<LatticePlan, RuntimeError> {
        let layout = layout(looped);
        let pattern = layout.pattern();
        let functions = LoopFunction::ALL
            .iter()
            .map(|&f| code(looped, &layout, f, params))
            .collect::<Result<Vec<_>, _>>()?;
        Ok(LatticePlan {
            functions,
            pattern,
            layout,
        })
    }
}

/// The plans of function `f`.
fn code(
    looped: &Looped,
    layout: &Layout,
    f: LoopFunction,
    params: usize,
) -> Result<LoopCode, RuntimeError> {
    let dim = looped.dim();
    let len = match f {
        LoopFunction::Value | LoopFunction::EnergyDifference => 1,
        LoopFunction::HessianNonzeros => layout.nnz,
        _ => dim,
    };
    let n = looped.n() as i64;
    let mut sums = Vec::with_capacity(looped.sums().len());
    for (k, s) in looped.sums().iter().enumerate() {
        let program = f.program(s.summand());
        let at = |i: i64| site_plan(looped, layout, f, &program, k, i);
        let (lo, hi) = s.range();
        // Every slot in the lattice: `1 <= i + c <= n` for every offset `c`.
        let (cmin, cmax) = s
            .slots()
            .iter()
            .fold((0i64, 0i64), |(a, b), &(_, c, _)| (a.min(c), b.max(c)));
        let (first, last) = (lo.max(1 - cmin), hi.min(n - cmax));
        let mut segments = Vec::new();
        let end = |i: i64| Segment {
            first: i,
            last: i,
            relative: false,
            plan: at(i),
        };
        if first <= last {
            segments.extend((lo..first).map(end));
            // The interior's plan, relative to the site: the same at both ends.
            let plan = at(first).shifted(first);
            if at(last).shifted(last) != plan {
                return Err(malformed(
                    f,
                    "the interior's plan is not the same at every site",
                ));
            }
            segments.push(Segment {
                first,
                last,
                relative: true,
                plan,
            });
            segments.extend((last + 1..=hi).map(end));
        } else {
            segments.extend((lo..=hi).map(end));
        }
        sums.push(SumPlan { program, segments });
    }
    let nested = (0..looped.nested().len())
        .map(|k| nested_plan(looped, layout, f, k))
        .collect();
    let code = LoopCode {
        function: f,
        sums,
        nested,
        dim,
        len,
        params,
    };
    check(&code)?;
    Ok(code)
}

/// What happens at site `i` of sum `k` for function `f` (absolute addresses).
fn site_plan(
    looped: &Looped,
    layout: &Layout,
    f: LoopFunction,
    program: &Program,
    k: usize,
    i: i64,
) -> SitePlan {
    let s = &looped.sums()[k];
    let site_of = |slot: usize| {
        let (letter, c, _) = s.slots()[slot];
        looped.site(letter, i + c)
    };
    let slot_of_local = |l: usize| s.slots().iter().position(|&(_, _, local)| local == l);
    let loads = (0..s.summand().dim())
        .map(|l| match slot_of_local(l).map(site_of) {
            Some(Site::Var(a)) => Load::Z(a as i64),
            Some(Site::Const(v)) => Load::Const(v),
            None => Load::Const(0.0),
        })
        .collect();
    let mut stores = Vec::new();
    let computed = |o: Output| program.outputs.iter().any(|&(x, _)| x == o);
    match f {
        LoopFunction::Value | LoopFunction::EnergyDifference => {
            let o = f.scalar_output();
            stores.push(Store {
                source: computed(o).then_some(o),
                target: Target::Acc,
                twice: false,
            });
        }
        LoopFunction::HessianNonzeros => {
            for (idx, &(r, t)) in s.pattern().iter().enumerate() {
                let (lr, lt) = (s.slots()[r].2, s.slots()[t].2);
                let o = Output::Hessian(lr.min(lt), lr.max(lt));
                let place = &layout.places[k][idx];
                let at = match place.interior {
                    Some((lo, hi, base)) if (lo..=hi).contains(&i) => Some(base + i),
                    _ => place
                        .edges
                        .iter()
                        .find(|&&(e, _)| e == i)
                        .map(|&(_, at)| at as i64),
                };
                let Some(at) = at else { continue };
                let var = |slot: usize| match site_of(slot) {
                    Site::Var(a) => Some(a),
                    Site::Const(_) => None,
                };
                stores.push(Store {
                    source: computed(o).then_some(o),
                    target: Target::Out(at),
                    twice: r != t && var(r) == var(t),
                });
            }
        }
        _ => {
            for &(o, _) in &program.outputs {
                let Some(l) = f.local_output(o) else { continue };
                let Some(slot) = slot_of_local(l) else {
                    continue;
                };
                if let Site::Var(a) = site_of(slot) {
                    stores.push(Store {
                        source: Some(o),
                        target: Target::Out(a as i64),
                        twice: false,
                    });
                }
            }
        }
    }
    SitePlan { loads, stores }
}

/// The plan of nested sum `k` for function `f`: loads and stores relative to the indices.
fn nested_plan(looped: &Looped, layout: &Layout, f: LoopFunction, k: usize) -> NestedPlan {
    let s = &looped.nested()[k];
    let program = f.program(s.summand());
    let n = looped.n();
    let slot_of_local = |l: usize| s.slots().iter().find(|slot| slot.local == l);
    let loads = (0..s.summand().dim())
        .map(|l| match slot_of_local(l) {
            Some(slot) => TupleLoad::Z(Affine::of(slot, n)),
            None => TupleLoad::Const(0.0),
        })
        .collect();
    let computed = |o: Output| program.outputs.iter().any(|&(x, _)| x == o);
    let mut stores = Vec::new();
    match f {
        LoopFunction::Value | LoopFunction::EnergyDifference => {
            let o = f.scalar_output();
            stores.push(TupleStore {
                source: computed(o).then_some(o),
                target: TupleTarget::Acc,
            });
        }
        LoopFunction::HessianNonzeros => {
            for (idx, &(r, t)) in s.pattern().iter().enumerate() {
                let (sr, st) = (&s.slots()[r], &s.slots()[t]);
                let o = Output::Hessian(sr.local.min(st.local), sr.local.max(st.local));
                let place = &layout.nested[k][idx];
                let target = match (place.block, place.interior) {
                    (Some(b), _) => TupleTarget::Block {
                        block: layout.blocks[b],
                        a: Affine::of(sr, n),
                        b: Affine::of(st, n),
                    },
                    (None, Some((_, _, base))) => TupleTarget::Out(Affine {
                        coef: [place.stride, 0],
                        offset: base,
                    }),
                    (None, None) => continue,
                };
                stores.push(TupleStore {
                    source: computed(o).then_some(o),
                    target,
                });
            }
        }
        _ => {
            for &(o, _) in &program.outputs {
                let Some(l) = f.local_output(o) else { continue };
                let Some(slot) = slot_of_local(l) else {
                    continue;
                };
                stores.push(TupleStore {
                    source: Some(o),
                    target: TupleTarget::Out(Affine::of(slot, n)),
                });
            }
        }
    }
    NestedPlan {
        program,
        tuples: *s.tuples(),
        loads,
        stores,
    }
}

fn malformed(f: LoopFunction, reason: &str) -> RuntimeError {
    RuntimeError::MalformedProgram {
        what: f.name(),
        reason: reason.to_string(),
    }
}

/// Every address of every segment inside its buffer, at both ends of a loop; every source an
/// output of the program; every program well formed (see [`crate::jit::check`]).
fn check(code: &LoopCode) -> Result<(), RuntimeError> {
    let f = code.function;
    for sum in &code.sums {
        let p = &sum.program;
        crate::layout::check_ops(p).map_err(|reason| malformed(f, &reason))?;
        if p.params != code.params {
            return Err(malformed(
                f,
                "a summand program has another number of parameters",
            ));
        }
        for seg in &sum.segments {
            if seg.plan.loads.len() != p.dim {
                return Err(malformed(f, "a site loads another number of coordinates"));
            }
            let ends: &[i64] = if seg.relative {
                &[seg.first, seg.last]
            } else {
                &[0]
            };
            for &i in ends {
                let inside = |k: i64, len: usize| (0..len as i64).contains(&(i + k));
                let loads = seg.plan.loads.iter().all(|l| match *l {
                    Load::Z(k) => inside(k, code.dim),
                    Load::Const(_) => true,
                });
                let stores = seg.plan.stores.iter().all(|s| {
                    let target = match s.target {
                        Target::Out(k) => inside(k, code.len),
                        Target::Acc => f.scalar(),
                    };
                    target
                        && s.source
                            .is_none_or(|o| p.outputs.iter().any(|&(x, _)| x == o))
                });
                if !(loads && stores) {
                    return Err(malformed(f, "a site reads or writes out of range"));
                }
            }
        }
    }
    for plan in &code.nested {
        let p = &plan.program;
        crate::layout::check_ops(p).map_err(|reason| malformed(f, &reason))?;
        if p.params != code.params || plan.loads.len() != p.dim {
            return Err(malformed(f, "a nested sum's program does not fit its plan"));
        }
        // Every index is affine with nonnegative coefficients: smallest at the smallest
        // indices, largest at the largest.
        let Some([(imin, imax), (jmin, jmax)]) = plan.tuples.extent() else {
            continue;
        };
        let corners = [[imin, jmin], [imax, jmax]];
        let inside = |a: &Affine, len: usize| {
            a.coef.iter().all(|&c| c >= 0)
                && corners
                    .iter()
                    .all(|&at| (0..len as i64).contains(&a.at(at)))
        };
        let loads = plan.loads.iter().all(|l| match l {
            TupleLoad::Z(a) => inside(a, code.dim),
            TupleLoad::Const(_) => true,
        });
        let stores = plan.stores.iter().all(|s| {
            let target = match &s.target {
                TupleTarget::Acc => f.scalar(),
                TupleTarget::Out(a) => inside(a, code.len),
                TupleTarget::Block { block, a, b } => {
                    let held = |x: &Affine| {
                        x.coef.iter().all(|&c| c >= 0)
                            && corners.iter().all(|&at| {
                                let k = x.at(at);
                                k >= block.first as i64 && k < (block.first + block.len) as i64
                            })
                    };
                    held(a) && held(b) && block.start + block.nnz() <= code.len
                }
            };
            target
                && s.source
                    .is_none_or(|o| p.outputs.iter().any(|&(x, _)| x == o))
        });
        if !(loads && stores) {
            return Err(malformed(f, "a nested sum reads or writes out of range"));
        }
    }
    Ok(())
}

/// The plans of `code` run by the engine's interpreter ([`Program::eval`],
/// [`Program::eval_pair`]), site by site, adding up as compiled code does: the reference the
/// JIT's loops are tested against. `out` is zeroed first.
pub fn interpret(
    code: &LoopCode,
    z0: &[f64],
    z1: &[f64],
    params: &[f64],
    out: &mut [f64],
) -> Result<(), RuntimeError> {
    out.fill(0.0);
    let mut acc = 0.0f64;
    let two = code.function.two_point();
    for sum in &code.sums {
        let p = &sum.program;
        for seg in &sum.segments {
            for i in seg.first..=seg.last {
                let base = if seg.relative { i } else { 0 };
                let local = |z: &[f64]| -> Vec<f64> {
                    seg.plan
                        .loads
                        .iter()
                        .map(|l| match *l {
                            Load::Z(k) => z[(base + k) as usize],
                            Load::Const(v) => v,
                        })
                        .collect()
                };
                let outputs = outputs(p, two, &local(z0), &local(z1), params)?;
                for s in &seg.plan.stores {
                    let e = s
                        .source
                        .and_then(|o| outputs.iter().find(|&&(x, _)| x == o))
                        .map_or(0.0, |&(_, v)| v);
                    let e = if s.twice { 2.0 * e } else { e };
                    match s.target {
                        Target::Acc => acc += e,
                        Target::Out(k) => out[(base + k) as usize] += e,
                    }
                }
            }
        }
    }
    for plan in &code.nested {
        let p = &plan.program;
        for at in plan.tuples.iter() {
            let local = |z: &[f64]| -> Vec<f64> {
                plan.loads
                    .iter()
                    .map(|l| match *l {
                        TupleLoad::Z(a) => z[a.at(at) as usize],
                        TupleLoad::Const(v) => v,
                    })
                    .collect()
            };
            let outputs = outputs(p, two, &local(z0), &local(z1), params)?;
            for s in &plan.stores {
                let e = s
                    .source
                    .and_then(|o| outputs.iter().find(|&&(x, _)| x == o))
                    .map_or(0.0, |&(_, v)| v);
                match s.target {
                    TupleTarget::Acc => acc += e,
                    TupleTarget::Out(a) => out[a.at(at) as usize] += e,
                    TupleTarget::Block { block, a, b } => {
                        out[block.position(a.at(at) as usize, b.at(at) as usize)] += e
                    }
                }
            }
        }
    }
    if code.function.scalar() {
        out[0] = acc;
    }
    Ok(())
}

/// The outputs of `p` at `x0` (and `x1` for a two-point program), by output.
fn outputs(
    p: &Program,
    two: bool,
    x0: &[f64],
    x1: &[f64],
    params: &[f64],
) -> Result<Vec<(Output, f64)>, RuntimeError> {
    Ok(if two {
        let e = p.eval_pair(x0, x1, params)?;
        p.outputs
            .iter()
            .map(|&(o, _)| {
                let v = match o {
                    Output::DiscreteGradient(l) => e.discrete_gradient[l],
                    Output::EnergyDifference => e.energy_difference,
                    Output::DiscreteGradientDefect(l) => e.discrete_gradient_defect[l],
                    _ => 0.0,
                };
                (o, v)
            })
            .collect()
    } else {
        let e = p.eval(x0, params)?;
        let d = p.dim;
        p.outputs
            .iter()
            .map(|&(o, _)| {
                let v = match o {
                    Output::Value => e.value,
                    Output::Gradient(l) => e.gradient[l],
                    Output::Hessian(a, b) => e.hessian[a * d + b],
                    Output::Psi => e.psi,
                    _ => 0.0,
                };
                (o, v)
            })
            .collect()
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    /// What the JIT compiles, per function: the operations of every program it emits (once
    /// per segment) and the additions. The same for 64 and 16,384 sites: compiled code does not
    /// grow with the lattice.
    #[test]
    fn the_plans_do_not_grow_with_the_number_of_sites() {
        let size = |n: usize| {
            let src = format!(
                "sum(i = 1..N, p[i]^2/2) + sum(i = 0..N, (q[i+1] - q[i])^2/2 + (q[i+1] - q[i])^3/12) \
                 where N = {n}, q[0] = q[N+1] = 0"
            );
            let looped = dth_symbolic::looped::compile(&src, &[]).unwrap();
            let plan = LatticePlan::new(&looped, 0).unwrap();
            plan.functions
                .iter()
                .map(|f| {
                    f.sums
                        .iter()
                        .map(|s| {
                            let stores: usize =
                                s.segments.iter().map(|g| g.plan.stores.len()).sum();
                            (s.segments.len() * s.program.ops.len(), stores)
                        })
                        .collect::<Vec<_>>()
                })
                .collect::<Vec<_>>()
        };
        let (small, large) = (size(64), size(16384));
        assert_eq!(small, large);
        // The bonds' sum: one end site at each end, the interior's loop between.
        assert_eq!(
            LatticePlan::new(
                &dth_symbolic::looped::compile(
                    "sum(i = 1..N, p[i]^2/2) + sum(i = 0..N, (q[i+1] - q[i])^4) \
                     where N = 64, q[0] = q[N+1] = 0",
                    &[]
                )
                .unwrap(),
                0
            )
            .unwrap()
            .functions[0]
                .sums[1]
                .segments
                .iter()
                .map(|g| (g.first, g.last, g.relative))
                .collect::<Vec<_>>(),
            [(0, 0, false), (1, 63, true), (64, 64, false)]
        );
    }
}
