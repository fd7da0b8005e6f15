//! Build provenance for `snell --version` and every benchmark report:
//! git commit (or "unknown" outside git), Embree header version, rustc, profile.
use std::process::Command;

fn run(cmd: &str, args: &[&str]) -> Option<String> {
    let out = Command::new(cmd).args(args).output().ok()?;
    if !out.status.success() {
        return None;
    }
    let s = String::from_utf8_lossy(&out.stdout).trim().to_string();
    (!s.is_empty()).then_some(s)
}

fn main() {
    let commit = run("git", &["rev-parse", "--short=12", "HEAD"]).unwrap_or_else(|| "unknown".into());
    let dirty = run("git", &["status", "--porcelain", "--untracked-files=no"])
        .map(|s| !s.is_empty())
        .unwrap_or(false);
    let commit = if dirty && commit != "unknown" {
        format!("{commit}-dirty")
    } else {
        commit
    };
    let embree = std::env::var("DEP_EMBREE3_VERSION").unwrap_or_else(|_| "unknown".into());
    let rustc = std::env::var("RUSTC").unwrap_or_else(|_| "rustc".into());
    let rustc_version = run(&rustc, &["--version"]).unwrap_or_else(|| "unknown".into());
    let profile = std::env::var("PROFILE").unwrap_or_else(|_| "unknown".into());
    println!("cargo:rustc-env=SNELL_GIT_COMMIT={commit}");
    println!("cargo:rustc-env=SNELL_EMBREE_VERSION={embree}");
    println!("cargo:rustc-env=SNELL_RUSTC_VERSION={rustc_version}");
    println!("cargo:rustc-env=SNELL_PROFILE={profile}");
    // `git rev-parse --git-path` also finds HEAD and the index of a worktree
    // (where `.git` is a file): a commit rewrites the index, so the embedded
    // commit follows it.
    for f in ["HEAD", "index"] {
        if let Some(p) = run("git", &["rev-parse", "--git-path", f]) {
            if std::path::Path::new(&p).exists() {
                println!("cargo:rerun-if-changed={p}");
            }
        }
    }
    println!("cargo:rerun-if-changed=build.rs");
}
