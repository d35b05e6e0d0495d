//! Errors and table plumbing shared by the response and manifest readers.
//!
//! In: a CSV file, or a Parquet file (`.parquet`, with the `polars` feature). Out: its header and
//! its data rows as text cells, the same for both formats, so validation, results and error
//! messages do not depend on the format.
//!
//! Every error names the file, and where a cell is at fault, the data row (1-based, the header
//! not counted), the file line (for Parquet, the line the row would have in CSV: row + 1), and the
//! column name, so a user can go straight to the cell.

use std::path::{Path, PathBuf};

use super::parquet::ParquetRows;

/// Why an input file could not be used. Nothing is written when any of these occurs.
#[derive(Debug, thiserror::Error)]
pub enum InputError {
    #[error("{file}: cannot read: {source}")]
    Io { file: PathBuf, source: std::io::Error },
    #[error("{file}: cannot write: {source}")]
    Write { file: PathBuf, source: std::io::Error },
    #[error("{file}: not valid CSV at line {line}: {detail}")]
    Csv { file: PathBuf, line: u64, detail: String },
    #[error("{file}: missing column \"{column}\" (the header has: {header})")]
    MissingColumn { file: PathBuf, column: &'static str, header: String },
    #[error("{file}: row {row} (line {line}), column \"{column}\": {problem}")]
    Cell { file: PathBuf, row: u64, line: u64, column: String, problem: String },
    #[error("{file}: no data rows")]
    Empty { file: PathBuf },
    #[error("{file}: not usable as Parquet: {detail}")]
    Parquet { file: PathBuf, detail: String },
    #[error("{file}: Parquet files need facslab built with the `polars` feature (cargo build --release --features polars)")]
    NeedsPolars { file: PathBuf },
    #[error("{file}: {source}")]
    Labels { file: PathBuf, source: crate::stimuli::labels::LabelFileError },
}

/// Whether `path` names a Parquet file (extension `.parquet`, any case); anything else is CSV.
pub fn is_parquet(path: &Path) -> bool {
    path.extension().is_some_and(|e| e.eq_ignore_ascii_case("parquet"))
}

/// A table opened for reading by column name: CSV, or Parquet (by extension).
pub(crate) struct TableInput {
    pub file: PathBuf,
    rows: Rows,
    header: csv::StringRecord,
}

/// Where a table's rows come from; both give rows of text cells.
enum Rows {
    Csv(csv::Reader<Box<dyn std::io::Read>>),
    Parquet(ParquetRows),
}

/// Where a record sits, for error messages.
#[derive(Debug, Clone, Copy)]
pub(crate) struct Place {
    pub row: u64,
    pub line: u64,
}

impl TableInput {
    /// Opens a Parquet file if `path` ends in `.parquet`, else a CSV file.
    pub fn open(path: &Path) -> Result<Self, InputError> {
        if is_parquet(path) {
            let (rows, header) = ParquetRows::open(path)?;
            return Ok(Self { file: path.into(), rows: Rows::Parquet(rows), header: csv::StringRecord::from(header) });
        }
        Self::open_csv(path)
    }

    /// Opens `path` as CSV, whatever its extension.
    pub fn open_csv(path: &Path) -> Result<Self, InputError> {
        let file = std::fs::File::open(path).map_err(|source| InputError::Io { file: path.into(), source })?;
        Self::from_reader(path, Box::new(std::io::BufReader::with_capacity(1 << 20, file)))
    }

    /// Reads CSV from `read` (`path` is used in error messages).
    pub fn from_reader(path: &Path, read: Box<dyn std::io::Read>) -> Result<Self, InputError> {
        let mut reader = csv::ReaderBuilder::new().has_headers(true).flexible(false).from_reader(read);
        let header = reader.headers().map_err(|e| csv_error(path, &e))?.clone();
        Ok(Self { file: path.into(), rows: Rows::Csv(reader), header })
    }

    /// The header's column names.
    pub fn header_names(&self) -> Vec<String> {
        self.header.iter().map(str::to_owned).collect()
    }

    /// The index of a required column.
    pub fn column(&self, column: &'static str) -> Result<usize, InputError> {
        self.header.iter().position(|h| h.trim() == column).ok_or_else(|| InputError::MissingColumn {
            file: self.file.clone(),
            column,
            header: self.header.iter().collect::<Vec<_>>().join(","),
        })
    }

    /// Calls `each` for every data row with its place; stops at the first error. A cell that
    /// is not UTF-8 is an error naming its row and column.
    pub fn for_each(
        &mut self,
        mut each: impl FnMut(&csv::StringRecord, Place) -> Result<(), InputError>,
    ) -> Result<u64, InputError> {
        let (file, header) = (self.file.clone(), self.header.clone());
        self.for_each_bytes_mut(|bytes, place| {
            let text = csv::StringRecord::from_byte_record(std::mem::take(bytes)).map_err(|e| {
                let column = e.utf8_error().field();
                InputError::Cell {
                    file: file.clone(),
                    row: place.row,
                    line: place.line,
                    column: header.get(column).unwrap_or("?").to_string(),
                    problem: "not valid UTF-8".into(),
                }
            })?;
            let result = each(&text, place);
            // The record's buffers are reused for the next row.
            *bytes = text.into_byte_record();
            result
        })
    }

    /// Like [`Self::for_each`], over raw bytes (no per-row UTF-8 check or allocation); the
    /// caller checks the cells it uses with [`Fields`].
    pub fn for_each_bytes(
        &mut self,
        mut each: impl FnMut(&csv::ByteRecord, Place) -> Result<(), InputError>,
    ) -> Result<u64, InputError> {
        self.for_each_bytes_mut(|record, place| each(record, place))
    }

    /// The one row loop of both formats: numbers the rows, and refuses a table without any.
    fn for_each_bytes_mut(
        &mut self,
        mut each: impl FnMut(&mut csv::ByteRecord, Place) -> Result<(), InputError>,
    ) -> Result<u64, InputError> {
        let mut record = csv::ByteRecord::new();
        let mut row = 0;
        while self.next_record(&mut record)? {
            row += 1;
            // A CSV record knows its line (quoted cells can span lines); a Parquet row is
            // placed as if under a header line.
            let line = record.position().map_or(row + 1, |p| p.line());
            each(&mut record, Place { row, line })?;
        }
        if row == 0 {
            return Err(InputError::Empty { file: self.file.clone() });
        }
        Ok(row)
    }

    /// Reads the next row into `record`; false at the end.
    fn next_record(&mut self, record: &mut csv::ByteRecord) -> Result<bool, InputError> {
        match &mut self.rows {
            Rows::Csv(reader) => reader.read_byte_record(record).map_err(|e| csv_error(&self.file, &e)),
            Rows::Parquet(rows) => rows.next_record(record),
        }
    }

    /// An error about one cell.
    pub fn cell(&self, place: Place, column: &str, problem: impl Into<String>) -> InputError {
        InputError::Cell {
            file: self.file.clone(),
            row: place.row,
            line: place.line,
            column: column.to_string(),
            problem: problem.into(),
        }
    }
}

/// A byte record's cells as trimmed text, after one UTF-8 check of the whole record (rather than
/// one per cell, or a copy into a `StringRecord`).
pub(crate) struct Fields<'r> {
    text: &'r str,
    record: &'r csv::ByteRecord,
}

impl<'r> Fields<'r> {
    /// The record's cells, or the index of the first cell that is not UTF-8.
    pub fn new(record: &'r csv::ByteRecord) -> Result<Self, usize> {
        match std::str::from_utf8(record.as_slice()) {
            Ok(text) => Ok(Fields { text, record }),
            Err(_) => Err((0..record.len()).find(|&i| std::str::from_utf8(&record[i]).is_err()).unwrap_or(0)),
        }
    }

    /// Cell `index`, trimmed.
    ///
    /// # Panics
    /// If `index` is out of range (callers use indices of header columns; rows have the
    /// header's length because the reader is not flexible).
    pub fn get(&self, index: usize) -> &'r str {
        self.text[self.record.range(index).expect("cell index within the header")].trim()
    }
}

/// FxHash (the rustc hasher): a multiply-rotate hash, much faster than SipHash on the short
/// keys of a response file (ids, packed indices). Not DoS-resistant, which a local analysis of
/// the user's own files does not need.
#[derive(Default, Clone, Copy)]
pub(crate) struct FxHasher(u64);

const FX_SEED: u64 = 0x51_7c_c1_b7_27_22_0a_95;

impl FxHasher {
    #[inline]
    fn add(&mut self, word: u64) {
        self.0 = (self.0.rotate_left(5) ^ word).wrapping_mul(FX_SEED);
    }
}

impl std::hash::Hasher for FxHasher {
    #[inline]
    fn write(&mut self, bytes: &[u8]) {
        let mut chunks = bytes.chunks_exact(8);
        for c in &mut chunks {
            self.add(u64::from_le_bytes(c.try_into().expect("8 bytes")));
        }
        let rest = chunks.remainder();
        if !rest.is_empty() {
            let mut buf = [0u8; 8];
            buf[..rest.len()].copy_from_slice(rest);
            self.add(u64::from_le_bytes(buf));
        }
    }

    #[inline]
    fn write_u8(&mut self, i: u8) {
        self.add(u64::from(i));
    }

    #[inline]
    fn write_u32(&mut self, i: u32) {
        self.add(u64::from(i));
    }

    #[inline]
    fn write_u64(&mut self, i: u64) {
        self.add(i);
    }

    #[inline]
    fn write_usize(&mut self, i: usize) {
        self.add(i as u64);
    }

    #[inline]
    fn finish(&self) -> u64 {
        self.0
    }
}

/// A `HashMap` with [`FxHasher`].
pub(crate) type FxHashMap<K, V> = std::collections::HashMap<K, V, std::hash::BuildHasherDefault<FxHasher>>;

fn csv_error(path: &Path, e: &csv::Error) -> InputError {
    let line = e.position().map_or(0, |p| p.line());
    InputError::Csv { file: path.into(), line, detail: e.to_string() }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn table(bytes: &[u8]) -> TableInput {
        TableInput::from_reader(Path::new("t.csv"), Box::new(std::io::Cursor::new(bytes.to_vec()))).expect("header")
    }

    #[test]
    fn text_rows_are_numbered_and_a_bad_cell_is_named() {
        let mut seen = Vec::new();
        let rows = table(b"a,b\n1,\"x\ny\"\n2,z\n").for_each(|r, place| {
            seen.push((r[1].to_string(), place.row, place.line));
            Ok(())
        });
        assert_eq!(rows.expect("rows"), 2);
        assert_eq!(seen, [("x\ny".to_string(), 1, 2), ("z".to_string(), 2, 4)]);
        let e = table(b"a,b\n1,2\n3,\xff\n").for_each(|_, _| Ok(())).expect_err("not UTF-8").to_string();
        assert_eq!(e, "t.csv: row 2 (line 3), column \"b\": not valid UTF-8");
        let e = table(b"a,b\n").for_each(|_, _| Ok(())).expect_err("no rows").to_string();
        assert_eq!(e, "t.csv: no data rows");
    }

    #[test]
    fn parquet_is_told_by_the_extension() {
        assert!(is_parquet(Path::new("dir/r.parquet")) && is_parquet(Path::new("R.PARQUET")));
        assert!(!is_parquet(Path::new("r.csv")) && !is_parquet(Path::new("parquet")) && !is_parquet(Path::new("r.parquet.csv")));
    }
}
