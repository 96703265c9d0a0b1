//! The process's memory as the system counts it, for the status bar and the state report.

/// The process's resident set, bytes (`VmRSS` in `/proc/self/status`); `None` where there is no
/// such file.
pub fn resident_bytes() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    let line = status.lines().find(|l| l.starts_with("VmRSS:"))?;
    let kib: u64 = line.split_whitespace().nth(1)?.parse().ok()?;
    Some(kib * 1024)
}
