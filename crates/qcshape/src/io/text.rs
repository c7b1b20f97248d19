//! Byte-level helpers shared by the text formats: a whitespace tokenizer that tracks line
//! numbers, number parsing on byte slices, and shortest round-trip float formatting.
//!
//! Everything works on `&[u8]` so that files that are not UTF-8 (or binary garbage) are
//! reported as bad tokens instead of failing up front.

use std::fmt;

/// A forward cursor over a byte buffer that yields whitespace-separated tokens and knows the
/// (1-based) line of the last token it returned. Binary formats that mix text and raw data
/// (VTK) also take raw byte runs from it.
#[derive(Clone)]
pub(crate) struct Cursor<'a> {
    bytes: &'a [u8],
    pos: usize,
    /// Line of the byte at `pos`.
    cur_line: usize,
    /// Line of the last token returned.
    tok_line: usize,
}

impl<'a> Cursor<'a> {
    /// A cursor at the start of `bytes`, at line `first_line`.
    pub(crate) fn new(bytes: &'a [u8], first_line: usize) -> Self {
        Cursor {
            bytes,
            pos: 0,
            cur_line: first_line,
            tok_line: first_line,
        }
    }

    /// The next token, or `None` at the end of the buffer.
    pub(crate) fn next_token(&mut self) -> Option<&'a [u8]> {
        while self.pos < self.bytes.len() && self.bytes[self.pos].is_ascii_whitespace() {
            if self.bytes[self.pos] == b'\n' {
                self.cur_line += 1;
            }
            self.pos += 1;
        }
        if self.pos >= self.bytes.len() {
            return None;
        }
        let start = self.pos;
        while self.pos < self.bytes.len() && !self.bytes[self.pos].is_ascii_whitespace() {
            self.pos += 1;
        }
        self.tok_line = self.cur_line;
        Some(&self.bytes[start..self.pos])
    }

    /// Line of the last token returned (or of the current position if none was).
    pub(crate) fn line(&self) -> usize {
        self.tok_line
    }

    /// Moves past the next line break (or to the end of the buffer).
    pub(crate) fn skip_line(&mut self) {
        while self.pos < self.bytes.len() {
            let b = self.bytes[self.pos];
            self.pos += 1;
            if b == b'\n' {
                self.cur_line += 1;
                return;
            }
        }
    }

    /// Rest of the current line (without the line break), consuming it.
    pub(crate) fn rest_of_line(&mut self) -> &'a [u8] {
        let start = self.pos;
        while self.pos < self.bytes.len() && self.bytes[self.pos] != b'\n' {
            self.pos += 1;
        }
        let s = &self.bytes[start..self.pos];
        self.skip_line();
        s
    }

    /// Byte offset of the cursor.
    pub(crate) fn offset(&self) -> usize {
        self.pos
    }

    /// Bytes left after the cursor.
    pub(crate) fn remaining(&self) -> usize {
        self.bytes.len() - self.pos
    }

    /// Takes the next `n` raw bytes, or `None` if fewer remain (the cursor does not move then).
    pub(crate) fn take(&mut self, n: usize) -> Option<&'a [u8]> {
        if n > self.remaining() {
            return None;
        }
        let s = &self.bytes[self.pos..self.pos + n];
        self.cur_line += s.iter().filter(|&&b| b == b'\n').count();
        self.pos += n;
        Some(s)
    }
}

/// Splits a line into whitespace-separated tokens.
pub(crate) fn tokens(line: &[u8]) -> impl Iterator<Item = &[u8]> {
    line.split(|b| b.is_ascii_whitespace()).filter(|t| !t.is_empty())
}

/// Iterates over `(line number, line)` with `\n` separators and a trailing `\r` removed.
pub(crate) fn lines(bytes: &[u8]) -> impl Iterator<Item = (usize, &[u8])> {
    bytes.split(|&b| b == b'\n').enumerate().map(|(i, l)| {
        let l = l.strip_suffix(b"\r").unwrap_or(l);
        (i + 1, l)
    })
}

/// Parses a float token (`nan` and `inf` parse; callers check finiteness separately so that
/// they can report a non-finite coordinate rather than a bad number).
pub(crate) fn parse_f64(tok: &[u8]) -> Option<f64> {
    std::str::from_utf8(tok).ok()?.parse::<f64>().ok()
}

/// Parses a decimal integer token (an optional sign and digits).
pub(crate) fn parse_i64(tok: &[u8]) -> Option<i64> {
    std::str::from_utf8(tok).ok()?.parse::<i64>().ok()
}

/// Parses a non-negative count; also accepts an integral float such as `3.0`.
pub(crate) fn parse_count(tok: &[u8]) -> Option<u64> {
    if let Ok(v) = std::str::from_utf8(tok).ok()?.parse::<u64>() {
        return Some(v);
    }
    let f = parse_f64(tok)?;
    (f.is_finite() && f >= 0.0 && f.fract() == 0.0 && f < 1.8e19).then_some(f as u64)
}

/// A token for an error message: lossy UTF-8, shortened to 40 characters, quoted.
/// A token as text for an error value: lossy UTF-8, at most 40 characters (then "...").
pub(crate) fn clip(tok: &[u8]) -> String {
    let s = String::from_utf8_lossy(tok);
    let short: String = s.chars().take(40).collect();
    if short.len() < s.len() {
        format!("{short}...")
    } else {
        short
    }
}

pub(crate) fn show(tok: &[u8]) -> String {
    let s = String::from_utf8_lossy(tok);
    let short: String = s.chars().take(40).collect();
    if short.len() < s.len() {
        format!("{short:?}...")
    } else {
        format!("{short:?}")
    }
}

/// Formats a float with the fewest digits that read back to the same value; plain notation
/// for ordinary magnitudes and exponent notation for very small or large ones.
pub(crate) struct Float(pub f64);

impl fmt::Display for Float {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let a = self.0.abs();
        if a == 0.0 || !a.is_finite() || (1e-5..1e16).contains(&a) {
            write!(f, "{}", self.0)
        } else {
            write!(f, "{:e}", self.0)
        }
    }
}

/// Upper bound for a capacity hint: never reserve more items than `available` bytes could
/// hold at `min_bytes` each, so a huge declared count cannot exhaust memory.
pub(crate) fn capacity(declared: u64, available: usize, min_bytes: usize) -> usize {
    let cap = (available / min_bytes.max(1)) as u64;
    declared.min(cap) as usize
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn cursor_tracks_lines() {
        let mut c = Cursor::new(b"a b\n\n  e\r\nf\t\nh", 1);
        let mut got = Vec::new();
        while let Some(t) = c.next_token() {
            got.push((String::from_utf8_lossy(t).into_owned(), c.line()));
        }
        let want = [("a", 1), ("b", 1), ("e", 3), ("f", 4), ("h", 5)];
        assert_eq!(got.len(), want.len());
        for (g, w) in got.iter().zip(want) {
            assert_eq!((g.0.as_str(), g.1), w);
        }
    }

    #[test]
    fn float_format_round_trips() {
        for x in [
            0.0,
            -0.0,
            1.0,
            0.1,
            -2.5e-7,
            1e300,
            3.0e-300,
            1.0 / 3.0,
            123456.789,
            f64::MIN_POSITIVE,
        ] {
            let s = Float(x).to_string();
            assert_eq!(s.parse::<f64>().unwrap().to_bits(), x.to_bits(), "{s}");
        }
        assert_eq!(Float(0.5).to_string(), "0.5");
        assert_eq!(Float(1e-7).to_string(), "1e-7");
    }

    #[test]
    fn counts() {
        assert_eq!(parse_count(b"12"), Some(12));
        assert_eq!(parse_count(b"3.0"), Some(3));
        assert_eq!(parse_count(b"-1"), None);
        assert_eq!(parse_count(b"1.5"), None);
        assert_eq!(parse_count(b"nan"), None);
        assert_eq!(capacity(u64::MAX, 100, 10), 10);
    }
}
