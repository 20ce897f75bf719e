//! The integration tests, in one binary.

// Helpers are shared between test modules; which of them a module uses is not an API.
#![allow(unreachable_pub)]

/// The repository's root, as a string literal: these are the tests of the `bw4t` package
/// (`crates/bw4t-cli`), two folders down from it.
macro_rules! repo_root {
    () => {
        concat!(env!("CARGO_MANIFEST_DIR"), "/../..")
    };
}

/// Shared helpers: loading maps, and the scenario runner the rule tests are written in.
mod util;

/// Every rule of the simulation, as scenario scripts on the fixed-content map.
mod sim_rules;

/// Properties over random play: deltas rebuild snapshots, determinism, a pinned digest.
mod sim_properties;

/// The kinematic motion against the stepped reference: the same matches, bit for bit.
mod motion_agreement;

/// Maps and their seeded random content.
mod maps;

/// Original BW4T XML maps, on fixtures of this repository: import, format detection, errors.
mod import;

/// Built-in agents in headless matches.
mod agents;

/// `bw4t eval`: the suite's reference rows, agent programs, scoring outcomes, errors.
mod eval;

/// The cooperative team's progress rule: no deadlock whatever the seed and team size.
mod coop_deadlock;

/// The built-in team in the shared message language: what it says, silence, requests.
mod coop_language;

/// The match server over real loopback TCP.
mod server;

/// One server, many matches: templates, routing, the queue, the API, isolation.
mod arena;

/// The match host over TCP: roles and tokens, seats, join/leave churn, lockstep timing.
mod host;

/// The match host on a simulated clock, without sockets: pacing, deadlines, grace, slow readers.
mod host_clock;

/// The conformance suite: example transcripts replayed against the server.
mod conformance;

/// The documents against the tree: every path they name exists, every crate is mapped.
mod tidy;

/// The documents' shell examples, run: `bw4t` commands for real, other programs named with
/// the test that covers them.
mod doc_examples;

/// The protocol documents: schemas and examples checked against the Rust types.
mod protocol_docs;

/// `bw4t run`: headless and served matches, external agent processes, replays.
mod run;

/// The web side: the page, the map layout, the protocol over WebSocket.
mod web;

/// Studies: the participant flow over the HTTP API, resuming, the export, bad study files.
mod study;

/// Study designs: between and mixed subjects, practice rounds, pass marks and the
/// screen-out, quotas, balance over completers, seeds fixed per slot and trial.
mod study_designs;

/// Questionnaires: number and matrix items, show_if, maxlength, shuffled items and rows.
mod study_questionnaires;

/// `bw4t tournament`: files, statistics, resume, shards, failing agents.
mod tournament;

/// Tournaments on a cluster: shards from Slurm and Kubernetes variables, merge checks,
/// resuming the missing matches, and the job files written.
mod cluster;

/// The `bw4t` binary, run as a child process.
mod cli;

/// `bw4t mcp` over HTTP against a hostile visitor: the token, origins, one driving session,
/// connection limits, bounded arguments, simulated waits and cancelled calls.
mod mcp;

/// `bw4t bench arena` on small figures: fields and invariants, no timing.
mod bench_arena;

/// Map tools: check, render, show, import.
mod map_tools;

/// Maps are checked before anything is built from them: limits, the check's errors, ranges.
mod map_guard;

/// The original BW4T map files, when `BW4T_ORIGINAL_MAPS` names their folder (ignored otherwise).
mod original_maps;
