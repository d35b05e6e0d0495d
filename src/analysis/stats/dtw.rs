//! Dynamic time warping between two 1-D series (e.g. an AU intensity track over frames).
//!
//! There is no single DTW convention, so both are explicit:
//! - [`DtwCost::SqrtOfSquared`]: √(Σ (xᵢ − yⱼ)² along the optimal path) — dtaidistance's
//!   `distance` and tslearn's `dtw`;
//! - [`DtwCost::SumAbs`]: Σ |xᵢ − yⱼ| along the optimal path — the textbook / fastdtw form.
//!
//! Recurrence: D[i, j] = cost(xᵢ, yⱼ) + min(D[i−1, j−1], D[i−1, j], D[i, j−1]).
//! The path runs from (0, 0) to (n−1, m−1); ties when backtracking prefer the diagonal, then
//! (i−1, j), then (i, j−1), as dtaidistance and tslearn do.
//!
//! Sakoe–Chiba band of radius w ([`Band`]):
//! - [`BandShape::LengthAdjusted`]: for n ≤ m, cell (i, j) is allowed when
//!   −w ≤ j − i ≤ (m − n) + w (symmetrically for n > m) — the band is widened by the length
//!   difference, as tslearn's `sakoe_chiba_radius = w` and dtaidistance's `window = w + 1`;
//! - [`BandShape::Naive`]: |i − j| ≤ w; with unequal lengths and w < |n − m| no path exists,
//!   which is reported as [`StatsError::NoPathInBand`].

use super::error::check_finite;
use super::{Result, StatsError};

/// Local cost and how the total is reported.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub enum DtwCost {
    /// √ of the summed squared differences (dtaidistance, tslearn).
    SqrtOfSquared,
    /// Sum of absolute differences.
    SumAbs,
}

/// Shape of the Sakoe–Chiba band on series of unequal length.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub enum BandShape {
    /// |i − j| ≤ radius.
    Naive,
    /// Widened by the length difference (tslearn / dtaidistance).
    LengthAdjusted,
}

/// Optional global constraint.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize)]
pub enum Band {
    None,
    SakoeChiba { radius: usize, shape: BandShape },
}

/// DTW distance and the optimal warping path (pairs of indices into x and y).
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Dtw {
    pub distance: f64,
    pub path: Vec<(usize, usize)>,
}

/// Whether cell (i, j) lies inside the band for lengths n, m.
fn allowed(i: usize, j: usize, n: usize, m: usize, band: Band) -> bool {
    let (i, j) = (i as i64, j as i64);
    match band {
        Band::None => true,
        Band::SakoeChiba { radius, shape } => {
            let w = radius as i64;
            match shape {
                BandShape::Naive => (i - j).abs() <= w,
                BandShape::LengthAdjusted if n <= m => (-w..=(m - n) as i64 + w).contains(&(j - i)),
                BandShape::LengthAdjusted => (-w..=(n - m) as i64 + w).contains(&(i - j)),
            }
        }
    }
}

/// Accumulated cost matrix, (n+1) × (m+1) with D[0][0] = 0 and ∞ elsewhere on the border.
fn accumulate(x: &[f64], y: &[f64], cost: DtwCost, band: Band) -> Vec<Vec<f64>> {
    let (n, m) = (x.len(), y.len());
    let mut d = vec![vec![f64::INFINITY; m + 1]; n + 1];
    d[0][0] = 0.0;
    for i in 1..=n {
        for j in 1..=m {
            if !allowed(i - 1, j - 1, n, m, band) {
                continue;
            }
            let diff = x[i - 1] - y[j - 1];
            let local = match cost {
                DtwCost::SqrtOfSquared => diff * diff,
                DtwCost::SumAbs => diff.abs(),
            };
            d[i][j] = local + d[i - 1][j - 1].min(d[i - 1][j]).min(d[i][j - 1]);
        }
    }
    d
}

/// Backtracks the optimal path through the accumulated matrix (diagonal first on ties).
fn backtrack(d: &[Vec<f64>]) -> Vec<(usize, usize)> {
    let (mut i, mut j) = (d.len() - 1, d[0].len() - 1);
    let mut path = vec![(i - 1, j - 1)];
    while (i, j) != (1, 1) {
        let steps = [(i - 1, j - 1), (i - 1, j), (i, j - 1)];
        let (bi, bj) = steps
            .into_iter()
            .filter(|&(a, b)| a >= 1 && b >= 1)
            .fold(None, |best: Option<(usize, usize)>, s| match best {
                Some(b) if d[b.0][b.1] <= d[s.0][s.1] => Some(b),
                _ => Some(s),
            })
            .expect("a finite cell always has a finite predecessor");
        (i, j) = (bi, bj);
        path.push((i - 1, j - 1));
    }
    path.reverse();
    path
}

/// DTW distance and path between `x` and `y` (see the module doc for the conventions).
pub fn dtw(x: &[f64], y: &[f64], cost: DtwCost, band: Band) -> Result<Dtw> {
    for (what, s) in [("DTW series x", x), ("DTW series y", y)] {
        super::error::check_len(what, s, 1)?;
        check_finite(what, s)?;
    }
    let d = accumulate(x, y, cost, band);
    let total = d[x.len()][y.len()];
    if !total.is_finite() {
        let radius = match band {
            Band::SakoeChiba { radius, .. } => radius,
            Band::None => 0,
        };
        return Err(StatsError::NoPathInBand { radius });
    }
    let distance = match cost {
        DtwCost::SqrtOfSquared => total.sqrt(),
        DtwCost::SumAbs => total,
    };
    Ok(Dtw {
        distance,
        path: backtrack(&d),
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::analysis::stats::test_support::*;

    fn band(radius: usize, shape: BandShape) -> Band {
        Band::SakoeChiba { radius, shape }
    }

    #[test]
    fn both_conventions_match_references() {
        // dtaidistance.dtw.distance and tslearn.metrics.dtw (√ of squared)
        let sq = dtw(&S1, &S2, DtwCost::SqrtOfSquared, Band::None).unwrap();
        assert_close(
            "dtaidistance",
            sq.distance,
            r("dtw/dtaidistance_sqrt_of_squared"),
        );
        assert_close("tslearn", sq.distance, r("dtw/tslearn_sqrt_of_squared"));
        assert_close(
            "DP squared",
            sq.distance.powi(2),
            r("dtw/dp_squared_cost_sum"),
        );
        // textbook DP with |·| cost (and fastdtw radius 1, exact on this input)
        let abs = dtw(&S1, &S2, DtwCost::SumAbs, Band::None).unwrap();
        assert_close("DP abs", abs.distance, r("dtw/dp_abs_cost_sum"));
        assert_close("fastdtw", abs.distance, r("dtw/fastdtw_abs_radius1"));
    }

    #[test]
    fn path_matches_dtaidistance_and_tslearn() {
        // dtaidistance.dtw.warping_path and tslearn.metrics.dtw_path
        let path = dtw(&S1, &S2, DtwCost::SqrtOfSquared, Band::None)
            .unwrap()
            .path;
        for key in ["dtw/path_dtaidistance", "dtw/path_tslearn"] {
            let expected: Vec<(usize, usize)> =
                serde_json::from_value::<Vec<[usize; 2]>>(rv(key).clone())
                    .unwrap()
                    .into_iter()
                    .map(|[a, b]| (a, b))
                    .collect();
            assert_eq!(path, expected, "{key}");
        }
    }

    #[test]
    fn equal_length_band_matches_references() {
        // textbook DP with |i − j| ≤ w = dtaidistance(window = w + 1) = tslearn(radius = w)
        for w in 0..4 {
            let expected = r(&format!("dtw/band_equal_length/sqrt_of_squared/w{w}"));
            for shape in [BandShape::Naive, BandShape::LengthAdjusted] {
                let got = dtw(&S1, &S4, DtwCost::SqrtOfSquared, band(w, shape))
                    .unwrap()
                    .distance;
                assert_close(&format!("w{w} {shape:?}"), got, expected);
            }
        }
    }

    #[test]
    fn unequal_length_band_conventions_differ() {
        for w in 0..3 {
            let base = format!("dtw/band_unequal_length/w{w}");
            // dtaidistance(window = w + 1) and tslearn(sakoe_chiba_radius = w)
            let adj = dtw(
                &S1,
                &S5,
                DtwCost::SqrtOfSquared,
                band(w, BandShape::LengthAdjusted),
            )
            .unwrap();
            assert_close(
                &format!("{base} dtaidistance"),
                adj.distance,
                r(&format!("{base}/dtaidistance_window_w_plus_1")),
            );
            assert_close(
                &format!("{base} tslearn"),
                adj.distance,
                r(&format!("{base}/tslearn_radius_w")),
            );
            // textbook DP with naive |i − j| ≤ w: null (∞) in the reference for w < 2
            let naive = dtw(&S1, &S5, DtwCost::SqrtOfSquared, band(w, BandShape::Naive));
            match rv(&format!("{base}/naive_abs_i_minus_j")).as_f64() {
                Some(v) => assert_close(&format!("{base} naive"), naive.unwrap().distance, v),
                None => assert_eq!(naive, Err(StatsError::NoPathInBand { radius: w })),
            }
        }
        // The band shape is symmetric in the argument order.
        let ab = dtw(
            &S1,
            &S5,
            DtwCost::SqrtOfSquared,
            band(1, BandShape::LengthAdjusted),
        )
        .unwrap();
        let ba = dtw(
            &S5,
            &S1,
            DtwCost::SqrtOfSquared,
            band(1, BandShape::LengthAdjusted),
        )
        .unwrap();
        assert_close_tol("symmetric", ab.distance, ba.distance, IDENTITY_TOL);
    }

    #[test]
    fn identities() {
        // Identical series: distance 0 along the diagonal; a wide band changes nothing.
        let same = dtw(&S1, &S1, DtwCost::SumAbs, Band::None).unwrap();
        assert_eq!(same.distance, 0.0);
        assert!(same.path.iter().all(|(i, j)| i == j));
        let wide = dtw(&S1, &S2, DtwCost::SqrtOfSquared, band(20, BandShape::Naive)).unwrap();
        assert_close_tol(
            "wide band",
            wide.distance,
            r("dtw/dtaidistance_sqrt_of_squared"),
            IDENTITY_TOL,
        );
        assert!(matches!(
            dtw(&[], &S1, DtwCost::SumAbs, Band::None),
            Err(StatsError::TooFewObservations { .. })
        ));
    }
}
