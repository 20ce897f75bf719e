//! Streamable HTTP: the MCP endpoint at `/mcp` on a plain HTTP/1.1 server (hyper), every
//! client a session of the same robot. Only loopback host names are accepted unless the
//! operator names more (rmcp's check against DNS rebinding).

use std::convert::Infallible;
use std::sync::Arc;

use bytes::Bytes;
use http_body_util::{BodyExt, Full};
use hyper::body::Incoming;
use hyper_util::rt::TokioIo;
use rmcp::transport::streamable_http_server::session::local::LocalSessionManager;
use rmcp::transport::streamable_http_server::{StreamableHttpServerConfig, StreamableHttpService};
use tokio::net::TcpListener;
use tower_service::Service;

use crate::server::RobotServer;

/// The path of the MCP endpoint.
pub const MCP_PATH: &str = "/mcp";

/// Serves `server` on `listener` until the process ends; `hosts` are the `Host` names
/// allowed besides loopback.
pub async fn serve_http(
    server: RobotServer,
    listener: TcpListener,
    hosts: Vec<String>,
) -> std::io::Result<()> {
    let mut config = StreamableHttpServerConfig::default();
    config.allowed_hosts.extend(hosts);
    let mcp: StreamableHttpService<RobotServer, LocalSessionManager> = StreamableHttpService::new(
        move || Ok(server.clone()),
        Arc::new(LocalSessionManager::default()),
        config,
    );
    loop {
        let (stream, _) = listener.accept().await?;
        let mcp = mcp.clone();
        tokio::spawn(async move {
            let route = hyper::service::service_fn(move |request: http::Request<Incoming>| {
                let mut mcp = mcp.clone();
                async move {
                    if request.uri().path() != MCP_PATH {
                        let body =
                            Full::new(Bytes::from_static(b"not found: the MCP endpoint is /mcp\n")).boxed();
                        let mut response = http::Response::new(body);
                        *response.status_mut() = http::StatusCode::NOT_FOUND;
                        return Ok::<_, Infallible>(response);
                    }
                    mcp.call(request).await
                }
            });
            // A client that goes away mid-request is its own business.
            let _ = hyper::server::conn::http1::Builder::new()
                .serve_connection(TokioIo::new(stream), route)
                .await;
        });
    }
}
