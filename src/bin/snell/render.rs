//! `snell render`: load the scene with its overrides, plan the part, render,
//! write by the output rules of [`crate::output`], report.
use crate::args::RenderArgs;
use crate::output::{self, Resume};
use crate::write::write_json;
use snell::render::{CancelToken, ProgressSink, RenderOptions, RenderSettings, Rendered};
use snell::scene::{BuildOptions, RenderScene};
use snell::{Error, Result};
use std::time::Instant;

pub fn render(mut a: RenderArgs) -> Result<()> {
    if let (Some(sw), Some(i)) = (&a.sweep, a.sweep_index) {
        a.set.push(snell::overrides::sweep_value(sw, i)?);
    }
    let (output, aov, quiet, farm) = (&a.output, &a.aov, a.quiet, &a.farm);
    if farm.mkdir {
        snell::farm::make_parent(output)?;
    }
    let load_t = Instant::now();
    let build = BuildOptions {
        import: a.import.options()?,
        analytic_set: a.analytic_shapes == crate::args::AnalyticShapes::Auto,
        ..BuildOptions::default()
    };
    let tag = snell::render::id_tag(a.nested, a.light_sampling.into());
    let (s, scene_id) = snell::farm::load(&a.scene, &a.set, &build, &tag)?;
    let load_s = load_t.elapsed().as_secs_f64();
    for w in &s.warnings {
        eprintln!("warning: {w}");
    }
    let settings = render_settings(&a, &s)?;
    let resume = Resume::new(output, farm.resume.as_ref(), farm.resume_partial, quiet);
    let fa = snell::farm::FarmArgs {
        region: farm.region.clone(),
        region_cell: farm.region_cell.clone(),
        samples: farm.samples.clone(),
        sample_chunk: farm.sample_chunk.clone(),
        resume: resume.from.clone(),
        part: farm.part,
    };
    let plan = snell::farm::plan(&settings, &scene_id, &fa, output::is_exr(output))?;
    if plan.is_part && !aov.is_empty() {
        return Err(Error::Invalid(
            "--aov layers are not merged: render them in one piece (no --region, --samples, --resume or --part)"
                .into(),
        ));
    }
    let progress = match (farm.progress_lines, quiet) {
        (true, _) => ProgressSink::Lines,
        (false, true) => ProgressSink::None,
        (false, false) => ProgressSink::Bar,
    };
    let cancel = CancelToken::new();
    stop_on_signals(&cancel);
    let r = snell::render::render_part(
        &s,
        &settings,
        &RenderOptions {
            threads: a.threads,
            progress,
            want_aovs: !aov.is_empty(),
            cancel,
            observer: None,
            packet_width: a.packet_width.into(),
            flights: a.flights.into(),
            shading: a.shading.into(),
        },
        &plan.spec,
    )?;
    let written = output::written_path(output, &r);
    let attrs = output::attributes(&r);
    let st = render_stats(&r, &s, &settings, load_s, &scene_id, &a.set);
    output::write_render(&written, &r, &plan, aov, &attrs, &st, quiet)?;
    if let Some(p) = &a.stats_json {
        write_json(p, &st)?;
    }
    resume.finish(&r, &written, output);
    if r.stats.counters.nan > 0 {
        eprintln!(
            "warning: {} samples were NaN or Inf and were dropped",
            r.stats.counters.nan
        );
    }
    if !quiet {
        eprintln!(
            "rendered {}x{} at {} spp in {:.2} s ({:.3} Msamples/s, {:.3} Mrays/s)",
            r.width,
            r.height,
            r.spp_done,
            r.stats.wall_s,
            st["samples_per_s"].as_f64().unwrap_or(0.0) / 1e6,
            st["rays_per_s"].as_f64().unwrap_or(0.0) / 1e6
        );
    }
    say!("{}", written.display());
    Ok(())
}

/// The scene's render settings with the command line's strategy, light
/// sampling, spp, seed and resolution.
fn render_settings(a: &RenderArgs, s: &RenderScene) -> Result<RenderSettings> {
    let mut settings = RenderSettings::from_scene(s)
        .with_strategy(a.nested)
        .with_light_sampling(a.light_sampling.into());
    if let Some(v) = a.spp {
        settings = settings.with_spp(v);
    }
    if let Some(v) = a.seed {
        settings = settings.with_seed(v);
    }
    if a.width.is_some() || a.height.is_some() {
        settings = settings.with_resolution(a.width.unwrap_or(s.width), a.height.unwrap_or(s.height))?;
    }
    Ok(settings)
}

/// Ctrl-C (or SIGTERM, SIGHUP: a farm cancelling the task) cancels the
/// render holding `cancel` at the next tile boundary and the image so far is
/// written, clearly named; a second signal exits at once.
fn stop_on_signals(cancel: &CancelToken) {
    let cancel = cancel.clone();
    let _ = ctrlc::set_handler(move || {
        if cancel.is_cancelled() {
            std::process::exit(130);
        }
        cancel.cancel();
        eprintln!("\ninterrupted: finishing the tiles in progress (Ctrl-C again to exit at once)");
    });
}

/// The stats JSON of a render: the render's own, plus the run's CPU and load
/// time, the part it covers, the scene's identity, how Embree built it, the
/// overrides and the medium's tracing method and field kind.
fn render_stats(
    r: &Rendered,
    scene: &RenderScene,
    settings: &RenderSettings,
    load_s: f64,
    scene_id: &str,
    set: &[String],
) -> serde_json::Value {
    let mut st = r.stats.to_json(settings, r.spp_done);
    // The tiles' CPU time (the render pool's, as `wall_s` times the tiles)
    // before `cpu_s` becomes the whole run's: on a loaded machine it
    // measures the render where the wall clock does not.
    st["tiles_cpu_s"] = serde_json::json!(r.stats.cpu_s);
    st["cpu_s"] = serde_json::json!(snell::timing::process_cpu_s());
    st["load_s"] = serde_json::json!(load_s);
    st["region"] = serde_json::json!(r.region.to_string());
    st["samples_range"] = serde_json::json!(format!("{}:{}", r.sample_start, r.sample_count));
    st["scene_id"] = serde_json::json!(scene_id);
    let eb = &scene.embree;
    st["embree_scene"] = serde_json::json!({
        "robust": eb.flags().robust,
        "context_filter": eb.flags().context_filter,
        "build_quality": eb.build_quality().name(),
        "user_geometries": eb.user_geometries(),
        "analytic_set": scene.analytic_set.is_some(),
    });
    st["overrides"] = serde_json::json!(set);
    // The method the medium is traced by, `auto` resolved (null without a
    // medium), and its field: what a speed figure of the render depends on.
    let medium = scene.medium.as_ref();
    st["grin_method"] = serde_json::json!(medium.map(|m| m.method().name()));
    st["grin_field"] = serde_json::json!(medium.map(|m| m.field().kind()));
    st
}
