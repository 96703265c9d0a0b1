//! Where the editor keeps its settings and its cache (recovery copies, locks, crash reports): the
//! platform's base folders as `etcetera` finds them (XDG on Linux and macOS: `$XDG_CONFIG_HOME`
//! or `~/.config`, `$XDG_CACHE_HOME` or `~/.cache`), each with a `treelight` folder, unless
//! `TREELIGHT_CONFIG_DIR` or `TREELIGHT_CACHE_DIR` names one.

use etcetera::BaseStrategy;
use std::path::PathBuf;

fn from_env(key: &str) -> Option<PathBuf> {
    std::env::var_os(key)
        .filter(|v| !v.is_empty())
        .map(PathBuf::from)
}

/// The editor's config folder.
pub fn config_dir() -> Option<PathBuf> {
    from_env("TREELIGHT_CONFIG_DIR").or_else(|| {
        etcetera::choose_base_strategy()
            .ok()
            .map(|s| s.config_dir().join("treelight"))
    })
}

/// The editor's cache folder.
pub fn cache_dir() -> Option<PathBuf> {
    from_env("TREELIGHT_CACHE_DIR").or_else(|| {
        etcetera::choose_base_strategy()
            .ok()
            .map(|s| s.cache_dir().join("treelight"))
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_folders_are_the_ones_earlier_versions_used_on_linux() {
        // Earlier versions looked up `$XDG_*_HOME/treelight`, else `~/.config` and `~/.cache`:
        // what etcetera's XDG strategy gives, so settings and recovery copies are found in place.
        let strategy = etcetera::choose_base_strategy().unwrap();
        let home = etcetera::home_dir().unwrap();
        let config = std::env::var_os("XDG_CONFIG_HOME")
            .filter(|v| !v.is_empty() && std::path::Path::new(v).is_absolute())
            .map_or_else(|| home.join(".config"), PathBuf::from);
        let cache = std::env::var_os("XDG_CACHE_HOME")
            .filter(|v| !v.is_empty() && std::path::Path::new(v).is_absolute())
            .map_or_else(|| home.join(".cache"), PathBuf::from);
        if cfg!(target_os = "linux") {
            assert_eq!(strategy.config_dir(), config);
            assert_eq!(strategy.cache_dir(), cache);
        }
    }
}
