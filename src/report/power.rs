//! The files of a power analysis (`facslab power`): `power.json` (the [`PowerTable`]
//! serialised), `power.csv` (one row per size × statistic × item, through the report's table
//! model) and `power.png` (CI width against size beside the spread of the estimates, and the
//! t-test's power).
//!
//! In: a [`PowerTable`]. Out: (file name, bytes). **Invariant:** same table, same bytes.

use super::ReportError;
use super::table::{Cell, Row, Table};
use crate::analysis::power::PowerTable;

/// The CSV table: every row, numbers unrounded.
fn table(power: &PowerTable) -> Table {
    let rows = power
        .rows
        .iter()
        .map(|r| {
            let lead = [Cell::count(r.size), Cell::text(&r.statistic), Cell::text(&r.item), Cell::count(r.runs), Cell::num(r.estimate_mean, 3), Cell::opt_or_empty(r.ci_width_mean, 3)];
            let spread = [r.spread_low, r.spread_high, r.spread_width].map(|v| Cell::num(v, 3));
            Row::new(lead.into_iter().chain(spread).chain([Cell::opt_or_empty(r.power, 3)]).collect())
        })
        .collect();
    let fields = ["size", "statistic", "item", "runs", "estimate_mean", "ci_width_mean", "spread_low", "spread_high", "spread_width", "power"];
    Table::new("power.csv", &fields, rows)
}

/// `power.json`, `power.csv` and `power.png`.
pub fn files(power: &PowerTable) -> Result<Vec<(String, Vec<u8>)>, ReportError> {
    let json = serde_json::to_string_pretty(power).map_err(|e| ReportError::Output { path: "power.json".into(), detail: e.to_string() })?;
    Ok(vec![("power.json".into(), json.into_bytes()), ("power.csv".into(), table(power).csv()?), ("power.png".into(), super::plots::power(power)?)])
}
