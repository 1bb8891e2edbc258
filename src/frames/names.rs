//! A submission's names: the tests a folder's files or an upload's file
//! names stand for (plain relative paths, nothing that could show another
//! name on the triage page), and its `name=value` keys, each bounded.

use super::{FramesError, Input, Source, EXTENSIONS, MAX_FRAMES};
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

/// The images in `folder` and its subfolders, each a frame of the test
/// named by its path from `folder` without its extension (`ui/button` for
/// `ui/button.png`), in name order. Files of other extensions are left
/// out; links are not followed.
pub fn collect_folder(folder: &Path) -> Result<Vec<Input>, FramesError> {
    Ok(collect_folder_noting(folder)?.0)
}

/// [`collect_folder`], with the files it left out (not images, or not
/// regular files), by path, so that a command can say so.
pub fn collect_folder_noting(folder: &Path) -> Result<(Vec<Input>, Vec<String>), FramesError> {
    let name = folder.display().to_string();
    let mut skipped = Vec::new();
    let mut found: BTreeMap<String, PathBuf> = BTreeMap::new();
    let mut pending = vec![folder.to_path_buf()];
    let mut files = 0usize;
    while let Some(dir) = pending.pop() {
        let entries = std::fs::read_dir(&dir).map_err(|e| FramesError::File {
            file: dir.display().to_string(),
            detail: format!("cannot list it: {e}"),
        })?;
        for entry in entries {
            let entry = entry.map_err(|e| FramesError::File {
                file: dir.display().to_string(),
                detail: format!("cannot list it: {e}"),
            })?;
            let path = entry.path();
            let kind = entry.file_type().map_err(|e| FramesError::File {
                file: path.display().to_string(),
                detail: e.to_string(),
            })?;
            if kind.is_dir() {
                pending.push(path);
                continue;
            }
            let ext = path
                .extension()
                .and_then(|e| e.to_str())
                .map(str::to_ascii_lowercase);
            if !kind.is_file() || !ext.is_some_and(|e| EXTENSIONS.contains(&e.as_str())) {
                skipped.push(path.display().to_string());
                continue;
            }
            files += 1;
            if files > MAX_FRAMES {
                return Err(FramesError::TooMany {
                    folder: name,
                    count: files,
                    max: MAX_FRAMES,
                });
            }
            let test = test_name(folder, &path)?;
            if let Some(first) = found.get(&test) {
                let (a, b) = ordered(first, &path);
                return Err(FramesError::Duplicate {
                    test,
                    first: a,
                    second: b,
                });
            }
            found.insert(test, path);
        }
    }
    if found.is_empty() {
        return Err(FramesError::Empty { folder: name });
    }
    skipped.sort();
    let inputs = found
        .into_iter()
        .map(|(test, path)| Input {
            test,
            file: path.display().to_string(),
            source: Source::Path(path),
        })
        .collect();
    Ok((inputs, skipped))
}

fn ordered(a: &Path, b: &Path) -> (String, String) {
    let (a, b) = (a.display().to_string(), b.display().to_string());
    if a <= b {
        (a, b)
    } else {
        (b, a)
    }
}

/// A character that shows nothing or turns the text around it (Unicode's
/// format characters: zero-width ones, the bidirectional controls, the
/// byte-order mark, the soft hyphen): in a test name it can make one test
/// look like another.
fn invisible(c: char) -> bool {
    matches!(c,
        '\u{00AD}' | '\u{061C}' | '\u{180E}' | '\u{200B}'..='\u{200F}' | '\u{202A}'..='\u{202E}'
        | '\u{2060}'..='\u{2064}' | '\u{2066}'..='\u{206F}' | '\u{FEFF}' | '\u{FFF9}'..='\u{FFFB}')
}

/// `path`'s test name: its path from `folder`, `/`-separated, without the
/// extension.
fn test_name(folder: &Path, path: &Path) -> Result<String, FramesError> {
    let file = path.display().to_string();
    let relative = path.strip_prefix(folder).unwrap_or(path).with_extension("");
    let mut parts = Vec::new();
    for c in relative.components() {
        match c {
            std::path::Component::Normal(p) => match p.to_str() {
                Some(s) if s.chars().any(|c| c.is_control() || invisible(c)) => {
                    return Err(FramesError::File {
                        file,
                        detail: "a control, invisible or direction-changing character (such as U+202E) in the name, which would show another name on the triage page".into(),
                    })
                }
                Some(s) => parts.push(s.to_owned()),
                None => {
                    return Err(FramesError::File {
                        file,
                        detail: "a name that is not UTF-8 cannot be a test name".into(),
                    })
                }
            },
            _ => {
                return Err(FramesError::File {
                    file,
                    detail: "a test name is a plain path inside the folder".into(),
                })
            }
        }
    }
    Ok(parts.join("/"))
}

/// The most keys a submission carries.
pub const MAX_KEYS: usize = 32;
/// The longest key name, in bytes.
pub const MAX_KEY_NAME: usize = 64;
/// The longest key value, in bytes: keys name a device, a backend, a
/// branch or a commit, and go into every report, alert and listing.
pub const MAX_KEY_VALUE: usize = 256;

/// `name=value` pairs, as `--key` gives them: at most [`MAX_KEYS`], each
/// name at most [`MAX_KEY_NAME`] bytes and each value [`MAX_KEY_VALUE`].
pub fn parse_keys(pairs: &[String]) -> Result<BTreeMap<String, String>, FramesError> {
    if pairs.len() > MAX_KEYS {
        return Err(FramesError::KeyBounds {
            what: format!("{} keys", pairs.len()),
            most: MAX_KEYS,
        });
    }
    let mut keys = BTreeMap::new();
    for pair in pairs {
        let shown = || clip(pair, 48);
        let Some((k, v)) = pair.split_once('=') else {
            return Err(FramesError::Key(shown()));
        };
        if k.len() > MAX_KEY_NAME {
            return Err(FramesError::KeyBounds {
                what: format!("key {}: a name of {} bytes", shown(), k.len()),
                most: MAX_KEY_NAME,
            });
        }
        if v.len() > MAX_KEY_VALUE {
            return Err(FramesError::KeyBounds {
                what: format!("key {k}: a value of {} bytes", v.len()),
                most: MAX_KEY_VALUE,
            });
        }
        let plain = |c: char| c.is_ascii_alphanumeric() || "_-.".contains(c);
        if k.is_empty()
            || !k.chars().all(plain)
            || keys.insert(k.to_owned(), v.to_owned()).is_some()
        {
            return Err(FramesError::Key(shown()));
        }
    }
    Ok(keys)
}

/// `text`'s first `most` characters, and `…` when there were more.
pub(super) fn clip(text: &str, most: usize) -> String {
    match text.char_indices().nth(most) {
        Some((at, _)) => format!("{}…", &text[..at]),
        None => text.to_owned(),
    }
}

/// A test name an uploaded file's name gives (`ui/button.png` is a frame
/// of `ui/button`): `/`-separated plain names, no `.` or `..`, no empty
/// part, no backslash or control character, and an image extension.
pub fn test_of_upload(name: &str) -> Result<String, FramesError> {
    // The name quoted short, so that a long one's reason is not cut off.
    let bad = |detail: &str| FramesError::File {
        file: clip(name, 48),
        detail: detail.to_owned(),
    };
    let (stem, ext) = name
        .rsplit_once('.')
        .filter(|(stem, _)| !stem.is_empty() && !stem.ends_with('/'))
        .ok_or_else(|| bad("no extension: name each image test.png, .exr, .hdr or .pfm"))?;
    if !EXTENSIONS.contains(&ext.to_ascii_lowercase().as_str()) {
        return Err(bad("not an image extension (.png, .exr, .hdr, .pfm)"));
    }
    if name.len() > 512 {
        return Err(bad("a name over 512 bytes"));
    }
    for part in stem.split('/') {
        if part.is_empty() || part == "." || part == ".." {
            return Err(bad(
                "a test name is a plain relative path: no empty part, '.', '..' or leading '/'",
            ));
        }
        if part.chars().any(|c| c == '\\' || c.is_control()) {
            return Err(bad("a backslash or control character in the name"));
        }
        if part.chars().any(invisible) {
            return Err(bad(
                "an invisible or direction-changing character (such as U+202E) in the name, which would show another name on the triage page",
            ));
        }
    }
    Ok(stem.to_owned())
}

/// A file of a submitted folder, read only if it is still a regular file
/// when opened (a FIFO put in its place is refused, not waited on).
pub(super) fn read_regular(path: &std::path::Path) -> std::io::Result<Vec<u8>> {
    use std::io::Read;
    let mut bytes = Vec::new();
    crate::io::open_regular(path)?.read_to_end(&mut bytes)?;
    Ok(bytes)
}
