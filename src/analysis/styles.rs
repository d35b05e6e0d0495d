//! Ratings by label and style: the analysis of seed 004's two rating studies.
//!
//! In: the manifest (each stimulus's label and `style`) and the ratings. Out: per rating scale
//! whose stimuli carry at least two styles and two labels, a [`StyleScale`]:
//! - mean and sample SD (n − 1) per label × style cell (seed Fig. 8: real vs generated per
//!   type; Fig. 10: realistic vs cartoon avatar per type), per style and overall;
//! - the two-way between-subjects ANOVA style × label with interaction, on every rating, Type II
//!   and Type III sums of squares (sum-to-zero contrasts; `stats::anova`), factor A = style,
//!   B = label (statsmodels `anova_lm(ols("y ~ C(style, Sum) * C(label, Sum)"), typ=…)`);
//! - Scheffé pairwise tests (`stats::posthoc::scheffe`, scikit-posthocs `posthoc_scheffe`) over
//!   the label × style cells as groups, MS_within of that one-way layout: every pair in the
//!   CSV; the page shows the pairs that differ in style only (the seed's reading: which types
//!   the two avatars are judged differently on).
//!
//! Labels are listed in their set's report order, styles in the order first met in the manifest.
//! **Invariant:** cells with no rating are left out of the tests, never filled.

use serde::Serialize;

use super::manifest::Manifest;
use super::outcome::Outcome;
use super::rating::Describe;
use super::responses::{Responses, Scale};
use super::stats::anova::{AnovaTable, SsType, TwoWayCells, two_way_cells};
use super::stats::posthoc::scheffe;

pub const CONVENTION: &str = "Ratings by label and style (seed 004): per scale, mean and sample SD (n-1) per label x style cell, per style and overall; two-way between-subjects ANOVA style x label with interaction on every rating, Type II and Type III SS (sum-to-zero contrasts; A = style, B = label); Scheffe pairwise tests over the label x style cells as groups (MS_within of the cells, df N - k); the page lists the pairs of one label in two styles.";

/// One label × style cell.
#[derive(Debug, Clone, Serialize)]
pub struct StyleCell {
    pub label: String,
    pub style: String,
    pub stats: Option<Describe>,
}

/// One Scheffé comparison of two cells.
#[derive(Debug, Clone, Serialize)]
pub struct CellPair {
    pub a: StyleKey,
    pub b: StyleKey,
    /// mean_a − mean_b.
    pub mean_diff: f64,
    pub f: f64,
    pub p: f64,
}

/// A cell's label and style.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct StyleKey {
    pub label: String,
    pub style: String,
}

/// One rating scale by label and style.
#[derive(Debug, Clone, Serialize)]
pub struct StyleScale {
    pub scale: Scale,
    pub label_set: String,
    pub styles: Vec<String>,
    pub labels: Vec<String>,
    /// Label-major: every label × style, in `labels` × `styles` order.
    pub cells: Vec<StyleCell>,
    /// Per style over all labels (the seed's grand means per avatar).
    pub per_style: Vec<StyleCell>,
    pub overall: Option<Describe>,
    pub type_ii: Outcome<AnovaTable>,
    pub type_iii: Outcome<AnovaTable>,
    pub scheffe: Outcome<Vec<CellPair>>,
}

/// The ratings of one scale, by (label index, style index).
struct ByCell {
    labels: Vec<String>,
    styles: Vec<String>,
    values: Vec<Vec<f64>>,
}

impl ByCell {
    fn gather(manifest: &Manifest, responses: &Responses, scale: Scale) -> ByCell {
        let labels = manifest.label_set().report_order();
        let mut styles: Vec<String> = Vec::new();
        for s in &manifest.stimuli {
            if !s.style.is_empty() && !styles.contains(&s.style) {
                styles.push(s.style.clone());
            }
        }
        let mut values = vec![Vec::new(); labels.len() * styles.len()];
        for r in responses.ratings.iter().filter(|r| r.scale == scale) {
            let stimulus = &manifest.stimuli[r.stimulus];
            let label = stimulus.emotion.as_ref().and_then(|e| labels.iter().position(|l| l == e));
            let style = styles.iter().position(|s| *s == stimulus.style);
            if let (Some(l), Some(s)) = (label, style) {
                values[l * styles.len() + s].push(r.value);
            }
        }
        ByCell { labels, styles, values }
    }

    fn key(&self, cell: usize) -> StyleKey {
        let k = self.styles.len();
        StyleKey { label: self.labels[cell / k].clone(), style: self.styles[cell % k].clone() }
    }

    /// Whether the data support a style × label analysis: two styles and two labels rated.
    fn crossed(&self) -> bool {
        let k = self.styles.len();
        let rated_styles = (0..k).filter(|s| self.values.iter().skip(*s).step_by(k.max(1)).any(|v| !v.is_empty())).count();
        let rated_labels = self.values.chunks(k.max(1)).filter(|c| c.iter().any(|v| !v.is_empty())).count();
        rated_styles >= 2 && rated_labels >= 2
    }

    fn anova(&self, ss_type: SsType) -> Outcome<AnovaTable> {
        let mut cells = TwoWayCells::with_levels(self.styles.clone(), self.labels.clone());
        for (i, values) in self.values.iter().enumerate() {
            for &v in values {
                cells.add(i % self.styles.len(), i / self.styles.len(), v);
            }
        }
        two_way_cells(&cells, ss_type).map(|table| table.named("style", "label")).into()
    }

    fn scheffe(&self) -> Outcome<Vec<CellPair>> {
        let rated: Vec<usize> = (0..self.values.len()).filter(|&i| !self.values[i].is_empty()).collect();
        let groups: Vec<&[f64]> = rated.iter().map(|&i| self.values[i].as_slice()).collect();
        scheffe(&groups)
            .map(|pairs| pairs.into_iter().map(|p| CellPair { a: self.key(rated[p.i]), b: self.key(rated[p.j]), mean_diff: p.mean_diff, f: p.statistic, p: p.p }).collect())
            .into()
    }
}

fn describe_all<'a>(values: impl Iterator<Item = &'a Vec<f64>>) -> Option<Describe> {
    let all: Vec<f64> = values.flatten().copied().collect();
    super::rating::describe(&all)
}

/// One [`StyleScale`] per rated scale whose stimuli cross at least two styles with two labels.
pub fn analyze(manifest: &Manifest, responses: &Responses) -> Vec<StyleScale> {
    Scale::ALL.into_iter().filter_map(|scale| scale_by_style(manifest, responses, scale)).collect()
}

fn scale_by_style(manifest: &Manifest, responses: &Responses, scale: Scale) -> Option<StyleScale> {
    let by = ByCell::gather(manifest, responses, scale);
    if !by.crossed() {
        return None;
    }
    let k = by.styles.len();
    let cells = (0..by.values.len()).map(|i| StyleCell { label: by.key(i).label, style: by.key(i).style, stats: super::rating::describe(&by.values[i]) }).collect();
    let per_style = by.styles.iter().enumerate().map(|(s, style)| StyleCell { label: String::new(), style: style.clone(), stats: describe_all(by.values.iter().skip(s).step_by(k)) }).collect();
    Some(StyleScale {
        scale,
        label_set: manifest.label_set().id().to_string(),
        overall: describe_all(by.values.iter()),
        type_ii: by.anova(SsType::II),
        type_iii: by.anova(SsType::III),
        scheffe: by.scheffe(),
        cells,
        per_style,
        styles: by.styles,
        labels: by.labels,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::facs::{Catalog, EmotionTable};

    const HEADER: &str = "stimulus_id,media,file,identity,expression,emotion,intensity,style\n";

    fn read(manifest: &str, responses: &str) -> (Manifest, Responses) {
        let (catalog, emotions) = (Catalog::built_in(), EmotionTable::built_in());
        let m = Manifest::from_csv("m.csv", manifest, catalog).unwrap();
        let r = Responses::from_csv("r.csv", responses, &m, catalog, &emotions).unwrap();
        (m, r)
    }

    #[test]
    fn cells_follow_the_label_sets_order_and_the_manifests_styles() {
        let manifest = format!(
            "{HEADER}s1,video,a,wm1,6+12,laughs:sly_smile,1,realistic\ns2,video,b,wm1,6+12,laughs:sly_smile,1,cartoon\ns3,video,c,wm1,6+12,laughs:laughter,1,realistic\ns4,video,d,wm1,6+12,laughs:laughter,1,cartoon\n"
        );
        let mut responses = String::from("participant_id,group,stimulus_id,trial,measure,value,rt_ms\n");
        for (p, values) in [("p1", [4, 2, 5, 3]), ("p2", [5, 3, 4, 3]), ("p3", [3, 1, 5, 4])] {
            for (s, v) in ["s1", "s2", "s3", "s4"].iter().zip(values) {
                responses.push_str(&format!("{p},g,{s},1,q1,{v},\n"));
            }
        }
        let (m, r) = read(&manifest, &responses);
        let out = analyze(&m, &r);
        assert_eq!(out.len(), 1, "only q1 was rated");
        let q1 = &out[0];
        assert_eq!((q1.label_set.as_str(), q1.styles.clone()), ("laughs", vec!["realistic".to_string(), "cartoon".to_string()]));
        let rated: Vec<(&str, &str, f64)> = q1.cells.iter().filter_map(|c| Some((c.label.as_str(), c.style.as_str(), c.stats.as_ref()?.mean))).collect();
        // laughter comes before sly_smile in the set's declared order.
        assert_eq!(rated, [("laughter", "realistic", 14.0 / 3.0), ("laughter", "cartoon", 10.0 / 3.0), ("sly_smile", "realistic", 4.0), ("sly_smile", "cartoon", 2.0)]);
        assert_eq!(q1.per_style[1].stats.as_ref().map(|d| d.n), Some(6));
        let anova = q1.type_iii.as_result().unwrap();
        assert!(anova.row("style").is_some() && anova.row("label").is_some() && anova.row("style:label").is_some());
        let pairs = q1.scheffe.as_result().unwrap();
        assert_eq!(pairs.len(), 6, "four rated cells, six pairs");
        assert_eq!(pairs[0].a, StyleKey { label: "laughter".into(), style: "realistic".into() });
    }

    #[test]
    fn one_style_gives_no_style_analysis() {
        let manifest = format!("{HEADER}s1,video,a,wm1,6+12,laughs:sly_smile,1,realistic\ns2,video,b,wm1,6+12,laughs:laughter,1,realistic\n");
        let responses = "participant_id,group,stimulus_id,trial,measure,value,rt_ms\np1,g,s1,1,q2,4,\np1,g,s2,2,q2,3,\n";
        let (m, r) = read(&manifest, responses);
        assert!(analyze(&m, &r).is_empty());
    }

    /// The reference values of `tests/fixtures/stats/laugh_studies.py` (statsmodels anova_lm,
    /// scikit-posthocs posthoc_scheffe) on the simulated studies beside it.
    fn reference() -> serde_json::Value {
        serde_json::from_str(include_str!("../../tests/fixtures/stats/laugh_studies.expected.json")).expect("the fixture is JSON")
    }

    const FIXTURES: [(&str, &str, &str); 2] = [
        ("description", include_str!("../../tests/fixtures/stats/laughs/description/manifest.csv"), include_str!("../../tests/fixtures/stats/laughs/description/responses.csv")),
        ("motion", include_str!("../../tests/fixtures/stats/laughs/motion/manifest.csv"), include_str!("../../tests/fixtures/stats/laughs/motion/responses.csv")),
    ];

    fn close(what: &str, got: f64, expected: &serde_json::Value) {
        let expected = expected.as_f64().unwrap_or_else(|| panic!("{what}: no reference value"));
        assert!((got - expected).abs() <= 1e-6, "{what}: got {got}, statsmodels/scikit-posthocs {expected}");
    }

    fn check_anova(what: &str, table: &AnovaTable, expected: &serde_json::Value) {
        for term in ["style", "label", "style:label", "residual"] {
            let row = table.row(term).unwrap_or_else(|| panic!("{what}: no {term} row"));
            let e = &expected[if term == "residual" { "Residual" } else { term }];
            close(&format!("{what} {term} SS"), row.ss, &e["ss"]);
            close(&format!("{what} {term} df"), row.df, &e["df"]);
            if let (Some(f), Some(p)) = (row.f, row.p) {
                close(&format!("{what} {term} F"), f, &e["f"]);
                close(&format!("{what} {term} p"), p, &e["p"]);
            }
        }
    }

    #[test]
    fn styles_equal_statsmodels_and_scikit_posthocs() {
        let reference = reference();
        for (study, manifest, responses) in FIXTURES {
            let (m, r) = read(manifest, responses);
            let scales = analyze(&m, &r);
            let expected = &reference["studies"][study];
            assert_eq!(scales.len(), expected.as_object().map_or(0, |o| o.len()), "{study}: one analysis per rated scale");
            for s in &scales {
                let what = format!("{study} {}", s.scale.name());
                let e = &expected[s.scale.name()];
                for c in s.cells.iter().filter(|c| c.stats.is_some()) {
                    let d = c.stats.as_ref().expect("filtered");
                    let cell = &e["cells"][format!("{}|{}", c.label, c.style)];
                    assert_eq!(Some(d.n as u64), cell["n"].as_u64(), "{what} {} {}", c.label, c.style);
                    close(&format!("{what} {} {} mean", c.label, c.style), d.mean, &cell["mean"]);
                    close(&format!("{what} {} {} sd", c.label, c.style), d.sd.unwrap_or(f64::NAN), &cell["sd"]);
                }
                check_anova(&format!("{what} Type II"), s.type_ii.as_result().expect("defined"), &e["type_ii"]);
                check_anova(&format!("{what} Type III"), s.type_iii.as_result().expect("defined"), &e["type_iii"]);
                let pairs = s.scheffe.as_result().expect("defined");
                assert_eq!(Some(pairs.len()), e["scheffe_p"].as_object().map(|o| o.len()), "{what}: every pair");
                for p in pairs {
                    let (a, b) = (format!("{}|{}", p.a.label, p.a.style), format!("{}|{}", p.b.label, p.b.style));
                    let key = if a < b { format!("{a}~{b}") } else { format!("{b}~{a}") };
                    close(&format!("{what} Scheffé {key}"), p.p, &e["scheffe_p"][&key]);
                }
            }
        }
    }

    #[test]
    fn the_reference_data_are_what_simulate_writes() {
        use crate::analysis::simulate::{Design, SimOptions, simulate};
        for ((design, missing), (study, manifest, responses)) in [(Design::LaughDescription, 0.0), (Design::LaughMotion, 0.05)].into_iter().zip(FIXTURES) {
            let (m, r) = simulate(&SimOptions { design, seed: 4, participants: 24, missing, ..SimOptions::default() });
            assert!(m == manifest && r == responses, "{study}: rerun the commands in laugh_studies.py and the script");
        }
    }

    #[test]
    fn the_simulated_effects_show_in_the_report() {
        let (study, manifest, responses) = FIXTURES[0];
        let (m, r) = read(manifest, responses);
        let s = &analyze(&m, &r)[0];
        let mean = |style: &str| s.per_style.iter().find(|c| c.style == style).and_then(|c| c.stats.as_ref()).map(|d| d.mean).unwrap_or(f64::NAN);
        assert!(mean("real") > mean("realistic") + 0.5, "{study}: the real recordings match their descriptions better, as simulated");
        let style = s.type_ii.as_result().unwrap().row("style").unwrap();
        assert!(style.p.unwrap() < 1e-6, "{study}: a 0.9-point source effect on {} ratings is found", s.overall.as_ref().unwrap().n);
    }
}
