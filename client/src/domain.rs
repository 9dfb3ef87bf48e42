//! iceoryx2 domains: processes started with the same `COSIM_DOMAIN` see
//! one another's servers and nobody else's (iceoryx2's own domains: a
//! configuration whose file prefix is the domain's, so that every file
//! and shared-memory segment of one domain is invisible to another).
//! Unset or empty: iceoryx2's global configuration, as before. `cosim
//! sweep` gives each run its own, so that runs side by side never meet.

use crate::ClientError;
use iceoryx2::prelude::*;
use std::sync::OnceLock;

/// The environment variable that names the domain.
pub const DOMAIN_VAR: &str = "COSIM_DOMAIN";

/// The longest domain name (iceoryx2 prefixes every file name with it).
const LONGEST: usize = 64;

/// The iceoryx2 configuration of this process's domain (read once).
pub fn config() -> Result<&'static Config, ClientError> {
    static CONFIG: OnceLock<Result<Config, String>> = OnceLock::new();
    let made = CONFIG.get_or_init(|| {
        let domain = std::env::var(DOMAIN_VAR).unwrap_or_default();
        of(&domain)
    });
    made.as_ref().map_err(|detail| ClientError::Ipc {
        what: format!("{DOMAIN_VAR} names no usable domain"),
        detail: detail.clone(),
    })
}

/// The configuration of domain `domain` ("" for the global one).
pub fn of(domain: &str) -> Result<Config, String> {
    let mut config = Config::global_config().clone();
    if domain.is_empty() {
        return Ok(config);
    }
    check(domain)?;
    config.global.prefix = FileName::new(format!("cosim_{domain}_").as_bytes())
        .map_err(|e| format!("{domain:?}: {e:?}"))?;
    Ok(config)
}

/// A domain name: letters, digits, `-` and `_`, at most 64 of them.
pub fn check(domain: &str) -> Result<(), String> {
    let fine = |c: char| c.is_ascii_alphanumeric() || c == '-' || c == '_';
    if domain.is_empty() || domain.len() > LONGEST || !domain.chars().all(fine) {
        return Err(format!(
            "{domain:?}: a domain is 1 to {LONGEST} letters, digits, '-' or '_'"
        ));
    }
    Ok(())
}

/// A node builder in this process's domain.
pub fn node() -> Result<NodeBuilder, ClientError> {
    Ok(NodeBuilder::new().config(config()?))
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_domain_is_a_prefix_and_a_bad_name_is_refused() {
        let c = of("sweep-7_a").expect("a good name");
        assert_eq!(c.global.prefix.to_string(), "cosim_sweep-7_a_");
        assert_eq!(
            of("").expect("global").global.prefix,
            Config::global_config().global.prefix
        );
        for bad in ["a/b", "a b", "ü", &"x".repeat(65)] {
            assert!(of(bad).is_err(), "{bad:?} accepted");
        }
    }
}
