//! The tables of seed 004's studies: ratings by label × style (Fig. 8 / Fig. 10 as numbers), the
//! two-way ANOVA style × label (Type II and III) and the Scheffé post hoc pairs.
//!
//! In: the report's [`StyleScale`]s. Out: `styles_means.csv`, `styles_anova.csv`,
//! `styles_scheffe.csv` ([`Table`]s); an undefined statistic is empty cells with the reason in
//! `undefined`.

use super::{describe, fields};
use crate::analysis::stats::anova::AnovaTable;
use crate::analysis::styles::StyleScale;
use crate::report::table::{Cell, Column, Line, Pattern, Pivot, Row, Spread, Table, View};

/// Mean (sd) per label and style, every scale; the rows `all` give the per-style grand means.
pub(super) fn means(scales: &[StyleScale]) -> Table {
    let mut rows = Vec::new();
    for s in scales {
        let cells = s.cells.iter().chain(&s.per_style).map(|c| (if c.label.is_empty() { "all" } else { c.label.as_str() }, c.style.as_str(), c.stats.as_ref()));
        for (label, style, d) in cells.chain([("all", "all", s.overall.as_ref())]) {
            let mut row = vec![Cell::text(s.scale.name()), Cell::text(label), Cell::text(style), Cell::text(format!("{} {style}", s.scale.name()))];
            row.extend(describe(d, 2));
            rows.push(Row::new(row));
        }
    }
    let pivot = Pivot {
        keys: vec!["label".into()],
        last: Some("all".into()),
        lead: vec!["Label".into()],
        spreads: vec![Spread { only: None, across: "column".into(), label: "{}".into(), sorted: false, missing: "–".into() }],
        lines: vec![Line { lead: vec![Pattern::parse("{label}").wording("all", "All labels")], values: vec![Pattern::parse("{mean} ({sd})")] }],
    };
    Table::new("styles_means.csv", &["scale", "label", "style", "column", "n", "mean", "sd"], rows)
        .titled("Ratings by label and style: mean (sd) (seed 004, Fig. 8 and Fig. 10)")
        .view(View::Pivot(pivot))
}

fn anova_rows(scale: &str, ty: &str, table: Result<&AnovaTable, &str>, rows: &mut Vec<Row>) {
    let lead = [Cell::text(scale), Cell::text(ty)];
    match table {
        Ok(table) => rows.extend(table.rows.iter().map(|row| {
            let (f, p, eta) = (Cell::opt_or_empty(row.f, 3), row.p.map_or(Cell::Empty, Cell::P), Cell::opt_or_empty(row.partial_eta2, 4));
            Row::new(lead.iter().cloned().chain([Cell::text(&row.term), Cell::num(row.ss, 3), Cell::num(row.df, 0), f, p, eta, Cell::Empty]).collect())
        })),
        Err(e) => rows.push(Row::new(lead.into_iter().chain(std::iter::repeat_n(Cell::Empty, 6)).chain([Cell::text(e)]).collect())),
    }
}

/// The two-way ANOVA style × label with interaction, Type II and Type III, per scale.
pub(super) fn anova(scales: &[StyleScale]) -> Table {
    let mut rows = Vec::new();
    for s in scales {
        anova_rows(s.scale.name(), "II", s.type_ii.as_result(), &mut rows);
        anova_rows(s.scale.name(), "III", s.type_iii.as_result(), &mut rows);
    }
    let columns = vec![
        Column::new("Scale", "{scale}"),
        Column::new("SS type", "{ss_type}"),
        Column::new("Term", "{term}undefined: {undefined}").wording("style:label", "style × label"),
        Column::new("SS", "{ss}"),
        Column::new("df", "{df}"),
        Column::new("F", "{f}"),
        Column::new("p", "{p}"),
        Column::new("partial η²", "{partial_eta2}"),
    ];
    Table::new("styles_anova.csv", &["scale", "ss_type", "term", "ss", "df", "f", "p", "partial_eta2", "undefined"], rows)
        .titled("Two-way ANOVA: style × label with interaction (Type II and Type III SS)")
        .view(View::Columns(columns))
}

/// Scheffé pairs over the label × style cells: all in the CSV, the same-label pairs on the page.
pub(super) fn scheffe(scales: &[StyleScale]) -> Table {
    let mut rows = Vec::new();
    for s in scales {
        let lead = Cell::text(s.scale.name());
        match s.scheffe.as_result() {
            Ok(pairs) => rows.extend(pairs.iter().map(|p| {
                let same = if p.a.label == p.b.label { "yes" } else { "no" };
                let texts = [&p.a.label, &p.a.style, &p.b.label, &p.b.style].map(Cell::text);
                Row::new([lead.clone()].into_iter().chain(texts).chain([Cell::text(same), Cell::num(p.mean_diff, 3), Cell::num(p.f, 3), Cell::P(p.p), Cell::Empty]).collect())
            })),
            Err(e) => {
                let blank = |n| std::iter::repeat_n(Cell::Empty, n);
                rows.push(Row::new([lead].into_iter().chain(blank(4)).chain([Cell::text("yes")]).chain(blank(3)).chain([Cell::text(e)]).collect()))
            }
        }
    }
    let columns = vec![
        Column::new("Scale", "{scale}"),
        Column::new("Label", "{label_a}"),
        Column::new("Styles (A − B)", "{style_a} − {style_b}undefined: {undefined}"),
        Column::new("Mean difference", "{mean_diff}"),
        Column::new("Scheffé F", "{f}"),
        Column::new("p", "{p}"),
    ];
    let head = ["scale", "label_a", "style_a", "label_b", "style_b", "same_label"];
    Table::new("styles_scheffe.csv", &fields(&head, &["mean_diff", "f", "p", "undefined"]), rows)
        .titled("Scheffé post hoc: one label in two styles (every pair of label × style cells in styles_scheffe.csv)")
        .view(View::Columns(columns))
        .page_only("same_label", "yes")
}
