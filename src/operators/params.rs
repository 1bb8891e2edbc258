//! An operator's parameters: their kinds, ranges, defaults and values, and
//! the reading of an `[operator]` table.

use serde::Serialize;

/// The names the tone-map settings and the API use for themselves, which no
/// operator (nor parameter) may take.
pub(super) const RESERVED: &[&str] = &[
    "kind",
    "operator",
    "preset",
    "colour_space",
    "display",
    "bloom",
    "bloom_pass",
    "bloom_threshold",
    "bloom_downsample",
    "bloom_radius",
    "bloom_sigma",
    "brightness",
    "contrast",
    "saturation",
    "gamma",
    "gpu",
    "format",
    "sanitize",
    // The `tonemap` command's own flags.
    "input",
    "output",
    "json",
    "max_pixels",
    "adapter",
    "backend",
    "hdr_format",
    "reduction",
    "env_filter",
    "execution",
    "help",
];

/// A parameter name: lower-case words joined by `_` (a flag replaces them
/// with `-`), not one of the settings' own.
pub(super) fn check_name(name: &str) -> Result<(), String> {
    let ok = name.starts_with(|c: char| c.is_ascii_lowercase())
        && name
            .chars()
            .all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || c == '_');
    if !ok {
        return Err(format!(
            "parameter name {name:?}: lower-case letters, digits and _ only, starting with a letter"
        ));
    }
    if RESERVED.contains(&name) {
        return Err(format!("parameter name {name:?} is the settings' own"));
    }
    Ok(())
}

/// An interval of allowed numbers; every number must also be finite.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Range {
    /// The lower bound.
    pub min: f64,
    /// Whether the lower bound itself is excluded.
    pub min_open: bool,
    /// The upper bound (+∞ for none).
    pub max: f64,
    /// Whether the upper bound itself is excluded.
    pub max_open: bool,
}

impl Range {
    /// (0, ∞): any finite number > 0.
    pub const POSITIVE: Range = Range {
        min: 0.0,
        min_open: true,
        max: f64::INFINITY,
        max_open: true,
    };
    /// [0, ∞): any finite number ≥ 0.
    pub const NON_NEGATIVE: Range = Range {
        min: 0.0,
        min_open: false,
        max: f64::INFINITY,
        max_open: true,
    };

    /// [1e-6, 1e6]: a gain, key or adaptation luminance. Twelve decades
    /// cover every real exposure, and keep every intermediate of the GPU's
    /// f32 arithmetic finite under any rewrite a driver may apply, over the
    /// stress suite's inputs of up to 1e30 (docs/stress.md#range-safe-arithmetic).
    pub const GAIN: Range = Range::closed(1e-6, 1e6);

    /// [1e-30, 1e30]: an absolute luminance given by hand (a white, a
    /// maximum). f32 holds every such number as a normal float, so the GPU
    /// gets the value the reference uses; a positive number below f32's
    /// range would reach it as 0, which means "measure it" or "never burn".
    pub const LUMINANCE: Range = Range::closed(1e-30, 1e30);

    /// [min, max].
    pub const fn closed(min: f64, max: f64) -> Range {
        Range {
            min,
            min_open: false,
            max,
            max_open: false,
        }
    }

    /// Whether `v` is in the range (and finite).
    pub fn contains(&self, v: f64) -> bool {
        v.is_finite()
            && if self.min_open {
                v > self.min
            } else {
                v >= self.min
            }
            && if self.max_open {
                v < self.max
            } else {
                v <= self.max
            }
    }

    /// "a finite number > 0", "in (0, 1]", "in [1e-6, 1e6]".
    pub fn describe(&self) -> String {
        let lo = if self.min_open { ">" } else { ">=" };
        if self.max == f64::INFINITY {
            if self.min == 0.0 && self.min_open {
                return "a finite number > 0".to_owned();
            }
            return format!("a finite number {lo} {}", shown(self.min));
        }
        format!(
            "in {}{}, {}{}",
            if self.min_open { "(" } else { "[" },
            shown(self.min),
            shown(self.max),
            if self.max_open { ")" } else { "]" }
        )
    }
}

/// A bound as a person reads it: 0.5, 100, 1e-6, 1e30.
fn shown(v: f64) -> String {
    if v != 0.0 && !(1e-4..1e7).contains(&v.abs()) {
        format!("{v:e}")
    } else {
        format!("{v}")
    }
}

/// What a parameter holds.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Kind {
    /// A number in a range.
    Number(Range),
    /// A number in a range, or `"auto"` (the operator works it out).
    NumberOrAuto(Range),
    /// true or false.
    Flag,
    /// One of these words.
    Word(&'static [&'static str]),
}

impl Kind {
    /// Numbers (with or without "auto"), flags and words are three types; a
    /// parameter name means one of them across all operators.
    pub(super) fn same_type(&self, other: &Kind) -> bool {
        self.type_name() == other.type_name()
    }

    pub(super) fn type_name(&self) -> &'static str {
        match self {
            Kind::Number(_) | Kind::NumberOrAuto(_) => "number",
            Kind::Flag => "flag",
            Kind::Word(_) => "word",
        }
    }

    /// The JSON-schema type of the parameter as a query string carries it.
    pub fn schema_type(&self) -> &'static str {
        match self {
            Kind::Number(_) => "number",
            Kind::NumberOrAuto(_) | Kind::Word(_) => "string",
            Kind::Flag => "boolean",
        }
    }
}

/// A parameter's value.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Value {
    /// Not given and with no default: the operator measures it instead.
    Unset,
    /// A number.
    Number(f64),
    /// `"auto"`.
    Auto,
    /// true or false.
    Flag(bool),
    /// One of a [`Kind::Word`]'s words.
    Word(&'static str),
}

impl Serialize for Value {
    fn serialize<S: serde::Serializer>(&self, s: S) -> Result<S::Ok, S::Error> {
        match self {
            Value::Unset => s.serialize_none(),
            Value::Number(v) => s.serialize_f64(*v),
            Value::Auto => s.serialize_str("auto"),
            Value::Flag(b) => s.serialize_bool(*b),
            Value::Word(w) => s.serialize_str(w),
        }
    }
}

impl std::fmt::Display for Value {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        match self {
            Value::Unset => f.write_str("(measured)"),
            Value::Number(v) => f.write_str(&number_words(*v)),
            Value::Auto => f.write_str("auto"),
            Value::Flag(b) => write!(f, "{b}"),
            Value::Word(w) => f.write_str(w),
        }
    }
}

/// A number as an error quotes it: its shortest form, or in exponent form
/// when that is long (`1e300`, not 301 digits).
pub fn number_words(x: f64) -> String {
    let plain = format!("{x}");
    if plain.len() > 24 {
        format!("{x:e}")
    } else {
        plain
    }
}

/// A client's text as an error quotes it: its first 48 characters, and
/// `…` when there were more.
fn clipped(text: &str) -> String {
    match text.char_indices().nth(48) {
        Some((at, _)) => format!("{}…", &text[..at]),
        None => text.to_owned(),
    }
}

/// One parameter of an operator.
#[derive(Clone, Copy, Debug)]
pub struct Param {
    /// Its name (a scene key and API parameter; the flag is `--name` with
    /// `-` for `_`).
    pub name: &'static str,
    /// One line for documentation and `--help`.
    pub doc: &'static str,
    /// What it holds.
    pub kind: Kind,
    /// Its default; [`Value::Unset`] for one the operator measures when not
    /// given.
    pub default: Value,
}

impl Param {
    /// `v` checked against the kind and range; the error names the
    /// parameter.
    pub fn accept(&self, v: Value) -> Result<Value, String> {
        let name = self.name;
        match (self.kind, v) {
            (Kind::Number(r) | Kind::NumberOrAuto(r), Value::Number(x)) => {
                if r.contains(x) {
                    Ok(v)
                } else {
                    Err(format!(
                        "{name}: must be {}, got {}",
                        r.describe(),
                        number_words(x)
                    ))
                }
            }
            (Kind::NumberOrAuto(_), Value::Auto) => Ok(v),
            (Kind::Flag, Value::Flag(_)) => Ok(v),
            (Kind::Word(words), Value::Word(w)) if words.contains(&w) => Ok(v),
            _ => Err(format!("{name}: expected {}, got {v}", self.expected())),
        }
    }

    /// What the parameter takes, in words.
    pub fn expected(&self) -> String {
        match self.kind {
            Kind::Number(r) => r.describe(),
            Kind::NumberOrAuto(r) => format!("{} or \"auto\"", r.describe()),
            Kind::Flag => "true or false".to_owned(),
            Kind::Word(words) => format!("one of {}", words.join(", ")),
        }
    }

    /// The value a flag's or a query's text gives, checked.
    pub fn parse(&self, text: &str) -> Result<Value, String> {
        let t = text.trim();
        let v = match self.kind {
            Kind::NumberOrAuto(_) if t == "auto" => Value::Auto,
            Kind::Number(_) | Kind::NumberOrAuto(_) => match t.parse::<f64>() {
                Ok(x) => Value::Number(x),
                Err(_) => {
                    return Err(format!(
                        "{}: expected {}, got {:?}",
                        self.name,
                        self.expected(),
                        clipped(text)
                    ))
                }
            },
            Kind::Flag => match t {
                "true" | "1" => Value::Flag(true),
                "false" | "0" => Value::Flag(false),
                _ => {
                    return Err(format!(
                        "{}: expected true or false, got {:?}",
                        self.name,
                        clipped(text)
                    ))
                }
            },
            Kind::Word(words) => match words.iter().find(|w| **w == t) {
                Some(w) => Value::Word(w),
                None => {
                    return Err(format!(
                        "{}: expected {}, got {:?}",
                        self.name,
                        self.expected(),
                        clipped(text)
                    ))
                }
            },
        };
        self.accept(v)
    }

    pub(super) fn read_raw(&self, raw: &Raw) -> Result<Value, String> {
        match raw {
            Raw::Number(x) => self.accept(Value::Number(*x)),
            Raw::Bool(b) => self.accept(Value::Flag(*b)),
            Raw::Text(t) => self.parse_text_value(t),
        }
    }

    /// A string in a scene file: "auto" or a word (a number must be written
    /// as a number).
    fn parse_text_value(&self, t: &str) -> Result<Value, String> {
        match self.kind {
            Kind::NumberOrAuto(_) if t == "auto" => Ok(Value::Auto),
            Kind::Word(_) => self.parse(t),
            _ => Err(format!(
                "{}: expected {}, got {:?}",
                self.name,
                self.expected(),
                clipped(t)
            )),
        }
    }
}

/// Every parameter of an operator with its value, in the definition's
/// order.
#[derive(Clone, Debug, PartialEq)]
pub struct Values(Vec<(&'static str, Value)>);

impl Values {
    pub(super) fn new(v: Vec<(&'static str, Value)>) -> Values {
        Values(v)
    }

    /// The parameters and their values.
    pub fn iter(&self) -> impl Iterator<Item = &(&'static str, Value)> {
        self.0.iter()
    }

    /// The value of parameter `name` ([`Value::Unset`] for a name the
    /// operator lacks).
    pub fn get(&self, name: &str) -> Value {
        self.0
            .iter()
            .find(|(n, _)| *n == name)
            .map(|(_, v)| *v)
            .unwrap_or(Value::Unset)
    }

    /// A number's value, `None` when unset or "auto".
    pub fn number(&self, name: &str) -> Option<f64> {
        match self.get(name) {
            Value::Number(v) => Some(v),
            _ => None,
        }
    }

    /// A number that has a default, so is always set (0 if the definition
    /// lacks it).
    pub fn num(&self, name: &str) -> f64 {
        self.number(name).unwrap_or(0.0)
    }

    /// Whether the parameter is "auto".
    pub fn is_auto(&self, name: &str) -> bool {
        self.get(name) == Value::Auto
    }

    /// A flag's value (false when unset).
    pub fn flag(&self, name: &str) -> bool {
        self.get(name) == Value::Flag(true)
    }

    /// A word's value ("" when unset).
    pub fn word(&self, name: &str) -> &'static str {
        match self.get(name) {
            Value::Word(w) => w,
            _ => "",
        }
    }
}

/// A value as a scene file (TOML or JSON) holds it, before it is checked.
pub(super) enum Raw {
    Number(f64),
    Bool(bool),
    Text(String),
}
