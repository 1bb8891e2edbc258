//! The cICP chunk of a PNG as the file has it, read before any decoder
//! trusts it: at most one (PNG Third Edition), four bytes (primaries,
//! transfer, matrix, full-range flag, ITU-T H.273 code points), an RGB
//! matrix (0) and the full range (1), which is all PNG allows. A file that
//! says anything else, or says it twice, is refused with what it says and
//! where, rather than read as whatever a decoder kept.

use super::error::HdrIoError;

const FORMAT: &str = "PNG";

/// cICP: the colour primaries and transfer characteristics, as H.273 codes
/// them; the matrix is 0 (RGB) and the range full, as PNG requires.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Cicp {
    /// 1 = BT.709, 9 = BT.2020.
    pub primaries: u8,
    /// 13 = sRGB, 16 = PQ (SMPTE ST 2084), 18 = HLG (ARIB STD-B67).
    pub transfer: u8,
}

impl Cicp {
    /// BT.2020 primaries with the PQ transfer (BT.2100 PQ).
    pub const BT2100_PQ: Cicp = Cicp {
        primaries: 9,
        transfer: 16,
    };
    /// BT.2020 primaries with the HLG transfer (BT.2100 HLG).
    pub const BT2100_HLG: Cicp = Cicp {
        primaries: 9,
        transfer: 18,
    };
}

impl std::fmt::Display for Cicp {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        let primaries = match self.primaries {
            1 => "BT.709",
            9 => "BT.2020",
            12 => "Display P3",
            _ => "other",
        };
        let transfer = match self.transfer {
            1 | 6 | 14 | 15 => "BT.709",
            8 => "linear",
            13 => "sRGB",
            16 => "PQ",
            18 => "HLG",
            _ => "other",
        };
        write!(
            f,
            "primaries {} ({primaries}), transfer {} ({transfer})",
            self.primaries, self.transfer
        )
    }
}

/// The file's cICP, checked: `None` when it has none.
pub fn scan(bytes: &[u8], file: &str) -> Result<Option<Cicp>, HdrIoError> {
    let corrupt = |detail: String| HdrIoError::Corrupt {
        file: file.to_string(),
        format: FORMAT,
        detail,
    };
    let unsupported = |detail: String| HdrIoError::Unsupported {
        file: file.to_string(),
        format: FORMAT,
        detail,
    };
    const SIGNATURE: &[u8] = b"\x89PNG\r\n\x1a\n";
    if !bytes.starts_with(SIGNATURE) {
        return Err(corrupt("not a PNG (its signature is missing)".into()));
    }
    let mut at = SIGNATURE.len();
    let mut found: Option<(Cicp, usize)> = None;
    // The chunks up to the image data, where cICP must come.
    while at + 8 <= bytes.len() {
        let len = u32::from_be_bytes(bytes[at..at + 4].try_into().unwrap_or_default()) as usize;
        let kind = &bytes[at + 4..at + 8];
        if kind == b"IDAT" || kind == b"IEND" {
            break;
        }
        let data = at + 8;
        let Some(end) = data.checked_add(len).filter(|&e| e + 4 <= bytes.len()) else {
            return Err(corrupt(format!(
                "the {} chunk at byte {at} says {len} bytes, past the end of the file",
                String::from_utf8_lossy(kind)
            )));
        };
        if kind == b"cICP" {
            if len != 4 {
                return Err(corrupt(format!(
                    "the cICP chunk at byte {at} has {len} bytes; it has 4 (primaries, \
                     transfer, matrix, full range)"
                )));
            }
            let d = &bytes[data..end];
            let cicp = Cicp {
                primaries: d[0],
                transfer: d[1],
            };
            if let Some((first, first_at)) = found {
                return Err(corrupt(format!(
                    "two cICP chunks, at byte {first_at} ({first}) and at byte {at} ({cicp}); \
                     a PNG has at most one"
                )));
            }
            if d[2] != 0 {
                return Err(unsupported(format!(
                    "the cICP chunk at byte {at} says matrix coefficients {} (not RGB); PNG \
                     holds RGB only (matrix 0)",
                    d[2]
                )));
            }
            if d[3] != 1 {
                return Err(unsupported(format!(
                    "the cICP chunk at byte {at} says narrow (video) range ({cicp}, full-range \
                     flag {}); only full-range code values are read",
                    d[3]
                )));
            }
            found = Some((cicp, at));
        }
        at = end + 4;
    }
    Ok(found.map(|(c, _)| c))
}

#[cfg(test)]
mod tests {
    use super::*;

    /// A PNG's signature and chunks (CRCs not checked here, so zero).
    fn png(chunks: &[(&[u8; 4], &[u8])]) -> Vec<u8> {
        let mut out = b"\x89PNG\r\n\x1a\n".to_vec();
        for (kind, data) in chunks {
            out.extend_from_slice(&(data.len() as u32).to_be_bytes());
            out.extend_from_slice(*kind);
            out.extend_from_slice(data);
            out.extend_from_slice(&[0; 4]);
        }
        out
    }

    #[test]
    fn a_cicp_that_lies_is_refused_with_what_it_says() {
        let ihdr: (&[u8; 4], &[u8]) = (b"IHDR", &[0; 13]);
        let pq: (&[u8; 4], &[u8]) = (b"cICP", &[9, 16, 0, 1]);
        let hlg: (&[u8; 4], &[u8]) = (b"cICP", &[9, 18, 0, 1]);
        let idat: (&[u8; 4], &[u8]) = (b"IDAT", &[]);
        assert_eq!(
            scan(&png(&[ihdr, pq, idat]), "a.png").unwrap(),
            Some(Cicp::BT2100_PQ)
        );
        assert_eq!(scan(&png(&[ihdr, idat]), "a.png").unwrap(), None);
        let e = scan(&png(&[ihdr, pq, hlg, idat]), "a.png").unwrap_err();
        let text = e.to_string();
        assert!(
            text.contains("two cICP chunks") && text.contains("(PQ)") && text.contains("(HLG)"),
            "{text}"
        );
        let narrow: (&[u8; 4], &[u8]) = (b"cICP", &[9, 16, 0, 0]);
        let text = scan(&png(&[ihdr, narrow, idat]), "a.png")
            .unwrap_err()
            .to_string();
        assert!(text.contains("narrow (video) range"), "{text}");
        let ycbcr: (&[u8; 4], &[u8]) = (b"cICP", &[9, 16, 9, 1]);
        let text = scan(&png(&[ihdr, ycbcr, idat]), "a.png")
            .unwrap_err()
            .to_string();
        assert!(text.contains("matrix coefficients 9"), "{text}");
        let short: (&[u8; 4], &[u8]) = (b"cICP", &[9, 16]);
        let text = scan(&png(&[ihdr, short, idat]), "a.png")
            .unwrap_err()
            .to_string();
        assert!(text.contains("has 2 bytes"), "{text}");
        assert!(!text.contains("Some("), "{text}");
        // A cICP after the image data is not one a reader may take.
        assert_eq!(scan(&png(&[ihdr, idat, hlg]), "a.png").unwrap(), None);
    }
}
