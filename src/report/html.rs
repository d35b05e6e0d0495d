//! `report.html`: the tables of the seed's layout, the plots, and each section's convention.
//! Plain string building; every piece of text from the data goes through [`esc`].

use std::fmt::Write;

use super::{Report, fmt};
use crate::analysis::coding::Maybe;
use crate::analysis::responses::Scale;

/// HTML-escapes text for element content and quoted attributes.
pub(crate) fn esc(text: &str) -> String {
    let mut out = String::with_capacity(text.len());
    for c in text.chars() {
        match c {
            '&' => out.push_str("&amp;"),
            '<' => out.push_str("&lt;"),
            '>' => out.push_str("&gt;"),
            '"' => out.push_str("&quot;"),
            '\'' => out.push_str("&#39;"),
            c => out.push(c),
        }
    }
    out
}

fn f2(v: f64) -> String {
    fmt(v, 2)
}

fn f3m(m: &Maybe) -> String {
    m.value.map_or_else(|| "–".to_string(), |v| fmt(v, 3))
}

fn p(v: f64) -> String {
    if v < 0.001 { "&lt; .001".into() } else { fmt(v, 3) }
}

struct Html(String);

impl Html {
    fn table(&mut self, header: &[&str], rows: Vec<Vec<String>>) {
        self.0.push_str("<table><thead><tr>");
        for h in header {
            let _ = write!(self.0, "<th>{}</th>", esc(h));
        }
        self.0.push_str("</tr></thead><tbody>");
        for r in rows {
            self.0.push_str("<tr>");
            for c in r {
                // Cells are escaped by the callers (some carry entities).
                let _ = write!(self.0, "<td>{c}</td>");
            }
            self.0.push_str("</tr>");
        }
        self.0.push_str("</tbody></table>");
    }

    fn convention(&mut self, text: &str) {
        let _ = write!(self.0, "<p class=\"conv\"><b>Conventions.</b> {}</p>", esc(text));
    }

    fn img(&mut self, plots: &[(String, String)], name: &str) {
        if let Some((file, caption)) = plots.iter().find(|(f, _)| f == name) {
            let _ = write!(self.0, "<figure><img src=\"{0}\" alt=\"{1}\"><figcaption>{1}</figcaption></figure>", esc(file), esc(caption));
        }
    }
}

const STYLE: &str = "body{font-family:'DejaVu Sans',Verdana,sans-serif;max-width:1150px;margin:2em auto;padding:0 1em;color:#222;line-height:1.4}\
h1{font-size:1.6em}h2{border-bottom:2px solid #3182bd;padding-bottom:.2em;margin-top:2em}h3{margin-top:1.5em}\
table{border-collapse:collapse;margin:.6em 0 1em;font-size:.85em}th,td{border:1px solid #ccc;padding:.25em .5em;text-align:right}\
th{background:#eef4fa}td:first-child,th:first-child{text-align:left}tr:nth-child(even) td{background:#fafafa}\
.conv{font-size:.85em;color:#555;background:#f6f6f0;border-left:4px solid #c9b458;padding:.5em .8em}\
figure{margin:1em 0}img{max-width:100%;border:1px solid #ddd}figcaption{font-size:.85em;color:#555}\
.diag{font-weight:bold;background:#dbe9f6 !important}";

/// The whole page: the inputs, then one section per part of the report.
pub(super) fn page(report: &Report, plots: &[(String, String)]) -> String {
    let mut h = Html(String::new());
    let i = &report.inputs;
    let _ = write!(
        h.0,
        "<!DOCTYPE html><html lang=\"en\"><head><meta charset=\"utf-8\"><title>facslab validation report</title><style>{STYLE}</style></head><body>\
         <h1>Validation report</h1><p>Responses <code>{}</code> ({} rows, {} participants, groups: {}) against manifest <code>{}</code> ({} stimuli). \
         facslab {}. Matching: side {}, intensity {}. Every number here is in <code>report.json</code>; each table is also a CSV file beside this page.</p>",
        esc(&i.responses_file),
        i.rows,
        i.participants,
        esc(&i.groups.join(", ")),
        esc(&i.manifest_file),
        i.stimuli,
        esc(&report.facslab_version),
        if report.options.match_side { "required" } else { "ignored" },
        if report.options.match_intensity { "required" } else { "ignored" },
    );

    if let Some(c) = &report.coding {
        coding_section(&mut h, c, plots);
    }
    if let Some(d) = &report.demographics {
        demographics_section(&mut h, d);
    }
    if let Some(r) = &report.rating {
        rating_conditions(&mut h, r, plots);
        rating_believability(&mut h, r, plots);
        rating_anova(&mut h, r);
        rating_group_tests(&mut h, r);
        rating_table14(&mut h, r);
    }
    h.0.push_str("</body></html>\n");
    h.0
}

/// Experiments 1–2: Tables 1–4 and the coders' agreement.
fn coding_section(h: &mut Html, c: &crate::analysis::coding::CodingReport, plots: &[(String, String)]) {
    h.0.push_str("<h2>FACS coders (Experiments 1–2)</h2>");
    let _ = write!(
        h.0,
        "<p>{} coders, {} coded stimuli, {} answered (coder, stimulus) pairs, {} missing. AU set: {} AUs. \
         Macro mean: accuracy {}, precision {}, recall {}, F1 {}. Micro: accuracy {}, precision {}, recall {}, F1 {}.</p>",
        c.coders.len(),
        c.stimuli,
        c.answered_pairs,
        c.missing_pairs,
        c.au_set.len(),
        f2(c.macro_mean.accuracy),
        f2(c.macro_mean.precision),
        f2(c.macro_mean.recall),
        f2(c.macro_mean.f1),
        f2(c.micro.accuracy),
        f2(c.micro.precision),
        f2(c.micro.recall),
        f2(c.micro.f1),
    );
    h.convention(&c.convention);
    h.0.push_str("<h3>Table 1. AU recognition (AUs with equal rounded results grouped)</h3>");
    let rows = c
        .table1_groups
        .iter()
        .map(|g| {
            let aus = g.aus.iter().map(|a| format!("AU{a}")).collect::<Vec<_>>().join(", ");
            vec![esc(&aus), f2(g.metrics.accuracy), f2(g.metrics.precision), f2(g.metrics.recall), f2(g.metrics.f1)]
        })
        .collect();
    h.table(&["Action Unit", "Accuracy", "Precision", "Recall", "F1-Measure"], rows);
    h.0.push_str("<h3>Tables 2–3. Per AU: metrics, Cronbach's α (coders as items) and AUs mistaken for</h3>");
    let rows = c
        .per_au
        .iter()
        .map(|r| {
            let m = r.metrics;
            let mistaken = if r.mistaken_for.is_empty() { "-".to_string() } else { super::tables::au_list(&r.mistaken_for) };
            vec![
                format!("AU{} {}", r.au, esc(&r.name)),
                r.shown_in.to_string(),
                format!("{}/{}/{}/{}", r.counts.tp, r.counts.fp, r.counts.fn_, r.counts.tn),
                f2(m.accuracy),
                f2(m.precision),
                f2(m.recall),
                f2(m.f1),
                f3m(&r.alpha),
                f3m(&r.fleiss_kappa),
                esc(&mistaken),
            ]
        })
        .collect();
    h.table(&["AU", "shown in", "TP/FP/FN/TN", "Accuracy", "Precision", "Recall", "F1", "α", "Fleiss κ", "Mistaken for (count)"], rows);
    h.img(plots, "plot_f1_per_au.png");
    if c.combinations.iter().any(|r| r.combination.contains('+')) {
        h.0.push_str("<h3>Table 4. AU combinations (false positives in parentheses)</h3>");
        let mut rows: Vec<Vec<String>> = c
            .combinations
            .iter()
            .map(|r| {
                let m = r.metrics;
                vec![esc(&r.combination), esc(&r.recognised_display), f2(m.accuracy), f2(m.precision), f2(m.recall), f2(m.f1)]
            })
            .collect();
        let m = c.combinations_macro_mean;
        rows.push(vec!["<b>Mean</b>".into(), String::new(), f2(m.accuracy), f2(m.precision), f2(m.recall), f2(m.f1)]);
        h.table(&["Shown combination", "Recognised AUs", "Accuracy", "Precision", "Recall", "F1-Measure"], rows);
    }
    h.0.push_str("<h3>Agreement between coders</h3>");
    let mut rows: Vec<Vec<String>> = c
        .agreement
        .pairs
        .iter()
        .map(|p| vec![format!("{} – {}", esc(&p.coder_a), esc(&p.coder_b)), p.common_stimuli.to_string(), f3m(&p.cohen_kappa), fmt(p.dice_mean, 3)])
        .collect();
    rows.push(vec!["all coders (Fleiss κ)".into(), c.agreement.complete_stimuli.to_string(), f3m(&c.agreement.fleiss_kappa), "–".into()]);
    h.table(&["Coders", "Stimuli", "κ", "Dice (mean)"], rows);
}

/// Table 6.
fn demographics_section(h: &mut Html, d: &crate::analysis::demographics::Demographics) {
    h.0.push_str("<h2>Table 6. Participants</h2>");
    h.convention(&d.convention);
    let eth: Vec<String> = {
        let mut v: Vec<String> = Vec::new();
        for r in &d.rows {
            for l in &r.ethnicity {
                if !v.contains(&l.level) {
                    v.push(l.level.clone());
                }
            }
        }
        v
    };
    let genders: Vec<String> = {
        let mut v: Vec<String> = Vec::new();
        for r in &d.rows {
            for l in &r.gender {
                if !v.contains(&l.level) {
                    v.push(l.level.clone());
                }
            }
        }
        v.sort();
        v
    };
    let mut header: Vec<String> = vec!["Stimuli".into(), "# of subjects".into(), "Mean age".into()];
    header.extend(genders.iter().map(|g| format!("{g} (age avg.)")));
    header.extend(eth.iter().cloned());
    let rows = d
        .rows
        .iter()
        .map(|r| {
            let mut cells = vec![esc(&r.stratum), r.participants.to_string(), r.mean_age.map_or("–".into(), |a| fmt(a, 1))];
            for g in &genders {
                cells.push(match r.gender.iter().find(|l| &l.level == g) {
                    Some(l) => format!("{}% ({})", fmt(l.percent, 1), l.mean_age.map_or("–".into(), |a| fmt(a, 1))),
                    None => "0%".into(),
                });
            }
            for e in &eth {
                cells.push(r.ethnicity.iter().find(|l| &l.level == e).map_or("0%".into(), |l| format!("{}%", fmt(l.percent, 1))));
            }
            cells
        })
        .collect();
    let header: Vec<&str> = header.iter().map(String::as_str).collect();
    h.table(&header, rows);
}

/// Experiments 3–4: per condition, the confusion matrix and recognition rates.
fn rating_conditions(h: &mut Html, r: &crate::analysis::rating::RatingReport, plots: &[(String, String)]) {
    h.0.push_str("<h2>Lay raters (Experiments 3–4)</h2>");
    let _ = write!(h.0, "<p>{} answer options; chance = {}.</p>", r.labels.len(), fmt(r.chance, 4));
    h.convention(&r.convention);
    for (n, c) in r.conditions.iter().enumerate() {
        let Some(conf) = &c.confusion else { continue };
        let _ = write!(
            h.0,
            "<h3>Table {}. Emotion recognition rates, {} stimuli ({} participants, {} answers)</h3>",
            7 + n,
            esc(&c.key),
            c.participants,
            c.answers
        );
        let mut header = vec!["Shown \\ chosen".to_string()];
        header.extend(conf.columns.iter().cloned());
        let rows = conf
            .rows
            .iter()
            .enumerate()
            .map(|(i, row)| {
                let mut cells = vec![esc(row)];
                for (j, v) in conf.percent[i].iter().enumerate() {
                    let text = fmt(*v, 1);
                    cells.push(if conf.columns[j] == *row { format!("<span class=\"diag\">{text}</span>") } else { text });
                }
                cells
            })
            .collect();
        let header: Vec<&str> = header.iter().map(String::as_str).collect();
        h.table(&header, rows);
        let _ = write!(
            h.0,
            "<p>Average rate is {} percent (accuracy {} percent).</p>",
            c.average_rate.map_or("–".into(), |v| fmt(100.0 * v, 1)),
            c.accuracy.map_or("–".into(), |v| fmt(100.0 * v, 1))
        );
        let rows = c
            .emotions
            .iter()
            .map(|e| {
                vec![
                    esc(&e.emotion),
                    e.answers.to_string(),
                    fmt(100.0 * e.rate, 1),
                    format!("{}–{}", fmt(100.0 * e.rate_ci95.0, 1), fmt(100.0 * e.rate_ci95.1, 1)),
                    fmt(e.hu, 3),
                    fmt(e.hu_chance, 3),
                    p(e.binomial_p),
                ]
            })
            .collect();
        h.table(&["Emotion", "Answers", "Rate %", "95% CI", "Hu", "Hu chance", "p (binomial vs chance)"], rows);
        h.img(plots, &format!("plot_confusion_{}.png", super::tables::slug(&c.key)));
    }

}

/// Table 11: believability per condition and emotion.
fn rating_believability(h: &mut Html, r: &crate::analysis::rating::RatingReport, plots: &[(String, String)]) {
    let with_belv: Vec<_> = r.conditions.iter().filter_map(|c| c.scales.iter().find(|s| s.scale == Scale::Believability).map(|s| (c, s))).collect();
    if !with_belv.is_empty() {
        h.0.push_str("<h3>Table 11. Believability (sd) and Cronbach's α (participants as items, stimuli as cases)</h3>");
        let mut header = vec!["Emotion".to_string(), "Measure".to_string()];
        header.extend(with_belv.iter().map(|(c, _)| c.key.clone()));
        let mut rows = Vec::new();
        for label in r.labels.iter().filter(|l| *l != "none") {
            if !with_belv.iter().any(|(_, s)| s.cells.iter().any(|x| &x.emotion == label)) {
                continue;
            }
            let cell = |s: &crate::analysis::rating::ScaleSummary| s.cells.iter().find(|x| &x.emotion == label).cloned();
            let mut belv = vec![esc(label), "Belv. (sd)".into()];
            let mut alpha = vec![String::new(), "Cronbach α".into()];
            for (_, s) in &with_belv {
                match cell(s) {
                    Some(x) => {
                        belv.push(x.stats.as_ref().map_or("–".into(), |d| format!("{} ({})", f2(d.mean), d.sd.map_or("–".into(), f2))));
                        alpha.push(f3m(&x.alpha));
                    }
                    None => {
                        belv.push("–".into());
                        alpha.push("–".into());
                    }
                }
            }
            rows.push(belv);
            rows.push(alpha);
        }
        let mut avg = vec!["Average believability".to_string(), String::new()];
        let mut alpha = vec!["All stimuli".to_string(), "Cronbach α".into()];
        for (_, s) in &with_belv {
            avg.push(s.overall.as_ref().map_or("–".into(), |d| format!("{} ({})", f2(d.mean), d.sd.map_or("–".into(), f2))));
            alpha.push(format!("{} ({}×{})", f3m(&s.alpha), s.alpha_cases, s.alpha_items));
        }
        rows.push(avg);
        rows.push(alpha);
        let header: Vec<&str> = header.iter().map(String::as_str).collect();
        h.table(&header, rows);
        h.img(plots, "plot_believability.png");
    }

}

/// The two-way ANOVAs.
fn rating_anova(h: &mut Html, r: &crate::analysis::rating::RatingReport) {
    if !r.anova.is_empty() {
        h.0.push_str("<h3>Two-way ANOVA: emotion × intensity (per media)</h3>");
        let mut rows = Vec::new();
        for a in &r.anova {
            for (ty, t) in [("II", a.type_ii.as_result()), ("III", a.type_iii.as_result())] {
                match t {
                    Ok(t) => {
                        for row in &t.rows {
                            let term = row.term.replace(':', " × ");
                            rows.push(vec![
                                a.media.label().into(),
                                esc(&a.outcome),
                                ty.into(),
                                term.into(),
                                fmt(row.ss, 3),
                                fmt(row.df, 0),
                                row.f.map_or(String::new(), |f| fmt(f, 3)),
                                row.p.map_or(String::new(), p),
                                row.partial_eta2.map_or(String::new(), |e| fmt(e, 4)),
                            ]);
                        }
                    }
                    Err(e) => rows.push(vec![a.media.label().into(), esc(&a.outcome), ty.into(), format!("undefined: {}", esc(e)), String::new(), String::new(), String::new(), String::new(), String::new()]),
                }
            }
        }
        h.table(&["Media", "Outcome", "SS type", "Term", "SS", "df", "F", "p", "partial η²"], rows);
    }

}

/// Group comparisons.
fn rating_group_tests(h: &mut Html, r: &crate::analysis::rating::RatingReport) {
    let overall: Vec<_> = r.group_tests.iter().filter(|g| g.emotion == "all").collect();
    if !overall.is_empty() {
        h.0.push_str("<h3>Group comparisons (per-participant scores; per-emotion tests in group_tests.csv)</h3>");
        let mut rows = Vec::new();
        for g in overall {
            for (name, t) in [("Student", g.student.as_result()), ("Welch", g.welch.as_result())] {
                let d = |x: &Option<crate::analysis::rating::Describe>| x.as_ref().map_or("–".into(), |d| format!("{} (n={})", fmt(d.mean, 3), d.n));
                let mut cells = vec![esc(&g.condition), esc(&g.outcome), format!("{} vs {}", esc(&g.group_a), esc(&g.group_b)), d(&g.a), d(&g.b), name.into()];
                match t {
                    Ok(t) => cells.extend([fmt(t.t, 3), fmt(t.df, 2), p(t.p_two_sided), fmt(t.cohen_d, 3), format!("[{}, {}]", fmt(t.ci.0, 3), fmt(t.ci.1, 3))]),
                    Err(e) => {
                        cells.push(format!("undefined: {}", esc(e)));
                        cells.extend(vec![String::new(); 4]);
                    }
                }
                rows.push(cells);
            }
        }
        h.table(&["Condition", "Outcome", "Groups", "Mean A", "Mean B", "Test", "t", "df", "p", "Cohen's d", "95% CI of difference"], rows);
    }

}

/// Table 14.
fn rating_table14(h: &mut Html, r: &crate::analysis::rating::RatingReport) {
    if !r.table14.is_empty() {
        h.0.push_str("<h3>Table 14. Static expressions: this study beside published figures (rate % (believability))</h3>");
        let systems: Vec<String> = {
            let mut v: Vec<String> = r.table14.iter().flat_map(|x| x.published.keys().cloned()).collect();
            v.sort();
            v.dedup();
            v
        };
        let mut header = vec!["Emotion".to_string(), "Intensity".to_string(), "This study".to_string()];
        header.extend(systems.iter().map(|s| format!("{s} (published)")));
        let rows = r
            .table14
            .iter()
            .map(|x| {
                let mut cells = vec![
                    esc(&x.emotion),
                    format!("{}%", x.intensity_percent),
                    format!("{} ({})", x.recognition_percent.map_or("–".into(), |v| fmt(v, 1)), x.believability.map_or("–".into(), f2)),
                ];
                for s in &systems {
                    cells.push(x.published.get(s).map_or("–".into(), |(rate, b)| format!("{} ({})", fmt(*rate, 2), fmt(*b, 1))));
                }
                cells
            })
            .collect();
        let header: Vec<&str> = header.iter().map(String::as_str).collect();
        h.table(&header, rows);
        h.0.push_str("<p class=\"conv\">Published figures: HapFACS 3.0, Table 14 (FACSGen believability rescaled from 7 to 5 points by its authors); file <code>analysis/published/table14.csv</code>.</p>");
    }
}


#[cfg(test)]
mod tests {
    use super::esc;

    #[test]
    fn escapes_markup() {
        assert_eq!(esc("<a href=\"x\">&'"), "&lt;a href=&quot;x&quot;&gt;&amp;&#39;");
    }
}
