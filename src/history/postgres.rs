//! The shared engine: a PostgreSQL database every runner and the server reach
//! (`--db postgres://…`), through the rust-postgres client (the blocking
//! wrapper of tokio-postgres; the history's callers are synchronous, and the
//! server calls it off its async threads).
//!
//! Connections are kept for reuse: a history dropped returns its connection
//! to a small idle list keyed by address and access, so the API does not
//! connect (and authenticate) once per request.

use super::backend::{ddl_for_postgres, Backend, Dialect, Row, Sql, Value};
use super::reconnect::{connection_lost, Backoff};
use super::{redacted, HistoryError, SCHEMA_VERSION};
use bytes::BytesMut;
use postgres::types::{IsNull, ToSql, Type};
use postgres::{Client, GenericClient, NoTls};
use std::sync::{Mutex, MutexGuard};

/// What went wrong, in the server's own words when it answered: the client's
/// Display says only "db error" for those.
pub fn describe(e: &postgres::Error) -> String {
    match e.as_db_error() {
        Some(db) => {
            let mut s = format!("{} {}: {}", db.severity(), db.code().code(), db.message());
            if let Some(d) = db.detail() {
                s += &format!(" ({d})");
            }
            if let Some(h) = db.hint() {
                s += &format!("; hint: {h}");
            }
            s
        }
        None => match std::error::Error::source(e) {
            Some(cause) => format!("{e}: {cause}"),
            None => e.to_string(),
        },
    }
}

/// Statements PostgreSQL needs beside a shared migration: the identity
/// column that keeps insertion order (SQLite's rowid) where it is read.
fn postgres_extra(version: usize) -> &'static str {
    match version {
        1 => {
            "ALTER TABLE stage_timings ADD COLUMN seq BIGINT GENERATED ALWAYS AS IDENTITY;
             ALTER TABLE tradeoff_points ADD COLUMN seq BIGINT GENERATED ALWAYS AS IDENTITY;"
        }
        _ => "",
    }
}

/// A key no other program is likely to lock: serialises migrations when
/// several runners open a fresh database at once.
const MIGRATION_LOCK: i64 = 0x746f_6e65_6761_7465; // "tonegate"

static IDLE: Mutex<Vec<(String, bool, Client)>> = Mutex::new(Vec::new());
const IDLE_MAX: usize = 16;

fn open_client(url: &str, read_only: bool) -> Result<Client, postgres::Error> {
    let mut c = Client::connect(url, NoTls)?;
    // The history's queries are short index walks. PostgreSQL's JIT
    // compiles any plan whose estimate is high (as a fresh or unanalysed
    // table's estimates are), which cost 7-70 ms a query for ~1 ms of work
    // in benches/history.rs.
    let mut setup = "SET jit = off;".to_owned();
    if read_only {
        setup += "SET default_transaction_read_only = on;";
    }
    c.batch_execute(&setup)?;
    Ok(c)
}

pub struct Postgres {
    client: Mutex<Option<Client>>,
    url: String,
    read_only: bool,
}

impl Postgres {
    /// Connects (reusing an idle connection to the same address when there
    /// is one), retrying within the process's retry budget.
    pub fn connect(url: &str, read_only: bool) -> Result<Postgres, HistoryError> {
        let reused = {
            let mut idle = IDLE.lock().unwrap_or_else(|p| p.into_inner());
            idle.iter()
                .position(|(u, r, c)| u == url && *r == read_only && !c.is_closed())
                .map(|i| idle.swap_remove(i).2)
        };
        let db = Postgres {
            client: Mutex::new(reused),
            url: url.to_owned(),
            read_only,
        };
        // A reused connection is tried by its first statement (and replaced
        // then if the server dropped it); a new one is made here, so an
        // unreachable address is this call's error.
        db.with(|_| Ok(()))?;
        Ok(db)
    }

    fn err(&self, source: postgres::Error) -> HistoryError {
        HistoryError::Postgres {
            url: redacted(&self.url),
            source,
        }
    }

    fn lock(&self) -> Result<MutexGuard<'_, Option<Client>>, HistoryError> {
        self.client
            .lock()
            .map_err(|_| HistoryError::Invalid("history connection poisoned by a panic".into()))
    }

    /// Runs `f` on the connection, made anew when it was lost; a lost
    /// connection (`connection_lost`) is replaced and `f` run again, backing
    /// off, until the retry budget is spent.
    fn with<T>(
        &self,
        mut f: impl FnMut(&mut Client) -> Result<T, postgres::Error>,
    ) -> Result<T, HistoryError> {
        let mut backoff = Backoff::new();
        loop {
            let mut guard = self.lock()?;
            let tried = match guard.as_mut() {
                Some(client) => f(client),
                None => open_client(&self.url, self.read_only).and_then(|mut c| {
                    let out = f(&mut c);
                    *guard = Some(c);
                    out
                }),
            };
            match tried {
                Ok(v) => {
                    backoff.answered();
                    return Ok(v);
                }
                Err(e) if connection_lost(&e) => {
                    *guard = None;
                    drop(guard);
                    tracing::debug!("history database: {}; trying again", describe(&e));
                    if !backoff.wait() {
                        return Err(self.err(e));
                    }
                }
                Err(e) => return Err(self.err(e)),
            }
        }
    }
}

impl Drop for Postgres {
    fn drop(&mut self) {
        let Some(client) = self.client.get_mut().ok().and_then(Option::take) else {
            return;
        };
        if client.is_closed() {
            return;
        }
        let mut idle = IDLE.lock().unwrap_or_else(|p| p.into_inner());
        if idle.len() < IDLE_MAX {
            idle.push((self.url.clone(), self.read_only, client));
        }
    }
}

/// Binds a value as the parameter's own type: PostgreSQL infers each `$N`'s
/// type from the statement, and the history's integers and reals are bound
/// to whatever width the column or expression has there.
impl ToSql for Value {
    fn to_sql(
        &self,
        ty: &Type,
        out: &mut BytesMut,
    ) -> Result<IsNull, Box<dyn std::error::Error + Sync + Send>> {
        match self {
            Value::Null => Ok(IsNull::Yes),
            Value::Int(v) => match *ty {
                Type::INT8 => v.to_sql(ty, out),
                Type::INT4 => i32::try_from(*v)?.to_sql(ty, out),
                Type::INT2 => i16::try_from(*v)?.to_sql(ty, out),
                Type::BOOL => (*v != 0).to_sql(ty, out),
                Type::FLOAT8 => (*v as f64).to_sql(ty, out),
                Type::FLOAT4 => (*v as f32).to_sql(ty, out),
                _ => v.to_string().to_sql(ty, out),
            },
            Value::Real(v) => match *ty {
                Type::FLOAT4 => (*v as f32).to_sql(ty, out),
                _ => v.to_sql(ty, out),
            },
            Value::Text(s) => s.as_str().to_sql(ty, out),
            Value::Blob(b) => b.as_slice().to_sql(ty, out),
        }
    }

    fn accepts(_: &Type) -> bool {
        true
    }

    postgres::types::to_sql_checked!();
}

fn row_of(r: &postgres::Row) -> Result<Row, postgres::Error> {
    let mut out = Vec::with_capacity(r.len());
    for (i, col) in r.columns().iter().enumerate() {
        let v = match *col.type_() {
            Type::INT8 => r.try_get::<_, Option<i64>>(i)?.map(Value::Int),
            Type::INT4 => r
                .try_get::<_, Option<i32>>(i)?
                .map(|v| Value::Int(v.into())),
            Type::INT2 => r
                .try_get::<_, Option<i16>>(i)?
                .map(|v| Value::Int(v.into())),
            Type::BOOL => r.try_get::<_, Option<bool>>(i)?.map(Value::from),
            Type::FLOAT8 => r.try_get::<_, Option<f64>>(i)?.map(Value::from),
            Type::FLOAT4 => r
                .try_get::<_, Option<f32>>(i)?
                .map(|v| Value::from(f64::from(v))),
            Type::BYTEA => r.try_get::<_, Option<Vec<u8>>>(i)?.map(Value::Blob),
            _ => r.try_get::<_, Option<String>>(i)?.map(Value::Text),
        };
        out.push(v.unwrap_or(Value::Null));
    }
    Ok(Row(out))
}

fn params(args: &[Value]) -> Vec<&(dyn ToSql + Sync)> {
    args.iter().map(|a| a as &(dyn ToSql + Sync)).collect()
}

fn run_query(
    c: &mut impl GenericClient,
    sql: &str,
    args: &[Value],
) -> Result<Vec<Row>, postgres::Error> {
    c.query(sql, &params(args))?.iter().map(row_of).collect()
}

impl Sql for Postgres {
    fn execute(&self, sql: &str, args: &[Value]) -> Result<u64, HistoryError> {
        self.with(|c| c.execute(sql, &params(args)))
    }

    fn query(&self, sql: &str, args: &[Value]) -> Result<Vec<Row>, HistoryError> {
        self.with(|c| run_query(c, sql, args))
    }
}

/// A transaction in progress, its statements run one at a time.
struct InTransaction<'a, 'b> {
    tx: std::cell::RefCell<&'a mut postgres::Transaction<'b>>,
    db: &'a Postgres,
}

impl Sql for InTransaction<'_, '_> {
    fn execute(&self, sql: &str, args: &[Value]) -> Result<u64, HistoryError> {
        self.tx
            .borrow_mut()
            .execute(sql, &params(args))
            .map_err(|e| self.db.err(e))
    }

    fn query(&self, sql: &str, args: &[Value]) -> Result<Vec<Row>, HistoryError> {
        run_query(*self.tx.borrow_mut(), sql, args).map_err(|e| self.db.err(e))
    }
}

impl Backend for Postgres {
    fn dialect(&self) -> Dialect {
        Dialect::Postgres
    }

    fn transaction(
        &self,
        f: &mut dyn FnMut(&dyn Sql) -> Result<(), HistoryError>,
    ) -> Result<(), HistoryError> {
        // As `with`, for a transaction: one whose connection was lost was
        // rolled back by the server, and is run again whole on a new one.
        let mut backoff = Backoff::new();
        loop {
            let mut guard = self.lock()?;
            if guard.is_none() {
                match open_client(&self.url, self.read_only) {
                    Ok(c) => *guard = Some(c),
                    Err(e) if connection_lost(&e) => {
                        drop(guard);
                        if !backoff.wait() {
                            return Err(self.err(e));
                        }
                        continue;
                    }
                    Err(e) => return Err(self.err(e)),
                }
            }
            let Some(client) = guard.as_mut() else {
                continue;
            };
            let done = match client.transaction() {
                Ok(mut tx) => f(&InTransaction {
                    tx: std::cell::RefCell::new(&mut tx),
                    db: self,
                })
                .and_then(|()| tx.commit().map_err(|e| self.err(e))),
                Err(e) => Err(self.err(e)),
            };
            match done {
                Ok(()) => {
                    backoff.answered();
                    return Ok(());
                }
                Err(HistoryError::Postgres { source, .. }) if connection_lost(&source) => {
                    *guard = None;
                    drop(guard);
                    tracing::debug!("history database: {}; trying again", describe(&source));
                    if !backoff.wait() {
                        return Err(self.err(source));
                    }
                }
                Err(e) => return Err(e),
            }
        }
    }

    fn schema_version(&self) -> Result<i64, HistoryError> {
        self.with(|c| {
            let exists: Option<String> = c
                .query_one("SELECT to_regclass('tonegate_schema')::text", &[])?
                .get(0);
            if exists.is_none() {
                return Ok(0);
            }
            Ok(c.query_opt("SELECT version FROM tonegate_schema", &[])?
                .map_or(0, |r| r.get(0)))
        })
    }

    fn migrate(&self, migrations: &[&str]) -> Result<(), HistoryError> {
        let newer = self.with(|c| {
            let mut tx = c.transaction()?;
            tx.execute("SELECT pg_advisory_xact_lock($1)", &[&MIGRATION_LOCK])?;
            tx.batch_execute(
                "CREATE TABLE IF NOT EXISTS tonegate_schema (version BIGINT NOT NULL)",
            )?;
            let version: i64 = match tx.query_opt("SELECT version FROM tonegate_schema", &[])? {
                Some(r) => r.get(0),
                None => {
                    tx.execute("INSERT INTO tonegate_schema (version) VALUES (0)", &[])?;
                    0
                }
            };
            if version > SCHEMA_VERSION {
                return Ok(Some(version));
            }
            // PostgreSQL's DDL is transactional: every pending migration and
            // the version commit together, or none does.
            for (i, sql) in migrations.iter().enumerate().skip(version as usize) {
                tx.batch_execute(&ddl_for_postgres(sql))?;
                tx.batch_execute(postgres_extra(i + 1))?;
            }
            tx.execute(
                "UPDATE tonegate_schema SET version = $1",
                &[&(migrations.len() as i64).max(version)],
            )?;
            tx.commit()?;
            Ok(None)
        })?;
        match newer {
            Some(found) => Err(HistoryError::NewerSchema {
                path: redacted(&self.url).into(),
                found,
                known: SCHEMA_VERSION,
            }),
            None => Ok(()),
        }
    }

    fn integrity(&self) -> Result<String, HistoryError> {
        Err(HistoryError::Invalid(format!(
            "{}: an integrity check is SQLite's (PRAGMA integrity_check); PostgreSQL checks its own pages",
            redacted(&self.url)
        )))
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::history::is_url;

    #[test]
    fn passwords_are_not_shown() {
        assert_eq!(
            redacted("postgres://ci:s3cret@db.example:5432/tonegate"),
            "postgres://ci:***@db.example:5432/tonegate"
        );
        assert_eq!(redacted("postgres://ci@db/t"), "postgres://ci@db/t");
        assert!(is_url("postgresql://localhost/t") && !is_url("history.sqlite"));
    }
}
