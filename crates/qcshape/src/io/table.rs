//! CSV tables as qcshape reads them (data set manifests, distance matrices, label files,
//! landmarks, cohort labels): the file read within [`crate::limits::MAX_TABLE_FILE_BYTES`],
//! fields trimmed, lines starting with `#` skipped, a header row, and every problem at its
//! 1-based line, in the caller's own error type ([`TableErrors`]).

use std::path::{Path, PathBuf};

use csv::StringRecord;

/// The csv crate's error, which a table's malformed-CSV problem keeps ([`TableErrors::malformed`]).
pub use csv::Error as CsvError;

/// An error type that a table's problems become.
pub trait TableErrors: Sized {
    /// `path` could not be read (missing, not a regular file, too large).
    fn unreadable(path: &Path, error: std::io::Error) -> Self;
    /// Malformed CSV on `line` of `path` (1-based; 0 if unknown): the csv crate's error, kept.
    fn malformed(path: &Path, line: u64, error: csv::Error) -> Self;
}

/// A CSV table after its header; its problems are `E`s.
pub struct Table<E> {
    /// The header row (empty when the file holds no row at all).
    pub header: StringRecord,
    /// The header's line (1 when unknown).
    pub header_line: u64,
    path: PathBuf,
    rdr: csv::Reader<std::io::Cursor<Vec<u8>>>,
    /// Each line's first byte and whether the csv reader skips it (empty, or a `#` comment).
    lines: Lines,
    errors: std::marker::PhantomData<fn() -> E>,
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

fn malformed<E: TableErrors>(path: &Path, e: csv::Error, lines: &Lines, default_line: u64) -> E {
    let line = e.position().map_or(default_line, |p| lines.of(p.byte()));
    E::malformed(path, line, e)
}

impl<E: TableErrors> Table<E> {
    /// Reads `path` and its header. `flexible`: rows may hold any number of fields (else a
    /// row with another count than the header is malformed).
    pub fn read(path: &Path, flexible: bool) -> Result<Self, E> {
        let bytes = crate::limits::read_regular_file(path, crate::limits::MAX_TABLE_FILE_BYTES)
            .map_err(|e| E::unreadable(path, e))?;
        let lines = Lines::new(&bytes);
        let mut rdr = csv::ReaderBuilder::new()
            .has_headers(true)
            .flexible(flexible)
            .trim(csv::Trim::All)
            .comment(Some(b'#'))
            .from_reader(std::io::Cursor::new(bytes));
        let header = rdr.headers().map_err(|e| malformed(path, e, &lines, 1))?.clone();
        let header_line = header.position().map_or(1, |p| lines.of(p.byte()));
        Ok(Table {
            header,
            header_line,
            path: path.into(),
            rdr,
            lines,
            errors: std::marker::PhantomData,
        })
    }

    /// The position of the header's column `name` (without case), if any.
    pub fn column(&self, name: &str) -> Option<usize> {
        self.header.iter().position(|h| h.eq_ignore_ascii_case(name))
    }

    /// The rows after the header, each with its line.
    pub fn rows(&mut self) -> impl Iterator<Item = Result<(u64, StringRecord), E>> + '_ {
        let (path, lines) = (&self.path, &self.lines);
        self.rdr.records().map(move |rec| {
            let rec = rec.map_err(|e| malformed(path, e, lines, 0))?;
            Ok((rec.position().map_or(0, |p| lines.of(p.byte())), rec))
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Debug)]
    enum TableError {
        Read,
        Line(u64, csv::Error),
    }

    impl TableErrors for TableError {
        fn unreadable(_: &Path, _: std::io::Error) -> Self {
            TableError::Read
        }
        fn malformed(_: &Path, line: u64, error: csv::Error) -> Self {
            TableError::Line(line, error)
        }
    }

    fn read(path: &Path, flexible: bool) -> Result<Table<TableError>, TableError> {
        Table::read(path, flexible)
    }

    /// Lines count every line of the file, comments included (the csv crate's own positions
    /// said 1, 3 and 5 here: at the skipped lines before a record, without the comments).
    #[test]
    fn a_table_is_trimmed_with_comments_and_lines() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("t.csv");
        std::fs::write(&path, "# a comment\n Name , Label \n\na, x\n# more\nb ,y\n").unwrap();
        let mut t = read(&path, false).unwrap();
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
        let err = read(&path, false).unwrap().rows().next().unwrap().unwrap_err();
        assert!(
            matches!(&err, TableError::Line(4, e) if e.to_string().contains("found record with 3 fields")),
            "{err:?}"
        );
        assert_eq!(read(&path, true).unwrap().rows().count(), 1);

        std::fs::write(&path, "").unwrap();
        assert!(read(&path, true).unwrap().header.is_empty());
        let missing = read(&dir.path().join("none.csv"), true);
        assert!(matches!(missing, Err(TableError::Read)));
    }
}
