//! Balanced assignment and seeded trial order (design.md §6.4–5).
//!
//! In: the study's stimuli with their current load (completed ratings plus unexpired
//! reservations, counted by the database inside the same `BEGIN IMMEDIATE` transaction that
//! stores the result) and the participant's seed. Out: the participant's trial plan: practice
//! trials first, then the main trials in a seeded order with the attention checks spread over
//! it, one per equal segment.
//!
//! Invariants: a participant never sees a main stimulus twice; with a share of `n` stimuli the
//! `n` least-loaded stimuli are chosen (ties broken by the seed), so completed counts never
//! differ by more than one while participants finish; the same inputs give the same plan.

use crate::seeded::SplitMix64;

/// What a trial is for.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum TrialKind {
    Practice,
    Trial,
    Attention,
}

impl TrialKind {
    pub fn as_str(self) -> &'static str {
        match self {
            TrialKind::Practice => "practice",
            TrialKind::Trial => "trial",
            TrialKind::Attention => "attention",
        }
    }

    pub fn parse(text: &str) -> Option<TrialKind> {
        [TrialKind::Practice, TrialKind::Trial, TrialKind::Attention].into_iter().find(|k| k.as_str() == text)
    }
}

/// One trial of a participant's plan.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PlannedTrial {
    pub kind: TrialKind,
    pub stimulus_id: String,
    /// Which attention check (index into the design's checks).
    pub check_index: Option<usize>,
}

/// The study has every rating it asked for.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("every stimulus already has its {target} ratings")]
pub struct StudyFull {
    pub target: usize,
}

/// `items` by load, least loaded first, ties in an order seeded by `seed` (the same seed gives
/// the same order).
fn least_loaded_first<T>(items: impl IntoIterator<Item = (usize, T)>, seed: u64) -> Vec<T> {
    let mut rng = SplitMix64(seed);
    let mut order: Vec<(usize, u64, T)> = items.into_iter().map(|(load, item)| (load, rng.next_u64(), item)).collect();
    order.sort_unstable_by_key(|(load, tie, _)| (*load, *tie));
    order.into_iter().map(|(_, _, item)| item).collect()
}

/// The `share` least-loaded stimuli (`share` = 0: all of them). With a `target`, a participant
/// is only taken while some stimulus is below it.
pub fn choose_stimuli(loads: &[(String, usize)], share: usize, target: usize, seed: u64) -> Result<Vec<String>, StudyFull> {
    if target > 0 && loads.iter().all(|(_, load)| *load >= target) {
        return Err(StudyFull { target });
    }
    let order = least_loaded_first(loads.iter().map(|(id, load)| (*load, id)), seed ^ 0xA551_6E00);
    let n = if share == 0 { order.len() } else { share.min(order.len()) };
    Ok(order[..n].iter().map(|id| id.to_string()).collect())
}

/// The stimuli of the `labels` least-loaded labels, a label's stimuli together (in id order),
/// for designs that show whole labels (`labels_per_participant`; seed 004's study 1: six or
/// seven types, each with its real and its generated video). A label's load is its most-loaded
/// stimulus's; with a `target`, a participant is only taken while some label is below it.
pub fn choose_labels(loads: &[(String, usize)], label_of: &dyn Fn(&str) -> Option<String>, labels: usize, target: usize, seed: u64) -> Result<Vec<Vec<String>>, StudyFull> {
    let mut groups: std::collections::BTreeMap<String, (usize, Vec<String>)> = std::collections::BTreeMap::new();
    for (id, load) in loads {
        let group = groups.entry(label_of(id).unwrap_or_default()).or_default();
        group.0 = group.0.max(*load);
        group.1.push(id.clone());
    }
    if target > 0 && groups.values().all(|(load, _)| *load >= target) {
        return Err(StudyFull { target });
    }
    let groups = groups.into_values().map(|(load, mut ids)| {
        ids.sort();
        (load, ids)
    });
    Ok(least_loaded_first(groups, seed ^ 0xA551_6E01).into_iter().take(labels).collect())
}

/// The full plan: `practice` stimuli drawn from `pool` (not from the main share when the pool
/// allows), then the main stimuli shuffled, with `checks` attention checks spread over them.
pub fn plan_trials(main: &[String], pool: &[String], practice: usize, checks: usize, seed: u64) -> Vec<PlannedTrial> {
    plan_with(main, pool, practice, checks, seed, &|order, rng| {
        rng.shuffle(order);
        (1..=order.len()).collect()
    })
}

/// The plan of whole labels ([`choose_labels`]): the labels in a seeded order, each label's
/// stimuli one after another (in a seeded order), attention checks only between labels.
pub fn plan_label_trials(groups: &[Vec<String>], pool: &[String], practice: usize, checks: usize, seed: u64) -> Vec<PlannedTrial> {
    let main: Vec<String> = groups.concat();
    plan_with(&main, pool, practice, checks, seed, &|order, rng| {
        let mut shuffled: Vec<Vec<&String>> = groups.iter().map(|g| g.iter().collect()).collect();
        rng.shuffle(&mut shuffled);
        shuffled.iter_mut().for_each(|g| rng.shuffle(g));
        let (mut ends, mut at) = (Vec::new(), 0);
        for group in &shuffled {
            at += group.len();
            ends.push(at);
        }
        *order = shuffled.concat();
        ends
    })
}

/// Where the main trials go: `arrange` orders them and returns the positions a check may follow
/// (the number of main trials before it, rising).
type Arrange<'a> = dyn Fn(&mut Vec<&'a String>, &mut SplitMix64) -> Vec<usize> + 'a;

fn plan_with<'a>(main: &'a [String], pool: &[String], practice: usize, checks: usize, seed: u64, arrange: &Arrange<'a>) -> Vec<PlannedTrial> {
    let mut rng = SplitMix64(seed);
    let mut trials = Vec::with_capacity(practice + main.len() + checks);

    let mut candidates: Vec<&String> = pool.iter().filter(|s| !main.contains(s)).collect();
    if candidates.len() < practice {
        candidates = pool.iter().collect();
    }
    rng.shuffle(&mut candidates);
    for stimulus in candidates.into_iter().take(practice) {
        trials.push(PlannedTrial { kind: TrialKind::Practice, stimulus_id: stimulus.clone(), check_index: None });
    }

    let mut order: Vec<&String> = main.iter().collect();
    let allowed = arrange(&mut order, &mut rng);
    let segments = checks.max(1);
    let mut at = Vec::with_capacity(checks);
    for k in 0..checks {
        // Check k goes after a seeded trial of segment k (never before the first main trial),
        // at a position `arrange` allows (the first allowed one after the segment if none is in it).
        let (lo, hi) = (k * order.len() / segments, ((k + 1) * order.len() / segments).max(k * order.len() / segments + 1));
        let inside: Vec<usize> = allowed.iter().copied().filter(|&p| p > lo && p <= hi).collect();
        at.push(match inside.len() {
            0 => allowed.iter().copied().find(|&p| p > lo).or(allowed.last().copied()).unwrap_or(1),
            n => inside[rng.below(n)],
        });
    }
    for (i, stimulus) in order.iter().enumerate() {
        trials.push(PlannedTrial { kind: TrialKind::Trial, stimulus_id: (*stimulus).clone(), check_index: None });
        for (k, _) in at.iter().enumerate().filter(|(_, after)| **after == i + 1) {
            let shown = if main.is_empty() { pool[rng.below(pool.len())].clone() } else { main[rng.below(main.len())].clone() };
            trials.push(PlannedTrial { kind: TrialKind::Attention, stimulus_id: shown, check_index: Some(k) });
        }
    }
    trials
}

#[cfg(test)]
mod tests {
    use super::*;

    fn ids(n: usize) -> Vec<String> {
        (0..n).map(|i| format!("s{i:02}")).collect()
    }

    #[test]
    fn least_loaded_first_and_full_when_every_target_is_met() {
        let loads: Vec<(String, usize)> = ids(4).into_iter().zip([3, 1, 2, 1]).collect();
        let mut got = choose_stimuli(&loads, 2, 5, 9).unwrap();
        got.sort();
        assert_eq!(got, vec!["s01", "s03"]);
        assert_eq!(choose_stimuli(&loads, 0, 0, 9).unwrap().len(), 4);
        let full: Vec<(String, usize)> = ids(3).into_iter().map(|s| (s, 5)).collect();
        assert_eq!(choose_stimuli(&full, 2, 5, 1), Err(StudyFull { target: 5 }));
    }

    #[test]
    fn sequential_participants_keep_counts_within_one() {
        let mut loads: Vec<(String, usize)> = ids(10).into_iter().map(|s| (s, 0)).collect();
        for seed in 0..37 {
            for id in choose_stimuli(&loads, 3, 0, seed).unwrap() {
                loads.iter_mut().find(|(s, _)| *s == id).unwrap().1 += 1;
            }
            let (min, max) = (loads.iter().map(|l| l.1).min().unwrap(), loads.iter().map(|l| l.1).max().unwrap());
            assert!(max - min <= 1, "after participant {seed}: {loads:?}");
        }
    }

    #[test]
    fn plan_has_practice_first_every_main_stimulus_once_and_spread_checks() {
        let pool = ids(20);
        let main: Vec<String> = pool[..12].to_vec();
        let plan = plan_trials(&main, &pool, 2, 3, 42);
        assert_eq!(plan.len(), 2 + 12 + 3);
        assert!(plan[..2].iter().all(|t| t.kind == TrialKind::Practice && !main.contains(&t.stimulus_id)));
        let mut shown: Vec<&String> = plan.iter().filter(|t| t.kind == TrialKind::Trial).map(|t| &t.stimulus_id).collect();
        shown.sort();
        assert_eq!(shown, main.iter().collect::<Vec<_>>());
        let checks: Vec<usize> = plan.iter().enumerate().filter(|(_, t)| t.kind == TrialKind::Attention).map(|(i, _)| i).collect();
        assert_eq!(checks.len(), 3);
        assert!(checks[0] > 2, "a check before the first main trial: {checks:?}");
        assert_eq!(plan_trials(&main, &pool, 2, 3, 42), plan, "same seed, same plan");
        assert_ne!(plan_trials(&main, &pool, 2, 3, 43), plan);
    }

    /// 13 labels of two stimuli each (a real and a generated video per laugh type).
    fn pairs() -> (Vec<(String, usize)>, impl Fn(&str) -> Option<String>) {
        let loads = ids(26).into_iter().map(|s| (s, 0)).collect();
        (loads, |id: &str| id[1..].parse::<usize>().ok().map(|n| format!("type{}", n / 2)))
    }

    #[test]
    fn whole_labels_are_chosen_least_rated_first_and_shown_one_after_another() {
        let (mut loads, label_of) = pairs();
        for seed in 0..20 {
            let groups = choose_labels(&loads, &label_of, 7, 0, seed).unwrap();
            assert_eq!(groups.len(), 7);
            assert!(groups.iter().all(|g| g.len() == 2 && label_of(&g[0]) == label_of(&g[1])), "whole labels: {groups:?}");
            for id in groups.concat() {
                loads.iter_mut().find(|(s, _)| *s == id).unwrap().1 += 1;
            }
            let counts: Vec<usize> = loads.iter().map(|l| l.1).collect();
            assert!(counts.iter().max().unwrap() - counts.iter().min().unwrap() <= 1, "after participant {seed}: {counts:?}");
            let plan = plan_label_trials(&groups, &ids(26), 0, 2, seed);
            let shown: Vec<&String> = plan.iter().filter(|t| t.kind == TrialKind::Trial).map(|t| &t.stimulus_id).collect();
            assert_eq!(shown.len(), 14);
            for pair in shown.chunks(2) {
                assert_eq!(label_of(pair[0]), label_of(pair[1]), "a label's stimuli follow each other: {shown:?}");
            }
            let mains_before = |i: usize| plan[..i].iter().filter(|t| t.kind == TrialKind::Trial).count();
            for (i, _) in plan.iter().enumerate().filter(|(_, t)| t.kind == TrialKind::Attention) {
                assert_eq!(mains_before(i) % 2, 0, "checks only between labels");
            }
        }
        let full: Vec<(String, usize)> = ids(4).into_iter().map(|s| (s, 3)).collect();
        assert_eq!(choose_labels(&full, &label_of, 1, 3, 1), Err(StudyFull { target: 3 }));
    }

    #[test]
    fn one_check_over_one_trial() {
        let pool = ids(1);
        let plan = plan_trials(&pool, &pool, 0, 1, 1);
        assert_eq!(plan.iter().map(|t| t.kind).collect::<Vec<_>>(), vec![TrialKind::Trial, TrialKind::Attention]);
    }
}
