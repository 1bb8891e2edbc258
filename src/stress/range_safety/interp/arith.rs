//! The float arithmetic of the evaluator, where the rewrites apply:
//! division (reassociated, or through a reciprocal), fused multiply-adds,
//! dot products and matrix products, and the math functions; every result
//! flushed where subnormals are and checked.

use super::scalar::{compare, int_binary, int_math, map1, zip, zip3};
use super::{Frame, Run, Val};
use naga::{BinaryOperator as B, Expression as E, Handle, MathFunction as M};

impl Run<'_> {
    pub(super) fn operand(&self, f: &Frame, h: Handle<E>, op: B) -> Option<(Handle<E>, Handle<E>)> {
        match &f.func.expressions[h] {
            E::Binary { op: o, left, right } if *o == op => Some((*left, *right)),
            _ => None,
        }
    }

    pub(super) fn is_float(v: &Val) -> bool {
        match v {
            Val::F(_) => true,
            Val::C(c) => c.first().is_some_and(Self::is_float),
            _ => false,
        }
    }

    pub(super) fn binary(
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

    pub(super) fn plain(&mut self, f: &Frame, h: Handle<E>, op: B, l: &Val, r: &Val) -> Val {
        zip(l, r, &mut |x, y| match op {
            B::Add => Val::F(self.res(f, h, x + y, || format!("{x:e} + {y:e}"))),
            B::Subtract => Val::F(self.res(f, h, x - y, || format!("{x:e} - {y:e}"))),
            B::Multiply => Val::F(self.res(f, h, x * y, || format!("{x:e} * {y:e}"))),
            B::Modulo => Val::F(self.res(f, h, x % y, || format!("{x:e} % {y:e}"))),
            other => compare(other, x, y).unwrap_or_else(|| panic!("float {other:?}")),
        })
    }

    pub(super) fn divide(&mut self, f: &Frame, h: Handle<E>, x: f32, y: f32) -> f32 {
        if self.rw.reciprocal {
            let inv = self.res(f, h, 1.0 / y, || format!("1 / {y:e}"));
            self.res(f, h, x * inv, || format!("{x:e} * (1 / {y:e})"))
        } else {
            self.res(f, h, x / y, || format!("{x:e} / {y:e}"))
        }
    }

    /// Σ a[i]·b[i], accumulated in order (with fused multiply-adds where
    /// they apply): how dot products and matrix rows are evaluated.
    pub(super) fn dot(&mut self, f: &Frame, h: Handle<E>, a: &[Val], b: &[Val]) -> f32 {
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

    pub(super) fn matrix_multiply(&mut self, f: &Frame, h: Handle<E>, l: &Val, r: &Val) -> Val {
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

    pub(super) fn math(
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
