//! `snell grin-trace` and `snell warp-points`: a JSON document of queries in,
//! a JSON document of answers out.
use crate::args::QueriesArgs;
use crate::write::write_or_print;
use snell::{Error, Result};

pub fn grin_trace(a: QueriesArgs) -> Result<()> {
    let text = std::fs::read_to_string(&a.queries).map_err(|e| Error::io(&a.queries, e))?;
    let out = snell::media::grin_trace_json(&text)
        .map_err(|e| Error::Invalid(format!("{}: {e}", a.queries.display())))?;
    write_or_print(a.output, &out)
}

pub fn warp_points(a: QueriesArgs) -> Result<()> {
    let text = std::fs::read_to_string(&a.queries).map_err(|e| Error::io(&a.queries, e))?;
    let out = snell::warp::points::warp_points_json(&a.queries.display().to_string(), &text)
        .map_err(Error::Invalid)?;
    write_or_print(a.output, &out)
}
