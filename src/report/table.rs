//! The table model: every table of the report is built into a [`Table`] once, and both its CSV
//! file and its table on `report.html` are written from that one value.
//!
//! In: named fields (the CSV header) and rows of typed [`Cell`]s, with a [`View`] saying how the
//! page shows them. Out: the CSV bytes ([`Table::csv`]: every field, numbers at full `f64`
//! precision, an undefined value empty) and a [`PageTable`] ([`Table::page`]: the view's columns,
//! numbers rounded to each cell's decimals, plain text for the template to escape).
//! **Invariants:** a row is in both outputs unless it is marked for one ([`On`]); a row has one
//! cell per field (the CSV writer refuses anything else); a page column names only fields of its
//! table (an unknown name is an error, not an empty cell).

use serde::Serialize;

use super::ReportError;
use crate::analysis::coding::Maybe;

/// One value of a table.
#[derive(Debug, Clone, PartialEq)]
pub enum Cell {
    /// Text from the data, or a label.
    Text(String),
    /// A count.
    Count(u64),
    /// A number; the page rounds it to `decimals`.
    Num { value: f64, decimals: usize },
    /// A proportion in [0, 1]; the page shows it in percent, rounded to `decimals`.
    Rate { value: f64, decimals: usize },
    /// A p-value; the page shows `< .001` or three decimals.
    P(f64),
    /// A statistic that is undefined on the data: empty in the CSV, `–` on the page.
    Missing,
    /// Nothing belongs here (a total row's counts, a residual's F): empty in both.
    Empty,
}

impl Cell {
    pub fn text(text: impl Into<String>) -> Cell {
        Cell::Text(text.into())
    }

    pub fn count(n: impl TryInto<u64>) -> Cell {
        n.try_into().map_or(Cell::Missing, Cell::Count)
    }

    pub fn num(value: f64, decimals: usize) -> Cell {
        Cell::Num { value, decimals }
    }

    /// A number, or [`Cell::Missing`] when there is none.
    pub fn opt(value: Option<f64>, decimals: usize) -> Cell {
        value.map_or(Cell::Missing, |v| Cell::num(v, decimals))
    }

    /// A number, or [`Cell::Empty`] when none belongs here.
    pub fn opt_or_empty(value: Option<f64>, decimals: usize) -> Cell {
        value.map_or(Cell::Empty, |v| Cell::num(v, decimals))
    }

    pub fn maybe(m: &Maybe, decimals: usize) -> Cell {
        Cell::opt(m.value, decimals)
    }

    /// The CSV text: unrounded.
    pub fn csv(&self) -> String {
        match self {
            Cell::Text(t) => t.clone(),
            Cell::Count(n) => n.to_string(),
            Cell::Num { value, .. } | Cell::Rate { value, .. } | Cell::P(value) => value.to_string(),
            Cell::Missing | Cell::Empty => String::new(),
        }
    }

    /// The page text: rounded, not yet escaped.
    pub fn page(&self) -> String {
        match self {
            Cell::Text(t) => t.clone(),
            Cell::Count(n) => n.to_string(),
            Cell::Num { value, decimals } => format!("{value:.decimals$}"),
            Cell::Rate { value, decimals } => format!("{:.decimals$}", 100.0 * value),
            Cell::P(p) if *p < 0.001 => "< .001".into(),
            Cell::P(p) => format!("{p:.3}"),
            Cell::Missing => "–".into(),
            Cell::Empty => String::new(),
        }
    }

    fn is_empty(&self) -> bool {
        match self {
            Cell::Empty => true,
            Cell::Text(t) => t.is_empty(),
            _ => false,
        }
    }
}

/// A row's cell for a field (empty where a row is short: the CSV writer refuses such a row).
fn cell(row: &Row, i: usize) -> &Cell {
    row.cells.get(i).unwrap_or(&Cell::Empty)
}

/// Where a row goes.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum On {
    Both,
    /// Only the CSV file (the macro and micro rows beside the per-AU rows).
    File,
    /// Only the page (Table 4's mean row).
    Page,
}

/// One row: a cell per field.
#[derive(Debug, Clone, PartialEq)]
pub struct Row {
    pub cells: Vec<Cell>,
    pub on: On,
    /// The field whose page cell is highlighted (a confusion matrix's diagonal).
    pub mark: Option<usize>,
    /// A total row (its first page cell is bold).
    pub total: bool,
}

impl Row {
    pub fn new(cells: Vec<Cell>) -> Row {
        Row { cells, on: On::Both, mark: None, total: false }
    }

    pub fn only(mut self, on: On) -> Row {
        self.on = on;
        self
    }

    pub fn marking(mut self, field: Option<usize>) -> Row {
        self.mark = field;
        self
    }

    pub fn total(mut self) -> Row {
        self.total = true;
        self
    }
}

/// Page text made of fields: `AU{au} {name}`. The text before a field (and after the last) is
/// written only when that field's cell is not empty, so `{t}undefined: {undefined}` gives the
/// t value or the reason, and `{mean} ({sd})` drops the brackets where no SD belongs.
#[derive(Debug, Clone, PartialEq)]
pub struct Pattern {
    parts: Vec<Part>,
    /// The whole text when the pattern names no field.
    literal: String,
    /// Page words for whole cell values of the file (`emotion:intensity` → `emotion × intensity`).
    wording: Vec<(String, String)>,
}

#[derive(Debug, Clone, PartialEq)]
struct Part {
    before: String,
    field: String,
    after: String,
}

impl Pattern {
    pub fn parse(pattern: &str) -> Pattern {
        let (mut parts, mut literal) = (Vec::new(), String::new());
        let mut rest = pattern;
        while let Some(open) = rest.find('{') {
            let Some(close) = rest[open..].find('}').map(|c| open + c) else { break };
            literal.push_str(&rest[..open]);
            parts.push(Part { before: std::mem::take(&mut literal), field: rest[open + 1..close].to_string(), after: String::new() });
            rest = &rest[close + 1..];
        }
        literal.push_str(rest);
        if let Some(last) = parts.last_mut() {
            last.after = std::mem::take(&mut literal);
        }
        Pattern { parts, literal, wording: Vec::new() }
    }

    /// A pattern of one field, whatever characters its name holds.
    pub fn field(name: &str) -> Pattern {
        Pattern { parts: vec![Part { before: String::new(), field: name.to_string(), after: String::new() }], literal: String::new(), wording: Vec::new() }
    }

    /// The page writes `to` for a cell whose value is `from`.
    pub fn wording(mut self, from: &str, to: &str) -> Pattern {
        self.wording.push((from.into(), to.into()));
        self
    }

    /// The text for one row; `mark` says whether it shows the row's marked field.
    fn render(&self, table: &Table, row: &Row) -> Result<(String, bool), ReportError> {
        let mut text = self.literal.clone();
        let mut mark = false;
        for part in &self.parts {
            let i = table.field(&part.field)?;
            mark |= row.mark == Some(i);
            let value = cell(row, i);
            if !value.is_empty() {
                let page = value.page();
                let page = self.wording.iter().find(|(from, _)| *from == page).map_or(page.as_str(), |(_, to)| to.as_str());
                text.push_str(&part.before);
                text.push_str(page);
                text.push_str(&part.after);
            }
        }
        Ok((text, mark))
    }
}

/// A page column: its heading and the text of its cells.
#[derive(Debug, Clone, PartialEq)]
pub struct Column {
    pub label: String,
    pub pattern: Pattern,
}

impl Column {
    pub fn new(label: impl Into<String>, pattern: &str) -> Column {
        Column { label: label.into(), pattern: Pattern::parse(pattern) }
    }

    /// The page writes `to` for a cell whose value is `from`.
    pub fn wording(mut self, from: &str, to: &str) -> Column {
        self.pattern = self.pattern.wording(from, to);
        self
    }
}

/// How the page shows a table.
#[derive(Debug, Clone, PartialEq)]
pub enum View {
    /// Not on the page (a CSV file only).
    FileOnly,
    /// One page row per row, in these columns.
    Columns(Vec<Column>),
    /// Rows spread into columns (the seed's wide Tables 6, 11 and 14 from long CSV files).
    Pivot(Pivot),
}

/// A wide page table from a long one: the rows that share the `keys` fields make one group, shown
/// as one page row per [`Line`]; each [`Spread`] turns the values of a field into columns.
#[derive(Debug, Clone, PartialEq)]
pub struct Pivot {
    pub keys: Vec<String>,
    /// A value of the first key whose group goes last (the "all" summary rows).
    pub last: Option<String>,
    /// The headings of the lead columns (the lines' `lead` patterns).
    pub lead: Vec<String>,
    pub spreads: Vec<Spread>,
    pub lines: Vec<Line>,
}

/// Columns made from the values of the field `across` (among the rows where `only` holds).
#[derive(Debug, Clone, PartialEq)]
pub struct Spread {
    pub only: Option<(String, String)>,
    pub across: String,
    /// The heading; `{}` stands for the value.
    pub label: String,
    /// Columns in sorted order rather than in order of appearance.
    pub sorted: bool,
    /// The text where a group has no row for a column.
    pub missing: String,
}

/// A spread's column values, the field they are read from, and the field and value a row must
/// have to count (`only`).
type SpreadColumns = (Vec<String>, usize, Option<(usize, String)>);

/// One page row of each group: the lead cells (from the group's first row), then one pattern per
/// spread, applied to the row of each column.
#[derive(Debug, Clone, PartialEq)]
pub struct Line {
    pub lead: Vec<Pattern>,
    pub values: Vec<Pattern>,
}

/// A table: its CSV file, its page heading, its fields and rows, and its page view.
#[derive(Debug, Clone, PartialEq)]
pub struct Table {
    pub file: String,
    pub title: Option<String>,
    pub fields: Vec<String>,
    pub rows: Vec<Row>,
    pub view: View,
    /// The page shows only the rows where this field has this value.
    pub only: Option<(String, String)>,
}

/// A table as the page template gets it: plain text, escaped by the template.
#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct PageTable {
    pub title: Option<String>,
    pub header: Vec<String>,
    pub rows: Vec<PageRow>,
}

#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct PageRow {
    pub cells: Vec<PageCell>,
    pub total: bool,
}

#[derive(Debug, Clone, Serialize, PartialEq)]
pub struct PageCell {
    pub text: String,
    pub mark: bool,
}

impl Table {
    pub fn new(file: impl Into<String>, fields: &[&str], rows: Vec<Row>) -> Table {
        let fields = fields.iter().map(|f| f.to_string()).collect();
        Table { file: file.into(), title: None, fields, rows, view: View::FileOnly, only: None }
    }

    pub fn titled(mut self, title: impl Into<String>) -> Table {
        self.title = Some(title.into());
        self
    }

    pub fn view(mut self, view: View) -> Table {
        self.view = view;
        self
    }

    pub fn page_only(mut self, field: &str, value: &str) -> Table {
        self.only = Some((field.into(), value.into()));
        self
    }

    fn field(&self, name: &str) -> Result<usize, ReportError> {
        self.fields.iter().position(|f| f == name).ok_or_else(|| self.error(format!("the page names a field it does not have: {name:?}")))
    }

    fn error(&self, detail: String) -> ReportError {
        ReportError::Table { file: self.file.clone(), detail }
    }

    /// The CSV file: the header, then every row not marked for the page only.
    pub fn csv(&self) -> Result<Vec<u8>, ReportError> {
        let mut w = csv::Writer::from_writer(Vec::new());
        w.write_record(&self.fields).map_err(|e| self.error(e.to_string()))?;
        for row in self.rows.iter().filter(|r| r.on != On::Page) {
            w.write_record(row.cells.iter().map(Cell::csv)).map_err(|e| self.error(e.to_string()))?;
        }
        w.into_inner().map_err(|e| self.error(e.to_string()))
    }

    /// The rows the page shows, also restricted by `also` (field, value) pairs.
    fn page_rows(&self, also: &[(&str, &str)]) -> Result<Vec<&Row>, ReportError> {
        let mut filters = Vec::new();
        for (field, value) in self.only.iter().map(|(f, v)| (f.as_str(), v.as_str())).chain(also.iter().copied()) {
            filters.push((self.field(field)?, value));
        }
        let keep = |r: &&Row| r.on != On::File && filters.iter().all(|(i, v)| cell(r, *i).csv() == *v);
        Ok(self.rows.iter().filter(keep).collect())
    }

    /// The page's table (`None` for a CSV-only table), restricted by `also` (field, value) pairs.
    pub fn page(&self, also: &[(&str, &str)]) -> Result<Option<PageTable>, ReportError> {
        let rows = self.page_rows(also)?;
        let (header, rows) = match &self.view {
            View::FileOnly => return Ok(None),
            View::Columns(columns) => (columns.iter().map(|c| c.label.clone()).collect(), self.flat(columns, &rows)?),
            View::Pivot(pivot) => self.pivot(pivot, &rows)?,
        };
        Ok(Some(PageTable { title: self.title.clone(), header, rows }))
    }

    fn flat(&self, columns: &[Column], rows: &[&Row]) -> Result<Vec<PageRow>, ReportError> {
        rows.iter()
            .map(|row| {
                let cells = columns
                    .iter()
                    .map(|c| c.pattern.render(self, row).map(|(text, mark)| PageCell { text, mark }))
                    .collect::<Result<Vec<_>, _>>()?;
                Ok(PageRow { cells, total: row.total })
            })
            .collect()
    }

    /// The groups of rows with equal key fields, in order of appearance (`last` at the end).
    fn groups<'r>(&self, pivot: &Pivot, rows: &[&'r Row]) -> Result<Vec<Vec<&'r Row>>, ReportError> {
        let keys = pivot.keys.iter().map(|k| self.field(k)).collect::<Result<Vec<_>, _>>()?;
        let key_of = |r: &Row| keys.iter().map(|i| cell(r, *i).csv()).collect::<Vec<_>>();
        let mut groups: Vec<(Vec<String>, Vec<&Row>)> = Vec::new();
        for row in rows {
            let key = key_of(row);
            match groups.iter_mut().find(|(k, _)| *k == key) {
                Some((_, members)) => members.push(row),
                None => groups.push((key, vec![row])),
            }
        }
        if let Some(last) = &pivot.last {
            groups.sort_by_key(|(k, _)| k.first() == Some(last));
        }
        Ok(groups.into_iter().map(|(_, members)| members).collect())
    }

    /// The column values of a spread, and the field they are read from.
    fn spread_values(&self, spread: &Spread, rows: &[&Row]) -> Result<SpreadColumns, ReportError> {
        let across = self.field(&spread.across)?;
        let only = match &spread.only {
            Some((f, v)) => Some((self.field(f)?, v.clone())),
            None => None,
        };
        let mut values: Vec<String> = Vec::new();
        for row in rows.iter().filter(|r| only.as_ref().is_none_or(|(i, v)| cell(r, *i).csv() == *v)) {
            let value = cell(row, across).csv();
            if !value.is_empty() && !values.contains(&value) {
                values.push(value);
            }
        }
        if spread.sorted {
            values.sort();
        }
        Ok((values, across, only))
    }

    fn pivot(&self, pivot: &Pivot, rows: &[&Row]) -> Result<(Vec<String>, Vec<PageRow>), ReportError> {
        let spreads = pivot.spreads.iter().map(|s| self.spread_values(s, rows)).collect::<Result<Vec<_>, _>>()?;
        let mut header = pivot.lead.clone();
        for (spread, (values, _, _)) in pivot.spreads.iter().zip(&spreads) {
            header.extend(values.iter().map(|v| spread.label.replace("{}", v)));
        }
        let mut out = Vec::new();
        for group in self.groups(pivot, rows)? {
            for line in &pivot.lines {
                let mut cells = Vec::new();
                for pattern in &line.lead {
                    cells.push(pattern.render(self, group[0])?.0);
                }
                for (s, (spread, (values, across, only))) in pivot.spreads.iter().zip(&spreads).enumerate() {
                    for value in values {
                        let hit = group.iter().find(|r| cell(r, *across).csv() == *value && only.as_ref().is_none_or(|(i, v)| cell(r, *i).csv() == *v));
                        cells.push(match (hit, line.values.get(s)) {
                            (Some(row), Some(pattern)) => pattern.render(self, row)?.0,
                            _ => spread.missing.clone(),
                        });
                    }
                }
                out.push(PageRow { cells: cells.into_iter().map(|text| PageCell { text, mark: false }).collect(), total: false });
            }
        }
        Ok((header, out))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn texts(page: &PageTable) -> Vec<Vec<&str>> {
        page.rows.iter().map(|r| r.cells.iter().map(|c| c.text.as_str()).collect()).collect()
    }

    fn model() -> Table {
        let rows = vec![
            Row::new(vec![Cell::text("a"), Cell::num(0.123456, 2), Cell::Missing, Cell::P(0.0004)]),
            Row::new(vec![Cell::text("b"), Cell::num(2.0, 2), Cell::Rate { value: 0.5, decimals: 1 }, Cell::Empty]).only(On::File),
            Row::new(vec![Cell::text("Mean"), Cell::Empty, Cell::Empty, Cell::P(0.5)]).only(On::Page).total(),
        ];
        let columns = vec![Column::new("Name", "{name}"), Column::new("Value", "{value} ({rate})"), Column::new("p", "{p}")];
        Table::new("t.csv", &["name", "value", "rate", "p"], rows).titled("T").view(View::Columns(columns))
    }

    #[test]
    fn the_file_keeps_full_precision_and_the_page_rounds() {
        let t = model();
        assert_eq!(String::from_utf8(t.csv().unwrap()).unwrap(), "name,value,rate,p\na,0.123456,,0.0004\nb,2,0.5,\n");
        let page = t.page(&[]).unwrap().unwrap();
        assert_eq!(page.header, ["Name", "Value", "p"]);
        assert_eq!(texts(&page), [vec!["a", "0.12 (–)", "< .001"], vec!["Mean", "", "0.500"]]);
        assert!(page.rows[1].total && !page.rows[0].total);
    }

    #[test]
    fn a_pattern_drops_the_text_around_an_empty_cell() {
        let rows = vec![Row::new(vec![Cell::num(1.5, 1), Cell::Empty, Cell::text("no variance")]), Row::new(vec![Cell::num(2.0, 1), Cell::num(0.25, 2), Cell::Empty])];
        let t = Table::new("t.csv", &["t", "sd", "undefined"], rows).view(View::Columns(vec![
            Column::new("t", "{t} ({sd})"),
            Column::new("sd", "[{sd}]"),
            Column::new("why", "{sd}undefined: {undefined}"),
            Column::new("label", "Belv."),
        ]));
        let page = t.page(&[]).unwrap().unwrap();
        assert_eq!(texts(&page), [vec!["1.5", "", "undefined: no variance", "Belv."], vec!["2.0 (0.25)", "[0.25]", "0.25", "Belv."]]);
    }

    #[test]
    fn a_pivot_spreads_a_field_into_columns() {
        let row = |k: &str, c: &str, v: f64| Row::new(vec![Cell::text(k), Cell::text(c), Cell::num(v, 1)]);
        let rows = vec![row("all", "x", 1.0), row("b", "y", 2.0), row("a", "y", 3.0), row("a", "x", 4.0)];
        let spread = Spread { only: None, across: "c".into(), label: "c={}".into(), sorted: true, missing: "0".into() };
        let pivot = Pivot {
            keys: vec!["k".into()],
            last: Some("all".into()),
            lead: vec!["k".into()],
            spreads: vec![spread],
            lines: vec![Line { lead: vec![Pattern::parse("{k}").wording("all", "All")], values: vec![Pattern::parse("{v}%")] }],
        };
        let page = Table::new("t.csv", &["k", "c", "v"], rows).view(View::Pivot(pivot)).page(&[]).unwrap().unwrap();
        assert_eq!(page.header, ["k", "c=x", "c=y"]);
        assert_eq!(texts(&page), [vec!["b", "0", "2.0%"], vec!["a", "4.0%", "3.0%"], vec!["All", "1.0%", "0"]]);
    }

    #[test]
    fn filters_marks_and_mistakes_are_kept() {
        let rows = vec![
            Row::new(vec![Cell::text("x"), Cell::Count(1)]).marking(Some(1)),
            Row::new(vec![Cell::text("y"), Cell::Count(2)]),
        ];
        let t = Table::new("t.csv", &["k", "n"], rows).view(View::Columns(vec![Column::new("K", "{k}"), Column::new("N", "{n}")]));
        let page = t.page(&[("k", "x")]).unwrap().unwrap();
        assert_eq!(texts(&page), [vec!["x", "1"]]);
        assert!(page.rows[0].cells[1].mark && !page.rows[0].cells[0].mark);
        let err = t.page(&[("nope", "x")]).unwrap_err().to_string();
        assert!(err.contains("t.csv") && err.contains("nope"), "{err}");
        let short = Table::new("s.csv", &["a", "b"], vec![Row::new(vec![Cell::Count(1)])]);
        assert!(short.csv().unwrap_err().to_string().contains("s.csv"));
        assert_eq!(short.page(&[]).unwrap(), None, "a CSV-only table is not on the page");
    }
}
