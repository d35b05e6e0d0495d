//! Analysis of variance.
//!
//! Conventions:
//! - [`one_way`]: classic between-groups ANOVA; η² = SS_between / SS_total (equal to partial η²
//!   with one factor, which is what pingouin reports as `np2`).
//! - [`two_way`]: between-subjects A × B ANOVA fitted as an OLS linear model with **sum-to-zero
//!   (deviation) contrasts** for both factors and their interaction, as statsmodels'
//!   `C(A, Sum) * C(B, Sum)`. Type I is sequential in the order A, B, A:B; Type II tests each
//!   main effect after the other main effect (interaction after both); Type III tests each term
//!   after all others — only meaningful with sum-to-zero contrasts. Levels are sorted. Empty cells
//!   are rejected (rank-deficient design).
//! - [`rm_one_way`]: one-way repeated-measures ANOVA on complete wide data (rows = subjects,
//!   columns = conditions); sphericity by Mauchly's W with pingouin's χ² approximation;
//!   Greenhouse–Geisser ε and the GG-corrected p.

use super::descriptive::mean;
use super::error::{check_finite, check_len, check_same_len};
use super::linalg::rss_and_rank;
use super::{Result, StatsError};
use nalgebra::{DMatrix, DVector};
use statrs::distribution::{ChiSquared, ContinuousCDF, FisherSnedecor};

/// Upper-tail probability of F(df1, df2) at `f`.
pub(crate) fn f_sf(f: f64, df1: f64, df2: f64) -> Result<f64> {
    let dist = FisherSnedecor::new(df1, df2).map_err(|e| StatsError::InvalidParameter {
        what: "F distribution",
        detail: e.to_string(),
    })?;
    Ok(dist.sf(f))
}

// ------------------------------------------------------------------------------- one-way

/// One-way between-groups ANOVA.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct OneWay {
    pub ss_between: f64,
    pub ss_within: f64,
    pub df_between: f64,
    pub df_within: f64,
    pub ms_between: f64,
    pub ms_within: f64,
    pub f: f64,
    pub p: f64,
    /// η² = SS_between / (SS_between + SS_within).
    pub eta2: f64,
}

/// Pooled within-group quantities shared by ANOVA and the post hoc tests.
pub(crate) struct Pooled {
    pub means: Vec<f64>,
    pub ns: Vec<usize>,
    pub ss_within: f64,
    pub df_within: f64,
}

impl Pooled {
    /// Mean square within (error variance).
    pub fn ms_within(&self) -> f64 {
        self.ss_within / self.df_within
    }
}

/// Checks groups (k ≥ 2, each n ≥ 1, finite, N > k) and pools them.
pub(crate) fn pool_groups(groups: &[&[f64]]) -> Result<Pooled> {
    if groups.len() < 2 {
        return Err(StatsError::TooFewObservations {
            what: "ANOVA groups",
            needed: 2,
            got: groups.len(),
        });
    }
    let mut means = Vec::with_capacity(groups.len());
    let mut ss_within = 0.0;
    for g in groups {
        check_len("ANOVA group", g, 1)?;
        check_finite("ANOVA group", g)?;
        let m = mean(g)?;
        ss_within += g.iter().map(|v| (v - m).powi(2)).sum::<f64>();
        means.push(m);
    }
    let n_total: usize = groups.iter().map(|g| g.len()).sum();
    if n_total <= groups.len() {
        return Err(StatsError::TooFewObservations {
            what: "ANOVA (N > k)",
            needed: groups.len() + 1,
            got: n_total,
        });
    }
    let ns = groups.iter().map(|g| g.len()).collect();
    Ok(Pooled {
        means,
        ns,
        ss_within,
        df_within: (n_total - groups.len()) as f64,
    })
}

/// One-way ANOVA over `groups` (each a slice of observations).
pub fn one_way(groups: &[&[f64]]) -> Result<OneWay> {
    let pooled = pool_groups(groups)?;
    let n_total: usize = pooled.ns.iter().sum();
    let grand = groups.iter().flat_map(|g| g.iter()).sum::<f64>() / n_total as f64;
    let ss_between: f64 = pooled
        .means
        .iter()
        .zip(&pooled.ns)
        .map(|(m, &n)| n as f64 * (m - grand).powi(2))
        .sum();
    if pooled.ss_within == 0.0 {
        return Err(StatsError::ZeroVariance {
            what: "one-way ANOVA (within groups)",
        });
    }
    let df_between = (groups.len() - 1) as f64;
    let (ms_b, ms_w) = (ss_between / df_between, pooled.ms_within());
    let f = ms_b / ms_w;
    Ok(OneWay {
        ss_between,
        ss_within: pooled.ss_within,
        df_between,
        df_within: pooled.df_within,
        ms_between: ms_b,
        ms_within: ms_w,
        f,
        p: f_sf(f, df_between, pooled.df_within)?,
        eta2: ss_between / (ss_between + pooled.ss_within),
    })
}

// ------------------------------------------------------------------------------- two-way

/// Sums-of-squares type for unbalanced designs (identical on balanced designs).
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub enum SsType {
    /// Sequential: A, then B after A, then A:B after A and B.
    I,
    /// Hierarchical: A after B, B after A, A:B after A and B.
    II,
    /// Marginal: each term after all others (sum-to-zero contrasts).
    III,
}

/// One row of an ANOVA table.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct AnovaRow {
    /// `A`, `B`, `A:B` or `Residual`.
    pub term: String,
    pub ss: f64,
    pub df: f64,
    /// None for the residual row.
    pub f: Option<f64>,
    pub p: Option<f64>,
    /// SS_term / (SS_term + SS_residual); None for the residual row.
    pub partial_eta2: Option<f64>,
}

/// Two-way ANOVA table: rows A, B, A:B, Residual.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct AnovaTable {
    pub ss_type: SsType,
    pub rows: Vec<AnovaRow>,
}

impl AnovaTable {
    /// The row for `term` (`"A"`, `"B"`, `"A:B"`, `"Residual"`).
    pub fn row(&self, term: &str) -> Option<&AnovaRow> {
        self.rows.iter().find(|r| r.term == term)
    }

    /// The table with its terms named after the factors (`a`, `b`, `a:b`) and the residual row
    /// as `residual`, as reports print them.
    pub fn named(mut self, a: &str, b: &str) -> AnovaTable {
        for row in &mut self.rows {
            row.term = match row.term.as_str() {
                "A" => a.to_string(),
                "B" => b.to_string(),
                "A:B" => format!("{a}:{b}"),
                other => other.to_lowercase(),
            };
        }
        self
    }
}

/// Factor coding of the design matrix. The public API always uses [`Coding::Sum`]; treatment
/// coding exists to pin, in a test, why Type III needs sum-to-zero contrasts.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(crate) enum Coding {
    /// Deviation contrasts: level l < L−1 → e_l, last level → −1 in every column.
    Sum,
    /// Dummy contrasts against the first level.
    #[cfg_attr(not(test), allow(dead_code))]
    Treatment,
}

/// Sorted distinct levels and each observation's level index.
fn encode_levels<S: AsRef<str>>(x: &[S]) -> (Vec<String>, Vec<usize>) {
    let mut levels: Vec<&str> = x.iter().map(|s| s.as_ref()).collect();
    levels.sort_unstable();
    levels.dedup();
    let idx = x
        .iter()
        .map(|s| levels.binary_search(&s.as_ref()).unwrap_or(0))
        .collect();
    (levels.into_iter().map(str::to_owned).collect(), idx)
}

/// Contrast columns (L − 1 of them) for one observation at level `l` of `n_levels`.
fn contrast_row(l: usize, n_levels: usize, coding: Coding) -> Vec<f64> {
    (0..n_levels - 1)
        .map(|c| match coding {
            Coding::Sum if l == n_levels - 1 => -1.0,
            Coding::Sum => f64::from(u8::from(l == c)),
            Coding::Treatment => f64::from(u8::from(l == c + 1)),
        })
        .collect()
}

/// Design matrix [1 | A | B | A:B] and the column indices of each term.
struct Design {
    x: DMatrix<f64>,
    a: Vec<usize>,
    b: Vec<usize>,
    ab: Vec<usize>,
}

/// One design row per (A, B) pair, each row multiplied by `weight[r]`.
fn build_design(
    ia: &[usize],
    la: usize,
    ib: &[usize],
    lb: usize,
    weight: impl Fn(usize) -> f64,
    coding: Coding,
) -> Design {
    let (pa, pb) = (la - 1, lb - 1);
    let ncol = 1 + pa + pb + pa * pb;
    let mut x = DMatrix::zeros(ia.len(), ncol);
    for r in 0..ia.len() {
        let (ca, cb) = (
            contrast_row(ia[r], la, coding),
            contrast_row(ib[r], lb, coding),
        );
        let w = weight(r);
        x[(r, 0)] = w;
        for k in 0..pa {
            x[(r, 1 + k)] = w * ca[k];
        }
        for k in 0..pb {
            x[(r, 1 + pa + k)] = w * cb[k];
        }
        for k in 0..pa * pb {
            x[(r, 1 + pa + pb + k)] = w * ca[k / pb] * cb[k % pb];
        }
    }
    let a = (1..=pa).collect();
    let b = (pa + 1..=pa + pb).collect();
    let ab = (pa + pb + 1..ncol).collect();
    Design { x, a, b, ab }
}

/// Column set: intercept plus the given terms.
fn with_terms(terms: &[&Vec<usize>]) -> Vec<usize> {
    let mut cols = vec![0];
    for t in terms {
        cols.extend(t.iter().copied());
    }
    cols
}

/// Sufficient statistics of a two-way layout: per (A, B) cell the count, the mean and the
/// within-cell sum of squared deviations (Welford's update, so one pass and no cancellation).
///
/// Every model of a two-way ANOVA is a function of the cell, so for any of them
/// RSS = SS_within + Σ_cells n·(ȳ_cell − ŷ_cell)²: the fit on the cell means, weighted by the
/// counts, gives exactly the sums of squares of the fit on the observations, in time
/// independent of the number of observations.
#[derive(Debug, Clone, Default)]
pub struct TwoWayCells {
    a_levels: Vec<String>,
    b_levels: Vec<String>,
    /// Row-major `a_levels × b_levels`: (n, mean, SS within).
    cells: Vec<(u64, f64, f64)>,
    /// Index of the first non-finite value pushed, if any.
    non_finite: Option<usize>,
    pushed: usize,
}

impl TwoWayCells {
    /// An empty layout; levels are added as observations name them.
    pub fn new() -> Self {
        Self::default()
    }

    /// An empty layout with known level names (observations then use [`Self::add`]); levels
    /// that receive no observation are left out of the ANOVA, as with [`two_way`].
    pub fn with_levels(a_levels: Vec<String>, b_levels: Vec<String>) -> Self {
        let cells = vec![(0, 0.0, 0.0); a_levels.len() * b_levels.len()];
        TwoWayCells { a_levels, b_levels, cells, ..Self::default() }
    }

    fn level(levels: &mut Vec<String>, name: &str) -> (usize, bool) {
        match levels.iter().position(|l| l == name) {
            Some(i) => (i, false),
            None => {
                levels.push(name.to_owned());
                (levels.len() - 1, true)
            }
        }
    }

    /// Adds one observation `y` at levels named `a` and `b`.
    pub fn push(&mut self, a: &str, b: &str, y: f64) {
        let (ia, new_a) = Self::level(&mut self.a_levels, a);
        let (ib, new_b) = Self::level(&mut self.b_levels, b);
        if new_a || new_b {
            let (la, lb) = (self.a_levels.len(), self.b_levels.len());
            let old_lb = if new_b { lb - 1 } else { lb };
            let mut cells = vec![(0, 0.0, 0.0); la * lb];
            for (k, c) in self.cells.iter().enumerate() {
                cells[(k / old_lb) * lb + k % old_lb] = *c;
            }
            self.cells = cells;
        }
        self.add(ia, ib, y);
    }

    /// Adds one observation `y` at level indices `ia`, `ib` (into the names given to
    /// [`Self::with_levels`]).
    ///
    /// # Panics
    /// If an index is out of range.
    pub fn add(&mut self, ia: usize, ib: usize, y: f64) {
        assert!(ia < self.a_levels.len() && ib < self.b_levels.len(), "level index out of range");
        if !y.is_finite() && self.non_finite.is_none() {
            self.non_finite = Some(self.pushed);
        }
        self.pushed += 1;
        let c = &mut self.cells[ia * self.b_levels.len() + ib];
        c.0 += 1;
        let d = y - c.1;
        c.1 += d / c.0 as f64;
        c.2 += d * (y - c.1);
    }

    /// Observations added.
    pub fn n(&self) -> usize {
        self.pushed
    }
}

/// Two-way between-subjects ANOVA of `y` on factors `a` and `b` (see the module doc).
pub fn two_way<S: AsRef<str>, T: AsRef<str>>(
    a: &[S],
    b: &[T],
    y: &[f64],
    ss_type: SsType,
) -> Result<AnovaTable> {
    check_same_len("two-way ANOVA (A vs y)", a.len(), y.len())?;
    check_same_len("two-way ANOVA (B vs y)", b.len(), y.len())?;
    check_finite("two-way ANOVA y", y)?;
    let ((la, ia), (lb, ib)) = (encode_levels(a), encode_levels(b));
    let mut cells = TwoWayCells::with_levels(la, lb);
    for ((&i, &j), &v) in ia.iter().zip(&ib).zip(y) {
        cells.add(i, j, v);
    }
    two_way_cells(&cells, ss_type)
}

/// Two-way ANOVA from cell summaries: the same table as [`two_way`] on the observations.
pub fn two_way_cells(cells: &TwoWayCells, ss_type: SsType) -> Result<AnovaTable> {
    two_way_cells_coded(cells, ss_type, Coding::Sum)
}

/// Levels that hold observations, sorted by name: (old index → new index, count).
fn used_levels(names: &[String], used: impl Fn(usize) -> bool) -> (Vec<Option<usize>>, usize) {
    let mut order: Vec<usize> = (0..names.len()).filter(|&i| used(i)).collect();
    order.sort_by(|&x, &y| names[x].cmp(&names[y]));
    let mut map = vec![None; names.len()];
    for (new, &old) in order.iter().enumerate() {
        map[old] = Some(new);
    }
    (map, order.len())
}

fn check_levels(la: usize, lb: usize) -> Result<()> {
    if la < 2 || lb < 2 {
        return Err(StatsError::InvalidParameter {
            what: "two-way ANOVA",
            detail: format!("each factor needs ≥ 2 levels (A has {la}, B has {lb})"),
        });
    }
    Ok(())
}

pub(crate) fn two_way_cells_coded(
    cells: &TwoWayCells,
    ss_type: SsType,
    coding: Coding,
) -> Result<AnovaTable> {
    if let Some(index) = cells.non_finite {
        return Err(StatsError::NonFinite { what: "two-way ANOVA y", index });
    }
    let lb_all = cells.b_levels.len();
    let count = |ia: usize, ib: usize| cells.cells[ia * lb_all + ib].0;
    let (map_a, la) = used_levels(&cells.a_levels, |i| (0..lb_all).any(|j| count(i, j) > 0));
    let (map_b, lb) = used_levels(&cells.b_levels, |j| (0..cells.a_levels.len()).any(|i| count(i, j) > 0));
    check_levels(la, lb)?;
    // One row per non-empty cell, in (A, B) order of the sorted levels.
    let mut rows: Vec<(usize, usize, (u64, f64, f64))> = Vec::new();
    for (i, mi) in map_a.iter().enumerate() {
        for (j, mj) in map_b.iter().enumerate() {
            let c = cells.cells[i * lb_all + j];
            if let (Some(a), Some(b), true) = (mi, mj, c.0 > 0) {
                rows.push((*a, *b, c));
            }
        }
    }
    rows.sort_by_key(|r| (r.0, r.1));
    let n: u64 = rows.iter().map(|r| r.2.0).sum();
    let ss_within: f64 = rows.iter().map(|r| r.2.2).sum();
    let ia: Vec<usize> = rows.iter().map(|r| r.0).collect();
    let ib: Vec<usize> = rows.iter().map(|r| r.1).collect();
    let sqrt_n: Vec<f64> = rows.iter().map(|r| (r.2.0 as f64).sqrt()).collect();
    let d = build_design(&ia, la, &ib, lb, |r| sqrt_n[r], coding);
    let yv = DVector::from_iterator(rows.len(), rows.iter().zip(&sqrt_n).map(|(r, w)| w * r.2.1));
    let rss = |cols: &[usize]| {
        let (rss, rank) = rss_and_rank(&d.x, &yv, cols);
        (ss_within + rss, rank)
    };
    finish_table(&d, n as usize, ss_type, rss)
}

/// The ANOVA table from a design and its RSS function (RSS and rank for a column set).
fn finish_table(
    d: &Design,
    n: usize,
    ss_type: SsType,
    rss_of: impl Fn(&[usize]) -> (f64, usize),
) -> Result<AnovaTable> {
    let full = with_terms(&[&d.a, &d.b, &d.ab]);
    let (rss_full, rank_full) = rss_of(&full);
    if rank_full < full.len() || n <= rank_full {
        return Err(StatsError::RankDeficient {
            what: "two-way ANOVA",
            detail: format!(
                "rank {rank_full} of {} columns with n = {n} (empty cell?)",
                full.len(),
            ),
        });
    }
    let rss = |terms: &[&Vec<usize>]| rss_of(&with_terms(terms)).0;
    let (ss_a, ss_b, ss_ab) = match ss_type {
        SsType::I => (
            rss(&[]) - rss(&[&d.a]),
            rss(&[&d.a]) - rss(&[&d.a, &d.b]),
            rss(&[&d.a, &d.b]) - rss_full,
        ),
        SsType::II => (
            rss(&[&d.b]) - rss(&[&d.a, &d.b]),
            rss(&[&d.a]) - rss(&[&d.a, &d.b]),
            rss(&[&d.a, &d.b]) - rss_full,
        ),
        SsType::III => (
            rss(&[&d.b, &d.ab]) - rss_full,
            rss(&[&d.a, &d.ab]) - rss_full,
            rss(&[&d.a, &d.b]) - rss_full,
        ),
    };
    let df_res = (n - rank_full) as f64;
    if rss_full == 0.0 {
        return Err(StatsError::ZeroVariance {
            what: "two-way ANOVA (residual)",
        });
    }
    let mse = rss_full / df_res;
    let term = |name: &str, ss: f64, df: usize| -> Result<AnovaRow> {
        let df = df as f64;
        let f = ss / df / mse;
        Ok(AnovaRow {
            term: name.to_owned(),
            ss,
            df,
            f: Some(f),
            p: Some(f_sf(f, df, df_res)?),
            partial_eta2: Some(ss / (ss + rss_full)),
        })
    };
    let rows = vec![
        term("A", ss_a, d.a.len())?,
        term("B", ss_b, d.b.len())?,
        term("A:B", ss_ab, d.ab.len())?,
        AnovaRow {
            term: "Residual".into(),
            ss: rss_full,
            df: df_res,
            f: None,
            p: None,
            partial_eta2: None,
        },
    ];
    Ok(AnovaTable { ss_type, rows })
}

/// The reference path: OLS on every observation (one design row each). Same results as
/// [`two_way_cells_coded`], at a cost that grows with the number of observations; kept to check
/// the cell path and to pin the treatment-coding pitfall.
#[cfg(test)]
pub(crate) fn two_way_observations<S: AsRef<str>, T: AsRef<str>>(
    a: &[S],
    b: &[T],
    y: &[f64],
    ss_type: SsType,
    coding: Coding,
) -> Result<AnovaTable> {
    check_same_len("two-way ANOVA (A vs y)", a.len(), y.len())?;
    check_same_len("two-way ANOVA (B vs y)", b.len(), y.len())?;
    check_finite("two-way ANOVA y", y)?;
    let ((la, ia), (lb, ib)) = (encode_levels(a), encode_levels(b));
    check_levels(la.len(), lb.len())?;
    let d = build_design(&ia, la.len(), &ib, lb.len(), |_| 1.0, coding);
    let yv = DVector::from_column_slice(y);
    finish_table(&d, y.len(), ss_type, |cols| rss_and_rank(&d.x, &yv, cols))
}

// ------------------------------------------------------------------------------- repeated measures

/// One-way repeated-measures ANOVA with sphericity diagnostics.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct RmAnova {
    pub ss_conditions: f64,
    pub ss_subjects: f64,
    pub ss_error: f64,
    /// k − 1.
    pub df1: f64,
    /// (k − 1)(n − 1).
    pub df2: f64,
    pub f: f64,
    /// Uncorrected p.
    pub p_unc: f64,
    /// Partial η² = SS_conditions / (SS_conditions + SS_error).
    pub partial_eta2: f64,
    /// Greenhouse–Geisser ε (1 when k = 2).
    pub eps_gg: f64,
    /// p from F(ε·df1, ε·df2).
    pub p_gg: f64,
    /// Mauchly's W (1 when k = 2).
    pub mauchly_w: f64,
    /// p of Mauchly's χ² approximation (1 when k = 2).
    pub mauchly_p: f64,
}

/// Checks rectangular, complete wide data: n ≥ 2 subjects, k ≥ 2 conditions.
fn check_wide(data: &[Vec<f64>]) -> Result<(usize, usize)> {
    let n = data.len();
    if n < 2 {
        return Err(StatsError::TooFewObservations {
            what: "RM ANOVA subjects",
            needed: 2,
            got: n,
        });
    }
    let k = data[0].len();
    if k < 2 {
        return Err(StatsError::TooFewObservations {
            what: "RM ANOVA conditions",
            needed: 2,
            got: k,
        });
    }
    for row in data {
        check_same_len("RM ANOVA row (conditions)", row.len(), k)?;
        check_finite("RM ANOVA (complete cases only)", row)?;
    }
    Ok((n, k))
}

/// Sample covariance matrix (n − 1) of the columns of wide data.
fn covariance(data: &[Vec<f64>], n: usize, k: usize) -> DMatrix<f64> {
    let means: Vec<f64> = (0..k)
        .map(|j| data.iter().map(|r| r[j]).sum::<f64>() / n as f64)
        .collect();
    DMatrix::from_fn(k, k, |i, j| {
        data.iter()
            .map(|r| (r[i] - means[i]) * (r[j] - means[j]))
            .sum::<f64>()
            / (n - 1) as f64
    })
}

/// Orthonormal Helmert contrasts, k × (k − 1): columns orthogonal to 1 and to each other.
fn helmert(k: usize) -> DMatrix<f64> {
    DMatrix::from_fn(k, k - 1, |i, j| {
        let norm = (((j + 1) * (j + 2)) as f64).sqrt();
        match i {
            i if i <= j => 1.0 / norm,
            i if i == j + 1 => -((j + 1) as f64) / norm,
            _ => 0.0,
        }
    })
}

/// Greenhouse–Geisser ε, Mauchly's W and its p from the orthonormalised covariance.
fn sphericity(data: &[Vec<f64>], n: usize, k: usize) -> Result<(f64, f64, f64)> {
    if k == 2 {
        return Ok((1.0, 1.0, 1.0));
    }
    let c = helmert(k);
    let m = c.transpose() * covariance(data, n, k) * &c;
    let d = (k - 1) as f64;
    let tr = m.trace();
    let eps = tr * tr / (d * (&m * &m).trace());
    let w = m.determinant() / (tr / d).powf(d);
    // pingouin / Mauchly (1940): χ² = −ln W · (1 − (2d² + d + 2)/(6d(n−1))) · (n − 1), d(d+1)/2 − 1 df.
    let ddof = (n - 1) as f64;
    let chi2 = -w.ln() * (1.0 - (2.0 * d * d + d + 2.0) / (6.0 * d * ddof)) * ddof;
    let dof = d * (d + 1.0) / 2.0 - 1.0;
    let p = ChiSquared::new(dof)
        .map_err(|e| StatsError::InvalidParameter {
            what: "χ² distribution",
            detail: e.to_string(),
        })?
        .sf(chi2);
    Ok((eps, w, p))
}

/// One-way repeated-measures ANOVA on wide data (rows = subjects, columns = conditions).
/// Missing-data policy: complete cases only — a NaN anywhere is an error; drop the subject first.
pub fn rm_one_way(data: &[Vec<f64>]) -> Result<RmAnova> {
    let (n, k) = check_wide(data)?;
    let grand = data.iter().flatten().sum::<f64>() / (n * k) as f64;
    let col_mean = |j: usize| data.iter().map(|r| r[j]).sum::<f64>() / n as f64;
    let ss_conditions = (0..k)
        .map(|j| n as f64 * (col_mean(j) - grand).powi(2))
        .sum::<f64>();
    let ss_subjects = data
        .iter()
        .map(|r| k as f64 * (r.iter().sum::<f64>() / k as f64 - grand).powi(2))
        .sum::<f64>();
    let ss_total = data
        .iter()
        .flatten()
        .map(|v| (v - grand).powi(2))
        .sum::<f64>();
    let ss_error = ss_total - ss_conditions - ss_subjects;
    if ss_error <= 0.0 {
        return Err(StatsError::ZeroVariance {
            what: "RM ANOVA (error term)",
        });
    }
    let (df1, df2) = ((k - 1) as f64, ((k - 1) * (n - 1)) as f64);
    let f = (ss_conditions / df1) / (ss_error / df2);
    let (eps_gg, mauchly_w, mauchly_p) = sphericity(data, n, k)?;
    Ok(RmAnova {
        ss_conditions,
        ss_subjects,
        ss_error,
        df1,
        df2,
        f,
        p_unc: f_sf(f, df1, df2)?,
        partial_eta2: ss_conditions / (ss_conditions + ss_error),
        eps_gg,
        p_gg: f_sf(f, eps_gg * df1, eps_gg * df2)?,
        mauchly_w,
        mauchly_p,
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::analysis::stats::test_support::*;
    use crate::analysis::stats::ttest::student_t;

    #[test]
    fn one_way_matches_scipy_and_pingouin() {
        let r_ = one_way(&[&G1, &G2, &G3]).unwrap();
        // scipy.stats.f_oneway (F, p); pingouin.anova detailed (SS, np2)
        assert_close("F", r_.f, r("anova_oneway/F"));
        assert_close("p", r_.p, r("anova_oneway/p"));
        assert_close("df_between", r_.df_between, r("anova_oneway/df_between"));
        assert_close("df_within", r_.df_within, r("anova_oneway/df_within"));
        assert_close("SS_between", r_.ss_between, r("anova_oneway/SS_between"));
        assert_close("SS_within", r_.ss_within, r("anova_oneway/SS_within"));
        assert_close("eta2", r_.eta2, r("anova_oneway/eta2"));
    }

    #[test]
    fn two_groups_f_equals_student_t_squared() {
        // Identity: with two groups, one-way ANOVA's F = t² and the p-values coincide.
        let a = one_way(&[&A, &B]).unwrap();
        let t = student_t(&A, &B, 0.95).unwrap();
        assert_close_tol("F = t²", a.f, t.t * t.t, IDENTITY_TOL);
        assert_close_tol("p", a.p, t.p_two_sided, 1e-8);
    }

    fn check_table(table: &AnovaTable, key: &str) {
        // statsmodels anova_lm(ols("y ~ C(A, Sum) * C(B, Sum)"), typ=…)
        for term in ["A", "B", "A:B", "Residual"] {
            let row = table.row(term).unwrap();
            let base = format!("anova_twoway_unbalanced/{key}/{term}");
            assert_close(&format!("{base} SS"), row.ss, r(&format!("{base}/SS")));
            assert_close(&format!("{base} df"), row.df, r(&format!("{base}/df")));
            if term != "Residual" {
                assert_close(
                    &format!("{base} F"),
                    row.f.unwrap(),
                    r(&format!("{base}/F")),
                );
                assert_close(
                    &format!("{base} p"),
                    row.p.unwrap(),
                    r(&format!("{base}/p")),
                );
            }
        }
    }

    #[test]
    fn two_way_types_match_statsmodels() {
        check_table(&two_way(&TW_A, &TW_B, &TW_Y, SsType::I).unwrap(), "typ1");
        check_table(&two_way(&TW_A, &TW_B, &TW_Y, SsType::II).unwrap(), "typ2");
        check_table(&two_way(&TW_A, &TW_B, &TW_Y, SsType::III).unwrap(), "typ3");
    }

    #[test]
    fn type_three_with_treatment_coding_is_the_known_wrong_answer() {
        // statsmodels anova_lm(ols("y ~ C(A) * C(B)"), typ=3): SS(A) = 2.667 tests A at B's
        // reference level only — the pitfall sum-to-zero contrasts avoid.
        let t = two_way_observations(&TW_A, &TW_B, &TW_Y, SsType::III, Coding::Treatment).unwrap();
        let cells = cells_of(&TW_A, &TW_B, &TW_Y);
        let t_cells = two_way_cells_coded(&cells, SsType::III, Coding::Treatment).unwrap();
        assert_close_tol("cell path, treatment-coded SS(A)", t_cells.row("A").unwrap().ss, t.row("A").unwrap().ss, IDENTITY_TOL);
        let wrong = r("anova_twoway_unbalanced/typ3_with_treatment_coding_WRONG/A_SS");
        assert_close("treatment-coded SS(A)", t.row("A").unwrap().ss, wrong);
        let right = two_way(&TW_A, &TW_B, &TW_Y, SsType::III).unwrap();
        assert!((right.row("A").unwrap().ss - wrong).abs() > 1.0);
    }

    fn cells_of(a: &[&str], b: &[&str], y: &[f64]) -> TwoWayCells {
        let mut cells = TwoWayCells::new();
        for ((a, b), y) in a.iter().zip(b).zip(y) {
            cells.push(a, b, *y);
        }
        cells
    }

    #[test]
    fn cell_path_equals_observation_path() {
        // Identity: RSS = SS_within + weighted RSS on cell means, for every model of the layout.
        let cells = cells_of(&TW_A, &TW_B, &TW_Y);
        assert_eq!(cells.n(), TW_Y.len());
        for ty in [SsType::I, SsType::II, SsType::III] {
            let obs = two_way_observations(&TW_A, &TW_B, &TW_Y, ty, Coding::Sum).unwrap();
            let fast = two_way_cells(&cells, ty).unwrap();
            assert_eq!(obs.rows.len(), fast.rows.len());
            for (o, f) in obs.rows.iter().zip(&fast.rows) {
                let what = format!("{ty:?} {}", o.term);
                assert_eq!(o.term, f.term);
                assert_eq!(o.df, f.df, "{what} df");
                assert_close_tol(&format!("{what} SS"), f.ss, o.ss, IDENTITY_TOL);
                for (name, x, y) in [("F", f.f, o.f), ("p", f.p, o.p), ("partial eta2", f.partial_eta2, o.partial_eta2)] {
                    assert_eq!(x.is_some(), y.is_some(), "{what} {name}");
                    if let (Some(x), Some(y)) = (x, y) {
                        assert_close_tol(&format!("{what} {name}"), x, y, IDENTITY_TOL);
                    }
                }
            }
        }
        // Observations pushed in another order, and levels first seen in another order, give
        // the same table (levels are sorted before the design is built).
        let mut order: Vec<usize> = (0..TW_Y.len()).collect();
        order.reverse();
        let mut shuffled = TwoWayCells::new();
        for &i in &order {
            shuffled.push(TW_A[i], TW_B[i], TW_Y[i]);
        }
        let (x, y) = (two_way_cells(&shuffled, SsType::III).unwrap(), two_way_cells(&cells, SsType::III).unwrap());
        for (r1, r2) in x.rows.iter().zip(&y.rows) {
            assert_close_tol(&r1.term, r1.ss, r2.ss, IDENTITY_TOL);
        }
    }

    #[test]
    fn cell_path_rejects_non_finite_and_one_level() {
        let mut cells = cells_of(&TW_A, &TW_B, &TW_Y);
        cells.push("a1", "b1", f64::NAN);
        assert!(matches!(two_way_cells(&cells, SsType::II), Err(StatsError::NonFinite { index: 21, .. })));
        let one = cells_of(&["a", "a", "a"], &["x", "y", "y"], &[1.0, 2.0, 3.0]);
        assert!(matches!(two_way_cells(&one, SsType::II), Err(StatsError::InvalidParameter { .. })));
    }

    #[test]
    fn balanced_design_all_types_agree() {
        // Identity: on a balanced design Type I = II = III.
        let a: Vec<&str> = (0..12).map(|i| if i < 6 { "a1" } else { "a2" }).collect();
        let b: Vec<&str> = (0..12).map(|i| ["b1", "b2", "b3"][i % 3]).collect();
        let y = [3.1, 4.2, 5.0, 2.9, 4.8, 5.5, 4.0, 4.1, 7.2, 3.7, 5.0, 6.6];
        let t1 = two_way(&a, &b, &y, SsType::I).unwrap();
        for ty in [SsType::II, SsType::III] {
            let t = two_way(&a, &b, &y, ty).unwrap();
            for (r1, r2) in t1.rows.iter().zip(&t.rows) {
                assert_close_tol(&format!("{ty:?} {}", r1.term), r2.ss, r1.ss, IDENTITY_TOL);
            }
        }
        // and the terms plus residual add up to the total SS
        let m = y.iter().sum::<f64>() / 12.0;
        let total: f64 = y.iter().map(|v| (v - m).powi(2)).sum();
        assert_close_tol(
            "SS sum",
            t1.rows.iter().map(|r| r.ss).sum(),
            total,
            IDENTITY_TOL,
        );
    }

    #[test]
    fn two_way_rejects_empty_cell() {
        let a = ["a1", "a1", "a2", "a2", "a1"];
        let b = ["b1", "b2", "b1", "b1", "b1"];
        let y = [1.0, 2.0, 3.0, 4.0, 1.5];
        assert!(matches!(
            two_way(&a, &b, &y, SsType::III),
            Err(StatsError::RankDeficient { .. })
        ));
    }

    #[test]
    fn rm_anova_matches_pingouin() {
        let r_ = rm_one_way(&rm_wide()).unwrap();
        // pingouin.rm_anova(detailed=True, correction=True)
        assert_close("F", r_.f, r("rm_anova/F"));
        assert_close("df1", r_.df1, r("rm_anova/df1"));
        assert_close("df2", r_.df2, r("rm_anova/df2"));
        assert_close("p_unc", r_.p_unc, r("rm_anova/p_unc"));
        assert_close("p_GG", r_.p_gg, r("rm_anova/p_GG"));
        assert_close("eps_GG", r_.eps_gg, r("rm_anova/eps_GG"));
        assert_close("W", r_.mauchly_w, r("rm_anova/sphericity_W"));
        assert_close("W p", r_.mauchly_p, r("rm_anova/sphericity_p"));
    }

    #[test]
    fn rm_anova_two_conditions_equals_paired_t_squared() {
        // Identity: with two conditions, RM ANOVA F = paired t², ε = 1.
        let data: Vec<Vec<f64>> = PRE.iter().zip(&POST).map(|(a, b)| vec![*a, *b]).collect();
        let rm = rm_one_way(&data).unwrap();
        let t = crate::analysis::stats::ttest::paired_t(&PRE, &POST, 0.95).unwrap();
        assert_close_tol("F = t²", rm.f, t.t * t.t, IDENTITY_TOL);
        assert_eq!(rm.eps_gg, 1.0);
    }

    #[test]
    fn rm_anova_rejects_missing() {
        let mut d = rm_wide();
        d[2][1] = f64::NAN;
        assert!(matches!(rm_one_way(&d), Err(StatsError::NonFinite { .. })));
        d[2] = vec![1.0, 2.0];
        assert!(matches!(
            rm_one_way(&d),
            Err(StatsError::LengthMismatch { .. })
        ));
    }
}
