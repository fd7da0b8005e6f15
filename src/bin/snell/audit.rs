//! `snell audit nested`: interior lists against point-in-solid tests, per
//! strategy.
use crate::args::AuditNestedArgs;
use crate::write::write_json;
use snell::integrator::Queries;
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
    let queries: &[Queries] = if a.packets {
        &[Queries::Single, Queries::Packets]
    } else {
        &[Queries::Single]
    };
    for strategy in a.nested {
        for &q in queries {
            let t = Instant::now();
            let tr = snell::integrator::Tracer::new(&s).with_strategy(strategy);
            let r = pool.install(|| snell::audit::audit_scene_with(tr, a.rays, a.seed, q))?;
            let name = match q {
                Queries::Single => strategy.name().to_string(),
                Queries::Packets => format!("{}+packets", strategy.name()),
            };
            say!("{name:<15} {r} [{:.1} s]", t.elapsed().as_secs_f64());
            out.push(serde_json::json!({
                "scene": a.scene.display().to_string(),
                "strategy": strategy.name(),
                "queries": match q { Queries::Single => "single", Queries::Packets => "packets" },
                "report": r,
                "provenance": snell::provenance::json(),
            }));
        }
    }
    if let Some(p) = &a.json {
        write_json(p, &out)?;
    }
    Ok(())
}
