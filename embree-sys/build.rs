//! Finds Embree 3 and generates bindings. Discovery order (DESIGN.md):
//! 1. `EMBREE_DIR` (a prefix with `include/` and `lib/`),
//! 2. pkg-config `embree3`, where an `embree3.pc` exists,
//! 3. the system default (`/usr/include/embree3`, `-lembree3`).
//!
//! Debian 12's `libembree-dev` ships no `.pc` file, so 3 is the usual path.
use std::env;
use std::path::{Path, PathBuf};
use std::process::Command;

const HINT: &str = "snell needs Intel Embree 3 and libclang to build.\n\
  On Debian/Ubuntu: apt-get update && apt-get install -y libembree-dev libclang-dev\n\
  (or run `make demo` / `make test`, which install them), or set EMBREE_DIR to a prefix \
  holding include/embree3/rtcore.h and lib/libembree3.so.";

fn fail(what: &str) -> ! {
    eprintln!("\nerror: embree-sys: {what}\n{HINT}\n");
    // A single readable message instead of a bindgen backtrace.
    std::process::exit(1);
}

struct Found {
    include_dirs: Vec<PathBuf>,
    lib_dirs: Vec<PathBuf>,
}

fn from_embree_dir() -> Option<Found> {
    let dir = PathBuf::from(env::var_os("EMBREE_DIR")?);
    if !dir.join("include/embree3/rtcore.h").exists() {
        fail(&format!(
            "EMBREE_DIR={} has no include/embree3/rtcore.h",
            dir.display()
        ));
    }
    let mut lib_dirs = vec![dir.join("lib")];
    if dir.join("lib64").exists() {
        lib_dirs.push(dir.join("lib64"));
    }
    Some(Found {
        include_dirs: vec![dir.join("include")],
        lib_dirs,
    })
}

fn from_pkg_config() -> Option<Found> {
    let out = Command::new("pkg-config")
        .args(["--cflags-only-I", "--libs-only-L", "embree3"])
        .output()
        .ok()?;
    if !out.status.success() {
        return None;
    }
    let text = String::from_utf8_lossy(&out.stdout).to_string();
    let mut found = Found {
        include_dirs: vec![],
        lib_dirs: vec![],
    };
    for tok in text.split_whitespace() {
        if let Some(p) = tok.strip_prefix("-I") {
            found.include_dirs.push(PathBuf::from(p));
        } else if let Some(p) = tok.strip_prefix("-L") {
            found.lib_dirs.push(PathBuf::from(p));
        }
    }
    Some(found)
}

fn system_default() -> Found {
    let candidates = ["/usr/include", "/usr/local/include"];
    let inc = candidates
        .iter()
        .map(Path::new)
        .find(|p| p.join("embree3/rtcore.h").exists())
        .unwrap_or_else(|| fail("header embree3/rtcore.h not found in /usr/include or /usr/local/include"));
    let has_lib = [
        "/usr/lib/x86_64-linux-gnu",
        "/usr/lib/aarch64-linux-gnu",
        "/usr/lib",
        "/usr/local/lib",
        "/usr/lib64",
    ]
    .iter()
    .any(|d| Path::new(d).join("libembree3.so").exists());
    if !has_lib {
        fail("library libembree3.so not found (the -dev package provides the unversioned link)");
    }
    Found {
        include_dirs: vec![inc.to_path_buf()],
        lib_dirs: vec![],
    }
}

fn header_version(include_dirs: &[PathBuf]) -> String {
    for d in include_dirs {
        if let Ok(text) = std::fs::read_to_string(d.join("embree3/rtcore_config.h")) {
            for line in text.lines() {
                if let Some(rest) = line.strip_prefix("#define RTC_VERSION_STRING") {
                    return rest.trim().trim_matches('"').to_string();
                }
            }
        }
    }
    "unknown".to_string()
}

fn main() {
    println!("cargo:rerun-if-env-changed=EMBREE_DIR");
    println!("cargo:rerun-if-changed=wrapper.h");
    let found = from_embree_dir()
        .or_else(from_pkg_config)
        .unwrap_or_else(system_default);
    for d in &found.lib_dirs {
        println!("cargo:rustc-link-search=native={}", d.display());
    }
    println!("cargo:rustc-link-lib=dylib=embree3");

    let version = header_version(&found.include_dirs);
    println!("cargo:rustc-env=EMBREE_SYS_HEADER_VERSION={version}");
    // Visible to dependents' build scripts as DEP_EMBREE3_VERSION.
    println!("cargo:version={version}");

    let mut builder = bindgen::Builder::default()
        .header("wrapper.h")
        .allowlist_function("rtc.*")
        .allowlist_type("RTC.*")
        .allowlist_var("RTC.*")
        .derive_default(true)
        .derive_debug(true)
        .prepend_enum_name(false)
        .layout_tests(true);
    for d in &found.include_dirs {
        builder = builder.clang_arg(format!("-I{}", d.display()));
    }
    // bindgen panics (rather than returning Err) when libclang cannot be loaded.
    let prev_hook = std::panic::take_hook();
    std::panic::set_hook(Box::new(|_| {}));
    let generated = std::panic::catch_unwind(std::panic::AssertUnwindSafe(move || builder.generate()));
    std::panic::set_hook(prev_hook);
    let bindings = match generated {
        Ok(Ok(b)) => b,
        Ok(Err(e)) => fail(&format!("bindgen could not parse embree3/rtcore.h: {e}")),
        Err(_) => fail("bindgen could not load libclang (package libclang-dev)"),
    };
    let out = PathBuf::from(env::var("OUT_DIR").expect("cargo sets OUT_DIR"));
    if let Err(e) = bindings.write_to_file(out.join("bindings.rs")) {
        fail(&format!("cannot write bindings: {e}"));
    }
}
