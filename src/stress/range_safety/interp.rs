//! An evaluator of naga's IR for the per-pixel functions of the shaders, in
//! f32, under the rewrites a Vulkan driver may apply to them. The WGSL is
//! parsed by naga (the front end wgpu itself uses), so what is evaluated is
//! the shader's own text, not a copy of its formulas.
//!
//! The rewrites, each a freedom the SPIR-V environment of the Vulkan
//! specification gives an implementation ("Precision and Operation of
//! SPIR-V Instructions", docs/stress.md#range-safe-arithmetic):
//! - `reassociate`: `(a / b) / c` evaluated as `a / (b · c)`;
//! - `reciprocal`: `a / b` evaluated as `a · (1 / b)`;
//! - `flush`: every subnormal operand and result flushed to zero;
//! - `fma`: `a · b + c` (and `c ± a · b`) with one rounding.
//!
//! Every float result of an operation is checked: the first one that is not
//! finite is kept as a [`Fault`] with its line of WGSL.

use naga::{
    BinaryOperator as B, Expression as E, Handle, MathFunction as M, Module, ScalarKind,
    Statement as S, TypeInner,
};
use std::collections::HashMap;

/// Which of the driver's rewrites apply (each everywhere it can).
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Rewrites {
    pub reassociate: bool,
    pub reciprocal: bool,
    pub flush: bool,
    pub fma: bool,
}

impl Rewrites {
    /// None of them: IEEE f32 with subnormals kept (llvmpipe).
    pub const NONE: Rewrites = Rewrites {
        reassociate: false,
        reciprocal: false,
        flush: false,
        fma: false,
    };

    /// All 16 combinations, [`Rewrites::NONE`] first.
    pub fn every() -> impl Iterator<Item = Rewrites> {
        (0u8..16).map(|m| Rewrites {
            reassociate: m & 1 != 0,
            reciprocal: m & 2 != 0,
            flush: m & 4 != 0,
            fma: m & 8 != 0,
        })
    }
}

impl std::fmt::Display for Rewrites {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let names: Vec<&str> = [
            (self.reassociate, "a/b/c as a/(b*c)"),
            (self.reciprocal, "a/b as a*(1/b)"),
            (self.flush, "subnormals flushed"),
            (self.fma, "fused multiply-add"),
        ]
        .iter()
        .filter(|(on, _)| *on)
        .map(|(_, n)| *n)
        .collect();
        if names.is_empty() {
            f.write_str("as written")
        } else {
            f.write_str(&names.join(", "))
        }
    }
}

/// A value of the IR: scalars, composites (vectors, matrices as columns,
/// structs, arrays) and pointers into a variable.
#[derive(Clone, Debug, PartialEq)]
pub enum Val {
    F(f32),
    U(u32),
    I(i32),
    B(bool),
    C(Vec<Val>),
    P(Root, Vec<usize>),
}

#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Root {
    Local(usize),
    Global(usize),
}

impl Val {
    pub fn f(&self) -> f32 {
        match self {
            Val::F(x) => *x,
            other => panic!("expected an f32, got {other:?}"),
        }
    }

    pub fn vec3(c: [f32; 3]) -> Val {
        Val::C(c.iter().map(|v| Val::F(*v)).collect())
    }

    /// The floats of a scalar or vector.
    pub fn floats(&self) -> Vec<f32> {
        match self {
            Val::F(x) => vec![*x],
            Val::C(v) => v.iter().flat_map(|x| x.floats()).collect(),
            other => panic!("expected floats, got {other:?}"),
        }
    }

    fn comp(&self) -> &[Val] {
        match self {
            Val::C(v) => v,
            other => panic!("expected a composite, got {other:?}"),
        }
    }
}

/// The first non-finite intermediate of an evaluation.
#[derive(Clone, Debug)]
pub struct Fault {
    /// The WGSL line that computed it.
    pub line: String,
    pub line_number: u32,
    /// The operation and its operands.
    pub what: String,
}

/// A parsed module with the host's override constants and uniform values.
pub struct Program {
    module: Module,
    source: String,
    overrides: HashMap<String, f64>,
    globals: HashMap<String, Val>,
}

enum Flow {
    Next,
    Break,
    Continue,
    Return(Option<Val>),
}

struct Frame<'f> {
    func: &'f naga::Function,
    args: Vec<Val>,
    locals: Vec<Val>,
    cache: Vec<Option<Val>>,
}

impl Program {
    /// Parses `source` (a composed stage shader); panics with naga's message
    /// on a parse error, which the shader tests report first.
    pub fn new(source: String) -> Program {
        let module = naga::front::wgsl::parse_str(&source)
            .unwrap_or_else(|e| panic!("{}", e.emit_to_string(&source)));
        Program {
            module,
            source,
            overrides: HashMap::new(),
            globals: HashMap::new(),
        }
    }

    /// Sets override constants, as a pipeline's `constants` do.
    pub fn overrides(&mut self, values: &[(&str, f64)]) -> &mut Self {
        for (k, v) in values {
            self.overrides.insert((*k).to_owned(), *v);
        }
        self
    }

    /// Sets the value of a module-scope variable (a uniform).
    pub fn global(&mut self, name: &str, v: Val) -> &mut Self {
        self.globals.insert(name.to_owned(), v);
        self
    }

    /// A struct of the module's type `ty` from f32 words, as a uniform
    /// buffer holds them (std140-like: each member at its naga offset).
    pub fn struct_from_words(&self, ty: &str, words: &[f32]) -> Val {
        let (h, _) = self
            .module
            .types
            .iter()
            .find(|(_, t)| t.name.as_deref() == Some(ty))
            .unwrap_or_else(|| panic!("no type {ty}"));
        self.words_to(h, words, 0)
    }

    fn words_to(&self, ty: Handle<naga::Type>, words: &[f32], offset: u32) -> Val {
        let word = |o: u32| words.get((o / 4) as usize).copied().unwrap_or(0.0);
        match &self.module.types[ty].inner {
            TypeInner::Scalar(s) => match s.kind {
                ScalarKind::Float => Val::F(word(offset)),
                ScalarKind::Uint => Val::U(word(offset).to_bits()),
                ScalarKind::Sint => Val::I(word(offset).to_bits() as i32),
                _ => Val::B(word(offset).to_bits() != 0),
            },
            TypeInner::Vector { size, .. } => Val::C(
                (0..*size as u32)
                    .map(|i| Val::F(word(offset + 4 * i)))
                    .collect(),
            ),
            TypeInner::Struct { members, .. } => Val::C(
                members
                    .iter()
                    .map(|m| self.words_to(m.ty, words, offset + m.offset))
                    .collect(),
            ),
            TypeInner::Array {
                base,
                size: naga::ArraySize::Constant(n),
                stride,
            } => Val::C(
                (0..n.get())
                    .map(|i| self.words_to(*base, words, offset + i * stride))
                    .collect(),
            ),
            TypeInner::Matrix { columns, rows, .. } => Val::C(
                (0..*columns as u32)
                    .map(|c| {
                        Val::C(
                            (0..*rows as u32)
                                .map(|r| Val::F(word(offset + 16 * c + 4 * r)))
                                .collect(),
                        )
                    })
                    .collect(),
            ),
            other => panic!("no uniform words for {other:?}"),
        }
    }

    /// Calls function `name` with `args` under `rw`: its result, and the
    /// first non-finite intermediate if there was one.
    pub fn call(&self, name: &str, args: Vec<Val>, rw: Rewrites) -> (Option<Val>, Option<Fault>) {
        let (h, _) = self
            .module
            .functions
            .iter()
            .find(|(_, f)| f.name.as_deref() == Some(name))
            .unwrap_or_else(|| panic!("no function {name}"));
        let mut run = Run {
            p: self,
            rw,
            globals: vec![None; self.module.global_variables.len()],
            fault: None,
        };
        let args = args.into_iter().map(|a| run.flushed(a)).collect();
        let out = run.call(h, args);
        (out, run.fault)
    }
}

struct Run<'p> {
    p: &'p Program,
    rw: Rewrites,
    globals: Vec<Option<Val>>,
    fault: Option<Fault>,
}

impl<'p> Run<'p> {
    fn m(&self) -> &'p Module {
        &self.p.module
    }

    fn flush(&self, x: f32) -> f32 {
        if self.rw.flush && x != 0.0 && x.abs() < f32::MIN_POSITIVE {
            0.0f32.copysign(x)
        } else {
            x
        }
    }

    fn flushed(&self, v: Val) -> Val {
        match v {
            Val::F(x) => Val::F(self.flush(x)),
            Val::C(v) => Val::C(v.into_iter().map(|x| self.flushed(x)).collect()),
            other => other,
        }
    }

    /// One float result: flushed, and checked.
    fn res(&mut self, f: &Frame, h: Handle<E>, x: f32, what: impl FnOnce() -> String) -> f32 {
        let x = self.flush(x);
        if !x.is_finite() && self.fault.is_none() {
            let loc = f.func.expressions.get_span(h).location(&self.p.source);
            let line = self
                .p
                .source
                .lines()
                .nth(loc.line_number.saturating_sub(1) as usize)
                .unwrap_or("")
                .trim()
                .to_owned();
            self.fault = Some(Fault {
                line,
                line_number: loc.line_number,
                what: format!("{} = {x} ({})", what(), self.rw),
            });
        }
        x
    }

    fn call(&mut self, h: Handle<naga::Function>, args: Vec<Val>) -> Option<Val> {
        let func = &self.m().functions[h];
        let locals = func
            .local_variables
            .iter()
            .map(|(_, l)| self.zero(l.ty))
            .collect();
        let mut frame = Frame {
            func,
            args,
            locals,
            cache: vec![None; func.expressions.len()],
        };
        // Locals with an initialiser take it on entry (naga hoists them).
        for (i, (_, l)) in func.local_variables.iter().enumerate() {
            if let Some(init) = l.init {
                let v = self.eval(&mut frame, init);
                frame.locals[i] = v;
            }
        }
        match self.block(&mut frame, &func.body) {
            Flow::Return(v) => v,
            _ => None,
        }
    }

    fn block(&mut self, f: &mut Frame, block: &naga::Block) -> Flow {
        for st in block.iter() {
            let flow = self.statement(f, st);
            if !matches!(flow, Flow::Next) {
                return flow;
            }
        }
        Flow::Next
    }

    fn statement(&mut self, f: &mut Frame, st: &S) -> Flow {
        match st {
            S::Emit(range) => {
                for h in range.clone() {
                    let v = self.compute(f, h);
                    f.cache[h.index()] = Some(v);
                }
                Flow::Next
            }
            S::Block(b) => self.block(f, b),
            S::If {
                condition,
                accept,
                reject,
            } => {
                if self.eval(f, *condition) == Val::B(true) {
                    self.block(f, accept)
                } else {
                    self.block(f, reject)
                }
            }
            S::Switch { selector, cases } => {
                let sel = self.eval(f, *selector);
                let mut hit = false;
                for c in cases {
                    hit = hit
                        || match c.value {
                            naga::SwitchValue::I32(v) => sel == Val::I(v),
                            naga::SwitchValue::U32(v) => sel == Val::U(v),
                            naga::SwitchValue::Default => true,
                        };
                    if hit {
                        match self.block(f, &c.body) {
                            Flow::Next if c.fall_through => continue,
                            Flow::Next | Flow::Break => return Flow::Next,
                            other => return other,
                        }
                    }
                }
                Flow::Next
            }
            S::Loop {
                body,
                continuing,
                break_if,
            } => {
                for _ in 0..1_000_000 {
                    match self.block(f, body) {
                        Flow::Break => return Flow::Next,
                        Flow::Return(v) => return Flow::Return(v),
                        Flow::Next | Flow::Continue => {}
                    }
                    if let Flow::Return(v) = self.block(f, continuing) {
                        return Flow::Return(v);
                    }
                    if let Some(b) = break_if {
                        if self.eval(f, *b) == Val::B(true) {
                            return Flow::Next;
                        }
                    }
                }
                panic!("a loop ran a million times");
            }
            S::Break => Flow::Break,
            S::Continue => Flow::Continue,
            S::Return { value } => Flow::Return(value.map(|v| self.eval(f, v))),
            S::Store { pointer, value } => {
                let v = self.eval(f, *value);
                match self.eval(f, *pointer) {
                    Val::P(root, path) => *self.place(f, root, &path) = v,
                    other => panic!("store through {other:?}"),
                }
                Flow::Next
            }
            S::Call {
                function,
                arguments,
                result,
            } => {
                let args = arguments.iter().map(|a| self.eval(f, *a)).collect();
                let out = self.call(*function, args);
                if let (Some(r), Some(v)) = (result, out) {
                    f.cache[r.index()] = Some(v);
                }
                Flow::Next
            }
            other => panic!("the evaluator does not run {other:?}"),
        }
    }

    fn place<'a>(&'a mut self, f: &'a mut Frame, root: Root, path: &[usize]) -> &'a mut Val {
        let mut v = match root {
            Root::Local(i) => &mut f.locals[i],
            Root::Global(i) => {
                if self.globals[i].is_none() {
                    let g = self.global_value(i);
                    self.globals[i] = Some(g);
                }
                self.globals[i].as_mut().expect("just set")
            }
        };
        for &i in path {
            v = match v {
                Val::C(c) => &mut c[i],
                other => panic!("index {i} into {other:?}"),
            };
        }
        v
    }

    fn global_value(&self, i: usize) -> Val {
        let (_, g) = self
            .m()
            .global_variables
            .iter()
            .nth(i)
            .expect("a global of the module");
        let name = g.name.clone().unwrap_or_default();
        match self.p.globals.get(&name) {
            Some(v) => self.flushed(v.clone()),
            None => panic!("the module reads global {name}, and no value was given"),
        }
    }

    fn zero(&self, ty: Handle<naga::Type>) -> Val {
        match &self.m().types[ty].inner {
            TypeInner::Scalar(s) => zero_scalar(s.kind),
            TypeInner::Vector { size, scalar } => {
                Val::C(vec![zero_scalar(scalar.kind); *size as usize])
            }
            TypeInner::Matrix { columns, rows, .. } => {
                Val::C(vec![
                    Val::C(vec![Val::F(0.0); *rows as usize]);
                    *columns as usize
                ])
            }
            TypeInner::Array {
                base,
                size: naga::ArraySize::Constant(n),
                ..
            } => Val::C(vec![self.zero(*base); n.get() as usize]),
            TypeInner::Struct { members, .. } => {
                Val::C(members.iter().map(|m| self.zero(m.ty)).collect())
            }
            other => panic!("no zero value of {other:?}"),
        }
    }

    fn override_value(&self, h: Handle<naga::Override>) -> Val {
        let o = &self.m().overrides[h];
        let name = o.name.clone().unwrap_or_default();
        let kind = match &self.m().types[o.ty].inner {
            TypeInner::Scalar(s) => s.kind,
            other => panic!("override {name} of type {other:?}"),
        };
        match self.p.overrides.get(&name) {
            Some(&v) => match kind {
                ScalarKind::Float => Val::F(self.flush(v as f32)),
                ScalarKind::Uint => Val::U(v as u32),
                ScalarKind::Sint => Val::I(v as i32),
                _ => Val::B(v != 0.0),
            },
            None => {
                let init = o
                    .init
                    .unwrap_or_else(|| panic!("override {name} has no value"));
                self.const_eval(init)
            }
        }
    }

    /// A module-scope expression (a constant's or override's initialiser).
    fn const_eval(&self, h: Handle<E>) -> Val {
        match &self.m().global_expressions[h] {
            E::Literal(l) => literal(l),
            E::Constant(c) => self.const_eval(self.m().constants[*c].init),
            E::Override(o) => self.override_value(*o),
            E::ZeroValue(ty) => self.zero(*ty),
            E::Compose { components, .. } => {
                Val::C(components.iter().map(|c| self.const_eval(*c)).collect())
            }
            E::Splat { size, value } => Val::C(vec![self.const_eval(*value); *size as usize]),
            E::Unary {
                op: naga::UnaryOperator::Negate,
                expr,
            } => match self.const_eval(*expr) {
                Val::F(x) => Val::F(-x),
                Val::I(x) => Val::I(-x),
                other => panic!("negate {other:?}"),
            },
            other => panic!("constant expression {other:?}"),
        }
    }

    fn eval(&mut self, f: &mut Frame, h: Handle<E>) -> Val {
        if let Some(v) = &f.cache[h.index()] {
            return v.clone();
        }
        self.compute(f, h)
    }

    fn compute(&mut self, f: &mut Frame, h: Handle<E>) -> Val {
        let func = f.func;
        match &func.expressions[h] {
            E::Literal(l) => literal(l),
            E::Constant(c) => self.flushed(self.const_eval(self.m().constants[*c].init)),
            E::Override(o) => self.override_value(*o),
            E::ZeroValue(ty) => self.zero(*ty),
            E::FunctionArgument(i) => f.args[*i as usize].clone(),
            E::GlobalVariable(g) => Val::P(Root::Global(g.index()), Vec::new()),
            E::LocalVariable(l) => Val::P(Root::Local(l.index()), Vec::new()),
            E::CallResult(_) => panic!("a call's result read before the call"),
            E::Compose { components, .. } => {
                Val::C(components.iter().map(|c| self.eval(f, *c)).collect())
            }
            E::Access { base, index } => {
                let i = match self.eval(f, *index) {
                    Val::U(i) => i as usize,
                    Val::I(i) => i as usize,
                    other => panic!("index {other:?}"),
                };
                self.index(f, *base, i)
            }
            E::AccessIndex { base, index } => self.index(f, *base, *index as usize),
            E::Splat { size, value } => Val::C(vec![self.eval(f, *value); *size as usize]),
            E::Swizzle {
                size,
                vector,
                pattern,
            } => {
                let v = self.eval(f, *vector);
                Val::C(
                    pattern[..*size as usize]
                        .iter()
                        .map(|c| v.comp()[*c as usize].clone())
                        .collect(),
                )
            }
            E::Load { pointer } => match self.eval(f, *pointer) {
                Val::P(root, path) => self.place(f, root, &path).clone(),
                other => panic!("load through {other:?}"),
            },
            E::Unary { op, expr } => {
                let v = self.eval(f, *expr);
                self.unary(*op, v)
            }
            E::Binary { op, left, right } => self.binary(f, h, *op, *left, *right),
            E::Select {
                condition,
                accept,
                reject,
            } => {
                let c = self.eval(f, *condition);
                let a = self.eval(f, *accept);
                let r = self.eval(f, *reject);
                select(&c, a, r)
            }
            E::Relational { fun, argument } => {
                let v = self.eval(f, *argument);
                let bools = |v: &Val| -> Vec<bool> {
                    v.comp().iter().map(|b| matches!(b, Val::B(true))).collect()
                };
                match fun {
                    naga::RelationalFunction::All => Val::B(bools(&v).iter().all(|b| *b)),
                    naga::RelationalFunction::Any => Val::B(bools(&v).iter().any(|b| *b)),
                    naga::RelationalFunction::IsNan => map1(&v, &mut |x| Val::B(x.is_nan())),
                    naga::RelationalFunction::IsInf => map1(&v, &mut |x| Val::B(x.is_infinite())),
                }
            }
            E::Math {
                fun,
                arg,
                arg1,
                arg2,
                ..
            } => {
                let a = self.eval(f, *arg);
                let b = arg1.map(|x| self.eval(f, x));
                let c = arg2.map(|x| self.eval(f, x));
                self.math(f, h, *fun, a, b, c)
            }
            E::As {
                expr,
                kind,
                convert,
            } => {
                let v = self.eval(f, *expr);
                cast(&v, *kind, convert.is_some())
            }
            other => panic!("the evaluator does not compute {other:?}"),
        }
    }

    fn index(&mut self, f: &mut Frame, base: Handle<E>, i: usize) -> Val {
        match self.eval(f, base) {
            Val::P(root, mut path) => {
                path.push(i);
                Val::P(root, path)
            }
            Val::C(v) => v[i].clone(),
            other => panic!("index {i} into {other:?}"),
        }
    }

    fn unary(&mut self, op: naga::UnaryOperator, v: Val) -> Val {
        match v {
            Val::C(c) => Val::C(c.into_iter().map(|x| self.unary(op, x)).collect()),
            Val::F(x) => Val::F(-x),
            Val::I(x) => match op {
                naga::UnaryOperator::Negate => Val::I(x.wrapping_neg()),
                _ => Val::I(!x),
            },
            Val::U(x) => Val::U(!x),
            Val::B(x) => Val::B(!x),
            other => panic!("unary {op:?} on {other:?}"),
        }
    }

    fn operand(&self, f: &Frame, h: Handle<E>, op: B) -> Option<(Handle<E>, Handle<E>)> {
        match &f.func.expressions[h] {
            E::Binary { op: o, left, right } if *o == op => Some((*left, *right)),
            _ => None,
        }
    }

    fn is_float(v: &Val) -> bool {
        match v {
            Val::F(_) => true,
            Val::C(c) => c.first().is_some_and(Self::is_float),
            _ => false,
        }
    }

    fn binary(
        &mut self,
        f: &mut Frame,
        h: Handle<E>,
        op: B,
        left: Handle<E>,
        right: Handle<E>,
    ) -> Val {
        let l = self.eval(f, left);
        let r = self.eval(f, right);
        if !Self::is_float(&l) && !Self::is_float(&r) {
            return int_binary(op, &l, &r);
        }
        let matrix = |v: &Val| matches!(v, Val::C(c) if matches!(c.first(), Some(Val::C(_))));
        if op == B::Multiply && (matrix(&l) || matrix(&r)) {
            return self.matrix_multiply(f, h, &l, &r);
        }
        match op {
            B::Divide => {
                if self.rw.reassociate {
                    if let Some((a, b)) = self.operand(f, left, B::Divide) {
                        let a = self.eval(f, a);
                        let b = self.eval(f, b);
                        let bc = zip(&b, &r, &mut |x, y| {
                            Val::F(self.res(f, h, x * y, || format!("{x:e} * {y:e}")))
                        });
                        return zip(&a, &bc, &mut |x, y| Val::F(self.divide(f, h, x, y)));
                    }
                }
                zip(&l, &r, &mut |x, y| Val::F(self.divide(f, h, x, y)))
            }
            B::Add | B::Subtract if self.rw.fma => {
                let sign = if op == B::Add { 1.0 } else { -1.0 };
                if let Some((a, b)) = self.operand(f, left, B::Multiply) {
                    let (a, b) = (self.eval(f, a), self.eval(f, b));
                    if !matrix(&a) && !matrix(&b) {
                        return zip3(&a, &b, &r, &mut |x, y, z| {
                            let v = x.mul_add(y, sign * z);
                            Val::F(
                                self.res(f, h, v, || format!("fma({x:e}, {y:e}, {:e})", sign * z)),
                            )
                        });
                    }
                }
                if let Some((a, b)) = self.operand(f, right, B::Multiply) {
                    let (a, b) = (self.eval(f, a), self.eval(f, b));
                    if !matrix(&a) && !matrix(&b) {
                        return zip3(&a, &b, &l, &mut |x, y, z| {
                            let v = (sign * x).mul_add(y, z);
                            Val::F(
                                self.res(f, h, v, || format!("fma({:e}, {y:e}, {z:e})", sign * x)),
                            )
                        });
                    }
                }
                self.plain(f, h, op, &l, &r)
            }
            _ => self.plain(f, h, op, &l, &r),
        }
    }

    fn plain(&mut self, f: &Frame, h: Handle<E>, op: B, l: &Val, r: &Val) -> Val {
        zip(l, r, &mut |x, y| match op {
            B::Add => Val::F(self.res(f, h, x + y, || format!("{x:e} + {y:e}"))),
            B::Subtract => Val::F(self.res(f, h, x - y, || format!("{x:e} - {y:e}"))),
            B::Multiply => Val::F(self.res(f, h, x * y, || format!("{x:e} * {y:e}"))),
            B::Modulo => Val::F(self.res(f, h, x % y, || format!("{x:e} % {y:e}"))),
            other => compare(other, x, y).unwrap_or_else(|| panic!("float {other:?}")),
        })
    }

    fn divide(&mut self, f: &Frame, h: Handle<E>, x: f32, y: f32) -> f32 {
        if self.rw.reciprocal {
            let inv = self.res(f, h, 1.0 / y, || format!("1 / {y:e}"));
            self.res(f, h, x * inv, || format!("{x:e} * (1 / {y:e})"))
        } else {
            self.res(f, h, x / y, || format!("{x:e} / {y:e}"))
        }
    }

    /// Σ a[i]·b[i], accumulated in order (with fused multiply-adds where
    /// they apply): how dot products and matrix rows are evaluated.
    fn dot(&mut self, f: &Frame, h: Handle<E>, a: &[Val], b: &[Val]) -> f32 {
        let mut acc = 0.0f32;
        for (i, (x, y)) in a.iter().zip(b).enumerate() {
            let (x, y) = (x.f(), y.f());
            acc = if i == 0 {
                self.res(f, h, x * y, || format!("{x:e} * {y:e}"))
            } else if self.rw.fma {
                self.res(f, h, x.mul_add(y, acc), || {
                    format!("fma({x:e}, {y:e}, {acc:e})")
                })
            } else {
                let p = self.res(f, h, x * y, || format!("{x:e} * {y:e}"));
                self.res(f, h, acc + p, || format!("{acc:e} + {p:e}"))
            };
        }
        acc
    }

    fn matrix_multiply(&mut self, f: &Frame, h: Handle<E>, l: &Val, r: &Val) -> Val {
        // Column-major: M·v = Σ columns[i]·v[i]; v·M = (dot(v, column j))_j.
        match (l, r) {
            (Val::C(cols), Val::C(v)) if matches!(cols[0], Val::C(_)) => {
                let rows = cols[0].comp().len();
                Val::C(
                    (0..rows)
                        .map(|j| {
                            let row: Vec<Val> = cols.iter().map(|c| c.comp()[j].clone()).collect();
                            Val::F(self.dot(f, h, &row, v))
                        })
                        .collect(),
                )
            }
            (Val::C(v), Val::C(cols)) => Val::C(
                cols.iter()
                    .map(|c| Val::F(self.dot(f, h, v, c.comp())))
                    .collect(),
            ),
            other => panic!("matrix product {other:?}"),
        }
    }

    fn math(
        &mut self,
        f: &Frame,
        h: Handle<E>,
        fun: M,
        a: Val,
        b: Option<Val>,
        c: Option<Val>,
    ) -> Val {
        if !Self::is_float(&a) {
            return int_math(fun, &a, b.as_ref(), c.as_ref());
        }
        let name = format!("{fun:?}");
        let one = |run: &mut Self, g: &dyn Fn(f32) -> f32| {
            map1(&a, &mut |x| {
                let v = g(x);
                Val::F(run.res(f, h, v, || format!("{name}({x:e})")))
            })
        };
        match fun {
            M::Abs => one(self, &|x| x.abs()),
            M::Floor => one(self, &|x| x.floor()),
            M::Ceil => one(self, &|x| x.ceil()),
            M::Round => one(self, &|x| x.round_ties_even()),
            M::Fract => one(self, &|x| x - x.floor()),
            M::Trunc => one(self, &|x| x.trunc()),
            M::Sqrt => one(self, &|x| x.sqrt()),
            M::InverseSqrt => one(self, &|x| 1.0 / x.sqrt()),
            M::Exp => one(self, &|x| x.exp()),
            M::Exp2 => one(self, &|x| x.exp2()),
            M::Log => one(self, &|x| x.ln()),
            M::Log2 => one(self, &|x| x.log2()),
            M::Sin => one(self, &|x| x.sin()),
            M::Cos => one(self, &|x| x.cos()),
            M::Tan => one(self, &|x| x.tan()),
            M::Tanh => one(self, &|x| x.tanh()),
            M::Atan => one(self, &|x| x.atan()),
            M::Atanh => one(self, &|x| x.atanh()),
            M::Asin => one(self, &|x| x.asin()),
            M::Acos => one(self, &|x| x.acos()),
            M::Degrees => one(self, &|x| x.to_degrees()),
            M::Radians => one(self, &|x| x.to_radians()),
            M::Saturate => one(self, &|x| x.clamp(0.0, 1.0)),
            M::Sign => one(self, &|x| {
                if x > 0.0 {
                    1.0
                } else if x < 0.0 {
                    -1.0
                } else {
                    0.0
                }
            }),
            M::Min | M::Max | M::Pow | M::Atan2 | M::Step => {
                let b = b.expect("two arguments");
                zip(&a, &b, &mut |x, y| {
                    let v = match fun {
                        M::Min => x.min(y),
                        M::Max => x.max(y),
                        M::Pow => x.powf(y),
                        M::Atan2 => x.atan2(y),
                        _ => {
                            if y >= x {
                                1.0
                            } else {
                                0.0
                            }
                        }
                    };
                    Val::F(self.res(f, h, v, || format!("{name}({x:e}, {y:e})")))
                })
            }
            M::Clamp => {
                let (lo, hi) = (b.expect("three"), c.expect("three"));
                zip3(&a, &lo, &hi, &mut |x, l, u| Val::F(x.max(l).min(u)))
            }
            M::Mix => {
                // mix(x, y, t) = x·(1 − t) + y·t, as the SPIR-V extended
                // instruction set defines FMix.
                let (y, t) = (b.expect("three"), c.expect("three"));
                let t = if matches!(t, Val::F(_)) && matches!(a, Val::C(_)) {
                    Val::C(vec![t; a.comp().len()])
                } else {
                    t
                };
                zip3(&a, &y, &t, &mut |x, y, t| {
                    let u = self.res(f, h, 1.0 - t, || format!("1 - {t:e}"));
                    let p = self.res(f, h, x * u, || format!("{x:e} * {u:e}"));
                    let v = if self.rw.fma {
                        y.mul_add(t, p)
                    } else {
                        p + self.flush(y * t)
                    };
                    Val::F(self.res(f, h, v, || format!("mix({x:e}, {y:e}, {t:e})")))
                })
            }
            M::Fma => {
                let (y, z) = (b.expect("three"), c.expect("three"));
                zip3(&a, &y, &z, &mut |x, y, z| {
                    Val::F(self.res(f, h, x.mul_add(y, z), || {
                        format!("fma({x:e}, {y:e}, {z:e})")
                    }))
                })
            }
            M::Dot => {
                let b = b.expect("two");
                Val::F(self.dot(f, h, a.comp(), b.comp()))
            }
            M::Length => {
                let v = a.floats();
                let mut acc = 0.0f32;
                for x in v {
                    let p = self.res(f, h, x * x, || format!("{x:e}^2"));
                    acc = self.res(f, h, acc + p, || format!("{acc:e} + {p:e}"));
                }
                Val::F(self.res(f, h, acc.sqrt(), || format!("sqrt({acc:e})")))
            }
            other => panic!("the evaluator has no {other:?}"),
        }
    }
}

fn zero_scalar(kind: ScalarKind) -> Val {
    match kind {
        ScalarKind::Float | ScalarKind::AbstractFloat => Val::F(0.0),
        ScalarKind::Uint => Val::U(0),
        ScalarKind::Sint | ScalarKind::AbstractInt => Val::I(0),
        ScalarKind::Bool => Val::B(false),
    }
}

fn literal(l: &naga::Literal) -> Val {
    match l {
        naga::Literal::F32(v) => Val::F(*v),
        naga::Literal::F64(v) | naga::Literal::AbstractFloat(v) => Val::F(*v as f32),
        naga::Literal::U32(v) => Val::U(*v),
        naga::Literal::I32(v) => Val::I(*v),
        naga::Literal::AbstractInt(v) => Val::I(*v as i32),
        naga::Literal::Bool(v) => Val::B(*v),
        other => panic!("literal {other:?}"),
    }
}

fn map1(v: &Val, g: &mut dyn FnMut(f32) -> Val) -> Val {
    match v {
        Val::F(x) => g(*x),
        Val::C(c) => Val::C(c.iter().map(|x| map1(x, g)).collect()),
        other => panic!("float function of {other:?}"),
    }
}

/// Element by element, a scalar standing for every element.
fn zip(a: &Val, b: &Val, g: &mut dyn FnMut(f32, f32) -> Val) -> Val {
    match (a, b) {
        (Val::F(x), Val::F(y)) => g(*x, *y),
        (Val::C(x), Val::C(y)) => Val::C(x.iter().zip(y).map(|(x, y)| zip(x, y, g)).collect()),
        (Val::C(x), s @ Val::F(_)) => Val::C(x.iter().map(|x| zip(x, s, g)).collect()),
        (s @ Val::F(_), Val::C(y)) => Val::C(y.iter().map(|y| zip(s, y, g)).collect()),
        other => panic!("float operands {other:?}"),
    }
}

fn zip3(a: &Val, b: &Val, c: &Val, g: &mut dyn FnMut(f32, f32, f32) -> Val) -> Val {
    let n = [a, b, c].iter().find_map(|v| match v {
        Val::C(c) => Some(c.len()),
        _ => None,
    });
    match n {
        None => g(a.f(), b.f(), c.f()),
        Some(n) => {
            let at = |v: &Val, i: usize| match v {
                Val::C(c) => c[i].clone(),
                s => s.clone(),
            };
            Val::C(
                (0..n)
                    .map(|i| zip3(&at(a, i), &at(b, i), &at(c, i), g))
                    .collect(),
            )
        }
    }
}

fn select(c: &Val, accept: Val, reject: Val) -> Val {
    match c {
        Val::B(true) => accept,
        Val::B(false) => reject,
        Val::C(cs) => Val::C(
            cs.iter()
                .enumerate()
                .map(|(i, c)| select(c, accept.comp()[i].clone(), reject.comp()[i].clone()))
                .collect(),
        ),
        other => panic!("select on {other:?}"),
    }
}

/// A comparison of two scalars; `None` for an operator that is not one.
fn compare<T: PartialOrd>(op: B, x: T, y: T) -> Option<Val> {
    Some(Val::B(match op {
        B::Equal => x == y,
        B::NotEqual => x != y,
        B::Less => x < y,
        B::LessEqual => x <= y,
        B::Greater => x > y,
        B::GreaterEqual => x >= y,
        _ => return None,
    }))
}

fn int_binary(op: B, l: &Val, r: &Val) -> Val {
    match (l, r) {
        (Val::C(x), Val::C(y)) => {
            Val::C(x.iter().zip(y).map(|(x, y)| int_binary(op, x, y)).collect())
        }
        (Val::C(x), s) => Val::C(x.iter().map(|x| int_binary(op, x, s)).collect()),
        (s, Val::C(y)) => Val::C(y.iter().map(|y| int_binary(op, s, y)).collect()),
        (Val::U(x), Val::U(y)) => {
            let (x, y) = (*x, *y);
            match op {
                B::Add => Val::U(x.wrapping_add(y)),
                B::Subtract => Val::U(x.wrapping_sub(y)),
                B::Multiply => Val::U(x.wrapping_mul(y)),
                B::Divide => Val::U(x.checked_div(y).unwrap_or(x)),
                B::Modulo => Val::U(if y == 0 { 0 } else { x % y }),
                B::And => Val::U(x & y),
                B::InclusiveOr => Val::U(x | y),
                B::ExclusiveOr => Val::U(x ^ y),
                B::ShiftLeft => Val::U(x.wrapping_shl(y)),
                B::ShiftRight => Val::U(x.wrapping_shr(y)),
                other => compare(other, x, y).unwrap_or_else(|| panic!("u32 {other:?}")),
            }
        }
        (Val::I(x), Val::I(y)) => {
            let (x, y) = (*x, *y);
            match op {
                B::Add => Val::I(x.wrapping_add(y)),
                B::Subtract => Val::I(x.wrapping_sub(y)),
                B::Multiply => Val::I(x.wrapping_mul(y)),
                B::Divide => Val::I(if y == 0 { x } else { x.wrapping_div(y) }),
                B::Modulo => Val::I(if y == 0 { 0 } else { x.wrapping_rem(y) }),
                other => compare(other, x, y).unwrap_or_else(|| panic!("i32 {other:?}")),
            }
        }
        (Val::B(x), Val::B(y)) => match op {
            B::LogicalAnd | B::And => Val::B(*x && *y),
            B::LogicalOr | B::InclusiveOr => Val::B(*x || *y),
            B::Equal => Val::B(x == y),
            B::NotEqual => Val::B(x != y),
            other => panic!("bool {other:?}"),
        },
        other => panic!("integer operands {other:?}"),
    }
}

fn int_math(fun: M, a: &Val, b: Option<&Val>, c: Option<&Val>) -> Val {
    match (fun, a, b, c) {
        (M::Min, Val::U(x), Some(Val::U(y)), _) => Val::U(*x.min(y)),
        (M::Max, Val::U(x), Some(Val::U(y)), _) => Val::U(*x.max(y)),
        (M::Clamp, Val::U(x), Some(Val::U(l)), Some(Val::U(u))) => Val::U(*x.max(l).min(u)),
        (M::Min, Val::I(x), Some(Val::I(y)), _) => Val::I(*x.min(y)),
        (M::Max, Val::I(x), Some(Val::I(y)), _) => Val::I(*x.max(y)),
        (M::Clamp, Val::I(x), Some(Val::I(l)), Some(Val::I(u))) => Val::I(*x.max(l).min(u)),
        (M::Abs, Val::I(x), _, _) => Val::I(x.wrapping_abs()),
        (_, Val::C(x), _, _) => Val::C(
            x.iter()
                .enumerate()
                .map(|(i, x)| {
                    let pick = |v: Option<&Val>| match v {
                        Some(Val::C(c)) => Some(c[i].clone()),
                        other => other.cloned(),
                    };
                    int_math(fun, x, pick(b).as_ref(), pick(c).as_ref())
                })
                .collect(),
        ),
        other => panic!("integer function {other:?}"),
    }
}

fn cast(v: &Val, kind: ScalarKind, convert: bool) -> Val {
    match v {
        Val::C(c) => Val::C(c.iter().map(|x| cast(x, kind, convert)).collect()),
        _ if !convert => {
            let bits = match v {
                Val::F(x) => x.to_bits(),
                Val::U(x) => *x,
                Val::I(x) => *x as u32,
                other => panic!("bitcast {other:?}"),
            };
            match kind {
                ScalarKind::Float => Val::F(f32::from_bits(bits)),
                ScalarKind::Uint => Val::U(bits),
                _ => Val::I(bits as i32),
            }
        }
        _ => {
            let x = match v {
                Val::F(x) => *x as f64,
                Val::U(x) => *x as f64,
                Val::I(x) => *x as f64,
                Val::B(b) => *b as u8 as f64,
                other => panic!("convert {other:?}"),
            };
            match kind {
                // WGSL's float → integer conversion saturates, as Rust's `as`.
                ScalarKind::Float => Val::F(x as f32),
                ScalarKind::Uint => Val::U(x as u32),
                ScalarKind::Sint => Val::I(x as i32),
                _ => Val::B(x != 0.0),
            }
        }
    }
}
