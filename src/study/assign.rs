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

/// The `share` least-loaded stimuli (`share` = 0: all of them). With a `target`, a participant
/// is only taken while some stimulus is below it.
pub fn choose_stimuli(loads: &[(String, usize)], share: usize, target: usize, seed: u64) -> Result<Vec<String>, StudyFull> {
    if target > 0 && loads.iter().all(|(_, load)| *load >= target) {
        return Err(StudyFull { target });
    }
    let mut order: Vec<(usize, u64, &str)> = {
        let mut rng = SplitMix64(seed ^ 0xA551_6E00);
        loads.iter().map(|(id, load)| (*load, rng.next_u64(), id.as_str())).collect()
    };
    order.sort_unstable();
    let n = if share == 0 { order.len() } else { share.min(order.len()) };
    Ok(order[..n].iter().map(|(_, _, id)| id.to_string()).collect())
}

/// The full plan: `practice` stimuli drawn from `pool` (not from the main share when the pool
/// allows), then the main stimuli shuffled, with `checks` attention checks spread over them.
pub fn plan_trials(main: &[String], pool: &[String], practice: usize, checks: usize, seed: u64) -> Vec<PlannedTrial> {
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
    rng.shuffle(&mut order);
    let segments = checks.max(1);
    let mut at = Vec::with_capacity(checks);
    for k in 0..checks {
        // Check k goes after a seeded trial of segment k (never before the first main trial).
        let (lo, hi) = (k * order.len() / segments, ((k + 1) * order.len() / segments).max(k * order.len() / segments + 1));
        at.push(lo + 1 + rng.below(hi - lo));
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

    #[test]
    fn one_check_over_one_trial() {
        let pool = ids(1);
        let plan = plan_trials(&pool, &pool, 0, 1, 1);
        assert_eq!(plan.iter().map(|t| t.kind).collect::<Vec<_>>(), vec![TrialKind::Trial, TrialKind::Attention]);
    }
}
