//! `bw4t mcp`: one robot behind a Model Context Protocol server, over stdio or streamable
//! HTTP, in a match of its own or in a served one. Standard output belongs to the MCP
//! client in stdio mode, so everything else goes to standard error. Over stdio only the
//! parent process reaches the robot; over HTTP only the holder of its bearer token.

use std::net::{SocketAddr, ToSocketAddrs};
use std::path::PathBuf;
use std::time::Duration;

use anyhow::{Context, Result, bail};
use bw4t_agents::Strategy;
use bw4t_mcp::{Docs, HttpOptions, Link, LinkOptions, LocalMatch, MAX_TOOL_SECONDS, RobotServer};
use bw4t_protocol::SessionOptions;
use bw4t_runner::TickLimit;
use clap::Args;

/// Options of `bw4t mcp`.
#[derive(Args)]
pub(crate) struct McpArgs {
    /// Join the match served at HOST:PORT (default: BW4T_HOST and BW4T_PORT when set, as
    /// `bw4t run --agent` and tournaments give them; else a match of its own).
    #[arg(long, value_name = "HOST:PORT")]
    connect: Option<String>,
    /// The player name (default: BW4T_NAME, else Model).
    #[arg(long)]
    name: Option<String>,
    /// The player token of the served match (default: BW4T_TOKEN).
    #[arg(long)]
    token: Option<String>,
    /// A served match to join, by name.
    #[arg(long = "match", value_name = "NAME", conflicts_with = "template")]
    match_name: Option<String>,
    /// A template of the server whose next free seat to take.
    #[arg(long, value_name = "NAME")]
    template: Option<String>,
    /// The map: the one to play in a match of its own (default fixed), or, joining a
    /// served match, the one to describe (default: the match's map, if it is shipped).
    #[arg(long)]
    map: Option<String>,
    /// A match of its own: the seed (a random one is chosen and printed when omitted).
    #[arg(long)]
    seed: Option<u64>,
    /// A match of its own: built-in teammates, by strategy (coop, silent, ignoring,
    /// baseline), comma-separated; each adds a robot.
    #[arg(long, value_delimiter = ',', value_name = "STRATEGY,...")]
    teammates: Vec<String>,
    /// A match of its own: the last tick (default: derived from the map).
    #[arg(long)]
    max_ticks: Option<u64>,
    /// A match of its own: seconds the match waits for the robot's driver in a tick
    /// before it goes on without it (0: for ever).
    #[arg(long, default_value_t = 600)]
    deadline_s: u64,
    /// A match of its own: write its replay here.
    #[arg(long)]
    replay: Option<PathBuf>,
    /// A match of its own: write its result (JSON) here when it ends.
    #[arg(long)]
    out: Option<PathBuf>,
    /// Serve MCP over streamable HTTP at this address (endpoint /mcp) instead of stdio.
    /// Every request must carry `Authorization: Bearer TOKEN`: the robot is driven by
    /// whoever holds the token, printed on standard error at start.
    #[arg(long, value_name = "ADDR")]
    http: Option<SocketAddr>,
    /// With --http: the bearer token (default: a random one, printed at start).
    #[arg(long, value_name = "TOKEN", requires = "http")]
    http_token: Option<String>,
    /// With --http: a Host name to accept besides loopback's (repeat for more); a browser
    /// page from that host is accepted too.
    #[arg(long = "allow-host", value_name = "HOST", requires = "http")]
    allow_hosts: Vec<String>,
    /// With --http: a browser origin (`https://app.example:8080`, or `null`) to accept
    /// besides this machine's and the --allow-host names' (repeat for more). Requests with
    /// any other `Origin` are refused (403); requests without one are not browser pages.
    #[arg(long = "allow-origin", value_name = "ORIGIN", requires = "http")]
    allow_origins: Vec<String>,
    /// With --http: connections held at once; more are answered 503. Each must send a
    /// request head within 10 s of opening and between requests.
    #[arg(long, default_value_t = 64, value_name = "N", requires = "http")]
    http_max_connections: usize,
    /// Seconds a tool call may take before it returns `timeout`: wall time, and in a
    /// lockstep match simulated time too (no call runs the match further), as `wait`'s
    /// `seconds` are there.
    #[arg(long, default_value_t = 120.0)]
    tool_timeout_s: f64,
    /// Seconds to wait for a seat when joining.
    #[arg(long, default_value_t = 30)]
    join_timeout_s: u64,
    /// Write one JSON line per tool call here: tool, arguments, tick, ticks taken, the
    /// wall time thinking before it and running it, outcome.
    #[arg(long)]
    log: Option<PathBuf>,
    /// Write one JSON line per tool call here with what it returned: the text, the
    /// structured content, isError, the ticks it started and ended at, its estimated
    /// tokens (default with --log: beside it, `NAME.transcript.jsonl`).
    #[arg(long, value_name = "FILE")]
    transcript: Option<PathBuf>,
    /// Brief results: each gives only what changed since the previous one (the outcome,
    /// the changes, the clock, notices and the changed fields of the state); `look` still
    /// gives the whole situation.
    #[arg(long)]
    brief: bool,
    /// Play only a served match: fail at once, naming what is missing, unless --connect or
    /// the BW4T_* variables (`bw4t run --agent`, tournaments) say which, rather than
    /// start a match of its own.
    #[arg(long, conflicts_with_all = ["seed", "teammates", "max_ticks", "replay", "out"])]
    served: bool,
}

/// The variables a served match's agent is given, each with the flag that replaces it.
const SERVED_VARIABLES: [(&str, &str); 4] = [
    ("BW4T_HOST", "--connect"),
    ("BW4T_PORT", "--connect"),
    ("BW4T_NAME", "--name"),
    ("BW4T_TOKEN", "--token"),
];

/// With --served: an error naming every variable missing (and not replaced by its flag),
/// and how to pass them on through an MCP host.
fn check_served(args: &McpArgs) -> Result<()> {
    let given = |flag: &str| match flag {
        "--connect" => args.connect.is_some(),
        "--name" => args.name.is_some(),
        _ => args.token.is_some(),
    };
    let missing: Vec<&str> = SERVED_VARIABLES
        .iter()
        .filter(|(variable, flag)| std::env::var_os(variable).is_none() && !given(flag))
        .map(|(variable, _)| *variable)
        .collect();
    // An address given on the command line needs nothing from the environment.
    if missing.is_empty() || args.connect.is_some() {
        return Ok(());
    }
    bail!(
        "--served: no served match to join: {} not set. `bw4t run --agent` and tournaments give them \
         to the agent program; an MCP host that starts `bw4t mcp` with an environment of its own drops \
         them unless its server entry passes them on (e.g. \"env\": {{\"BW4T_HOST\": \"...\", \"BW4T_PORT\": \
         \"...\", \"BW4T_NAME\": \"...\", \"BW4T_TOKEN\": \"...\"}}, see docs/mcp.md), or give --connect HOST:PORT \
         --name NAME --token TOKEN",
        missing.join(", ")
    )
}

/// Where the transcript goes: --transcript, else beside --log.
fn transcript_path(args: &McpArgs) -> Option<PathBuf> {
    args.transcript.clone().or_else(|| args.log.as_ref().map(|log| log.with_extension("transcript.jsonl")))
}

/// A JSON-lines file to write, or nothing.
fn jsonl_writer(path: Option<&std::path::Path>, flag: &str) -> Result<bw4t_mcp::DecisionLog> {
    Ok(match path {
        Some(path) => Some(Box::new(
            std::fs::File::create(path).with_context(|| format!("cannot write {flag} {}", path.display()))?,
        )),
        None => None,
    })
}

/// A served match's address, from --connect or the environment.
fn served_address(args: &McpArgs) -> Result<Option<SocketAddr>> {
    let given = match &args.connect {
        Some(address) => address.clone(),
        None => match (std::env::var("BW4T_HOST"), std::env::var("BW4T_PORT")) {
            (Ok(host), Ok(port)) => format!("{host}:{port}"),
            _ => return Ok(None),
        },
    };
    let addr = given
        .to_socket_addrs()
        .with_context(|| format!("cannot resolve '{given}' (expected HOST:PORT)"))?
        .next()
        .with_context(|| format!("'{given}' resolves to no address"))?;
    Ok(Some(addr))
}

/// Runs `bw4t mcp` until the MCP client goes away.
pub(crate) fn run(args: &McpArgs) -> Result<()> {
    if !(args.tool_timeout_s > 0.0 && args.tool_timeout_s <= MAX_TOOL_SECONDS) {
        bail!("--tool-timeout-s must be above 0 and at most {MAX_TOOL_SECONDS}");
    }
    if args.http_max_connections == 0 {
        bail!("--http-max-connections must be at least 1");
    }
    if args.http_token.as_deref().is_some_and(|token| token.len() < 16 || token.contains(char::is_whitespace))
    {
        bail!("--http-token must be at least 16 characters, without spaces");
    }
    if args.served {
        check_served(args)?;
    }
    let served = served_address(args)?;
    let own_match_flags = [
        args.seed.is_some(),
        !args.teammates.is_empty(),
        args.max_ticks.is_some(),
        args.replay.is_some(),
        args.out.is_some(),
    ];
    if served.is_some() && own_match_flags.into_iter().any(|given| given) {
        bail!(
            "--seed, --teammates, --max-ticks, --replay and --out are for a match of its own, not with --connect (or BW4T_HOST)"
        );
    }
    if served.is_none() && (args.match_name.is_some() || args.template.is_some()) {
        bail!("--match and --template name a served match: give --connect HOST:PORT too");
    }
    let teammates = args
        .teammates
        .iter()
        .map(|name| {
            let known: Vec<&str> = Strategy::ALL.iter().map(|s| s.name()).collect();
            Strategy::named(name).with_context(|| {
                format!("--teammates: unknown strategy '{name}' (known: {})", known.join(", "))
            })
        })
        .collect::<Result<Vec<_>>>()?;
    let link_options = LinkOptions {
        decisions: jsonl_writer(args.log.as_deref(), "--log")?,
        transcript: jsonl_writer(transcript_path(args).as_deref(), "--transcript")?,
        brief: args.brief,
    };
    let name =
        args.name.clone().or_else(|| std::env::var("BW4T_NAME").ok()).unwrap_or_else(|| "Model".into());
    let runtime = tokio::runtime::Builder::new_multi_thread().worker_threads(2).enable_all().build()?;
    runtime.block_on(async {
        let join_wait = Duration::from_secs(args.join_timeout_s);
        let (link, map, own) = match served {
            Some(addr) => {
                let token = args.token.clone().or_else(|| std::env::var("BW4T_TOKEN").ok());
                let mut options = SessionOptions::agent(name, token);
                options.match_name = args.match_name.clone();
                options.template = args.template.clone();
                let link = Link::join(addr, options, join_wait, link_options).await?;
                let map = match (&args.map, link.match_info()) {
                    (Some(spec), _) => Some(crate::maps::load(spec)?),
                    (None, Some(info)) => crate::maps::load(&info.map).ok(),
                    (None, None) => None,
                };
                eprintln!("bw4t mcp: joined the match at {addr}");
                (link, map, None)
            }
            None => {
                let map = crate::maps::load(args.map.as_deref().unwrap_or("fixed"))?;
                if 1 + teammates.len() > map.spawns().len() {
                    bail!("{} robots but map '{}' has {} spawn points", 1 + teammates.len(), map.name(), map.spawns().len());
                }
                let mut setup = LocalMatch::setup(map.clone(), &name, &teammates);
                setup.seed = args.seed.unwrap_or_else(crate::random_seed);
                let max_ticks = args.max_ticks.unwrap_or_else(|| TickLimit::for_map(&map, &setup.game).ticks);
                setup.max_ticks = Some(max_ticks);
                let seed = setup.seed;
                eprintln!(
                    "bw4t mcp: a match of its own on map '{}', seed {seed}, {} built-in teammates, tick limit {max_ticks}",
                    map.name(),
                    teammates.len()
                );
                let started = LocalMatch {
                    setup,
                    deadline: (args.deadline_s > 0).then(|| Duration::from_secs(args.deadline_s)),
                    replay: crate::runs::replay_writer(args.replay.as_deref())?,
                }
                .start()
                .await?;
                let link = Link::join(started.addr, started.hello, join_wait, link_options).await?;
                (link, Some(map), Some(started.result))
            }
        };
        let server = RobotServer::new(link, Docs::new(map), Duration::from_secs_f64(args.tool_timeout_s));
        match args.http {
            Some(addr) => {
                let listener = tokio::net::TcpListener::bind(addr).await.with_context(|| format!("cannot listen on {addr}"))?;
                let bound = listener.local_addr()?;
                let token = args.http_token.clone().unwrap_or_else(bw4t_server::random_token);
                eprintln!("bw4t mcp: MCP over streamable HTTP at http://{bound}{}", bw4t_mcp::MCP_PATH);
                eprintln!("bw4t mcp: bearer token {token} (send Authorization: Bearer {token})");
                let mut options = HttpOptions::new(token);
                options.hosts.clone_from(&args.allow_hosts);
                options.origins.clone_from(&args.allow_origins);
                options.max_connections = args.http_max_connections;
                bw4t_mcp::serve_http(server, listener, options).await;
            }
            None => bw4t_mcp::serve_stdio(server).await.map_err(anyhow::Error::msg)?,
        }
        if let (Some(result), Some(path)) = (own, &args.out) {
            if result.is_finished() {
                let result = result.await??;
                std::fs::write(path, serde_json::to_string_pretty(&result)? + "\n")
                    .with_context(|| format!("cannot write --out {}", path.display()))?;
            } else {
                eprintln!("bw4t mcp: the match had not ended when the client left; no result written");
            }
        }
        Ok(())
    })
}
