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
    /// Seed 004 study 1: real vs generated laugh videos of 6-7 random types, description match 0-5.
    LaughDescription,
    /// Seed 004 study 2: the 13 laugh types on the realistic and cartoon avatar, q1 and q2 0-5.
    LaughMotion,
}

#[derive(Clone, Copy, ValueEnum)]
pub enum ConfusionArg {
    /// Wrong answers go to a similar AU or emotion.
    Similar,
    /// Wrong answers are drawn uniformly.
    Uniform,
}

/// The answer model of a simulation (shared by `simulate` and `power`).
#[derive(Args)]
pub struct ModelArgs {
    /// Which experiment to imitate.
    #[arg(long, value_enum, default_value = "exp1")]
    pub design: DesignArg,
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
    /// Believability shift (scale points) of the raters of every group after the first (exp3, exp4).
    #[arg(long, default_value_t = 0.0)]
    pub group_difference: f64,
}

impl ModelArgs {
    /// The simulation options of this model with `seed`, `coders` and `participants`.
    fn options(&self, seed: u64, coders: usize, participants: usize) -> anyhow::Result<SimOptions> {
        for (name, p) in [("accuracy", self.accuracy), ("false-positive", self.false_positive), ("missing", self.missing)] {
            anyhow::ensure!((0.0..=1.0).contains(&p), "--{name} must be a probability in [0, 1], got {p}");
        }
        anyhow::ensure!(self.group_difference.is_finite() && self.group_difference.abs() <= 5.0, "--group-difference must be between -5 and 5 scale points, got {}", self.group_difference);
        Ok(SimOptions {
            design: match self.design {
                DesignArg::Exp1 => Design::Exp1,
                DesignArg::Exp2 => Design::Exp2,
                DesignArg::Exp3 => Design::Exp3,
                DesignArg::Exp4 => Design::Exp4,
                DesignArg::LaughDescription => Design::LaughDescription,
                DesignArg::LaughMotion => Design::LaughMotion,
            },
            seed,
            coders,
            participants,
            identities: self.identities,
            accuracy: self.accuracy,
            false_positive: self.false_positive,
            confusion: match self.confusion {
                ConfusionArg::Similar => Confusion::Similar,
                ConfusionArg::Uniform => Confusion::Uniform,
            },
            groups: self.groups.iter().map(|g| g.trim().to_string()).filter(|g| !g.is_empty()).collect(),
            missing: self.missing,
            group_difference: self.group_difference,
        })
    }
}

#[derive(Args)]
pub struct SimulateArgs {
    #[command(flatten)]
    pub model: ModelArgs,
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
}

#[derive(Args)]
pub struct PowerArgs {
    #[command(flatten)]
    pub model: ModelArgs,
    /// Output directory for power.csv, power.json and power.png.
    #[arg(short, long)]
    pub output: PathBuf,
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Sample sizes (comma-separated): coders (exp1, exp2) or raters per condition (exp3, exp4).
    #[arg(long, value_delimiter = ',', default_value = "3,5,10,20")]
    pub sizes: Vec<usize>,
    /// Simulated studies per size.
    #[arg(long, default_value_t = 200)]
    pub runs: usize,
}

pub fn analyze(args: AnalyzeArgs) -> anyhow::Result<()> {
    let started = std::time::Instant::now();
    let (catalog, emotions) = (Catalog::built_in(), EmotionTable::built_in());
    let manifest = Manifest::read(&args.manifest, catalog)?;
    let responses = Responses::read(&args.responses, &manifest, catalog, &emotions)?;
    let options = CodingOptions { match_side: args.match_side, match_intensity: args.match_intensity };
    let report = crate::report::build(&manifest, &responses, options, &args.responses, &args.manifest);
    crate::report::write(&report, &args.output)?;
    eprintln!("analysed {} rows in {:.2} s; report in {}", responses.rows, started.elapsed().as_secs_f64(), args.output.display());
    Ok(())
}

pub fn simulate(args: SimulateArgs) -> anyhow::Result<()> {
    let options = args.model.options(args.seed, args.coders, args.participants)?;
    let (manifest, responses) = run_simulation(&options);
    std::fs::create_dir_all(&args.output).with_context(|| format!("creating {}", args.output.display()))?;
    for (name, text) in [("manifest.csv", manifest), ("responses.csv", responses)] {
        let path = args.output.join(name);
        std::fs::write(&path, text).with_context(|| format!("writing {}", path.display()))?;
    }
    eprintln!("wrote {}/manifest.csv and responses.csv", args.output.display());
    Ok(())
}

/// Expected CI widths and t-test power over sample sizes, from repeated seeded simulations.
pub fn power(args: PowerArgs) -> anyhow::Result<()> {
    let model = args.model.options(args.seed, 0, 0)?;
    crate::analysis::power::check(&args.sizes, args.runs)?;
    let started = std::time::Instant::now();
    let bar = crate::progress::bar((args.runs * args.sizes.len()) as u64, "studies", "simulating and analysing");
    let table = crate::analysis::power::run(&model, &args.sizes, args.runs, &|| bar.inc(1))?;
    bar.finish_and_clear();
    std::fs::create_dir_all(&args.output).with_context(|| format!("creating {}", args.output.display()))?;
    for (name, bytes) in crate::report::power::files(&table)? {
        let path = args.output.join(&name);
        std::fs::write(&path, bytes).with_context(|| format!("writing {}", path.display()))?;
    }
    let studies = args.runs * args.sizes.len();
    eprintln!("analysed {studies} simulated studies in {:.1} s; wrote {}/power.csv, power.json and power.png", started.elapsed().as_secs_f64(), args.output.display());
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
