//! Planning a validation study: how wide the 95 % CIs of the headline statistics will be, and
//! how often a group t-test finds an assumed difference, for each sample size.
//!
//! In: an answer model ([`SimOptions`]: design, accuracy, confusion, missing data, the assumed
//! group difference), the sample sizes (coders for exp1/exp2, raters per condition for exp3),
//! the number of runs and a seed. For every size, `runs` seeded simulations
//! ([`super::simulate::simulate`]) are read and analysed exactly as a real study
//! ([`super::analyze`]), so the statistics and their CIs are the report's own.
//!
//! Out: a [`PowerTable`]: per size and statistic, the mean over runs of the reported 95 % CI
//! width, and the 2.5–97.5 % spread of the point estimates over the runs (linear interpolation
//! between order statistics, numpy's default). When the CI is calibrated, the two agree. For the
//! group t-test, the power: the share of runs with Welch p < .05.
//!
//! Statistics: per-AU F1 (exp1/exp2; Jeffreys CI, one row per shown AU and their mean),
//! recognition rate per condition × emotion (Clopper–Pearson CI, one row each and their mean),
//! mean believability per condition (t CI over the participants' means), and the Welch t-test
//! of the first two groups' mean believability per condition (its CI of the difference, and the
//! power). For seed 004's laugh designs, per rating scale: each style's mean (t CI over its
//! ratings), and the power of the two-way ANOVA's style effect and style × label interaction
//! (Type II, the seed's melancholy-smile and false-laughter interaction in the simulation).
//!
//! **Invariants:** the same options give the same table (each run's seed is derived from the
//! seed, the size and the run index only); sizes and runs are bounded ([`MAX_RUNS`],
//! [`MAX_SIZES`], [`MAX_SIZE`], [`MAX_WORK`]) with errors that say which bound.

use serde::Serialize;

use super::coding::CodingOptions;
use super::manifest::Manifest;
use super::rating::BELIEVABILITY_OUTCOME;
use super::responses::{Responses, Scale};
use super::simulate::{Design, SimOptions, simulate};
use super::stats::descriptive::quantile_sorted as quantile;
use crate::facs::{Catalog, EmotionTable};
use crate::seeded::SplitMix64;

pub const MAX_RUNS: usize = 2000;
pub const MAX_SIZES: usize = 20;
pub const MAX_SIZE: usize = 500;
/// Runs × the sum of the sizes: a bound on the simulated participants in total.
pub const MAX_WORK: usize = 400_000;

/// The significance level of the power.
pub const POWER_ALPHA: f64 = 0.05;

/// Why a power analysis cannot run.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum PowerError {
    #[error("runs must be between 2 and {MAX_RUNS}, got {0}")]
    Runs(usize),
    #[error("give between 1 and {MAX_SIZES} sizes, got {0}")]
    SizeCount(usize),
    #[error("each size must be between 2 and {MAX_SIZE}, got {0}")]
    Size(usize),
    #[error("runs × the sum of the sizes is {0}, more than {MAX_WORK}: use fewer runs or smaller sizes")]
    Work(usize),
    #[error("a simulated study did not read back: {0}")]
    Simulation(String),
}

/// One statistic at one size.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct PowerRow {
    pub size: usize,
    /// `per-AU F1`, `recognition rate`, `believability mean`, `believability t-test`; for the
    /// laugh designs `style mean`, `style effect` and `style x label interaction`.
    pub statistic: String,
    /// The AU, `condition emotion`, condition, or `mean` for the mean over the items.
    pub item: String,
    /// Runs in which the statistic was defined.
    pub runs: usize,
    pub estimate_mean: f64,
    /// Mean width of the reported 95 % CI (`None` for the ANOVA's F-tests, which report none).
    pub ci_width_mean: Option<f64>,
    pub spread_low: f64,
    pub spread_high: f64,
    /// spread_high − spread_low: what the CI width should match.
    pub spread_width: f64,
    /// Share of runs with p < .05 (the t-test and the F-tests).
    pub power: Option<f64>,
}

/// The whole power analysis.
#[derive(Debug, Clone, Serialize)]
pub struct PowerTable {
    pub convention: String,
    pub design: String,
    pub seed: u64,
    pub runs: usize,
    pub sizes: Vec<usize>,
    pub accuracy: f64,
    pub group_difference: f64,
    pub rows: Vec<PowerRow>,
}

pub const CONVENTION: &str = "For each size (coders for exp1/exp2, raters per media x intensity condition for exp3), R seeded simulations are analysed as a real study. ci_width_mean = mean over runs of the reported 95% CI width; spread = 2.5-97.5% percentiles of the point estimates over runs (linear interpolation); a calibrated CI has ci_width_mean close to spread_width. per-AU F1: Jeffreys CI (the report's); recognition rate: Clopper-Pearson; believability mean: t CI over participants' means; believability t-test: Welch, first two groups, per condition, CI of the difference, power = share of runs with p < .05; laugh designs (participants per study): style mean per scale and style, t CI over its ratings; style effect and style x label interaction: Type II two-way ANOVA, estimate = partial eta squared, no CI, power = share of runs with p < .05. Rows with item = mean average the items' rows.";

/// One statistic of one analysed run.
struct Observation {
    statistic: &'static str,
    item: String,
    estimate: f64,
    /// The reported 95 % CI; `None` for a test that reports none (the ANOVA's F-tests).
    ci: Option<(f64, f64)>,
    p: Option<f64>,
}

/// Checks the bounds of a power analysis.
pub fn check(sizes: &[usize], runs: usize) -> Result<(), PowerError> {
    if !(2..=MAX_RUNS).contains(&runs) {
        return Err(PowerError::Runs(runs));
    }
    if sizes.is_empty() || sizes.len() > MAX_SIZES {
        return Err(PowerError::SizeCount(sizes.len()));
    }
    if let Some(&bad) = sizes.iter().find(|s| !(2..=MAX_SIZE).contains(*s)) {
        return Err(PowerError::Size(bad));
    }
    let work = runs * sizes.iter().sum::<usize>();
    if work > MAX_WORK {
        return Err(PowerError::Work(work));
    }
    Ok(())
}

/// The seed of one run: a function of the seed, the size and the run index only.
fn run_seed(seed: u64, size: usize, run: usize) -> u64 {
    SplitMix64(seed ^ ((size as u64) << 32) ^ run as u64).next_u64()
}

/// Simulates and analyses one run; returns its headline statistics.
fn one_run(model: &SimOptions, size: usize, seed: u64) -> Result<Vec<Observation>, PowerError> {
    let options = match model.design {
        Design::Exp3 | Design::Exp4 | Design::LaughDescription | Design::LaughMotion => SimOptions { seed, participants: size, ..model.clone() },
        Design::Exp1 | Design::Exp2 => SimOptions { seed, coders: size, ..model.clone() },
    };
    let (manifest_csv, responses_csv) = simulate(&options);
    let (catalog, emotions) = (Catalog::built_in(), EmotionTable::built_in());
    let manifest = Manifest::from_csv("manifest.csv", &manifest_csv, catalog).map_err(|e| PowerError::Simulation(e.to_string()))?;
    let responses = Responses::from_csv("responses.csv", &responses_csv, &manifest, catalog, &emotions).map_err(|e| PowerError::Simulation(e.to_string()))?;
    let analysis = super::analyze(&manifest, &responses, &CodingOptions::default());
    let mut out = Vec::new();
    if let Some(c) = &analysis.coding {
        for r in c.per_au.iter().filter(|r| r.shown_in > 0) {
            if let Ok(&ci) = r.f1_ci95.as_result() {
                out.push(Observation { statistic: "per-AU F1", item: format!("AU{}", r.au), estimate: r.metrics.f1, ci: Some(ci), p: None });
            }
        }
    }
    if let Some(r) = &analysis.rating {
        for c in &r.conditions {
            for e in &c.emotions {
                out.push(Observation { statistic: "recognition rate", item: format!("{} {}", c.key, e.emotion), estimate: e.rate, ci: Some(e.rate_ci95), p: None });
            }
            let believability = c.scales.iter().find(|s| s.scale == Scale::Believability).and_then(|s| s.participant_means.as_result().ok());
            if let Some(s) = believability {
                out.push(Observation { statistic: "believability mean", item: c.key.clone(), estimate: s.mean, ci: Some(s.ci), p: None });
            }
        }
        let tests = r.group_tests.iter().filter(|t| t.emotion == "all" && t.outcome == BELIEVABILITY_OUTCOME && r.conditions.iter().any(|c| c.key == t.condition));
        for t in tests {
            if let Ok(w) = t.welch.as_result() {
                out.push(Observation { statistic: "believability t-test", item: t.condition.clone(), estimate: w.mean_diff, ci: Some(w.ci), p: Some(w.p_two_sided) });
            }
        }
    }
    analysis.styles.iter().for_each(|s| out.extend(style_observations(s)));
    Ok(out)
}

/// The laugh designs' statistics of one rating scale: each style's mean rating (t CI over its
/// ratings, the report's between-subjects convention) and, from the Type II ANOVA, the style
/// effect and the style × label interaction (estimate: partial η²; power: p < .05).
fn style_observations(s: &super::styles::StyleScale) -> Vec<Observation> {
    let scale = s.scale.name();
    let mut out = Vec::new();
    for cell in &s.per_style {
        let Some(d) = &cell.stats else { continue };
        let Some(sd) = d.sd else { continue };
        let Ok(t) = super::stats::descriptive::t_critical(0.95, (d.n - 1) as f64) else { continue };
        let half = t * sd / (d.n as f64).sqrt();
        let ci = (d.mean - half, d.mean + half);
        out.push(Observation { statistic: "style mean", item: format!("{scale} {}", cell.style), estimate: d.mean, ci: Some(ci), p: None });
    }
    if let Ok(table) = s.type_ii.as_result() {
        for (statistic, term) in [("style effect", "style"), ("style x label interaction", "style:label")] {
            if let Some(row) = table.row(term)
                && let (Some(p), Some(eta)) = (row.p, row.partial_eta2)
            {
                out.push(Observation { statistic, item: scale.to_string(), estimate: eta, ci: None, p: Some(p) });
            }
        }
    }
    out
}

/// The row of one statistic at one size from its observations over the runs.
fn summarise(size: usize, statistic: &str, item: &str, obs: &[&Observation]) -> PowerRow {
    let n = obs.len() as f64;
    let mut estimates: Vec<f64> = obs.iter().map(|o| o.estimate).collect();
    estimates.sort_by(f64::total_cmp);
    let (low, high) = (quantile(&estimates, 0.025), quantile(&estimates, 0.975));
    let tested: Vec<f64> = obs.iter().filter_map(|o| o.p).collect();
    PowerRow {
        size,
        statistic: statistic.into(),
        item: item.into(),
        runs: obs.len(),
        estimate_mean: estimates.iter().sum::<f64>() / n,
        ci_width_mean: obs.iter().map(|o| o.ci.map(|(low, high)| high - low)).sum::<Option<f64>>().map(|w| w / n),
        spread_low: low,
        spread_high: high,
        spread_width: high - low,
        power: (!tested.is_empty()).then(|| tested.iter().filter(|&&p| p < POWER_ALPHA).count() as f64 / tested.len() as f64),
    }
}

/// The rows of one size: one per (statistic, item) defined in ≥ 2 runs, then per statistic with
/// several items the mean of its rows (item `mean`).
fn rows_of_size(size: usize, observations: &[Observation]) -> Vec<PowerRow> {
    let mut keys: Vec<(&str, &str)> = Vec::new();
    for o in observations {
        if !keys.contains(&(o.statistic, o.item.as_str())) {
            keys.push((o.statistic, o.item.as_str()));
        }
    }
    let mut rows: Vec<PowerRow> = Vec::new();
    for (statistic, item) in keys {
        let obs: Vec<&Observation> = observations.iter().filter(|o| o.statistic == statistic && o.item == item).collect();
        if obs.len() >= 2 {
            rows.push(summarise(size, statistic, item, &obs));
        }
    }
    let mut statistics: Vec<String> = Vec::new();
    for r in &rows {
        if !statistics.contains(&r.statistic) {
            statistics.push(r.statistic.clone());
        }
    }
    for statistic in statistics {
        let items: Vec<&PowerRow> = rows.iter().filter(|r| r.statistic == statistic).collect();
        if items.len() < 2 {
            continue;
        }
        let mean = |f: fn(&PowerRow) -> f64| items.iter().map(|r| f(r)).sum::<f64>() / items.len() as f64;
        let power = items.iter().map(|r| r.power).collect::<Option<Vec<f64>>>().map(|p| p.iter().sum::<f64>() / p.len() as f64);
        let (low, high) = (mean(|r| r.spread_low), mean(|r| r.spread_high));
        let ci_width_mean = items.iter().map(|r| r.ci_width_mean).sum::<Option<f64>>().map(|w| w / items.len() as f64);
        let summary = PowerRow { size, statistic: statistic.clone(), item: "mean".into(), runs: items.iter().map(|r| r.runs).min().unwrap_or(0), estimate_mean: mean(|r| r.estimate_mean), ci_width_mean, spread_low: low, spread_high: high, spread_width: mean(|r| r.spread_width), power };
        rows.push(summary);
    }
    rows
}

/// Runs the power analysis; `tick` is called after every simulated study (for a progress bar).
pub fn run(model: &SimOptions, sizes: &[usize], runs: usize, tick: &dyn Fn()) -> Result<PowerTable, PowerError> {
    check(sizes, runs)?;
    let mut rows = Vec::new();
    for &size in sizes {
        let mut observations = Vec::new();
        for r in 0..runs {
            observations.extend(one_run(model, size, run_seed(model.seed, size, r))?);
            tick();
        }
        rows.extend(rows_of_size(size, &observations));
    }
    Ok(PowerTable { convention: CONVENTION.into(), design: model.design.name().into(), seed: model.seed, runs, sizes: sizes.to_vec(), accuracy: model.accuracy, group_difference: model.group_difference, rows })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn bounds_are_checked_with_the_bound_named() {
        assert_eq!(check(&[5], 1), Err(PowerError::Runs(1)));
        assert_eq!(check(&[], 10), Err(PowerError::SizeCount(0)));
        assert_eq!(check(&[5, 1], 10), Err(PowerError::Size(1)));
        assert_eq!(check(&[500, 500], 1000), Err(PowerError::Work(1_000_000)));
        assert!(check(&[3, 10], 50).is_ok());
    }

    #[test]
    fn a_t_test_finds_a_large_difference_more_often_than_none() {
        let model = |d: f64| SimOptions { design: Design::Exp3, seed: 4, identities: 1, group_difference: d, ..SimOptions::default() };
        let power = |d: f64| {
            let t = run(&model(d), &[10], 12, &|| {}).unwrap();
            t.rows.iter().find(|r| r.statistic == "believability t-test" && r.item == "mean").and_then(|r| r.power).unwrap()
        };
        let (none, large) = (power(0.0), power(1.5));
        assert!(large > 0.8 && none < 0.3, "power with no difference {none}, with 1.5 points {large}");
    }

    #[test]
    fn the_laugh_designs_interaction_is_found_more_often_with_more_participants() {
        let model = SimOptions { design: Design::LaughMotion, seed: 9, ..SimOptions::default() };
        let t = run(&model, &[5, 40], 40, &|| {}).unwrap();
        let row = |statistic: &str, size: usize| t.rows.iter().find(|r| r.statistic == statistic && r.item == "mean" && r.size == size).unwrap_or_else(|| panic!("no {statistic} at {size}"));
        let interaction = |size| row("style x label interaction", size).power.unwrap();
        assert!(interaction(5) < 0.3 && interaction(40) > 0.7, "the seed's interaction: power {} at 5, {} at 40 participants", interaction(5), interaction(40));
        let style = row("style effect", 40).power.unwrap();
        assert!(style <= 0.15, "no style effect is simulated, so it is found about as often as alpha: {style}");
        assert_eq!(row("style effect", 40).ci_width_mean, None, "an F-test reports no CI");
        let mean = row("style mean", 40);
        let (width, spread) = (mean.ci_width_mean.unwrap(), mean.spread_width);
        assert!(width > 0.1 && width < spread, "the ratings' t CI ignores that a participant's ratings go together: {width} vs spread {spread}");
    }
}
