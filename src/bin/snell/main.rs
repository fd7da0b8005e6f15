//! The `snell` command line: `args` is its shape (the clap types), each other
//! module runs one family of subcommands; `run` only dispatches.
#![deny(unsafe_code)]

/// Print to stdout, ignoring a closed pipe (`snell … | head` must not panic).
macro_rules! say {
    ($($t:tt)*) => {{
        use std::io::Write;
        let _ = writeln!(std::io::stdout(), $($t)*);
    }};
}

mod args;
mod audit;
mod bench;
mod convert;
mod farm;
mod fuzz;
mod grin_fan;
mod output;
mod queries;
mod render;
mod report;
mod warp_render;
mod write;

use args::{AuditCmd, BenchCmd, Cli, Cmd};
use clap::Parser;
use snell::Result;
use std::process::ExitCode;

fn main() -> ExitCode {
    match run(Cli::parse()) {
        Ok(()) => ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e}");
            ExitCode::from(1)
        }
    }
}

fn run(cli: Cli) -> Result<()> {
    match cli.cmd {
        Cmd::Render(a) => render::render(a),
        Cmd::Convert(a) => convert::convert(a),
        Cmd::Merge(a) => farm::merge(a),
        Cmd::Table(a) => farm::table(a),
        Cmd::Audit {
            which: AuditCmd::Nested(a),
        } => audit::audit_nested(a),
        Cmd::GrinTrace(a) => queries::grin_trace(a),
        Cmd::GrinFan(a) => grin_fan::grin_fan(a),
        Cmd::WarpPoints(a) => queries::warp_points(a),
        Cmd::WarpRender(a) => warp_render::warp_render(a),
        Cmd::Fuzz(a) => fuzz::fuzz(a),
        Cmd::Report(a) => report::report(a),
        Cmd::Bench {
            which: BenchCmd::Embree(a),
        } => bench::bench_embree(a),
        Cmd::Bench {
            which: BenchCmd::Nested(a),
        } => bench::bench_nested(a),
        Cmd::Bench {
            which: BenchCmd::Render(a),
        } => bench::bench_render(a),
        Cmd::Bench {
            which: BenchCmd::Grin(a),
        } => bench::bench_grin(a),
    }
}
