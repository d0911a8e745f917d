//! Programs compiled to machine code with Cranelift.
//!
//! Each program becomes one function `f(z, z1, params, out)` of four pointers: operation `i`
//! of the program becomes one instruction (or one call) defining SSA value `i`, inputs and
//! parameters are loads, and each output is stored where its [`Function`] places it. Nothing
//! is reordered: Cranelift's only floating-point rewrites are exact (constant folding of
//! results that are not NaN, `-(-x) = x`, `(-x)(-y) = xy`) and it never fuses a multiply and
//! an add, so the compiled program performs the interpreter's operations in its order and
//! returns its bits. Transcendentals call [`crate::shims`], the same Rust functions the
//! interpreter calls.
//!
//! Long programs are cut into functions of at most [`CHUNK`] operations (one huge function
//! compiles superlinearly and spills around every call): a slot used after its own chunk is
//! kept in a stack array of the entry function, which calls the chunks in order.
//!
//! The compiled code is owned by [`Code`], freed when the last [`JitFunction`] using it is
//! dropped.

use std::collections::HashMap;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::sync::Arc;

use cranelift_codegen::ir::condcodes::IntCC;
use cranelift_codegen::ir::{
    types, AbiParam, FuncRef, InstBuilder, MemFlagsData, Signature, StackSlotData, StackSlotKind,
    UserFuncName, Value,
};
use cranelift_codegen::settings::{self, Configurable};
use cranelift_codegen::Context;
use cranelift_frontend::{FunctionBuilder, FunctionBuilderContext, Variable};
use cranelift_jit::{JITBuilder, JITModule};
use cranelift_module::{default_libcall_names, FuncId, Linkage, Module};
use dth_symbolic::{Kernel, Op, Output, Program, Slot};

use crate::error::{JitError, RuntimeError};
use crate::lattice::{
    Affine, Load, LoopCode, NestedPlan, SitePlan, Target, TupleLoad, TupleTarget,
};
use crate::layout::{Function, Placement};
use crate::shims;

/// The most operations compiled into one machine function.
pub const CHUNK: usize = 6000;

/// Compiled code: `f(z, z1, params, out)`.
type Entry = unsafe extern "C" fn(*const f64, *const f64, *const f64, *mut f64);

/// The owner of a module's machine code and of the kernels its code points to.
pub struct Code {
    module: Option<JITModule>,
    /// The bytes of machine code its functions hold.
    bytes: usize,
    /// Each distinct kernel the programs call, allocated before the code is written and
    /// never resized, so the addresses baked into the code stay valid.
    _kernels: Box<[Kernel]>,
}

// SAFETY: after `finalize_definitions` the module is never used again except to free its
// memory in `drop`, which runs once, with exclusive access. The code it holds is immutable
// and reentrant: it reads its inputs, writes its outputs and calls the thread-safe shims.
// The raw pointers that make `JITModule` neither `Send` nor `Sync` point into that memory.
unsafe impl Send for Code {}
// SAFETY: as above; `&Code` gives no access to the module at all.
unsafe impl Sync for Code {}

impl Drop for Code {
    fn drop(&mut self) {
        if let Some(module) = self.module.take() {
            // SAFETY: every `JitFunction` pointing into this memory holds an `Arc<Code>`; this
            // is the last one going away, so no pointer into the code is live.
            unsafe { module.free_memory() }
        }
    }
}

/// One compiled program.
#[derive(Clone)]
pub struct JitFunction {
    entry: Entry,
    /// Keeps the code `entry` points into alive.
    _code: Arc<Code>,
}

impl std::fmt::Debug for JitFunction {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("JitFunction")
            .field("entry", &(self.entry as *const u8))
            .finish()
    }
}

impl JitFunction {
    /// The bytes of machine code of the whole module this function was compiled into
    /// (shared with the module's other functions).
    pub(crate) fn module_bytes(&self) -> usize {
        self._code.bytes
    }

    /// `true` when `self` and `other` point into the same module.
    fn same_module(&self, other: &JitFunction) -> bool {
        Arc::ptr_eq(&self._code, &other._code)
    }

    /// Runs the program at `z`, `z1` (equal for a one-point program) with `params`, writing
    /// its outputs to `out`.
    ///
    /// # Safety
    ///
    /// `z` and `z1` have the program's dimension, `params` its number of parameters, and
    /// `out` the length of its [`Function`]'s buffer (the program was checked against these
    /// by [`compile`]).
    pub(crate) unsafe fn call(&self, z: &[f64], z1: &[f64], params: &[f64], out: &mut [f64]) {
        // SAFETY: the caller's contract; the code only touches these four ranges.
        unsafe { (self.entry)(z.as_ptr(), z1.as_ptr(), params.as_ptr(), out.as_mut_ptr()) }
    }
}

/// The bytes of machine code of the modules `functions` were compiled into, each module once.
pub fn code_bytes<'a>(functions: impl IntoIterator<Item = &'a JitFunction>) -> usize {
    let mut seen: Vec<&JitFunction> = Vec::new();
    for f in functions {
        if !seen.iter().any(|s| s.same_module(f)) {
            seen.push(f);
        }
    }
    seen.iter().map(|f| f.module_bytes()).sum()
}

/// Compiles each `(function, program)` pair into one module; the programs are checked
/// first ([`check`]). A Cranelift failure, or a panic inside Cranelift (caught), is
/// [`RuntimeError::Jit`].
pub fn compile(programs: &[(Function, &Program)]) -> Result<Vec<JitFunction>, RuntimeError> {
    for &(f, p) in programs {
        check(f, p)?;
    }
    let jobs: Vec<Job> = programs.iter().map(|&(f, p)| Job::Program(f, p)).collect();
    guarded(|what| build(&jobs, what))
}

/// Compiles the functions of a lattice in loops ([`LoopCode`], checked when planned) into one
/// module, one function each: code whose size does not grow with the number of sites.
pub fn compile_loops(codes: &[&LoopCode]) -> Result<Vec<JitFunction>, RuntimeError> {
    let jobs: Vec<Job> = codes.iter().map(|&c| Job::Loop(c)).collect();
    guarded(|what| build(&jobs, what))
}

/// What one function of a module computes.
enum Job<'a> {
    /// A straight-line program.
    Program(Function, &'a Program),
    /// A lattice's loops.
    Loop(&'a LoopCode),
}

impl Job<'_> {
    fn name(&self) -> &'static str {
        match self {
            Job::Program(f, _) => f.name(),
            Job::Loop(c) => c.function.name(),
        }
    }

    /// The programs the function runs.
    fn programs(&self) -> Vec<&Program> {
        match self {
            Job::Program(_, p) => vec![p],
            Job::Loop(c) => {
                let nested = c.nested.iter().map(|s| &s.program);
                c.sums.iter().map(|s| &s.program).chain(nested).collect()
            }
        }
    }
}

/// `work(what)`, with a panic inside it caught and returned as [`JitError::Panicked`] naming
/// the program `work` last said (through `what`) it was compiling.
fn guarded<T>(
    work: impl FnOnce(&mut &'static str) -> Result<T, JitError>,
) -> Result<T, RuntimeError> {
    let mut what = "module";
    match catch_unwind(AssertUnwindSafe(|| work(&mut what))) {
        Ok(r) => r.map_err(RuntimeError::Jit),
        Err(panic) => {
            let reason = panic
                .downcast_ref::<&str>()
                .map(|s| s.to_string())
                .or_else(|| panic.downcast_ref::<String>().cloned())
                .unwrap_or_else(|| "unknown panic".to_string());
            Err(RuntimeError::Jit(JitError::Panicked { what, reason }))
        }
    }
}

/// A program compiled code can run without reading or writing out of bounds: operands
/// before their use, inputs and parameters in range, outputs placed inside the buffer.
pub fn check(f: Function, p: &Program) -> Result<(), RuntimeError> {
    let bad = |reason: String| RuntimeError::MalformedProgram {
        what: f.name(),
        reason,
    };
    crate::layout::check_ops(p).map_err(bad)?;
    let len = f.len(p.dim);
    for &(o, s) in &p.outputs {
        let inside = |k: usize| k < len;
        match f.place(o, p.dim) {
            Placement::At(a, b) if inside(a) && b.is_none_or(inside) => {}
            Placement::At(..) => return Err(bad(format!("output {o:?} outside the buffer"))),
            Placement::NotReturned | Placement::Unknown => {
                return Err(RuntimeError::UnsupportedOutput {
                    what: f.name(),
                    output: o,
                })
            }
        }
        if s as usize >= p.ops.len() {
            return Err(bad(format!(
                "output {o:?} reads slot {s} of {}",
                p.ops.len()
            )));
        }
    }
    Ok(())
}

/// The host's code generator, tuned for run time.
fn module() -> Result<JITModule, JitError> {
    let mut flags = settings::builder();
    let settings = [
        ("opt_level", "speed"),
        // The JIT needs absolute addresses (it refuses position-independent code) and calls
        // to host functions anywhere in the address space.
        ("is_pic", "false"),
        ("use_colocated_libcalls", "false"),
        // Chunks of long programs keep their shared slots in a stack array of up to a few
        // hundred KB: probe it page by page, inline (no runtime support needed).
        ("enable_probestack", "true"),
        ("probestack_strategy", "inline"),
    ];
    for (name, value) in settings {
        flags.set(name, value).map_err(|e| JitError::Setting {
            name,
            reason: e.to_string(),
        })?;
    }
    let isa = cranelift_native::builder()
        .map_err(|reason| JitError::UnsupportedHost {
            reason: reason.to_string(),
        })?
        .finish(settings::Flags::new(flags))
        .map_err(|e| JitError::UnsupportedHost {
            reason: e.to_string(),
        })?;
    let mut builder = JITBuilder::with_isa(isa, default_libcall_names());
    for f in dth_symbolic::Func::ALL {
        let (name, address) = shims::func(f);
        builder.symbol(name, address);
    }
    for (name, address) in [shims::pow(), shims::kernels()] {
        builder.symbol(name, address);
    }
    Ok(JITModule::new(builder))
}

/// The shims declared in a module.
struct Imports {
    funcs: HashMap<&'static str, FuncId>,
}

fn build(jobs: &[Job], what: &mut &'static str) -> Result<Vec<JitFunction>, JitError> {
    let mut module = module()?;
    let ptr = module.target_config().pointer_type();
    let f64s = |n: usize, module: &JITModule| {
        let mut s = module.make_signature();
        s.params.extend((0..n).map(|_| AbiParam::new(types::F64)));
        s.returns.push(AbiParam::new(types::F64));
        s
    };
    let mut imports = Imports {
        funcs: HashMap::new(),
    };
    let fail = |what: &'static str| {
        move |e: cranelift_module::ModuleError| JitError::Codegen {
            what,
            reason: e.to_string(),
        }
    };
    let unary = f64s(1, &module);
    for f in dth_symbolic::Func::ALL {
        let (name, _) = shims::func(f);
        let id = module
            .declare_function(name, Linkage::Import, &unary)
            .map_err(fail("shim"))?;
        imports.funcs.insert(name, id);
    }
    let (pow, _) = shims::pow();
    let id = module
        .declare_function(pow, Linkage::Import, &f64s(2, &module))
        .map_err(fail("shim"))?;
    imports.funcs.insert(pow, id);
    let (kernel, _) = shims::kernels();
    let mut ksig = f64s(2, &module);
    ksig.params.insert(0, AbiParam::new(ptr));
    let id = module
        .declare_function(kernel, Linkage::Import, &ksig)
        .map_err(fail("shim"))?;
    imports.funcs.insert(kernel, id);

    let mut ctx = module.make_context();
    let mut fctx = FunctionBuilderContext::new();
    let mut distinct: Vec<Kernel> = Vec::new();
    for p in jobs.iter().flat_map(Job::programs) {
        for op in &p.ops {
            if let Op::Kernel(k, ..) = *op {
                if !distinct.contains(&k) {
                    distinct.push(k);
                }
            }
        }
    }
    let kernels: Box<[Kernel]> = distinct.into_boxed_slice();
    let mut entries = Vec::with_capacity(jobs.len());
    let mut count = 0u32;
    let mut bytes = 0;
    for job in jobs {
        *what = job.name();
        let mut emitter = Emitter {
            module: &mut module,
            ctx: &mut ctx,
            fctx: &mut fctx,
            imports: &imports,
            kernels: &kernels,
            ptr,
            count: &mut count,
            bytes: &mut bytes,
            what: job.name(),
        };
        let id = match *job {
            Job::Program(f, p) => emitter.program(f, p)?,
            Job::Loop(code) => emitter.looped(code)?,
        };
        entries.push(id);
    }
    *what = "module";
    module.finalize_definitions().map_err(fail("module"))?;
    let addresses: Vec<*const u8> = entries
        .iter()
        .map(|&id| module.get_finalized_function(id))
        .collect();
    let code = Arc::new(Code {
        module: Some(module),
        bytes,
        _kernels: kernels,
    });
    Ok(addresses
        .into_iter()
        .map(|a| JitFunction {
            // SAFETY: `a` is a finalized function built with the signature `Entry` (four
            // pointers in the host's C calling convention, no return value).
            entry: unsafe { std::mem::transmute::<*const u8, Entry>(a) },
            _code: Arc::clone(&code),
        })
        .collect())
}

/// Writes one program's functions into a module.
struct Emitter<'a> {
    module: &'a mut JITModule,
    ctx: &'a mut Context,
    fctx: &'a mut FunctionBuilderContext,
    imports: &'a Imports,
    kernels: &'a [Kernel],
    ptr: types::Type,
    /// Functions defined so far in the module (their names).
    count: &'a mut u32,
    /// The bytes of machine code defined so far.
    bytes: &'a mut usize,
    /// The program's name, for errors.
    what: &'static str,
}

type ModuleResult<T> = Result<T, JitError>;

impl Emitter<'_> {
    fn signature(&self, pointers: usize) -> Signature {
        let mut s = self.module.make_signature();
        s.params
            .extend((0..pointers).map(|_| AbiParam::new(self.ptr)));
        s
    }

    /// Declares a fresh function of `pointers` pointer arguments.
    fn declare(&mut self, pointers: usize, linkage: Linkage) -> ModuleResult<FuncId> {
        *self.count += 1;
        let name = format!("dth_program_{}", self.count);
        let sig = self.signature(pointers);
        self.module
            .declare_function(&name, linkage, &sig)
            .map_err(|e| self.error(e))
    }

    /// The entry function of `p`: the program itself when it fits one chunk, else a function
    /// calling its chunks with a stack array for the slots they share.
    fn program(&mut self, f: Function, p: &Program) -> ModuleResult<FuncId> {
        let plan = Plan::new(f, p);
        let entry = self.declare(4, Linkage::Export)?;
        if plan.chunks.len() == 1 {
            self.define(entry, 4, |e, b, args| {
                e.chunk(b, p, &plan, 0, args, None);
            })?;
            return Ok(entry);
        }
        let mut chunks = Vec::with_capacity(plan.chunks.len());
        for c in 0..plan.chunks.len() {
            let id = self.declare(5, Linkage::Local)?;
            self.define(id, 5, |e, b, args| {
                e.chunk(b, p, &plan, c, &args[..4], Some(args[4]));
            })?;
            chunks.push(id);
        }
        let bytes = u32::try_from(8 * plan.shared.max(1)).unwrap_or(u32::MAX);
        self.define(entry, 4, |e, b, args| {
            let slot = b.create_sized_stack_slot(StackSlotData::new(
                StackSlotKind::ExplicitSlot,
                bytes,
                3,
            ));
            let scratch = b.ins().stack_addr(e.ptr, slot, 0);
            let mut call_args = args.to_vec();
            call_args.push(scratch);
            for &c in &chunks {
                let callee = e.module.declare_func_in_func(c, b.func);
                b.ins().call(callee, &call_args);
            }
        })?;
        Ok(entry)
    }

    /// Defines function `id` of `pointers` pointer arguments with the body `body` writes
    /// (given the arguments), followed by a return.
    fn define(
        &mut self,
        id: FuncId,
        pointers: usize,
        body: impl FnOnce(&mut Self, &mut FunctionBuilder, &[Value]),
    ) -> ModuleResult<()> {
        self.module.clear_context(self.ctx);
        self.ctx.func.signature = self.signature(pointers);
        self.ctx.func.name = UserFuncName::user(0, id.as_u32());
        // The builder borrows the context; the body needs the module: split the borrows.
        let mut func =
            std::mem::replace(&mut self.ctx.func, cranelift_codegen::ir::Function::new());
        let mut fctx = std::mem::replace(self.fctx, FunctionBuilderContext::new());
        {
            let mut b = FunctionBuilder::new(&mut func, &mut fctx);
            let block = b.create_block();
            b.append_block_params_for_function_params(block);
            b.switch_to_block(block);
            let args = b.block_params(block).to_vec();
            body(self, &mut b, &args);
            b.ins().return_(&[]);
            b.seal_all_blocks();
            b.finalize(self.module.target_config());
        }
        *self.fctx = fctx;
        self.ctx.func = func;
        self.module
            .define_function(id, self.ctx)
            .map_err(|e| self.error(e))?;
        *self.bytes += self
            .ctx
            .compiled_code()
            .map_or(0, |c| c.code_buffer().len());
        Ok(())
    }

    fn error(&self, e: cranelift_module::ModuleError) -> JitError {
        JitError::Codegen {
            what: self.what,
            reason: e.to_string(),
        }
    }

    /// Operation `op` as one instruction or one call: `operand` gives a slot's value, and
    /// `input(b, second, k)` loads coordinate `k` of `z` (of `z1` when `second`).
    fn op(
        &mut self,
        b: &mut FunctionBuilder,
        refs: &mut HashMap<&'static str, FuncRef>,
        op: Op,
        params: Value,
        operand: &mut dyn FnMut(&mut FunctionBuilder, Slot) -> Value,
        input: &mut dyn FnMut(&mut FunctionBuilder, bool, usize) -> Value,
    ) -> Value {
        let flags = MemFlagsData::trusted();
        let get = operand;
        let mut call = |e: &mut Self, b: &mut FunctionBuilder, name: &'static str, a: &[Value]| {
            let callee = *refs
                .entry(name)
                .or_insert_with(|| e.module.declare_func_in_func(e.imports.funcs[name], b.func));
            let inst = b.ins().call(callee, a);
            b.inst_results(inst)[0]
        };
        match op {
            Op::Input(k) => input(b, false, k as usize),
            Op::Input1(k) => input(b, true, k as usize),
            Op::Param(k) => b.ins().load(types::F64, flags, params, (8 * k) as i32),
            Op::Const(x) => b.ins().f64const(x),
            Op::Add(x, y) => {
                let (x, y) = (get(b, x), get(b, y));
                b.ins().fadd(x, y)
            }
            Op::Sub(x, y) => {
                let (x, y) = (get(b, x), get(b, y));
                b.ins().fsub(x, y)
            }
            Op::Mul(x, y) => {
                let (x, y) = (get(b, x), get(b, y));
                b.ins().fmul(x, y)
            }
            Op::Div(x, y) => {
                let (x, y) = (get(b, x), get(b, y));
                b.ins().fdiv(x, y)
            }
            Op::Neg(x) => {
                let x = get(b, x);
                b.ins().fneg(x)
            }
            Op::Sqrt(x) => {
                let x = get(b, x);
                b.ins().sqrt(x)
            }
            Op::Powf(x, e) => {
                let x = get(b, x);
                let e = b.ins().f64const(e);
                call(self, b, shims::pow().0, &[x, e])
            }
            Op::Call(f, x) => {
                let x = get(b, x);
                call(self, b, shims::func(f).0, &[x])
            }
            Op::Kernel(k, x, y) => {
                let (x, y) = (get(b, x), get(b, y));
                // Every kernel of the programs was collected before any code was written.
                let held = self
                    .kernels
                    .iter()
                    .find(|&&held| held == k)
                    .unwrap_or(&self.kernels[0]);
                let address = held as *const Kernel as i64;
                let k = b.ins().iconst(self.ptr, address);
                call(self, b, shims::kernels().0, &[k, x, y])
            }
        }
    }

    /// The function of a looped lattice ([`LoopCode`]): per sum, its end sites one by one
    /// (absolute addresses) and its interior as one loop whose body is the summand's program
    /// once, addressing `z`, `z1` and `out` relative to the site.
    fn looped(&mut self, code: &LoopCode) -> ModuleResult<FuncId> {
        let entry = self.declare(4, Linkage::Export)?;
        self.define(entry, 4, |e, b, args| e.loops(b, code, args))?;
        Ok(entry)
    }

    fn loops(&mut self, b: &mut FunctionBuilder, code: &LoopCode, args: &[Value]) {
        let (z, z1, params, out) = (args[0], args[1], args[2], args[3]);
        let flags = MemFlagsData::trusted();
        let acc = b.declare_var(types::F64);
        let zero = b.ins().f64const(0.0);
        b.def_var(acc, zero);
        let mut refs: HashMap<&'static str, FuncRef> = HashMap::new();
        for sum in &code.sums {
            for seg in &sum.segments {
                if !seg.relative {
                    let bases = [z, z1, out];
                    let at = |_: &mut FunctionBuilder| bases;
                    self.site(b, &mut refs, &sum.program, &seg.plan, params, acc, at);
                    continue;
                }
                // for (i = first; i <= last; i++) { body at i }
                let i = b.declare_var(types::I64);
                let first = b.ins().iconst(types::I64, seg.first);
                b.def_var(i, first);
                let (header, body, exit) = (b.create_block(), b.create_block(), b.create_block());
                b.ins().jump(header, &[]);
                b.switch_to_block(header);
                let iv = b.use_var(i);
                let done = b.ins().icmp_imm_s(IntCC::SignedGreaterThan, iv, seg.last);
                b.ins().brif(done, exit, &[], body, &[]);
                b.switch_to_block(body);
                let iv = b.use_var(i);
                let ptr = self.ptr;
                let bytes = b.ins().imul_imm_s(iv, 8);
                let bytes = if ptr == types::I64 {
                    bytes
                } else {
                    b.ins().ireduce(ptr, bytes)
                };
                let at =
                    |b: &mut FunctionBuilder| [z, z1, out].map(|base| b.ins().iadd(base, bytes));
                self.site(b, &mut refs, &sum.program, &seg.plan, params, acc, at);
                let next = b.ins().iadd_imm_s(iv, 1);
                b.def_var(i, next);
                b.ins().jump(header, &[]);
                b.switch_to_block(exit);
            }
        }
        for plan in &code.nested {
            self.nested(b, &mut refs, plan, args, acc);
        }
        if code.function.scalar() {
            let v = b.use_var(acc);
            b.ins().store(flags, v, out, 0);
        }
    }

    /// `for (v = first; v <= last; v++) body(v)`, `first` and `last` values of the function.
    fn count(
        &mut self,
        b: &mut FunctionBuilder,
        first: Value,
        last: Value,
        body: &mut dyn FnMut(&mut Self, &mut FunctionBuilder, Value),
    ) {
        let v = b.declare_var(types::I64);
        b.def_var(v, first);
        let end = b.declare_var(types::I64);
        b.def_var(end, last);
        let (header, inside, exit) = (b.create_block(), b.create_block(), b.create_block());
        b.ins().jump(header, &[]);
        b.switch_to_block(header);
        let (vv, ev) = (b.use_var(v), b.use_var(end));
        let done = b.ins().icmp(IntCC::SignedGreaterThan, vv, ev);
        b.ins().brif(done, exit, &[], inside, &[]);
        b.switch_to_block(inside);
        let vv = b.use_var(v);
        body(self, b, vv);
        let vv = b.use_var(v);
        let next = b.ins().iadd_imm_s(vv, 1);
        b.def_var(v, next);
        b.ins().jump(header, &[]);
        b.switch_to_block(exit);
    }

    /// A nested sum ([`NestedPlan`]): a loop over the outer index, inside it one over the
    /// inner index (from bounds affine in the outer), the summand's program at each tuple.
    fn nested(
        &mut self,
        b: &mut FunctionBuilder,
        refs: &mut HashMap<&'static str, FuncRef>,
        plan: &NestedPlan,
        args: &[Value],
        acc: Variable,
    ) {
        let (lo, hi) = plan.tuples.outer;
        let (first, last) = (
            b.ins().iconst(types::I64, lo),
            b.ins().iconst(types::I64, hi),
        );
        self.count(b, first, last, &mut |e, b, i| match plan.tuples.inner {
            None => {
                let j = b.ins().iconst(types::I64, 0);
                e.tuple(b, refs, plan, args, acc, [i, j]);
            }
            Some([(al, bl), (ah, bh)]) => {
                let bound = |b: &mut FunctionBuilder, a: i64, c: i64| {
                    let ai = b.ins().imul_imm_s(i, a);
                    b.ins().iadd_imm_s(ai, c)
                };
                let (first, last) = (bound(b, al, bl), bound(b, ah, bh));
                e.count(b, first, last, &mut |e, b, j| {
                    e.tuple(b, refs, plan, args, acc, [i, j]);
                });
            }
        });
    }

    /// The operations of a loop-free summand program `p` in order, its inputs from
    /// `input(b, second, k)` (local coordinate `k` of `z`, or of `z1` when `second`); returns
    /// the value of every slot.
    fn straight(
        &mut self,
        b: &mut FunctionBuilder,
        refs: &mut HashMap<&'static str, FuncRef>,
        p: &Program,
        params: Value,
        input: &mut dyn FnMut(&mut FunctionBuilder, bool, usize) -> Value,
    ) -> Vec<Value> {
        let mut vals: Vec<Value> = Vec::with_capacity(p.ops.len());
        for &op in &p.ops {
            let mut get = |_: &mut FunctionBuilder, s: Slot| vals[s as usize];
            let v = self.op(b, refs, op, params, &mut get, input);
            vals.push(v);
        }
        vals
    }

    /// One tuple `at = [i, j]` of a nested sum: the local coordinates loaded at their affine
    /// indices, the summand's program, its outputs added.
    fn tuple(
        &mut self,
        b: &mut FunctionBuilder,
        refs: &mut HashMap<&'static str, FuncRef>,
        plan: &NestedPlan,
        args: &[Value],
        acc: Variable,
        at: [Value; 2],
    ) {
        let (z, z1, params, out) = (args[0], args[1], args[2], args[3]);
        let flags = MemFlagsData::trusted();
        let ptr = self.ptr;
        let index = |b: &mut FunctionBuilder, a: &Affine| {
            let i = b.ins().imul_imm_s(at[0], a.coef[0]);
            let j = b.ins().imul_imm_s(at[1], a.coef[1]);
            let k = b.ins().iadd(i, j);
            b.ins().iadd_imm_s(k, a.offset)
        };
        let address = |b: &mut FunctionBuilder, base: Value, k: Value| {
            let bytes = b.ins().imul_imm_s(k, 8);
            let bytes = if ptr == types::I64 {
                bytes
            } else {
                b.ins().ireduce(ptr, bytes)
            };
            b.ins().iadd(base, bytes)
        };
        let p = &plan.program;
        let vals = self.straight(
            b,
            refs,
            p,
            params,
            &mut |b, second, k| match plan.loads[k] {
                TupleLoad::Z(a) => {
                    let k = index(b, &a);
                    let at = address(b, if second { z1 } else { z }, k);
                    b.ins().load(types::F64, flags, at, 0)
                }
                TupleLoad::Const(v) => b.ins().f64const(v),
            },
        );
        for s in &plan.stores {
            let e = output(b, p, &vals, s.source);
            let k = match s.target {
                TupleTarget::Acc => {
                    accumulate(b, acc, e);
                    continue;
                }
                TupleTarget::Out(a) => index(b, &a),
                TupleTarget::Block { block, a, b: c } => {
                    // start + o len - o (o - 1) / 2 + (lo - first), o = hi - lo.
                    let (x, y) = (index(b, &a), index(b, &c));
                    let (lo, hi) = (b.ins().smin(x, y), b.ins().smax(x, y));
                    let o = b.ins().isub(hi, lo);
                    let o1 = b.ins().iadd_imm_s(o, -1);
                    let tri = b.ins().imul(o, o1);
                    let tri = b.ins().sshr_imm_u(tri, 1);
                    let along = b.ins().imul_imm_s(o, block.len as i64);
                    let k = b.ins().isub(along, tri);
                    let k = b.ins().iadd(k, lo);
                    b.ins()
                        .iadd_imm_s(k, block.start as i64 - block.first as i64)
                }
            };
            let at = address(b, out, k);
            add_to(b, at, 0, e);
        }
    }

    /// One site: the local coordinates loaded as `plan` says from `bases(b) = [z, z1, out]`
    /// (moved to the site in a loop), the summand's program, its outputs added.
    #[allow(clippy::too_many_arguments)]
    fn site(
        &mut self,
        b: &mut FunctionBuilder,
        refs: &mut HashMap<&'static str, FuncRef>,
        p: &Program,
        plan: &SitePlan,
        params: Value,
        acc: Variable,
        bases: impl FnOnce(&mut FunctionBuilder) -> [Value; 3],
    ) {
        let flags = MemFlagsData::trusted();
        let [z, z1, out] = bases(b);
        let offset = |k: i64| (8 * k) as i32;
        let vals = self.straight(
            b,
            refs,
            p,
            params,
            &mut |b, second, k| match plan.loads[k] {
                Load::Z(at) => {
                    let base = if second { z1 } else { z };
                    b.ins().load(types::F64, flags, base, offset(at))
                }
                Load::Const(v) => b.ins().f64const(v),
            },
        );
        for s in &plan.stores {
            let e = output(b, p, &vals, s.source);
            let e = if s.twice {
                let two = b.ins().f64const(2.0);
                b.ins().fmul(two, e)
            } else {
                e
            };
            match s.target {
                Target::Acc => accumulate(b, acc, e),
                Target::Out(k) => add_to(b, out, offset(k), e),
            }
        }
    }

    /// The operations of chunk `c`: inputs `args = [z, z1, params, out]`, `scratch` the
    /// shared slots (when the program has several chunks).
    fn chunk(
        &mut self,
        b: &mut FunctionBuilder,
        p: &Program,
        plan: &Plan,
        c: usize,
        args: &[Value],
        scratch: Option<Value>,
    ) {
        let (z, z1, params, out) = (args[0], args[1], args[2], args[3]);
        let flags = MemFlagsData::trusted();
        let range = plan.chunks[c].clone();
        let mut vals: HashMap<Slot, Value> = HashMap::new();
        let mut refs: HashMap<&'static str, FuncRef> = HashMap::new();
        let offset = |k: usize| (8 * k) as i32;
        for i in range {
            let mut get = |b: &mut FunctionBuilder, s: Slot| -> Value {
                *vals.entry(s).or_insert_with(|| {
                    // Defined in an earlier chunk: `Plan` gave it a place in `scratch`.
                    let at = plan.shared_index[s as usize] as usize;
                    let base = scratch.unwrap_or(out);
                    b.ins().load(types::F64, flags, base, offset(at))
                })
            };
            let mut input = |b: &mut FunctionBuilder, second: bool, k: usize| {
                let base = if second { z1 } else { z };
                b.ins().load(types::F64, flags, base, offset(k))
            };
            let v = self.op(b, &mut refs, p.ops[i], params, &mut get, &mut input);
            vals.insert(i as Slot, v);
            for &at in &plan.stores[i] {
                b.ins().store(flags, v, out, offset(at));
            }
            if let (Some(scratch), true) = (scratch, plan.shared_index[i] != u32::MAX) {
                let at = plan.shared_index[i] as usize;
                b.ins().store(flags, v, scratch, offset(at));
            }
        }
    }
}

/// The value of the summand's output `source` among the program's values `vals`, or `0` when
/// the program does not compute it.
fn output(b: &mut FunctionBuilder, p: &Program, vals: &[Value], source: Option<Output>) -> Value {
    match source.and_then(|o| p.outputs.iter().find(|&&(x, _)| x == o)) {
        Some(&(_, slot)) => vals[slot as usize],
        None => b.ins().f64const(0.0),
    }
}

/// `e` added to the `f64` at `base + offset` in memory.
fn add_to(b: &mut FunctionBuilder, base: Value, offset: i32, e: Value) {
    let flags = MemFlagsData::trusted();
    let old = b.ins().load(types::F64, flags, base, offset);
    let sum = b.ins().fadd(old, e);
    b.ins().store(flags, sum, base, offset);
}

/// `acc += e`.
fn accumulate(b: &mut FunctionBuilder, acc: Variable, e: Value) {
    let a = b.use_var(acc);
    let sum = b.ins().fadd(a, e);
    b.def_var(acc, sum);
}

/// How a program is cut into chunks, where its outputs go, and which slots chunks share.
struct Plan {
    chunks: Vec<std::ops::Range<usize>>,
    /// The buffer indices each slot is stored to.
    stores: Vec<Vec<usize>>,
    /// For a slot read by a later chunk, its index in the shared array; `u32::MAX` if none.
    shared_index: Vec<u32>,
    /// The number of shared slots.
    shared: usize,
}

impl Plan {
    fn new(f: Function, p: &Program) -> Plan {
        let n = p.ops.len();
        let chunks: Vec<_> = (0..n.div_ceil(CHUNK).max(1))
            .map(|c| c * CHUNK..((c + 1) * CHUNK).min(n))
            .collect();
        let mut stores = vec![Vec::new(); n];
        for &(o, s) in &p.outputs {
            if let Placement::At(a, b) = f.place(o, p.dim) {
                stores[s as usize].push(a);
                stores[s as usize].extend(b);
            }
        }
        let mut shared_index = vec![u32::MAX; n];
        let mut shared = 0;
        for (i, op) in p.ops.iter().enumerate() {
            for s in operands(op) {
                let s = s as usize;
                if s / CHUNK != i / CHUNK && shared_index[s] == u32::MAX {
                    shared_index[s] = shared;
                    shared += 1;
                }
            }
        }
        Plan {
            chunks,
            stores,
            shared_index,
            shared: shared as usize,
        }
    }
}

/// The slots `op` reads.
fn operands(op: &Op) -> impl Iterator<Item = Slot> {
    let (a, b) = match *op {
        Op::Input(_) | Op::Input1(_) | Op::Param(_) | Op::Const(_) => (None, None),
        Op::Neg(a) | Op::Sqrt(a) | Op::Powf(a, _) | Op::Call(_, a) => (Some(a), None),
        Op::Add(a, b) | Op::Sub(a, b) | Op::Mul(a, b) | Op::Div(a, b) | Op::Kernel(_, a, b) => {
            (Some(a), Some(b))
        }
    };
    a.into_iter().chain(b)
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A panic inside Cranelift becomes a typed error naming the program, not a crash.
    #[test]
    fn a_panic_while_compiling_is_a_typed_error() {
        let r: Result<(), _> = guarded(|what| {
            *what = "hessian";
            panic!("can't resolve symbol dth_nothing");
        });
        let Err(RuntimeError::Jit(JitError::Panicked { what, reason })) = r else {
            panic!("{r:?}");
        };
        assert_eq!(
            (what, reason.as_str()),
            ("hessian", "can't resolve symbol dth_nothing")
        );
    }

    /// A program reading past its inputs is refused before any code exists.
    #[test]
    fn malformed_programs_are_refused() {
        let system = dth_symbolic::compile("p1^2/2 + q1^2/2", &[]).unwrap();
        let mut p = Function::Gradient.program(&system).unwrap();
        p.ops[0] = Op::Input(7);
        let r = compile(&[(Function::Gradient, &p)]);
        assert!(
            matches!(
                r,
                Err(RuntimeError::MalformedProgram {
                    what: "gradient",
                    ..
                })
            ),
            "{r:?}"
        );
    }
}
