//! A BW4T robot behind a Model Context Protocol server (`bw4t mcp`): any MCP client (an
//! agent host, a model's tool loop) drives one robot of a match through tools, reads the
//! rules, map and goal as resources, and gets a role prompt.
//!
//! Over stdio only the parent process can reach the server; over HTTP the robot belongs
//! to whoever holds its bearer token (`http.rs`), and is driven by one MCP session at a
//! time (`seat.rs`).
//!
//! The robot is a protocol client like any other ([`Link`] owns its TCP connection): it
//! joins a served match, or a match of its own ([`LocalMatch`]) on loopback. The tools
//! are answered by a sans-IO robot (`robot.rs`) that turns server messages and tool
//! commands into client messages and reports.

mod answer;
mod docs;
mod echo;
mod http;
mod link;
mod local;
mod robot;
mod seat;
mod server;
mod view;

pub use docs::Docs;
pub use http::{HttpOptions, MCP_PATH, serve_http};
pub use link::{DecisionLog, JoinError, Link, LinkOptions};
pub use local::{LocalMatch, Started};
pub use server::{
    MAX_FREE_TEXT_CHARS, MAX_MESSAGE_NUMBER, MAX_NAME_BYTES, MAX_TOOL_SECONDS, MAX_WAIT_TICKS, RobotServer,
};

/// Serves `server` over standard input and output until the client closes them.
pub async fn serve_stdio(server: RobotServer) -> Result<(), String> {
    use rmcp::ServiceExt;
    let running = server.serve(rmcp::transport::stdio()).await.map_err(|e| format!("MCP over stdio: {e}"))?;
    running.waiting().await.map(|_| ()).map_err(|e| format!("MCP over stdio: {e}"))
}
