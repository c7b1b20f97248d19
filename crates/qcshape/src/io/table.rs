//! CSV tables as qcshape reads them (data set manifests, distance matrices, label files,
//! landmarks, cohort labels): the file read within [`crate::limits::MAX_TABLE_FILE_BYTES`],
//! fields trimmed, lines starting with `#` skipped, a header row, and every problem at its
//! 1-based line. The callers turn a [`TableError`] into their own error type.

use std::path::Path;

use csv::StringRecord;

/// Why a table could not be read.
#[derive(Debug)]
pub(crate) enum TableError {
    /// The file could not be read (missing, not a regular file, too large).
    Read(std::io::Error),
    /// Malformed CSV: the line (0 if unknown) and the message (`malformed CSV: ...`).
    Line(u64, String),
}

impl TableError {
    /// The caller's error: `read` for a file that could not be read, `line` for a line.
    pub(crate) fn into_error<E>(
        self,
        read: impl FnOnce(std::io::Error) -> E,
        line: impl FnOnce(u64, String) -> E,
    ) -> E {
        match self {
            TableError::Read(e) => read(e),
            TableError::Line(n, message) => line(n, message),
        }
    }
}

/// A CSV table after its header.
pub(crate) struct Table {
    /// The header row (empty when the file holds no row at all).
    pub(crate) header: StringRecord,
    /// The header's line (1 when unknown).
    pub(crate) header_line: u64,
    rdr: csv::Reader<std::io::Cursor<Vec<u8>>>,
    /// Each line's first byte and whether the csv reader skips it (empty, or a `#` comment).
    lines: Lines,
}

/// The lines of a file: the csv crate places a record at the start of the empty and comment
/// lines before it and does not count comment lines, so a record's line is found here from its
/// byte offset, past the lines it skips.
struct Lines(Vec<(u64, bool)>);

impl Lines {
    fn new(bytes: &[u8]) -> Lines {
        let mut out = Vec::new();
        let mut start = 0;
        for line in bytes.split_inclusive(|&b| b == b'\n') {
            let text = line.strip_suffix(b"\n").unwrap_or(line);
            let text = text.strip_suffix(b"\r").unwrap_or(text);
            out.push((start, text.is_empty() || text.starts_with(b"#")));
            start += line.len() as u64;
        }
        Lines(out)
    }

    /// The 1-based line of the record that the csv reader places at byte `offset`.
    fn of(&self, offset: u64) -> u64 {
        let mut k = self
            .0
            .partition_point(|&(start, _)| start <= offset)
            .saturating_sub(1);
        while k + 1 < self.0.len() && self.0[k].1 {
            k += 1;
        }
        k as u64 + 1
    }
}

fn malformed(e: &csv::Error, lines: &Lines, default_line: u64) -> TableError {
    let line = e.position().map_or(default_line, |p| lines.of(p.byte()));
    TableError::Line(line, format!("malformed CSV: {e}"))
}

impl Table {
    /// Reads `path` and its header. `flexible`: rows may hold any number of fields (else a
    /// row with another count than the header is malformed).
    pub(crate) fn read(path: &Path, flexible: bool) -> Result<Table, TableError> {
        let bytes = crate::limits::read_regular_file(path, crate::limits::MAX_TABLE_FILE_BYTES)
            .map_err(TableError::Read)?;
        let lines = Lines::new(&bytes);
        let mut rdr = csv::ReaderBuilder::new()
            .has_headers(true)
            .flexible(flexible)
            .trim(csv::Trim::All)
            .comment(Some(b'#'))
            .from_reader(std::io::Cursor::new(bytes));
        let header = rdr.headers().map_err(|e| malformed(&e, &lines, 1))?.clone();
        let header_line = header.position().map_or(1, |p| lines.of(p.byte()));
        Ok(Table {
            header,
            header_line,
            rdr,
            lines,
        })
    }

    /// The position of the header's column `name` (without case), if any.
    pub(crate) fn column(&self, name: &str) -> Option<usize> {
        self.header.iter().position(|h| h.eq_ignore_ascii_case(name))
    }

    /// The rows after the header, each with its line.
    pub(crate) fn rows(&mut self) -> impl Iterator<Item = Result<(u64, StringRecord), TableError>> + '_ {
        let lines = &self.lines;
        self.rdr.records().map(move |rec| {
            let rec = rec.map_err(|e| malformed(&e, lines, 0))?;
            Ok((rec.position().map_or(0, |p| lines.of(p.byte())), rec))
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    /// Lines count every line of the file, comments included (the csv crate's own positions
    /// said 1, 3 and 5 here: at the skipped lines before a record, without the comments).
    #[test]
    fn a_table_is_trimmed_with_comments_and_lines() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("t.csv");
        std::fs::write(&path, "# a comment\n Name , Label \n\na, x\n# more\nb ,y\n").unwrap();
        let mut t = Table::read(&path, false).unwrap();
        let head = (t.header_line, t.column("name"), t.column("LABEL"));
        let rows: Vec<(u64, Vec<String>)> = t
            .rows()
            .map(|r| {
                r.map(|(l, rec)| (l, rec.iter().map(str::to_string).collect()))
                    .unwrap()
            })
            .collect();
        assert_eq!(head, (2, Some(0), Some(1)));
        assert_eq!(
            rows,
            [
                (4, vec!["a".into(), "x".into()]),
                (6, vec!["b".into(), "y".into()])
            ]
        );

        std::fs::write(&path, "name,label\n# c\n\na,x,extra\n").unwrap();
        let err = Table::read(&path, false)
            .unwrap()
            .rows()
            .next()
            .unwrap()
            .unwrap_err();
        assert!(
            matches!(&err, TableError::Line(4, m) if m.starts_with("malformed CSV: ")),
            "{err:?}"
        );
        assert_eq!(Table::read(&path, true).unwrap().rows().count(), 1);

        std::fs::write(&path, "").unwrap();
        assert!(Table::read(&path, true).unwrap().header.is_empty());
        let missing = Table::read(&dir.path().join("none.csv"), true);
        assert!(matches!(missing, Err(TableError::Read(_))));
    }
}
