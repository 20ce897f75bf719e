//! A participant's credential: an unguessable secret made at their arrival, given to their
//! browser as an `HttpOnly`, `SameSite=Strict` cookie and kept only as its SHA-256. The
//! participant id (a platform's, such as Prolific's) is a label anyone may know; the
//! secret is what lets a browser act as that participant.

use http::HeaderMap;
use sha2::{Digest, Sha256};

/// The cookie of participant `id` is named this and the id (ids are letters, digits, `-`
/// and `_`, all allowed in a cookie's name), so one browser may hold several.
const COOKIE_PREFIX: &str = "bw4t_study_";

/// A new secret: 32 bytes from the operating system, in hex.
pub(crate) fn new_secret() -> std::io::Result<String> {
    let mut bytes = [0u8; 32];
    getrandom::fill(&mut bytes).map_err(|e| std::io::Error::other(format!("no randomness: {e}")))?;
    Ok(hex(&bytes))
}

/// The SHA-256 of `secret`, in hex: what the study's database keeps.
pub(crate) fn digest(secret: &str) -> String {
    hex(&Sha256::digest(secret.as_bytes()))
}

fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

/// The `Set-Cookie` value giving `id`'s secret to their browser. `Secure` when the request
/// came over TLS, which this server knows only from a proxy's `X-Forwarded-Proto: https`
/// (the server speaks plain HTTP). Believing that header needs no trust: a client that
/// lies about it only restricts its own cookie.
pub(crate) fn set_cookie(id: &str, secret: &str, headers: &HeaderMap) -> String {
    let secure = headers
        .get_all("x-forwarded-proto")
        .iter()
        .filter_map(|v| v.to_str().ok())
        .any(|v| v.split(',').next().is_some_and(|first| first.trim().eq_ignore_ascii_case("https")));
    let mut cookie = format!("{COOKIE_PREFIX}{id}={secret}; Path=/api/study; HttpOnly; SameSite=Strict");
    if secure {
        cookie.push_str("; Secure");
    }
    cookie
}

/// The secret the request's cookies carry for participant `id`, if any.
pub(crate) fn presented<'a>(headers: &'a HeaderMap, id: &str) -> Option<&'a str> {
    headers
        .get_all(http::header::COOKIE)
        .iter()
        .filter_map(|v| v.to_str().ok())
        .flat_map(|v| v.split(';'))
        .filter_map(|pair| pair.trim().split_once('='))
        .find(|(name, _)| name.strip_prefix(COOKIE_PREFIX) == Some(id))
        .map(|(_, value)| value.trim())
}

/// What a request proves about participant `id`, whose records keep `expected` (a digest).
#[derive(Debug, PartialEq, Eq)]
pub(crate) enum Proof {
    /// The right secret.
    Valid,
    /// No secret for them.
    Missing,
    /// A secret that is not theirs (or they have none, made by an older version).
    Wrong,
}

/// Checks the request's secret for `id` against the digest kept.
pub(crate) fn check(headers: &HeaderMap, id: &str, expected: Option<&str>) -> Proof {
    match (presented(headers, id), expected) {
        (None, _) => Proof::Missing,
        // The digests are compared, not the secret: equal time matters not for a hash.
        (Some(secret), Some(expected)) if digest(secret) == expected => Proof::Valid,
        _ => Proof::Wrong,
    }
}

#[cfg(test)]
mod tests {
    use super::{Proof, check, digest, new_secret, set_cookie};
    use http::HeaderMap;

    fn with(name: &str, value: &str) -> HeaderMap {
        let mut headers = HeaderMap::new();
        headers.insert(
            http::HeaderName::from_bytes(name.as_bytes()).expect("name"),
            value.parse().expect("value"),
        );
        headers
    }

    #[test]
    fn only_the_secret_made_at_arrival_proves_the_participant() {
        let secret = new_secret().expect("random");
        assert_eq!(secret.len(), 64);
        assert_ne!(secret, new_secret().expect("random"), "each secret is new");
        let kept = digest(&secret);
        let cookie = with("cookie", &format!("other=1; bw4t_study_p1={secret}; bw4t_study_p10=x"));
        assert_eq!(check(&cookie, "p1", Some(&kept)), Proof::Valid);
        assert_eq!(check(&cookie, "p10", Some(&kept)), Proof::Wrong);
        assert_eq!(check(&cookie, "p2", Some(&kept)), Proof::Missing);
        assert_eq!(check(&cookie, "p1", None), Proof::Wrong, "no digest kept: nothing proves it");
        assert_eq!(check(&HeaderMap::new(), "p1", Some(&kept)), Proof::Missing);
    }

    #[test]
    fn the_cookie_is_http_only_same_site_strict_and_secure_behind_tls() {
        let plain = set_cookie("p1", "s", &HeaderMap::new());
        assert_eq!(plain, "bw4t_study_p1=s; Path=/api/study; HttpOnly; SameSite=Strict");
        let tls = set_cookie("p1", "s", &with("x-forwarded-proto", "https"));
        assert!(tls.ends_with("; Secure"), "{tls}");
    }
}
