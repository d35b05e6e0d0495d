//! Parquet input (the `polars` feature).
//!
//! In: a Parquet file (written by facslab, pandas, polars, Arrow …). Out: its rows as text cells
//! for [`super::input::TableInput`].
//!
//! Every cell becomes the text a CSV file would hold: strings as they are, integers and floats in
//! Rust's shortest decimal form (`3`, `0.5`, `1200`), other types as polars casts them to strings
//! (`true`), nulls and NaN as empty cells. The analysis reads these rows through the same
//! interface as CSV rows, so results and error messages are the same for both formats. Row
//! groups are read one at a time, so memory follows the largest row group, not the file.

use std::fmt::Display;
use std::fs::File;
use std::path::{Path, PathBuf};

use polars::prelude::*;

use super::input::InputError;

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

#[cfg(test)]
mod tests {
    use super::*;

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
}
