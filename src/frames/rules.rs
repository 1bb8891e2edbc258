//! The rules a user keeps beside their frames (docs/frames.md#rules): for
//! tests whose names match a pattern, how far a frame may be from a positive
//! digest and still pass, in the check vocabulary, and what an untriaged
//! digest does.

pub use super::pixels::{AlphaRule, Colour, Mask, DEFAULT_ALPHA, MAX_MASKS};
use crate::check::spec::{Check, CheckSpec};
use serde::Deserialize;
use std::path::Path;

/// What an untriaged digest does to its submission.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Untriaged {
    /// Fails it (exit 1) until someone marks the digest.
    #[default]
    Fail,
    /// Passes it, with a warning in the report.
    Warn,
    /// Passes it with a warning when its test is new (no digest of the
    /// test was ever marked positive or negative), and fails it otherwise:
    /// new tests come in, changed ones are stopped.
    AcceptNew,
}

/// What a test that vanished does to its submission: one the last
/// submission of the same trace (the same keys but `commit`) on the same
/// branch had, and this one has not.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Deserialize, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Vanished {
    /// Listed in the report, and the submission passes.
    #[default]
    Warn,
    /// Fails it (exit 1).
    Fail,
}

/// The most `[[tests]]` rules a file may hold: each frame is matched
/// against them in turn.
pub const MAX_RULES: usize = 256;

pub use crate::history::MAX_PATTERN_CHARS;

/// The rules file.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Rules {
    #[serde(default)]
    pub untriaged: Untriaged,
    /// What a test that vanished from the folder does.
    #[serde(default)]
    pub vanished: Vanished,
    /// The branch whose triage every other branch falls back to (a
    /// submission's `branch` key; one without it is on this branch).
    #[serde(default = "main_branch")]
    pub main_branch: String,
    /// The first whose pattern matches a test applies to it.
    #[serde(default)]
    pub tests: Vec<TestRule>,
}

fn main_branch() -> String {
    "main".into()
}

impl Default for Rules {
    fn default() -> Rules {
        Rules {
            untriaged: Untriaged::default(),
            vanished: Vanished::default(),
            main_branch: main_branch(),
            tests: Vec::new(),
        }
    }
}

/// The thresholds of the tests a pattern matches.
#[derive(Clone, Debug, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct TestRule {
    /// A test name, where `*` stands for any characters but `/` and `**`
    /// for any characters at all.
    pub pattern: String,
    /// The rule applies only to submissions with every one of these keys
    /// (`{ backend = "dx12" }`: a looser bound for one backend, written
    /// before the general rule, since the first that matches applies).
    #[serde(default)]
    pub keys: std::collections::BTreeMap<String, String>,
    /// Checks of an 8-bit or PQ PNG against a positive (the checks a
    /// scene's `[[checks]]` has for one frame against its golden), each
    /// with the `adapter` it is for, if any: a substring of the
    /// submission's `adapter` key, any case, which overrides a bound of the
    /// same kind for every adapter (as in a scene).
    #[serde(default)]
    pub checks: Vec<CheckSpec>,
    /// Bounds for an HDR file (EXR, Radiance, PFM) against a positive.
    #[serde(default)]
    pub hdr: HdrBounds,
    /// What a PNG's alpha channel means for these tests: its colour
    /// composited `over` the background (the default), or `ignore`d (the
    /// colour channels as stored). Either way the frame and its positives
    /// are read alike.
    #[serde(default)]
    pub alpha: AlphaRule,
    /// The colour under a frame with alpha, `"#rrggbb"` in the frame's own
    /// codes: black unless given.
    #[serde(default)]
    pub background: Option<Colour>,
    /// Regions left out of the comparison (a clock, a cursor, a video).
    #[serde(default)]
    pub masks: Vec<Mask>,
}

impl TestRule {
    /// How the frames of its tests read their alpha channel.
    pub fn alpha(&self) -> crate::io::Alpha {
        match self.alpha {
            AlphaRule::Over => crate::io::Alpha::Over(self.background.map_or([0; 3], |c| c.0)),
            AlphaRule::Ignore => crate::io::Alpha::Ignore,
        }
    }
}

/// How a frame under `rule` (none: no rule covers its test) reads its
/// alpha channel.
pub fn alpha_of(rule: Option<&TestRule>) -> crate::io::Alpha {
    rule.map_or(DEFAULT_ALPHA, TestRule::alpha)
}

/// How far an HDR file may be from a positive (docs/hdr-metrics.md's
/// figures), each bound only when given.
#[derive(Clone, Debug, Default, PartialEq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct HdrBounds {
    pub max_hdr_flip_mean: Option<f64>,
    pub min_pu21_psnr: Option<f64>,
    pub max_delta_e_itp_mean: Option<f64>,
}

impl HdrBounds {
    pub fn is_empty(&self) -> bool {
        *self == HdrBounds::default()
    }
}

impl Rules {
    /// Reads and checks a rules file; every error names the file, and the
    /// rule and key it is about.
    pub fn load(path: &Path) -> Result<Rules, String> {
        let text = crate::io::read_small_text(path)
            .map_err(|e| format!("reading {}: {e}", path.display()))?;
        Rules::parse(&text, &path.display().to_string())
    }

    /// Parses and checks a rules file's text; `name` says where it came
    /// from in errors.
    pub fn parse(text: &str, name: &str) -> Result<Rules, String> {
        let rules: Rules = toml::from_str(text)
            .map_err(|e| format!("{name}: {}", crate::io::toml_error(text, &e)))?;
        rules.check().map_err(|(i, e)| {
            match i.and_then(|i| crate::io::nth_line_starting(text, "[[tests]]", i)) {
                Some(line) => format!("{name}: line {line}: {e}"),
                None => format!("{name}: {e}"),
            }
        })?;
        Ok(rules)
    }

    /// Each rule checked; an error says which rule (its index) and why.
    fn check(&self) -> Result<(), (Option<usize>, String)> {
        if self.tests.len() > MAX_RULES {
            return Err((
                None,
                format!("{} [[tests]] rules: at most {MAX_RULES}", self.tests.len()),
            ));
        }
        for (i, rule) in self.tests.iter().enumerate() {
            Rules::check_rule(i, rule).map_err(|e| (Some(i), e))?;
        }
        Ok(())
    }

    fn check_rule(i: usize, rule: &TestRule) -> Result<(), String> {
        let chars = rule.pattern.chars().count();
        if chars > MAX_PATTERN_CHARS {
            return Err(format!(
                "tests[{i}]: a pattern of {chars} characters: at most {MAX_PATTERN_CHARS}"
            ));
        }
        let at = format!("tests[{i}] ({:?})", rule.pattern);
        if rule.pattern.is_empty() {
            return Err(format!("{at}: an empty pattern"));
        }
        if rule.masks.len() > MAX_MASKS {
            return Err(format!(
                "{at}: {} masks: at most {MAX_MASKS}",
                rule.masks.len()
            ));
        }
        if let Some(m) = rule.masks.iter().find(|m| m.width == 0 || m.height == 0) {
            return Err(format!(
                "{at}: a mask of {}x{} pixels covers nothing",
                m.width, m.height
            ));
        }
        if rule.alpha == AlphaRule::Ignore && rule.background.is_some() {
            return Err(format!(
                "{at}: a background with alpha = \"ignore\": the background is what alpha = \"over\" composites over"
            ));
        }
        for spec in &rule.checks {
            let c = &spec.check;
            if !spec.options.is_empty() || spec.spp.is_some() {
                return Err(format!(
                    "{at}: {}: options and spp are about tonegate's own renders; a frames rule is chosen by the submission's keys",
                    c.rule().kind
                ));
            }
            if !one_frame(c) {
                return Err(format!(
                    "{at}: {} is not a check of a frame against another",
                    c.rule().kind
                ));
            }
            let bound = c.rule().bound;
            if !bound.is_finite() || bound < 0.0 {
                return Err(format!(
                    "{at}: {} must be a finite number >= 0",
                    c.rule().kind
                ));
            }
        }
        let h = &rule.hdr;
        for (key, v) in [
            ("max_hdr_flip_mean", h.max_hdr_flip_mean),
            ("min_pu21_psnr", h.min_pu21_psnr),
            ("max_delta_e_itp_mean", h.max_delta_e_itp_mean),
        ] {
            if v.is_some_and(|v| !v.is_finite() || v < 0.0) {
                return Err(format!("{at}: hdr.{key} must be a finite number >= 0"));
            }
        }
        Ok(())
    }

    /// The rule for `test` in a submission with `keys`: the first whose
    /// pattern matches the test and whose keys the submission has.
    pub fn for_test(
        &self,
        test: &str,
        keys: &std::collections::BTreeMap<String, String>,
    ) -> Option<&TestRule> {
        self.tests.iter().find(|r| {
            matches(&r.pattern, test) && r.keys.iter().all(|(k, v)| keys.get(k) == Some(v))
        })
    }
}

/// Whether `c` bounds one frame against another (the rest are about a
/// sequence, a stage's time or another scene).
fn one_frame(c: &Check) -> bool {
    matches!(
        c,
        Check::MinPsnr(_)
            | Check::MinSsim(_)
            | Check::MaxMse(_)
            | Check::MaxAbsDiff(_)
            | Check::MaxMeanAbsDiff(_)
            | Check::MaxFractionOver { .. }
            | Check::MaxPixelsOver { .. }
            | Check::MaxFlipMean(_)
            | Check::MaxFlipPercentile { .. }
    )
}

/// Whether `name` matches `pattern` (`*`: any run of characters but `/`;
/// `**`: any run at all), in time linear in each: the pattern is run as a
/// set of positions over the name's characters, never by backtracking (a
/// pattern of many `**` against a long name took minutes that way).
pub fn matches(pattern: &str, name: &str) -> bool {
    #[derive(Clone, Copy, PartialEq)]
    enum Token {
        Char(char),
        /// `*`: any run without `/`.
        Star,
        /// `**`: any run.
        Stars,
    }
    let mut tokens = Vec::with_capacity(pattern.len());
    let mut chars = pattern.chars().peekable();
    while let Some(c) = chars.next() {
        tokens.push(match c {
            '*' if chars.peek() == Some(&'*') => {
                chars.next();
                Token::Stars
            }
            '*' => Token::Star,
            c => Token::Char(c),
        });
    }
    // `at[i]`: the first `i` tokens have matched the name so far. A star
    // matches nothing too, so a position before one reaches past it.
    let close = |at: &mut Vec<bool>| {
        for i in 0..tokens.len() {
            if at[i] && !matches!(tokens[i], Token::Char(_)) {
                at[i + 1] = true;
            }
        }
    };
    let mut at = vec![false; tokens.len() + 1];
    at[0] = true;
    close(&mut at);
    let mut next = vec![false; tokens.len() + 1];
    for c in name.chars() {
        next.iter_mut().for_each(|n| *n = false);
        for (i, token) in tokens.iter().enumerate() {
            if !at[i] {
                continue;
            }
            match *token {
                Token::Char(p) if p == c => next[i + 1] = true,
                Token::Char(_) => {}
                Token::Star if c == '/' => {}
                Token::Star | Token::Stars => next[i] = true,
            }
        }
        close(&mut next);
        if !next.iter().any(|&n| n) {
            return false;
        }
        std::mem::swap(&mut at, &mut next);
    }
    at[tokens.len()]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn patterns_match_within_and_across_folders() {
        assert!(matches("ui/*", "ui/button"));
        assert!(!matches("ui/*", "ui/menu/item"));
        assert!(matches("ui/**", "ui/menu/item"));
        assert!(matches("*-dark", "button-dark"));
        assert!(!matches("*-dark", "button-light"));
        assert!(matches("sky", "sky"));
        assert!(!matches("sky", "skyline"));
        assert!(matches("**", "a/b/c"));
        assert!(matches("a**b*c", "a/x/b-c"));
        assert!(!matches("a**b*c", "a/x/b/c"));
        assert!(matches("**/*", "a/b"));
        assert!(!matches("", "a"));
        assert!(matches("", ""));
        assert!(matches("é*", "été"));
    }

    /// Rules chosen by the submission's keys, first match first: dx12's
    /// own rule before the general one.
    #[test]
    fn a_rule_can_be_chosen_by_the_submissions_keys() {
        let rules = Rules::parse(
            "untriaged = \"accept_new\"\n\
             [[tests]]\npattern = \"**\"\nkeys = { backend = \"dx12\" }\nchecks = [{ max_abs_diff = 8 }]\n\
             [[tests]]\npattern = \"**\"\nchecks = [{ max_abs_diff = 1 }]\n",
            "rules.toml",
        )
        .unwrap();
        assert_eq!(rules.untriaged, Untriaged::AcceptNew);
        let keys =
            |b: &str| std::collections::BTreeMap::from([("backend".to_owned(), b.to_owned())]);
        let bound = |b: &str| {
            rules.for_test("ui/x", &keys(b)).unwrap().checks[0]
                .check
                .rule()
                .bound
        };
        assert_eq!((bound("dx12"), bound("vulkan")), (8.0, 1.0));
        assert_eq!(
            rules.for_test("ui/x", &Default::default()).unwrap().checks[0]
                .check
                .rule()
                .bound,
            1.0
        );
    }

    /// The pattern that backtracking took minutes over (ten `**a`s and a
    /// final `**b`, against a hundred `a`s): matched by positions, it is
    /// answered at once; by backtracking this test would not end.
    #[test]
    fn many_double_stars_against_a_long_name_are_answered() {
        let pattern = "**a".repeat(10) + "**b";
        let name = "a".repeat(100);
        assert!(!matches(&pattern, &name));
        assert!(matches(&pattern, &(name.clone() + "b")));
        assert!(!matches(
            &("*a".repeat(10) + "*b"),
            &("a/".repeat(50) + "b")
        ));
    }

    #[test]
    fn a_rules_file_is_checked_key_by_key() {
        let ok: Rules = toml::from_str(
            r#"
            untriaged = "warn"
            [[tests]]
            pattern = "ui/*"
            checks = [{ max_abs_diff = 1 }, { max_fraction_over = { lsb = 1, fraction = 0.01 } }]
            hdr = { max_hdr_flip_mean = 0.05 }
            "#,
        )
        .unwrap();
        ok.check().unwrap();
        assert_eq!(ok.untriaged, Untriaged::Warn);
        let none = std::collections::BTreeMap::new();
        assert!(ok.for_test("ui/button", &none).is_some() && ok.for_test("menu", &none).is_none());
        let fps: Rules =
            toml::from_str("[[tests]]\npattern = \"a\"\nchecks = [{ min_fps = 30.0 }]").unwrap();
        assert!(fps
            .check()
            .unwrap_err()
            .1
            .contains("min_fps is not a check of a frame"));
        assert!(toml::from_str::<Rules>("[[tests]]\npattern = \"a\"\nbogus = 1").is_err());
        let long = format!(
            "[[tests]]\npattern = \"{}\"",
            "*".repeat(MAX_PATTERN_CHARS + 1)
        );
        let e = Rules::parse(&long, "rules.toml").unwrap_err();
        assert!(
            e.contains("tests[0]: a pattern of 257 characters: at most 256"),
            "{e}"
        );
        // Every error names its line: the rule's, or TOML's own.
        let e = Rules::parse(
            "[[tests]]\npattern = \"a\"\n\n[[tests]]\npattern = \"\"\n",
            "rules.toml",
        )
        .unwrap_err();
        assert!(e.starts_with("rules.toml: line 4: tests[1]"), "{e}");
        let e = Rules::parse("untriaged = \"warn\"\nmain_branch = 3\n", "rules.toml").unwrap_err();
        assert!(e.starts_with("rules.toml: line 2:"), "{e}");
        let many = "[[tests]]\npattern = \"a\"\n".repeat(MAX_RULES + 1);
        let e = Rules::parse(&many, "rules.toml").unwrap_err();
        assert!(e.contains("257 [[tests]] rules: at most 256"), "{e}");
    }
}
