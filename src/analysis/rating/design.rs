//! The statistics a rater study's design calls for, decided from who saw what.
//!
//! In: the rater section's conditions (media × intensity, with their participants, answers and
//! ratings) and the emotions shown in each. Out: [`DesignTests`]: repeated-measures ANOVAs over
//! emotion, paired t-tests over a two-level factor, a one-way ANOVA between condition groups with
//! its post hoc tests, and a note for every test that the design does not call for, saying why.
//!
//! Rules (written into the report as [`DESIGN_CONVENTION`]):
//! - a participant's **score** is their proportion correct or their mean believability, over the
//!   stimuli of one level (an emotion, a condition);
//! - **within-subject**: a factor is within-subject when at least two participants have a score
//!   at every level and they are at least half of the participants with any score; the others
//!   are dropped and counted (`dropped`). Then: RM ANOVA over the shown emotions of each
//!   condition (≥ 2 emotions), and a paired t-test per two-level factor (intensity within a
//!   media, media within an intensity), first level minus second in the report's order;
//! - **between-subjects**: when no participant has answers or ratings in two conditions, the
//!   conditions are groups of participants: a one-way ANOVA over them (≥ 2 groups), and Tukey HSD
//!   and Scheffé post hoc tests only after a significant ANOVA (p < .05) of ≥ 3 groups.
//!
//! **Invariant:** every test is either in the result or named in `notes` with the reason it is
//! absent; none is shown for a design that does not call for it.

use serde::Serialize;

use super::{BELIEVABILITY_OUTCOME, ConditionData, Context, Describe, RECOGNITION_OUTCOME, Scale, Tallies, describe};
use crate::analysis::outcome::Outcome;
use crate::analysis::stats::anova::{OneWay, RmAnova, one_way, rm_one_way};
use crate::analysis::stats::posthoc::{Pairwise, scheffe, tukey_hsd};
use crate::analysis::stats::ttest::{TTest, paired_t};

/// The significance level that opens the post hoc tests.
pub const POST_HOC_ALPHA: f64 = 0.05;

pub const DESIGN_CONVENTION: &str = "Statistics the design calls for, decided from who saw what. Score = a participant's proportion correct or mean believability over the stimuli of one level. Within-subject factor: at least 2 participants have a score at every level and they are at least half of those with any score; the others are dropped (counted). Then a repeated-measures ANOVA over the shown emotions of each condition (one-way, complete cases; sphericity by Mauchly's W; Greenhouse-Geisser epsilon and GG-corrected p; partial eta squared), and a paired t-test (two-sided, first level minus second, Cohen's d_av and d_z, 95% CI) for each two-level factor seen by the same participants (intensity within a media, media within an intensity). Between-subjects: when no participant answered in two conditions, the media x intensity conditions are groups of participants: one-way ANOVA of the per-participant scores; Tukey HSD (Tukey-Kramer, simultaneous 95% CI) and Scheffe post hoc tests only after a significant ANOVA (p < .05) of at least 3 groups. ICC: Shrout & Fleiss forms on the complete stimuli x raters matrix of each condition (the matrix of its Cronbach's alpha); headline ICC(2,k) (two-way random, absolute agreement, mean of the k raters: the reliability of the reported mean ratings) and ICC(2,1) (one rater); ICC(3,k) equals that alpha.";

/// A repeated-measures ANOVA over the emotions shown in one condition.
#[derive(Debug, Clone, Serialize)]
pub struct WithinEmotion {
    pub condition: String,
    pub outcome: String,
    pub emotions: Vec<String>,
    /// Participants with a score for every emotion (the ANOVA's subjects).
    pub participants: usize,
    /// Participants with some but not all scores, left out.
    pub dropped: usize,
    /// Mean score per emotion over the participants used.
    pub means: Vec<f64>,
    pub anova: Outcome<RmAnova>,
}

/// A paired t-test over a two-level factor seen by the same participants.
#[derive(Debug, Clone, Serialize)]
pub struct PairedTest {
    /// `intensity` or `media`.
    pub factor: String,
    pub level_a: String,
    pub level_b: String,
    pub outcome: String,
    pub participants: usize,
    pub dropped: usize,
    pub a: Option<Describe>,
    pub b: Option<Describe>,
    /// On score(level_a) − score(level_b).
    pub test: Outcome<TTest>,
}

/// A one-way ANOVA between the condition groups of participants, with post hoc tests.
#[derive(Debug, Clone, Serialize)]
pub struct BetweenConditions {
    pub outcome: String,
    pub conditions: Vec<String>,
    pub groups: Vec<Option<Describe>>,
    pub anova: Outcome<OneWay>,
    /// Pairs index `conditions`; empty unless the ANOVA is significant with ≥ 3 groups.
    pub tukey: Vec<Pairwise>,
    pub scheffe: Vec<Pairwise>,
}

/// Everything the design calls for, and why the rest is absent.
#[derive(Debug, Clone, Serialize)]
pub struct DesignTests {
    pub convention: String,
    pub within_emotion: Vec<WithinEmotion>,
    pub paired: Vec<PairedTest>,
    pub between_conditions: Vec<BetweenConditions>,
    pub notes: Vec<String>,
}

/// A participant's score at one level, from one condition's tallies.
type Score<'a> = Box<dyn Fn(usize) -> Option<f64> + 'a>;

/// The participants with a score at every level, as wide rows (participant × level), and how
/// many had some score but not all; `Err` with the reason when the factor is not within-subject.
fn complete(participants: &[usize], levels: &[Score<'_>]) -> Result<(Vec<Vec<f64>>, usize), String> {
    let mut rows = Vec::new();
    let mut partial = 0;
    for &p in participants {
        let row: Vec<Option<f64>> = levels.iter().map(|score| score(p)).collect();
        match row.iter().copied().collect::<Option<Vec<f64>>>() {
            Some(full) => rows.push(full),
            None if row.iter().any(Option::is_some) => partial += 1,
            None => {}
        }
    }
    let any = rows.len() + partial;
    if rows.len() < 2 || 2 * rows.len() < any {
        return Err(format!("{} of {any} participants have a score at every level", rows.len()));
    }
    Ok((rows, partial))
}

/// A participant's score in a condition's tallies for a label (`None`: over all its stimuli).
type TallyScore = fn(&Tallies, usize, Option<usize>) -> Option<f64>;

/// The two outcomes, each with a participant's score in a condition's tallies for a label
/// (`None`: over all its stimuli); believability only when rated, recognition only when answered.
fn outcomes(ctx: &Context<'_>, answered: bool) -> Vec<(&'static str, TallyScore)> {
    let mut out: Vec<(&'static str, TallyScore)> = Vec::new();
    if answered {
        out.push((RECOGNITION_OUTCOME, |t, p, l| t.correct_rate(p, l)));
    }
    if ctx.scales_present.contains(&Scale::Believability) {
        out.push((BELIEVABILITY_OUTCOME, |t, p, l| t.believability_mean(p, l)));
    }
    out
}

/// RM ANOVAs over the shown emotions of each condition.
fn within_emotion(ctx: &Context<'_>, data: &[ConditionData<'_>], tallies: &[Tallies], shown: &[Vec<usize>], notes: &mut Vec<String>) -> Vec<WithinEmotion> {
    let mut out = Vec::new();
    for ((d, tally), labels) in data.iter().zip(tallies).zip(shown) {
        if labels.len() < 2 {
            notes.push(format!("RM ANOVA over emotion, {}: not called for (one emotion shown)", d.name));
            continue;
        }
        for (outcome, score) in outcomes(ctx, !d.answers.is_empty()) {
            let levels: Vec<Score<'_>> = labels.iter().map(|&t| Box::new(move |p: usize| score(tally, p, Some(t))) as Score<'_>).collect();
            match complete(&d.participants, &levels) {
                Ok((rows, dropped)) => {
                    let means = (0..labels.len()).map(|j| rows.iter().map(|r| r[j]).sum::<f64>() / rows.len() as f64).collect();
                    let emotions = labels.iter().map(|&t| ctx.labels[t].clone()).collect();
                    out.push(WithinEmotion { condition: d.name.clone(), outcome: outcome.into(), emotions, participants: rows.len(), dropped, means, anova: rm_one_way(&rows).into() });
                }
                Err(why) => notes.push(format!("RM ANOVA over emotion, {}, {outcome}: not called for, emotion is not within-subject ({why})", d.name)),
            }
        }
    }
    out
}

/// The pairs of conditions that differ in one two-level factor: (factor, a, b) as indices of
/// `data`, a before b in the report's order.
fn two_level_pairs(data: &[ConditionData<'_>]) -> Vec<(&'static str, usize, usize)> {
    let mut pairs = Vec::new();
    for (factor, same, differs) in [("intensity", 0, 1), ("media", 1, 0)] {
        let part = |d: &ConditionData<'_>, i: usize| if i == 0 { d.key.0.as_str().to_string() } else { d.key.1.to_string() };
        for a in 0..data.len() {
            let slice: Vec<usize> = (0..data.len()).filter(|&b| part(&data[b], same) == part(&data[a], same)).collect();
            if slice.len() == 2 && slice[0] == a && part(&data[a], differs) != part(&data[slice[1]], differs) {
                pairs.push((factor, a, slice[1]));
            }
        }
    }
    pairs
}

/// Paired t-tests over each two-level factor seen by the same participants.
fn paired(ctx: &Context<'_>, data: &[ConditionData<'_>], tallies: &[Tallies], notes: &mut Vec<String>) -> Vec<PairedTest> {
    let mut out = Vec::new();
    for (factor, a, b) in two_level_pairs(data) {
        let (da, db) = (&data[a], &data[b]);
        let mut participants: Vec<usize> = da.participants.iter().chain(&db.participants).copied().collect();
        participants.sort_unstable();
        participants.dedup();
        for (outcome, score) in outcomes(ctx, !da.answers.is_empty() && !db.answers.is_empty()) {
            let levels: Vec<Score<'_>> = [a, b].iter().map(|&i| Box::new(move |p: usize| score(&tallies[i], p, None)) as Score<'_>).collect();
            match complete(&participants, &levels) {
                Ok((rows, dropped)) => {
                    let (x, y): (Vec<f64>, Vec<f64>) = rows.iter().map(|r| (r[0], r[1])).unzip();
                    let test = paired_t(&x, &y, 0.95).into();
                    out.push(PairedTest { factor: factor.into(), level_a: da.name.clone(), level_b: db.name.clone(), outcome: outcome.into(), participants: rows.len(), dropped, a: describe(&x), b: describe(&y), test });
                }
                Err(why) => notes.push(format!("Paired t, {} vs {}, {outcome}: not called for, {factor} is not within-subject ({why})", da.name, db.name)),
            }
        }
    }
    out
}

/// The one-way ANOVA between condition groups and, after a significant one, the post hoc tests.
fn between_conditions(ctx: &Context<'_>, data: &[ConditionData<'_>], tallies: &[Tallies], notes: &mut Vec<String>) -> Vec<BetweenConditions> {
    if data.len() < 2 {
        return Vec::new();
    }
    let mut seen = vec![0usize; ctx.n_participants()];
    data.iter().flat_map(|d| &d.participants).for_each(|&p| seen[p] += 1);
    let shared = seen.iter().filter(|&&n| n > 1).count();
    if shared > 0 {
        notes.push(format!("One-way ANOVA between conditions: not called for, {shared} participants answered in more than one condition (the conditions are not separate groups)"));
        return Vec::new();
    }
    let answered = data.iter().any(|d| !d.answers.is_empty());
    let mut out = Vec::new();
    for (outcome, score) in outcomes(ctx, answered) {
        let scored: Vec<(String, Vec<f64>)> = data.iter().zip(tallies).map(|(d, t)| (d.name.clone(), d.participants.iter().filter_map(|&p| score(t, p, None)).collect::<Vec<f64>>())).filter(|(_, v)| !v.is_empty()).collect();
        let groups: Vec<&[f64]> = scored.iter().map(|(_, v)| v.as_slice()).collect();
        let anova: Outcome<OneWay> = one_way(&groups).into();
        let (tukey, scheffe) = post_hoc(&anova, &groups, outcome, notes);
        let (conditions, summaries) = scored.iter().map(|(name, v)| (name.clone(), describe(v))).unzip();
        out.push(BetweenConditions { outcome: outcome.into(), conditions, groups: summaries, anova, tukey, scheffe });
    }
    out
}

/// Tukey HSD and Scheffé after a significant ANOVA of ≥ 3 groups; otherwise a note saying why not.
fn post_hoc(anova: &Outcome<OneWay>, groups: &[&[f64]], outcome: &str, notes: &mut Vec<String>) -> (Vec<Pairwise>, Vec<Pairwise>) {
    let why_not = match anova.as_result() {
        Err(e) => format!("the ANOVA is undefined ({e})"),
        Ok(_) if groups.len() < 3 => "two groups: the ANOVA is the pairwise comparison".to_string(),
        Ok(a) if a.p >= POST_HOC_ALPHA => format!("the ANOVA is not significant (p = {:.3} ≥ .05)", a.p),
        Ok(_) => match (tukey_hsd(groups, 0.95), scheffe(groups)) {
            (Ok(t), Ok(s)) => return (t, s),
            (Err(e), _) | (_, Err(e)) => format!("undefined ({e})"),
        },
    };
    notes.push(format!("Post hoc tests between conditions, {outcome}: not shown, {why_not}"));
    (Vec::new(), Vec::new())
}

/// The emotions portrayed by the stimuli that were answered or rated in a condition (display
/// indices, in display order).
fn emotions_judged(ctx: &Context<'_>, d: &ConditionData<'_>) -> Vec<usize> {
    let stimuli = d.answers.iter().map(|e| e.stimulus).chain(d.ratings.iter().map(|r| r.stimulus));
    let labels: std::collections::BTreeSet<usize> = stimuli.filter_map(|s| ctx.stim_label(s)).collect();
    labels.into_iter().collect()
}

/// Every test the design of these conditions calls for.
pub(super) fn analyze(ctx: &Context<'_>, data: &[ConditionData<'_>]) -> DesignTests {
    let tallies: Vec<Tallies> = data.iter().map(|d| Tallies::new(ctx, d)).collect();
    let shown: Vec<Vec<usize>> = data.iter().map(|d| emotions_judged(ctx, d)).collect();
    let mut notes = Vec::new();
    let within_emotion = within_emotion(ctx, data, &tallies, &shown, &mut notes);
    let paired = paired(ctx, data, &tallies, &mut notes);
    if two_level_pairs(data).is_empty() {
        notes.push("Paired t: not called for, no two conditions differ in one two-level factor".into());
    }
    let between_conditions = between_conditions(ctx, data, &tallies, &mut notes);
    DesignTests { convention: DESIGN_CONVENTION.into(), within_emotion, paired, between_conditions, notes }
}

#[cfg(test)]
mod tests {
    use std::fmt::Write;

    use super::super::{RatingReport, analyze};
    use super::*;
    use crate::analysis::stats::test_support::{G1, G2, G3, POST, PRE, assert_close, r, rm_wide};

    /// The extra references of these tests (`tests/fixtures/stats/report_design.expected.json`:
    /// scipy.stats.tukey_hsd and pingouin.intraclass_corr on the inputs written there).
    fn fixture(path: &str) -> f64 {
        let text = include_str!("../../../tests/fixtures/stats/report_design.expected.json");
        let json: serde_json::Value = serde_json::from_str(text).expect("fixture parses");
        json.pointer(&format!("/{path}")).and_then(serde_json::Value::as_f64).unwrap_or_else(|| panic!("{path} missing"))
    }

    /// `m` ratings on the 0–5 scale that sum to `sum` (as even as possible).
    fn ratings_summing_to(sum: u32, m: u32) -> Vec<u32> {
        assert!(sum <= 5 * m, "{sum} does not fit {m} ratings of at most 5");
        (0..m).map(|i| sum / m + u32::from(i < sum % m)).collect()
    }

    /// A study built row by row: stimuli per (media, intensity, emotion) and believability ratings.
    #[derive(Default)]
    struct Study {
        manifest: String,
        responses: String,
    }

    const EXPRESSIONS: [(&str, &str); 3] = [("happiness", "6+12+25"), ("sadness", "1+4+15"), ("surprise", "1+2+5+26")];

    impl Study {
        /// `n` stimuli of one emotion in one condition; returns their ids.
        fn stimuli(&mut self, media: &str, intensity: &str, emotion: usize, n: usize) -> Vec<String> {
            let (label, expression) = EXPRESSIONS[emotion];
            (0..n)
                .map(|i| {
                    let id = format!("{media}{intensity}{label}{i}");
                    let _ = writeln!(self.manifest, "{id},{media},wm1,{expression},{label},{intensity}");
                    id
                })
                .collect()
        }

        /// Participant `pid` rates `stimuli` with ratings summing to `sum`.
        fn rate(&mut self, pid: &str, stimuli: &[String], sum: u32) {
            for (s, v) in stimuli.iter().zip(ratings_summing_to(sum, stimuli.len() as u32)) {
                let _ = writeln!(self.responses, "{pid},g,{s},1,believability,{v},");
            }
        }

        fn report(&self) -> RatingReport {
            let (m, r) = crate::analysis::fixture(&self.manifest, &self.responses);
            analyze(&m, &r).expect("ratings present")
        }
    }

    #[test]
    fn rm_anova_over_emotion_equals_the_reference() {
        // RM of stats_reference.py (6 subjects × 3 conditions, values 7–16) as per-participant mean
        // believability over 4 stimuli per emotion: ratings summing to y, so each mean is y / 4.
        // F, its dfs and p, ε, Mauchly's W and its p are unchanged by that scaling.
        let mut study = Study::default();
        let stimuli: Vec<Vec<String>> = (0..3).map(|e| study.stimuli("image", "1", e, 4)).collect();
        let wide = rm_wide();
        for (i, row) in wide.iter().enumerate() {
            for (e, &y) in row.iter().enumerate() {
                study.rate(&format!("p{i}"), &stimuli[e], y as u32);
            }
        }
        let rep = study.report();
        let [w] = rep.design.within_emotion.as_slice() else { panic!("one RM ANOVA: {:?}", rep.design.within_emotion) };
        assert_eq!((w.condition.as_str(), w.outcome.as_str(), w.participants, w.dropped), ("image 100%", BELIEVABILITY_OUTCOME, 6, 0));
        assert_eq!(w.emotions, ["happiness", "sadness", "surprise"]);
        let a = w.anova.as_result().expect("defined");
        assert_eq!((a.df1, a.df2), (r("rm_anova/df1"), r("rm_anova/df2")));
        for (what, got, expected) in [("F", a.f, "F"), ("p", a.p_unc, "p_unc"), ("p GG", a.p_gg, "p_GG"), ("eps", a.eps_gg, "eps_GG"), ("W", a.mauchly_w, "sphericity_W"), ("p W", a.mauchly_p, "sphericity_p")] {
            assert_close(what, got, r(&format!("rm_anova/{expected}")));
        }
        let column_mean = |j: usize| wide.iter().map(|row| row[j]).sum::<f64>() / 6.0 / 4.0;
        assert_close("mean of sadness", w.means[1], column_mean(1));
    }

    /// Groups G1–G3 of stats_reference.py, one participant per value, in three conditions of
    /// 20 stimuli each; each mean believability is y / 2 (ratings summing to 10 y).
    fn three_condition_groups(groups: [&[f64]; 3]) -> RatingReport {
        let mut study = Study::default();
        let mut pn = 0;
        for ((media, intensity), group) in [("video", "1"), ("video", "0.5"), ("image", "1")].into_iter().zip(groups) {
            let stimuli = study.stimuli(media, intensity, 0, 20);
            for y in group {
                pn += 1;
                study.rate(&format!("p{pn}"), &stimuli, (10.0 * y).round() as u32);
            }
        }
        study.report()
    }

    #[test]
    fn anova_between_conditions_and_post_hoc_equal_the_references() {
        let rep = three_condition_groups([&G1, &G2, &G3]);
        let [b] = rep.design.between_conditions.as_slice() else { panic!("one ANOVA: {:?}", rep.design.notes) };
        assert_eq!(b.conditions, ["video 100%", "video 50%", "image 100%"]);
        let a = b.anova.as_result().expect("defined");
        // F and p are unchanged by halving every value.
        assert_close("one-way F", a.f, r("anova_oneway/F"));
        assert_close("one-way p", a.p, r("anova_oneway/p"));
        let names = ["g1-g2", "g1-g3", "g2-g3"];
        assert_eq!(b.scheffe.len(), 3);
        for (pair, name) in b.scheffe.iter().zip(names) {
            assert_close("Scheffé F", pair.statistic, r(&format!("scheffe/{name}/F_scheffe")));
            assert_close("Scheffé p", pair.p, r(&format!("scheffe/{name}/p")));
        }
        assert_eq!(b.tukey.len(), 3);
        for (pair, name) in b.tukey.iter().zip(names) {
            let path = format!("tukey_hsd/pairs/{name}");
            assert_close("Tukey difference", pair.mean_diff, fixture(&format!("{path}/mean_diff")));
            assert_close("Tukey p", pair.p, fixture(&format!("{path}/p")));
            let (low, high) = pair.ci.expect("Tukey has a CI");
            assert_close("Tukey CI low", low, fixture(&format!("{path}/ci95/0")));
            assert_close("Tukey CI high", high, fixture(&format!("{path}/ci95/1")));
        }
        // Separate groups: no paired test, no RM ANOVA (one emotion), each said so.
        assert!(rep.design.paired.is_empty() && rep.design.within_emotion.is_empty());
        assert!(rep.design.notes.iter().any(|n| n.starts_with("Paired t, video 100% vs video 50%") && n.contains("0 of 11")), "{:?}", rep.design.notes);
    }

    #[test]
    fn post_hoc_tests_are_absent_after_a_non_significant_anova() {
        // Three groups with nearly equal means: the ANOVA is computed, the post hoc tests are not.
        let rep = three_condition_groups([&[5.0, 5.2, 4.8, 5.1], &[5.1, 4.9, 5.0], &[5.2, 4.8, 5.0, 5.0]]);
        let [b] = rep.design.between_conditions.as_slice() else { panic!("one ANOVA") };
        assert!(b.anova.as_result().expect("defined").p >= POST_HOC_ALPHA);
        assert!(b.tukey.is_empty() && b.scheffe.is_empty());
        assert!(rep.design.notes.iter().any(|n| n.contains("Post hoc") && n.contains("not significant")), "{:?}", rep.design.notes);
    }

    #[test]
    fn paired_t_over_intensity_equals_the_reference() {
        // PRE and POST of stats_reference.py as each participant's mean believability over the 10
        // video stimuli at 100 % (PRE) and at 50 % (POST), ratings summing to 10 y: means equal y.
        let mut study = Study::default();
        let (full, half) = (study.stimuli("video", "1", 0, 10), study.stimuli("video", "0.5", 0, 10));
        for (i, (pre, post)) in PRE.iter().zip(POST).enumerate() {
            study.rate(&format!("p{i}"), &full, (10.0 * pre).round() as u32);
            study.rate(&format!("p{i}"), &half, (10.0 * post).round() as u32);
        }
        let rep = study.report();
        let [t] = rep.design.paired.as_slice() else { panic!("one paired test: {:?}", rep.design.notes) };
        assert_eq!((t.factor.as_str(), t.level_a.as_str(), t.level_b.as_str(), t.participants, t.dropped), ("intensity", "video 100%", "video 50%", 8, 0));
        let x = t.test.as_result().expect("defined");
        assert_close("paired t", x.t, r("ttest_rel/t"));
        assert_close("paired p", x.p_two_sided, r("ttest_rel/p_two_sided"));
        assert_eq!(x.df, r("ttest_rel/df"));
        // The same participants in both conditions: they are not separate groups.
        assert!(rep.design.between_conditions.is_empty());
        assert!(rep.design.notes.iter().any(|n| n.contains("8 participants answered in more than one condition")), "{:?}", rep.design.notes);
    }

    #[test]
    fn icc_beside_alpha_equals_pingouin() {
        let data = [[4, 3, 5, 4], [2, 2, 3, 1], [5, 4, 5, 5], [1, 0, 2, 1], [3, 3, 4, 2], [2, 1, 1, 2]];
        let mut study = Study::default();
        let stimuli = study.stimuli("image", "1", 0, 6);
        for rater in 0..4 {
            for (s, row) in stimuli.iter().zip(&data) {
                let _ = writeln!(study.responses, "r{rater},g,{s},1,believability,{},", row[rater]);
            }
        }
        let rep = study.report();
        let scale = &rep.conditions[0].scales[0];
        let i = scale.icc.as_result().expect("defined");
        let v = |name: &str| fixture(&format!("icc/values/{name}"));
        for (what, got, name) in [("ICC(1,1)", i.icc1, "ICC(1,1)"), ("ICC(2,1)", i.icc2, "ICC(A,1)"), ("ICC(3,1)", i.icc3, "ICC(C,1)"), ("ICC(1,k)", i.icc1k, "ICC(1,k)"), ("ICC(2,k)", i.icc2k, "ICC(A,k)"), ("ICC(3,k)", i.icc3k, "ICC(C,k)")] {
            assert_close(what, got, v(name));
        }
        // Cronbach's α with the raters as items is ICC(3,k) (consistency of the mean of k raters).
        assert_close("alpha = ICC(3,k)", scale.alpha.value.expect("alpha"), i.icc3k);
        assert_eq!((scale.alpha_cases, scale.alpha_items), (6, 4));
    }

    #[test]
    fn rm_anova_drops_incomplete_participants_and_is_absent_for_one_emotion_per_participant() {
        let mut study = Study::default();
        let stimuli: Vec<Vec<String>> = (0..3).map(|e| study.stimuli("image", "1", e, 1)).collect();
        // p0–p3 rate all three emotions, p4 only two: four used, one dropped.
        for (p, sums) in [[3, 4, 5], [2, 4, 4], [3, 3, 5], [1, 2, 4]].iter().enumerate() {
            for (e, &sum) in sums.iter().enumerate() {
                study.rate(&format!("p{p}"), &stimuli[e], sum);
            }
        }
        study.rate("p4", &stimuli[0], 2);
        study.rate("p4", &stimuli[1], 3);
        let rep = study.report();
        let [w] = rep.design.within_emotion.as_slice() else { panic!("one RM ANOVA") };
        assert_eq!((w.participants, w.dropped), (4, 1));
        // Each participant rates one emotion only: emotion is between-subjects, no RM ANOVA.
        let mut study = Study::default();
        let stimuli: Vec<Vec<String>> = (0..3).map(|e| study.stimuli("image", "1", e, 1)).collect();
        for p in 0..6 {
            study.rate(&format!("p{p}"), &stimuli[p % 3], 3 + (p % 2) as u32);
        }
        let rep = study.report();
        assert!(rep.design.within_emotion.is_empty());
        assert!(rep.design.notes.iter().any(|n| n.contains("emotion is not within-subject (0 of 6")), "{:?}", rep.design.notes);
        // Nobody rated every stimulus: no complete stimuli × raters matrix, the ICC says why.
        let scale = &rep.conditions[0].scales[0];
        assert_eq!(scale.alpha_items, 0);
        assert!(scale.icc.as_result().is_err_and(|why| !why.is_empty()));
    }
}
