//! `facslab curves fit` (landmark tracks of one laugh type → curves.json with its Table 3) and
//! `facslab curves table` (curves.json → Table 3 as CSV).
//!
//! Order, so a failure leaves nothing partial: the type, ε and every track are read and checked
//! first; the fit runs in memory; only then is the output written.

use std::path::{Path, PathBuf};

use anyhow::{bail, Context};

use crate::facs::Catalog;
use crate::laugh::fit::{self, Distance, FitOptions, NeutralSource};
use crate::laugh::landmarks::{self, Layout, LandmarkTrack};
use crate::laugh::params::Epsilon;
use crate::laugh::LaughTable;
use crate::laugh::Curves;

/// The subcommands of `facslab curves`.
#[derive(Debug, clap::Subcommand)]
pub enum CurvesCommand {
    /// Fit a laugh type's AU curves from landmark tracks of several takes (seed 004, Eq. 1,
    /// DTW, k-medoids prototype).
    #[command(after_help = "Examples:\n  facslab curves fit s01.csv s02.csv s03.csv --type open_mouthed_smile -o curves.json\n  facslab curves fit takes/*.csv --type laughter --layout openface --epsilon 0.2 --band 15 --distance sum-abs -o laughter.json\n  facslab curves fit take.csv --type false_smile --neutral rest.csv --fps 25 -o false_smile.json\n  facslab curves table curves.json -o table3.csv\n\nTracks are CSV, one row per frame: OpenFace 2 (x_0..x_67, y_0..y_67), dlib/iBUG 68, the seed's\n66 points, or MediaPipe 468/478; the layout is read from the header unless --layout is given.\nThe prototype take's curves are written; curves.json also holds Table 3 for `curves table`.")]
    Fit(FitArgs),
    /// Write the Table 3 of a fitted curves.json (DTW distances between takes per controller,
    /// mean and sd per take) as CSV.
    #[command(after_help = "Examples:\n  facslab curves table curves.json -o table3.csv\n  facslab curves table curves.json            # to standard output")]
    Table(TableArgs),
}

/// The arguments of `facslab curves fit`.
#[derive(Debug, clap::Args)]
pub struct FitArgs {
    /// Landmark track CSV files, one per take of the same laugh type.
    #[arg(required = true)]
    tracks: Vec<PathBuf>,
    /// The laugh type's id (one of the thirteen; see docs/laugh-curves.md).
    #[arg(long = "type")]
    laugh_type: String,
    /// Output curves JSON.
    #[arg(short, long)]
    output: PathBuf,
    /// Landmark layout of every track (default: read from each header).
    #[arg(long, value_enum)]
    layout: Option<Layout>,
    /// ε of Eq. 1, in [0.1, 0.3]: a controller saturates at a change of ε times its neutral value.
    #[arg(long, default_value_t = 0.2)]
    epsilon: f64,
    /// A landmark track of the face at rest; its mean is the neutral (default: each take's first frames).
    #[arg(long)]
    neutral: Option<PathBuf>,
    /// Frames at the start of each take averaged as its neutral (without --neutral).
    #[arg(long, default_value_t = 5)]
    neutral_frames: usize,
    /// Sakoe-Chiba band radius in frames (length-adjusted, as tslearn's sakoe_chiba_radius).
    #[arg(long, default_value_t = 10)]
    band: usize,
    /// DTW distance: sqrt-squared (dtaidistance/tslearn) or sum-abs (textbook/fastdtw).
    #[arg(long, value_enum, default_value_t = Distance::SqrtSquared)]
    distance: Distance,
    /// Frame rate of the tracks.
    #[arg(long, default_value_t = 30)]
    fps: u32,
}

/// The arguments of `facslab curves table`.
#[derive(Debug, clap::Args)]
pub struct TableArgs {
    /// A curves.json written by `facslab curves fit`.
    curves: PathBuf,
    /// Output CSV (default: standard output).
    #[arg(short, long)]
    output: Option<PathBuf>,
}

pub fn curves_command(command: CurvesCommand) -> anyhow::Result<()> {
    match command {
        CurvesCommand::Fit(args) => fit_command(&args),
        CurvesCommand::Table(args) => table_command(&args),
    }
}

fn read(path: &Path, layout: Option<Layout>) -> anyhow::Result<LandmarkTrack> {
    let text = std::fs::read_to_string(path).with_context(|| format!("{}: cannot read it", path.display()))?;
    Ok(landmarks::read_track(&path.display().to_string(), &text, layout)?)
}

fn fit_command(args: &FitArgs) -> anyhow::Result<()> {
    let table = LaughTable::built_in();
    if table.get(&args.laugh_type).is_none() {
        bail!("--type {:?} is not a laugh type; the types are: {}", args.laugh_type, table.ids().join(", "));
    }
    if !(1..=120).contains(&args.fps) {
        bail!("--fps must be 1-120, not {}", args.fps);
    }
    let epsilon = Epsilon::new(args.epsilon)?;
    let neutral = match &args.neutral {
        Some(path) => NeutralSource::Track(read(path, args.layout)?),
        None => NeutralSource::FirstFrames(args.neutral_frames.max(1)),
    };
    let bar = crate::progress::bar(args.tracks.len() as u64, "tracks", "reading");
    let mut takes = Vec::with_capacity(args.tracks.len());
    for path in &args.tracks {
        takes.push(read(path, args.layout)?);
        bar.inc(1);
    }
    bar.finish_and_clear();
    let options = FitOptions { laugh_type: args.laugh_type.clone(), fps: args.fps, epsilon, neutral, band: args.band, distance: args.distance };
    let curves = fit::fit(&takes, &options)?;
    curves.validate(Catalog::built_in()).context("the fitted curves are not valid")?;
    crate::stimuli::build::write_atomic(&args.output, curves.to_json().as_bytes()).with_context(|| format!("writing {}", args.output.display()))?;
    let report = curves.fit.as_ref().context("fit wrote no report")?;
    eprintln!(
        "{} takes, {} frames at {} fps; prototype: {} (DTW {}, band {}, ε {}) → {}",
        takes.len(),
        curves.frame_count(),
        curves.fps,
        report.takes[report.prototype],
        fit::distance_name(report.distance),
        report.band_radius,
        report.epsilon,
        args.output.display()
    );
    Ok(())
}

fn table_command(args: &TableArgs) -> anyhow::Result<()> {
    let text = std::fs::read_to_string(&args.curves).with_context(|| format!("{}: cannot read it", args.curves.display()))?;
    let curves = Curves::from_json(&text, Catalog::built_in()).with_context(|| format!("{}", args.curves.display()))?;
    let Some(report) = &curves.fit else {
        bail!("{}: these curves were not made by `facslab curves fit` (no Table 3 in them)", args.curves.display());
    };
    let csv = fit::table_csv(report);
    match &args.output {
        Some(path) => crate::stimuli::build::write_atomic(path, csv.as_bytes()).with_context(|| format!("writing {}", path.display()))?,
        None => print!("{csv}"),
    }
    Ok(())
}
