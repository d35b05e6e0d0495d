//! The tables of the statistics a design calls for: RM ANOVA over emotion, paired t, the one-way
//! ANOVA between condition groups with its post hoc tests, and the ICCs beside Cronbach's α.
//!
//! In: the rater section ([`RatingReport`]). Out: [`Table`]s; a table without rows is still
//! written as a CSV file (its header), and the page leaves it out. An undefined statistic is an
//! empty cell with the reason in `undefined`.

use super::{describe, fields};
use crate::analysis::rating::RatingReport;
use crate::analysis::stats::posthoc::Pairwise;
use crate::report::table::{Cell, Column, Row, Table, View};

/// `n, mean, sd` and the undefined-reason pattern shared by the test columns.
const UNDEFINED: &str = "undefined";

/// The cells of an undefined statistic: `n` empty cells, then the reason.
fn undefined(n: usize, why: &str) -> impl Iterator<Item = Cell> {
    std::iter::repeat_n(Cell::Empty, n).chain([Cell::text(why)])
}

/// Repeated-measures ANOVA over emotion, per condition and outcome.
pub(super) fn rm_anova(r: &RatingReport) -> Table {
    let mut rows = Vec::new();
    for w in &r.design.within_emotion {
        let mut cells = vec![Cell::text(&w.condition), Cell::text(&w.outcome), Cell::text(w.emotions.join("; ")), Cell::count(w.participants), Cell::count(w.dropped)];
        match w.anova.as_result() {
            Ok(a) => cells.extend([
                Cell::num(a.f, 3),
                Cell::num(a.df1, 0),
                Cell::num(a.df2, 0),
                Cell::P(a.p_unc),
                Cell::num(a.eps_gg, 3),
                Cell::P(a.p_gg),
                Cell::num(a.mauchly_w, 3),
                Cell::P(a.mauchly_p),
                Cell::num(a.partial_eta2, 3),
                Cell::Empty,
            ]),
            Err(e) => cells.extend(undefined(9, e)),
        }
        rows.push(Row::new(cells));
    }
    let columns = vec![
        Column::new("Condition", "{condition}"),
        Column::new("Outcome", "{outcome}"),
        Column::new("Participants", "{participants} ({dropped} dropped)"),
        Column::new("F", "F({df1}, {df2}) = {f}undefined: {undefined}"),
        Column::new("p", "{p}"),
        Column::new("GG ε", "{eps_gg}"),
        Column::new("p (GG)", "{p_gg}"),
        Column::new("Mauchly W (p)", "{mauchly_w} ({mauchly_p})"),
        Column::new("partial η²", "{partial_eta2}"),
    ];
    let head = ["condition", "outcome", "emotions", "participants", "dropped"];
    let tail = ["f", "df1", "df2", "p", "eps_gg", "p_gg", "mauchly_w", "mauchly_p", "partial_eta2", UNDEFINED];
    Table::new("rm_anova_emotion.csv", &fields(&head, &tail), rows)
        .titled("Repeated-measures ANOVA over emotion (within-subject; Greenhouse–Geisser corrected)")
        .view(View::Columns(columns))
}

/// Paired t-tests over a two-level factor seen by the same participants.
pub(super) fn paired(r: &RatingReport) -> Table {
    let mut rows = Vec::new();
    for t in &r.design.paired {
        let mut cells = vec![Cell::text(&t.factor), Cell::text(&t.level_a), Cell::text(&t.level_b), Cell::text(&t.outcome), Cell::count(t.participants), Cell::count(t.dropped)];
        cells.extend(describe(t.a.as_ref(), 3).into_iter().skip(1).chain(describe(t.b.as_ref(), 3).into_iter().skip(1)));
        match t.test.as_result() {
            Ok(x) => {
                let (low, high) = x.ci;
                cells.extend([Cell::num(x.t, 3), Cell::num(x.df, 0), Cell::P(x.p_two_sided), Cell::num(x.mean_diff, 3), Cell::num(low, 3), Cell::num(high, 3)]);
                cells.extend([Cell::num(x.cohen_d, 3), Cell::opt_or_empty(x.cohen_dz, 3), Cell::Empty]);
            }
            Err(e) => cells.extend(undefined(8, e)),
        }
        rows.push(Row::new(cells));
    }
    let columns = vec![
        Column::new("Levels (A − B)", "{level_a} − {level_b}"),
        Column::new("Outcome", "{outcome}"),
        Column::new("Participants", "{participants} ({dropped} dropped)"),
        Column::new("Mean A (sd)", "{mean_a} ({sd_a})"),
        Column::new("Mean B (sd)", "{mean_b} ({sd_b})"),
        Column::new("t", "t({df}) = {t}undefined: {undefined}"),
        Column::new("p", "{p}"),
        Column::new("Difference [95% CI]", "{mean_diff} [{ci95_low}, {ci95_high}]"),
        Column::new("d_av / d_z", "{cohen_d} / {cohen_dz}"),
    ];
    let head = ["factor", "level_a", "level_b", "outcome", "participants", "dropped", "mean_a", "sd_a", "mean_b", "sd_b"];
    let tail = ["t", "df", "p", "mean_diff", "ci95_low", "ci95_high", "cohen_d", "cohen_dz", UNDEFINED];
    Table::new("paired_tests.csv", &fields(&head, &tail), rows)
        .titled("Paired t-tests (the same participants saw both levels)")
        .view(View::Columns(columns))
}

/// The one-way ANOVA between condition groups of participants.
pub(super) fn between(r: &RatingReport) -> Table {
    let mut rows = Vec::new();
    for b in &r.design.between_conditions {
        let n: usize = b.groups.iter().flatten().map(|d| d.n).sum();
        let mut cells = vec![Cell::text(&b.outcome), Cell::text(b.conditions.join("; ")), Cell::count(b.conditions.len()), Cell::count(n)];
        match b.anova.as_result() {
            Ok(a) => cells.extend([Cell::num(a.f, 3), Cell::num(a.df_between, 0), Cell::num(a.df_within, 0), Cell::P(a.p), Cell::num(a.eta2, 3), Cell::Empty]),
            Err(e) => cells.extend(undefined(5, e)),
        }
        rows.push(Row::new(cells));
    }
    let columns = vec![
        Column::new("Outcome", "{outcome}"),
        Column::new("Groups (participants)", "{groups} ({participants})"),
        Column::new("F", "F({df_between}, {df_within}) = {f}undefined: {undefined}"),
        Column::new("p", "{p}"),
        Column::new("η²", "{eta2}"),
    ];
    let fields = ["outcome", "conditions", "groups", "participants", "f", "df_between", "df_within", "p", "eta2", UNDEFINED];
    Table::new("anova_between_conditions.csv", &fields, rows)
        .titled("One-way ANOVA between the condition groups (per-participant scores)")
        .view(View::Columns(columns))
}

/// The rows of one post hoc test.
fn pairs<'a>(outcome: &'a str, test: &'a str, conditions: &'a [String], pairs: &'a [Pairwise]) -> impl Iterator<Item = Row> + 'a {
    pairs.iter().map(move |p| {
        let name = |i: usize| Cell::text(conditions.get(i).map_or("", String::as_str));
        let (low, high) = p.ci.map_or((Cell::Empty, Cell::Empty), |(l, h)| (Cell::num(l, 3), Cell::num(h, 3)));
        Row::new(vec![Cell::text(outcome), Cell::text(test), name(p.i), name(p.j), Cell::num(p.mean_diff, 3), Cell::num(p.statistic, 3), Cell::P(p.p), low, high])
    })
}

/// Tukey HSD and Scheffé after a significant one-way ANOVA between condition groups.
pub(super) fn post_hoc(r: &RatingReport) -> Table {
    let mut rows = Vec::new();
    for b in &r.design.between_conditions {
        rows.extend(pairs(&b.outcome, "tukey", &b.conditions, &b.tukey));
        rows.extend(pairs(&b.outcome, "scheffe", &b.conditions, &b.scheffe));
    }
    let columns = vec![
        Column::new("Outcome", "{outcome}"),
        Column::new("Test", "{test}").wording("tukey", "Tukey HSD (q)").wording("scheffe", "Scheffé (F)"),
        Column::new("Groups (A − B)", "{condition_a} − {condition_b}"),
        Column::new("Difference", "{mean_diff}"),
        Column::new("Statistic", "{statistic}"),
        Column::new("p", "{p}"),
        Column::new("Simultaneous 95% CI", "[{ci95_low}, {ci95_high}]"),
    ];
    let fields = ["outcome", "test", "condition_a", "condition_b", "mean_diff", "statistic", "p", "ci95_low", "ci95_high"];
    Table::new("post_hoc_conditions.csv", &fields, rows)
        .titled("Post hoc tests between the condition groups (after a significant ANOVA)")
        .view(View::Columns(columns))
}

/// ICCs of every rating scale per condition, beside Cronbach's α (the page: believability).
pub(super) fn icc(r: &RatingReport) -> Table {
    let mut rows = Vec::new();
    for c in &r.conditions {
        for s in &c.scales {
            let mut cells = vec![Cell::text(&c.key), Cell::text(s.scale.name()), Cell::count(s.alpha_cases), Cell::count(s.alpha_items), Cell::maybe(&s.alpha, 3)];
            match s.icc.as_result() {
                Ok(i) => cells.extend([i.icc2k, i.icc2, i.icc1, i.icc1k, i.icc3, i.icc3k].map(|v| Cell::num(v, 3)).into_iter().chain([Cell::Empty])),
                Err(e) => cells.extend(undefined(6, e)),
            }
            rows.push(Row::new(cells));
        }
    }
    let columns = vec![
        Column::new("Condition", "{condition}"),
        Column::new("Stimuli × raters", "{stimuli}×{raters}"),
        Column::new("Cronbach α", "{alpha}"),
        Column::new("ICC(2,k)", "{icc2k}undefined: {undefined}"),
        Column::new("ICC(2,1)", "{icc2_1}"),
        Column::new("ICC(1,1)", "{icc1_1}"),
        Column::new("ICC(1,k)", "{icc1k}"),
        Column::new("ICC(3,1)", "{icc3_1}"),
        Column::new("ICC(3,k)", "{icc3k}"),
    ];
    let fields = ["condition", "scale", "stimuli", "raters", "alpha", "icc2k", "icc2_1", "icc1_1", "icc1k", "icc3_1", "icc3k", UNDEFINED];
    Table::new("icc.csv", &fields, rows)
        .titled("Intraclass correlation (stimuli × raters, complete data; headline ICC(2,k) and ICC(2,1))")
        .view(View::Columns(columns))
        .page_only("scale", crate::analysis::responses::Scale::Believability.name())
}
