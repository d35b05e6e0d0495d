//! Every table of the report, built once from the [`Report`] into the [`Table`] model, in page
//! order. The CSV files and the tables of `report.html` are both written from these values.
//!
//! In: a [`Report`]. Out: [`Table`]s named by their CSV file. **Invariant:** the CSV files keep
//! their names and columns (numbers unrounded, an undefined value empty); each table's page view
//! names only its own fields.

mod design;
mod styles;

use super::Report;
use super::table::{Cell, Column, Line, On, Pattern, Pivot, Row, Spread, Table, View};
use crate::analysis::coding::{AuCount, CodingReport, Counts, Metrics};
use crate::analysis::demographics::Demographics;
use crate::analysis::rating::{Condition, Describe, RatingReport};
use crate::analysis::responses::Scale;
use crate::study::measure::Demographic;

const METRICS: [&str; 4] = ["accuracy", "precision", "recall", "f1"];
const COUNTS: [&str; 4] = ["tp", "fp", "fn", "tn"];

/// The `accuracy, precision, recall, f1` cells, shown with two decimals.
fn metrics(m: &Metrics) -> [Cell; 4] {
    [m.accuracy, m.precision, m.recall, m.f1].map(|v| Cell::num(v, 2))
}

fn counts(c: &Counts) -> [Cell; 4] {
    [c.tp, c.fp, c.fn_, c.tn].map(Cell::Count)
}

/// The page columns of the four metrics; the F1 heading differs between the seed's tables.
fn metric_columns(f1: &str) -> Vec<Column> {
    ["Accuracy", "Precision", "Recall", f1].iter().zip(METRICS).map(|(label, field)| Column::new(*label, &format!("{{{field}}}"))).collect()
}

/// `AU12 (3); AU6 (1)`; none is [`Cell::Missing`].
fn au_list(list: &[AuCount]) -> Cell {
    if list.is_empty() {
        return Cell::Missing;
    }
    Cell::text(list.iter().map(|m| format!("{} ({})", m.au, m.count)).collect::<Vec<_>>().join("; "))
}

fn fields<'a>(head: &[&'a str], tail: &[&'a str]) -> Vec<&'a str> {
    head.iter().chain(tail).copied().collect()
}

/// A file-name-safe condition key: `video 100%` → `video_100`.
pub(crate) fn slug(key: &str) -> String {
    key.replace('%', "").replace(' ', "_")
}

/// Every table, in page order.
pub(super) fn all(report: &Report) -> Vec<Table> {
    let mut out = Vec::new();
    if let Some(c) = &report.coding {
        out.extend([per_au(c), table1(c), table2(c), table4(c), agreement(c)]);
        out.extend(au_level(c));
    }
    if let Some(r) = &report.rating {
        for (n, c) in r.conditions.iter().enumerate() {
            out.extend(confusion(n, c));
        }
        out.extend([recognition(r), table11(r), design::icc(r), group_tests(r), anova(r)]);
        out.extend([design::rm_anova(r), design::paired(r), design::between(r), design::post_hoc(r)]);
        out.extend(table14(r));
    }
    if !report.styles.is_empty() {
        out.extend([styles::means(&report.styles), styles::anova(&report.styles), styles::scheffe(&report.styles)]);
    }
    if let Some(d) = &report.demographics {
        out.push(table6(d));
    }
    out
}

/// Table 1: AUs with equal rounded results grouped.
fn table1(c: &CodingReport) -> Table {
    let rows = c
        .table1_groups
        .iter()
        .map(|g| {
            let aus = g.aus.iter().map(|a| format!("AU{a}")).collect::<Vec<_>>().join(", ");
            Row::new([Cell::Text(aus)].into_iter().chain(metrics(&g.metrics)).collect())
        })
        .collect();
    let mut columns = vec![Column::new("Action Unit", "{aus}")];
    columns.extend(metric_columns("F1-Measure"));
    Table::new("table1_grouped.csv", &fields(&["aus"], &METRICS), rows)
        .titled("Table 1. AU recognition (AUs with equal rounded results grouped)")
        .view(View::Columns(columns))
}

/// Tables 2–3: per AU, with the macro mean and micro rows in the CSV file.
fn per_au(c: &CodingReport) -> Table {
    let mut rows: Vec<Row> = c
        .per_au
        .iter()
        .map(|r| {
            let mut cells = vec![Cell::Count(r.au.into()), Cell::text(&r.name), Cell::count(r.shown_in)];
            cells.extend(counts(&r.counts).into_iter().chain(metrics(&r.metrics)));
            cells.extend([Cell::maybe(&r.alpha, 3), Cell::maybe(&r.fleiss_kappa, 3), au_list(&r.mistaken_for)]);
            Row::new(cells)
        })
        .collect();
    for (label, m, total) in [("macro mean (shown AUs)", c.shown_macro_mean, None), ("macro mean (all AUs)", c.macro_mean, None), ("micro", c.micro, Some(c.total))] {
        let mut cells = vec![Cell::text(label), Cell::Empty, Cell::Empty];
        cells.extend(total.as_ref().map_or([Cell::Empty, Cell::Empty, Cell::Empty, Cell::Empty], counts));
        cells.extend(metrics(&m).into_iter().chain([Cell::Empty, Cell::Empty, Cell::Empty]));
        rows.push(Row::new(cells).only(On::File));
    }
    let mut columns = vec![Column::new("AU", "AU{au} {name}"), Column::new("shown in", "{shown_in}"), Column::new("TP/FP/FN/TN", "{tp}/{fp}/{fn}/{tn}")];
    columns.extend(metric_columns("F1"));
    columns.extend([Column::new("α", "{alpha}"), Column::new("Fleiss κ", "{fleiss_kappa}"), Column::new("Mistaken for (count)", "{mistaken_for}")]);
    let head = fields(&["au", "name", "shown_in"], &COUNTS);
    Table::new("table1_3_per_au.csv", &fields(&fields(&head, &METRICS), &["alpha", "fleiss_kappa", "mistaken_for"]), rows)
        .titled("Tables 2–3. Per AU: metrics, Cronbach's α (coders as items) and AUs mistaken for")
        .view(View::Columns(columns))
}

/// Table 2 as its own file: the AUs that were shown.
fn table2(c: &CodingReport) -> Table {
    let rows = c.per_au.iter().filter(|r| r.shown_in > 0).map(|r| Row::new(vec![Cell::Count(r.au.into()), Cell::maybe(&r.alpha, 3), au_list(&r.mistaken_for)])).collect();
    Table::new("table2_alpha.csv", &["au", "alpha", "mistaken_for"], rows)
}

/// Table 4: AU combinations; on the page only when some combination has two AUs or more.
fn table4(c: &CodingReport) -> Table {
    let mut rows: Vec<Row> = c
        .combinations
        .iter()
        .map(|r| {
            let mut cells = vec![Cell::text(&r.combination), Cell::text(&r.recognised_display), Cell::count(r.stimuli), Cell::count(r.answers)];
            cells.extend(counts(&r.counts).into_iter().chain(metrics(&r.metrics)));
            Row::new(cells)
        })
        .collect();
    let mut mean = vec![Cell::text("Mean")];
    mean.extend(std::iter::repeat_n(Cell::Empty, 7).chain(metrics(&c.combinations_macro_mean)));
    rows.push(Row::new(mean).only(On::Page).total());
    let mut columns = vec![Column::new("Shown combination", "{combination}"), Column::new("Recognised AUs", "{recognised}")];
    columns.extend(metric_columns("F1-Measure"));
    let shown = c.combinations.iter().any(|r| r.combination.contains('+'));
    let head = fields(&["combination", "recognised", "stimuli", "answers"], &COUNTS);
    Table::new("table4_combinations.csv", &fields(&head, &METRICS), rows)
        .titled("Table 4. AU combinations (false positives in parentheses)")
        .view(if shown { View::Columns(columns) } else { View::FileOnly })
}

/// Agreement between coders: Cohen's κ per pair, then Fleiss' κ over all coders.
fn agreement(c: &CodingReport) -> Table {
    let mut rows: Vec<Row> = c
        .agreement
        .pairs
        .iter()
        .map(|p| Row::new(vec![Cell::text(&p.coder_a), Cell::text(&p.coder_b), Cell::count(p.common_stimuli), Cell::maybe(&p.cohen_kappa, 3), Cell::num(p.dice_mean, 3)]))
        .collect();
    let a = &c.agreement;
    rows.push(Row::new(vec![Cell::text("all coders (Fleiss)"), Cell::Empty, Cell::count(a.complete_stimuli), Cell::maybe(&a.fleiss_kappa, 3), Cell::Empty]));
    let columns = vec![
        Column::new("Coders", "{coder_a} – {coder_b}").wording("all coders (Fleiss)", "all coders (Fleiss κ)"),
        Column::new("Stimuli", "{common_stimuli}"),
        Column::new("κ", "{cohen_kappa}"),
        Column::new("Dice (mean)", "{dice_mean}"),
    ];
    Table::new("coder_agreement.csv", &["coder_a", "coder_b", "common_stimuli", "cohen_kappa", "dice_mean"], rows)
        .titled("Agreement between coders")
        .view(View::Columns(columns))
}

/// This study's single-AU recognition rate or combination accuracy beside the published ones
/// (HapFACS §4.3.2); none when no published figure fits the study.
fn au_level(c: &CodingReport) -> Option<Table> {
    if c.comparison.is_empty() {
        return None;
    }
    let rows = c
        .comparison
        .iter()
        .map(|x| Row::new(vec![Cell::text(&x.stimuli), Cell::count(x.count), Cell::num(x.percent, 1), Cell::text(&x.system), Cell::Count(x.published_count.into()), Cell::num(x.published_percent, 1)]))
        .collect();
    let columns = vec![
        Column::new("Stimuli", "{stimuli}"),
        Column::new("This study", "{percent}% of {count}"),
        Column::new("Published", "{system}: {published_percent}% of {published_count}"),
    ];
    let fields = ["stimuli", "count", "percent", "system", "published_count", "published_percent"];
    let title = "AU level: this study beside published figures (single AUs: mean recognition rate; combinations: mean accuracy)";
    Some(Table::new("au_level_comparison.csv", &fields, rows).titled(title).view(View::Columns(columns)))
}

/// Tables 7–10: a condition's confusion matrix, in counts (CSV only) and in row percent.
fn confusion(n: usize, c: &Condition) -> Vec<Table> {
    let Some(conf) = &c.confusion else { return Vec::new() };
    let mut fields = vec!["shown"];
    fields.extend(conf.columns.iter().map(String::as_str));
    let counts = conf.rows.iter().zip(&conf.counts).map(|(shown, row)| Row::new([Cell::text(shown)].into_iter().chain(row.iter().map(|v| Cell::Count(*v))).collect()));
    let percent = conf.rows.iter().zip(&conf.percent).map(|(shown, row)| {
        let diagonal = conf.columns.iter().position(|col| col == shown).map(|j| j + 1);
        Row::new([Cell::text(shown)].into_iter().chain(row.iter().map(|v| Cell::num(*v, 1))).collect()).marking(diagonal)
    });
    let mut columns = vec![Column::new("Shown \\ chosen", "{shown}")];
    columns.extend(conf.columns.iter().map(|col| Column { label: col.clone(), pattern: Pattern::field(col) }));
    let slug = slug(&c.key);
    let title = format!("Table {}. Emotion recognition rates, {} stimuli ({} participants, {} answers)", 7 + n, c.key, c.participants, c.answers);
    vec![
        Table::new(format!("confusion_{slug}_counts.csv"), &fields, counts.collect()),
        Table::new(format!("confusion_{slug}_percent.csv"), &fields, percent.collect()).titled(title).view(View::Columns(columns)),
    ]
}

/// Recognition rates per condition and shown emotion (the page shows one condition at a time).
fn recognition(r: &RatingReport) -> Table {
    let mut rows = Vec::new();
    for c in &r.conditions {
        for e in &c.emotions {
            let (low, high) = e.rate_ci95;
            rows.push(Row::new(vec![
                Cell::text(&c.key),
                Cell::text(&e.emotion),
                Cell::count(e.stimuli),
                Cell::Count(e.answers),
                Cell::Count(e.hits),
                Cell::Rate { value: e.rate, decimals: 1 },
                Cell::num(e.hu, 3),
                Cell::num(e.hu_chance, 3),
                Cell::P(e.binomial_p),
                Cell::Rate { value: low, decimals: 1 },
                Cell::Rate { value: high, decimals: 1 },
            ]));
        }
    }
    let columns = vec![
        Column::new("Emotion", "{emotion}"),
        Column::new("Answers", "{answers}"),
        Column::new("Rate %", "{rate}"),
        Column::new("95% CI", "{rate_ci95_low}–{rate_ci95_high}"),
        Column::new("Hu", "{hu}"),
        Column::new("Hu chance", "{hu_chance}"),
        Column::new("p (binomial vs chance)", "{binomial_p_vs_chance}"),
    ];
    let fields = ["condition", "emotion", "stimuli", "answers", "hits", "rate", "hu", "hu_chance", "binomial_p_vs_chance", "rate_ci95_low", "rate_ci95_high"];
    Table::new("recognition.csv", &fields, rows).view(View::Columns(columns))
}

/// `n, mean, sd` cells of a description (n = 0 and undefined mean and SD without one).
fn describe(d: Option<&Describe>, decimals: usize) -> [Cell; 3] {
    [Cell::count(d.map_or(0, |d| d.n)), Cell::opt(d.map(|d| d.mean), decimals), Cell::opt(d.and_then(|d| d.sd), decimals)]
}

/// Table 11: every rating scale per condition and emotion (CSV); the page shows believability.
fn table11(r: &RatingReport) -> Table {
    let mut rows = Vec::new();
    for c in &r.conditions {
        for s in &c.scales {
            let cells = s.cells.iter().map(|x| (x.emotion.as_str(), x.stats.as_ref(), &x.alpha, x.alpha_cases, x.alpha_items));
            for (emotion, d, alpha, cases, items) in cells.chain([("all", s.overall.as_ref(), &s.alpha, s.alpha_cases, s.alpha_items)]) {
                let mut row = vec![Cell::text(&c.key), Cell::text(s.scale.name()), Cell::text(emotion)];
                row.extend(describe(d, 2));
                row.extend([Cell::maybe(alpha, 3), Cell::count(cases), Cell::count(items)]);
                rows.push(Row::new(row));
            }
        }
    }
    let pivot = Pivot {
        keys: vec!["emotion".into()],
        last: Some("all".into()),
        lead: vec!["Emotion".into(), "Measure".into()],
        spreads: vec![Spread { only: None, across: "condition".into(), label: "{}".into(), sorted: false, missing: "–".into() }],
        lines: vec![
            Line { lead: vec![Pattern::parse("{emotion}").wording("all", "All stimuli"), Pattern::parse("Belv. (sd)")], values: vec![Pattern::parse("{mean} ({sd})")] },
            Line { lead: vec![Pattern::parse(""), Pattern::parse("Cronbach α")], values: vec![Pattern::parse("{alpha} ({alpha_cases}×{alpha_items})")] },
        ],
    };
    Table::new("table11_ratings.csv", &["condition", "scale", "emotion", "n", "mean", "sd", "alpha", "alpha_cases", "alpha_items"], rows)
        .titled("Table 11. Believability (sd) and Cronbach's α (participants as items, stimuli as cases)")
        .view(View::Pivot(pivot))
        .page_only("scale", Scale::Believability.name())
}

/// Student and Welch tests between the groups (the page shows the tests over all emotions).
fn group_tests(r: &RatingReport) -> Table {
    let mut rows = Vec::new();
    for g in &r.group_tests {
        for (name, test) in [("student", g.student.as_result()), ("welch", g.welch.as_result())] {
            let mut cells = vec![Cell::text(&g.condition), Cell::text(&g.emotion), Cell::text(&g.outcome), Cell::text(&g.group_a), Cell::text(&g.group_b)];
            cells.extend(describe(g.a.as_ref(), 3).into_iter().chain(describe(g.b.as_ref(), 3)));
            cells.push(Cell::text(name));
            match test {
                Ok(t) => {
                    let (low, high) = t.ci;
                    cells.extend([Cell::num(t.t, 3), Cell::num(t.df, 2), Cell::P(t.p_two_sided), Cell::num(t.cohen_d, 3), Cell::num(low, 3), Cell::num(high, 3), Cell::Empty]);
                }
                Err(e) => cells.extend(std::iter::repeat_n(Cell::Empty, 6).chain([Cell::text(e)])),
            }
            rows.push(Row::new(cells));
        }
    }
    let columns = vec![
        Column::new("Condition", "{condition}"),
        Column::new("Outcome", "{outcome}"),
        Column::new("Groups", "{group_a} vs {group_b}"),
        Column::new("Mean A", "{mean_a} (n={n_a})"),
        Column::new("Mean B", "{mean_b} (n={n_b})"),
        Column::new("Test", "{test}").wording("student", "Student").wording("welch", "Welch"),
        Column::new("t", "{t}undefined: {undefined}"),
        Column::new("df", "{df}"),
        Column::new("p", "{p}"),
        Column::new("Cohen's d", "{cohen_d}"),
        Column::new("95% CI of difference", "[{ci95_low}, {ci95_high}]"),
    ];
    let head = ["condition", "emotion", "outcome", "group_a", "group_b", "n_a", "mean_a", "sd_a", "n_b", "mean_b", "sd_b"];
    Table::new("group_tests.csv", &fields(&head, &["test", "t", "df", "p", "cohen_d", "ci95_low", "ci95_high", "undefined"]), rows)
        .titled("Group comparisons (per-participant scores; per-emotion tests in group_tests.csv)")
        .view(View::Columns(columns))
        .page_only("emotion", "all")
}

/// The two-way ANOVAs, Type II and III.
fn anova(r: &RatingReport) -> Table {
    let mut rows = Vec::new();
    for a in &r.anova {
        for (ty, table) in [("II", a.type_ii.as_result()), ("III", a.type_iii.as_result())] {
            let lead = [Cell::text(a.media.as_str()), Cell::text(&a.outcome), Cell::count(a.n), Cell::text(ty)];
            match table {
                Ok(table) => rows.extend(table.rows.iter().map(|row| {
                    let (f, p, eta) = (Cell::opt_or_empty(row.f, 3), row.p.map_or(Cell::Empty, Cell::P), Cell::opt_or_empty(row.partial_eta2, 4));
                    Row::new(lead.iter().cloned().chain([Cell::text(&row.term), Cell::num(row.ss, 3), Cell::num(row.df, 0), f, p, eta, Cell::Empty]).collect())
                })),
                Err(e) => rows.push(Row::new(lead.into_iter().chain(std::iter::repeat_n(Cell::Empty, 6)).chain([Cell::text(e)]).collect())),
            }
        }
    }
    let columns = vec![
        Column::new("Media", "{media}"),
        Column::new("Outcome", "{outcome}"),
        Column::new("SS type", "{ss_type}"),
        r.anova.iter().fold(Column::new("Term", "{term}undefined: {undefined}"), |c, a| c.wording(&format!("{}:{}", a.a, a.b), &format!("{} × {}", a.a, a.b))),
        Column::new("SS", "{ss}"),
        Column::new("df", "{df}"),
        Column::new("F", "{f}"),
        Column::new("p", "{p}"),
        Column::new("partial η²", "{partial_eta2}"),
    ];
    Table::new("anova.csv", &["media", "outcome", "n", "ss_type", "term", "ss", "df", "f", "p", "partial_eta2", "undefined"], rows)
        .titled("Two-way ANOVA: emotion × intensity (per media)")
        .view(View::Columns(columns))
}

/// Table 14: this study beside the published figures; absent when there is nothing to compare.
fn table14(r: &RatingReport) -> Option<Table> {
    if r.table14.is_empty() {
        return None;
    }
    let mut rows = Vec::new();
    for x in &r.table14 {
        let this = [Cell::text(&x.emotion), Cell::Count(x.intensity_percent.into()), Cell::opt(x.recognition_percent, 1), Cell::opt(x.believability, 2)];
        if x.published.is_empty() {
            rows.push(Row::new(this.iter().cloned().chain([Cell::Empty, Cell::Empty, Cell::Empty]).collect()));
        }
        for (system, (rate, b)) in &x.published {
            rows.push(Row::new(this.iter().cloned().chain([Cell::text(system), Cell::num(*rate, 2), Cell::num(*b, 1)]).collect()));
        }
    }
    let pivot = Pivot {
        keys: vec!["emotion".into(), "intensity_percent".into()],
        last: None,
        lead: vec!["Emotion".into(), "Intensity".into(), "This study".into()],
        spreads: vec![Spread { only: None, across: "system".into(), label: "{} (published)".into(), sorted: true, missing: "–".into() }],
        lines: vec![Line {
            lead: vec![Pattern::parse("{emotion}"), Pattern::parse("{intensity_percent}%"), Pattern::parse("{this_study_recognition_percent} ({this_study_believability})")],
            values: vec![Pattern::parse("{published_recognition_percent} ({published_believability})")],
        }],
    };
    let study = ["emotion", "intensity_percent", "this_study_recognition_percent", "this_study_believability"];
    let fields = fields(&study, &["system", "published_recognition_percent", "published_believability"]);
    let title = "Table 14. Static expressions: this study beside published figures (rate % (believability))";
    Some(Table::new("table14_comparison.csv", &fields, rows).titled(title).view(View::Pivot(pivot)))
}

/// Table 6: per stratum, gender with the mean age of each, and ethnicity (CSV: also education).
fn table6(d: &Demographics) -> Table {
    let mut rows = Vec::new();
    for r in &d.rows {
        for (item, levels) in [(Demographic::Gender, &r.gender), (Demographic::Ethnicity, &r.ethnicity), (Demographic::Education, &r.education)] {
            for l in levels {
                let stratum = [Cell::text(&r.stratum), Cell::count(r.participants), Cell::opt(r.mean_age, 1)];
                let level = [Cell::text(item.name()), Cell::text(&l.level), Cell::count(l.n), Cell::num(l.percent, 1), Cell::opt(l.mean_age, 1)];
                rows.push(Row::new(stratum.into_iter().chain(level).collect()));
            }
        }
    }
    let spread = |item: &str, label: &str, sorted: bool| {
        let only = Some(("item".to_string(), item.to_string()));
        Spread { only, across: "level".into(), label: label.into(), sorted, missing: "0%".into() }
    };
    let pivot = Pivot {
        keys: vec!["stratum".into()],
        last: None,
        lead: vec!["Stimuli".into(), "# of subjects".into(), "Mean age".into()],
        spreads: vec![spread(Demographic::Gender.name(), "{} (age avg.)", true), spread(Demographic::Ethnicity.name(), "{}", false)],
        lines: vec![Line {
            lead: vec![Pattern::parse("{stratum}"), Pattern::parse("{participants}"), Pattern::parse("{mean_age}")],
            values: vec![Pattern::parse("{percent}% ({level_mean_age})"), Pattern::parse("{percent}%")],
        }],
    };
    Table::new("table6_demographics.csv", &["stratum", "participants", "mean_age", "item", "level", "n", "percent", "level_mean_age"], rows).view(View::Pivot(pivot))
}
