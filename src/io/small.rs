//! Small files read by name (rules, alerts, tokens, secrets), refused when
//! they are no regular file or too large, and the lines their errors name.

use super::open_regular;
use std::path::Path;

/// The most bytes [`read_small`] reads: rules, alerts, token and secret
/// files are a few kilobytes.
pub const MAX_SMALL_FILE_BYTES: u64 = 1 << 20;

/// Reads a small file named by a flag or a setting (rules, alerts, tokens,
/// secrets): a regular file only ([`open_regular`]: a FIFO is refused at
/// once rather than waited on), of at most [`MAX_SMALL_FILE_BYTES`].
pub fn read_small(path: &Path) -> std::io::Result<Vec<u8>> {
    use std::io::Read;
    let mut bytes = Vec::new();
    open_regular(path)?
        .take(MAX_SMALL_FILE_BYTES + 1)
        .read_to_end(&mut bytes)?;
    if bytes.len() as u64 > MAX_SMALL_FILE_BYTES {
        return Err(std::io::Error::new(
            std::io::ErrorKind::InvalidData,
            format!("larger than {MAX_SMALL_FILE_BYTES} bytes, which such a file never is"),
        ));
    }
    Ok(bytes)
}

/// A TOML error of a small file as `line N: message` (its line from the
/// error's span), the form every file's errors take.
pub fn toml_error(text: &str, e: &toml::de::Error) -> String {
    match e.span() {
        Some(span) => format!("line {}: {}", line_at(text, span.start), e.message()),
        None => e.message().to_owned(),
    }
}

/// The line (1-based) of byte `offset` of `text`.
pub fn line_at(text: &str, offset: usize) -> usize {
    text.as_bytes()[..offset.min(text.len())]
        .iter()
        .filter(|&&b| b == b'\n')
        .count()
        + 1
}

/// The line (1-based) of the `n`-th (from 0) line of `text` that starts,
/// after blanks, with `start` (`[[webhook]]`, `pattern`): where the `n`-th
/// entry of an array of tables begins.
pub fn nth_line_starting(text: &str, start: &str, n: usize) -> Option<usize> {
    text.lines()
        .enumerate()
        .filter(|(_, l)| l.trim_start().starts_with(start))
        .nth(n)
        .map(|(i, _)| i + 1)
}

/// [`read_small`] of a UTF-8 text.
pub fn read_small_text(path: &Path) -> std::io::Result<String> {
    String::from_utf8(read_small(path)?).map_err(|e| {
        std::io::Error::new(
            std::io::ErrorKind::InvalidData,
            format!("not UTF-8 text (byte {})", e.utf8_error().valid_up_to()),
        )
    })
}
