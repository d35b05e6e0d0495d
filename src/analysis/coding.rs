//! FACS coders against the ground truth (HapFACS Exp. 1–2, Tables 1–4).
//!
//! Conventions (also written into the report):
//! - **Unit of decision**: one (coder, stimulus, AU) triple, present or absent, over every
//!   (coder, stimulus) pair with an `aus` answer. A missing answer is a missing pair: it is left
//!   out (not counted as "nothing marked") and the number of missing pairs is reported.
//! - **AU set**: the catalog AUs that occur in the ground truth of a coded stimulus or in any
//!   answer, ordered by code. TN counts (and so accuracy) depend on this set.
//! - **Matching**: by default an AU counts as recognised when the coder marked its code. With
//!   `match_side` the marked side (L, R or both) must equal the shown side; with
//!   `match_intensity` the marked letter must equal the shown intensity's nearest FACS letter
//!   (A–E = 15/30/55/85/100 %; no letter written never matches; a shown AU without intensity is
//!   E). A shown AU marked with the wrong side or intensity is a miss (FN), not an FP.
//! - **Metrics** (HapFACS Eq. 2–5): accuracy = (TP+TN)/N, precision = TP/(TP+FP), recall =
//!   TP/(TP+FN), F1 = 2TP/(2TP+FP+FN); 0/0 is reported as 0. **Macro** = unweighted mean over
//!   the AU set; **micro** = from TP/FP/FN/TN summed over the AU set.
//! - **F1 CI** (per AU, 95 %): Jeffreys interval, conditional on the shown (positive) and
//!   not-shown (negative) pairs: recall and false-positive rate from their Jeffreys posteriors
//!   (Beta(x + ½, n − x + ½)), the equal-tailed percentiles of the F1 they imply, seeded by the
//!   counts (`stats::classification::f1_ci`).
//! - **Mistaken for**: for each miss of a shown AU, the AUs the coder marked on that stimulus
//!   that the stimulus does not show, counted.
//! - **Combinations** (Table 4): stimuli grouped by the set of AU codes shown; "recognised" =
//!   shown AUs recognised at least once; false positives (in parentheses) = AUs marked at least
//!   once that the combination does not show, with counts; metrics are micro over the AU set
//!   and the combination's (coder, stimulus) pairs; the mean row is the macro mean over
//!   combinations.
//! - **Agreement** (codes only, sides and intensities ignored), over the stimuli that every
//!   coder answered (complete cases): Cronbach's α per AU with coders as items and stimuli as
//!   cases (marked = 1); Fleiss' κ per AU and over all (stimulus, AU) items; pairwise Cohen's κ
//!   over (stimulus, AU) items; pairwise Dice = mean over common stimuli of 2|A∩B|/(|A|+|B|).

use std::collections::{BTreeMap, BTreeSet};

use serde::Serialize;

use super::manifest::Manifest;
use super::responses::Responses;
use super::outcome::Outcome;
use super::stats::classification::f1_ci;
use super::stats::reliability::{cohen_kappa, cronbach_alpha, dice, fleiss_kappa};
use crate::facs::{Activation, Catalog, Expression, Intensity, IntensityLevel};

/// How strictly an answer must match the shown AU.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize)]
pub struct CodingOptions {
    pub match_side: bool,
    pub match_intensity: bool,
}

/// Confusion counts of a binary decision.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq, Serialize)]
pub struct Counts {
    pub tp: u64,
    pub fp: u64,
    #[serde(rename = "fn")]
    pub fn_: u64,
    pub tn: u64,
}

impl Counts {
    fn add(&mut self, o: Counts) {
        self.tp += o.tp;
        self.fp += o.fp;
        self.fn_ += o.fn_;
        self.tn += o.tn;
    }

    /// HapFACS Eq. 2–5 with 0/0 = 0.
    pub fn metrics(&self) -> Metrics {
        let (tp, fp, fn_, tn) = (self.tp as f64, self.fp as f64, self.fn_ as f64, self.tn as f64);
        let r = |a: f64, b: f64| if b == 0.0 { 0.0 } else { a / b };
        Metrics {
            accuracy: r(tp + tn, tp + fp + fn_ + tn),
            precision: r(tp, tp + fp),
            recall: r(tp, tp + fn_),
            f1: r(2.0 * tp, 2.0 * tp + fp + fn_),
        }
    }
}

/// Accuracy, precision, recall and F1.
#[derive(Debug, Clone, Copy, Default, PartialEq, Serialize)]
pub struct Metrics {
    pub accuracy: f64,
    pub precision: f64,
    pub recall: f64,
    pub f1: f64,
}

impl Metrics {
    fn mean(all: &[Metrics]) -> Metrics {
        let n = all.len().max(1) as f64;
        let s = |f: fn(&Metrics) -> f64| all.iter().map(f).sum::<f64>() / n;
        Metrics { accuracy: s(|m| m.accuracy), precision: s(|m| m.precision), recall: s(|m| m.recall), f1: s(|m| m.f1) }
    }
}

/// An AU and how often it was given.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct AuCount {
    pub au: u16,
    pub count: u64,
}

/// A statistic that may be undefined on the data, with the reason when it is. In
/// `report.json` it is the number itself, or `{"undefined": "why"}` (as [`super::outcome::Outcome`]).
#[derive(Debug, Clone, PartialEq)]
pub struct Maybe {
    pub value: Option<f64>,
    pub undefined: Option<String>,
}

impl Serialize for Maybe {
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        use serde::ser::SerializeMap;
        match self.value {
            Some(v) => serializer.serialize_f64(v),
            None => {
                let mut map = serializer.serialize_map(Some(1))?;
                map.serialize_entry("undefined", self.undefined.as_deref().unwrap_or("no value"))?;
                map.end()
            }
        }
    }
}

impl Maybe {
    pub fn of<E: std::fmt::Display>(r: Result<f64, E>) -> Maybe {
        match r {
            Ok(v) if v.is_finite() => Maybe { value: Some(v), undefined: None },
            Ok(v) => Maybe { value: None, undefined: Some(format!("not finite ({v})")) },
            Err(e) => Maybe { value: None, undefined: Some(e.to_string()) },
        }
    }
}

/// One AU's row of Tables 1–3.
#[derive(Debug, Clone, Serialize)]
pub struct AuRow {
    pub au: u16,
    pub name: String,
    /// Coded stimuli that show this AU.
    pub shown_in: usize,
    pub counts: Counts,
    pub metrics: Metrics,
    /// 95 % CI of `metrics.f1` (Jeffreys, conditional on what was shown; see `f1_ci`).
    pub f1_ci95: Outcome<(f64, f64)>,
    pub mistaken_for: Vec<AuCount>,
    /// Cronbach's α with coders as items, stimuli as cases (Table 2).
    pub alpha: Maybe,
    pub fleiss_kappa: Maybe,
}

/// AUs sharing the same rounded metrics (the layout of HapFACS Table 1).
#[derive(Debug, Clone, Serialize)]
pub struct MetricGroup {
    pub aus: Vec<u16>,
    /// Metrics rounded to two decimals, as in the seed's table.
    pub metrics: Metrics,
}

/// One row of Table 4.
#[derive(Debug, Clone, Serialize)]
pub struct CombinationRow {
    /// Shown AU codes, e.g. `1 + 2 + 4`.
    pub combination: String,
    pub stimuli: usize,
    pub answers: usize,
    pub recognised: Vec<u16>,
    pub missed: Vec<u16>,
    pub false_positives: Vec<AuCount>,
    /// `1 + 2 + 4 + (41 + 42)`: recognised AUs, then false positives in parentheses.
    pub recognised_display: String,
    pub counts: Counts,
    pub metrics: Metrics,
}

/// Agreement between two coders.
#[derive(Debug, Clone, Serialize)]
pub struct CoderPair {
    pub coder_a: String,
    pub coder_b: String,
    pub common_stimuli: usize,
    pub cohen_kappa: Maybe,
    pub dice_mean: f64,
}

/// Agreement between coders.
#[derive(Debug, Clone, Serialize)]
pub struct Agreement {
    pub complete_stimuli: usize,
    pub fleiss_kappa: Maybe,
    pub pairs: Vec<CoderPair>,
}

/// Everything the coder section of the report holds.
#[derive(Debug, Clone, Serialize)]
pub struct CodingReport {
    pub convention: String,
    pub options: CodingOptions,
    pub coders: Vec<String>,
    pub stimuli: usize,
    pub answered_pairs: usize,
    pub missing_pairs: usize,
    pub au_set: Vec<u16>,
    pub per_au: Vec<AuRow>,
    pub total: Counts,
    /// Averaged over every AU of the AU set (false-positive-only AUs included).
    pub macro_mean: Metrics,
    /// Averaged over the AUs the coded stimuli show (HapFACS's Table 3 mean): the headline.
    pub shown_macro_mean: Metrics,
    pub micro: Metrics,
    pub table1_groups: Vec<MetricGroup>,
    pub combinations: Vec<CombinationRow>,
    pub combinations_macro_mean: Metrics,
    pub agreement: Agreement,
    /// This study beside the published AU-level figures (HapFACS §4.3.2).
    pub comparison: Vec<AuLevelComparison>,
}

/// This study's single-AU recognition rate (mean recall over the AUs shown) or combination
/// accuracy (mean over combinations), beside a published system's figure.
#[derive(Debug, Clone, Serialize)]
pub struct AuLevelComparison {
    /// `single AUs` or `AU combinations`.
    pub stimuli: String,
    /// This study: how many AUs (or combinations) were shown, and the percent.
    pub count: usize,
    pub percent: f64,
    /// The published system, its number of AUs (or combinations) and its percent.
    pub system: String,
    pub published_count: u32,
    pub published_percent: f64,
}

/// Published AU-level figures (stimuli, system, count, percent).
pub const PUBLISHED_AU_LEVEL: &str = include_str!("../../analysis/published/au_level.csv");

fn published_au_level() -> Vec<(String, String, u32, f64)> {
    super::published::rows(PUBLISHED_AU_LEVEL)
        .filter_map(|f| Some((f.first()?.to_string(), f.get(1)?.to_string(), f.get(2)?.parse().ok()?, f.get(3)?.parse().ok()?)))
        .collect()
}

/// The comparison rows: a study of single AUs (Exp. 1) beside the published single-AU rates, a
/// study of AU combinations (Exp. 2) beside the published combination accuracies.
fn comparison(per_au: &[AuRow], shown_macro_mean: &Metrics, combinations: &[CombinationRow], combinations_macro_mean: &Metrics) -> Vec<AuLevelComparison> {
    let (stimuli, count, percent) = if combinations.iter().any(|c| c.combination.contains('+')) {
        ("AU combinations", combinations.len(), 100.0 * combinations_macro_mean.accuracy)
    } else {
        ("single AUs", per_au.iter().filter(|r| r.shown_in > 0).count(), 100.0 * shown_macro_mean.recall)
    };
    published_au_level()
        .into_iter()
        .filter(|(s, ..)| s == stimuli)
        .map(|(stimuli, system, published_count, published_percent)| AuLevelComparison { stimuli, count, percent, system, published_count, published_percent })
        .collect()
}

/// The module documentation, as stated in the report.
pub const CONVENTION: &str = "Decisions: (coder, stimulus, AU) present/absent over every answered (coder, stimulus) pair; missing answers are left out and counted. AU set: catalog AUs occurring in the ground truth of a coded stimulus or in any answer. Metrics: HapFACS Eq. 2-5 (accuracy (TP+TN)/N, precision TP/(TP+FP), recall TP/(TP+FN), F1 2TP/(2TP+FP+FN)), 0/0 = 0; macro = unweighted mean, headline over the AUs the stimuli show (as HapFACS Table 3), beside it over the whole AU set (AUs only coders marked included); micro = from summed counts. F1 95% CI per AU (report.json): Jeffreys interval conditional on the shown and not-shown pairs: recall ~ Beta(TP+1/2, FN+1/2), false-positive rate ~ Beta(FP+1/2, TN+1/2), 2.5-97.5% percentiles of the implied F1 over 2000 draws seeded by the counts, widened to contain the observed F1. A shown AU marked with the wrong side/intensity (when matching is required) is a miss. Mistaken for: AUs marked on a stimulus that does not show them, counted at each miss. Combinations: grouped by shown AU codes; recognised = shown AUs recognised at least once; false positives in parentheses; metrics micro over the AU set; mean = macro over combinations. Agreement uses AU codes only over stimuli every coder answered (complete cases): Cronbach's alpha per AU (coders = items, stimuli = cases, marked = 1), Fleiss' kappa per AU and over (stimulus, AU) items, pairwise Cohen's kappa over (stimulus, AU) items, Dice = mean 2|A&B|/(|A|+|B|) over common stimuli.";

fn nearest_level(value: f64) -> IntensityLevel {
    let mut best = IntensityLevel::E;
    for level in IntensityLevel::ALL {
        if (level.fraction() - value).abs() < (best.fraction() - value).abs() {
            best = level;
        }
    }
    best
}

fn answer_level(a: &Activation) -> Option<IntensityLevel> {
    match a.intensity? {
        Intensity::Level(l) => Some(l),
        other => Some(nearest_level(other.value())),
    }
}

/// Whether every shown activation of AU `au` is matched by a marked one.
fn recognised(truth: &Expression, answer: &Expression, au: u16, options: CodingOptions) -> bool {
    let shown = truth.activations().iter().filter(|t| t.au.0 == au);
    let mut any = false;
    for t in shown {
        any = true;
        let hit = answer.activations().iter().any(|a| {
            a.au.0 == au
                && (!options.match_side || a.side == t.side)
                && (!options.match_intensity || answer_level(a) == Some(nearest_level(t.strength())))
        });
        if !hit {
            return false;
        }
    }
    any
}

fn codes(e: &Expression) -> Vec<u16> {
    e.codes().into_iter().map(|c| c.0).collect()
}

fn join(aus: &[u16]) -> String {
    aus.iter().map(u16::to_string).collect::<Vec<_>>().join(" + ")
}

/// One combination's tallies: stimuli, answers, summed counts, false positives, recognised AUs.
type ComboTally = (usize, usize, Counts, BTreeMap<u16, u64>, BTreeSet<u16>);

/// What one pass over every (coder, stimulus) answer counts.
struct Tally {
    counts: Vec<Counts>,
    shown_in: Vec<usize>,
    mistaken: Vec<BTreeMap<u16, u64>>,
    /// Combinations in order of first appearance, with their tallies.
    combo_keys: Vec<Vec<u16>>,
    combos: Vec<ComboTally>,
}

/// Counts every answer against the shown AUs, per AU and per combination.
fn tally(manifest: &Manifest, responses: &Responses, by_stim: &BTreeMap<usize, Vec<usize>>, au_set: &[u16], options: CodingOptions) -> Tally {
    let au_pos = |au: u16| au_set.binary_search(&au).expect("AU in the set");
    let mut t = Tally { counts: vec![Counts::default(); au_set.len()], shown_in: vec![0; au_set.len()], mistaken: vec![BTreeMap::new(); au_set.len()], combo_keys: Vec::new(), combos: Vec::new() };
    for (&s, answers) in by_stim {
        let truth = &manifest.stimuli[s].expression;
        let shown = codes(truth);
        for &au in &shown {
            t.shown_in[au_pos(au)] += 1;
        }
        let ci = match t.combo_keys.iter().position(|k| *k == shown) {
            Some(ci) => ci,
            None => {
                t.combo_keys.push(shown.clone());
                t.combos.push((0, 0, Counts::default(), BTreeMap::new(), BTreeSet::new()));
                t.combo_keys.len() - 1
            }
        };
        t.combos[ci].0 += 1;
        for &i in answers {
            let answer = &responses.aus[i].aus;
            let marked = codes(answer);
            let extra: Vec<u16> = marked.iter().copied().filter(|a| !shown.contains(a)).collect();
            t.combos[ci].1 += 1;
            let mut pair = Counts { tn: au_set.len() as u64, ..Counts::default() };
            for &au in &shown {
                let k = au_pos(au);
                pair.tn -= 1;
                if recognised(truth, answer, au, options) {
                    t.counts[k].tp += 1;
                    pair.tp += 1;
                    t.combos[ci].4.insert(au);
                } else {
                    t.counts[k].fn_ += 1;
                    pair.fn_ += 1;
                    for &x in &extra {
                        *t.mistaken[k].entry(x).or_default() += 1;
                    }
                }
            }
            for &au in &extra {
                t.counts[au_pos(au)].fp += 1;
                pair.fp += 1;
                pair.tn -= 1;
                *t.combos[ci].3.entry(au).or_default() += 1;
            }
            t.combos[ci].2.add(pair);
        }
    }
    let answered_pairs = responses.aus.len() as u64;
    for c in &mut t.counts {
        c.tn = answered_pairs - c.tp - c.fp - c.fn_;
    }
    t
}

/// One row per AU: counts, metrics, what it was mistaken for, α and Fleiss κ over the complete
/// stimuli (`complete_marks[stimulus][coder]` = the codes marked).
fn au_rows(au_set: &[u16], tally: &Tally, complete_marks: &[Vec<Vec<u16>>], catalog: &Catalog) -> Vec<AuRow> {
    au_set
        .iter()
        .enumerate()
        .map(|(k, &au)| {
            let rows: Vec<Vec<f64>> = complete_marks.iter().map(|m| m.iter().map(|c| if c.contains(&au) { 1.0 } else { 0.0 }).collect()).collect();
            let table: Vec<Vec<u64>> = rows
                .iter()
                .map(|r| {
                    let yes = r.iter().filter(|&&v| v == 1.0).count() as u64;
                    vec![yes, r.len() as u64 - yes]
                })
                .collect();
            let mut mistaken_for: Vec<AuCount> = tally.mistaken[k].iter().map(|(&au, &count)| AuCount { au, count }).collect();
            mistaken_for.sort_by(|a, b| b.count.cmp(&a.count).then(a.au.cmp(&b.au)));
            AuRow {
                au,
                name: catalog.get(crate::facs::AuCode(au)).map_or_else(String::new, |u| u.name.clone()),
                shown_in: tally.shown_in[k],
                counts: tally.counts[k],
                metrics: tally.counts[k].metrics(),
                f1_ci95: {
                    let c = tally.counts[k];
                    f1_ci(c.tp, c.fp, c.fn_, c.tn, 0.95).into()
                },
                mistaken_for,
                alpha: Maybe::of(cronbach_alpha(&rows, 0.95).map(|a| a.alpha)),
                fleiss_kappa: Maybe::of(fleiss_kappa(&table)),
            }
        })
        .collect()
}

/// Table 1 layout: AUs with equal rounded metrics together.
fn table1_groups(per_au: &[AuRow]) -> Vec<MetricGroup> {
    let round = |m: Metrics| {
        let r = |v: f64| (v * 100.0).round() / 100.0;
        Metrics { accuracy: r(m.accuracy), precision: r(m.precision), recall: r(m.recall), f1: r(m.f1) }
    };
    let mut groups: Vec<MetricGroup> = Vec::new();
    for row in per_au.iter().filter(|r| r.shown_in > 0) {
        let m = round(row.metrics);
        match groups.iter_mut().find(|g| g.metrics == m) {
            Some(g) => g.aus.push(row.au),
            None => groups.push(MetricGroup { aus: vec![row.au], metrics: m }),
        }
    }
    groups.sort_by(|a, b| a.metrics.f1.total_cmp(&b.metrics.f1).then(a.aus[0].cmp(&b.aus[0])));
    groups
}

/// Table 4: one row per shown combination.
fn combination_rows(tally: &Tally) -> Vec<CombinationRow> {
    tally
        .combo_keys
        .iter()
        .zip(&tally.combos)
        .map(|(shown, (stimuli, answers, c, fps, rec))| {
            let recognised: Vec<u16> = shown.iter().copied().filter(|a| rec.contains(a)).collect();
            let missed: Vec<u16> = shown.iter().copied().filter(|a| !rec.contains(a)).collect();
            let false_positives: Vec<AuCount> = fps.iter().map(|(&au, &count)| AuCount { au, count }).collect();
            let mut display = if recognised.is_empty() { "-".to_string() } else { join(&recognised) };
            if !false_positives.is_empty() {
                let fp: Vec<u16> = false_positives.iter().map(|f| f.au).collect();
                display = format!("{display} + ({})", join(&fp));
            }
            CombinationRow {
                combination: if shown.is_empty() { "0".into() } else { join(shown) },
                stimuli: *stimuli,
                answers: *answers,
                recognised,
                missed,
                false_positives,
                recognised_display: display,
                counts: *c,
                metrics: c.metrics(),
            }
        })
        .collect()
}

/// Pairwise Cohen κ over AU decisions and mean Dice, on the stimuli both coders coded.
fn coder_pairs(responses: &Responses, coders: &[usize], coder_of: &BTreeMap<usize, usize>, au_set: &[u16]) -> Vec<CoderPair> {
    let mut by_coder: Vec<BTreeMap<usize, Vec<u16>>> = vec![BTreeMap::new(); coders.len()];
    for a in &responses.aus {
        by_coder[coder_of[&a.participant]].insert(a.stimulus, codes(&a.aus));
    }
    let mut pairs = Vec::new();
    for i in 0..coders.len() {
        for j in i + 1..coders.len() {
            let common: Vec<usize> = by_coder[i].keys().copied().filter(|s| by_coder[j].contains_key(s)).collect();
            let (mut la, mut lb) = (Vec::new(), Vec::new());
            let mut dice_sum = 0.0;
            for s in &common {
                let (a, b) = (&by_coder[i][s], &by_coder[j][s]);
                dice_sum += dice(a, b);
                for au in au_set {
                    la.push(if a.contains(au) { "1" } else { "0" });
                    lb.push(if b.contains(au) { "1" } else { "0" });
                }
            }
            pairs.push(CoderPair {
                coder_a: responses.participants[coders[i]].id.clone(),
                coder_b: responses.participants[coders[j]].id.clone(),
                common_stimuli: common.len(),
                cohen_kappa: Maybe::of(cohen_kappa(&["0", "1"], &la, &lb)),
                dice_mean: if common.is_empty() { 0.0 } else { dice_sum / common.len() as f64 },
            });
        }
    }
    pairs
}

/// Computes the coder section; `None` when there are no `aus` answers.
pub fn analyze(manifest: &Manifest, responses: &Responses, catalog: &Catalog, options: CodingOptions) -> Option<CodingReport> {
    if responses.aus.is_empty() {
        return None;
    }
    // Coders in order of first answer; stimuli in manifest order.
    let mut coder_of: BTreeMap<usize, usize> = BTreeMap::new();
    let mut coders: Vec<usize> = Vec::new();
    for a in &responses.aus {
        coder_of.entry(a.participant).or_insert_with(|| {
            coders.push(a.participant);
            coders.len() - 1
        });
    }
    let mut by_stim: BTreeMap<usize, Vec<usize>> = BTreeMap::new();
    for (i, a) in responses.aus.iter().enumerate() {
        by_stim.entry(a.stimulus).or_default().push(i);
    }
    let mut au_set: BTreeSet<u16> = BTreeSet::new();
    for (&s, answers) in &by_stim {
        au_set.extend(codes(&manifest.stimuli[s].expression));
        for &i in answers {
            au_set.extend(codes(&responses.aus[i].aus));
        }
    }
    let au_set: Vec<u16> = au_set.into_iter().collect();
    let tally = tally(manifest, responses, &by_stim, &au_set, options);
    let answered_pairs = responses.aus.len();

    // Agreement on complete cases: marked[stimulus][coder] = codes.
    let complete: Vec<usize> = by_stim.iter().filter(|(_, a)| a.len() == coders.len()).map(|(&s, _)| s).collect();
    let marked_by = |s: usize| -> Vec<Vec<u16>> {
        let mut m = vec![Vec::new(); coders.len()];
        for &i in &by_stim[&s] {
            m[coder_of[&responses.aus[i].participant]] = codes(&responses.aus[i].aus);
        }
        m
    };
    let complete_marks: Vec<Vec<Vec<u16>>> = complete.iter().map(|&s| marked_by(s)).collect();
    let per_au = au_rows(&au_set, &tally, &complete_marks, catalog);
    let mut total = Counts::default();
    for c in &tally.counts {
        total.add(*c);
    }
    let all_metrics: Vec<Metrics> = per_au.iter().map(|r| r.metrics).collect();
    let combinations = combination_rows(&tally);
    let combinations_macro_mean = Metrics::mean(&combinations.iter().map(|c| c.metrics).collect::<Vec<_>>());
    // Overall Fleiss κ over (stimulus, AU) items.
    let fleiss_table: Vec<Vec<u64>> = complete_marks
        .iter()
        .flat_map(|m| au_set.iter().map(move |au| {
            let yes = m.iter().filter(|c| c.contains(au)).count() as u64;
            vec![yes, m.len() as u64 - yes]
        }))
        .collect();
    let pairs = coder_pairs(responses, &coders, &coder_of, &au_set);
    let shown_macro_mean = Metrics::mean(&per_au.iter().filter(|r| r.shown_in > 0).map(|r| r.metrics).collect::<Vec<_>>());
    let comparison = comparison(&per_au, &shown_macro_mean, &combinations, &combinations_macro_mean);
    Some(CodingReport {
        convention: CONVENTION.to_string(),
        options,
        coders: coders.iter().map(|&p| responses.participants[p].id.clone()).collect(),
        stimuli: by_stim.len(),
        answered_pairs,
        missing_pairs: coders.len() * by_stim.len() - answered_pairs,
        au_set,
        macro_mean: Metrics::mean(&all_metrics),
        shown_macro_mean,
        micro: total.metrics(),
        total,
        table1_groups: table1_groups(&per_au),
        per_au,
        combinations,
        combinations_macro_mean,
        agreement: Agreement { complete_stimuli: complete.len(), fleiss_kappa: Maybe::of(fleiss_kappa(&fleiss_table)), pairs },
        comparison,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    fn run(manifest: &str, responses: &str, options: CodingOptions) -> CodingReport {
        let (m, r) = crate::analysis::fixture(manifest, responses);
        analyze(&m, &r, Catalog::built_in(), options).unwrap()
    }

    fn row(r: &CodingReport, au: u16) -> &AuRow {
        r.per_au.iter().find(|x| x.au == au).unwrap()
    }

    /// Hand-counted: two stimuli (AU 11; AUs 1+2), three coders.
    /// s1 shows 11: c1 marks 11, c2 marks 11, c3 marks 38 (mistaken for 38).
    /// s2 shows 1+2: c1 1+2, c2 1+2+4, c3 1.
    #[test]
    fn counts_metrics_and_mistakes_by_hand() {
        let r = run(
            "s1,video,wm1,11,,1\ns2,video,wm1,1+2,,1\n",
            "c1,g,s1,1,aus,11,\nc2,g,s1,1,aus,11,\nc3,g,s1,1,aus,38,\n\
             c1,g,s2,2,aus,1+2,\nc2,g,s2,2,aus,1+2+4,\nc3,g,s2,2,aus,1,\n",
            CodingOptions::default(),
        );
        assert_eq!(r.au_set, [1, 2, 4, 11, 38]);
        assert_eq!(r.answered_pairs, 6);
        assert_eq!(r.missing_pairs, 0);
        let au11 = row(&r, 11);
        assert_eq!(au11.counts, Counts { tp: 2, fp: 0, fn_: 1, tn: 3 });
        assert_eq!(au11.mistaken_for, [AuCount { au: 38, count: 1 }]);
        assert!((au11.metrics.recall - 2.0 / 3.0).abs() < 1e-12);
        assert!((au11.metrics.f1 - 0.8).abs() < 1e-12);
        let au2 = row(&r, 2);
        assert_eq!(au2.counts, Counts { tp: 2, fp: 0, fn_: 1, tn: 3 });
        let au4 = row(&r, 4);
        assert_eq!(au4.counts, Counts { tp: 0, fp: 1, fn_: 0, tn: 5 });
        assert_eq!(au4.metrics.precision, 0.0);
        // Micro: TP 7 (11×2, 1×3, 2×2), FP 2 (38, 4), FN 2 (11, 2), N = 6 pairs × 5 AUs = 30.
        assert_eq!(r.total, Counts { tp: 7, fp: 2, fn_: 2, tn: 19 });
        // F1 is the harmonic mean of P and R.
        let m = r.micro;
        assert!((m.f1 - 2.0 * m.precision * m.recall / (m.precision + m.recall)).abs() < 1e-12);
        let combo = r.combinations.iter().find(|c| c.combination == "1 + 2").unwrap();
        assert_eq!(combo.recognised_display, "1 + 2 + (4)");
        assert_eq!(combo.counts, Counts { tp: 5, fp: 1, fn_: 1, tn: 8 });
        // α for AU 11 over two complete stimuli: c1, c2 = (1, 0), c3 = (0, 0) -> item variances
        // 0.5, 0.5, 0; total (2, 0) variance 2; α = 3/2 · (1 − 1/2) = 0.75 (HapFACS Table 2's value).
        assert!((au11.alpha.value.unwrap() - 0.75).abs() < 1e-12);
        assert_eq!(r.agreement.pairs.len(), 3);
        let c1c2 = &r.agreement.pairs[0];
        assert!((c1c2.dice_mean - (1.0 + 0.8) / 2.0).abs() < 1e-12);
    }

    #[test]
    fn side_and_intensity_matching() {
        let m = "s1,video,wm1,R14C+1,,1\n";
        let answers = "c1,g,s1,1,aus,L14C+1B,\nc2,g,s1,1,aus,R14C+1E,\nc3,g,s1,1,aus,14+1,\n";
        let loose = run(m, answers, CodingOptions::default());
        assert_eq!(row(&loose, 14).counts.tp, 3);
        let side = run(m, answers, CodingOptions { match_side: true, match_intensity: false });
        assert_eq!(row(&side, 14).counts, Counts { tp: 1, fp: 0, fn_: 2, tn: 0 });
        let both = run(m, answers, CodingOptions { match_side: true, match_intensity: true });
        assert_eq!(row(&both, 14).counts.tp, 1);
        // AU 1 is shown at E (no letter); only c2 wrote E.
        assert_eq!(row(&both, 1).counts.tp, 1);
    }

    #[test]
    fn missing_answers_are_counted_not_coded() {
        let r = run("s1,video,wm1,1,,1\ns2,video,wm1,2,,1\n", "c1,g,s1,1,aus,1,\nc2,g,s1,1,aus,1,\nc1,g,s2,2,aus,2,\n", CodingOptions::default());
        assert_eq!(r.missing_pairs, 1);
        assert_eq!(r.agreement.complete_stimuli, 1);
    }

    #[test]
    fn published_au_level_figures_parse_and_sit_beside_this_study() {
        let p = published_au_level();
        assert_eq!(p.len(), 4);
        assert!(p.contains(&("single AUs".to_string(), "HapFACS".to_string(), 49, 94.6)));
        let single = run("s1,video,wm1,1,,1\ns2,video,wm1,2,,1\n", "c1,g,s1,1,aus,1,\nc1,g,s2,2,aus,1,\n", CodingOptions::default());
        let rows: Vec<_> = single.comparison.iter().map(|c| (c.stimuli.as_str(), c.system.as_str(), c.count, c.percent)).collect();
        // AU 1 found once of once, AU 2 never: mean recall 50 %.
        assert_eq!(rows, [("single AUs", "HapFACS", 2, 50.0), ("single AUs", "FACSGen", 2, 50.0)]);
        let combos = run("s1,video,wm1,1+2,,1\n", "c1,g,s1,1,aus,1+2,\n", CodingOptions::default());
        assert!(combos.comparison.iter().all(|c| c.stimuli == "AU combinations" && c.percent == 100.0), "{:?}", combos.comparison);
    }

    #[test]
    fn the_headline_mean_is_over_the_aus_shown() {
        // AU 1 shown and found; AU 2 only marked by the coder (a false positive).
        let r = run("s1,video,wm1,1,,1\n", "c1,g,s1,1,aus,1+2,\n", CodingOptions::default());
        assert_eq!((row(&r, 1).metrics.f1, row(&r, 2).metrics.f1), (1.0, 0.0));
        assert_eq!(r.shown_macro_mean.f1, 1.0, "HapFACS Table 3's mean: AU 1 only");
        assert_eq!(r.macro_mean.f1, 0.5, "over the AU set: AU 1 and AU 2");
    }
}
