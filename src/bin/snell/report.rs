//! `snell report`: run the measurements and write the report directory.
use crate::args::ReportArgs;
use snell::Result;

pub fn report(a: ReportArgs) -> Result<()> {
    let opts = snell::report::ReportOptions {
        out: a.output,
        quick: a.quick,
        scenes_dir: a.scenes_dir,
    };
    let command = std::env::args().collect::<Vec<_>>().join(" ");
    let index = snell::report::run(&opts, &command, |m| eprintln!("{m}"))?;
    say!("{}", index.display());
    Ok(())
}
