//! One CSV per table. Numbers are written unrounded (full `f64` precision); empty = undefined.

use super::Report;
use crate::analysis::coding::{AuCount, CodingReport, Counts, Maybe, Metrics};
use crate::analysis::demographics::Demographics;
use crate::analysis::rating::RatingReport;

struct Table {
    w: csv::Writer<Vec<u8>>,
}

impl Table {
    fn new(header: &[&str]) -> Table {
        let mut w = csv::Writer::from_writer(Vec::new());
        w.write_record(header).expect("in memory");
        Table { w }
    }

    fn row(&mut self, cells: Vec<String>) {
        self.w.write_record(&cells).expect("in memory");
    }

    fn done(self) -> String {
        String::from_utf8(self.w.into_inner().expect("in memory")).expect("UTF-8")
    }
}

fn num(v: f64) -> String {
    v.to_string()
}

fn opt(v: Option<f64>) -> String {
    v.map_or_else(String::new, num)
}

/// The `tp, fp, fn, tn, accuracy, precision, recall, f1` cells of a coder table row.
fn counts_and_metrics(c: &Counts, m: &Metrics) -> [String; 8] {
    [c.tp.to_string(), c.fp.to_string(), c.fn_.to_string(), c.tn.to_string(), num(m.accuracy), num(m.precision), num(m.recall), num(m.f1)]
}

fn maybe(m: &Maybe) -> String {
    opt(m.value)
}

pub(crate) fn au_list(list: &[AuCount]) -> String {
    list.iter().map(|m| format!("{} ({})", m.au, m.count)).collect::<Vec<_>>().join("; ")
}

/// A file-name-safe condition key: `video 100%` → `video_100`.
pub(crate) fn slug(key: &str) -> String {
    key.replace('%', "").replace(' ', "_")
}

/// Every CSV table of the report, by file name.
pub(super) fn all(report: &Report) -> Vec<(String, String)> {
    let mut out = Vec::new();
    if let Some(c) = &report.coding {
        coding_tables(c, &mut out);
    }
    if let Some(r) = &report.rating {
        condition_tables(r, &mut out);
        group_tests_table(r, &mut out);
        anova_table(r, &mut out);
        table14(r, &mut out);
    }
    if let Some(d) = &report.demographics {
        demographics_table(d, &mut out);
    }
    out
}

type Files = Vec<(String, String)>;

/// Tables 1–4 and the coders' agreement.
fn coding_tables(c: &CodingReport, out: &mut Files) {
    let mut t = Table::new(&["au", "name", "shown_in", "tp", "fp", "fn", "tn", "accuracy", "precision", "recall", "f1", "alpha", "fleiss_kappa", "mistaken_for"]);
    for r in &c.per_au {
        let mut cells = vec![r.au.to_string(), r.name.clone(), r.shown_in.to_string()];
        cells.extend(counts_and_metrics(&r.counts, &r.metrics));
        cells.extend([maybe(&r.alpha), maybe(&r.fleiss_kappa), au_list(&r.mistaken_for)]);
        t.row(cells);
    }
    for (label, m) in [("macro mean", c.macro_mean), ("micro", c.micro)] {
        let mut cells = vec![label.to_string(), String::new(), String::new()];
        cells.extend(if label == "micro" {
            [c.total.tp, c.total.fp, c.total.fn_, c.total.tn].map(|v| v.to_string()).to_vec()
        } else {
            vec![String::new(); 4]
        });
        cells.extend([num(m.accuracy), num(m.precision), num(m.recall), num(m.f1), String::new(), String::new(), String::new()]);
        t.row(cells);
    }
    out.push(("table1_3_per_au.csv".into(), t.done()));

    let mut t = Table::new(&["aus", "accuracy", "precision", "recall", "f1"]);
    for g in &c.table1_groups {
        let aus = g.aus.iter().map(|a| format!("AU{a}")).collect::<Vec<_>>().join(", ");
        t.row(vec![aus, num(g.metrics.accuracy), num(g.metrics.precision), num(g.metrics.recall), num(g.metrics.f1)]);
    }
    out.push(("table1_grouped.csv".into(), t.done()));

    let mut t = Table::new(&["au", "alpha", "mistaken_for"]);
    for r in c.per_au.iter().filter(|r| r.shown_in > 0) {
        t.row(vec![r.au.to_string(), maybe(&r.alpha), au_list(&r.mistaken_for)]);
    }
    out.push(("table2_alpha.csv".into(), t.done()));

    let mut t = Table::new(&["combination", "recognised", "stimuli", "answers", "tp", "fp", "fn", "tn", "accuracy", "precision", "recall", "f1"]);
    for r in &c.combinations {
        let mut cells = vec![r.combination.clone(), r.recognised_display.clone(), r.stimuli.to_string(), r.answers.to_string()];
        cells.extend(counts_and_metrics(&r.counts, &r.metrics));
        t.row(cells);
    }
    out.push(("table4_combinations.csv".into(), t.done()));

    let mut t = Table::new(&["coder_a", "coder_b", "common_stimuli", "cohen_kappa", "dice_mean"]);
    for p in &c.agreement.pairs {
        t.row(vec![p.coder_a.clone(), p.coder_b.clone(), p.common_stimuli.to_string(), maybe(&p.cohen_kappa), num(p.dice_mean)]);
    }
    t.row(vec!["all coders (Fleiss)".into(), String::new(), c.agreement.complete_stimuli.to_string(), maybe(&c.agreement.fleiss_kappa), String::new()]);
    out.push(("coder_agreement.csv".into(), t.done()));
}

/// Confusion matrices (Tables 7–10), recognition rates and Table 11.
fn condition_tables(r: &RatingReport, out: &mut Files) {
    let mut rec = Table::new(&["condition", "emotion", "stimuli", "answers", "hits", "rate", "hu", "hu_chance", "binomial_p_vs_chance", "rate_ci95_low", "rate_ci95_high"]);
    let mut belv = Table::new(&["condition", "scale", "emotion", "n", "mean", "sd", "alpha", "alpha_cases", "alpha_items"]);
    for c in &r.conditions {
        if let Some(conf) = &c.confusion {
            for (kind, percent) in [("counts", false), ("percent", true)] {
                let mut header = vec!["shown"];
                header.extend(conf.columns.iter().map(String::as_str));
                let mut t = Table::new(&header);
                for (i, row) in conf.rows.iter().enumerate() {
                    let mut cells = vec![row.clone()];
                    if percent {
                        cells.extend(conf.percent[i].iter().map(|v| num(*v)));
                    } else {
                        cells.extend(conf.counts[i].iter().map(u64::to_string));
                    }
                    t.row(cells);
                }
                out.push((format!("confusion_{}_{kind}.csv", slug(&c.key)), t.done()));
            }
        }
        for e in &c.emotions {
            rec.row(vec![
                c.key.clone(),
                e.emotion.clone(),
                e.stimuli.to_string(),
                e.answers.to_string(),
                e.hits.to_string(),
                num(e.rate),
                num(e.hu),
                num(e.hu_chance),
                num(e.binomial_p),
                num(e.rate_ci95.0),
                num(e.rate_ci95.1),
            ]);
        }
        for s in &c.scales {
            for cell in &s.cells {
                let d = cell.stats.as_ref();
                belv.row(vec![
                    c.key.clone(),
                    s.scale.name().into(),
                    cell.emotion.clone(),
                    d.map_or(0, |d| d.n).to_string(),
                    opt(d.map(|d| d.mean)),
                    opt(d.and_then(|d| d.sd)),
                    maybe(&cell.alpha),
                    cell.alpha_cases.to_string(),
                    cell.alpha_items.to_string(),
                ]);
            }
            let d = s.overall.as_ref();
            belv.row(vec![
                c.key.clone(),
                s.scale.name().into(),
                "all".into(),
                d.map_or(0, |d| d.n).to_string(),
                opt(d.map(|d| d.mean)),
                opt(d.and_then(|d| d.sd)),
                maybe(&s.alpha),
                s.alpha_cases.to_string(),
                s.alpha_items.to_string(),
            ]);
        }
    }
    out.push(("recognition.csv".into(), rec.done()));
    out.push(("table11_ratings.csv".into(), belv.done()));
}

/// Student and Welch tests between the groups.
fn group_tests_table(r: &RatingReport, out: &mut Files) {
    let mut t = Table::new(&[
        "condition", "emotion", "outcome", "group_a", "group_b", "n_a", "mean_a", "sd_a", "n_b", "mean_b", "sd_b", "test", "t", "df", "p", "cohen_d",
        "ci95_low", "ci95_high", "undefined",
    ]);
    for g in &r.group_tests {
        for (name, test) in [("student", g.student.as_result()), ("welch", g.welch.as_result())] {
            let mut cells = vec![g.condition.clone(), g.emotion.clone(), g.outcome.clone(), g.group_a.clone(), g.group_b.clone()];
            for d in [&g.a, &g.b] {
                let d = d.as_ref();
                cells.extend([d.map_or(0, |d| d.n).to_string(), opt(d.map(|d| d.mean)), opt(d.and_then(|d| d.sd))]);
            }
            cells.push(name.into());
            match test {
                Ok(t) => cells.extend([num(t.t), num(t.df), num(t.p_two_sided), num(t.cohen_d), num(t.ci.0), num(t.ci.1), String::new()]),
                Err(e) => {
                    cells.extend(vec![String::new(); 6]);
                    cells.push(e.to_string());
                }
            }
            t.row(cells);
        }
    }
    out.push(("group_tests.csv".into(), t.done()));
}

/// The two-way ANOVAs, Type II and III.
fn anova_table(r: &RatingReport, out: &mut Files) {
    let mut t = Table::new(&["media", "outcome", "n", "ss_type", "term", "ss", "df", "f", "p", "partial_eta2", "undefined"]);
    for a in &r.anova {
        for (ty, table) in [("II", a.type_ii.as_result()), ("III", a.type_iii.as_result())] {
            match table {
                Ok(table) => {
                    for row in &table.rows {
                        let term = row.term.clone();
                        t.row(vec![
                            a.media.label().into(),
                            a.outcome.clone(),
                            a.n.to_string(),
                            ty.into(),
                            term,
                            num(row.ss),
                            num(row.df),
                            opt(row.f),
                            opt(row.p),
                            opt(row.partial_eta2),
                            String::new(),
                        ]);
                    }
                }
                Err(e) => {
                    let mut cells = vec![a.media.label().into(), a.outcome.clone(), a.n.to_string(), ty.into()];
                    cells.extend(vec![String::new(); 6]);
                    cells.push(e.to_string());
                    t.row(cells);
                }
            }
        }
    }
    out.push(("anova.csv".into(), t.done()));
}

/// Table 14: this study beside the published figures.
fn table14(r: &RatingReport, out: &mut Files) {
    if !r.table14.is_empty() {
        let mut t = Table::new(&["emotion", "intensity_percent", "this_study_recognition_percent", "this_study_believability", "system", "published_recognition_percent", "published_believability"]);
        for row in &r.table14 {
            if row.published.is_empty() {
                t.row(vec![row.emotion.clone(), row.intensity_percent.to_string(), opt(row.recognition_percent), opt(row.believability), String::new(), String::new(), String::new()]);
            }
            for (system, (rate, b)) in &row.published {
                t.row(vec![
                    row.emotion.clone(),
                    row.intensity_percent.to_string(),
                    opt(row.recognition_percent),
                    opt(row.believability),
                    system.clone(),
                    num(*rate),
                    num(*b),
                ]);
            }
        }
        out.push(("table14_comparison.csv".into(), t.done()));
    }
}

/// Table 6.
fn demographics_table(d: &Demographics, out: &mut Files) {
    let mut t = Table::new(&["stratum", "participants", "mean_age", "item", "level", "n", "percent", "level_mean_age"]);
    for r in &d.rows {
        for (item, levels) in [("gender", &r.gender), ("ethnicity", &r.ethnicity), ("education", &r.education)] {
            for l in levels {
                t.row(vec![
                    r.stratum.clone(),
                    r.participants.to_string(),
                    opt(r.mean_age),
                    item.into(),
                    l.level.clone(),
                    l.n.to_string(),
                    num(l.percent),
                    opt(l.mean_age),
                ]);
            }
        }
    }
    out.push(("table6_demographics.csv".into(), t.done()));
}
