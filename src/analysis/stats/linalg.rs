//! Least squares for the linear-model ANOVA (thin wrapper over nalgebra's SVD).

use nalgebra::{DMatrix, DVector};

/// Relative singular-value cut-off for rank and pseudo-inverse.
const RANK_EPS: f64 = 1e-10;

/// Residual sum of squares and rank of the least-squares fit of `y` on the columns `cols` of `x`.
/// An empty column set gives RSS = Σy² and rank 0.
pub(crate) fn rss_and_rank(x: &DMatrix<f64>, y: &DVector<f64>, cols: &[usize]) -> (f64, usize) {
    if cols.is_empty() {
        return (y.norm_squared(), 0);
    }
    let sub = x.select_columns(cols);
    let svd = sub.clone().svd(true, true);
    let max_sv = svd.singular_values.max();
    let eps = RANK_EPS * max_sv.max(f64::MIN_POSITIVE);
    let rank = svd.rank(eps);
    let beta = svd.solve(y, eps).expect("U and V were computed");
    let resid = y - sub * beta;
    (resid.norm_squared(), rank)
}
