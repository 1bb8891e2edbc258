//! The embedded engine: one SQLite file in WAL mode.

use super::backend::{numbered_for_sqlite, Backend, Dialect, Row, Sql, Value};
use super::{HistoryError, SCHEMA_VERSION};
use rusqlite::types::{ToSqlOutput, ValueRef};
use rusqlite::Connection;
use std::path::PathBuf;

pub struct Sqlite {
    pub(super) conn: Connection,
    pub(super) path: PathBuf,
}

impl rusqlite::ToSql for Value {
    fn to_sql(&self) -> rusqlite::Result<ToSqlOutput<'_>> {
        Ok(match self {
            Value::Null => ToSqlOutput::Borrowed(ValueRef::Null),
            Value::Int(v) => ToSqlOutput::Borrowed(ValueRef::Integer(*v)),
            Value::Real(v) => ToSqlOutput::Borrowed(ValueRef::Real(*v)),
            Value::Text(v) => ToSqlOutput::Borrowed(ValueRef::Text(v.as_bytes())),
            Value::Blob(v) => ToSqlOutput::Borrowed(ValueRef::Blob(v)),
        })
    }
}

impl Sqlite {
    pub(super) fn err(&self, source: rusqlite::Error) -> HistoryError {
        HistoryError::Sqlite {
            path: self.path.clone(),
            source,
        }
    }
}

fn run_query(conn: &Connection, sql: &str, args: &[Value]) -> rusqlite::Result<Vec<Row>> {
    let mut stmt = conn.prepare_cached(&numbered_for_sqlite(sql))?;
    let n = stmt.column_count();
    let mut rows = stmt.query(rusqlite::params_from_iter(args))?;
    let mut out = Vec::new();
    while let Some(r) = rows.next()? {
        let mut row = Vec::with_capacity(n);
        for i in 0..n {
            row.push(match r.get_ref(i)? {
                ValueRef::Null => Value::Null,
                ValueRef::Integer(v) => Value::Int(v),
                ValueRef::Real(v) => Value::Real(v),
                ValueRef::Text(t) => Value::Text(String::from_utf8_lossy(t).into_owned()),
                ValueRef::Blob(b) => Value::Blob(b.to_vec()),
            });
        }
        out.push(Row(row));
    }
    Ok(out)
}

fn run_execute(conn: &Connection, sql: &str, args: &[Value]) -> rusqlite::Result<u64> {
    let mut stmt = conn.prepare_cached(&numbered_for_sqlite(sql))?;
    Ok(stmt.execute(rusqlite::params_from_iter(args))? as u64)
}

impl Sql for Sqlite {
    fn execute(&self, sql: &str, args: &[Value]) -> Result<u64, HistoryError> {
        run_execute(&self.conn, sql, args).map_err(|e| self.err(e))
    }

    fn query(&self, sql: &str, args: &[Value]) -> Result<Vec<Row>, HistoryError> {
        run_query(&self.conn, sql, args).map_err(|e| self.err(e))
    }
}

/// A transaction: the connection itself, between BEGIN and COMMIT.
struct InTransaction<'a>(&'a Sqlite);

impl Sql for InTransaction<'_> {
    fn execute(&self, sql: &str, args: &[Value]) -> Result<u64, HistoryError> {
        self.0.execute(sql, args)
    }

    fn query(&self, sql: &str, args: &[Value]) -> Result<Vec<Row>, HistoryError> {
        self.0.query(sql, args)
    }
}

/// A transaction that takes the write lock at BEGIN. A deferred one that
/// reads first and writes later cannot wait for another writer: SQLite
/// answers "database is locked" at once (the snapshot it read is stale), so
/// two runners storing artifacts at the same moment would fail. Rolled back
/// when dropped uncommitted (an error or a panic in between).
struct Immediate<'a> {
    db: &'a Sqlite,
    open: bool,
}

impl<'a> Immediate<'a> {
    fn begin(db: &'a Sqlite) -> Result<Immediate<'a>, HistoryError> {
        db.conn
            .execute_batch("BEGIN IMMEDIATE")
            .map_err(|e| db.err(e))?;
        Ok(Immediate { db, open: true })
    }

    fn commit(mut self) -> Result<(), HistoryError> {
        let done = self
            .db
            .conn
            .execute_batch("COMMIT")
            .map_err(|e| self.db.err(e));
        // A COMMIT that failed leaves the transaction open: Drop rolls it back.
        self.open = done.is_err();
        done
    }
}

impl Drop for Immediate<'_> {
    fn drop(&mut self) {
        if self.open {
            let _ = self.db.conn.execute_batch("ROLLBACK");
        }
    }
}

impl Backend for Sqlite {
    fn dialect(&self) -> Dialect {
        Dialect::Sqlite
    }

    fn transaction(
        &self,
        f: &mut dyn FnMut(&dyn Sql) -> Result<(), HistoryError>,
    ) -> Result<(), HistoryError> {
        let tx = Immediate::begin(self)?;
        f(&InTransaction(self))?;
        tx.commit()
    }

    fn schema_version(&self) -> Result<i64, HistoryError> {
        self.conn
            .query_row("PRAGMA user_version", [], |r| r.get(0))
            .map_err(|e| self.err(e))
    }

    fn migrate(&self, migrations: &[&str]) -> Result<(), HistoryError> {
        let version = self.schema_version()?;
        if version > SCHEMA_VERSION {
            return Err(HistoryError::NewerSchema {
                path: self.path.clone(),
                found: version,
                known: SCHEMA_VERSION,
            });
        }
        for (i, sql) in migrations.iter().enumerate().skip(version as usize) {
            // Each migration and its version bump commit together.
            let tx = Immediate::begin(self)?;
            self.conn.execute_batch(sql).map_err(|e| self.err(e))?;
            self.conn
                .pragma_update(None, "user_version", (i + 1) as i64)
                .map_err(|e| self.err(e))?;
            tx.commit()?;
        }
        Ok(())
    }

    fn integrity(&self) -> Result<String, HistoryError> {
        self.conn
            .query_row("PRAGMA integrity_check", [], |r| r.get(0))
            .map_err(|e| self.err(e))
    }
}
