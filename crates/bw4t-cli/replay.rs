//! `bw4t replay`: check a replay by re-simulating it, or summarise it.

use std::path::PathBuf;

use anyhow::{Context, Result, bail};
use bw4t_runner::{Verdict, verify_replay};
use clap::{Args, Subcommand};

/// Options of `bw4t replay`.
#[derive(Args)]
pub struct ReplayArgs {
    #[command(subcommand)]
    command: ReplayCommand,
}

#[derive(Subcommand)]
enum ReplayCommand {
    /// Re-simulate and report the first tick whose state differs, or that all match.
    Verify {
        /// The replay file.
        file: PathBuf,
    },
    /// Print what the replay holds.
    Show {
        /// The replay file.
        file: PathBuf,
    },
    /// Serve the browser page on a replay: play, pause, speed, scrub to any tick.
    View {
        /// The replay file.
        file: PathBuf,
        /// Port for the page; 0 picks a free one.
        #[arg(long, default_value_t = 12380)]
        http: u16,
        /// Address to listen on.
        #[arg(long, default_value = "127.0.0.1")]
        bind: std::net::IpAddr,
    },
}

/// Runs a replay command.
pub fn run(args: &ReplayArgs) -> Result<()> {
    let (file, verify) = match &args.command {
        ReplayCommand::Verify { file } => (file, true),
        ReplayCommand::Show { file } => (file, false),
        ReplayCommand::View { file, http, bind } => return view(file, *bind, *http),
    };
    let text = std::fs::read_to_string(file).with_context(|| format!("cannot read {}", file.display()))?;
    let (verdict, summary) =
        verify_replay(&text).with_context(|| format!("{} is not a usable replay", file.display()))?;
    if verify {
        return match verdict {
            Verdict::Matches { digests, ticks } => {
                println!("ok: all {digests} digests match ({ticks} ticks re-simulated)");
                Ok(())
            }
            Verdict::Differs { tick, expected, found } => {
                bail!("the replay differs at tick {tick}: recorded {expected}, re-simulated {found}")
            }
        };
    }
    let h = &summary.header;
    println!("{} (format {}), map '{}', seed {}", h.program, h.format, h.map, h.seed);
    println!(
        "config: {} ticks/s, speed {}, robot collisions {}",
        h.ticks_per_second,
        h.speed,
        if h.robot_collisions { "on" } else { "off" }
    );
    println!("players: {}", summary.players.join(", "));
    println!(
        "{} ticks, {} actions, end: {}",
        summary.game_ticks,
        summary.actions,
        summary.reason.as_deref().unwrap_or("(none recorded)")
    );
    println!(
        "sequence {}/{}: {}",
        summary.sequence_index,
        summary.sequence.len(),
        summary.sequence.join(" ")
    );
    match verdict {
        Verdict::Matches { digests, .. } => println!("verified: all {digests} digests match"),
        Verdict::Differs { tick, .. } => println!("NOT verified: differs at tick {tick}"),
    }
    Ok(())
}

/// Serves the page on a replay until interrupted.
fn view(file: &std::path::Path, bind: std::net::IpAddr, port: u16) -> Result<()> {
    let text = std::fs::read_to_string(file).with_context(|| format!("cannot read {}", file.display()))?;
    let (header, map, frames) = bw4t_runner::replay_frames(&text)
        .with_context(|| format!("{} is not a usable replay", file.display()))?;
    let last = frames.len().saturating_sub(1);
    let site = bw4t_server::Site {
        map_json: bw4t_protocol::map_layout(&map).to_string(),
        info_json:
            serde_json::json!({"mode": "replay", "protocol": bw4t_protocol::VERSION, "map": header.map})
                .to_string(),
        replay: Some((
            serde_json::json!({
                "ticks": last,
                "tick_hz": header.ticks_per_second,
                "map": header.map,
                "seed": header.seed,
                "players": header.robots,
            })
            .to_string(),
            frames,
        )),
    };
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()
        .context("cannot start the runtime")?;
    runtime.block_on(async {
        let addr = std::net::SocketAddr::new(bind, port);
        let listener =
            tokio::net::TcpListener::bind(addr).await.with_context(|| format!("cannot listen on {addr}"))?;
        println!("http on {}", listener.local_addr().context("no local address")?);
        eprintln!(
            "bw4t: replay of map '{}', seed {}, {last} ticks; Ctrl-C (or SIGTERM) stops",
            header.map, header.seed
        );
        let ids = std::sync::Arc::new(std::sync::atomic::AtomicU64::new(1));
        let served =
            tokio::spawn(bw4t_server::serve_site(listener, std::sync::Arc::new(site), None, ids, 64, 256));
        crate::serve::stop_signal().await;
        served.abort();
        anyhow::Ok(())
    })
}

/// A buffered file for a replay, or none without a path.
pub fn writer(path: Option<&std::path::Path>) -> Result<Option<Box<dyn std::io::Write + Send>>> {
    let Some(path) = path else { return Ok(None) };
    let file = std::fs::File::create(path)
        .with_context(|| format!("cannot create replay file {}", path.display()))?;
    Ok(Some(Box::new(std::io::BufWriter::new(file))))
}
