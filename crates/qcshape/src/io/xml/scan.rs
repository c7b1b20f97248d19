//! A minimal XML scanner for VTK XML files: start and end tags with attributes, text runs.

use crate::io::syntax::SyntaxError;
use crate::io::ParseError;

/// Line (1-based) of byte `pos`.
pub(super) fn line_of(bytes: &[u8], pos: usize) -> usize {
    1 + bytes[..pos.min(bytes.len())]
        .iter()
        .filter(|&&b| b == b'\n')
        .count()
}

pub(super) fn syntax(bytes: &[u8], pos: usize, problem: SyntaxError) -> ParseError {
    ParseError::Syntax {
        line: line_of(bytes, pos),
        problem,
    }
}

/// One start tag: its name, attributes, whether it is self-closing, and where it starts.
#[derive(Debug)]
pub(super) struct Tag<'a> {
    pub(super) name: &'a [u8],
    pub(super) attrs: Vec<(&'a [u8], &'a [u8])>,
    pub(super) empty: bool,
    pub(super) pos: usize,
}

impl Tag<'_> {
    pub(super) fn attr(&self, key: &str) -> Option<&[u8]> {
        self.attrs
            .iter()
            .find(|(k, _)| *k == key.as_bytes())
            .map(|(_, v)| *v)
    }
    pub(super) fn attr_str(&self, key: &str) -> Option<String> {
        self.attr(key).map(|v| String::from_utf8_lossy(v).into_owned())
    }
}

/// Markup events.
pub(super) enum Event<'a> {
    Start(Tag<'a>),
    End(&'a [u8]),
    Text(usize, usize),
}

/// One scanner step.
enum Step<'a> {
    Event(Event<'a>),
    Skip,
    End,
}

/// A minimal XML scanner: start/end tags with attributes, text runs; skips the declaration,
/// comments, processing instructions and CDATA-free doctype lines.
pub(super) struct Scanner<'a> {
    pub(super) b: &'a [u8],
    pub(super) pos: usize,
}

impl<'a> Scanner<'a> {
    pub(super) fn next(&mut self) -> Result<Option<Event<'a>>, ParseError> {
        loop {
            match self.step()? {
                Step::Skip => continue,
                Step::Event(e) => return Ok(Some(e)),
                Step::End => return Ok(None),
            }
        }
    }

    fn step(&mut self) -> Result<Step<'a>, ParseError> {
        let b = self.b;
        if self.pos >= b.len() {
            return Ok(Step::End);
        }
        if b[self.pos] != b'<' {
            let start = self.pos;
            let end = b[start..]
                .iter()
                .position(|&c| c == b'<')
                .map_or(b.len(), |k| start + k);
            self.pos = end;
            return Ok(Step::Event(Event::Text(start, end)));
        }
        let start = self.pos;
        let find = |from: usize, pat: &[u8]| -> Option<usize> {
            b.get(from..)?
                .windows(pat.len())
                .position(|w| w == pat)
                .map(|k| from + k)
        };
        if b[start..].starts_with(b"<!--") {
            let end = find(start + 4, b"-->")
                .ok_or_else(|| syntax(b, start, SyntaxError::Unclosed { what: "a comment" }))?;
            self.pos = end + 3;
            return Ok(Step::Skip);
        }
        if b[start..].starts_with(b"<?") || b[start..].starts_with(b"<!") {
            let end = find(start + 2, b">")
                .ok_or_else(|| syntax(b, start, SyntaxError::Unclosed { what: "a tag" }))?;
            self.pos = end + 1;
            return Ok(Step::Skip);
        }
        let end =
            find(start + 1, b">").ok_or_else(|| syntax(b, start, SyntaxError::Unclosed { what: "a tag" }))?;
        self.pos = end + 1;
        let inner = &b[start + 1..end];
        if let Some(name) = inner.strip_prefix(b"/") {
            return Ok(Step::Event(Event::End(name.trim_ascii())));
        }
        let (inner, empty) = match inner.strip_suffix(b"/") {
            Some(i) => (i, true),
            None => (inner, false),
        };
        let name_end = inner
            .iter()
            .position(|c| c.is_ascii_whitespace())
            .unwrap_or(inner.len());
        let name = &inner[..name_end];
        if name.is_empty() {
            return Err(syntax(b, start, SyntaxError::NoName));
        }
        let mut attrs = Vec::new();
        let mut i = name_end;
        loop {
            while i < inner.len() && inner[i].is_ascii_whitespace() {
                i += 1;
            }
            if i >= inner.len() {
                break;
            }
            let k0 = i;
            while i < inner.len() && inner[i] != b'=' && !inner[i].is_ascii_whitespace() {
                i += 1;
            }
            let key = &inner[k0..i];
            while i < inner.len() && inner[i].is_ascii_whitespace() {
                i += 1;
            }
            if inner.get(i) != Some(&b'=') {
                return Err(syntax(
                    b,
                    start,
                    SyntaxError::NoValue {
                        attribute: String::from_utf8_lossy(key).into_owned(),
                    },
                ));
            }
            i += 1;
            while i < inner.len() && inner[i].is_ascii_whitespace() {
                i += 1;
            }
            let q = *inner.get(i).unwrap_or(&0);
            if q != b'"' && q != b'\'' {
                return Err(syntax(
                    b,
                    start,
                    SyntaxError::Unquoted {
                        attribute: String::from_utf8_lossy(key).into_owned(),
                    },
                ));
            }
            let v0 = i + 1;
            let v1 = inner[v0..]
                .iter()
                .position(|&c| c == q)
                .map(|k| v0 + k)
                .ok_or_else(|| {
                    syntax(
                        b,
                        start,
                        SyntaxError::Unclosed {
                            what: "an attribute value",
                        },
                    )
                })?;
            attrs.push((key, &inner[v0..v1]));
            i = v1 + 1;
        }
        Ok(Step::Event(Event::Start(Tag {
            name,
            attrs,
            empty,
            pos: start,
        })))
    }
}
