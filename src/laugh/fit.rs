//! Fitting a laugh type's curves from several takes: DTW between takes per controller (the
//! seed's Table 3), a prototype take by k-medoids, and its AU curves.
//!
//! In: landmark tracks (one per take) of one laugh type, and [`FitOptions`]. Stages:
//! 1. each take → FP1-FP15 → C1-C17 by Eq. 1 (`params.rs`), with the neutral from its own
//!    first frames or from a given neutral track;
//! 2. per controller, the DTW distance between every pair of takes (`stats::dtw`, Sakoe-Chiba
//!    band, the distance convention named) → [`ControllerTable`]: the matrix and, per take, the
//!    mean and sample sd (n − 1) of its distances to the others, as the seed's Table 3;
//! 3. the take distance = the sum over controllers of their DTW distances; the prototype is the
//!    medoid of k-medoids with k = 1 (`stats::cluster::pam_build` then `pam`);
//! 4. the prototype's controllers → AU tracks (`params::to_curves`), with a [`FitReport`].
//!
//! Out: [`Curves`] whose `fit` field holds the report. Invariant: the report names the distance
//! convention, band, ε and neutral used, so a Table 3 can be read back with its conventions.

use crate::analysis::stats::cluster::{pam, pam_build};
use crate::analysis::stats::dtw::{dtw, Band, BandShape, DtwCost};
use crate::analysis::stats::StatsError;
use crate::laugh::curves::Curves;
use crate::laugh::landmarks::{LandmarkTrack, TrackError};
use crate::laugh::params::{self, Epsilon, ParamsError, CONTROLLERS};

/// The DTW distance convention, as named on the command line and in the report.
#[derive(Debug, Clone, Copy, PartialEq, Eq, serde::Serialize, serde::Deserialize, clap::ValueEnum)]
#[serde(rename_all = "kebab-case")]
pub enum Distance {
    /// √(Σ (xᵢ − yⱼ)²) along the optimal path (dtaidistance, tslearn).
    SqrtSquared,
    /// Σ |xᵢ − yⱼ| along the optimal path (textbook, fastdtw).
    SumAbs,
}

impl Distance {
    pub fn cost(self) -> DtwCost {
        match self {
            Distance::SqrtSquared => DtwCost::SqrtOfSquared,
            Distance::SumAbs => DtwCost::SumAbs,
        }
    }
}

/// Where the neutral FP₀ of Eq. 1 comes from.
#[derive(Debug, Clone, PartialEq)]
pub enum NeutralSource {
    /// The mean of each take's own first N frames.
    FirstFrames(usize),
    /// The mean of every frame of a neutral track (one face at rest).
    Track(LandmarkTrack),
}

/// Choices of the fit.
#[derive(Debug, Clone, PartialEq)]
pub struct FitOptions {
    pub laugh_type: String,
    pub fps: u32,
    pub epsilon: Epsilon,
    pub neutral: NeutralSource,
    /// Sakoe-Chiba radius in frames (the length-adjusted band of tslearn / dtaidistance).
    pub band: usize,
    pub distance: Distance,
}

/// One controller's part of Table 3.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct ControllerTable {
    pub controller: String,
    pub name: String,
    /// DTW distance between takes i and j (0 on the diagonal).
    pub distances: Vec<Vec<f64>>,
    /// Per take, the mean of its distances to the other takes (None with one take).
    pub mean: Vec<Option<f64>>,
    /// Per take, their sample sd (n − 1; None with fewer than three takes).
    pub sd: Vec<Option<f64>>,
}

/// How the curves were fitted: written into curves.json, read by `facslab curves table`.
#[derive(Debug, Clone, PartialEq, serde::Serialize, serde::Deserialize)]
pub struct FitReport {
    /// The take files, in the order of the table's rows and columns.
    pub takes: Vec<String>,
    /// Each take's landmark layout.
    pub layouts: Vec<String>,
    pub epsilon: f64,
    /// "first N frames of each take" or the neutral file.
    pub neutral: String,
    pub band_radius: usize,
    pub distance: Distance,
    /// Index of the prototype take (the k = 1 medoid).
    pub prototype: usize,
    /// Σ over takes of the summed-over-controllers distance to the prototype.
    pub medoid_loss: f64,
    /// Table 3, per controller C1-C17.
    pub tables: Vec<ControllerTable>,
}

/// Why a fit failed.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum FitError {
    #[error(transparent)]
    Track(#[from] TrackError),
    #[error(transparent)]
    Params(#[from] ParamsError),
    #[error("no takes to fit")]
    NoTakes,
    #[error("controller {controller}: {source}")]
    Stats { controller: &'static str, source: StatsError },
}

/// Frames a take needs: the neutral frames and one more, and more than the band's radius.
pub fn frames_needed(options: &FitOptions) -> (usize, String) {
    let neutral = match options.neutral {
        NeutralSource::FirstFrames(n) => n,
        NeutralSource::Track(_) => 0,
    };
    let needed = (neutral + 1).max(options.band + 1).max(2);
    (needed, format!("{neutral} neutral frames and one more, and the DTW band of radius {} needs {} frames", options.band, options.band + 1))
}

/// C1-C17 per frame of every take.
fn take_controllers(takes: &[LandmarkTrack], options: &FitOptions) -> Result<Vec<Vec<[f64; 17]>>, FitError> {
    let (needed, why) = frames_needed(options);
    let given = match &options.neutral {
        NeutralSource::Track(track) => {
            track.require_frames(1, "a neutral track needs a frame")?;
            let p = params::track_parameters(track)?;
            Some(params::neutral_of(&p, p.len()))
        }
        NeutralSource::FirstFrames(_) => None,
    };
    takes
        .iter()
        .map(|take| {
            take.require_frames(needed, &why)?;
            let p = params::track_parameters(take)?;
            let neutral = match (&options.neutral, given) {
                (_, Some(n)) => n,
                (NeutralSource::FirstFrames(n), None) => params::neutral_of(&p, *n),
                (NeutralSource::Track(_), None) => unreachable!("a neutral track always gives FP0"),
            };
            Ok(params::controllers(&take.file, &p, &neutral, options.epsilon)?)
        })
        .collect()
}

/// DTW distance between every pair of `series` (symmetric, 0 on the diagonal).
pub fn pairwise(series: &[Vec<f64>], distance: Distance, radius: usize) -> Result<Vec<Vec<f64>>, StatsError> {
    let band = Band::SakoeChiba { radius, shape: BandShape::LengthAdjusted };
    let n = series.len();
    let mut d = vec![vec![0.0; n]; n];
    for i in 0..n {
        for j in i + 1..n {
            let v = dtw(&series[i], &series[j], distance.cost(), band)?.distance;
            (d[i][j], d[j][i]) = (v, v);
        }
    }
    Ok(d)
}

/// Per take, mean and sample sd of its distances to the other takes (Table 3's last rows).
pub fn mean_sd(distances: &[Vec<f64>]) -> (Vec<Option<f64>>, Vec<Option<f64>>) {
    let n = distances.len();
    (0..n)
        .map(|j| {
            let others: Vec<f64> = (0..n).filter(|&i| i != j).map(|i| distances[i][j]).collect();
            let k = others.len() as f64;
            let mean = (!others.is_empty()).then(|| others.iter().sum::<f64>() / k);
            let sd = mean.filter(|_| others.len() >= 2).map(|m| (others.iter().map(|v| (v - m).powi(2)).sum::<f64>() / (k - 1.0)).sqrt());
            (mean, sd)
        })
        .unzip()
}

/// k-medoids (PAM BUILD then SWAP) on a distance matrix: the medoid indices and the loss.
pub fn medoids(distances: &[Vec<f64>], k: usize) -> Result<(Vec<usize>, f64), StatsError> {
    let init = pam_build(distances, k)?;
    let result = pam(distances, &init, 100)?;
    Ok((result.medoids, result.loss))
}

/// Table 3 of every controller.
fn tables(controllers: &[Vec<[f64; 17]>], options: &FitOptions) -> Result<Vec<ControllerTable>, FitError> {
    CONTROLLERS
        .iter()
        .enumerate()
        .map(|(c, def)| {
            let series: Vec<Vec<f64>> = controllers.iter().map(|take| take.iter().map(|f| f[c]).collect()).collect();
            let distances = pairwise(&series, options.distance, options.band).map_err(|source| FitError::Stats { controller: def.id, source })?;
            let (mean, sd) = mean_sd(&distances);
            Ok(ControllerTable { controller: def.id.into(), name: def.name.into(), distances, mean, sd })
        })
        .collect()
}

/// Fits one laugh type's curves from its takes (see the module doc).
pub fn fit(takes: &[LandmarkTrack], options: &FitOptions) -> Result<Curves, FitError> {
    if takes.is_empty() {
        return Err(FitError::NoTakes);
    }
    let controllers = take_controllers(takes, options)?;
    let tables = tables(&controllers, options)?;
    let n = takes.len();
    let total: Vec<Vec<f64>> = (0..n).map(|i| (0..n).map(|j| tables.iter().map(|t| t.distances[i][j]).sum()).collect()).collect();
    let (found, medoid_loss) = medoids(&total, 1).map_err(|source| FitError::Stats { controller: "all", source })?;
    let prototype = found[0];
    let mut curves = params::to_curves(&controllers[prototype], &options.laugh_type, options.fps, &takes[prototype].file);
    curves.fit = Some(FitReport {
        takes: takes.iter().map(|t| t.file.clone()).collect(),
        layouts: takes.iter().map(|t| t.layout.name().to_string()).collect(),
        epsilon: options.epsilon.value(),
        neutral: match &options.neutral {
            NeutralSource::FirstFrames(k) => format!("first {k} frames of each take"),
            NeutralSource::Track(t) => t.file.clone(),
        },
        band_radius: options.band,
        distance: options.distance,
        prototype,
        medoid_loss,
        tables,
    });
    Ok(curves)
}

/// Table 3 as CSV: per controller, one row per take with its distances to every take, then a
/// `mean` and an `sd` row; empty cells where a value is undefined.
pub fn table_csv(report: &FitReport) -> String {
    let labels: Vec<String> = report.takes.iter().map(|t| take_label(t)).collect();
    let mut out = format!("# distance={}, band_radius={}, epsilon={}\ncontroller,name,row,{}\n", distance_name(report.distance), report.band_radius, report.epsilon, labels.join(","));
    let cell = |v: Option<f64>| v.map_or(String::new(), |v| format!("{v:.6}"));
    for t in &report.tables {
        for (label, row) in labels.iter().zip(&t.distances) {
            let cells: Vec<String> = row.iter().map(|v| format!("{v:.6}")).collect();
            out.push_str(&format!("{},{},{label},{}\n", t.controller, t.name, cells.join(",")));
        }
        for (what, values) in [("mean", &t.mean), ("sd", &t.sd)] {
            let cells: Vec<String> = values.iter().map(|v| cell(*v)).collect();
            out.push_str(&format!("{},{},{what},{}\n", t.controller, t.name, cells.join(",")));
        }
    }
    out
}

/// The CLI's name of a distance convention.
pub fn distance_name(distance: Distance) -> &'static str {
    match distance {
        Distance::SqrtSquared => "sqrt-squared",
        Distance::SumAbs => "sum-abs",
    }
}

/// A take's label in Table 3: its file name without folders and extension.
fn take_label(file: &str) -> String {
    let path = std::path::Path::new(file);
    path.file_stem().map_or(file.to_string(), |s| s.to_string_lossy().into_owned()).replace(',', "_")
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::analysis::stats::cluster::euclidean_distances;
    use crate::analysis::stats::test_support::{assert_abs, assert_close, pts, rv, r, S1, S2, S4, TABLE_2DP_TOL};

    /// The seed's Table 3 (smileFrown, open-mouth smile, s01-s07); s03-s07 is printed as 18.76
    /// in s03's column and 18.16 in s07's row; 18.76 is the value that gives s03's and s07's
    /// printed means, so it is used both ways.
    const SEED_TABLE3: [[f64; 7]; 7] = [
        [0.0, 12.85, 12.88, 27.82, 16.68, 36.82, 11.31],
        [12.85, 0.0, 42.15, 10.90, 8.66, 16.17, 9.16],
        [12.88, 42.15, 0.0, 48.25, 35.20, 38.21, 18.76],
        [27.82, 10.90, 48.25, 0.0, 4.78, 4.29, 13.42],
        [16.68, 8.66, 35.20, 4.78, 0.0, 9.56, 12.43],
        [36.82, 16.17, 38.21, 4.29, 9.56, 0.0, 13.66],
        [11.31, 9.16, 18.76, 13.42, 12.43, 13.66, 0.0],
    ];

    #[test]
    fn table3_mean_and_sd_reproduce_the_seeds_printed_rows() {
        let d: Vec<Vec<f64>> = SEED_TABLE3.iter().map(|r| r.to_vec()).collect();
        let (mean, sd) = mean_sd(&d);
        let seed_mean = [19.73, 16.65, 32.57, 18.24, 14.55, 19.79, 13.12];
        let seed_sd = [10.32, 12.79, 13.82, 17.00, 10.87, 14.32, 3.21];
        // The printed distances are themselves rounded to 2 decimals, so the seed's mean and sd
        // (from unrounded distances) agree within 0.01, not half a unit: s01's sd is 10.3148
        // from the printed column, 10.32 in print. The population sd (n) would give 9.42.
        for j in 0..7 {
            assert_abs(&format!("mean s0{}", j + 1), mean[j].unwrap(), seed_mean[j], 2.0 * TABLE_2DP_TOL);
            assert_abs(&format!("sd s0{}", j + 1), sd[j].unwrap(), seed_sd[j], 2.0 * TABLE_2DP_TOL);
        }
    }

    #[test]
    fn pipeline_dtw_and_medoids_equal_the_reference_libraries() {
        // dtaidistance 2.5.1 / tslearn 0.10.0 (√ of squared) and the exact DP (sum of |·|).
        let d = pairwise(&[S1.to_vec(), S2.to_vec()], Distance::SqrtSquared, 20).unwrap();
        assert_close("dtaidistance distance", d[0][1], r("dtw/dtaidistance_sqrt_of_squared"));
        assert_eq!(d[1][0], d[0][1]);
        let d = pairwise(&[S1.to_vec(), S2.to_vec()], Distance::SumAbs, 20).unwrap();
        assert_close("DP abs cost", d[0][1], r("dtw/dp_abs_cost_sum"));
        // Equal lengths: the length-adjusted band of radius w is tslearn's sakoe_chiba_radius=w.
        for w in 0..=3 {
            let d = pairwise(&[S1.to_vec(), S4.to_vec()], Distance::SqrtSquared, w).unwrap();
            assert_close(&format!("band w={w}"), d[0][1], r(&format!("dtw/band_equal_length/sqrt_of_squared/w{w}")));
        }
        // kmedoids 0.5.5 pam and scikit-learn-extra KMedoids(method="pam", init="build").
        let (found, loss) = medoids(&euclidean_distances(&pts()).unwrap(), 3).unwrap();
        let mut sorted = found.clone();
        sorted.sort_unstable();
        let expected: Vec<usize> = rv("kmedoids/pam_medoids").as_array().unwrap().iter().map(|v| v.as_u64().unwrap() as usize).collect();
        assert_eq!(sorted, expected);
        assert_close("PAM loss", loss, r("kmedoids/pam_loss_sum_dist"));
    }

    #[test]
    fn table_csv_names_its_conventions_and_leaves_undefined_cells_empty() {
        let report = FitReport {
            takes: vec!["a/s01.csv".into(), "b/s02.csv".into()],
            layouts: vec!["ibug68".into(); 2],
            epsilon: 0.2,
            neutral: "first 5 frames of each take".into(),
            band_radius: 10,
            distance: Distance::SumAbs,
            prototype: 0,
            medoid_loss: 1.5,
            tables: vec![ControllerTable { controller: "C9".into(), name: "smileFrown".into(), distances: vec![vec![0.0, 1.5], vec![1.5, 0.0]], mean: vec![Some(1.5), Some(1.5)], sd: vec![None, None] }],
        };
        let csv = table_csv(&report);
        assert_eq!(csv, "# distance=sum-abs, band_radius=10, epsilon=0.2\ncontroller,name,row,s01,s02\nC9,smileFrown,s01,0.000000,1.500000\nC9,smileFrown,s02,1.500000,0.000000\nC9,smileFrown,mean,1.500000,1.500000\nC9,smileFrown,sd,,\n");
    }
}
