//! Budgets per source address: no one address may hold more than its share of the
//! server's connections (protocol port, WebSockets, plain HTTP requests), so one client
//! cannot fill the server for everyone else (a place is an RAII guard, given back when
//! dropped), nor do something costly (a study's arrival) more often than its rate.
//!
//! An IPv6 source counts by its /64 network, which one host usually holds whole.

use std::collections::HashMap;
use std::net::{IpAddr, Ipv6Addr};
use std::sync::{Arc, Mutex};
use std::time::{Duration, Instant};

/// The address a budget counts `ip` under: an IPv4 address as itself (also when written
/// as IPv6), an IPv6 address as its /64 network.
pub fn source_key(ip: IpAddr) -> IpAddr {
    match ip {
        IpAddr::V4(_) => ip,
        IpAddr::V6(v6) => match v6.to_ipv4_mapped() {
            Some(v4) => IpAddr::V4(v4),
            None => IpAddr::V6(Ipv6Addr::from_bits(v6.to_bits() & !u128::from(u64::MAX))),
        },
    }
}

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
        let source = source_key(source);
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

/// How often each source may do something: at most `limit` times in a window of `window`
/// from its first time (a fixed window per source). The time is given, so tests drive it.
pub struct RateBudget {
    limit: u32,
    window: Duration,
    seen: Mutex<HashMap<IpAddr, (Instant, u32)>>,
}

/// The most sources a [`RateBudget`] remembers: a flood from more addresses than this in
/// one window is refused as a whole rather than let grow the memory.
const MAX_SOURCES_SEEN: usize = 100_000;

impl RateBudget {
    /// At most `limit` times per `window` per source.
    pub fn new(limit: u32, window: Duration) -> RateBudget {
        RateBudget { limit, window, seen: Mutex::default() }
    }

    /// At most this many times per window.
    pub fn limit(&self) -> u32 {
        self.limit
    }

    /// The window.
    pub fn window(&self) -> Duration {
        self.window
    }

    /// Counts one time of `source` at `now`; over its rate, how long until it may again.
    pub fn take(&self, source: IpAddr, now: Instant) -> Result<(), Duration> {
        let source = source_key(source);
        let mut seen = self.seen.lock().unwrap_or_else(|p| p.into_inner());
        let window = self.window;
        if seen.len() >= MAX_SOURCES_SEEN && !seen.contains_key(&source) {
            seen.retain(|_, (since, _)| now.saturating_duration_since(*since) < window);
            if seen.len() >= MAX_SOURCES_SEEN {
                let oldest = seen.values().map(|(since, _)| *since).min().unwrap_or(now);
                return Err(window.saturating_sub(now.saturating_duration_since(oldest)));
            }
        }
        let (since, count) = seen.entry(source).or_insert((now, 0));
        if now.saturating_duration_since(*since) >= window {
            (*since, *count) = (now, 0);
        }
        if *count >= self.limit {
            return Err(window.saturating_sub(now.saturating_duration_since(*since)));
        }
        *count += 1;
        Ok(())
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
    fn a_rate_counts_each_source_in_its_own_window() {
        let rate = RateBudget::new(2, Duration::from_secs(60));
        let start = Instant::now();
        let a: IpAddr = "10.0.0.1".parse().expect("an address");
        assert_eq!((rate.take(a, start), rate.take(a, start)), (Ok(()), Ok(())));
        let later = start + Duration::from_secs(20);
        assert_eq!(rate.take(a, later), Err(Duration::from_secs(40)), "the third waits out the window");
        assert_eq!(rate.take("10.0.0.2".parse().expect("an address"), later), Ok(()));
        assert_eq!(rate.take(a, start + Duration::from_secs(60)), Ok(()), "a new window");
    }

    #[test]
    fn an_ipv6_host_counts_as_its_network() {
        let rate = RateBudget::new(1, Duration::from_secs(60));
        let now = Instant::now();
        let one: IpAddr = "2001:db8:1:2::1".parse().expect("an address");
        let same_net: IpAddr = "2001:db8:1:2:ffff::9".parse().expect("an address");
        let other_net: IpAddr = "2001:db8:1:3::1".parse().expect("an address");
        assert_eq!(rate.take(one, now), Ok(()));
        assert!(rate.take(same_net, now).is_err(), "another address of the same /64");
        assert_eq!(rate.take(other_net, now), Ok(()));
        let mapped: IpAddr = "::ffff:10.0.0.1".parse().expect("an address");
        assert_eq!(source_key(mapped), "10.0.0.1".parse::<IpAddr>().expect("an address"));
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
