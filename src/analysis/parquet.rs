//! Parquet import and export (the `polars` feature).
//!
//! In: a Parquet file (written by facslab, pandas, polars, Arrow …) or a CSV table. Out: the
//! Parquet file's rows as text cells for [`super::input::TableInput`], or the table converted to
//! the other format on disk (`facslab convert`).
//!
//! **Reading.** Every cell becomes the text a CSV file would hold: strings as they are, integers
//! and floats in Rust's shortest decimal form (`3`, `0.5`, `1200`), other types as polars casts
//! them to strings (`true`), nulls and NaN as empty cells. The analysis reads these rows through
//! the same interface as CSV rows, so results and error messages are the same for both formats.
//! Row groups are read one at a time, so memory follows the largest row group, not the file.
//!
//! **Writing.** A CSV column becomes Int64 when every non-empty cell is an integer written the
//! way Rust writes it (`42`, `-7`; not `007` or `+7`), Float64 when every non-empty cell is a
//! finite number written the way Rust writes it (`0.5`, `1200`; not `1e3` or `0.50`), and String
//! otherwise; empty cells become nulls. So converting back gives every cell exactly. The CSV is
//! read twice (column types, then values) and written in row groups of [`ROW_GROUP`] rows, so
//! memory stays flat however large the file.

use std::fmt::Display;
use std::fs::File;
use std::path::{Path, PathBuf};

use polars::prelude::*;

use super::input::{InputError, Place, TableInput};

/// Rows per Parquet row group written by [`csv_to_parquet`].
pub const ROW_GROUP: usize = 1 << 17;

fn parquet_error(file: &Path, e: impl Display) -> InputError {
    InputError::Parquet { file: file.into(), detail: e.to_string() }
}

/// The rows of a Parquet file as text records, read one row group at a time.
pub(crate) struct ParquetRows {
    path: PathBuf,
    file: File,
    metadata: FileMetadataRef,
    /// First row and row count of each row group not read yet.
    groups: std::vec::IntoIter<(usize, usize)>,
    /// The row group being given out.
    columns: Vec<TextColumn>,
    height: usize,
    next: usize,
    cell: Vec<u8>,
}

impl ParquetRows {
    /// Opens `path` and reads its footer; returns the rows and the column names.
    pub fn open(path: &Path) -> Result<(ParquetRows, Vec<String>), InputError> {
        let mut file = File::open(path).map_err(|source| InputError::Io { file: path.into(), source })?;
        let mut reader = ParquetReader::new(&mut file);
        let header = reader.schema().map_err(|e| parquet_error(path, e))?.iter_names().map(|n| n.to_string()).collect();
        let metadata = reader.get_metadata().map_err(|e| parquet_error(path, e))?.clone();
        let groups: Vec<(usize, usize)> = metadata
            .row_groups
            .iter()
            .scan(0, |first, group| {
                let start = *first;
                *first += group.num_rows();
                Some((start, group.num_rows()))
            })
            .collect();
        let rows = ParquetRows {
            path: path.into(),
            file,
            metadata,
            groups: groups.into_iter(),
            columns: Vec::new(),
            height: 0,
            next: 0,
            cell: Vec::new(),
        };
        Ok((rows, header))
    }

    /// Reads the row group of `rows` rows from row `first` on.
    fn read_group(&mut self, (first, rows): (usize, usize)) -> Result<(), InputError> {
        let mut reader = ParquetReader::new(&mut self.file).with_slice(Some((first, rows)));
        reader.set_metadata(self.metadata.clone());
        let df = reader.finish().map_err(|e| parquet_error(&self.path, e))?;
        self.columns = df.columns().iter().map(|c| TextColumn::new(&self.path, c)).collect::<Result<_, _>>()?;
        (self.height, self.next) = (df.height(), 0);
        Ok(())
    }

    /// Fills `record` with the next row; false at the end.
    pub fn next_record(&mut self, record: &mut csv::ByteRecord) -> Result<bool, InputError> {
        while self.next >= self.height {
            match self.groups.next() {
                Some(group) => self.read_group(group)?,
                None => return Ok(false),
            }
        }
        record.clear();
        for column in &self.columns {
            self.cell.clear();
            column.write(self.next, &mut self.cell);
            record.push_field(&self.cell);
        }
        self.next += 1;
        Ok(true)
    }
}

/// One Parquet column, read as text cells.
enum TextColumn {
    Str(StringChunked),
    Int(Int64Chunked),
    UInt(UInt64Chunked),
    F32(Float32Chunked),
    F64(Float64Chunked),
}

impl TextColumn {
    fn new(file: &Path, column: &Column) -> Result<TextColumn, InputError> {
        let series = column.as_materialized_series().rechunk();
        let err = |e: PolarsError| parquet_error(file, format!("column \"{}\": {e}", column.name()));
        let dtype = series.dtype();
        Ok(if dtype.is_signed_integer() {
            TextColumn::Int(series.cast(&DataType::Int64).map_err(err)?.i64().map_err(err)?.clone())
        } else if dtype.is_unsigned_integer() {
            TextColumn::UInt(series.cast(&DataType::UInt64).map_err(err)?.u64().map_err(err)?.clone())
        } else if *dtype == DataType::Float32 {
            TextColumn::F32(series.f32().map_err(err)?.clone())
        } else if dtype.is_float() {
            TextColumn::F64(series.cast(&DataType::Float64).map_err(err)?.f64().map_err(err)?.clone())
        } else {
            TextColumn::Str(series.cast(&DataType::String).map_err(err)?.str().map_err(err)?.clone())
        })
    }

    /// Appends cell `row` as text to `out` (nothing for a null or NaN).
    fn write(&self, row: usize, out: &mut Vec<u8>) {
        match self {
            TextColumn::Str(c) => out.extend_from_slice(c.get(row).unwrap_or("").as_bytes()),
            TextColumn::Int(c) => push_number(out, c.get(row)),
            TextColumn::UInt(c) => push_number(out, c.get(row)),
            TextColumn::F32(c) => push_number(out, c.get(row).filter(|v| !v.is_nan())),
            TextColumn::F64(c) => push_number(out, c.get(row).filter(|v| !v.is_nan())),
        }
    }
}

fn push_number(out: &mut Vec<u8>, value: Option<impl Display>) {
    use std::io::Write;
    if let Some(v) = value {
        // Writing into a Vec cannot fail.
        let _ = write!(out, "{v}");
    }
}

/// How a CSV column is stored in Parquet (see the module doc).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Kind {
    Int,
    Float,
    Text,
}

impl Kind {
    fn dtype(self) -> DataType {
        match self {
            Kind::Int => DataType::Int64,
            Kind::Float => DataType::Float64,
            Kind::Text => DataType::String,
        }
    }
}

/// What the cells of one column seen so far allow.
#[derive(Debug, Clone, Copy)]
struct KindScan {
    int: bool,
    float: bool,
    any: bool,
}

impl Default for KindScan {
    fn default() -> Self {
        KindScan { int: true, float: true, any: false }
    }
}

impl KindScan {
    fn see(&mut self, cell: &str) {
        if cell.is_empty() {
            return;
        }
        self.any = true;
        self.int = self.int && cell.parse::<i64>().is_ok_and(|v| writes_as(v, cell));
        self.float = self.float && cell.parse::<f64>().is_ok_and(|v| v.is_finite() && writes_as(v, cell));
    }

    fn kind(self) -> Kind {
        match self {
            KindScan { any: false, .. } => Kind::Text,
            KindScan { int: true, .. } => Kind::Int,
            KindScan { float: true, .. } => Kind::Float,
            _ => Kind::Text,
        }
    }
}

/// Whether `value` is written back as exactly `cell`.
fn writes_as(value: impl Display, cell: &str) -> bool {
    value.to_string() == cell
}

/// The column types of a CSV table (first pass of [`csv_to_parquet`]).
fn scan_kinds(input: &Path) -> Result<Vec<Kind>, InputError> {
    let mut table = TableInput::open_csv(input)?;
    let mut scans = vec![KindScan::default(); table.header_names().len()];
    table.for_each(|record, _| {
        for (scan, cell) in scans.iter_mut().zip(record) {
            scan.see(cell);
        }
        Ok(())
    })?;
    Ok(scans.into_iter().map(KindScan::kind).collect())
}

/// One column of a row group being built.
enum Builder {
    Int(PrimitiveChunkedBuilder<Int64Type>),
    Float(PrimitiveChunkedBuilder<Float64Type>),
    Text(StringChunkedBuilder),
}

impl Builder {
    fn new(kind: Kind, name: &str) -> Builder {
        let name = PlSmallStr::from(name);
        match kind {
            Kind::Int => Builder::Int(PrimitiveChunkedBuilder::new(name, ROW_GROUP)),
            Kind::Float => Builder::Float(PrimitiveChunkedBuilder::new(name, ROW_GROUP)),
            Kind::Text => Builder::Text(StringChunkedBuilder::new(name, ROW_GROUP)),
        }
    }

    /// Appends a cell; false if it does not fit the column's type (the file changed since the
    /// first pass).
    fn push(&mut self, cell: &str) -> bool {
        match (self, cell.is_empty()) {
            (Builder::Int(b), true) => b.append_null(),
            (Builder::Float(b), true) => b.append_null(),
            (Builder::Text(b), true) => b.append_null(),
            (Builder::Int(b), false) => match cell.parse() {
                Ok(v) => b.append_value(v),
                Err(_) => return false,
            },
            (Builder::Float(b), false) => match cell.parse() {
                Ok(v) => b.append_value(v),
                Err(_) => return false,
            },
            (Builder::Text(b), false) => b.append_value(cell),
        }
        true
    }

    fn finish(self) -> Column {
        match self {
            Builder::Int(b) => b.finish().into_column(),
            Builder::Float(b) => b.finish().into_column(),
            Builder::Text(b) => b.finish().into_column(),
        }
    }
}

/// The row group being built from CSV records.
struct RowGroup<'a> {
    names: &'a [String],
    kinds: &'a [Kind],
    columns: Vec<Builder>,
    rows: usize,
}

impl<'a> RowGroup<'a> {
    fn new(names: &'a [String], kinds: &'a [Kind]) -> RowGroup<'a> {
        let columns = kinds.iter().zip(names).map(|(&k, n)| Builder::new(k, n)).collect();
        RowGroup { names, kinds, columns, rows: 0 }
    }

    /// Appends a record; the error names the first cell that does not fit its column.
    fn push(&mut self, record: &csv::StringRecord) -> Result<(), usize> {
        for (i, (column, cell)) in self.columns.iter_mut().zip(record).enumerate() {
            if !column.push(cell) {
                return Err(i);
            }
        }
        self.rows += 1;
        Ok(())
    }

    /// The rows so far as a data frame; the group starts again empty.
    fn take(&mut self) -> PolarsResult<DataFrame> {
        let empty = RowGroup::new(self.names, self.kinds);
        let columns = std::mem::replace(self, empty).columns;
        DataFrame::new_infer_height(columns.into_iter().map(Builder::finish).collect())
    }
}

/// Writes a CSV table as Parquet (column types as in the module doc); returns the rows written.
/// Nothing is left at `output` if it fails.
pub fn csv_to_parquet(input: &Path, output: &Path) -> Result<u64, InputError> {
    let kinds = scan_kinds(input)?;
    let mut table = TableInput::open_csv(input)?;
    let names = table.header_names();
    let schema: Schema = names.iter().zip(&kinds).map(|(n, k)| Field::new(n.as_str().into(), k.dtype())).collect();
    write_atomically(output, |file| {
        let out_err = |e: PolarsError| parquet_error(output, e);
        let mut writer = ParquetWriter::new(file).batched(&schema).map_err(out_err)?;
        let mut group = RowGroup::new(&names, &kinds);
        let rows = table.for_each(|record, place: Place| {
            group.push(record).map_err(|i| InputError::Cell {
                file: input.into(),
                row: place.row,
                line: place.line,
                column: names[i].clone(),
                problem: format!("\"{}\" does not match the column's type: the file changed while it was converted", &record[i]),
            })?;
            if group.rows == ROW_GROUP {
                writer.write_batch(&group.take().map_err(out_err)?).map_err(out_err)?;
            }
            Ok(())
        })?;
        if group.rows > 0 {
            writer.write_batch(&group.take().map_err(out_err)?).map_err(out_err)?;
        }
        writer.finish().map_err(out_err)?;
        Ok(rows)
    })
}

/// Writes a Parquet table as CSV (every column; nulls as empty cells); returns the rows
/// written. Nothing is left at `output` if it fails.
pub fn parquet_to_csv(input: &Path, output: &Path) -> Result<u64, InputError> {
    let mut table = TableInput::open(input)?;
    write_atomically(output, |file| {
        let write_err = |e: csv::Error| InputError::Write { file: output.into(), source: e.into() };
        let mut writer = csv::Writer::from_writer(std::io::BufWriter::new(file));
        writer.write_record(table.header_names()).map_err(write_err)?;
        let rows = table.for_each_bytes(|record, _| writer.write_byte_record(record).map_err(write_err))?;
        writer.flush().map_err(|source| InputError::Write { file: output.into(), source })?;
        Ok(rows)
    })
}

/// Runs `write` on a staging file beside `output`, renamed to `output` only if it succeeds.
fn write_atomically<T>(output: &Path, write: impl FnOnce(File) -> Result<T, InputError>) -> Result<T, InputError> {
    let name = output.file_name().map_or_else(|| "output".into(), |n| n.to_string_lossy().into_owned());
    let staging = output.with_file_name(format!(".{name}.partial"));
    let write_err = |source| InputError::Write { file: output.into(), source };
    let file = File::create(&staging).map_err(write_err)?;
    let result = write(file).and_then(|value| std::fs::rename(&staging, output).map(|()| value).map_err(write_err));
    if result.is_err() {
        // Best effort: the staging file is ours, and the error that matters is the one above.
        let _ = std::fs::remove_file(&staging);
    }
    result
}

#[cfg(test)]
mod tests {
    use super::*;

    fn kind_of(cells: &[&str]) -> Kind {
        let mut scan = KindScan::default();
        cells.iter().for_each(|c| scan.see(c));
        scan.kind()
    }

    #[test]
    fn columns_get_a_number_type_only_when_every_cell_comes_back_the_same() {
        assert_eq!(kind_of(&["1", "", "-7", "120"]), Kind::Int);
        assert_eq!(kind_of(&["1", "0.5", "", "1200"]), Kind::Float);
        assert_eq!(kind_of(&["-0"]), Kind::Float);
        for text in [&["007"][..], &["+7"], &["1e3"], &["0.50"], &["NaN"], &["inf"], &["1", " 2"], &["9007199254740993", "0.5"], &["a", "1"]] {
            assert_eq!(kind_of(text), Kind::Text, "{text:?}");
        }
        assert_eq!(kind_of(&["", ""]), Kind::Text);
    }

    /// Writes `csv`, converts it to Parquet and back, and returns the Parquet file's column
    /// types and the CSV written back.
    fn round_trip(csv: &str) -> (Vec<DataType>, String) {
        let dir = tempfile::tempdir().expect("temporary directory");
        let (a, p, b) = (dir.path().join("a.csv"), dir.path().join("t.parquet"), dir.path().join("b.csv"));
        std::fs::write(&a, csv).expect("write the CSV");
        assert_eq!(csv_to_parquet(&a, &p).expect("to Parquet"), csv.lines().count() as u64 - 1);
        let df = ParquetReader::new(File::open(&p).expect("open")).finish().expect("read back");
        parquet_to_csv(&p, &b).expect("to CSV");
        assert!(!dir.path().join(".b.csv.partial").exists() && !dir.path().join(".t.parquet.partial").exists());
        (df.dtypes(), std::fs::read_to_string(&b).expect("read the CSV"))
    }

    #[test]
    fn csv_to_parquet_and_back_keeps_every_cell() {
        let csv = "id,n,x,label,big\n\
                   s1,1,0.5,\"a, \"\"quoted\"\" cell\",9007199254740993\n\
                   s2,,1200,é,1\n\
                   s3,-7,-0.125,,2\n";
        let (dtypes, back) = round_trip(csv);
        assert_eq!(dtypes, [DataType::String, DataType::Int64, DataType::Float64, DataType::String, DataType::Int64]);
        assert_eq!(back, csv);
    }

    #[test]
    fn parquet_cells_read_as_csv_text_row_group_by_row_group() {
        let dir = tempfile::tempdir().expect("temporary directory");
        let path = dir.path().join("t.parquet");
        let df = DataFrame::new_infer_height(vec![
            Column::new("f32".into(), [Some(0.1f32), None, Some(f32::NAN)]),
            Column::new("f64".into(), [Some(3.0f64), Some(0.25), None]),
            Column::new("u32".into(), [Some(7u32), None, Some(255)]),
            Column::new("flag".into(), [Some(true), Some(false), None]),
        ])
        .expect("frame");
        // Two row groups, read one after the other.
        let mut writer = ParquetWriter::new(File::create(&path).expect("create")).batched(df.schema()).expect("writer");
        writer.write_batch(&df.slice(0, 2)).expect("first row group");
        writer.write_batch(&df.slice(2, 1)).expect("second row group");
        writer.finish().expect("footer");
        let (mut rows, header) = ParquetRows::open(&path).expect("open");
        assert_eq!(header, ["f32", "f64", "u32", "flag"]);
        assert_eq!(rows.groups.as_slice(), [(0, 2), (2, 1)]);
        let mut record = csv::ByteRecord::new();
        let mut seen = Vec::new();
        while rows.next_record(&mut record).expect("row") {
            seen.push(record.iter().map(|c| String::from_utf8_lossy(c).into_owned()).collect::<Vec<_>>());
        }
        assert_eq!(seen, [["0.1", "3", "7", "true"], ["", "0.25", "", "false"], ["", "", "255", ""]]);
    }

    #[test]
    fn a_file_that_is_not_parquet_is_named_and_nothing_is_written() {
        let dir = tempfile::tempdir().expect("temporary directory");
        let (p, out) = (dir.path().join("x.parquet"), dir.path().join("x.csv"));
        std::fs::write(&p, "a,b\n1,2\n").expect("write");
        let e = parquet_to_csv(&p, &out).expect_err("not Parquet").to_string();
        assert!(e.starts_with(&format!("{}: not usable as Parquet: ", p.display())), "{e}");
        assert!(std::fs::read_dir(dir.path()).expect("list").count() == 1, "only the input is left");
    }
}
