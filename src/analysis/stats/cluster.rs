//! Clustering with reproducible initialisation.
//!
//! - [`kmeans`]: Lloyd's algorithm from given initial centres (scikit-learn's `KMeans(init=…,
//!   n_init=1, algorithm="lloyd", tol=0)`): each iteration assigns every point to its nearest
//!   centre (squared Euclidean; ties → lowest centre index) and moves centres to the means;
//!   it stops when an iteration leaves the labels unchanged or after `max_iter`. `n_iter` counts
//!   the iterations run, including the one that detected convergence. An empty cluster keeps its
//!   previous centre. Inertia = Σ squared distances to the assigned centre.
//! - [`pam`]: k-medoids by the PAM SWAP phase from given initial medoids (the `kmedoids`
//!   package's `pam`): at each step apply the single medoid/non-medoid swap that lowers the total
//!   distance most; stop when no swap lowers it. Labels index into `medoids` (nearest medoid, ties
//!   → lowest index); loss = Σ distances to the nearest medoid.
//! - [`pam_build`]: PAM's deterministic BUILD initialisation (Kaufman & Rousseeuw 1990): first
//!   the point with the smallest total distance, then repeatedly the point that lowers the loss
//!   most (ties → lowest index), as scikit-learn-extra's `KMedoids(init="build")`.

use super::error::check_finite;
use super::{Result, StatsError};

/// Result of k-means.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct KMeans {
    pub labels: Vec<usize>,
    pub centers: Vec<Vec<f64>>,
    /// Σ squared Euclidean distances of points to their centres.
    pub inertia: f64,
    pub n_iter: usize,
}

/// Result of PAM k-medoids.
#[derive(Debug, Clone, PartialEq, serde::Serialize)]
pub struct Pam {
    /// Indices of the medoid points, in the order of the initial medoids they replaced.
    pub medoids: Vec<usize>,
    pub labels: Vec<usize>,
    /// Σ distances of points to their nearest medoid.
    pub loss: f64,
    /// Number of swaps applied.
    pub n_swaps: usize,
}

fn sq_dist(a: &[f64], b: &[f64]) -> f64 {
    a.iter().zip(b).map(|(x, y)| (x - y).powi(2)).sum()
}

/// Index of the minimum (first on ties).
fn argmin(values: impl Iterator<Item = f64>) -> (usize, f64) {
    values.enumerate().fold(
        (0, f64::INFINITY),
        |best, (i, v)| if v < best.1 { (i, v) } else { best },
    )
}

/// Checks a non-empty point set of one dimension with finite coordinates.
fn check_points(what: &'static str, points: &[Vec<f64>]) -> Result<usize> {
    let first = points.first().ok_or(StatsError::TooFewObservations {
        what,
        needed: 1,
        got: 0,
    })?;
    let dim = first.len();
    for p in points {
        super::error::check_same_len(what, p.len(), dim)?;
        check_finite(what, p)?;
    }
    Ok(dim)
}

fn assign(points: &[Vec<f64>], centers: &[Vec<f64>]) -> Vec<usize> {
    points
        .iter()
        .map(|p| argmin(centers.iter().map(|c| sq_dist(p, c))).0)
        .collect()
}

fn update_centers(points: &[Vec<f64>], labels: &[usize], centers: &mut [Vec<f64>]) {
    for (c, center) in centers.iter_mut().enumerate() {
        let members: Vec<&Vec<f64>> = points
            .iter()
            .zip(labels)
            .filter(|(_, l)| **l == c)
            .map(|(p, _)| p)
            .collect();
        if members.is_empty() {
            continue;
        }
        for (d, v) in center.iter_mut().enumerate() {
            *v = members.iter().map(|p| p[d]).sum::<f64>() / members.len() as f64;
        }
    }
}

/// k-means (Lloyd) from `initial_centers` (see the module doc).
pub fn kmeans(
    points: &[Vec<f64>],
    initial_centers: &[Vec<f64>],
    max_iter: usize,
) -> Result<KMeans> {
    let dim = check_points("k-means points", points)?;
    if check_points("k-means initial centres", initial_centers)? != dim {
        return Err(StatsError::LengthMismatch {
            what: "k-means centre dimension",
            left: initial_centers[0].len(),
            right: dim,
        });
    }
    if max_iter == 0 {
        return Err(StatsError::InvalidParameter {
            what: "k-means",
            detail: "max_iter = 0".into(),
        });
    }
    let mut centers = initial_centers.to_vec();
    let mut labels = vec![usize::MAX; points.len()];
    let mut n_iter = 0;
    while n_iter < max_iter {
        n_iter += 1;
        let new_labels = assign(points, &centers);
        update_centers(points, &new_labels, &mut centers);
        let converged = new_labels == labels;
        labels = new_labels;
        if converged {
            break;
        }
    }
    let labels = assign(points, &centers);
    let inertia = points
        .iter()
        .zip(&labels)
        .map(|(p, &l)| sq_dist(p, &centers[l]))
        .sum();
    Ok(KMeans {
        labels,
        centers,
        inertia,
        n_iter,
    })
}

/// k-means starting from the given rows of `points` as centres.
pub fn kmeans_from_rows(
    points: &[Vec<f64>],
    init_rows: &[usize],
    max_iter: usize,
) -> Result<KMeans> {
    let init = rows(points, init_rows)?;
    kmeans(points, &init, max_iter)
}

fn rows(points: &[Vec<f64>], idx: &[usize]) -> Result<Vec<Vec<f64>>> {
    idx.iter()
        .map(|&i| {
            points
                .get(i)
                .cloned()
                .ok_or_else(|| StatsError::InvalidParameter {
                    what: "initial rows",
                    detail: format!("row {i} out of range (n = {})", points.len()),
                })
        })
        .collect()
}

/// Euclidean distance matrix of `points`.
pub fn euclidean_distances(points: &[Vec<f64>]) -> Result<Vec<Vec<f64>>> {
    check_points("distance matrix points", points)?;
    Ok(points
        .iter()
        .map(|a| points.iter().map(|b| sq_dist(a, b).sqrt()).collect())
        .collect())
}

/// Total distance of every point to its nearest medoid.
fn pam_loss(dist: &[Vec<f64>], medoids: &[usize]) -> f64 {
    dist.iter()
        .map(|row| {
            medoids
                .iter()
                .map(|&m| row[m])
                .fold(f64::INFINITY, f64::min)
        })
        .sum()
}

/// Checks a square, finite distance matrix and distinct, in-range initial medoids.
fn check_pam(dist: &[Vec<f64>], init: &[usize]) -> Result<()> {
    let n = dist.len();
    for row in dist {
        super::error::check_same_len("PAM distance matrix (square)", row.len(), n)?;
        check_finite("PAM distance matrix", row)?;
    }
    let mut sorted = init.to_vec();
    sorted.sort_unstable();
    sorted.dedup();
    if init.is_empty() || sorted.len() != init.len() || sorted.last().is_some_and(|&m| m >= n) {
        return Err(StatsError::InvalidParameter {
            what: "PAM",
            detail: format!("initial medoids {init:?} for n = {n}"),
        });
    }
    Ok(())
}

/// PAM k-medoids on a distance matrix from `initial_medoids` (see the module doc).
pub fn pam(dist: &[Vec<f64>], initial_medoids: &[usize], max_swaps: usize) -> Result<Pam> {
    check_pam(dist, initial_medoids)?;
    let mut medoids = initial_medoids.to_vec();
    let mut loss = pam_loss(dist, &medoids);
    let mut n_swaps = 0;
    while n_swaps < max_swaps {
        let mut best = (loss, None);
        for slot in 0..medoids.len() {
            for cand in (0..dist.len()).filter(|c| !medoids.contains(c)) {
                let mut trial = medoids.clone();
                trial[slot] = cand;
                let l = pam_loss(dist, &trial);
                if l < best.0 {
                    best = (l, Some((slot, cand)));
                }
            }
        }
        match best {
            (l, Some((slot, cand))) if l < loss => {
                medoids[slot] = cand;
                loss = l;
                n_swaps += 1;
            }
            _ => break,
        }
    }
    let labels = dist
        .iter()
        .map(|row| argmin(medoids.iter().map(|&m| row[m])).0)
        .collect();
    Ok(Pam {
        medoids,
        labels,
        loss,
        n_swaps,
    })
}

/// PAM BUILD: `k` deterministic initial medoids for [`pam`] (see the module doc).
pub fn pam_build(dist: &[Vec<f64>], k: usize) -> Result<Vec<usize>> {
    let n = dist.len();
    if k == 0 || k > n {
        return Err(StatsError::InvalidParameter {
            what: "PAM BUILD",
            detail: format!("k = {k} for n = {n}"),
        });
    }
    check_pam(dist, &[0])?;
    let first = argmin(dist.iter().map(|row| row.iter().sum::<f64>())).0;
    let mut medoids = vec![first];
    let mut nearest: Vec<f64> = dist.iter().map(|row| row[first]).collect();
    while medoids.len() < k {
        let gain = |c: usize| -> f64 {
            if medoids.contains(&c) {
                return f64::NEG_INFINITY;
            }
            dist.iter()
                .zip(&nearest)
                .map(|(row, &d)| (d - row[c]).max(0.0))
                .sum()
        };
        let best = argmin((0..n).map(|c| -gain(c))).0;
        medoids.push(best);
        for (d, row) in nearest.iter_mut().zip(dist) {
            *d = d.min(row[best]);
        }
    }
    Ok(medoids)
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::analysis::stats::test_support::*;

    fn usizes(path: &str) -> Vec<usize> {
        serde_json::from_value(rv(path).clone()).unwrap()
    }

    #[test]
    fn kmeans_matches_sklearn() {
        // sklearn KMeans(init=PTS[[0, 4, 8]], n_init=1, algorithm="lloyd", tol=0), cross-checked
        // against scipy kmeans2 in the script
        let km = kmeans_from_rows(&pts(), &usizes("kmeans/init_rows"), 300).unwrap();
        assert_eq!(km.labels, usizes("kmeans/labels"));
        let centers: Vec<Vec<f64>> = serde_json::from_value(rv("kmeans/centers").clone()).unwrap();
        for (got, exp) in km.centers.iter().zip(&centers) {
            for (g, e) in got.iter().zip(exp) {
                assert_close("center", *g, *e);
            }
        }
        assert_close("inertia", km.inertia, r("kmeans/inertia_sum_sq"));
        assert_eq!(km.n_iter as f64, r("kmeans/n_iter"));
    }

    #[test]
    fn pam_matches_kmedoids() {
        // kmedoids.pam on the Euclidean distance matrix from medoids [0, 4, 8]
        // (agrees with kmedoids.fasterpam and scikit-learn-extra's PAM in the script)
        let d = euclidean_distances(&pts()).unwrap();
        let res = pam(&d, &[0, 4, 8], 100).unwrap();
        let mut medoids = res.medoids.clone();
        medoids.sort_unstable();
        assert_eq!(medoids, usizes("kmedoids/pam_medoids"));
        assert_close("loss", res.loss, r("kmedoids/pam_loss_sum_dist"));
        assert_eq!(res.labels, usizes("kmedoids/labels"));
    }

    #[test]
    fn build_then_swap_matches_scikit_learn_extra() {
        // scikit-learn-extra KMedoids(method="pam", init="build") medoids: [0, 4, 8]
        let d = euclidean_distances(&pts()).unwrap();
        let init = pam_build(&d, 3).unwrap();
        let mut medoids = pam(&d, &init, 100).unwrap().medoids;
        medoids.sort_unstable();
        assert_eq!(medoids, usizes("kmedoids/sklearn_extra_pam_medoids"));
        assert!(pam_build(&d, 14).is_err());
    }

    #[test]
    fn pam_recovers_from_a_bad_start() {
        // From a poor start (three medoids in one blob) PAM must not end worse than the good start,
        // and each swap strictly lowers the loss.
        let d = euclidean_distances(&pts()).unwrap();
        let bad = pam(&d, &[0, 1, 2], 100).unwrap();
        assert!(bad.n_swaps >= 2);
        assert!(bad.loss <= r("kmedoids/pam_loss_sum_dist") + 1e-12);
    }

    #[test]
    fn kmeans_identities_and_errors() {
        // Inertia equals the sum over clusters of within-cluster squared deviations.
        let km = kmeans_from_rows(&pts(), &[0, 4, 8], 300).unwrap();
        let p = pts();
        let by_cluster: f64 = (0..3)
            .map(|c| {
                let members: Vec<&Vec<f64>> = p
                    .iter()
                    .zip(&km.labels)
                    .filter(|(_, l)| **l == c)
                    .map(|(x, _)| x)
                    .collect();
                (0..2)
                    .map(|d| {
                        let m = members.iter().map(|x| x[d]).sum::<f64>() / members.len() as f64;
                        members.iter().map(|x| (x[d] - m).powi(2)).sum::<f64>()
                    })
                    .sum::<f64>()
            })
            .sum();
        assert_close_tol("inertia", km.inertia, by_cluster, IDENTITY_TOL);
        assert!(kmeans_from_rows(&pts(), &[0, 99], 10).is_err());
        assert!(matches!(
            kmeans(&[], &[vec![0.0]], 10),
            Err(StatsError::TooFewObservations { .. })
        ));
        assert!(pam(&[vec![0.0, 1.0], vec![1.0, 0.0]], &[0, 0], 10).is_err());
    }
}
