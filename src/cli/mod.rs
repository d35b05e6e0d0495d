//! The command line: parses arguments with clap and calls the library. The only place where
//! errors become messages for people (with `anyhow` context) and exit codes. This module holds the
//! engine and stimulus commands; [`speak`] and [`laugh`] the speaking and laughing faces; [`analysis`] holds `analyze`, `simulate` and `convert`; [`studio`]
//! the editor's server; [`web`] the study platform's `serve`, `demo`, `study`, `admin`, `export` and `report`.

pub mod analysis;
pub mod curves;
pub mod laugh;
pub mod speak;
pub mod studio;
pub mod web;

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{Context, bail};
use clap::{Parser, Subcommand, ValueEnum};

use crate::engine::identity::{Identity, IdentityTable};
use crate::engine::look::{Backdrop, Look};
use crate::engine::sheet::ContactSheet;
use crate::engine::{self, FrameSettings};
use crate::engine::timeline::{ClipTiming, Ramp, Timeline};
use crate::facs::{AppearanceSpec, AuCode, Catalog, EmotionTable, Expression};
use crate::stimuli::{self, SetSpec};

impl From<RampArg> for Ramp {
    fn from(ramp: RampArg) -> Ramp {
        match ramp {
            RampArg::Linear => Ramp::Linear,
            RampArg::Smoothstep => Ramp::Smoothstep,
            RampArg::Cosine => Ramp::Cosine,
        }
    }
}

#[derive(Parser)]
#[command(name = "facslab", version, about = "FACS-controlled facial-expression stimuli, studies and validation reports")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// List the Action Units facslab can show.
    #[command(after_help = "Examples:\n  facslab catalog\n  facslab catalog --appearance 6      # what AU6 looks like at A-E\n  facslab catalog --appearance all    # the whole appearance specification (Markdown)")]
    Catalog {
        /// Print what an AU looks like (its movement, furrows, bulges, shape and levels A-E):
        /// an AU number, or `all` for every AU.
        #[arg(long, value_name = "AU|all")]
        appearance: Option<String>,
    },

    /// List the identities (people) facslab can render, or generate a new one.
    #[command(after_help = "Examples:\n  facslab identities\n  facslab identities --identities people.toml\n  facslab identities new --sex F --age 34 --ancestry east-asian --seed 7 -o people.toml\n  facslab render 6+12 --identities people.toml --identity eaf7 -o smile.png")]
    Identities {
        #[command(subcommand)]
        command: Option<IdentitiesCommand>,
        /// Also list the people of this identity file (same format as stimuli/engine/identities.toml).
        #[arg(long)]
        identities: Option<PathBuf>,
    },

    /// Make a face speak a sentence while it shows an emotion: an MP4 with lip-synced sound.
    Speak(speak::SpeakArgs),

    /// Laugh and smile curves from landmark tracks: `curves fit` and `curves table`.
    #[command(subcommand)]
    Curves(curves::CurvesCommand),
    /// A laugh or smile of seed 004's thirteen types as an MP4, realistic or cartoon.
    Laugh(laugh::LaughArgs),

    /// Render one expression as a PNG still, or as an MP4 video (HapFACS clip or a timeline file).
    #[command(after_help = "Examples:\n  facslab render 1+2+5B+26 --identity wf1 -o surprise.png\n  facslab render L12C+R14 --identity bm2 -o smirk.png --size 970x960\n  facslab render 12@0.42 -o faint-smile.png\n  facslab render 6+12 --video -o smile.mp4                      # 1 s onset, 1 s apex, 1 s offset, 30 fps\n  facslab render 6+12 --video --onset 0.5 --ramp cosine -o smile.mp4 --export-timeline smile.json\n  facslab render --timeline smile.json -o smile.mp4 --frames smile-frames --poster smile.png\n\nFACS notation: AUs joined by '+'; L/R prefix = one side; A-E suffix = intensity\n(15/30/55/85/100 %), or @x for a fraction in [0, 1]; no suffix = E; 0 = neutral.\nVideos are H.264 in MP4, BT.601-tagged; an odd width or height is padded to even (485x480 -> 486x480).")]
    Render {
        /// The expression in FACS notation, e.g. "1+2+4B+L12C" (not with --timeline).
        #[arg(required_unless_present = "timeline")]
        expression: Option<String>,
        /// Who shows it (see `facslab identities`) [default: wm1].
        #[arg(long)]
        identity: Option<String>,
        /// Adds the people of this identity file (same TOML as stimuli/engine/identities.toml).
        #[arg(long)]
        identities: Option<PathBuf>,
        #[command(flatten)]
        look: LookArgs,
        /// Output file: .png for a still, .mp4 for a video.
        #[arg(short, long)]
        output: PathBuf,
        /// Image size as WIDTHxHEIGHT [default: 485x480].
        #[arg(long, value_parser = engine::parse_size)]
        size: Option<(u32, u32)>,
        /// Rendering threads (default: all cores; the image is the same either way).
        #[arg(long)]
        threads: Option<usize>,
        /// Render a video of EXPRESSION: 0 -> peak over --onset, held for --apex, back over --offset.
        #[arg(long, conflicts_with = "timeline")]
        video: bool,
        /// Render the video described by a timeline JSON file (identity and size come from the file).
        #[arg(long, conflicts_with_all = ["expression", "identity", "size"])]
        timeline: Option<PathBuf>,
        /// Onset duration in seconds (with --video).
        #[arg(long, default_value_t = 1.0, requires = "video")]
        onset: f64,
        /// Apex duration in seconds (with --video).
        #[arg(long, default_value_t = 1.0, requires = "video")]
        apex: f64,
        /// Offset duration in seconds (with --video).
        #[arg(long, default_value_t = 1.0, requires = "video")]
        offset: f64,
        /// Frames per second (with --video).
        #[arg(long, default_value_t = 30, requires = "video")]
        fps: u32,
        /// Ramp shape of onset and offset (with --video): linear (HapFACS), smoothstep or cosine.
        #[arg(long, value_enum, default_value = "linear", requires = "video")]
        ramp: RampArg,
        /// Also write the timeline used to this JSON file (render it again with --timeline).
        #[arg(long)]
        export_timeline: Option<PathBuf>,
        /// Also write every frame as PNG into this directory (000000.png, 000001.png, ...).
        #[arg(long)]
        frames: Option<PathBuf>,
        /// Also write the first frame as a poster PNG.
        #[arg(long)]
        poster: Option<PathBuf>,
        /// Video codec: h264 (default) or av1 (the fallback; needs the `av1` cargo feature).
        #[arg(long, value_enum, default_value = "h264")]
        codec: CodecArg,
    },

    /// Render a labelled contact sheet for a visual audit.
    #[command(after_help = "Examples:\n  facslab sheet -o aus.png                      # every AU at E, then L/R variants, on wm1\n  facslab sheet --set emotions -o emotions.png  # EmFACS prototypes at 100 % on every person")]
    Sheet {
        /// What to put on the sheet.
        #[arg(long, value_enum, default_value = "aus")]
        set: SheetSet,
        /// Identity for the AU sheet.
        #[arg(long, default_value = "wm1")]
        identity: String,
        /// Adds the people of this identity file (the emotions sheet shows them too).
        #[arg(long)]
        identities: Option<PathBuf>,
        #[command(flatten)]
        look: LookArgs,
        /// Output PNG file.
        #[arg(short, long)]
        output: PathBuf,
        /// Size of each tile as WIDTHxHEIGHT.
        #[arg(long, default_value = "242x240", value_parser = engine::parse_size)]
        tile: (u32, u32),
        /// Tiles per row.
        #[arg(long, default_value_t = 8)]
        columns: u32,
    },

    /// Build and check stimulus sets (specs in stimuli/sets/).
    #[command(subcommand)]
    Stimuli(StimuliCommand),

    /// Compute the validation report from responses and the stimulus manifest.
    #[command(after_help = "Examples:\n  facslab analyze --responses responses.csv --manifest manifest.csv -o report\n  facslab analyze --responses r.csv --manifest m.csv -o strict --match-side --match-intensity\n  facslab analyze --responses r.parquet --manifest m.parquet -o report   # built with --features polars\n\nWrites report.json (every number), report.html (tables and plots), one CSV per table and\nthe plots as PNG files. Inputs are validated in full first; on any error nothing is written.\nFiles ending in .parquet are read as Parquet (same results and error messages as CSV).")]
    Analyze(analysis::AnalyzeArgs),

    /// Build the demo stimulus set and two demo studies, then serve them and print the URLs.
    #[command(after_help = "Examples:\n  facslab demo                       # http://127.0.0.1:8080/s/demo-emotions, /s/demo-coding, /admin\n  facslab demo --port 9000 -o /tmp/demo\n\nEverything lives in the output directory (default facslab-demo/): the stimulus set, the\nSQLite database and the admin password (admin-password.txt). Running it again reuses them.")]
    Demo(web::DemoArgs),

    /// Compose and preview expressions in the browser; serves the live render API.
    #[command(after_help = "Examples:\n  facslab studio                      # then open http://127.0.0.1:8090/\n  facslab studio --port 9000\n\nAPI: POST /api/v1/render {\"expression\": \"1+2+5B\", \"identity\": \"wf1\", \"size\": \"485x480\"} -> PNG\n(the bytes `facslab render` writes); {\"timeline\": {...}} -> MP4; WebSocket /api/v1/stream.\nProtocol and client examples: docs/studio.md.")]
    Studio(studio::StudioArgs),

    /// Serve the study web app (participants and admin) from a study database.
    #[command(after_help = "Examples:\n  facslab serve --db lab.db\n  facslab serve --db lab.db --host 0.0.0.0 --port 8080\n  facslab serve --db postgres://lab@db.example.org/facslab --host 0.0.0.0   # several servers, one database\n\nCreate studies with `facslab study create` and the first admin with `facslab admin create`.")]
    Serve(web::ServeArgs),

    /// Create, check, list, open and close studies.
    #[command(subcommand)]
    Study(web::StudyCommand),

    /// Admin accounts, export API tokens and backups.
    #[command(subcommand)]
    Admin(web::AdminCommand),

    /// Export a study's responses (long CSV for `analyze`, wide CSV, JSON), its codebook, or a Psych-DS dataset.
    #[command(after_help = "Examples:\n  facslab export --study exp3 --db lab.db -o responses.csv\n  facslab export --study exp3 --format wide.csv --all --db lab.db -o wide.csv\n  facslab export --study exp3 --format psych-ds --db lab.db -o exp3-dataset")]
    Export(web::ExportArgs),

    /// The validation report of a study, straight from the study database.
    #[command(after_help = "Examples:\n  facslab report --study exp3 --db lab.db -o exp3-report\n  facslab report --study exp1 --db lab.db -o strict --match-side --match-intensity\n\nReads the study's judgements from the database and analyses them in memory against the\nmanifest of the study's stimulus set, as `facslab analyze` analyses files; a copy of the rows\nused is kept in OUTPUT.inputs/responses.csv (the bytes `facslab export` writes).")]
    Report(web::ReportArgs),

    /// Write synthetic responses and a manifest shaped like one of the seed's experiments.
    #[command(after_help = "Examples:\n  facslab simulate --design exp1 --seed 1 -o sim1           # 3 coders, 49 single AUs\n  facslab simulate --design exp2 --accuracy 0.8 -o sim2       # 54 AU combinations\n  facslab simulate --design exp3 --participants 40 --groups local,amt --missing 0.02 -o sim3\n\nWrites DIR/responses.csv and DIR/manifest.csv; the same options give the same bytes.")]
    Simulate(analysis::SimulateArgs),

    /// Plan a validation study: expected 95 % CI widths and t-test power over sample sizes.
    #[command(after_help = "Examples:\n  facslab power --design exp1 --sizes 3,5,10,20 --runs 200 -o power1        # how many FACS coders\n  facslab power --design exp3 --sizes 5,10,20,40 --runs 100 --group-difference 0.3 -o power3\n  facslab power --design exp1 --accuracy 0.7 --confusion uniform --sizes 5,10 --runs 50 -o p\n\nFor each size (coders for exp1/exp2, raters per media x intensity condition for exp3) it\nsimulates RUNS studies with seeds derived from --seed, analyses each as `facslab analyze`\nwould, and writes OUTPUT/power.csv, power.json and power.png: per statistic (per-AU F1,\nrecognition rate, believability mean, the believability t-test between the first two groups)\nthe mean reported 95% CI width beside the 2.5-97.5% spread of the estimates over the runs\n(they agree when the CI is calibrated), and the t-test's power (share of runs with p < .05)\nfor the assumed --group-difference. Bounds: 2-2000 runs, 1-20 sizes of 2-500, runs x sum of\nsizes <= 400000. The same options give the same bytes.")]
    Power(analysis::PowerArgs),

    /// Convert a response file or a manifest between CSV and Parquet (needs the `polars` feature).
    #[command(after_help = "Examples:\n  facslab convert sim/responses.csv -o responses.parquet\n  facslab convert sim/manifest.csv -o manifest.parquet\n  facslab convert responses.parquet -o responses.csv\n  facslab analyze --responses responses.parquet --manifest manifest.parquet -o report\n\nThe direction follows the extensions (.parquet or CSV). A column is stored as Int64 or\nFloat64 when every cell converts back to the same text, else as String; empty cells are\nnulls. Converting back gives every cell exactly. Needs facslab built with\n`cargo build --release --features polars`; without it the command says so and stops.")]
    Convert(analysis::ConvertArgs),
}

#[derive(Subcommand)]
enum StimuliCommand {
    /// Render a stimulus set: media with opaque names, manifest.csv/json, per-frame ground truth.
    #[command(after_help = "Examples:\n  facslab stimuli build stimuli/sets/demo.toml -o demo-set\n  facslab stimuli build stimuli/sets/exp1.toml -o exp1 --jobs 2\n  facslab stimuli build stimuli/sets/exp1.toml -o exp1 --dither-key exp1.key\n\nThe spec is validated completely before anything renders. Files already up to date\n(same manifest row, same sha256 on disk) are kept. Output layout: manifest.csv,\nmanifest.json, media/<id>.png|mp4, posters/, ground_truth/<id>.csv, timelines/<id>.json,\ndither.key.\n\nMedia and posters are dithered (each colour channel moved by at most 1 of 255) with the set's\nsecret key, so they differ from a public `facslab render` of the same expression. The key is\nmade on the first build and kept in OUTPUT/dither.key (never served): keep it private and\nback it up with the set, the same spec, seed and key rebuild the same bytes.")]
    Build {
        /// The set specification (TOML).
        spec: PathBuf,
        /// Output directory (created if needed).
        #[arg(short, long)]
        output: PathBuf,
        /// Worker threads (default: all cores).
        #[arg(long)]
        jobs: Option<usize>,
        /// Build only part K of N of the set (entries at positions K-1, K-1+N, …), for a cluster
        /// job array; join the parts with `stimuli merge`.
        #[arg(long, value_name = "K/N")]
        shard: Option<stimuli::Shard>,
        /// Dither with the key in this file (from `facslab stimuli key`) instead of OUTPUT/dither.key;
        /// needed with --shard, so that the parts of a set share one key.
        #[arg(long, value_name = "FILE", conflicts_with = "no_dither")]
        dither_key: Option<PathBuf>,
        /// No dither and no key: the media are the bytes `facslab render` writes.
        #[arg(long)]
        no_dither: bool,
    },
    /// Write a new secret dither key, for the shards of one set (`stimuli build --dither-key`).
    #[command(after_help = "Example:\n  facslab stimuli key -o exp1.key\n  facslab stimuli build stimuli/sets/exp1.toml -o part1 --shard 1/2 --dither-key exp1.key\n\n32 bytes from the operating system's randomness, as 64 hex digits (file mode 0600).\nThe key is never printed; an existing file is never overwritten.")]
    Key {
        /// The key file to create.
        #[arg(short, long)]
        output: PathBuf,
    },
    /// Join the shards of one set (built with --shard K/N) into the set one machine would build.
    #[command(after_help = "Examples:\n  facslab stimuli build stimuli/sets/exp1.toml -o part1 --shard 1/2\n  facslab stimuli build stimuli/sets/exp1.toml -o part2 --shard 2/2\n  facslab stimuli merge part1 part2 -o exp1\n\nEvery part K of N must be given once, all built from the same spec, seed and facslab\nversion; each media file is checked against its sha256. The result is byte for byte the\ndirectory `stimuli build` writes on one machine. docs/cluster.md has Slurm and Kubernetes\nexamples.")]
    Merge {
        /// The shard directories.
        #[arg(required = true)]
        shards: Vec<PathBuf>,
        /// Output directory (must be new or empty).
        #[arg(short, long)]
        output: PathBuf,
    },
    /// Validate a set specification and count its stimuli and frames, without rendering.
    #[command(after_help = "Example:\n  facslab stimuli check stimuli/sets/exp2.toml")]
    Check {
        /// The set specification (TOML).
        spec: PathBuf,
    },
}

#[derive(Subcommand)]
enum IdentitiesCommand {
    /// Generate a new person from the CC0 shape targets and append it to an identity file.
    #[command(after_help = "Examples:\n  facslab identities new --sex M --age 52 --ancestry middle-eastern --seed 3 -o people.toml\n  facslab identities new --sex M --age 40 --ancestry hispanic --seed 5 --beard 8 -o people.toml\n  facslab identities new --sex M --age 35 --ancestry european --seed 2 --beard 6 --beard-style goatee -o people.toml\n\nAncestries: african, east-asian, south-asian, hispanic, middle-eastern, european.\nThe same options give the same person; another --seed gives another person.")]
    New {
        /// F or M.
        #[arg(long, value_parser = parse_sex)]
        sex: crate::engine::people::Sex,
        /// Age in years (18..=90).
        #[arg(long, value_parser = clap::value_parser!(u32).range(18..=90))]
        age: u32,
        /// african, east-asian, south-asian, hispanic, middle-eastern or european.
        #[arg(long, value_parser = parse_origin)]
        ancestry: crate::engine::people::Origin,
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// The new person's id [default: ancestry code, f/m and the seed, e.g. eaf7].
        #[arg(long)]
        id: Option<String>,
        /// A beard, its hairs this many millimetres long (0..=20; 0 = none).
        #[arg(long, default_value_t = 0, value_parser = clap::value_parser!(u32).range(0..=crate::engine::identity::MAX_BEARD_MM as i64))]
        beard: u32,
        /// Where the beard grows: full (with cheeks and sideburns), goatee or moustache.
        #[arg(long, default_value = "full", value_parser = parse_beard_style, requires = "beard")]
        beard_style: crate::engine::identity::BeardStyle,
        /// The identity file to create or append to.
        #[arg(short, long)]
        output: PathBuf,
    },
}

fn parse_sex(text: &str) -> Result<crate::engine::people::Sex, String> {
    match text {
        "F" | "f" => Ok(crate::engine::people::Sex::Female),
        "M" | "m" => Ok(crate::engine::people::Sex::Male),
        _ => Err(format!("\"{text}\" is not F or M")),
    }
}

fn parse_beard_style(text: &str) -> Result<crate::engine::identity::BeardStyle, String> {
    use crate::engine::identity::BeardStyle;
    one_of(text, &BeardStyle::ALL, BeardStyle::name)
}

fn parse_origin(text: &str) -> Result<crate::engine::people::Origin, String> {
    use crate::engine::people::Origin;
    one_of(text, &Origin::ALL, Origin::name)
}

/// The value among `all` whose `name` is `text`, or a message listing the names there are.
fn one_of<T: Copy>(text: &str, all: &[T], name: fn(T) -> &'static str) -> Result<T, String> {
    all.iter().copied().find(|&value| name(value) == text).ok_or_else(|| {
        let names: Vec<&str> = all.iter().map(|&value| name(value)).collect();
        format!("\"{text}\" is not one of {}", names.join(", "))
    })
}

/// Adds the people of `path` (if any) to the identities every command renders.
pub fn install_identities(path: Option<&Path>) -> anyhow::Result<()> {
    let Some(path) = path else { return Ok(()) };
    let size = std::fs::metadata(path).with_context(|| format!("reading {}", path.display()))?.len();
    if size > crate::engine::identity::MAX_FILE_BYTES as u64 {
        bail!("{} is {size} bytes; an identity file may have at most {} bytes", path.display(), crate::engine::identity::MAX_FILE_BYTES);
    }
    let text = std::fs::read_to_string(path).with_context(|| format!("reading {}", path.display()))?;
    IdentityTable::install(&text).with_context(|| format!("in identity file {}", path.display()))?;
    Ok(())
}

/// Generates one person and appends it to `output` (created with a header if missing).
fn new_identity(request: &crate::engine::people::PersonRequest, output: &Path) -> anyhow::Result<()> {
    let block = crate::engine::people::generate(request);
    let existing = match std::fs::read_to_string(output) {
        Ok(text) => text,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => {
            "# People for facslab (`--identities FILE`); same format as stimuli/engine/identities.toml.\n".to_string()
        }
        Err(e) => return Err(e).with_context(|| format!("reading {}", output.display())),
    };
    let id = request.id();
    if IdentityTable::active().get(&id).is_ok() {
        bail!("\"{id}\" is a built-in identity; choose another --id or --seed");
    }
    let text = format!("{}\n\n{block}", existing.trim_end());
    crate::engine::identity::IdentityTable::from_toml(&text, crate::engine::asset::FaceModel::embedded())
        .with_context(|| format!("{} with the new person would not be a valid identity file", output.display()))?;
    stimuli::build::write_atomic(output, text.as_bytes())?;
    println!("{id}");
    Ok(())
}

/// Backdrop, light and colour: the same options on every command that renders.
#[derive(Debug, Clone, Copy, clap::Args)]
struct LookArgs {
    /// Backdrop: grey, black, #RRGGBB or transparent (an RGBA PNG, stills only).
    #[arg(long, default_value = "grey")]
    backdrop: crate::engine::look::Backdrop,
    /// Lighting preset: studio, soft or dramatic.
    #[arg(long, default_value = "studio")]
    light: crate::engine::look::LightPreset,
    /// Black-and-white output.
    #[arg(long)]
    grayscale: bool,
}

impl From<LookArgs> for Look {
    fn from(args: LookArgs) -> Look {
        Look { backdrop: args.backdrop, light: args.light, grayscale: args.grayscale }
    }
}

#[derive(Clone, Copy, PartialEq, ValueEnum)]
enum CodecArg {
    H264,
    Av1,
}

#[derive(Clone, Copy, ValueEnum)]
enum RampArg {
    Linear,
    Smoothstep,
    Cosine,
}

#[derive(Clone, Copy, ValueEnum)]
enum SheetSet {
    /// Every AU at E, then each unilateral AU on the left and on the right.
    Aus,
    /// Every EmFACS prototype at 100 % on every identity.
    Emotions,
}

/// Runs the command line and returns the process exit code.
pub fn run() -> ExitCode {
    let cli = Cli::parse();
    match dispatch(cli.command) {
        Ok(()) => ExitCode::SUCCESS,
        Err(err) => {
            eprintln!("error: {err:#}");
            ExitCode::FAILURE
        }
    }
}

fn dispatch(command: Command) -> anyhow::Result<()> {
    match command {
        Command::Demo(args) => web::demo_command(args),
        Command::Serve(args) => web::serve_command(args),
        Command::Studio(args) => studio::studio_command(args),
        Command::Speak(args) => speak::speak_command(args),
        Command::Curves(command) => curves::curves_command(command),
        Command::Laugh(args) => laugh::laugh_command(args),
        Command::Study(command) => web::study_command(command),
        Command::Admin(command) => web::admin_command(command),
        Command::Export(args) => web::export_command(args),
        Command::Report(args) => web::report_command(args),
        Command::Catalog { appearance: Some(which) } => print_appearance(&which),
        Command::Catalog { appearance: None } => {
            for unit in Catalog::built_in().iter() {
                let side = if unit.unilateral { "L/R" } else { "" };
                println!("{:>3}  {:<26} {:<22} {:<4} {}", unit.code, unit.name, unit.region.label(), side, unit.appearance);
            }
            Ok(())
        }
        Command::Identities { command: Some(IdentitiesCommand::New { sex, age, ancestry, seed, id, beard, beard_style, output }), .. } => {
            let request = crate::engine::people::PersonRequest { sex, age, origin: ancestry, seed, id, beard_mm: beard, beard_style };
            new_identity(&request, &output)
        }
        Command::Identities { command: None, identities } => {
            install_identities(identities.as_deref())?;
            for identity in IdentityTable::active().iter() {
                println!("{:<8} {}", identity.id, identity.description);
            }
            Ok(())
        }
        Command::Render {
            expression,
            identity,
            identities,
            look,
            output,
            size,
            threads,
            video,
            timeline,
            onset,
            apex,
            offset,
            fps,
            ramp,
            export_timeline,
            frames,
            poster,
            codec,
        } => {
            install_identities(identities.as_deref())?;
            let is_video = video || timeline.is_some();
            check_expression_length(expression.as_deref().unwrap_or_default())?;
            if !is_video {
                if export_timeline.is_some() || frames.is_some() || poster.is_some() {
                    bail!("--export-timeline, --frames and --poster go with --video or --timeline");
                }
                let expression = Catalog::built_in().parse(expression.as_deref().unwrap_or_default())?;
                let identity = IdentityTable::active().get(identity.as_deref().unwrap_or("wm1"))?;
                if output.extension().is_some_and(|e| e.eq_ignore_ascii_case("mp4")) {
                    bail!("output {} is a video: add --video (or --timeline FILE)", output.display());
                }
                check_png_path(&output)?;
                let (width, height) = size.unwrap_or(engine::DEFAULT_SIZE);
                let settings = FrameSettings { width, height, threads, look: look.into(), ..Default::default() };
                let frame = engine::render_frame(&expression, identity, settings)?;
                return write_png(&frame.encode_png(), &output);
            }
            let timeline = match timeline {
                Some(path) => {
                    let bytes = std::fs::metadata(&path).with_context(|| format!("reading {}", path.display()))?.len();
                    if bytes > engine::timeline::MAX_JSON_BYTES as u64 {
                        bail!("{} is {bytes} bytes; a timeline has at most 4 MiB", path.display());
                    }
                    let text = std::fs::read_to_string(&path).with_context(|| format!("reading {}", path.display()))?;
                    Timeline::from_json(&text).with_context(|| format!("in {}", path.display()))?
                }
                None => {
                    let expression = Catalog::built_in().parse(expression.as_deref().unwrap_or_default())?;
                    let timing = ClipTiming { onset_s: onset, apex_s: apex, offset_s: offset, ramp: ramp.into() };
                    let max = engine::timeline::MAX_DURATION_S;
                    for (what, v) in [("--onset", onset), ("--apex", apex), ("--offset", offset)] {
                        if !v.is_finite() || !(0.0..=max).contains(&v) {
                            bail!("{what} {} must be a duration from 0 to {max} seconds", engine::timeline::short_number(v));
                        }
                    }
                    if timing.total_s() > max {
                        bail!("the clip lasts {} s; a video lasts at most {max} s", engine::timeline::short_number(timing.total_s()));
                    }
                    let identity = identity.unwrap_or_else(|| "wm1".into());
                    Timeline::clip(&expression, timing, fps, &identity, size.unwrap_or(engine::DEFAULT_SIZE))
                }
            };
            let av1 = codec == CodecArg::Av1;
            if look.backdrop == Backdrop::Transparent {
                bail!("videos cannot have a transparent backdrop (use it for stills)");
            }
            let video = VideoOutputs { export: export_timeline.as_deref(), frames: frames.as_deref(), poster: poster.as_deref(), av1 };
            render_timeline_video(&timeline, &output, threads, look.into(), &video)
        }
        Command::Stimuli(StimuliCommand::Check { spec }) => {
            let set = SetSpec::load(&spec)?;
            let videos = set.entries.iter().filter(|e| matches!(e.content, stimuli::Content::Video { .. })).count();
            println!(
                "{}: {} stimuli ({} videos, {} images), {} frames to render at {}x{}, seed {}",
                set.name,
                set.entries.len(),
                videos,
                set.entries.len() - videos,
                set.frame_total(),
                set.size.0,
                set.size.1,
                set.seed
            );
            Ok(())
        }
        Command::Stimuli(StimuliCommand::Merge { shards, output }) => {
            let summary = stimuli::merge(&shards, &output).with_context(|| format!("merging into {}", output.display()))?;
            eprintln!("{} shards merged: {} stimuli, {} files in {}", summary.shards, summary.stimuli, summary.files, output.display());
            Ok(())
        }
        Command::Stimuli(StimuliCommand::Key { output }) => {
            let key = stimuli::DitherKey::create_file(&output)?;
            eprintln!("wrote a new dither key to {} (fingerprint {}); keep it private", output.display(), key.fingerprint());
            Ok(())
        }
        Command::Stimuli(StimuliCommand::Build { spec, output, jobs, shard, dither_key, no_dither }) => {
            let set = SetSpec::load(&spec)?;
            let started = std::time::Instant::now();
            let dither = match (dither_key, no_dither) {
                (_, true) => stimuli::Dithering::Off,
                (Some(path), false) => stimuli::Dithering::Key(stimuli::DitherKey::read(&path)?),
                (None, false) => stimuli::Dithering::SetKey,
            };
            let options = stimuli::BuildOptions { jobs, progress: true, dither };
            let summary = match shard {
                Some(shard) => stimuli::build_shard(&set, shard, &output, &options).map_err(anyhow::Error::from),
                None => stimuli::build(&set, &output, &options).map_err(anyhow::Error::from),
            }
            .with_context(|| format!("building {}", spec.display()))?;
            eprintln!(
                "{}{}: {} stimuli in {} ({} rendered, {} up to date; {} frames) in {:.1} s",
                set.name,
                shard.map(|s| format!(" shard {s}")).unwrap_or_default(),
                summary.stimuli,
                output.display(),
                summary.rendered,
                summary.skipped,
                summary.frames_rendered,
                started.elapsed().as_secs_f64()
            );
            Ok(())
        }
        Command::Sheet { set, identity, identities, look, output, tile, columns } => {
            install_identities(identities.as_deref())?;
            check_png_path(&output)?;
            if look.backdrop == Backdrop::Transparent {
                bail!("a contact sheet cannot have a transparent backdrop (render stills with it)");
            }
            let settings = FrameSettings { width: tile.0, height: tile.1, threads: None, look: look.into(), ..Default::default() };
            let sheet = match set {
                SheetSet::Aus => au_sheet(IdentityTable::active().get(&identity)?, settings, columns)?,
                SheetSet::Emotions => emotion_sheet(settings, columns)?,
            };
            write_png(&sheet.compose().encode_png(), &output)
        }
        Command::Analyze(args) => analysis::analyze(args),
        Command::Simulate(args) => analysis::simulate(args),
        Command::Power(args) => analysis::power(args),
        Command::Convert(args) => analysis::convert(args),
    }
}

fn au_sheet(identity: &Identity, settings: FrameSettings, columns: u32) -> anyhow::Result<ContactSheet> {
    let catalog = Catalog::built_in();
    let mut entries: Vec<(String, String)> = vec![("0".into(), "neutral".into())];
    entries.extend(catalog.iter().map(|u| (u.code.to_string(), format!("AU{} {}", u.code, u.name))));
    for unit in catalog.iter().filter(|u| u.unilateral) {
        for side in ["L", "R"] {
            entries.push((format!("{side}{}", unit.code), format!("{side}{} {}", unit.code, unit.name)));
        }
    }
    let mut sheet = ContactSheet::new(columns);
    let bar = crate::progress::bar(entries.len() as u64, "stills", format!("AU sheet of {}", identity.id));
    for (notation, caption) in entries {
        let expression = catalog.parse(&notation)?;
        sheet.push(engine::render_still(&expression, identity, settings)?, caption);
        bar.inc(1);
    }
    bar.finish_and_clear();
    Ok(sheet)
}

fn emotion_sheet(settings: FrameSettings, columns: u32) -> anyhow::Result<ContactSheet> {
    let mut sheet = ContactSheet::new(columns);
    for emotion in EmotionTable::built_in().iter() {
        for identity in IdentityTable::active().iter() {
            let image = engine::render_still(&emotion.expression, identity, settings)?;
            sheet.push(image, format!("{} {} ({})", identity.id, emotion.label, display(&emotion.expression)));
        }
    }
    Ok(sheet)
}

fn display(expression: &Expression) -> String {
    expression.to_string()
}

fn check_png_path(path: &Path) -> anyhow::Result<()> {
    if path.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase).as_deref() != Some("png") {
        bail!("output {} must end in .png", path.display());
    }
    Ok(())
}

/// Writes PNG bytes next to their destination first and renames them, so a failure leaves no file.
fn write_png(bytes: &[u8], path: &Path) -> anyhow::Result<()> {
    let partial = path.with_extension("png.partial");
    std::fs::write(&partial, bytes).with_context(|| format!("writing {}", partial.display()))?;
    std::fs::rename(&partial, path).with_context(|| format!("moving the image into place at {}", path.display()))
}

/// Longest FACS expression accepted on the command line.
const MAX_EXPRESSION_LEN: usize = crate::facs::MAX_NOTATION_LEN;

/// Refuses an over-long expression before parsing it, quoting only its start.
fn check_expression_length(expression: &str) -> anyhow::Result<()> {
    if expression.len() > MAX_EXPRESSION_LEN {
        let start: String = expression.chars().take(32).collect();
        bail!("the expression \"{start}…\" has {} characters; at most {MAX_EXPRESSION_LEN}", expression.len());
    }
    Ok(())
}

/// The optional extra outputs of a video.
struct VideoOutputs<'a> {
    export: Option<&'a Path>,
    frames: Option<&'a Path>,
    poster: Option<&'a Path>,
    av1: bool,
}

/// Renders a timeline to an MP4 (frames in parallel), with the optional extra outputs.
fn render_timeline_video(timeline: &Timeline, output: &Path, threads: Option<usize>, look: Look, outputs: &VideoOutputs) -> anyhow::Result<()> {
    let VideoOutputs { export, frames, poster, av1 } = *outputs;
    if av1 && !cfg!(feature = "av1") {
        bail!("this facslab was built without AV1 support (cargo build --features av1)");
    }
    if output.extension().and_then(|e| e.to_str()).map(str::to_ascii_lowercase).as_deref() != Some("mp4") {
        bail!("output {} must end in .mp4 for a video", output.display());
    }
    timeline.validate(Catalog::built_in())?;
    IdentityTable::active().get(&timeline.identity)?;
    if let Some(path) = export {
        stimuli::build::write_atomic(path, timeline.to_json().as_bytes())?;
    }
    let settings = FrameSettings { width: timeline.size[0], height: timeline.size[1], threads: Some(1), look, ..Default::default() };
    let pool = rayon::ThreadPoolBuilder::new().num_threads(threads.unwrap_or(0)).build()?;
    let mut first = None;
    let mut all_frames = Vec::new();
    let bar = crate::progress::bar(timeline.frame_count() as u64, "frames", "video");
    let bytes = pool.install(|| {
        stimuli::render_video(timeline, settings, frames, true, None, None, None, &mut |frame, image| {
            bar.set_position(frame as u64 + 1);
            if frame == 0 {
                first = Some(image.clone());
            }
            if av1 {
                all_frames.push(image.clone());
            }
        })
    })?;
    #[cfg(feature = "av1")]
    let bytes = if av1 { engine::video::encode_av1_mp4(&all_frames, timeline.fps)? } else { bytes };
    drop(all_frames);
    bar.finish_and_clear();
    stimuli::build::write_atomic(output, &bytes)?;
    if let (Some(path), Some(image)) = (poster, first) {
        check_png_path(path)?;
        write_png(&image.encode_png(), path)?;
    }
    let (w, h) = engine::video::even_size(timeline.size[0], timeline.size[1]);
    if (w, h) != (timeline.size[0], timeline.size[1]) {
        eprintln!("note: {}x{} frames were padded to {w}x{h} for the video encoder", timeline.size[0], timeline.size[1]);
    }
    Ok(())
}

/// `facslab catalog --appearance AU|all`: the appearance specification, as Markdown.
fn print_appearance(which: &str) -> anyhow::Result<()> {
    let catalog = Catalog::built_in();
    let spec = AppearanceSpec::built_in();
    let text = spec.to_markdown(catalog);
    if which.eq_ignore_ascii_case("all") {
        print!("{text}");
        return Ok(());
    }
    let number = which.trim();
    let number = number.get(..2).filter(|p| p.eq_ignore_ascii_case("au")).map_or(number, |_| &number[2..]);
    let code = number
        .parse::<u16>()
        .ok()
        .filter(|code| catalog.get(AuCode(*code)).is_some())
        .with_context(|| {
            let shown: String = which.chars().take(24).collect();
            format!("--appearance: `{shown}` is not a catalog AU number or `all` (see `facslab catalog`)")
        })?;
    let heading = format!("\n## AU{code} ");
    let section = text
        .split_once(&heading)
        .map(|(_, rest)| rest.split_once("\n## ").map_or(rest, |(own, _)| own))
        .context("the appearance specification has no section for this AU")?;
    print!("## AU{code} {section}");
    Ok(())
}
