//! Build provenance: what `snell --version` prints and every benchmark report repeats.

/// Git commit of the build ("unknown" outside git; "-dirty" with local edits).
pub const GIT_COMMIT: &str = env!("SNELL_GIT_COMMIT");
/// Embree header version snell was compiled against.
pub const EMBREE_VERSION: &str = env!("SNELL_EMBREE_VERSION");
/// `rustc --version` of the compiler that built snell.
pub const RUSTC_VERSION: &str = env!("SNELL_RUSTC_VERSION");
/// Cargo profile ("release", "debug").
pub const PROFILE: &str = env!("SNELL_PROFILE");

/// A short description of the machine: CPU model (lscpu's model name),
/// logical core count and which of the SIMD levels the kernels choose
/// between (avx2, avx512f) the CPU has.
pub fn machine() -> String {
    let info = std::fs::read_to_string("/proc/cpuinfo").unwrap_or_default();
    let field = |name: &str| {
        info.lines()
            .find(|l| l.split(':').next().map(str::trim) == Some(name))
            .and_then(|l| l.split(':').nth(1))
            .map(|s| s.trim().to_string())
    };
    let cpu = field("model name").unwrap_or_else(|| "unknown CPU".into());
    let cores = std::thread::available_parallelism().map(|n| n.get()).unwrap_or(0);
    let flags = field("flags").unwrap_or_default();
    let simd: Vec<&str> = ["avx2", "avx512f"]
        .into_iter()
        .filter(|f| flags.split_whitespace().any(|x| x == *f))
        .collect();
    let simd = if simd.is_empty() {
        "neither avx2 nor avx512f".to_string()
    } else {
        simd.join(" ")
    };
    format!("{cpu}, {cores} logical cores, SIMD {simd}")
}

/// One line naming the build and the machine, for reports.
pub fn line() -> String {
    format!(
        "snell {} commit {} | Embree {} | {} | profile {} | {}",
        env!("CARGO_PKG_VERSION"),
        GIT_COMMIT,
        EMBREE_VERSION,
        RUSTC_VERSION,
        PROFILE,
        machine()
    )
}

/// The same as a JSON object, for `--stats-json` and bench JSON.
pub fn json() -> serde_json::Value {
    serde_json::json!({
        "snell_version": env!("CARGO_PKG_VERSION"),
        "commit": GIT_COMMIT,
        "embree_version": EMBREE_VERSION,
        "rustc": RUSTC_VERSION,
        "profile": PROFILE,
        "machine": machine(),
    })
}
