//! Reading a scene file's `[operator]` table: each value checked where it
//! stands (so a TOML error names its line), then against the operator
//! `kind` names.

use super::params::{Kind, Raw, Value};
use super::{all, find, Operator, ToneOperator};
use serde::de::{DeserializeSeed, MapAccess, Visitor};

/// Reads one parameter's value where it stands, checked against every
/// operator that takes a parameter of that name: a value no operator could
/// take is an error at its own line.
struct ParamSeed {
    name: String,
}

impl<'de> DeserializeSeed<'de> for ParamSeed {
    type Value = (Raw, Value);
    fn deserialize<D: serde::Deserializer<'de>>(self, d: D) -> Result<Self::Value, D::Error> {
        let raw = d.deserialize_any(RawVisitor)?;
        let mut first_error = None;
        for op in all() {
            if let Some(p) = op.params().iter().find(|p| p.name == self.name) {
                match p.read_raw(&raw) {
                    Ok(v) => return Ok((raw, v)),
                    Err(e) => {
                        first_error.get_or_insert(e);
                    }
                }
            }
        }
        Err(serde::de::Error::custom(first_error.unwrap_or_else(|| {
            format!("unknown field `{}`", self.name)
        })))
    }
}

/// A value refused with its message, wherever it stands.
struct Refuse(String);

impl<'de> DeserializeSeed<'de> for Refuse {
    type Value = std::convert::Infallible;
    fn deserialize<D: serde::Deserializer<'de>>(self, _: D) -> Result<Self::Value, D::Error> {
        Err(serde::de::Error::custom(self.0))
    }
}

struct RawVisitor;

impl Visitor<'_> for RawVisitor {
    type Value = Raw;
    fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        f.write_str("a number, true or false, or a word")
    }
    fn visit_f64<E: serde::de::Error>(self, v: f64) -> Result<Raw, E> {
        Ok(Raw::Number(v))
    }
    fn visit_i64<E: serde::de::Error>(self, v: i64) -> Result<Raw, E> {
        Ok(Raw::Number(v as f64))
    }
    fn visit_u64<E: serde::de::Error>(self, v: u64) -> Result<Raw, E> {
        Ok(Raw::Number(v as f64))
    }
    fn visit_bool<E: serde::de::Error>(self, v: bool) -> Result<Raw, E> {
        Ok(Raw::Bool(v))
    }
    fn visit_str<E: serde::de::Error>(self, v: &str) -> Result<Raw, E> {
        Ok(Raw::Text(v.to_owned()))
    }
}

/// Reads an `[operator]` table.
pub(super) struct OperatorVisitor;

impl<'de> Visitor<'de> for OperatorVisitor {
    type Value = Operator;
    fn expecting(&self, f: &mut std::fmt::Formatter) -> std::fmt::Result {
        f.write_str("an operator table with kind and its parameters")
    }

    fn visit_map<A: MapAccess<'de>>(self, mut map: A) -> Result<Operator, A::Error> {
        use serde::de::Error;
        let mut def: Option<std::sync::Arc<dyn ToneOperator>> = None;
        let mut given: Vec<(String, Raw, Value)> = Vec::new();
        while let Some(key) = map.next_key::<String>()? {
            if key == "kind" {
                let name: String = map.next_value()?;
                def = Some(
                    find(&name).ok_or_else(|| A::Error::custom(super::unknown_operator(&name)))?,
                );
                continue;
            }
            if !all()
                .iter()
                .any(|o| o.params().iter().any(|p| p.name == key))
            {
                let mut known: Vec<&str> =
                    super::all_params().iter().map(|(p, _)| p.name).collect();
                known.insert(0, "kind");
                // Refused from its value, so that the error points at the
                // key's own line, not at the table's header.
                let message = format!(
                    "unknown field `{key}` in [operator] (a key after a table header belongs to that table: a key of the scene itself, such as fps, goes above its first [table]), expected one of {}",
                    known.join(", ")
                );
                match map.next_value_seed(Refuse(message))? {}
            }
            let (raw, v) = map.next_value_seed(ParamSeed { name: key.clone() })?;
            given.push((key, raw, v));
        }
        let def = match def {
            Some(d) => d,
            None => find(super::builtin()[0].name()).expect("the default operator is built in"),
        };
        // The values again, now against the chosen operator's own ranges.
        let mut values: Vec<(&str, Value)> = Vec::with_capacity(given.len());
        for (name, raw, v) in &given {
            match def.params().iter().find(|p| p.name == *name) {
                Some(p) => values.push((
                    name,
                    p.read_raw(raw)
                        .map_err(|e| auto_hint(def.as_ref(), name, *v, e))
                        .map_err(A::Error::custom)?,
                )),
                None => values.push((name, *v)),
            }
        }
        Operator::with(def, &values).map_err(A::Error::custom)
    }
}

/// A value another operator's parameter of that name takes ("auto") says
/// which operator that is.
pub(super) fn auto_hint(def: &dyn ToneOperator, name: &str, v: Value, error: String) -> String {
    if v != Value::Auto {
        return error;
    }
    let by: Vec<&str> = all()
        .iter()
        .filter(|o| {
            o.params()
                .iter()
                .any(|p| p.name == name && matches!(p.kind, Kind::NumberOrAuto(_)))
        })
        .map(|o| o.name())
        .collect();
    format!(
        "{name}: \"auto\" applies to operator {} only; {} needs a number",
        by.join(" and "),
        def.name()
    )
}
