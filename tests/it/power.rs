//! `facslab power`: CI widths over sample sizes from repeated simulations, through the real CLI.

use std::path::Path;

use crate::cli::{facslab, facslab_ok, stderr};

/// The `item = mean` rows of one statistic in `power.csv`: (size, ci_width_mean, spread_width).
fn mean_rows(dir: &Path, out: &str, statistic: &str) -> Vec<(usize, f64, f64)> {
    let mut csv = csv::Reader::from_path(dir.join(out).join("power.csv")).unwrap();
    let header = csv.headers().unwrap().clone();
    let col = |name: &str| header.iter().position(|h| h == name).unwrap_or_else(|| panic!("{name} not in {header:?}"));
    let (size, stat, item, width, spread) = (col("size"), col("statistic"), col("item"), col("ci_width_mean"), col("spread_width"));
    csv.records()
        .map(Result::unwrap)
        .filter(|r| &r[stat] == statistic && &r[item] == "mean")
        .map(|r| (r[size].parse().unwrap(), r[width].parse().unwrap(), r[spread].parse().unwrap()))
        .collect()
}

#[test]
fn exp1_ci_widths_shrink_with_coders_and_agree_with_the_spread_of_simulations() {
    let dir = tempfile::tempdir().unwrap();
    facslab_ok(dir.path(), &["power", "--design", "exp1", "--sizes", "3,5,10,20", "--runs", "40", "--seed", "3", "-o", "p"]);
    for file in ["power.csv", "power.json", "power.png"] {
        assert!(dir.path().join("p").join(file).exists(), "{file} missing");
    }
    let rows = mean_rows(dir.path(), "p", "per-AU F1");
    assert_eq!(rows.iter().map(|r| r.0).collect::<Vec<_>>(), [3, 5, 10, 20]);
    for pair in rows.windows(2) {
        assert!(pair[1].1 < pair[0].1, "the CI width shrinks with more coders: {rows:?}");
        assert!(pair[1].2 < pair[0].2, "so does the spread over the runs: {rows:?}");
    }
    // The report's Jeffreys CI is calibrated at every size, 3 coders included (the delta-method
    // Wald interval it replaced was 28 % narrower than the spread at 3 coders: no width when every
    // coder was right).
    for &(size, width, spread) in &rows {
        assert!((width / spread - 1.0).abs() < 0.2, "{size} coders: mean CI width {width:.3} against spread {spread:.3}");
    }
}

#[test]
fn power_gives_the_same_bytes_for_the_same_seed() {
    let dir = tempfile::tempdir().unwrap();
    for (out, seed) in [("a", "7"), ("b", "7"), ("c", "8")] {
        facslab_ok(dir.path(), &["power", "--design", "exp1", "--sizes", "3,6", "--runs", "5", "--seed", seed, "-o", out]);
    }
    for file in ["power.csv", "power.json", "power.png"] {
        let read = |out: &str| std::fs::read(dir.path().join(out).join(file)).unwrap();
        assert_eq!(read("a"), read("b"), "{file} differs between two runs with one seed");
    }
    assert_ne!(std::fs::read(dir.path().join("a/power.csv")).unwrap(), std::fs::read(dir.path().join("c/power.csv")).unwrap());
}

#[test]
fn power_refuses_unbounded_work_and_says_which_bound() {
    let dir = tempfile::tempdir().unwrap();
    for (args, message) in [
        (&["--runs", "1"][..], "runs must be between 2 and 2000, got 1"),
        (&["--sizes", "1,5"][..], "each size must be between 2 and 500, got 1"),
        (&["--sizes", "500,500", "--runs", "1000"][..], "more than 400000"),
        (&["--accuracy", "1.5"][..], "--accuracy must be a probability"),
    ] {
        let mut all = vec!["power", "--design", "exp1", "-o", "p"];
        all.extend_from_slice(args);
        let out = facslab(dir.path(), &all);
        assert!(!out.status.success(), "{args:?} accepted");
        assert!(stderr(&out).contains(message), "{args:?}: {}", stderr(&out));
        assert!(!dir.path().join("p").exists(), "nothing written for {args:?}");
    }
    let help = facslab_ok(dir.path(), &["power", "--help"]);
    assert!(String::from_utf8_lossy(&help.stdout).contains("facslab power --design exp1 --sizes"));
}
