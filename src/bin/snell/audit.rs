//! `snell audit nested`: interior lists against point-in-solid tests, per
//! strategy.
use crate::args::AuditNestedArgs;
use crate::write::write_json;
use snell::scene::{load_scene, BuildOptions};
use snell::{Error, Result};
use std::time::Instant;

pub fn audit_nested(a: AuditNestedArgs) -> Result<()> {
    let pool = rayon::ThreadPoolBuilder::new()
        .num_threads(a.threads.unwrap_or(0))
        .build()
        .map_err(|e| Error::Invalid(e.to_string()))?;
    say!("{}", snell::bench_header());
    let mut out = Vec::new();
    let s = load_scene(&a.scene, &BuildOptions::default())?;
    for strategy in a.nested {
        let t = Instant::now();
        let tr = snell::integrator::Tracer::new(&s).with_strategy(strategy);
        let r = pool.install(|| snell::audit::audit_scene(tr, a.rays, a.seed))?;
        say!("{:<7} {r} [{:.1} s]", strategy.name(), t.elapsed().as_secs_f64());
        out.push(serde_json::json!({
            "scene": a.scene.display().to_string(),
            "strategy": strategy.name(),
            "report": r,
            "provenance": snell::provenance::json(),
        }));
    }
    if let Some(p) = &a.json {
        write_json(p, &out)?;
    }
    Ok(())
}
