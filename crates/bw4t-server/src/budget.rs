//! Places per source address: no one address may hold more than its share of the
//! server's connections (protocol port, WebSockets, plain HTTP requests), so one client
//! cannot fill the server for everyone else. A place is an RAII guard, given back when
//! dropped.

use std::collections::HashMap;
use std::net::IpAddr;
use std::sync::{Arc, Mutex};

/// How many places each source address holds, and how many it may.
#[derive(Clone)]
pub(crate) struct SourceBudget {
    held: Arc<Mutex<HashMap<IpAddr, usize>>>,
    limit: usize,
}

impl SourceBudget {
    /// A budget of `limit` places per address.
    pub(crate) fn new(limit: usize) -> SourceBudget {
        SourceBudget { held: Arc::default(), limit }
    }

    /// The places each address may hold.
    pub(crate) fn limit(&self) -> usize {
        self.limit
    }

    /// One place for `source`, unless it holds all its share already.
    pub(crate) fn take(&self, source: IpAddr) -> Option<SourcePlace> {
        let mut held = self.held.lock().unwrap_or_else(|p| p.into_inner());
        let count = held.entry(source).or_default();
        if *count >= self.limit {
            return None;
        }
        *count += 1;
        Some(SourcePlace { held: self.held.clone(), source })
    }
}

/// One place of one source address, given back when dropped.
pub(crate) struct SourcePlace {
    held: Arc<Mutex<HashMap<IpAddr, usize>>>,
    source: IpAddr,
}

impl Drop for SourcePlace {
    fn drop(&mut self) {
        let mut held = self.held.lock().unwrap_or_else(|p| p.into_inner());
        if let Some(count) = held.get_mut(&self.source) {
            *count -= 1;
            if *count == 0 {
                // Addresses that hold nothing are forgotten, so the map stays as small as
                // the connections open.
                held.remove(&self.source);
            }
        }
    }
}

/// The address a request came from: the peer's, or, when the peer is a trusted reverse
/// proxy, the last address its `X-Forwarded-For` names (the one the proxy itself saw).
pub(crate) fn request_source(peer: IpAddr, forwarded_for: Option<&str>, trusted: &[IpAddr]) -> IpAddr {
    if !trusted.contains(&peer) {
        return peer;
    }
    let last = forwarded_for.and_then(|v| v.rsplit(',').next()).map(str::trim);
    last.and_then(|a| a.parse().ok()).unwrap_or(peer)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_address_holds_at_most_its_share_and_gets_places_back_when_they_are_dropped() {
        let budget = SourceBudget::new(2);
        let (a, b): (IpAddr, IpAddr) =
            ("10.0.0.1".parse().expect("an address"), "10.0.0.2".parse().expect("an address"));
        let first = budget.take(a).expect("a first place");
        let _second = budget.take(a).expect("a second place");
        assert!(budget.take(a).is_none(), "a third is beyond the share");
        assert!(budget.take(b).is_some(), "another address has its own share");
        drop(first);
        assert!(budget.take(a).is_some(), "a place given back can be taken again");
    }

    #[test]
    fn only_a_trusted_proxy_names_the_source() {
        let proxy: IpAddr = "10.0.0.9".parse().expect("an address");
        let other: IpAddr = "10.0.0.8".parse().expect("an address");
        let header = Some("1.2.3.4, 5.6.7.8");
        assert_eq!(request_source(proxy, header, &[proxy]), "5.6.7.8".parse::<IpAddr>().expect("an address"));
        assert_eq!(request_source(other, header, &[proxy]), other, "an untrusted peer's header is ignored");
        assert_eq!(request_source(proxy, Some("junk"), &[proxy]), proxy);
        assert_eq!(request_source(proxy, None, &[proxy]), proxy);
    }
}
