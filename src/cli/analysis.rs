//! The `analyze`, `simulate` and `convert` commands' arguments and bodies (wired up in [`super`]).

use std::path::PathBuf;

use anyhow::Context;
use clap::{Args, ValueEnum};

use crate::analysis::coding::CodingOptions;
use crate::analysis::is_parquet;
use crate::analysis::manifest::Manifest;
use crate::analysis::parquet;
use crate::analysis::responses::Responses;
use crate::analysis::simulate::{Confusion, Design, SimOptions, simulate as run_simulation};
use crate::facs::{Catalog, EmotionTable};

#[derive(Args)]
pub struct AnalyzeArgs {
    /// Responses in the long format (participant_id,group,stimulus_id,trial,measure,value,rt_ms):
    /// CSV, or Parquet (`.parquet`) when built with the `polars` feature.
    #[arg(long)]
    pub responses: PathBuf,
    /// The stimulus manifest (manifest.csv of a built stimulus set; or `.parquet` with the
    /// `polars` feature).
    #[arg(long)]
    pub manifest: PathBuf,
    /// Output directory (created; an earlier report in it is replaced).
    #[arg(short, long)]
    pub output: PathBuf,
    /// Count a coded AU as recognised only if its side (L/R/both) matches.
    #[arg(long)]
    pub match_side: bool,
    /// Count a coded AU as recognised only if its intensity letter matches.
    #[arg(long)]
    pub match_intensity: bool,
}

#[derive(Clone, Copy, ValueEnum)]
pub enum DesignArg {
    /// Single AUs, FACS coders (HapFACS Exp. 1).
    Exp1,
    /// AU combinations, FACS coders (Exp. 2).
    Exp2,
    /// Emotions, lay raters, images and videos at 50/100 % (Exp. 3).
    Exp3,
    /// Emotions, lay raters, the videos at 100 % only (Exp. 4; one per emotion with --identities 1).
    Exp4,
}

#[derive(Clone, Copy, ValueEnum)]
pub enum ConfusionArg {
    /// Wrong answers go to a similar AU or emotion.
    Similar,
    /// Wrong answers are drawn uniformly.
    Uniform,
}

#[derive(Args)]
pub struct SimulateArgs {
    /// Which experiment to imitate.
    #[arg(long, value_enum, default_value = "exp1")]
    pub design: DesignArg,
    /// Output directory for responses.csv and manifest.csv.
    #[arg(short, long)]
    pub output: PathBuf,
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Coders (exp1, exp2).
    #[arg(long, default_value_t = 3)]
    pub coders: usize,
    /// Raters per media × intensity condition (exp3, exp4).
    #[arg(long, default_value_t = 20)]
    pub participants: usize,
    /// Identities per emotion, intensity and media (exp3, exp4).
    #[arg(long, default_value_t = 2)]
    pub identities: usize,
    /// Probability of a correct answer per shown AU or emotion.
    #[arg(long, default_value_t = 0.85)]
    pub accuracy: f64,
    /// Probability that a coder adds an AU that is not shown.
    #[arg(long, default_value_t = 0.1)]
    pub false_positive: f64,
    /// Where wrong answers go.
    #[arg(long, value_enum, default_value = "similar")]
    pub confusion: ConfusionArg,
    /// Participant groups (comma-separated), assigned in turn (exp3, exp4).
    #[arg(long, value_delimiter = ',', default_value = "local,amt")]
    pub groups: Vec<String>,
    /// Probability that a judgement is missing.
    #[arg(long, default_value_t = 0.0)]
    pub missing: f64,
}

pub fn analyze(args: AnalyzeArgs) -> anyhow::Result<()> {
    let started = std::time::Instant::now();
    let (catalog, emotions) = (Catalog::built_in(), EmotionTable::built_in());
    let manifest = Manifest::read(&args.manifest, catalog, &emotions)?;
    let responses = Responses::read(&args.responses, &manifest, catalog, &emotions)?;
    let options = CodingOptions { match_side: args.match_side, match_intensity: args.match_intensity };
    let report = crate::report::build(&manifest, &responses, options, &args.responses, &args.manifest);
    crate::report::write(&report, &args.output)?;
    eprintln!("analysed {} rows in {:.2} s; report in {}", responses.rows, started.elapsed().as_secs_f64(), args.output.display());
    Ok(())
}

pub fn simulate(args: SimulateArgs) -> anyhow::Result<()> {
    for (name, p) in [("accuracy", args.accuracy), ("false-positive", args.false_positive), ("missing", args.missing)] {
        anyhow::ensure!((0.0..=1.0).contains(&p), "--{name} must be a probability in [0, 1], got {p}");
    }
    let options = SimOptions {
        design: match args.design {
            DesignArg::Exp1 => Design::Exp1,
            DesignArg::Exp2 => Design::Exp2,
            DesignArg::Exp3 => Design::Exp3,
            DesignArg::Exp4 => Design::Exp4,
        },
        seed: args.seed,
        coders: args.coders,
        participants: args.participants,
        identities: args.identities,
        accuracy: args.accuracy,
        false_positive: args.false_positive,
        confusion: match args.confusion {
            ConfusionArg::Similar => Confusion::Similar,
            ConfusionArg::Uniform => Confusion::Uniform,
        },
        groups: args.groups.iter().map(|g| g.trim().to_string()).filter(|g| !g.is_empty()).collect(),
        missing: args.missing,
    };
    let (manifest, responses) = run_simulation(&options);
    std::fs::create_dir_all(&args.output).with_context(|| format!("creating {}", args.output.display()))?;
    for (name, text) in [("manifest.csv", manifest), ("responses.csv", responses)] {
        let path = args.output.join(name);
        std::fs::write(&path, text).with_context(|| format!("writing {}", path.display()))?;
    }
    eprintln!("wrote {}/manifest.csv and responses.csv", args.output.display());
    Ok(())
}

#[derive(Args)]
pub struct ConvertArgs {
    /// The table to convert: a response file or a manifest, CSV or `.parquet`.
    pub input: PathBuf,
    /// Where to write it, in the other format (`.parquet` for a CSV input, CSV otherwise).
    #[arg(short, long)]
    pub output: PathBuf,
}

/// Converts a table between CSV and Parquet, the direction given by the extensions.
pub fn convert(args: ConvertArgs) -> anyhow::Result<()> {
    let rows = match (is_parquet(&args.input), is_parquet(&args.output)) {
        (false, true) => parquet::csv_to_parquet(&args.input, &args.output)?,
        (true, false) => parquet::parquet_to_csv(&args.input, &args.output)?,
        (true, true) => anyhow::bail!("both files are Parquet: the output of a .parquet input must be CSV (e.g. {})", args.input.with_extension("csv").display()),
        (false, false) => anyhow::bail!("neither file is Parquet: the output of a CSV input must end in .parquet (e.g. {})", args.input.with_extension("parquet").display()),
    };
    eprintln!("wrote {rows} rows to {}", args.output.display());
    Ok(())
}
