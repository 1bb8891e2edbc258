//! JSON for values that may be infinite (PSNR and SNR of identical images).
//!
//! serde_json writes non-finite floats as `null`, which would turn "perfect"
//! into "missing". The JSON grammar has no infinity token, but it does allow
//! any exponent, so +∞ is written as the number literal `1e999` (and −∞ as
//! `-1e999`): it is valid JSON, overflows to ±Infinity in JavaScript's
//! `JSON.parse` and Python's `json.loads`, and reads back here as ±∞.
//!
//! The literal goes out through serde_json's `RawValue`, so it only works with
//! serde_json's text serializers (`to_string`, `to_writer`, the pretty
//! variants). `serde_json::to_value` and `from_str::<serde_json::Value>`
//! refuse an out-of-range number; read such a report with this module (as
//! `Metrics` does) or with a parser that overflows to infinity. Finite values
//! are written exactly as serde_json would write them.

use serde::de::Error as _;
use serde::ser::Error as _;
use serde::{Deserialize, Deserializer, Serialize, Serializer};
use serde_json::value::RawValue;

/// The literal written for +∞.
pub const JSON_INFINITY: &str = "1e999";
/// The literal written for −∞.
pub const JSON_NEG_INFINITY: &str = "-1e999";

/// `#[serde(with = "...")]` helper: finite as usual, ±∞ as ±`1e999`.
pub mod extended_f64 {
    use super::*;

    pub fn serialize<S: Serializer>(value: &f64, serializer: S) -> Result<S::Ok, S::Error> {
        let literal = if value.is_finite() || value.is_nan() {
            // NaN falls through to serde_json's `null`; the metrics never
            // produce it, and no literal would be honest about it.
            return serializer.serialize_f64(*value);
        } else if *value > 0.0 {
            JSON_INFINITY
        } else {
            JSON_NEG_INFINITY
        };
        RawValue::from_string(literal.to_owned())
            .map_err(S::Error::custom)?
            .serialize(serializer)
    }

    /// Reads any JSON number, including the out-of-range literals, which
    /// overflow to ±∞ the way every IEEE parser rounds them.
    pub fn deserialize<'de, D: Deserializer<'de>>(deserializer: D) -> Result<f64, D::Error> {
        let raw = Box::<RawValue>::deserialize(deserializer)?;
        let text = raw.get().trim();
        // Rust's parser also takes "inf" and "NaN"; `RawValue` has already
        // checked the JSON grammar, which rules those out.
        text.parse::<f64>()
            .map_err(|e| D::Error::custom(format!("expected a JSON number, got {text}: {e}")))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Debug, PartialEq, Serialize, Deserialize)]
    struct Wrapped {
        #[serde(with = "extended_f64")]
        v: f64,
    }

    fn round_trip(v: f64) -> (String, f64) {
        let text = serde_json::to_string(&Wrapped { v }).unwrap();
        let back: Wrapped = serde_json::from_str(&text).unwrap();
        (text, back.v)
    }

    #[test]
    fn infinities_are_number_literals_that_read_back() {
        assert_eq!(
            round_trip(f64::INFINITY),
            (r#"{"v":1e999}"#.into(), f64::INFINITY)
        );
        assert_eq!(
            round_trip(f64::NEG_INFINITY),
            (r#"{"v":-1e999}"#.into(), f64::NEG_INFINITY)
        );
    }

    #[test]
    fn finite_values_are_written_as_serde_json_writes_them() {
        for v in [0.0, 48.130_803_608_679_1, -3.5, 1e300] {
            let (text, back) = round_trip(v);
            assert_eq!(
                text,
                format!("{{\"v\":{}}}", serde_json::to_string(&v).unwrap())
            );
            assert_eq!(back, v);
        }
    }

    #[test]
    fn pretty_printing_keeps_the_literal() {
        let text = serde_json::to_string_pretty(&Wrapped { v: f64::INFINITY }).unwrap();
        assert!(text.contains("\"v\": 1e999"), "{text}");
    }

    #[test]
    fn non_numbers_are_refused() {
        assert!(serde_json::from_str::<Wrapped>(r#"{"v":"inf"}"#).is_err());
        assert!(serde_json::from_str::<Wrapped>(r#"{"v":null}"#).is_err());
    }
}
