//! [`OperatorError`]: why an operator could not be made with the values
//! given, or could not be registered.

/// Why [`Operator::named`](super::Operator::named) (and `with`,
/// `with_value`, `from_text`) or [`register`](super::register) refused.
/// Each variant names the operator and parameter it is about; the reason a
/// value or a definition was refused is the text a person reads.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
#[non_exhaustive]
pub enum OperatorError {
    /// No operator has this name (or alias).
    #[error("operator: unknown operator {name:?}; expected one of {}", .known.join(", "))]
    UnknownOperator {
        /// The name asked for.
        name: String,
        /// The operators there are.
        known: Vec<&'static str>,
    },
    /// A parameter no operator takes.
    #[error("unknown parameter {parameter:?} for operator {operator}; it takes {}", takes_text(.takes))]
    UnknownParameter {
        /// The operator asked.
        operator: &'static str,
        /// The parameter given.
        parameter: String,
        /// The parameters it takes.
        takes: Vec<&'static str>,
    },
    /// A parameter other operators take, not this one.
    #[error("{parameter}: applies to operator {} only, not {operator}", .takers.join(" and "))]
    NotTaken {
        /// The operator asked.
        operator: &'static str,
        /// The parameter given.
        parameter: String,
        /// The operators that take it.
        takers: Vec<&'static str>,
    },
    /// A value out of its parameter's range, of the wrong type, or text
    /// that does not read as one.
    #[error("{reason}")]
    BadValue {
        /// The operator asked.
        operator: &'static str,
        /// The parameter.
        parameter: String,
        /// What is wrong with the value, naming the parameter.
        reason: String,
    },
    /// The operator's own check refused the values together
    /// ([`ToneOperator::check`](super::ToneOperator::check)).
    #[error("{reason}")]
    Refused {
        /// The operator.
        operator: &'static str,
        /// Its check's words.
        reason: String,
    },
    /// [`register`](super::register): the name is reserved or empty.
    #[error("operator name {name:?} is not allowed")]
    NameNotAllowed {
        /// The name.
        name: &'static str,
    },
    /// [`register`](super::register): another operator has the name.
    #[error("operator {name:?} is taken (by {by})")]
    NameTaken {
        /// The name (or alias).
        name: &'static str,
        /// The operator that has it.
        by: &'static str,
    },
    /// [`register`](super::register): the definition is inconsistent (more
    /// than four resolved values, a parameter's name or default, a
    /// parameter of another kind than another operator's of that name).
    #[error("operator {operator}: {reason}")]
    BadDefinition {
        /// The operator registered.
        operator: &'static str,
        /// What is wrong.
        reason: String,
    },
}

fn takes_text(takes: &[&str]) -> String {
    if takes.is_empty() {
        "none".to_owned()
    } else {
        takes.join(", ")
    }
}
