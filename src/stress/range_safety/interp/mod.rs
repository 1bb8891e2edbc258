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

use naga::{Handle, Module, ScalarKind, TypeInner};
use std::collections::HashMap;

mod arith;
mod eval;
mod scalar;

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
