//! Every operator described for a form or a schema: what `tonegate
//! operators` prints and `GET /api/v1/operators` answers.

use super::params::{Kind, Range, Value};
use super::{all, ToneOperator};
use serde::Serialize;

/// An operator as `tonegate operators` and `GET /api/v1/operators` describe
/// it: everything a form or a schema needs to offer it.
#[derive(Clone, Debug, Serialize)]
pub struct OperatorInfo {
    /// Its name.
    pub name: &'static str,
    /// Other names it is accepted by.
    pub aliases: &'static [&'static str],
    /// Its documentation line.
    pub summary: &'static str,
    /// The values it resolves per frame, which reports show.
    pub resolves: &'static [&'static str],
    /// Its parameters.
    pub params: Vec<ParamInfo>,
    /// Whether, at its defaults, it maps onto a display of known peak, so
    /// that PQ or HLG output (`display`) can be asked of it.
    pub hdr_output: bool,
}

/// One parameter of an [`OperatorInfo`].
#[derive(Clone, Debug, Serialize)]
pub struct ParamInfo {
    /// Its name.
    pub name: &'static str,
    /// Its documentation line.
    pub doc: &'static str,
    /// `number`, `number_or_auto`, `flag` or `word`.
    #[serde(rename = "type")]
    pub kind: &'static str,
    /// For numbers: the range (`max` null for none) and whether each end
    /// is excluded.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub range: Option<RangeInfo>,
    /// For words: the words.
    #[serde(skip_serializing_if = "Option::is_none")]
    pub words: Option<&'static [&'static str]>,
    /// The default; null when the operator measures it instead.
    pub default: Value,
    /// What it takes, in words ("a finite number > 0").
    pub expected: String,
}

/// A number's range in an [`OperatorInfo`].
#[derive(Clone, Copy, Debug, Serialize)]
pub struct RangeInfo {
    /// The lower bound.
    pub min: f64,
    /// Whether `min` is excluded.
    pub min_open: bool,
    /// The upper bound; none for unbounded.
    pub max: Option<f64>,
    /// Whether `max` is excluded.
    pub max_open: bool,
}

/// Every operator known, described.
pub fn describe() -> Vec<OperatorInfo> {
    all().iter().map(|o| describe_one(o.as_ref())).collect()
}

/// The operator's parameters at their defaults.
fn defaults(o: &dyn ToneOperator) -> super::Values {
    super::Values::new(o.params().iter().map(|p| (p.name, p.default)).collect())
}

fn describe_one(o: &dyn ToneOperator) -> OperatorInfo {
    let params = o
        .params()
        .iter()
        .map(|p| {
            let range = |r: &Range| RangeInfo {
                min: r.min,
                min_open: r.min_open,
                max: r.max.is_finite().then_some(r.max),
                max_open: r.max_open,
            };
            let (kind, range, words) = match &p.kind {
                Kind::Number(r) => ("number", Some(range(r)), None),
                Kind::NumberOrAuto(r) => ("number_or_auto", Some(range(r)), None),
                Kind::Flag => ("flag", None, None),
                Kind::Word(w) => ("word", None, Some(*w)),
            };
            ParamInfo {
                name: p.name,
                doc: p.doc,
                kind,
                range,
                words,
                default: p.default,
                expected: p.expected(),
            }
        })
        .collect();
    OperatorInfo {
        name: o.name(),
        aliases: o.aliases(),
        summary: o.summary(),
        resolves: o.resolved_names(),
        params,
        hdr_output: o.display_levels(&defaults(o)).is_some(),
    }
}
