//! `DataArray` values: number types, base64, the (optionally zlib-compressed) binary block
//! layout with its header words, and the `ascii` / `binary` / `appended` sources. Every header
//! value goes through checked arithmetic and is compared with the bytes present before
//! anything is allocated or sliced.

use std::io::Read;

use super::scan::line_of;
pub(super) use crate::io::number::Number as Ty;
use crate::io::syntax::SyntaxError;
use crate::io::{DataArrayError, ParseError};

/// File-level settings from the `VTKFile` element.
#[derive(Debug, Clone, Copy)]
pub(super) struct Settings {
    pub(super) big: bool,
    pub(super) header: usize,
    pub(super) zlib: bool,
}

/// Where a `DataArray`'s values are.
pub(super) enum Source {
    Ascii(usize, usize),
    Binary(usize, usize),
    Appended(u64),
}

/// One `DataArray`: where its values are and how to read them.
pub(crate) struct Array {
    /// The `Name` attribute.
    pub(crate) name: String,
    pub(super) ty: Ty,
    /// `NumberOfComponents` (1 if absent).
    pub(crate) components: usize,
    pub(super) source: Source,
    /// Line of the `DataArray` tag.
    pub(crate) line: usize,
}

const B64: &[u8; 64] = b"ABCDEFGHIJKLMNOPQRSTUVWXYZabcdefghijklmnopqrstuvwxyz0123456789+/";

fn b64_value(c: u8) -> Option<u32> {
    match c {
        b'A'..=b'Z' => Some((c - b'A') as u32),
        b'a'..=b'z' => Some((c - b'a') as u32 + 26),
        b'0'..=b'9' => Some((c - b'0') as u32 + 52),
        b'+' => Some(62),
        b'/' => Some(63),
        _ => None,
    }
}

/// Decodes base64 text (no whitespace; `=` padding allowed at the end of each quartet group);
/// `Err(k)` names the offending character's index.
fn b64_decode(t: &[u8]) -> Result<Vec<u8>, usize> {
    let mut out = Vec::with_capacity(t.len() / 4 * 3);
    for (q, chunk) in t.chunks(4).enumerate() {
        let mut v = 0u32;
        let mut n = 0;
        for (k, &c) in chunk.iter().enumerate() {
            if c == b'=' {
                if k < 2 || chunk[k..].iter().any(|&d| d != b'=') {
                    return Err(4 * q + k);
                }
                break;
            }
            v |= b64_value(c).ok_or(4 * q + k)? << (18 - 6 * k);
            n += 1;
        }
        if n < 2 {
            return Err(4 * q);
        }
        let bytes = [(v >> 16) as u8, (v >> 8) as u8, v as u8];
        out.extend_from_slice(&bytes[..n - 1]);
    }
    Ok(out)
}

/// Base64 of `data` with `=` padding.
pub(crate) fn b64_encode(data: &[u8]) -> String {
    let mut s = String::with_capacity(data.len().div_ceil(3) * 4);
    for c in data.chunks(3) {
        let v = (c[0] as u32) << 16 | (*c.get(1).unwrap_or(&0) as u32) << 8 | *c.get(2).unwrap_or(&0) as u32;
        for k in 0..4 {
            if k <= c.len() {
                s.push(B64[(v >> (18 - 6 * k) & 63) as usize] as char);
            } else {
                s.push('=');
            }
        }
    }
    s
}

/// Number of base64 characters that encode `n` bytes.
fn b64_len(n: u64) -> u64 {
    n.div_ceil(3).saturating_mul(4)
}

/// Reads the bytes of one array from a byte stream (raw appended data, or decoded base64).
struct Decoder<'a> {
    bytes: &'a [u8],
    s: Settings,
    /// Offset of `bytes[0]` in the file (for messages).
    base: usize,
    file_len: usize,
    /// Whether `bytes` is base64 text.
    base64: bool,
    what: String,
}

impl Decoder<'_> {
    fn truncated(&self, needed: u64, offset: u64) -> ParseError {
        ParseError::Truncated {
            what: self.what.clone(),
            needed,
            offset: self.base as u64 + offset,
            len: self.file_len as u64,
        }
    }

    fn invalid(&self, problem: DataArrayError) -> ParseError {
        ParseError::DataArray {
            array: self.what.clone(),
            problem,
        }
    }

    /// `n` bytes starting at text/byte position `at`, as stored (raw) or decoded (base64:
    /// `b64_len(n)` characters). Errors (never panics) if they are not all there.
    fn take(&self, at: u64, n: u64) -> Result<Vec<u8>, ParseError> {
        let len = if self.base64 { b64_len(n) } else { n };
        let end = at.checked_add(len).filter(|&e| e <= self.bytes.len() as u64);
        let Some(end) = end else {
            return Err(self.truncated(len, at));
        };
        // Both fit in usize: end <= bytes.len().
        let chunk = &self.bytes[at as usize..end as usize];
        if self.base64 {
            let mut d = b64_decode(chunk).map_err(|k| {
                self.invalid(DataArrayError::Base64 {
                    offset: (self.base as u64).saturating_add(at).saturating_add(k as u64),
                })
            })?;
            if (d.len() as u64) < n {
                return Err(self.truncated(len, at));
            }
            d.truncate(n as usize);
            Ok(d)
        } else {
            Ok(chunk.to_vec())
        }
    }

    /// Bytes (decoded, for base64) available from position `at` on.
    fn available(&self, at: u64) -> u64 {
        let rest = (self.bytes.len() as u64).saturating_sub(at);
        if self.base64 {
            rest / 4 * 3
        } else {
            rest
        }
    }

    fn word(&self, b: &[u8]) -> u64 {
        if self.s.header == 4 {
            Ty::U32.read(b, self.s.big) as u64
        } else {
            let mut a = [0u8; 8];
            a.copy_from_slice(b);
            if self.s.big {
                u64::from_be_bytes(a)
            } else {
                u64::from_le_bytes(a)
            }
        }
    }

    /// The array's raw bytes (exactly `expected` of them), starting at `at`.
    fn array(&self, at: u64, expected: u64) -> Result<Vec<u8>, ParseError> {
        let h = self.s.header as u64;
        if !self.s.zlib {
            // One header word (the byte count), then the data; base64 encodes them together.
            let head = self.take(at, h)?;
            let n = self.word(&head);
            if n != expected {
                return Err(self.invalid(DataArrayError::HeaderSize {
                    declared: n,
                    needed: expected,
                }));
            }
            let total = h
                .checked_add(n)
                .filter(|&t| t <= self.available(at))
                .ok_or_else(|| self.truncated(h.saturating_add(n), at))?;
            let all = self.take(at, total)?;
            return Ok(all[h as usize..].to_vec());
        }
        // Compressed: [nblocks, block size, last block size, compressed sizes...], then the
        // blocks; base64 encodes the header and the blocks separately.
        let first = self.take(at, h)?;
        let nb = self.word(&first);
        let head_len = nb
            .checked_add(3)
            .and_then(|k| k.checked_mul(h))
            .filter(|&l| l <= self.available(at))
            .ok_or_else(|| {
                self.invalid(DataArrayError::TooManyBlocks {
                    blocks: nb,
                    available: self.available(at),
                })
            })?;
        let head = self.take(at, head_len)?;
        let w: Vec<u64> = head.chunks_exact(h as usize).map(|c| self.word(c)).collect();
        let (bs, last) = (w[1], w[2]);
        let sizes = &w[3..];
        let total = match nb {
            0 => Some(0),
            _ => (nb - 1)
                .checked_mul(bs)
                .and_then(|t| t.checked_add(if last == 0 { bs } else { last })),
        };
        if total != Some(expected) {
            return Err(self.invalid(match total {
                Some(t) => DataArrayError::CompressedSize {
                    declared: t,
                    needed: expected,
                },
                None => DataArrayError::BlockSizesOverflow {
                    blocks: nb,
                    block_size: bs,
                },
            }));
        }
        let comp_total = sizes
            .iter()
            .try_fold(0u64, |a, &s| a.checked_add(s))
            .ok_or_else(|| self.invalid(DataArrayError::CompressedSizesOverflow))?;
        // zlib cannot inflate more than about 1032:1; a header claiming more is corrupt (and
        // must not make us reserve its size).
        if expected > comp_total.saturating_mul(1100).saturating_add(64) {
            return Err(self.invalid(DataArrayError::Ratio {
                compressed: comp_total,
                declared: expected,
            }));
        }
        let head_text = if self.base64 { b64_len(head_len) } else { head_len };
        let data_at = at
            .checked_add(head_text)
            .ok_or_else(|| self.truncated(comp_total, at))?;
        if comp_total > self.available(data_at) {
            return Err(self.truncated(comp_total, data_at));
        }
        let comp = self.take(data_at, comp_total)?;
        let mut out = Vec::new();
        let mut pos = 0usize;
        for (k, &cs) in sizes.iter().enumerate() {
            let want = if k as u64 + 1 == nb && last != 0 { last } else { bs };
            // The sizes sum to comp_total = comp.len(), so this slice is in range.
            let block = &comp[pos..pos + cs as usize];
            pos += cs as usize;
            let before = out.len();
            flate2::read::ZlibDecoder::new(block)
                .take(want.saturating_add(1))
                .read_to_end(&mut out)
                .map_err(|e| {
                    self.invalid(DataArrayError::Inflate {
                        block: k,
                        error: std::sync::Arc::new(e),
                    })
                })?;
            if (out.len() - before) as u64 != want {
                return Err(self.invalid(DataArrayError::BlockSize {
                    block: k,
                    found: (out.len() - before) as u64,
                    declared: want,
                }));
            }
        }
        Ok(out)
    }
}

/// The `count` values of an array.
pub(super) fn read_values(
    bytes: &[u8],
    s: Settings,
    appended: Option<(usize, bool)>,
    a: &Array,
    count: u64,
) -> Result<Vec<f64>, ParseError> {
    let what = format!("DataArray {:?} (line {})", a.name, a.line);
    let expected = count
        .checked_mul(a.ty.size() as u64)
        .ok_or_else(|| ParseError::SizeOverflow { what: what.clone() })?;
    let raw = match a.source {
        Source::Ascii(x, y) => {
            let text = &bytes[x..y];
            if count > (text.len() as u64).div_ceil(2) {
                return Err(ParseError::UnexpectedEnd {
                    expected: format!("{count} values in {what}, but it holds only {} bytes", text.len()),
                });
            }
            let mut out = Vec::with_capacity(count as usize);
            for (line, l) in (line_of(bytes, x)..).zip(text.split(|&c| c == b'\n')) {
                for tok in crate::io::text::tokens(l) {
                    let v = crate::io::text::parse_f64(tok).ok_or_else(|| ParseError::Syntax {
                        line,
                        problem: SyntaxError::Number {
                            what: what.to_string(),
                            found: crate::io::text::clip(tok),
                        },
                    })?;
                    out.push(v);
                }
            }
            if out.len() as u64 != count {
                return Err(ParseError::Syntax {
                    line: a.line,
                    problem: SyntaxError::ValueCount {
                        what: what.to_string(),
                        found: out.len(),
                        expected: count,
                    },
                });
            }
            return Ok(out);
        }
        Source::Binary(x, y) => {
            let text: Vec<u8> = bytes[x..y]
                .iter()
                .copied()
                .filter(|c| !c.is_ascii_whitespace())
                .collect();
            let d = Decoder {
                bytes: &text,
                s,
                base: x,
                file_len: bytes.len(),
                base64: true,
                what: what.clone(),
            };
            d.array(0, expected)?
        }
        Source::Appended(off) => {
            let (start, base64) = appended.ok_or_else(|| ParseError::Missing {
                what: format!("AppendedData for {what}, which is appended"),
            })?;
            let d = Decoder {
                bytes: &bytes[start..],
                s,
                base: start,
                file_len: bytes.len(),
                base64,
                what: what.clone(),
            };
            d.array(off, expected)?
        }
    };
    Ok(raw
        .chunks_exact(a.ty.size())
        .map(|c| a.ty.read(c, s.big))
        .collect())
}

/// One inline base64 array: `UInt64` byte count, then the data, encoded together.
pub(crate) fn b64_array(data: &[u8]) -> String {
    let mut buf = Vec::with_capacity(8 + data.len());
    buf.extend_from_slice(&(data.len() as u64).to_le_bytes());
    buf.extend_from_slice(data);
    b64_encode(&buf)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn base64_round_trips_and_rejects_garbage() {
        for n in 0..20u8 {
            let data: Vec<u8> = (0..n).map(|k| k.wrapping_mul(37).wrapping_add(n)).collect();
            let t = b64_encode(&data);
            assert_eq!(t.len() as u64, b64_len(n as u64));
            assert_eq!(b64_decode(t.as_bytes()).unwrap(), data);
        }
        assert_eq!(b64_encode(b"Man"), "TWFu");
        assert_eq!(b64_decode(b"TWE=").unwrap(), b"Ma");
        assert_eq!(b64_decode(b"TW*u"), Err(2));
        assert_eq!(b64_decode(b"T==="), Err(1));
    }
}
