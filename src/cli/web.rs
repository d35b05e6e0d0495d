//! The study platform's commands: `serve`, `demo`, `study`, `admin` and `export`.

use std::net::{IpAddr, SocketAddr};
use std::path::{Path, PathBuf};

use anyhow::{Context, bail};
use clap::{Args, Subcommand};

use crate::web::{AppState, serve};
use crate::db::{Db, DbUrl};
use crate::db::admin::Role;
use crate::db::export::{Format, Scope};
use crate::db::studies::StudyStatus;
use crate::study::StudyDesign;

/// The demo's stimulus set and study designs (compiled in, so `demo` runs anywhere).
const DEMO_SET: &str = include_str!("../../stimuli/sets/demo.toml");
const DEMO_STUDIES: [&str; 2] = [include_str!("../../studies/demo-emotions.toml"), include_str!("../../studies/demo-coding.toml")];

#[derive(Args)]
pub struct ServeArgs {
    /// The study database: an SQLite file (created with its schema if missing) or a
    /// `postgres://user@host/database` URL (several servers can share one).
    #[arg(long, default_value = "facslab.db")]
    pub db: DbUrl,
    /// Address to listen on.
    #[arg(long, default_value = "127.0.0.1")]
    pub host: IpAddr,
    /// Port to listen on (0 = any free port).
    #[arg(long, default_value_t = 8080)]
    pub port: u16,
    /// The address people use (e.g. https://faces.example.org behind a TLS proxy): with
    /// https, cookies are marked Secure and responses carry Strict-Transport-Security.
    #[arg(long)]
    pub public_url: Option<String>,
    /// A reverse proxy in front appends the client's address to X-Forwarded-For (used for
    /// the per-address limits instead of the proxy's own address).
    #[arg(long)]
    pub trusted_proxy: bool,
    /// Starts one client address may make in 5 minutes (a lab behind one address may need more).
    #[arg(long, default_value_t = 30, value_parser = clap::value_parser!(u32).range(1..=100_000))]
    pub starts_per_address: u32,
}

impl ServeArgs {
    /// The edge configuration these options ask for.
    pub fn edge(&self) -> anyhow::Result<crate::web::EdgeConfig> {
        let https = match self.public_url.as_deref() {
            None => false,
            Some(url) if url.starts_with("https://") && url.len() > 8 => true,
            Some(url) if url.starts_with("http://") && url.len() > 7 => false,
            Some(url) => bail!("--public-url \"{}\" is not an http:// or https:// URL", url.chars().take(60).collect::<String>()),
        };
        Ok(crate::web::EdgeConfig { https, trusted_proxy: self.trusted_proxy, starts_per_address: self.starts_per_address })
    }
}

#[derive(Args)]
pub struct DemoArgs {
    /// Directory for the demo's stimulus set and database.
    #[arg(short, long, default_value = "facslab-demo")]
    pub output: PathBuf,
    /// Address to listen on.
    #[arg(long, default_value = "127.0.0.1")]
    pub host: IpAddr,
    /// Port to listen on (0 = any free port).
    #[arg(long, default_value_t = 8080)]
    pub port: u16,
    /// Build the set and the studies, print the URLs, and exit without serving.
    #[arg(long)]
    pub no_serve: bool,
    /// The study database (default: `study.db` in the output directory; or a `postgres://` URL).
    #[arg(long)]
    pub db: Option<DbUrl>,
}

#[derive(Subcommand)]
pub enum StudyCommand {
    /// Create a study from a design file and a built stimulus set.
    #[command(after_help = "Examples:\n  facslab study create studies/exp3-emotions.toml --db lab.db --open\n  facslab study create my-study.toml --set out/exp3 --db lab.db")]
    Create {
        /// The study design (TOML; templates in studies/).
        design: PathBuf,
        /// The built stimulus set [default: the design's `stimuli`, relative to the design file].
        #[arg(long)]
        set: Option<PathBuf>,
        #[arg(long, default_value = "facslab.db")]
        db: DbUrl,
        /// Open the study for participants right away.
        #[arg(long)]
        open: bool,
    },
    /// Check a study design without creating anything.
    #[command(after_help = "Example:\n  facslab study check studies/exp1-coders.toml")]
    Check { design: PathBuf },
    /// List the studies with their progress.
    #[command(after_help = "Example:\n  facslab study list --db lab.db")]
    List {
        #[arg(long, default_value = "facslab.db")]
        db: DbUrl,
    },
    /// Open, close or return a study to draft.
    #[command(after_help = "Example:\n  facslab study status exp3 open --db lab.db")]
    Status {
        slug: String,
        #[arg(value_parser = parse_status)]
        status: StudyStatus,
        #[arg(long, default_value = "facslab.db")]
        db: DbUrl,
    },
}

#[derive(Subcommand)]
pub enum AdminCommand {
    /// Create an admin account (the password is read from FACSLAB_PASSWORD or asked for).
    #[command(after_help = "Examples:\n  facslab admin create alice --db lab.db                 # asks for the password\n  FACSLAB_PASSWORD=... facslab admin create bob --role viewer --db lab.db")]
    Create {
        username: String,
        #[arg(long, default_value = "admin", value_parser = ["admin", "researcher", "viewer"])]
        role: String,
        #[arg(long, default_value = "facslab.db")]
        db: DbUrl,
    },
    /// Make a token for the export API that reaches one study until it expires (printed once).
    #[command(after_help = "Example:\n  facslab admin token alice --study exp3 --days 30 --label nightly-backup --db lab.db\n  curl -H \"Authorization: Bearer TOKEN\" http://host/api/v1/studies/exp3/responses.csv")]
    Token {
        username: String,
        /// The study the token reaches (its slug).
        #[arg(long)]
        study: String,
        /// What the token may do (at most the owner's role).
        #[arg(long, default_value = "viewer", value_parser = ["viewer", "researcher"])]
        role: String,
        /// Days until the token expires (1 to 365).
        #[arg(long, default_value_t = 30)]
        days: u32,
        #[arg(long, default_value = "api")]
        label: String,
        #[arg(long, default_value = "facslab.db")]
        db: DbUrl,
    },
    /// Write a consistent copy of the database while the server runs (VACUUM INTO).
    #[command(after_help = "Example:\n  facslab admin backup backup-2026-11-23.db --db lab.db")]
    Backup {
        output: PathBuf,
        #[arg(long, default_value = "facslab.db")]
        db: DbUrl,
    },
}

#[derive(Args)]
pub struct ExportArgs {
    /// The study's slug.
    #[arg(long)]
    pub study: String,
    /// responses.csv (long, the `analyze` input), wide.csv, responses.json, codebook.csv, or
    /// psych-ds (a Psych-DS dataset directory: data files, their descriptions, the ground truth).
    #[arg(long, default_value = "responses.csv")]
    pub format: String,
    /// Include every participation except withdrawn ones (default: completed, not excluded).
    #[arg(long)]
    pub all: bool,
    #[arg(long, default_value = "facslab.db")]
    pub db: DbUrl,
    /// Output file (psych-ds: a directory that does not exist yet).
    #[arg(short, long)]
    pub output: PathBuf,
}

/// A study status given on the command line (draft, open or closed).
fn parse_status(text: &str) -> Result<StudyStatus, String> {
    let allowed: Vec<_> = StudyStatus::ALL.iter().map(|s| s.as_str()).collect();
    StudyStatus::parse(text).ok_or_else(|| format!("not one of {}", allowed.join(", ")))
}

fn runtime() -> anyhow::Result<tokio::runtime::Runtime> {
    Ok(tokio::runtime::Builder::new_multi_thread().enable_all().build()?)
}

async fn open(db: &DbUrl) -> anyhow::Result<Db> {
    Db::open(db).await.with_context(|| format!("opening the study database {db}"))
}

pub fn serve_command(args: ServeArgs) -> anyhow::Result<()> {
    runtime()?.block_on(async {
        let edge = args.edge()?;
        let db = open(&args.db).await?;
        let state = AppState::new(db)?.with_edge(edge);
        serve(state, SocketAddr::new(args.host, args.port), |addr| {
            println!("facslab study server on http://{addr}/admin  (database {}; Ctrl-C stops)", args.db);
        })
        .await
    })
}

/// The stimulus set of a design: `--set`, else the design's `stimuli` relative to the design
/// file; the label sets that set carries are registered, so the design may name one of them.
fn design_set(text: &str, design: &Path, set: Option<PathBuf>) -> anyhow::Result<PathBuf> {
    let set = set.unwrap_or_else(|| {
        let named = toml::from_str::<toml::Table>(text).ok().and_then(|t| t.get("stimuli")?.as_str().map(PathBuf::from));
        design.parent().unwrap_or(Path::new(".")).join(named.unwrap_or_default())
    });
    crate::stimuli::labels::register_set(&set)?;
    Ok(set)
}

pub fn study_command(command: StudyCommand) -> anyhow::Result<()> {
    match command {
        StudyCommand::Check { design } => {
            let text = std::fs::read_to_string(&design).with_context(|| format!("reading {}", design.display()))?;
            design_set(&text, &design, None)?;
            let d = StudyDesign::from_toml(&text).with_context(|| format!("in {}", design.display()))?;
            println!("{}: {} study \"{}\", {} Likert item(s), {} attention check(s)", d.slug, d.task.as_str(), d.title, d.items.len(), d.attention.checks.len());
            Ok(())
        }
        StudyCommand::Create { design, set, db, open: open_now } => runtime()?.block_on(async {
            let text = std::fs::read_to_string(&design).with_context(|| format!("reading {}", design.display()))?;
            let set = design_set(&text, &design, set)?;
            StudyDesign::from_toml(&text).with_context(|| format!("in {}", design.display()))?;
            let db = open(&db).await?;
            let d = db.create_study_from(&text, &set, open_now).await.with_context(|| format!("creating the study of {}", design.display()))?;
            println!("created study \"{}\" ({}) over {}; participants start at /s/{}", d.slug, if open_now { StudyStatus::Open } else { StudyStatus::Draft }, set.display(), d.slug);
            Ok(())
        }),
        StudyCommand::List { db } => runtime()?.block_on(async {
            let db = open(&db).await?;
            for s in db.studies().await? {
                let p = db.progress(s.id).await?;
                println!("{:<20} {:<7} completed {:>4}  in progress {:>4}  abandoned {:>4}  responses {:>6}  {}", s.slug, s.status, p.completed, p.active + p.reserved, p.abandoned, p.responses, s.title);
            }
            Ok(())
        }),
        StudyCommand::Status { slug, status, db } => runtime()?.block_on(async {
            open(&db).await?.set_study_status(&slug, status).await?;
            println!("{slug}: {status}");
            Ok(())
        }),
    }
}

fn read_password() -> anyhow::Result<String> {
    if let Ok(p) = std::env::var("FACSLAB_PASSWORD") {
        return Ok(p);
    }
    eprint!("password (at least 10 characters): ");
    let mut line = String::new();
    std::io::stdin().read_line(&mut line)?;
    Ok(line.trim_end_matches(['\n', '\r']).to_string())
}

pub fn admin_command(command: AdminCommand) -> anyhow::Result<()> {
    match command {
        AdminCommand::Create { username, role, db } => {
            let password = read_password()?;
            runtime()?.block_on(async {
                let role = Role::parse(&role).unwrap_or(Role::Viewer);
                open(&db).await?.create_admin(&username, &password, role).await?;
                println!("created {} \"{username}\"", role.as_str());
                Ok(())
            })
        }
        AdminCommand::Token { username, study, role, days, label, db } => runtime()?.block_on(async {
            let role = Role::parse(&role).unwrap_or(Role::Viewer);
            let token = open(&db).await?.create_api_token(&username, &study, role, days, &label).await?;
            println!("{token}");
            eprintln!("(shown once: keep it like a password)");
            Ok(())
        }),
        AdminCommand::Backup { output, db } => runtime()?.block_on(async {
            if output.exists() {
                bail!("{} exists already", output.display());
            }
            open(&db).await?.backup(&output).await?;
            println!("wrote {}", output.display());
            Ok(())
        }),
    }
}

/// A whole export of a study as text.
async fn export_text(db: &Db, slug: &str, file: &str, scope: Scope) -> anyhow::Result<String> {
    let row = db.study_by_slug(slug).await?.with_context(|| format!("no study \"{slug}\" in this database"))?;
    let design = row.design()?;
    if file == "codebook.csv" {
        return Ok(crate::db::export::codebook(&design));
    }
    let format = Format::parse(file).with_context(|| format!("unknown format \"{file}\" (responses.csv, wide.csv, responses.json, codebook.csv, psych-ds)"))?;
    let stimuli = crate::db::studies::trial_stimulus_ids(&db.study_stimuli(row.id).await?);
    let mut rx = db.export(row.id, &design, stimuli, format, scope);
    let mut text = String::new();
    while let Some(chunk) = rx.recv().await {
        text.push_str(&chunk?);
    }
    Ok(text)
}

pub fn export_command(args: ExportArgs) -> anyhow::Result<()> {
    runtime()?.block_on(async {
        let db = open(&args.db).await?;
        let scope = if args.all { Scope::All } else { Scope::Completed };
        if args.format == "psych-ds" {
            let row = db.study_by_slug(&args.study).await?.with_context(|| format!("no study \"{}\" in this database", args.study))?;
            db.psych_ds(row.id, &row.design()?, Path::new(&row.set_dir), scope, &args.output).await?;
            println!("wrote the Psych-DS dataset {}", args.output.display());
            return Ok(());
        }
        let text = export_text(&db, &args.study, &args.format, scope).await?;
        crate::stimuli::build::write_atomic(&args.output, text.as_bytes())?;
        println!("wrote {}", args.output.display());
        Ok(())
    })
}

#[derive(Args)]
pub struct ReportArgs {
    /// The study's slug.
    #[arg(long)]
    pub study: String,
    #[arg(long, default_value = "facslab.db")]
    pub db: DbUrl,
    /// Output directory for the report.
    #[arg(short, long)]
    pub output: PathBuf,
    /// Include every participation except withdrawn ones (default: completed, not excluded).
    #[arg(long)]
    pub all: bool,
    /// Count a coded AU as recognised only if its side matches.
    #[arg(long)]
    pub match_side: bool,
    /// Count a coded AU as recognised only if its intensity letter matches.
    #[arg(long)]
    pub match_intensity: bool,
}

/// `facslab report --study`: the study's judgements and its set's manifest, analysed in memory
/// as `facslab analyze` analyses files. The rows used are kept beside the report as
/// `OUTPUT.inputs/responses.csv` (the same bytes as `facslab export`), for the record only.
pub fn report_command(args: ReportArgs) -> anyhow::Result<()> {
    let started = std::time::Instant::now();
    let scope = if args.all { Scope::All } else { Scope::Completed };
    let (rows, set_dir) = runtime()?.block_on(async {
        let db = open(&args.db).await?;
        let row = db.study_by_slug(&args.study).await?.with_context(|| format!("no study \"{}\" in {}", args.study, args.db))?;
        anyhow::Ok((db.long_rows(row.id, scope).await?, PathBuf::from(row.set_dir)))
    })?;
    if rows.is_empty() {
        bail!("study \"{}\" has no responses to analyse yet (only completed, non-excluded participants count; --all adds the rest)", args.study);
    }
    let catalog = crate::facs::Catalog::built_in();
    let manifest_path = set_dir.join("manifest.csv");
    let manifest = crate::analysis::manifest::Manifest::read(&manifest_path, catalog)?;
    let responses = crate::analysis::responses::Responses::from_rows("responses.csv", &rows, &manifest, catalog)?;
    let options = crate::analysis::coding::CodingOptions { match_side: args.match_side, match_intensity: args.match_intensity };
    let report = crate::report::build(&manifest, &responses, options, std::path::Path::new("responses.csv"), &manifest_path);
    crate::report::write(&report, &args.output)?;
    let mut text = crate::analysis::responses::LONG_HEADER.to_string();
    rows.iter().for_each(|r| r.write_csv(&mut text));
    let inputs = args.output.with_extension("inputs");
    std::fs::create_dir_all(&inputs).with_context(|| format!("creating {}", inputs.display()))?;
    crate::stimuli::build::write_atomic(&inputs.join("responses.csv"), text.as_bytes())?;
    eprintln!("analysed {} rows in {:.2} s; report in {}", responses.rows, started.elapsed().as_secs_f64(), args.output.display());
    Ok(())
}

/// `facslab demo`: the demo set, two open demo studies, an admin account, the server.
pub fn demo_command(args: DemoArgs) -> anyhow::Result<()> {
    let set_dir = args.output.join("stimuli");
    let spec = crate::stimuli::SetSpec::from_toml(DEMO_SET)?;
    eprintln!("building the demo stimulus set in {} ...", set_dir.display());
    // Dithered with the set's own key (made on the first run, kept in the set directory).
    crate::stimuli::build(&spec, &set_dir, &crate::stimuli::build::BuildOptions { jobs: None, progress: true, ..Default::default() })?;
    let db_path = args.db.clone().unwrap_or_else(|| DbUrl::Sqlite(args.output.join("study.db")));
    runtime()?.block_on(async {
        let db = open(&db_path).await?;
        let mut slugs = Vec::new();
        for text in DEMO_STUDIES {
            let design = StudyDesign::from_toml(text)?;
            if db.study_by_slug(&design.slug).await?.is_none() {
                db.create_study_from(text, &set_dir, true).await?;
            }
            slugs.push(design.slug);
        }
        let password_note = if db.admin_count().await? == 0 {
            let password = crate::db::secret_token()[..16].to_string();
            db.create_admin("admin", &password, Role::Admin).await?;
            let note = format!("user admin, password {password}");
            std::fs::write(args.output.join("admin-password.txt"), format!("{note}\n"))?;
            note
        } else {
            format!("password in {}", args.output.join("admin-password.txt").display())
        };
        let print = |addr: SocketAddr| {
            println!("facslab demo (database {db_path}):");
            for slug in &slugs {
                println!("  participant: http://{addr}/s/{slug}");
            }
            println!("  admin:       http://{addr}/admin   ({password_note})");
        };
        if args.no_serve {
            print(SocketAddr::new(args.host, args.port));
            return Ok(());
        }
        let state = AppState::new(db)?;
        serve(state, SocketAddr::new(args.host, args.port), |addr| {
            print(addr);
            println!("Ctrl-C stops the server.");
        })
        .await
    })
}
