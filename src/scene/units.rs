//! The checked number types of the schema. Each refuses an out-of-range
//! value in `try_from`, so the TOML parser reports it with its key and line,
//! exactly like a typo.

use serde::{Deserialize, Serialize};

/// A number type whose every value satisfies a rule, checked on the way in.
/// `$what` completes "must be …" in the error; `$ts` names `$t` for serde.
macro_rules! checked_number {
    ($(#[$doc:meta])* $name:ident($t:ty as $ts:literal), $ok:expr, $what:literal) => {
        $(#[$doc])*
        #[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
        #[serde(try_from = $ts, into = $ts)]
        pub struct $name(pub(super) $t);

        impl TryFrom<$t> for $name {
            type Error = String;
            fn try_from(v: $t) -> Result<Self, String> {
                let ok: fn($t) -> bool = $ok;
                if ok(v) {
                    Ok(Self(v))
                } else {
                    Err(format!(concat!("must be ", $what, ", got {}"), v))
                }
            }
        }

        impl From<$name> for $t {
            fn from(v: $name) -> $t {
                v.0
            }
        }

        impl $name {
            pub fn get(self) -> $t {
                self.0
            }
        }
    };
}

checked_number!(
    /// A positive, finite number.
    Positive(f64 as "f64"),
    |v| v.is_finite() && v > 0.0,
    "a finite number > 0"
);
checked_number!(
    /// A finite number ≥ 0.
    NonNegative(f64 as "f64"),
    |v| v.is_finite() && v >= 0.0,
    "a finite number >= 0"
);
checked_number!(
    /// Bloom downsample factor, 2..=8.
    Factor(u32 as "u32"),
    |v| (2..=8).contains(&v),
    "between 2 and 8"
);
checked_number!(
    /// Gaussian radius in pixels, 1..=64.
    Radius(u32 as "u32"),
    |v| (1..=64).contains(&v),
    "between 1 and 64"
);

checked_number!(
    /// A number in [0, 1].
    Unit(f64 as "f64"),
    |v| (0.0..=1.0).contains(&v),
    "between 0 and 1"
);
checked_number!(
    /// A current-frame weight in (0, 1]: 0 would never take a new sample.
    Weight(f64 as "f64"),
    |v| v > 0.0 && v <= 1.0,
    "in (0, 1]"
);
checked_number!(
    /// A history weight in [0, 1): 1 would never take a new sample.
    Feedback(f64 as "f64"),
    |v| (0.0..1.0).contains(&v),
    "in [0, 1)"
);

/// Largest output frame a scene may ask for (both renderers allocate it).
pub const MAX_OUTPUT_PIXELS: u64 = 64 * 1024 * 1024;

/// A width×height pair, written `[w, h]`; both ≥ 1 and the product bounded.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Serialize, Deserialize)]
#[serde(try_from = "[u32; 2]", into = "[u32; 2]")]
pub struct Size {
    pub width: u32,
    pub height: u32,
}

impl TryFrom<[u32; 2]> for Size {
    type Error = String;
    fn try_from([width, height]: [u32; 2]) -> Result<Self, String> {
        if width == 0 || height == 0 {
            return Err(format!("size must be at least 1x1, got {width}x{height}"));
        }
        if width as u64 * height as u64 > MAX_OUTPUT_PIXELS {
            return Err(format!(
                "size {width}x{height} exceeds the limit of {MAX_OUTPUT_PIXELS} pixels"
            ));
        }
        Ok(Self { width, height })
    }
}

impl From<Size> for [u32; 2] {
    fn from(s: Size) -> [u32; 2] {
        [s.width, s.height]
    }
}

impl std::fmt::Display for Size {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        write!(f, "{}x{}", self.width, self.height)
    }
}

impl std::str::FromStr for Size {
    type Err = String;
    fn from_str(s: &str) -> Result<Self, String> {
        let (w, h) = s
            .split_once(['x', 'X'])
            .ok_or_else(|| format!("expected WxH, got {s:?}"))?;
        let parse = |t: &str| {
            t.trim()
                .parse::<u32>()
                .map_err(|_| format!("expected WxH with whole numbers, got {s:?}"))
        };
        Size::try_from([parse(w)?, parse(h)?])
    }
}
