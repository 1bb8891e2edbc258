//! An operator's parameters as text, by name, as the `tonemap` flags and
//! the API's query give them: one flag per parameter any operator takes,
//! made from the operators' definitions.

use crate::operators;
use serde::Serialize;

/// An operator's parameters as text, by name, in the order given.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct OperatorParams(pub Vec<(String, String)>);

impl OperatorParams {
    /// Parameter `name` set to `value` (as a flag or query would give it).
    pub fn set(&mut self, name: &str, value: impl ToString) {
        self.0.retain(|(n, _)| n != name);
        self.0.push((name.to_owned(), value.to_string()));
    }

    /// Whether `name` is the name of some operator's parameter.
    pub fn takes(name: &str) -> bool {
        operators::all_params().iter().any(|(p, _)| p.name == name)
    }
}

impl Serialize for OperatorParams {
    fn serialize<S: serde::Serializer>(&self, s: S) -> std::result::Result<S::Ok, S::Error> {
        use serde::ser::SerializeMap;
        let mut m = s.serialize_map(Some(self.0.len()))?;
        // As the value it stands for: a number as a number, a flag as a
        // bool, a word (or "auto") as text.
        for (n, v) in &self.0 {
            let t = v.trim();
            match (t.parse::<f64>(), t) {
                (Ok(x), _) if x.is_finite() => m.serialize_entry(n, &x)?,
                (_, "true") => m.serialize_entry(n, &true)?,
                (_, "false") => m.serialize_entry(n, &false)?,
                _ => m.serialize_entry(n, v)?,
            }
        }
        m.end()
    }
}

/// One flag per parameter any operator takes, from the operators'
/// definitions (`--white-fraction` for `white_fraction`), with the
/// operators that take it and its range in the help.
#[cfg(feature = "cli")]
impl clap::FromArgMatches for OperatorParams {
    fn from_arg_matches(m: &clap::ArgMatches) -> std::result::Result<Self, clap::Error> {
        let mut out = OperatorParams::default();
        for (p, _) in operators::all_params() {
            if let Ok(Some(v)) = m.try_get_one::<String>(p.name) {
                out.0.push((p.name.to_owned(), v.clone()));
            }
        }
        Ok(out)
    }
    fn update_from_arg_matches(
        &mut self,
        m: &clap::ArgMatches,
    ) -> std::result::Result<(), clap::Error> {
        *self = Self::from_arg_matches(m)?;
        Ok(())
    }
}

#[cfg(feature = "cli")]
impl clap::Args for OperatorParams {
    fn augment_args(cmd: clap::Command) -> clap::Command {
        let mut cmd = cmd;
        for (p, by) in operators::all_params() {
            let long: &'static str = Box::leak(p.name.replace('_', "-").into_boxed_str());
            let help = format!(
                "{} ({}; {}): {}",
                p.name,
                by.join(", "),
                p.expected(),
                p.doc
            );
            cmd = cmd.arg(
                clap::Arg::new(p.name)
                    .long(long)
                    .value_name("VALUE")
                    .help(help)
                    .help_heading("Operator parameters"),
            );
        }
        cmd
    }
    fn augment_args_for_update(cmd: clap::Command) -> clap::Command {
        Self::augment_args(cmd)
    }
}
