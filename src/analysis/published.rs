//! Published figures the report compares against (`analysis/published/*.csv`, compiled in).
//!
//! In: a table's text: `#` comment lines (what it is, its source), one header line, then
//! comma-separated rows. Out: each data row's cells. The tables are the project's own files, read
//! at compile time; a row that does not parse is left out by the caller (a unit test of each
//! caller counts its rows).

/// The data rows of a published table, as their cells (trimmed).
pub fn rows(text: &'static str) -> impl Iterator<Item = Vec<&'static str>> {
    text.lines().filter(|l| !l.starts_with('#') && !l.trim().is_empty()).skip(1).map(|l| l.split(',').map(str::trim).collect())
}

#[cfg(test)]
mod tests {
    #[test]
    fn comments_header_and_blank_lines_are_not_rows() {
        let rows: Vec<Vec<&str>> = super::rows("# a table\n# from somewhere\nx,y\n1, 2\n\n3,4\n").collect();
        assert_eq!(rows, [vec!["1", "2"], vec!["3", "4"]]);
    }
}
