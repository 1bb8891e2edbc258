//! How a history's address is shown: whether it is a PostgreSQL address at
//! all, without its password (errors, the console), and without its host
//! (what anyone reading the API may see).

/// Whether `db` names a PostgreSQL database rather than a SQLite file.
pub fn is_url(db: &str) -> bool {
    db.starts_with("postgres://") || db.starts_with("postgresql://")
}

/// The address as errors and the console show it: without a password.
pub fn redacted(url: &str) -> String {
    let Some((scheme, rest)) = url.split_once("://") else {
        return url.to_owned();
    };
    match rest.split_once('@') {
        Some((user, host)) if user.contains(':') => {
            let name = user.split(':').next().unwrap_or("");
            format!("{scheme}://{name}:***@{host}")
        }
        _ => url.to_owned(),
    }
}

/// A PostgreSQL address as an answer to anyone may show it: the scheme and
/// the database's name, without user, password, host or port
/// (`postgres://…/fleet`); anything else as it is.
pub fn without_host(url: &str) -> String {
    let Some((scheme, rest)) = url.split_once("://") else {
        return url.to_owned();
    };
    let name = rest
        .split_once('/')
        .map(|(_, db)| db.split('?').next().unwrap_or(""))
        .unwrap_or("");
    format!("{scheme}://…/{name}")
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_address_for_anyone_names_no_host() {
        assert_eq!(
            without_host("postgres://ci:secret@db.internal:5432/fleet?sslmode=require"),
            "postgres://…/fleet"
        );
        assert_eq!(
            without_host("/var/lib/tonegate/h.sqlite"),
            "/var/lib/tonegate/h.sqlite"
        );
    }
}
