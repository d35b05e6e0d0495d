//! `facslab studio`: the editor in the browser and the live render API ([`crate::studio`]).

use std::net::SocketAddr;

/// `facslab studio`'s options.
#[derive(Debug, clap::Args)]
pub struct StudioArgs {
    /// Address to listen on (127.0.0.1 keeps the studio to this computer).
    #[arg(long, default_value = "127.0.0.1")]
    pub host: std::net::IpAddr,
    /// Port to listen on (0 = any free port).
    #[arg(long, default_value_t = 8090)]
    pub port: u16,
    /// Also offer the people of this identity file (same format as stimuli/engine/identities.toml).
    #[arg(long)]
    pub identities: Option<std::path::PathBuf>,
}

/// Runs `facslab studio` until Ctrl-C.
pub fn studio_command(args: StudioArgs) -> anyhow::Result<()> {
    crate::cli::install_identities(args.identities.as_deref())?;
    let runtime = tokio::runtime::Builder::new_multi_thread().enable_all().build()?;
    runtime.block_on(crate::studio::serve(SocketAddr::new(args.host, args.port), |bound| {
        println!("facslab studio: http://{bound}/");
        use std::io::Write as _;
        let _ = std::io::stdout().flush();
    }))?;
    Ok(())
}
