//! The history's storage engines behind one small interface: SQL text with
//! `$1`-style parameters in, rows of plain values out. Every query of the
//! history is written once against it, so SQLite (the embedded default) and
//! PostgreSQL (a fleet's shared history) run the same statements; the few
//! places the dialects differ (the schema's column types, where insertion
//! order lives) are named by [`Dialect`].

use super::HistoryError;

/// A value bound to, or read from, a statement.
///
/// Booleans are stored as integers 0/1 on both engines (the schema is shared),
/// and a NaN is stored as NULL on both: SQLite cannot hold a NaN, and an
/// aggregate over a column must mean the same on both engines.
#[derive(Clone, Debug, PartialEq)]
pub enum Value {
    Null,
    Int(i64),
    Real(f64),
    Text(String),
    Blob(Vec<u8>),
}

impl From<i64> for Value {
    fn from(v: i64) -> Self {
        Value::Int(v)
    }
}
impl From<u32> for Value {
    fn from(v: u32) -> Self {
        Value::Int(v.into())
    }
}
impl From<usize> for Value {
    fn from(v: usize) -> Self {
        Value::Int(i64::try_from(v).unwrap_or(i64::MAX))
    }
}
impl From<bool> for Value {
    fn from(v: bool) -> Self {
        Value::Int(v.into())
    }
}
impl From<f64> for Value {
    fn from(v: f64) -> Self {
        if v.is_nan() {
            Value::Null
        } else {
            Value::Real(v)
        }
    }
}
impl From<&str> for Value {
    fn from(v: &str) -> Self {
        Value::Text(v.to_owned())
    }
}
impl From<&String> for Value {
    fn from(v: &String) -> Self {
        Value::Text(v.clone())
    }
}
impl From<String> for Value {
    fn from(v: String) -> Self {
        Value::Text(v)
    }
}
impl From<&[u8]> for Value {
    fn from(v: &[u8]) -> Self {
        Value::Blob(v.to_vec())
    }
}
impl<T: Into<Value>> From<Option<T>> for Value {
    fn from(v: Option<T>) -> Self {
        v.map_or(Value::Null, Into::into)
    }
}
impl<T: Clone + Into<Value>> From<&Option<T>> for Value {
    fn from(v: &Option<T>) -> Self {
        v.clone().map_or(Value::Null, Into::into)
    }
}

/// The arguments of a statement: `args![run, scene, ...]`.
macro_rules! args {
    ($($v:expr),* $(,)?) => {
        &[$($crate::history::backend::Value::from($v)),*][..]
    };
}
pub(crate) use args;

/// One result row.
#[derive(Clone, Debug)]
pub struct Row(pub Vec<Value>);

impl Row {
    fn at(&self, i: usize) -> Result<&Value, HistoryError> {
        self.0.get(i).ok_or_else(|| {
            HistoryError::Invalid(format!(
                "history row has no column {i} ({} columns)",
                self.0.len()
            ))
        })
    }

    fn wrong(&self, i: usize, want: &str) -> HistoryError {
        HistoryError::Invalid(format!(
            "history column {i}: expected {want}, found {:?}",
            self.0.get(i)
        ))
    }

    pub fn opt_int(&self, i: usize) -> Result<Option<i64>, HistoryError> {
        match self.at(i)? {
            Value::Null => Ok(None),
            Value::Int(v) => Ok(Some(*v)),
            _ => Err(self.wrong(i, "an integer")),
        }
    }

    pub fn int(&self, i: usize) -> Result<i64, HistoryError> {
        self.opt_int(i)?.ok_or_else(|| self.wrong(i, "an integer"))
    }

    pub fn bool(&self, i: usize) -> Result<bool, HistoryError> {
        Ok(self.int(i)? != 0)
    }

    pub fn opt_real(&self, i: usize) -> Result<Option<f64>, HistoryError> {
        match self.at(i)? {
            Value::Null => Ok(None),
            Value::Real(v) => Ok(Some(*v)),
            // SQLite returns an integral REAL aggregate as an integer.
            Value::Int(v) => Ok(Some(*v as f64)),
            _ => Err(self.wrong(i, "a number")),
        }
    }

    pub fn real(&self, i: usize) -> Result<f64, HistoryError> {
        self.opt_real(i)?.ok_or_else(|| self.wrong(i, "a number"))
    }

    pub fn opt_text(&self, i: usize) -> Result<Option<String>, HistoryError> {
        match self.at(i)? {
            Value::Null => Ok(None),
            Value::Text(v) => Ok(Some(v.clone())),
            _ => Err(self.wrong(i, "text")),
        }
    }

    pub fn text(&self, i: usize) -> Result<String, HistoryError> {
        self.opt_text(i)?.ok_or_else(|| self.wrong(i, "text"))
    }

    pub fn blob(&self, i: usize) -> Result<Vec<u8>, HistoryError> {
        match self.at(i)? {
            Value::Blob(v) => Ok(v.clone()),
            _ => Err(self.wrong(i, "bytes")),
        }
    }

    /// A stored word (`RunKind`, `RunStatus`).
    pub fn word<T: super::StoredWord>(&self, i: usize) -> Result<T, HistoryError> {
        let text = self.text(i)?;
        T::parse(&text).ok_or_else(|| {
            HistoryError::Invalid(format!("history column {i}: unknown {} {text:?}", T::WHAT))
        })
    }
}

/// Which SQL dialect an engine speaks, for the few statements that differ.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Dialect {
    Sqlite,
    Postgres,
}

impl Dialect {
    /// The column that orders a table's rows as they were inserted: SQLite's
    /// implicit `rowid`, and on PostgreSQL an identity column `seq` that its
    /// schema adds to the tables read in insertion order.
    pub fn insertion_order(self) -> &'static str {
        match self {
            Dialect::Sqlite => "rowid",
            Dialect::Postgres => "seq",
        }
    }

    /// What makes a claim's inner SELECT pass over rows another transaction
    /// holds: PostgreSQL's row locks. SQLite has one writer at a time, so
    /// the claim statement is already atomic there.
    pub fn skip_locked(self) -> &'static str {
        match self {
            Dialect::Sqlite => "",
            Dialect::Postgres => " FOR UPDATE SKIP LOCKED",
        }
    }
}

/// Running statements: an open connection or a transaction on one.
pub trait Sql {
    /// Runs a statement; returns how many rows it changed.
    fn execute(&self, sql: &str, args: &[Value]) -> Result<u64, HistoryError>;
    /// Runs a query; returns every row.
    fn query(&self, sql: &str, args: &[Value]) -> Result<Vec<Row>, HistoryError>;

    /// The first row, if any.
    fn query_opt(&self, sql: &str, args: &[Value]) -> Result<Option<Row>, HistoryError> {
        Ok(self.query(sql, args)?.into_iter().next())
    }
}

/// A storage engine the history runs on.
pub trait Backend: Sql + Send {
    fn dialect(&self) -> Dialect;
    /// Runs `f` in one transaction, committed when it returns Ok and rolled
    /// back otherwise.
    fn transaction(
        &self,
        f: &mut dyn FnMut(&dyn Sql) -> Result<(), HistoryError>,
    ) -> Result<(), HistoryError>;
    /// How many migrations the database has applied.
    fn schema_version(&self) -> Result<i64, HistoryError>;
    /// Applies the migrations after the database's version, each with its
    /// version bump in one transaction; refuses a newer schema.
    fn migrate(&self, migrations: &[&str]) -> Result<(), HistoryError>;
    /// The engine's own consistency check: "ok" when sound.
    fn integrity(&self) -> Result<String, HistoryError>;
}

/// Rewrites `$N` parameters as `?N` (SQLite numbers `$N` by first appearance,
/// not by N) outside quoted text.
pub fn numbered_for_sqlite(sql: &str) -> String {
    let mut out = String::with_capacity(sql.len());
    let mut quoted = false;
    let mut chars = sql.chars().peekable();
    while let Some(c) = chars.next() {
        if c == '\'' {
            quoted = !quoted;
        }
        if c == '$' && !quoted && chars.peek().is_some_and(char::is_ascii_digit) {
            out.push('?');
        } else {
            out.push(c);
        }
    }
    out
}

#[cfg(feature = "postgres")]
/// The shared schema's DDL in PostgreSQL's types: 64-bit integers (the
/// history binds every integer as one), double precision for REAL, and an
/// identity column for the runs' INTEGER PRIMARY KEY. Word by word, outside
/// quoted text.
pub fn ddl_for_postgres(sql: &str) -> String {
    let sql = sql.replace(
        "INTEGER PRIMARY KEY",
        "BIGINT GENERATED BY DEFAULT AS IDENTITY PRIMARY KEY",
    );
    let mut out = String::with_capacity(sql.len() + 64);
    let mut word = String::new();
    let mut quoted = false;
    let flush = |word: &mut String, out: &mut String| {
        out.push_str(match word.as_str() {
            "INTEGER" => "BIGINT",
            "REAL" => "DOUBLE PRECISION",
            "BLOB" => "BYTEA",
            w => w,
        });
        word.clear();
    };
    for c in sql.chars() {
        if !quoted && (c.is_ascii_alphanumeric() || c == '_') {
            word.push(c);
            continue;
        }
        flush(&mut word, &mut out);
        if c == '\'' {
            quoted = !quoted;
        }
        out.push(c);
    }
    flush(&mut word, &mut out);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parameters_are_numbered_for_sqlite_outside_quotes() {
        assert_eq!(
            numbered_for_sqlite("SELECT $7, '$1', $1 || 'a$2' FROM t WHERE x = $10"),
            "SELECT ?7, '$1', ?1 || 'a$2' FROM t WHERE x = ?10"
        );
    }

    #[cfg(feature = "postgres")]
    #[test]
    fn ddl_types_map_to_postgres_whole_words_only() {
        let pg = ddl_for_postgres(
            "CREATE TABLE runs (id INTEGER PRIMARY KEY, n INTEGER NOT NULL, x REAL, \
             real_name TEXT CHECK (real_name IN ('REAL', 'INTEGER')), INTEGERS REAL)",
        );
        assert_eq!(
            pg,
            "CREATE TABLE runs (id BIGINT GENERATED BY DEFAULT AS IDENTITY PRIMARY KEY, \
             n BIGINT NOT NULL, x DOUBLE PRECISION, \
             real_name TEXT CHECK (real_name IN ('REAL', 'INTEGER')), INTEGERS DOUBLE PRECISION)"
        );
    }

    #[test]
    fn nan_is_stored_as_null_and_rows_convert() {
        assert_eq!(Value::from(f64::NAN), Value::Null);
        assert_eq!(Value::from(Some(2.5)), Value::Real(2.5));
        assert_eq!(Value::from(None::<&str>), Value::Null);
        assert_eq!(Value::from(true), Value::Int(1));
        let r = Row(vec![Value::Int(3), Value::Null, Value::Text("a".into())]);
        assert_eq!(r.real(0).unwrap(), 3.0);
        assert!(r.bool(0).unwrap());
        assert_eq!(r.opt_real(1).unwrap(), None);
        assert!(r.int(1).is_err());
        assert!(r.int(2).is_err());
        assert!(r.text(3).is_err());
    }
}
