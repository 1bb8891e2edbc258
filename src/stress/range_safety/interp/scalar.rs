//! The evaluator's values without rewrites: literals, zero values,
//! element-by-element helpers, selection, comparisons, integer arithmetic
//! and casts.

use super::Val;
use naga::{BinaryOperator as B, MathFunction as M, ScalarKind};

pub(super) fn zero_scalar(kind: ScalarKind) -> Val {
    match kind {
        ScalarKind::Float | ScalarKind::AbstractFloat => Val::F(0.0),
        ScalarKind::Uint => Val::U(0),
        ScalarKind::Sint | ScalarKind::AbstractInt => Val::I(0),
        ScalarKind::Bool => Val::B(false),
    }
}

pub(super) fn literal(l: &naga::Literal) -> Val {
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

pub(super) fn map1(v: &Val, g: &mut dyn FnMut(f32) -> Val) -> Val {
    match v {
        Val::F(x) => g(*x),
        Val::C(c) => Val::C(c.iter().map(|x| map1(x, g)).collect()),
        other => panic!("float function of {other:?}"),
    }
}

/// Element by element, a scalar standing for every element.
pub(super) fn zip(a: &Val, b: &Val, g: &mut dyn FnMut(f32, f32) -> Val) -> Val {
    match (a, b) {
        (Val::F(x), Val::F(y)) => g(*x, *y),
        (Val::C(x), Val::C(y)) => Val::C(x.iter().zip(y).map(|(x, y)| zip(x, y, g)).collect()),
        (Val::C(x), s @ Val::F(_)) => Val::C(x.iter().map(|x| zip(x, s, g)).collect()),
        (s @ Val::F(_), Val::C(y)) => Val::C(y.iter().map(|y| zip(s, y, g)).collect()),
        other => panic!("float operands {other:?}"),
    }
}

pub(super) fn zip3(a: &Val, b: &Val, c: &Val, g: &mut dyn FnMut(f32, f32, f32) -> Val) -> Val {
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

pub(super) fn select(c: &Val, accept: Val, reject: Val) -> Val {
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
pub(super) fn compare<T: PartialOrd>(op: B, x: T, y: T) -> Option<Val> {
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

pub(super) fn int_binary(op: B, l: &Val, r: &Val) -> Val {
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

pub(super) fn int_math(fun: M, a: &Val, b: Option<&Val>, c: Option<&Val>) -> Val {
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

pub(super) fn cast(v: &Val, kind: ScalarKind, convert: bool) -> Val {
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
