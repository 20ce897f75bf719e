//! `bw4t study STUDY.toml`: serves a study (its pages' API and its conditions' matches) on
//! the many-match server until stopped, recording into a data directory; `bw4t study
//! export DIR`: that directory as tidy CSV (docs/STUDIES.md).

use std::net::SocketAddr;
use std::path::{Path, PathBuf};
use std::time::Duration;

use anyhow::{Context, Result, bail};
use bw4t_server::{ArenaConfig, ResultsStore};
use bw4t_study::{Study, StudyServer};
use clap::{Args, Subcommand};

/// Options of `bw4t study`.
#[derive(Args)]
#[command(args_conflicts_with_subcommands = true, subcommand_negates_reqs = true)]
pub(crate) struct StudyArgs {
    #[command(subcommand)]
    command: Option<StudyCommand>,
    /// The study file (every key: docs/STUDIES.md, examples/study/study.toml).
    #[arg(value_name = "STUDY.toml", required = true)]
    file: Option<PathBuf>,
    /// Where the study's data goes: a copy of the study file, the participants' records
    /// (the SQLite database study.sqlite3),
    /// the matches' results and replays. A restarted server continues from it.
    #[arg(long, value_name = "DIR")]
    data: Option<PathBuf>,
    /// A dry run: serve the study on free local ports into a fresh data directory
    /// (default study-data-dry-run), play N scripted participants through every page
    /// (every tenth declines consent), export the data and stop. The conditions play
    /// lockstep, as fast as the scripted players answer.
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..=1000))]
    simulate: Option<u32>,
    /// Run with a study file that differs from the one the data directory was started
    /// with (the old copy is kept as study-MS.toml). Pages and conditions must still mean
    /// what they meant for the participants so far.
    #[arg(long)]
    changed_study: bool,
    /// Address to listen on.
    #[arg(long, default_value = "127.0.0.1")]
    bind: std::net::IpAddr,
    /// The protocol's TCP port (agents, tests); 0 picks a free one.
    #[arg(long, default_value_t = 12300)]
    port: u16,
    /// The web port: participants' page, the dashboard, the API; 0 picks a free one.
    #[arg(long, default_value_t = 8080)]
    http: u16,
    /// The operator's token (dashboard, live view); one is made and printed when omitted.
    #[arg(long)]
    operator_token: Option<String>,
    /// Let pages from this origin open WebSockets on the web port (repeatable; `*`: any).
    #[arg(long, value_name = "URL", value_parser = bw4t_server::parse_origin)]
    allow_origin: Vec<String>,
    /// Connections accepted at once.
    #[arg(long, value_name = "N", default_value_t = 256)]
    max_connections: usize,
    /// Connections (and WebSockets) one source address may have open at once; raise it
    /// for participants who share one address.
    #[arg(long, value_name = "N", default_value_t = bw4t_server::ServerConfig::default().max_per_source)]
    max_per_source: usize,
    /// New participants one source address may make a minute (more get 429): raise it
    /// for a lab whose computers share one address.
    #[arg(long, value_name = "N", default_value_t = bw4t_study::StudyBudget::ARRIVALS_PER_MINUTE,
          value_parser = clap::value_parser!(u32).range(1..=1_000_000))]
    arrivals_per_minute: u32,
    /// A reverse proxy in front of the web port, whose `X-Forwarded-For` names the
    /// participant a WebSocket or a request is counted for (repeatable).
    #[arg(long, value_name = "IP")]
    trust_proxy: Vec<std::net::IpAddr>,
    #[command(flatten)]
    log: crate::serving::LogArgs,
}

#[derive(Subcommand)]
enum StudyCommand {
    /// Write a study's data as CSV (events, trials, answers, participants), metadata.json
    /// and the trials' replays.
    Export(ExportArgs),
}

#[derive(Args)]
struct ExportArgs {
    /// The study's data directory (`bw4t study --data DIR`).
    dir: PathBuf,
    /// Where to write (default: DIR/export).
    #[arg(long, value_name = "DIR")]
    out: Option<PathBuf>,
    /// Also export every trial's replay as trajectories for learners, into OUT/trajectories/
    /// (one directory per trial; its meta.json labels name the participant's anonymous id,
    /// the condition and the trial). As `bw4t replay trajectories`; --format, --ticks-per-step
    /// and --slots as there.
    #[arg(long)]
    trajectories: bool,
    #[command(flatten)]
    flags: crate::trajectories::TrajectoryFlags,
}

impl StudyArgs {
    /// The data directory: the one given, else the default of a real run or a dry run.
    fn data(&self) -> PathBuf {
        let default = if self.simulate.is_some() { "study-data-dry-run" } else { "study-data" };
        self.data.clone().unwrap_or_else(|| PathBuf::from(default))
    }
}

/// Runs `bw4t study ...`.
pub(crate) fn run(args: &StudyArgs) -> Result<()> {
    match (&args.command, &args.file) {
        (Some(StudyCommand::Export(export)), _) => run_export(export),
        (None, Some(file)) => serve(args, file),
        (None, None) => bail!("give a study file: bw4t study STUDY.toml"),
    }
}

fn run_export(args: &ExportArgs) -> Result<()> {
    let out = args.out.clone().unwrap_or_else(|| args.dir.join("export"));
    let summary = bw4t_study::export(&args.dir, &out).map_err(anyhow::Error::msg)?;
    outln!(
        "exported {} into {}: {}, {} ({} without an end), {}, {}, {}",
        args.dir.display(),
        out.display(),
        bw4t_runner::plural(summary.counts.participants, "participant"),
        bw4t_runner::plural(summary.counts.trials, "trial"),
        summary.counts.incomplete,
        bw4t_runner::plural(summary.counts.answers, "answer"),
        bw4t_runner::plural(summary.counts.events, "event"),
        bw4t_runner::plural(summary.counts.replays, "replay"),
    );
    if args.trajectories {
        let robots = crate::trajectories::export_study(&out, &args.flags)?;
        outln!(
            "wrote {} ({}) into {}",
            bw4t_runner::plural(robots, "robot trajectory"),
            args.flags.format.kind().as_str(),
            out.join("trajectories").display()
        );
    }
    Ok(())
}

fn serve(args: &StudyArgs, file: &Path) -> Result<()> {
    crate::serving::init_logs(&args.log);
    let mut study =
        bw4t_study::load(file, &|spec: &str| crate::maps::load(spec).map_err(|e| format!("{e:#}")))
            .map_err(anyhow::Error::msg)?;
    let data = args.data();
    if args.simulate.is_some() {
        let used = std::fs::read_dir(&data).map(|mut d| d.next().is_some()).unwrap_or(false);
        if used {
            bail!(
                "a dry run needs a fresh data directory, and {} is not empty: remove it or give --data DIR",
                data.display()
            );
        }
        // As fast as the scripted players answer, and no long wait for a partner.
        for condition in study.conditions.iter_mut().chain(study.practices.iter_mut()) {
            condition.mode = bw4t_protocol::Mode::Lockstep;
            condition.partner_timeout_s = condition.partner_timeout_s.min(1);
        }
    }
    keep_study_file(&data, &study, args.changed_study)?;
    let token = args.operator_token.clone().unwrap_or_else(bw4t_server::random_token);
    let mut settings = ArenaConfig::new(study.templates());
    settings.default = None;
    settings.server.operator_token = Some(token.clone());
    settings.server.closed = true;
    settings.server.allowed_origins = args.allow_origin.clone();
    settings.server.max_connections = args.max_connections;
    settings.server.max_per_source = args.max_per_source;
    settings.server.trusted_proxies = args.trust_proxy.clone();
    settings.server.hello_timeout = Duration::from_secs(10);
    let matches = data.join("matches");
    settings.results = ResultsStore::in_dir(&matches)
        .with_context(|| format!("cannot write results into {}", matches.display()))?;
    for c in &study.conditions {
        eprintln!(
            "bw4t: condition '{}': map '{}', {} and {} ({}), {} mode at {} ticks/s, {} s",
            c.name,
            c.map.name(),
            bw4t_runner::plural(c.humans, "human"),
            bw4t_runner::plural(c.teammates, "teammate"),
            c.strategy.name(),
            c.mode.name(),
            c.tick_hz,
            c.time_limit_s
        );
    }
    let runtime = tokio::runtime::Builder::new_multi_thread()
        .enable_all()
        .build()
        .context("cannot start the runtime")?;
    let dry_run = args.simulate.is_some();
    // A dry run is this machine's only, on ports nobody else uses.
    let (bind, port, http) =
        if dry_run { ([127, 0, 0, 1].into(), 0, 0) } else { (args.bind, args.port, args.http) };
    let simulated = runtime.block_on(async {
        let stop = crate::serving::stop_signal();
        let (listener, local) = crate::serving::listen(SocketAddr::new(bind, port))?;
        let (http, web) = crate::serving::listen(SocketAddr::new(bind, http))?;
        outln!("listening on {local}");
        outln!("http on {web}");
        let arena = bw4t_server::Arena::start(settings).context("cannot start the study's matches")?;
        let budget = bw4t_study::StudyBudget {
            arrivals_per_minute: args.arrivals_per_minute,
            ..bw4t_study::StudyBudget::default()
        };
        let server = StudyServer::open_with(study, &data, arena.clone(), budget)
            .with_context(|| format!("cannot open the study's data in {}", data.display()))?;
        let host = if web.ip().is_unspecified() { "THIS-HOST".to_string() } else { web.ip().to_string() };
        let base = format!("http://{host}:{}", web.port());
        outln!(
            "study '{}': {} so far",
            server.study().name,
            bw4t_runner::plural(server.participants(), "participant")
        );
        outln!("participant link: {base}/study?participant=ID (or ?PROLIFIC_PID=..., none: an id is made)");
        outln!("dashboard: {base}/study/admin?token={token}");
        if args.operator_token.is_none() {
            outln!("operator token: {token}");
        }
        let routes: Vec<std::sync::Arc<dyn bw4t_server::Routes>> = vec![std::sync::Arc::new(server)];
        let web_routes = Some(bw4t_server::Web { listener: http, routes });
        let Some(n) = args.simulate else {
            bw4t_server::serve_arena(&arena, listener, web_routes, stop).await;
            return anyhow::Ok(None);
        };
        let (done, finished) = tokio::sync::oneshot::channel::<()>();
        let serving = {
            let arena = arena.clone();
            tokio::spawn(async move {
                let finished = async {
                    let _ = finished.await;
                };
                bw4t_server::serve_arena(&arena, listener, web_routes, finished).await;
            })
        };
        outln!("dry run: {} through the study", bw4t_runner::plural(n as usize, "scripted participant"));
        let simulated = crate::study_simulate::simulate(n, web, local).await;
        let _ = done.send(());
        serving.await.context("the study's server")?;
        anyhow::Ok(Some(simulated))
    })?;
    let Some(simulated) = simulated else {
        crate::output::note(format_args!(
            "bw4t: stopped; the data is in {} (bw4t study export {0})",
            data.display()
        ));
        return Ok(());
    };
    outln!(
        "dry run: {} completed, {} declined consent, {} screened out, {} played",
        simulated.completed,
        simulated.declined,
        simulated.screened_out,
        bw4t_runner::plural(simulated.trials, "trial")
    );
    run_export(&ExportArgs { dir: data.clone(), out: None, trajectories: false, flags: Default::default() })?;
    if !simulated.stopped.is_empty() {
        bail!("the dry run found problems:\n  {}", simulated.stopped.join("\n  "));
    }
    Ok(())
}

/// Copies the study file into the data directory, or checks it is the one already there.
fn keep_study_file(data: &Path, study: &Study, changed: bool) -> Result<()> {
    std::fs::create_dir_all(data).with_context(|| format!("cannot make {}", data.display()))?;
    let copy = data.join("study.toml");
    if let Ok(old) = std::fs::read_to_string(&copy) {
        if old == study.text {
            return Ok(());
        }
        if !changed {
            bail!(
                "{} was started with another study file ({}); give a new --data directory, or \
                 --changed-study if the change keeps the meaning of every page and condition",
                data.display(),
                copy.display()
            );
        }
        let kept = data.join(format!("study-{}.toml", bw4t_study::now_ms()));
        std::fs::rename(&copy, &kept).with_context(|| format!("cannot keep {}", kept.display()))?;
    }
    std::fs::write(&copy, &study.text).with_context(|| format!("cannot write {}", copy.display()))
}
