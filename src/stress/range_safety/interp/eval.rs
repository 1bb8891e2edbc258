//! Running a function of the module: its statements, its expressions (the
//! float arithmetic is `arith`), variables, constants and overrides.

use super::scalar::{cast, literal, map1, select, zero_scalar};
use super::{Fault, Flow, Frame, Root, Run, Val};
use naga::{Expression as E, Handle, Module, ScalarKind, Statement as S, TypeInner};

impl<'p> Run<'p> {
    pub(super) fn m(&self) -> &'p Module {
        &self.p.module
    }

    pub(super) fn flush(&self, x: f32) -> f32 {
        if self.rw.flush && x != 0.0 && x.abs() < f32::MIN_POSITIVE {
            0.0f32.copysign(x)
        } else {
            x
        }
    }

    pub(super) fn flushed(&self, v: Val) -> Val {
        match v {
            Val::F(x) => Val::F(self.flush(x)),
            Val::C(v) => Val::C(v.into_iter().map(|x| self.flushed(x)).collect()),
            other => other,
        }
    }

    /// One float result: flushed, and checked.
    pub(super) fn res(
        &mut self,
        f: &Frame,
        h: Handle<E>,
        x: f32,
        what: impl FnOnce() -> String,
    ) -> f32 {
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

    pub(super) fn call(&mut self, h: Handle<naga::Function>, args: Vec<Val>) -> Option<Val> {
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

    pub(super) fn block(&mut self, f: &mut Frame, block: &naga::Block) -> Flow {
        for st in block.iter() {
            let flow = self.statement(f, st);
            if !matches!(flow, Flow::Next) {
                return flow;
            }
        }
        Flow::Next
    }

    pub(super) fn statement(&mut self, f: &mut Frame, st: &S) -> Flow {
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

    pub(super) fn place<'a>(
        &'a mut self,
        f: &'a mut Frame,
        root: Root,
        path: &[usize],
    ) -> &'a mut Val {
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

    pub(super) fn global_value(&self, i: usize) -> Val {
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

    pub(super) fn zero(&self, ty: Handle<naga::Type>) -> Val {
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

    pub(super) fn override_value(&self, h: Handle<naga::Override>) -> Val {
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
    pub(super) fn const_eval(&self, h: Handle<E>) -> Val {
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

    pub(super) fn eval(&mut self, f: &mut Frame, h: Handle<E>) -> Val {
        if let Some(v) = &f.cache[h.index()] {
            return v.clone();
        }
        self.compute(f, h)
    }

    pub(super) fn compute(&mut self, f: &mut Frame, h: Handle<E>) -> Val {
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

    pub(super) fn index(&mut self, f: &mut Frame, base: Handle<E>, i: usize) -> Val {
        match self.eval(f, base) {
            Val::P(root, mut path) => {
                path.push(i);
                Val::P(root, path)
            }
            Val::C(v) => v[i].clone(),
            other => panic!("index {i} into {other:?}"),
        }
    }

    pub(super) fn unary(&mut self, op: naga::UnaryOperator, v: Val) -> Val {
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
}
