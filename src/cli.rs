//! The command line: parses arguments with clap and calls the library. The only place where
//! errors become messages for people (with `anyhow` context) and exit codes.

use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::{Context, bail};
use clap::{Parser, Subcommand, ValueEnum};

use crate::engine::identity::{Identity, IdentityTable};
use crate::engine::image::RgbImage;
use crate::engine::sheet::ContactSheet;
use crate::engine::{self, FrameSettings};
use crate::facs::{Catalog, EmotionTable, Expression};

#[derive(Parser)]
#[command(name = "facslab", version, about = "FACS-controlled facial-expression stimuli, studies and validation reports")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// List the Action Units facslab can show.
    #[command(after_help = "Example:\n  facslab catalog")]
    Catalog,

    /// List the identities (people) facslab can render.
    #[command(after_help = "Example:\n  facslab identities")]
    Identities,

    /// Render one expression as a PNG still.
    #[command(after_help = "Examples:\n  facslab render 1+2+5B+26 --identity wf1 -o surprise.png\n  facslab render L12C+R14 --identity bm2 -o smirk.png --size 970x960\n  facslab render 12@0.42 -o faint-smile.png\n\nFACS notation: AUs joined by '+'; L/R prefix = one side; A-E suffix = intensity\n(15/30/55/85/100 %), or @x for a fraction in [0, 1]; no suffix = E; 0 = neutral.")]
    Render {
        /// The expression in FACS notation, e.g. "1+2+4B+L12C".
        expression: String,
        /// Who shows it (see `facslab identities`).
        #[arg(long, default_value = "wm1")]
        identity: String,
        /// Output PNG file.
        #[arg(short, long)]
        output: PathBuf,
        /// Image size as WIDTHxHEIGHT.
        #[arg(long, default_value = "485x480", value_parser = parse_size)]
        size: (u32, u32),
        /// Rendering threads (default: all cores; the image is the same either way).
        #[arg(long)]
        threads: Option<usize>,
    },

    /// Render a labelled contact sheet for a visual audit.
    #[command(after_help = "Examples:\n  facslab sheet -o aus.png                      # every AU at E, then L/R variants, on wm1\n  facslab sheet --set emotions -o emotions.png  # EmFACS prototypes at 100 % on all eight identities")]
    Sheet {
        /// What to put on the sheet.
        #[arg(long, value_enum, default_value = "aus")]
        set: SheetSet,
        /// Identity for the AU sheet.
        #[arg(long, default_value = "wm1")]
        identity: String,
        /// Output PNG file.
        #[arg(short, long)]
        output: PathBuf,
        /// Size of each tile as WIDTHxHEIGHT.
        #[arg(long, default_value = "242x240", value_parser = parse_size)]
        tile: (u32, u32),
        /// Tiles per row.
        #[arg(long, default_value_t = 8)]
        columns: u32,
    },

    /// Compute the validation report from responses and the stimulus manifest.
    #[command(after_help = "Examples:\n  facslab analyze --responses responses.csv --manifest manifest.csv -o report\n  facslab analyze --responses r.csv --manifest m.csv -o strict --match-side --match-intensity\n\nWrites report.json (every number), report.html (tables and plots), one CSV per table and\nthe plots as PNG files. Inputs are validated in full first; on any error nothing is written.")]
    Analyze(crate::analysis::cli::AnalyzeArgs),

    /// Write synthetic responses and a manifest shaped like one of the seed's experiments.
    #[command(after_help = "Examples:\n  facslab simulate --design exp1 --seed 1 -o sim1           # 3 coders, 49 single AUs\n  facslab simulate --design exp2 --accuracy 0.8 -o sim2       # 54 AU combinations\n  facslab simulate --design exp3 --participants 40 --groups local,amt --missing 0.02 -o sim3\n\nWrites DIR/responses.csv and DIR/manifest.csv; the same options give the same bytes.")]
    Simulate(crate::analysis::cli::SimulateArgs),
}

#[derive(Clone, Copy, ValueEnum)]
enum SheetSet {
    /// Every AU at E, then each unilateral AU on the left and on the right.
    Aus,
    /// Every EmFACS prototype at 100 % on every identity.
    Emotions,
}

fn parse_size(text: &str) -> Result<(u32, u32), String> {
    let bad = || format!("\"{text}\" is not a size like 485x480");
    let (w, h) = text.split_once(['x', 'X']).ok_or_else(bad)?;
    let (w, h) = (w.trim().parse().map_err(|_| bad())?, h.trim().parse().map_err(|_| bad())?);
    if !(16..=4096).contains(&w) || !(16..=4096).contains(&h) {
        return Err(format!("size {w}x{h} is out of range (each side 16..=4096)"));
    }
    Ok((w, h))
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
        Command::Catalog => {
            for unit in Catalog::built_in().iter() {
                let side = if unit.unilateral { "L/R" } else { "" };
                println!("{:>3}  {:<26} {:<22} {:<4} {}", unit.code, unit.name, unit.region.label(), side, unit.appearance);
            }
            Ok(())
        }
        Command::Identities => {
            for identity in IdentityTable::built_in().iter() {
                println!("{:<6} {}", identity.id, identity.description);
            }
            Ok(())
        }
        Command::Render { expression, identity, output, size, threads } => {
            let expression = Catalog::built_in().parse(&expression)?;
            let identity = IdentityTable::built_in().get(&identity)?;
            check_png_path(&output)?;
            let settings = FrameSettings { width: size.0, height: size.1, threads };
            let image = engine::render_still(&expression, identity, settings)?;
            write_png(&image, &output)
        }
        Command::Sheet { set, identity, output, tile, columns } => {
            check_png_path(&output)?;
            let settings = FrameSettings { width: tile.0, height: tile.1, threads: None };
            let sheet = match set {
                SheetSet::Aus => au_sheet(IdentityTable::built_in().get(&identity)?, settings, columns)?,
                SheetSet::Emotions => emotion_sheet(settings, columns)?,
            };
            write_png(&sheet.compose(), &output)
        }
        Command::Analyze(args) => crate::analysis::cli::analyze(args),
        Command::Simulate(args) => crate::analysis::cli::simulate(args),
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
    let total = entries.len();
    for (n, (notation, caption)) in entries.into_iter().enumerate() {
        eprint!("\rrendering {}/{total}", n + 1);
        let expression = catalog.parse(&notation)?;
        sheet.push(engine::render_still(&expression, identity, settings)?, caption);
    }
    eprintln!();
    Ok(sheet)
}

fn emotion_sheet(settings: FrameSettings, columns: u32) -> anyhow::Result<ContactSheet> {
    let mut sheet = ContactSheet::new(columns);
    for emotion in EmotionTable::built_in().iter() {
        for identity in IdentityTable::built_in().iter() {
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

/// Writes the PNG next to its destination first and renames it, so a failure leaves no file.
fn write_png(image: &RgbImage, path: &Path) -> anyhow::Result<()> {
    let partial = path.with_extension("png.partial");
    std::fs::write(&partial, image.encode_png()).with_context(|| format!("writing {}", partial.display()))?;
    std::fs::rename(&partial, path).with_context(|| format!("moving the image into place at {}", path.display()))
}
