//! CSV text through the csv crate, for every table facslab writes (manifests, response exports, the
//! long response format, the codebook): a field is quoted only where it must be (a comma, a quote
//! or a line break in it), quotes are doubled, lines end with `\n`.

/// Appends one record to `out`.
pub fn record<I, T>(out: &mut String, fields: I)
where
    I: IntoIterator<Item = T>,
    T: AsRef<[u8]>,
{
    // A small buffer: the default 8 KiB is made for files, not for one row of an export (longer
    // records still work: the writer flushes into the Vec as its buffer fills).
    let mut writer = csv::WriterBuilder::new().buffer_capacity(256).terminator(csv::Terminator::Any(b'\n')).from_writer(Vec::new());
    // Writing UTF-8 text into memory cannot fail; the fields are `str` bytes, so the result is UTF-8.
    if writer.write_record(fields).is_ok()
        && let Ok(bytes) = writer.into_inner()
    {
        out.push_str(&String::from_utf8_lossy(&bytes));
    }
}

/// One record as a line.
pub fn line<I, T>(fields: I) -> String
where
    I: IntoIterator<Item = T>,
    T: AsRef<[u8]>,
{
    let mut out = String::new();
    record(&mut out, fields);
    out
}

#[cfg(test)]
mod tests {
    use super::line;

    #[test]
    fn fields_are_quoted_only_where_they_must_be() {
        assert_eq!(line(["a", "", "b c"]), "a,,b c\n");
        assert_eq!(line(["x,y", "say \"hi\"", "two\nlines", "cr\r"]), "\"x,y\",\"say \"\"hi\"\"\",\"two\nlines\",\"cr\r\"\n");
        let text = line(["x,y", "q\"", ""]);
        let mut reader = csv::ReaderBuilder::new().has_headers(false).from_reader(text.as_bytes());
        let back: Vec<String> = reader.records().next().unwrap().unwrap().iter().map(String::from).collect();
        assert_eq!(back, ["x,y", "q\"", ""]);
        // A record longer than the writer's buffer.
        let long = "x".repeat(1000);
        assert_eq!(line([long.as_str(), "y,z"]), format!("{long},\"y,z\"\n"));
    }
}
