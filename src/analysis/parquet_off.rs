//! Parquet without the `polars` feature: the same interface as `parquet.rs`, where every
//! function says how to get a facslab that reads and writes Parquet.

use std::path::Path;

use super::input::InputError;

/// No Parquet rows can exist in this build.
pub(crate) enum ParquetRows {}

impl ParquetRows {
    pub fn open(path: &Path) -> Result<(ParquetRows, Vec<String>), InputError> {
        Err(InputError::NeedsPolars { file: path.into() })
    }

    pub fn next_record(&mut self, _record: &mut csv::ByteRecord) -> Result<bool, InputError> {
        match *self {}
    }
}

pub fn csv_to_parquet(_input: &Path, output: &Path) -> Result<u64, InputError> {
    Err(InputError::NeedsPolars { file: output.into() })
}

pub fn parquet_to_csv(input: &Path, _output: &Path) -> Result<u64, InputError> {
    Err(InputError::NeedsPolars { file: input.into() })
}

#[cfg(test)]
mod tests {
    #[test]
    fn parquet_input_says_to_rebuild_with_the_feature() {
        let catalog = crate::facs::Catalog::built_in();
        let e = crate::analysis::manifest::Manifest::read(std::path::Path::new("m.parquet"), catalog).unwrap_err();
        assert_eq!(
            e.to_string(),
            "m.parquet: Parquet files need facslab built with the `polars` feature (cargo build --release --features polars)"
        );
    }
}
