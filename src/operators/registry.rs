//! The operators known to this process: the built-in ones, then those a
//! caller registered, and what every one of their parameters is.

use super::params::{self, Param, Value};
use super::{
    aces2, aces_hill, aces_narkowicz, agx, bt2390, hable, pbr_neutral, reinhard02,
    reinhard_auto_key, reinhard_global, OperatorError, ToneOperator,
};
use std::sync::{Arc, OnceLock, RwLock};

/// The built-in operators, the default first.
pub fn builtin() -> Vec<Arc<dyn ToneOperator>> {
    vec![
        Arc::new(reinhard_global::ReinhardGlobal),
        Arc::new(reinhard_auto_key::ReinhardAutoKey),
        Arc::new(reinhard02::Reinhard02),
        Arc::new(aces_narkowicz::AcesNarkowicz),
        Arc::new(aces_hill::AcesHill),
        Arc::new(agx::Agx),
        Arc::new(pbr_neutral::PbrNeutral),
        Arc::new(hable::Hable),
        Arc::new(bt2390::Bt2390),
        Arc::new(aces2::Aces2),
    ]
}

fn registry() -> &'static RwLock<Vec<Arc<dyn ToneOperator>>> {
    static REGISTRY: OnceLock<RwLock<Vec<Arc<dyn ToneOperator>>>> = OnceLock::new();
    REGISTRY.get_or_init(|| RwLock::new(builtin()))
}

/// Every operator known: the built-in ones, then the registered ones.
pub fn all() -> Vec<Arc<dyn ToneOperator>> {
    registry().read().unwrap_or_else(|e| e.into_inner()).clone()
}

/// The operator called `name` (or one of its aliases).
pub fn find(name: &str) -> Option<Arc<dyn ToneOperator>> {
    all()
        .into_iter()
        .find(|o| o.name() == name || o.aliases().contains(&name))
}

/// The names of every operator, for messages and help.
pub fn names() -> Vec<&'static str> {
    all().iter().map(|o| o.name()).collect()
}

/// Adds a caller's operator, so that scene files, flags and the API know
/// it. Refused when its name (or an alias) is taken, when a parameter
/// shares a name with another operator's parameter of another kind (a
/// `--flag` means one thing), or when its defaults are out of its ranges.
pub fn register(op: Arc<dyn ToneOperator>) -> Result<(), OperatorError> {
    let mut ops = registry().write().unwrap_or_else(|e| e.into_inner());
    admissible(&ops, op.as_ref())?;
    ops.push(op);
    Ok(())
}

pub(super) fn admissible(
    known: &[Arc<dyn ToneOperator>],
    op: &dyn ToneOperator,
) -> Result<(), OperatorError> {
    let new_names = std::iter::once(op.name()).chain(op.aliases().iter().copied());
    for name in new_names {
        if params::RESERVED.contains(&name) || name.is_empty() {
            return Err(OperatorError::NameNotAllowed { name });
        }
        if let Some(o) = known
            .iter()
            .find(|o| o.name() == name || o.aliases().contains(&name))
        {
            return Err(OperatorError::NameTaken { name, by: o.name() });
        }
    }
    let bad = |reason: String| OperatorError::BadDefinition {
        operator: op.name(),
        reason,
    };
    if op.resolved_names().len() > 4 {
        return Err(bad(format!(
            "at most 4 resolved values, got {}",
            op.resolved_names().len()
        )));
    }
    for p in op.params() {
        params::check_name(p.name).map_err(bad)?;
        if p.default != Value::Unset {
            p.accept(p.default)
                .map_err(|e| bad(format!("default of {e}")))?;
        }
        for o in known {
            if let Some(q) = o.params().iter().find(|q| q.name == p.name) {
                if !q.kind.same_type(&p.kind) {
                    return Err(bad(format!(
                        "parameter {} is a {} in operator {}, not a {}",
                        p.name,
                        q.kind.type_name(),
                        o.name(),
                        p.kind.type_name()
                    )));
                }
            }
        }
    }
    Ok(())
}

/// Every parameter name any operator takes, once, with the operators that
/// take it: what the flags and the API's parameters are made of.
pub fn all_params() -> Vec<(Param, Vec<&'static str>)> {
    let mut out: Vec<(Param, Vec<&'static str>)> = Vec::new();
    for op in all() {
        for p in op.params() {
            match out.iter_mut().find(|(q, _)| q.name == p.name) {
                Some((_, by)) => by.push(op.name()),
                None => out.push((*p, vec![op.name()])),
            }
        }
    }
    out
}
