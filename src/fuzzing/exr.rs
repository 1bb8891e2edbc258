//! Builds an OpenEXR file from fuzz input: a valid layout (magic, version
//! flags, attributes, offset tables, block headers) around values the input
//! picks, most from ranges a real file has, some raw (hostile: negative or
//! huge sizes, windows past `i32`, wrong chunk counts, offsets anywhere).
//! Written from the OpenEXR file layout document.

/// Reads choices from the input; past its end every choice is 0.
struct Choices<'a> {
    data: &'a [u8],
}

impl Choices<'_> {
    fn byte(&mut self) -> u8 {
        match self.data.split_first() {
            Some((&b, rest)) => {
                self.data = rest;
                b
            }
            None => 0,
        }
    }
    fn u32(&mut self) -> u32 {
        u32::from_le_bytes([self.byte(), self.byte(), self.byte(), self.byte()])
    }
    /// True about one time in `n`.
    fn one_in(&mut self, n: u8) -> bool {
        self.byte().is_multiple_of(n)
    }
    /// A value in `lo..=hi` mostly, any `i32` one time in 16.
    fn size(&mut self, lo: i32, hi: i32) -> i32 {
        if self.one_in(16) {
            self.u32() as i32
        } else {
            lo + i32::from(self.byte()) % (hi - lo + 1)
        }
    }
    fn bytes(&mut self, n: usize) -> Vec<u8> {
        let n = n.min(self.data.len());
        let (head, rest) = self.data.split_at(n);
        self.data = rest;
        head.to_vec()
    }
}

fn attribute(out: &mut Vec<u8>, name: &str, kind: &str, value: &[u8]) {
    out.extend(name.as_bytes());
    out.push(0);
    out.extend(kind.as_bytes());
    out.push(0);
    out.extend((value.len() as i32).to_le_bytes());
    out.extend(value);
}

fn i32s(values: &[i32]) -> Vec<u8> {
    values.iter().flat_map(|v| v.to_le_bytes()).collect()
}

/// Scan lines per block of each compression, by its code.
fn lines_per_block(compression: u8) -> i32 {
    match compression {
        0..=2 => 1,
        3 | 5 => 16,
        4 | 6..=8 => 32,
        _ => 256,
    }
}

/// Bytes per sample of a pixel type code (uint, half, float).
fn sample_bytes(kind: i32) -> usize {
    if kind == 1 {
        2
    } else {
        4
    }
}

/// ⌈n / d⌉ for hostile values: both taken as at least 1, no overflow.
fn div_up(n: i32, d: i32) -> i32 {
    let (n, d) = (i64::from(n.max(1)), i64::from(d.max(1)));
    ((n + d - 1) / d) as i32
}

struct Part {
    tiled: bool,
    deep: bool,
    compression: u8,
    window: [i32; 4],
    tile: (i32, i32),
    channels: Vec<(&'static str, i32, i32, i32)>,
    chunk_count: i32,
}

const CHANNEL_NAMES: &[&str] = &["R", "G", "B", "A", "Y", "RY", "BY", "Z", "diffuse.R"];

fn part(c: &mut Choices<'_>) -> Part {
    let tiled = c.one_in(3);
    let deep = c.one_in(12);
    let compression = if c.one_in(16) {
        c.byte()
    } else {
        c.byte() % 10
    };
    let (x0, y0) = if c.one_in(4) {
        (c.size(-8, 8), c.size(-8, 8))
    } else {
        (0, 0)
    };
    let (w, h) = (c.size(1, 40), c.size(1, 40));
    let window = [
        x0,
        y0,
        x0.wrapping_add(w).wrapping_sub(1),
        y0.wrapping_add(h).wrapping_sub(1),
    ];
    let tile = (c.size(1, 16), c.size(1, 16));
    let mut channels = Vec::new();
    let count = if c.one_in(8) { c.byte() % 12 } else { 3 };
    for i in 0..count {
        let name = if c.one_in(4) {
            CHANNEL_NAMES[usize::from(c.byte()) % CHANNEL_NAMES.len()]
        } else {
            CHANNEL_NAMES[usize::from(i) % 3]
        };
        let kind = if c.one_in(16) {
            c.u32() as i32
        } else {
            i32::from(c.byte() % 3)
        };
        let (sx, sy) = if c.one_in(10) {
            (c.size(1, 3), c.size(1, 3))
        } else {
            (1, 1)
        };
        channels.push((name, kind, sx, sy));
    }
    // OpenEXR sorts channels by name.
    channels.sort_by_key(|ch| ch.0);
    let blocks = if tiled {
        div_up(w, tile.0).saturating_mul(div_up(h, tile.1))
    } else {
        div_up(h, lines_per_block(compression))
    };
    let chunk_count = if c.one_in(12) { c.u32() as i32 } else { blocks };
    Part {
        tiled,
        deep,
        compression,
        window,
        tile,
        channels,
        chunk_count,
    }
}

fn header(out: &mut Vec<u8>, p: &Part, index: usize, multipart: bool, c: &mut Choices<'_>) {
    let mut list = Vec::new();
    for &(name, kind, sx, sy) in &p.channels {
        list.extend(name.as_bytes());
        list.push(0);
        list.extend(kind.to_le_bytes());
        list.extend([0u8; 4]); // pLinear, reserved
        list.extend(i32s(&[sx, sy]));
    }
    list.push(0);
    attribute(out, "channels", "chlist", &list);
    attribute(out, "compression", "compression", &[p.compression]);
    attribute(out, "dataWindow", "box2i", &i32s(&p.window));
    attribute(out, "displayWindow", "box2i", &i32s(&p.window));
    attribute(out, "lineOrder", "lineOrder", &[c.byte() % 3]);
    attribute(out, "pixelAspectRatio", "float", &1.0f32.to_le_bytes());
    attribute(out, "screenWindowCenter", "v2f", &[0; 8]);
    attribute(out, "screenWindowWidth", "float", &1.0f32.to_le_bytes());
    if p.tiled {
        let mut desc = i32s(&[p.tile.0, p.tile.1]);
        desc.push(if c.one_in(6) { c.byte() } else { 0 });
        attribute(out, "tiles", "tiledesc", &desc);
    }
    if multipart || p.deep {
        let kind = match (p.tiled, p.deep) {
            (false, false) => "scanlineimage",
            (true, false) => "tiledimage",
            (false, true) => "deepscanline",
            (true, true) => "deeptile",
        };
        attribute(out, "name", "string", format!("part{index}").as_bytes());
        attribute(out, "type", "string", kind.as_bytes());
        attribute(out, "chunkCount", "int", &p.chunk_count.to_le_bytes());
        if p.deep {
            attribute(out, "version", "int", &1i32.to_le_bytes());
            attribute(out, "maxSamplesPerPixel", "int", &4i32.to_le_bytes());
        }
    }
    out.push(0);
}

/// One block's payload: raw input bytes, or (for uncompressed scan lines,
/// half the time) exactly the bytes the block should hold.
fn payload(p: &Part, c: &mut Choices<'_>) -> Vec<u8> {
    if p.compression == 0 && !p.tiled && !p.deep && c.one_in(2) {
        let w = usize::try_from(p.window[2].wrapping_sub(p.window[0]).wrapping_add(1))
            .unwrap_or(0)
            .min(64);
        let per_line: usize = p
            .channels
            .iter()
            .map(|&(_, kind, _, _)| sample_bytes(kind) * w)
            .sum();
        let mut v = c.bytes(per_line);
        v.resize(per_line, 0x3c);
        v
    } else {
        let n = usize::from(c.byte()) * if c.one_in(4) { 16 } else { 1 };
        c.bytes(n)
    }
}

/// The file the input describes.
pub fn build(data: &[u8]) -> Vec<u8> {
    let mut c = Choices { data };
    let multipart = c.one_in(6);
    let parts: Vec<Part> = (0..if multipart { 1 + c.byte() % 3 } else { 1 })
        .map(|_| part(&mut c))
        .collect();
    let mut out = vec![0x76, 0x2f, 0x31, 0x01];
    let mut flags: u32 = 2;
    if !multipart && parts[0].tiled {
        flags |= 0x200;
    }
    if parts.iter().any(|p| p.deep) {
        flags |= 0x800;
    }
    if multipart {
        flags |= 0x1000;
    }
    if c.one_in(32) {
        flags ^= 1 << (c.byte() % 32);
    }
    out.extend(flags.to_le_bytes());
    for (i, p) in parts.iter().enumerate() {
        header(&mut out, p, i, multipart, &mut c);
    }
    if multipart {
        out.push(0);
    }
    // Offset tables, then the blocks they point at.
    let tables_at = out.len();
    let counts: Vec<usize> = parts
        .iter()
        .map(|p| usize::try_from(p.chunk_count).unwrap_or(0).min(64))
        .collect();
    out.resize(tables_at + 8 * counts.iter().sum::<usize>(), 0);
    let mut slot = tables_at;
    for (index, (p, &count)) in parts.iter().zip(&counts).enumerate() {
        let lines = lines_per_block(p.compression);
        for b in 0..count {
            let offset = if c.one_in(20) {
                u64::from(c.u32())
            } else {
                out.len() as u64
            };
            out[slot..slot + 8].copy_from_slice(&offset.to_le_bytes());
            slot += 8;
            if multipart {
                out.extend((index as i32).to_le_bytes());
            }
            let b = b as i32;
            if p.tiled {
                let width = i64::from(p.window[2]) - i64::from(p.window[0]) + 1;
                let across = div_up(width.clamp(1, i64::from(i32::MAX)) as i32, p.tile.0);
                out.extend(i32s(&[b % across, b / across, 0, 0]));
            } else {
                let y = if c.one_in(16) {
                    c.u32() as i32
                } else {
                    p.window[1].wrapping_add(b.wrapping_mul(lines))
                };
                out.extend(y.to_le_bytes());
            }
            if p.deep {
                // Packed offset table size, packed sample size, unpacked size.
                out.extend(
                    [c.u32() as u64 % 256, c.u32() as u64 % 256, c.u32() as u64]
                        .iter()
                        .flat_map(|v| v.to_le_bytes()),
                );
            }
            let body = payload(p, &mut c);
            let size = if c.one_in(16) {
                c.u32() as i32
            } else {
                body.len() as i32
            };
            out.extend(size.to_le_bytes());
            out.extend(body);
        }
    }
    // What is left of the input trails the file (a damaged tail).
    out.extend(c.data);
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Choices that pick a plain file: single part, scan lines, no
    /// compression, 4×2, R G B in half floats, exact payloads of 0x3c3c
    /// (1.0586 as a half). It must decode to that image, so the builder
    /// writes the layout the format document describes.
    #[test]
    fn sane_choices_build_a_file_that_decodes_to_their_pixels() {
        let mut input = vec![
            1, // not multipart
            1, 1, // not tiled, not deep
            1, 0, // compression: none
            1, // window at the origin
            1, 3, 1, 1, // 4 × 2
            1, 0, 1, 0, // tile size (unused)
            1, // three channels
        ];
        input.extend([1u8, 1, 1, 1].repeat(3)); // R G B: half, 1×1 sampling
        input.extend([1, 1, 0]); // chunk count right, version flags kept, increasing lines
        for _ in 0..2 {
            input.extend([1, 1, 0]); // offset right, y right, exact payload
            input.extend([0x3c; 24]);
            input.push(1); // size right
        }
        let file = build(&input);
        let (img, _) = crate::io::decode_hdr(&file, "built.exr", &Default::default())
            .unwrap_or_else(|e| panic!("{e}"));
        assert_eq!((img.width, img.height), (4, 2));
        let half = 1.0 + 60.0 / 1024.0;
        assert!(
            img.pixels.iter().flatten().all(|&v| v == half),
            "{:?}",
            img.pixels
        );
        // Every other input still builds a file with the magic.
        assert_eq!(&build(&[])[..4], &[0x76, 0x2f, 0x31, 0x01]);
    }
}
