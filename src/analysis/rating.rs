//! Lay raters: emotion recognition and ratings (HapFACS Exp. 3–4, Tables 6–14).
//!
//! Conventions (also written into the report):
//! - **Conditions**: stimuli are grouped by media and peak intensity in whole percent
//!   (`video 100%`, `image 50%` …), the stimulus groups of Tables 7–10 and 12.
//! - **Label set**: the manifest's declared label set in its report order (EmFACS: non-neutral
//!   ones alphabetically, then `neutral`) plus `none`; chance = 1 / number of options. Confusion rows = shown emotion (only emotions
//!   shown in the condition), columns = chosen label; percent = row percent.
//! - **Recognition rate** = hits / answers for the shown emotion; the condition's average rate
//!   is the unweighted mean over the shown emotions (the seed's "Average rate"); accuracy is
//!   hits / all answers. Hu: Wagner (1993) per label. Binomial test: exact, one-sided
//!   (greater) against chance, Clopper–Pearson 95 % CI.
//! - **Ratings** (believability, description match, q1, q2): mean and sample SD (n − 1) over all
//!   ratings of a condition × emotion cell. Cronbach's α with participants as items and stimuli as
//!   cases, per condition (all its stimuli) and per condition × emotion (when ≥ 2 stimuli),
//!   complete cases only: participants who rated every stimulus of the cell. HapFACS's
//!   "participants as items, the 10 videos as cases" with one video per emotion and condition
//!   has a value only as the per-condition α; the per-emotion α is then undefined.
//! - **Group comparisons**: per pair of participant groups and per condition, per-participant
//!   recognition (proportion correct) and mean believability; per condition × emotion,
//!   per-participant proportion correct; the same per intensity over both media (HapFACS's
//!   grouping: AMT vs local at 50 % and at 100 %, overall and per emotion). Student (pooled) and Welch t, two-sided, Cohen's d
//!   (pooled SD), 95 % CI of the difference.
//! - **ANOVA**: per media, emotion × intensity between-subjects two-way ANOVA on recognition
//!   (1 = correct, per answer) and on believability (per rating), Type II and Type III SS with
//!   sum-to-zero contrasts.

use std::collections::{BTreeMap, BTreeSet};

use serde::Serialize;

use super::coding::Maybe;
use super::input::FxHashMap;
use super::manifest::{Manifest, Media};
use super::responses::{EmotionAnswer, Rating, Responses, Scale};
use super::stats::anova::{AnovaTable, SsType, TwoWayCells, two_way_cells};
use super::stats::binomial::{Alternative, binomial_test};
use super::stats::descriptive::{Summary, summary};
use super::stats::classification::ConfusionMatrix;
use super::stats::hit_rate::unbiased_hit_rates;
use super::stats::reliability::{Icc, cronbach_alpha, icc};
use super::outcome::Outcome;
use super::stats::ttest::{TTest, student_t, welch_t};

mod design;

pub use design::{BetweenConditions, DesignTests, PairedTest, WithinEmotion};

/// The outcome of the per-participant tests on recognition.
pub const RECOGNITION_OUTCOME: &str = "recognition (proportion correct)";
/// The outcome of the per-participant tests on believability.
pub const BELIEVABILITY_OUTCOME: &str = "believability (participant mean)";

pub const CONVENTION: &str = "Conditions: media x peak intensity in whole percent. Labels: EmFACS labels (non-neutral alphabetically, then neutral) plus none; chance = 1/options. Confusion: rows = shown emotion, columns = chosen label, percent = row percent. Recognition rate = hits/answers per shown emotion; average rate = unweighted mean over shown emotions; accuracy = hits/all answers. Hu: Wagner (1993). Binomial: exact one-sided (greater) vs chance, Clopper-Pearson 95% CI. Ratings: mean and sample SD (n-1) over all ratings of a cell. Participant means: per scale and condition, the mean of the participants' mean ratings with its t-based 95% CI (participants as units). Cronbach's alpha: participants = items, stimuli = cases (HapFACS: \"participants as items, the 10 videos as cases\"), complete cases only (participants who rated every stimulus of the cell); the condition's alpha over all its stimuli is the reading that has a value when each emotion has one stimulus per condition (the paper's design), the per-emotion alpha needs at least 2 stimuli of that emotion in the condition. Group comparisons: per media x intensity condition and, as HapFACS grouped them, per intensity over both media; per-participant proportion correct or mean rating; Student (pooled) and Welch t, two-sided, Cohen's d with pooled SD, 95% CI of the difference. ANOVA: per media, emotion x intensity, between-subjects, per answer (recognition 1/0) or per rating, Type II and Type III SS, sum-to-zero contrasts.";

/// A confusion matrix in counts and row percent.
#[derive(Debug, Clone, Serialize)]
pub struct Confusion {
    /// Shown emotions (rows).
    pub rows: Vec<String>,
    /// Answer options (columns).
    pub columns: Vec<String>,
    pub counts: Vec<Vec<u64>>,
    pub percent: Vec<Vec<f64>>,
}

/// Mean and SD of some ratings.
#[derive(Debug, Clone, Serialize)]
pub struct Describe {
    pub n: usize,
    pub mean: f64,
    /// Sample SD (n − 1); `None` for a single rating.
    pub sd: Option<f64>,
}

pub(crate) fn describe(x: &[f64]) -> Option<Describe> {
    if x.is_empty() {
        return None;
    }
    let n = x.len() as f64;
    let mean = x.iter().sum::<f64>() / n;
    let sd = (x.len() > 1).then(|| (x.iter().map(|v| (v - mean).powi(2)).sum::<f64>() / (n - 1.0)).sqrt());
    Some(Describe { n: x.len(), mean, sd })
}

/// One shown emotion in one condition.
#[derive(Debug, Clone, Serialize)]
pub struct EmotionRow {
    pub emotion: String,
    pub stimuli: usize,
    pub answers: u64,
    pub hits: u64,
    pub rate: f64,
    pub hu: f64,
    pub hu_chance: f64,
    pub binomial_p: f64,
    pub rate_ci95: (f64, f64),
}

/// One rating scale in one condition × emotion cell (Tables 11, 13).
#[derive(Debug, Clone, Serialize)]
pub struct ScaleCell {
    pub emotion: String,
    pub stats: Option<Describe>,
    pub alpha: Maybe,
    pub alpha_cases: usize,
    pub alpha_items: usize,
}

/// A rating scale in one condition.
#[derive(Debug, Clone, Serialize)]
pub struct ScaleSummary {
    pub scale: Scale,
    pub overall: Option<Describe>,
    pub alpha: Maybe,
    pub alpha_cases: usize,
    pub alpha_items: usize,
    /// Shrout & Fleiss ICCs on the same complete stimuli × raters matrix as `alpha`.
    pub icc: Outcome<Icc>,
    /// The participants' mean ratings summarised, participants as units: n, mean, SD, SEM and
    /// the t-based 95 % CI of the mean.
    pub participant_means: Outcome<Summary>,
    pub cells: Vec<ScaleCell>,
}

/// One stimulus group (media × intensity).
#[derive(Debug, Clone, Serialize)]
pub struct Condition {
    pub key: String,
    pub media: Media,
    pub intensity_percent: u32,
    pub stimuli: usize,
    pub participants: usize,
    pub answers: u64,
    pub confusion: Option<Confusion>,
    pub emotions: Vec<EmotionRow>,
    pub average_rate: Option<f64>,
    pub accuracy: Option<f64>,
    pub scales: Vec<ScaleSummary>,
}

/// A t-test between two groups on one outcome.
#[derive(Debug, Clone, Serialize)]
pub struct GroupTest {
    pub condition: String,
    /// `all` or an emotion label.
    pub emotion: String,
    pub outcome: String,
    pub group_a: String,
    pub group_b: String,
    pub a: Option<Describe>,
    pub b: Option<Describe>,
    pub student: Outcome<TTest>,
    pub welch: Outcome<TTest>,
}

/// A two-way ANOVA of one outcome within one media.
#[derive(Debug, Clone, Serialize)]
pub struct Anova {
    pub media: Media,
    pub outcome: String,
    /// Factor A.
    pub a: &'static str,
    /// Factor B.
    pub b: &'static str,
    pub n: usize,
    pub type_ii: Outcome<AnovaTable>,
    pub type_iii: Outcome<AnovaTable>,
}

/// Published figures beside ours (Table 14).
#[derive(Debug, Clone, Serialize)]
pub struct ComparisonRow {
    pub emotion: String,
    pub intensity_percent: u32,
    /// This study, image stimuli.
    pub recognition_percent: Option<f64>,
    pub believability: Option<f64>,
    /// system → (recognition %, believability).
    pub published: BTreeMap<String, (f64, f64)>,
}

/// Everything the rater section of the report holds.
#[derive(Debug, Clone, Serialize)]
pub struct RatingReport {
    pub convention: String,
    /// The label set the answers and stimuli are labelled from: its id and its name.
    pub label_set: String,
    pub label_set_name: String,
    pub labels: Vec<String>,
    pub chance: f64,
    pub conditions: Vec<Condition>,
    pub group_tests: Vec<GroupTest>,
    pub anova: Vec<Anova>,
    /// RM ANOVA, paired t, one-way ANOVA with post hoc: where the design calls for them.
    pub design: DesignTests,
    pub table14: Vec<ComparisonRow>,
}

/// The answer options in display order: the label set's report order (EmFACS: non-neutral
/// emotions alphabetically, then neutral, as HapFACS's tables), then `none` when offered.
fn display_labels(manifest: &Manifest, responses: &Responses) -> Vec<String> {
    let set = manifest.label_set();
    let none = responses.label(crate::study::labels::NONE).map(|_| crate::study::labels::NONE.to_string());
    set.report_order().into_iter().chain(none).collect()
}

type CondKey = (Media, u32);

fn cond_name(k: CondKey) -> String {
    format!("{} {}%", k.0.as_str(), k.1)
}

fn ttests(a: &[f64], b: &[f64]) -> (Outcome<TTest>, Outcome<TTest>) {
    (student_t(a, b, 0.95).into(), welch_t(a, b, 0.95).into())
}

/// Published Table 14 figures (emotion, system, intensity %, recognition %, believability).
pub const PUBLISHED_TABLE14: &str = include_str!("../../analysis/published/table14.csv");

fn published() -> Vec<(String, String, u32, f64, f64)> {
    super::published::rows(PUBLISHED_TABLE14)
        .filter_map(|f| Some((f.first()?.to_string(), f.get(1)?.to_string(), f.get(2)?.parse().ok()?, f.get(3)?.parse().ok()?, f.get(4)?.parse().ok()?)))
        .collect()
}

/// What every part of the rater section looks up: the label order and, per stimulus, its shown
/// label and condition (computed once).
struct Context<'a> {
    manifest: &'a Manifest,
    responses: &'a Responses,
    /// Display order of the labels.
    labels: Vec<String>,
    /// Response label index → display index.
    to_display: Vec<usize>,
    /// Per stimulus: the display index of the emotion it portrays.
    stim_labels: Vec<Option<usize>>,
    stim_conds: Vec<CondKey>,
    scales_present: BTreeSet<Scale>,
}

impl Context<'_> {
    fn stim_label(&self, s: usize) -> Option<usize> {
        self.stim_labels[s]
    }

    fn n_participants(&self) -> usize {
        self.responses.participants.len()
    }

    /// The conditions with any answer or rating: videos first, then higher intensities first
    /// (the seed's table order).
    fn condition_keys(&self) -> Vec<CondKey> {
        let mut used = vec![false; self.manifest.len()];
        for s in self.responses.emotions.iter().map(|e| e.stimulus).chain(self.responses.ratings.iter().map(|r| r.stimulus)) {
            used[s] = true;
        }
        let keys: BTreeSet<CondKey> = (0..self.manifest.len()).filter(|&s| used[s]).map(|s| self.stim_conds[s]).collect();
        let mut keys: Vec<CondKey> = keys.into_iter().collect();
        keys.sort_by(|a, b| b.0.cmp(&a.0).then(b.1.cmp(&a.1)));
        keys
    }
}

/// The answers and ratings of one condition, in file order.
struct ConditionData<'r> {
    key: CondKey,
    /// How the group comparisons name it (`video 100%`, or `100% (images and videos)`).
    name: String,
    stimuli: Vec<usize>,
    participants: Vec<usize>,
    answers: Vec<&'r EmotionAnswer>,
    ratings: Vec<&'r Rating>,
}

/// Splits the answers and ratings by condition in one pass each, keeping file order.
fn split_by_condition<'r>(ctx: &Context<'r>, keys: &[CondKey]) -> Vec<ConditionData<'r>> {
    let stim_cond_index: Vec<usize> = ctx.stim_conds.iter().map(|c| keys.iter().position(|k| k == c).unwrap_or(usize::MAX)).collect();
    let mut data: Vec<ConditionData<'r>> = keys
        .iter()
        .map(|&key| ConditionData { key, name: cond_name(key), stimuli: (0..ctx.manifest.len()).filter(|&s| ctx.stim_conds[s] == key).collect(), participants: Vec::new(), answers: Vec::new(), ratings: Vec::new() })
        .collect();
    for e in &ctx.responses.emotions {
        data[stim_cond_index[e.stimulus]].answers.push(e);
    }
    for r in &ctx.responses.ratings {
        data[stim_cond_index[r.stimulus]].ratings.push(r);
    }
    for d in &mut data {
        let mut here = vec![false; ctx.n_participants()];
        for p in d.answers.iter().map(|e| e.participant).chain(d.ratings.iter().map(|r| r.participant)) {
            here[p] = true;
        }
        d.participants = (0..ctx.n_participants()).filter(|&p| here[p]).collect();
    }
    data
}

/// HapFACS's grouping for the group comparisons: each intensity over both media (it compares
/// AMT and local raters per intensity), where more than one media has that intensity; with the
/// emotions shown there (those shown in any of its conditions, `shown[i]` for `data[i]`).
fn pooled_by_intensity<'r>(data: &[ConditionData<'r>], shown: &[Vec<usize>]) -> Vec<(ConditionData<'r>, Vec<usize>)> {
    let mut intensities: Vec<u32> = data.iter().map(|d| d.key.1).collect();
    intensities.sort_unstable_by(|a, b| b.cmp(a));
    intensities.dedup();
    let pool = |percent: u32| {
        let parts: Vec<usize> = (0..data.len()).filter(|&i| data[i].key.1 == percent).collect();
        let mut participants: Vec<usize> = parts.iter().flat_map(|&i| data[i].participants.iter().copied()).collect();
        participants.sort_unstable();
        participants.dedup();
        let mut labels: Vec<usize> = parts.iter().flat_map(|&i| shown[i].iter().copied()).collect();
        labels.sort_unstable();
        labels.dedup();
        let pooled = ConditionData {
            key: data[parts[0]].key,
            name: format!("{percent}% (images and videos)"),
            stimuli: parts.iter().flat_map(|&i| data[i].stimuli.iter().copied()).collect(),
            participants,
            answers: parts.iter().flat_map(|&i| data[i].answers.iter().copied()).collect(),
            ratings: parts.iter().flat_map(|&i| data[i].ratings.iter().copied()).collect(),
        };
        (parts.len() > 1).then_some((pooled, labels))
    };
    intensities.into_iter().filter_map(pool).collect()
}

/// Recognition in one condition: the confusion matrix and a row per shown emotion.
struct Recognition {
    confusion: Option<Confusion>,
    emotions: Vec<EmotionRow>,
    /// Display indices of the emotions shown.
    shown: Vec<usize>,
    total: u64,
    hits: u64,
}

fn recognition(ctx: &Context<'_>, d: &ConditionData<'_>) -> Recognition {
    let n_labels = ctx.labels.len();
    // Confusion over the full label set (square), rows restricted to shown emotions for display.
    // Answers to stimuli that portray no emotion (empty `emotion` in the manifest) have no row
    // to go in: they are left out of the confusion matrix.
    let mut counts = vec![vec![0u64; n_labels]; n_labels];
    for e in &d.answers {
        if let Some(t) = ctx.stim_label(e.stimulus) {
            counts[t][ctx.to_display[e.label]] += 1;
        }
    }
    let cm = ConfusionMatrix::from_counts(ctx.labels.clone(), counts.clone()).expect("square by construction");
    let hu = unbiased_hit_rates(&cm);
    let shown: Vec<usize> = (0..n_labels).filter(|&t| cm.row_sum(t) > 0).collect();
    let emotions = shown
        .iter()
        .map(|&t| {
            let (n, hits) = (cm.row_sum(t), counts[t][t]);
            let b = binomial_test(hits, n, 1.0 / n_labels as f64, Alternative::Greater, 0.95).expect("n > 0");
            EmotionRow {
                emotion: ctx.labels[t].clone(),
                stimuli: d.stimuli.iter().filter(|&&s| ctx.stim_label(s) == Some(t)).count(),
                answers: n,
                hits,
                rate: hits as f64 / n as f64,
                hu: hu[t].hu,
                hu_chance: hu[t].chance,
                binomial_p: b.p_value,
                rate_ci95: b.ci,
            }
        })
        .collect();
    let confusion = (!shown.is_empty()).then(|| Confusion {
        rows: shown.iter().map(|&t| ctx.labels[t].clone()).collect(),
        columns: ctx.labels.clone(),
        counts: shown.iter().map(|&t| counts[t].clone()).collect(),
        percent: shown.iter().map(|&t| counts[t].iter().map(|&c| 100.0 * c as f64 / cm.row_sum(t) as f64).collect()).collect(),
    });
    let total: u64 = shown.iter().map(|&t| cm.row_sum(t)).sum();
    let hits: u64 = shown.iter().map(|&t| counts[t][t]).sum();
    Recognition { confusion, emotions, shown, total, hits }
}

/// One scale's ratings in one condition: overall, per shown emotion, and Cronbach's α.
fn scale_summary(ctx: &Context<'_>, d: &ConditionData<'_>, scale: Scale) -> Option<ScaleSummary> {
    let these: Vec<&Rating> = d.ratings.iter().copied().filter(|r| r.scale == scale).collect();
    if these.is_empty() {
        return None;
    }
    let n_stimuli = ctx.manifest.len() as u64;
    let key_of = |p: usize, s: usize| (p as u64) * n_stimuli + s as u64;
    // value[(participant, stimulus)], and the values per shown label in file order.
    let mut value: FxHashMap<u64, f64> = FxHashMap::default();
    value.reserve(these.len());
    let (mut is_rater, mut is_rated) = (vec![false; ctx.n_participants()], vec![false; ctx.manifest.len()]);
    let mut by_label: Vec<Vec<f64>> = vec![Vec::new(); ctx.labels.len()];
    for r in &these {
        value.insert(key_of(r.participant, r.stimulus), r.value);
        is_rater[r.participant] = true;
        is_rated[r.stimulus] = true;
        if let Some(t) = ctx.stim_label(r.stimulus) {
            by_label[t].push(r.value);
        }
    }
    let raters: Vec<usize> = (0..ctx.n_participants()).filter(|&p| is_rater[p]).collect();
    // Complete cases: rows = stimuli (cases), columns = the raters who rated every one of them.
    let complete = |cases: &[usize]| -> Vec<Vec<f64>> {
        let items: Vec<usize> = raters.iter().copied().filter(|&p| cases.iter().all(|&s| value.contains_key(&key_of(p, s)))).collect();
        cases.iter().map(|&s| items.iter().map(|&p| value[&key_of(p, s)]).collect()).collect()
    };
    let alpha_of = |rows: &[Vec<f64>]| -> (Maybe, usize, usize) { (Maybe::of(cronbach_alpha(rows, 0.95).map(|a| a.alpha)), rows.len(), rows.first().map_or(0, Vec::len)) };
    let rated: Vec<usize> = d.stimuli.iter().copied().filter(|&s| is_rated[s]).collect();
    let matrix = complete(&rated);
    let (alpha, alpha_cases, alpha_items) = alpha_of(&matrix);
    let cells = (0..ctx.labels.len())
        .filter_map(|t| {
            let cases: Vec<usize> = rated.iter().copied().filter(|&s| ctx.stim_label(s) == Some(t)).collect();
            if cases.is_empty() {
                return None;
            }
            let (alpha, alpha_cases, alpha_items) = alpha_of(&complete(&cases));
            Some(ScaleCell { emotion: ctx.labels[t].clone(), stats: describe(&by_label[t]), alpha, alpha_cases, alpha_items })
        })
        .collect();
    let all: Vec<f64> = these.iter().map(|r| r.value).collect();
    let icc = icc(&matrix).into();
    let mut per_rater: FxHashMap<usize, (f64, f64)> = FxHashMap::default();
    for r in &these {
        let v = per_rater.entry(r.participant).or_default();
        *v = (v.0 + r.value, v.1 + 1.0);
    }
    let means: Vec<f64> = raters.iter().filter_map(|p| per_rater.get(p)).map(|(sum, n)| sum / n).collect();
    let participant_means = summary(&means, 0.95).into();
    Some(ScaleSummary { scale, overall: describe(&all), alpha, alpha_cases, alpha_items, icc, participant_means, cells })
}

/// Per-participant tallies of one condition: hits and answers per shown label, and the sum and
/// count of believability ratings.
struct Tallies {
    per_participant: Vec<Option<Vec<(u64, u64)>>>,
    believability: Vec<Option<(f64, u64)>>,
    /// Sum and count of believability ratings per participant and shown label.
    believability_by_label: Vec<Option<Vec<(f64, u64)>>>,
}

impl Tallies {
    fn new(ctx: &Context<'_>, d: &ConditionData<'_>) -> Tallies {
        let mut per_participant: Vec<Option<Vec<(u64, u64)>>> = vec![None; ctx.n_participants()];
        for e in &d.answers {
            if let Some(t) = ctx.stim_label(e.stimulus) {
                let v = per_participant[e.participant].get_or_insert_with(|| vec![(0, 0); ctx.labels.len()]);
                v[t].1 += 1;
                if ctx.to_display[e.label] == t {
                    v[t].0 += 1;
                }
            }
        }
        let mut believability: Vec<Option<(f64, u64)>> = vec![None; ctx.n_participants()];
        let mut believability_by_label: Vec<Option<Vec<(f64, u64)>>> = vec![None; ctx.n_participants()];
        for r in d.ratings.iter().filter(|r| r.scale == Scale::Believability) {
            let v = believability[r.participant].get_or_insert_default();
            v.0 += r.value;
            v.1 += 1;
            if let Some(t) = ctx.stim_label(r.stimulus) {
                let v = &mut believability_by_label[r.participant].get_or_insert_with(|| vec![(0.0, 0); ctx.labels.len()])[t];
                v.0 += r.value;
                v.1 += 1;
            }
        }
        Tallies { per_participant, believability, believability_by_label }
    }

    /// Mean believability of participant `p`, over all their ratings or for label `t`.
    fn believability_mean(&self, p: usize, t: Option<usize>) -> Option<f64> {
        let (sum, n) = match t {
            None => self.believability[p]?,
            Some(t) => self.believability_by_label[p].as_ref()?[t],
        };
        (n > 0).then(|| sum / n as f64)
    }

    /// Proportion correct of participant `p`, over all shown labels or for label `t`.
    fn correct_rate(&self, p: usize, t: Option<usize>) -> Option<f64> {
        let (hits, n) = match t {
            None => self.per_participant[p].as_ref().map(|v| v.iter().fold((0, 0), |acc, x| (acc.0 + x.0, acc.1 + x.1)))?,
            Some(t) => self.per_participant[p].as_ref()?[t],
        };
        (n > 0).then(|| hits as f64 / n as f64)
    }

    fn recognition(&self, ps: &[usize], t: Option<usize>) -> Vec<f64> {
        ps.iter().filter_map(|&p| self.correct_rate(p, t)).collect()
    }

    fn mean_believability(&self, ps: &[usize]) -> Vec<f64> {
        ps.iter().filter_map(|&p| self.believability_mean(p, None)).collect()
    }
}

/// The t-tests between every pair of groups within one condition.
fn group_tests(ctx: &Context<'_>, d: &ConditionData<'_>, shown: &[usize]) -> Vec<GroupTest> {
    let tallies = Tallies::new(ctx, d);
    let groups = &ctx.responses.groups;
    let in_group = |g: usize| -> Vec<usize> { d.participants.iter().copied().filter(|&p| ctx.responses.participants[p].group == g).collect() };
    let mut out = Vec::new();
    for ga in 0..groups.len() {
        for gb in ga + 1..groups.len() {
            let (pa, pb) = (in_group(ga), in_group(gb));
            if pa.is_empty() || pb.is_empty() {
                continue;
            }
            let mut push = |emotion: String, outcome: &str, a: Vec<f64>, b: Vec<f64>| {
                if a.is_empty() || b.is_empty() {
                    return;
                }
                let (student, welch) = ttests(&a, &b);
                let (group_a, group_b) = (groups[ga].clone(), groups[gb].clone());
                out.push(GroupTest { condition: d.name.clone(), emotion, outcome: outcome.into(), group_a, group_b, a: describe(&a), b: describe(&b), student, welch });
            };
            if !d.answers.is_empty() {
                push("all".into(), RECOGNITION_OUTCOME, tallies.recognition(&pa, None), tallies.recognition(&pb, None));
            }
            if ctx.scales_present.contains(&Scale::Believability) {
                push("all".into(), BELIEVABILITY_OUTCOME, tallies.mean_believability(&pa), tallies.mean_believability(&pb));
            }
            for &t in shown {
                push(ctx.labels[t].clone(), RECOGNITION_OUTCOME, tallies.recognition(&pa, Some(t)), tallies.recognition(&pb, Some(t)));
            }
        }
    }
    out
}

/// One condition's row of Tables 7–13.
fn condition(ctx: &Context<'_>, d: &ConditionData<'_>, recognition: Recognition) -> Condition {
    let Recognition { confusion, emotions, total, hits, .. } = recognition;
    let average_rate = (!emotions.is_empty()).then(|| emotions.iter().map(|e| e.rate).sum::<f64>() / emotions.len() as f64);
    Condition {
        key: cond_name(d.key),
        media: d.key.0,
        intensity_percent: d.key.1,
        stimuli: d.stimuli.len(),
        participants: d.participants.len(),
        answers: total,
        confusion,
        emotions,
        average_rate,
        accuracy: (total > 0).then(|| hits as f64 / total as f64),
        scales: ctx.scales_present.iter().filter_map(|&scale| scale_summary(ctx, d, scale)).collect(),
    }
}

/// Two-way ANOVAs (emotion × intensity) of recognition and believability within `media`.
fn anovas(ctx: &Context<'_>, media: Media, out: &mut Vec<Anova>) {
    let manifest = ctx.manifest;
    // Factor levels: the labels and the intensities (in whole percent) of the stimuli.
    let mut intensities: Vec<u32> = manifest.stimuli.iter().map(|s| s.intensity_percent()).collect();
    intensities.sort_unstable();
    intensities.dedup();
    let intensity_names: Vec<String> = intensities.iter().map(|i| format!("{i}%")).collect();
    let level_of: Vec<Option<(usize, usize)>> = (0..manifest.len())
        .map(|s| {
            let st = &manifest.stimuli[s];
            let t = ctx.stim_label(s).filter(|_| st.media == media)?;
            Some((t, intensities.binary_search(&st.intensity_percent()).expect("listed above")))
        })
        .collect();
    let mut fit = |outcome: &str, cells: TwoWayCells| {
        if cells.n() == 0 {
            return;
        }
        let run = |t| Outcome::from(two_way_cells(&cells, t)).map(|table| table.named("emotion", "intensity"));
        out.push(Anova { media, outcome: outcome.into(), a: "emotion", b: "intensity", n: cells.n(), type_ii: run(SsType::II), type_iii: run(SsType::III) });
    };
    let mut cells = TwoWayCells::with_levels(ctx.labels.clone(), intensity_names.clone());
    for e in &ctx.responses.emotions {
        if let Some((t, i)) = level_of[e.stimulus] {
            cells.add(t, i, if t == ctx.to_display[e.label] { 1.0 } else { 0.0 });
        }
    }
    fit("recognition", cells);
    let mut cells = TwoWayCells::with_levels(ctx.labels.clone(), intensity_names);
    for r in ctx.responses.ratings.iter().filter(|r| r.scale == Scale::Believability) {
        if let Some((t, i)) = level_of[r.stimulus] {
            cells.add(t, i, r.value);
        }
    }
    fit(Scale::Believability.name(), cells);
}

/// Table 14: this study's image conditions beside the published figures.
fn table14(conditions: &[Condition]) -> Vec<ComparisonRow> {
    let pubs = published();
    let mut rows = Vec::new();
    for c in conditions.iter().filter(|c| c.media == Media::Image) {
        for e in &c.emotions {
            let believability = c
                .scales
                .iter()
                .find(|s| s.scale == Scale::Believability)
                .and_then(|s| s.cells.iter().find(|x| x.emotion == e.emotion))
                .and_then(|x| x.stats.as_ref().map(|d| d.mean));
            let published = pubs.iter().filter(|p| p.0 == e.emotion && p.2 == c.intensity_percent).map(|p| (p.1.clone(), (p.3, p.4))).collect();
            rows.push(ComparisonRow { emotion: e.emotion.clone(), intensity_percent: c.intensity_percent, recognition_percent: Some(100.0 * e.rate), believability, published });
        }
    }
    rows
}

/// Computes the rater section; `None` when there are no emotion answers and no ratings.
pub fn analyze(manifest: &Manifest, responses: &Responses) -> Option<RatingReport> {
    if responses.emotions.is_empty() && responses.ratings.is_empty() {
        return None;
    }
    let labels = display_labels(manifest, responses);
    let ctx = Context {
        manifest,
        responses,
        to_display: responses.emotion_labels.iter().map(|l| labels.iter().position(|x| x == l).expect("label")).collect(),
        stim_labels: manifest.stimuli.iter().map(|st| labels.iter().position(|l| Some(l.as_str()) == st.emotion.as_deref())).collect(),
        stim_conds: manifest.stimuli.iter().map(|st| (st.media, st.intensity_percent())).collect(),
        scales_present: responses.ratings.iter().map(|r| r.scale).collect(),
        labels,
    };
    let mut conditions = Vec::new();
    let mut tests = Vec::new();
    let data = split_by_condition(&ctx, &ctx.condition_keys());
    let mut shown = Vec::new();
    for d in &data {
        let recognition = recognition(&ctx, d);
        tests.extend(group_tests(&ctx, d, &recognition.shown));
        shown.push(recognition.shown.clone());
        conditions.push(condition(&ctx, d, recognition));
    }
    for (d, shown) in pooled_by_intensity(&data, &shown) {
        tests.extend(group_tests(&ctx, &d, &shown));
    }
    let mut anova = Vec::new();
    for media in [Media::Video, Media::Image] {
        anovas(&ctx, media, &mut anova);
    }
    let table14 = table14(&conditions);
    let design = design::analyze(&ctx, &data);
    let set = manifest.label_set();
    Some(RatingReport {
        convention: CONVENTION.to_string(),
        label_set: set.id().to_string(),
        label_set_name: set.table().name.clone(),
        chance: 1.0 / ctx.labels.len() as f64,
        labels: ctx.labels,
        conditions,
        group_tests: tests,
        anova,
        design,
        table14,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn run(manifest: &str, responses: &str) -> RatingReport {
        let (m, r) = crate::analysis::fixture(manifest, responses);
        analyze(&m, &r).unwrap()
    }

    #[test]
    fn confusion_rates_and_alpha_by_hand() {
        // Two stimuli in one condition, three raters.
        let m = "h,image,wm1,6+12+25,happiness,1\ns,image,wm1,1+4+15,sadness,1\n";
        let r = "p1,g,h,1,emotion,happiness,\np2,g,h,1,emotion,happiness,\np3,g,h,1,emotion,pride,\n\
                 p1,g,s,2,emotion,sadness,\np2,g,s,2,emotion,none,\np3,g,s,2,emotion,sadness,\n\
                 p1,g,h,1,believability,4,\np2,g,h,1,believability,5,\np3,g,h,1,believability,3,\n\
                 p1,g,s,2,believability,2,\np2,g,s,2,believability,4,\np3,g,s,2,believability,1,\n";
        let rep = run(m, r);
        assert_eq!(rep.labels.len(), 11);
        assert_eq!(rep.labels[9], "neutral");
        assert_eq!(rep.labels[10], "none");
        let c = &rep.conditions[0];
        assert_eq!(c.key, "image 100%");
        let conf = c.confusion.as_ref().unwrap();
        assert_eq!(conf.rows, ["happiness", "sadness"]);
        let happy = &c.emotions[0];
        assert_eq!((happy.hits, happy.answers), (2, 3));
        // Hu(happiness) = 2² / (3 · 2) (column "happiness" chosen twice).
        assert!((happy.hu - 4.0 / 6.0).abs() < 1e-12);
        assert!((c.average_rate.unwrap() - 2.0 / 3.0).abs() < 1e-12);
        let pct = &conf.percent[0];
        assert!((pct.iter().sum::<f64>() - 100.0).abs() < 1e-9);
        // α: cases = stimuli (h, s), items = p1..p3: rows (4,5,3), (2,4,1).
        // item variances 2, 0.5, 2 (sum 4.5); totals 12, 7 -> variance 12.5; α = 1.5 (1 − 4.5/12.5) = 0.96.
        let belv = &c.scales[0];
        assert!((belv.alpha.value.unwrap() - 0.96).abs() < 1e-12);
        assert_eq!(belv.overall.as_ref().unwrap().n, 6);
    }

    #[test]
    fn groups_are_also_compared_per_intensity_over_both_media() {
        // One happy video and one happy still at 100 %; two raters per group, each sees one.
        let m = "v,video,wm1,6+12+25,happiness,1\ni,image,wm1,6+12+25,happiness,1\n";
        let r = "a1,amt,v,1,emotion,happiness,\na2,amt,i,1,emotion,happiness,\n\
                 l1,local,v,1,emotion,none,\nl2,local,i,1,emotion,happiness,\n";
        let rep = run(m, r);
        let pooled: Vec<&GroupTest> = rep.group_tests.iter().filter(|t| t.condition == "100% (images and videos)").collect();
        // Overall and for happiness: amt 1, 1 against local 0, 1.
        assert_eq!(pooled.len(), 2, "{:?}", rep.group_tests.iter().map(|t| &t.condition).collect::<Vec<_>>());
        assert_eq!((pooled[0].emotion.as_str(), pooled[1].emotion.as_str()), ("all", "happiness"));
        let (a, b) = (pooled[0].a.as_ref().unwrap(), pooled[0].b.as_ref().unwrap());
        assert_eq!((a.n, a.mean, b.n, b.mean), (2, 1.0, 2, 0.5));
        // The per-condition tests are still there (one rater per group and condition: no t).
        assert!(rep.group_tests.iter().any(|t| t.condition == "video 100%"));
    }

    #[test]
    fn published_table14_parses() {
        let p = published();
        assert_eq!(p.len(), 38);
        assert!(p.iter().any(|r| r.0 == "anger" && r.1 == "FACSGen" && r.2 == 100 && (r.3 - 87.82).abs() < 1e-9));
    }
}
