//! Tone-mapping operators: one public type, [`ToneOperator`], that each
//! operator implements once (docs/operators.md).
//!
//! An operator's definition holds everything the rest of tonegate derives:
//! its name and parameters (with their ranges and defaults), from which come
//! the scene keys, the `tonemap` flags, the API's parameters and its schema;
//! the statistics it needs and how it resolves them ([`ToneOperator::resolve`],
//! the f64 reference); its WGSL, which the `tonemap` stage and the fused
//! kernels include; and its documentation line. Nothing else in tonegate
//! matches on which operator it is: the operator is a pipeline key that
//! selects the WGSL, and everything else goes through this trait.
//!
//! Built-in operators are in [`builtin`]; a caller's own operator (in its
//! own crate, `examples/own_operator.rs`) is added with [`register`] and then
//! gets the whole harness: scene files, goldens from its f64 reference, the
//! GPU held to it, stress rows and `tradeoff`.

pub mod aces2;
mod aces_hill;
mod aces_narkowicz;
mod agx;
mod bt2390;
mod definition;
mod describe;
mod error;
mod fixed;
mod hable;
mod params;
mod pbr_neutral;
mod registry;
pub mod reinhard;
mod reinhard02;
mod reinhard_auto_key;
mod reinhard_global;
mod stats;
mod table;

pub use crate::color::pq_decode;
pub use bt2390::pq_encode;
pub use definition::{Curve, DisplayLevels, ExposureWord, Resolution, ToneOperator};
pub use describe::{describe, OperatorInfo, ParamInfo, RangeInfo};
pub use error::OperatorError;
pub use params::{Kind, Param, Range, Value, Values};
pub use registry::{all, all_params, builtin, find, names, register};
pub use reinhard02::preset as reinhard02_preset;
pub use stats::{LuminanceStats, StatsNeeds, Unmeasured};

/// The names of the operators that other parts of tonegate set up by name
/// (the default, the flat tone-map's preset, the bench's plan, the stress
/// suite's statistics set-ups): each operator's own `name` is this
/// constant, so a rename happens here only.
pub const REINHARD_GLOBAL: &str = "reinhard-global";
/// `reinhard-auto-key`'s name.
pub const REINHARD_AUTO_KEY: &str = "reinhard-auto-key";
/// `reinhard02`'s name (also the `--preset` of pfstmo's global mode).
pub const REINHARD02: &str = "reinhard02";
/// `agx`'s name (what the triage page shows HDR frames with by default).
pub const AGX: &str = "agx";

use serde::ser::SerializeMap;
use serde::{Deserialize, Serialize};
use std::sync::Arc;

/// The luminance an operator's statistics are measured in: the weights of
/// Y = w·RGB and the offset δ of the log-averages (ln(δ + Y)).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Luminance {
    /// Y = weights · (R, G, B).
    pub weights: [f64; 3],
    /// δ in ln(δ + Y).
    pub delta: f64,
}

impl Luminance {
    /// BT.709 weights and δ = 1e-4 (the image-processing lecture,
    /// docs/bibliography.md): what every operator measures in unless it says
    /// otherwise.
    pub const BT709: Luminance = Luminance {
        weights: crate::color::BT709,
        delta: reinhard::DELTA,
    };
}

/// An operator with its parameters' values: what a scene's `[operator]`
/// table, the `tonemap` flags and the API's parameters become.
#[derive(Clone)]
pub struct Operator {
    def: Arc<dyn ToneOperator>,
    values: Values,
}

impl Operator {
    /// Operator `def` with the `given` values (by parameter name), the rest
    /// at their defaults; each value checked against its range, then the
    /// operator's own checks.
    pub fn with(
        def: Arc<dyn ToneOperator>,
        given: &[(&str, Value)],
    ) -> Result<Operator, OperatorError> {
        for (name, _) in given {
            if !def.params().iter().any(|p| p.name == *name) {
                return Err(not_taken(def.as_ref(), name));
            }
        }
        let mut values = Vec::with_capacity(def.params().len());
        for p in def.params() {
            let v = given
                .iter()
                .rev()
                .find(|(n, _)| *n == p.name)
                .map(|(_, v)| *v)
                .unwrap_or(p.default);
            let v = if v == Value::Unset {
                v
            } else {
                p.accept(v).map_err(|e| OperatorError::BadValue {
                    operator: def.name(),
                    parameter: p.name.to_owned(),
                    reason: table::auto_hint(def.as_ref(), p.name, v, e),
                })?
            };
            values.push((p.name, v));
        }
        let values = Values::new(values);
        def.check(&values)
            .map_err(|reason| OperatorError::Refused {
                operator: def.name(),
                reason,
            })?;
        Ok(Operator { def, values })
    }

    /// The operator called `name` with the `given` values.
    pub fn named(name: &str, given: &[(&str, Value)]) -> Result<Operator, OperatorError> {
        let def = find(name).ok_or_else(|| unknown_operator(name))?;
        Operator::with(def, given)
    }

    /// This operator with parameter `name` set to `value`, the others as
    /// they are.
    pub fn with_value(&self, name: &str, value: Value) -> Result<Operator, OperatorError> {
        let mut given: Vec<(&str, Value)> = self
            .values
            .iter()
            .filter(|(_, v)| *v != Value::Unset)
            .map(|(n, v)| (*n, *v))
            .collect();
        given.push((name, value));
        Operator::with(self.def.clone(), &given)
    }

    /// Operator `def` with values given as text (flags, query parameters):
    /// each value is read as any operator's parameter of that name would
    /// read it (so a bad value is named as bad whatever the operator), then
    /// held to `def`'s own.
    pub fn from_text(
        def: Arc<dyn ToneOperator>,
        given: &[(String, String)],
    ) -> Result<Operator, OperatorError> {
        let mut values: Vec<(&str, Value)> = Vec::with_capacity(given.len());
        for (name, text) in given {
            let takers: Vec<Param> = all()
                .iter()
                .filter_map(|o| o.params().iter().find(|p| p.name == name).copied())
                .collect();
            if takers.is_empty() {
                return Err(not_taken(def.as_ref(), name));
            }
            let own = def.params().iter().find(|p| p.name == name).copied();
            let mut first_error = None;
            let mut read = None;
            for p in own.iter().chain(takers.iter()) {
                match p.parse(text) {
                    Ok(v) => {
                        read = Some(v);
                        break;
                    }
                    Err(e) => {
                        first_error.get_or_insert(e);
                    }
                }
            }
            match read {
                Some(v) => values.push((name, v)),
                None => {
                    return Err(OperatorError::BadValue {
                        operator: def.name(),
                        parameter: name.clone(),
                        reason: first_error.unwrap_or_default(),
                    })
                }
            }
        }
        Operator::with(def, &values)
    }

    /// Its definition.
    pub fn definition(&self) -> &dyn ToneOperator {
        self.def.as_ref()
    }

    /// Its definition, shared.
    pub fn definition_arc(&self) -> Arc<dyn ToneOperator> {
        self.def.clone()
    }

    /// Its name.
    pub fn name(&self) -> &'static str {
        self.def.name()
    }

    /// Its parameters' values (every parameter, defaults filled in).
    pub fn values(&self) -> &Values {
        &self.values
    }

    /// What it needs measured.
    pub fn needs(&self) -> StatsNeeds {
        self.def.needs(&self.values)
    }

    /// The luminance its statistics are measured in.
    pub fn luminance(&self) -> Luminance {
        self.def.luminance(&self.values)
    }

    /// The display it maps onto, for an operator with absolute output
    /// ([`ToneOperator::display_levels`]).
    pub fn display_levels(&self) -> Option<DisplayLevels> {
        self.def.display_levels(&self.values)
    }

    /// The f64 reference for a frame with statistics `stats`.
    pub fn resolve(&self, stats: &LuminanceStats) -> Result<Tone, Unmeasured> {
        let r = self.def.resolve(&self.values, stats)?;
        Ok(Tone {
            params: ToneParams {
                operator: self.name(),
                values: r.values,
            },
            curve: Arc::from(r.curve),
        })
    }

    /// The GPU's resolved vec4 as a report.
    pub fn gpu_resolved(&self, slots: [f32; 4]) -> ToneParams {
        ToneParams {
            operator: self.name(),
            values: self.def.gpu_resolved(&self.values, slots),
        }
    }
}

fn unknown_operator(name: &str) -> OperatorError {
    OperatorError::UnknownOperator {
        name: name.to_owned(),
        known: names(),
    }
}

/// The error for a parameter `def` does not take: which operators do, or
/// that none does.
fn not_taken(def: &dyn ToneOperator, name: &str) -> OperatorError {
    let takers: Vec<&'static str> = all()
        .iter()
        .filter(|o| o.params().iter().any(|p| p.name == name))
        .map(|o| o.name())
        .collect();
    if takers.is_empty() {
        OperatorError::UnknownParameter {
            operator: def.name(),
            parameter: name.to_owned(),
            takes: def.params().iter().map(|p| p.name).collect(),
        }
    } else {
        OperatorError::NotTaken {
            operator: def.name(),
            parameter: name.to_owned(),
            takers,
        }
    }
}

impl Default for Operator {
    /// `reinhard-global` with its defaults.
    fn default() -> Self {
        Operator::with(Arc::new(reinhard_global::ReinhardGlobal), &[])
            .expect("the default operator's defaults are in range")
    }
}

impl PartialEq for Operator {
    fn eq(&self, other: &Self) -> bool {
        self.name() == other.name() && self.values == other.values
    }
}

impl std::fmt::Debug for Operator {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{} {:?}", self.name(), self.values)
    }
}

impl Serialize for Operator {
    /// `kind` then every parameter with a value, in the definition's order;
    /// an unset optional parameter (measured instead) is left out.
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let set: Vec<_> = self
            .values
            .iter()
            .filter(|(_, v)| *v != Value::Unset)
            .collect();
        let mut m = s.serialize_map(Some(set.len() + 1))?;
        m.serialize_entry("kind", self.name())?;
        for (name, v) in set {
            m.serialize_entry(name, &v)?;
        }
        m.end()
    }
}

impl<'de> Deserialize<'de> for Operator {
    /// A table with `kind` and the operator's parameters. Each value is
    /// checked where it stands (so a TOML error names its line) against
    /// every operator taking a parameter of that name, then against the
    /// chosen operator once `kind` is known.
    fn deserialize<D: serde::Deserializer<'de>>(d: D) -> Result<Self, D::Error> {
        d.deserialize_map(table::OperatorVisitor)
    }
}

/// The resolved values of one frame, named: what reports show and what the
/// GPU's are compared with.
#[derive(Clone, Debug, PartialEq)]
pub struct ToneParams {
    /// The operator's name.
    pub operator: &'static str,
    /// Named values, in the operator's order.
    pub values: Vec<(&'static str, f64)>,
}

impl ToneParams {
    /// The value called `name`, if the operator resolves one.
    pub fn get(&self, name: &str) -> Option<f64> {
        self.values
            .iter()
            .find(|(n, _)| *n == name)
            .map(|(_, v)| *v)
    }

    /// Whether every resolved value is finite (a value that does not apply,
    /// such as the white point of a curve that never burns, is left out
    /// rather than reported as +∞).
    pub fn sane(&self) -> bool {
        self.values.iter().all(|(_, v)| v.is_finite())
    }
}

impl Serialize for ToneParams {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        let mut m = s.serialize_map(Some(self.values.len() + 1))?;
        m.serialize_entry("operator", self.operator)?;
        for (n, v) in &self.values {
            m.serialize_entry(n, v)?;
        }
        m.end()
    }
}

/// A frame's resolved operator: its values and its f64 curve.
#[derive(Clone)]
pub struct Tone {
    /// The resolved values.
    pub params: ToneParams,
    curve: Arc<dyn Curve>,
}

impl Tone {
    /// The display colour of scene colour `c` (f64 reference).
    #[inline]
    pub fn pixel(&self, c: [f64; 3]) -> [f64; 3] {
        self.curve.pixel(c)
    }
}

impl std::fmt::Debug for Tone {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        self.params.fmt(f)
    }
}

#[cfg(test)]
mod tests;
