//! `globe bench --scene soak`: the seeded random flight under faults, and its summary.

use std::process::ExitCode;

use anyhow::{Context, bail};
use globe::progress::Progress;
use globe::render::GpuContext;

use crate::args::*;
use crate::bench::*;

pub fn bench_soak(args: &BenchArgs) -> anyhow::Result<ExitCode> {
    use globe::instruments::soak;
    let seconds = args.seconds.unwrap_or(600.0);
    if !(seconds > 0.0 && seconds.is_finite()) {
        bail!("--seconds must be above 0 (got {seconds})");
    }
    if !(args.settle_timeout > 0.0 && args.settle_timeout.is_finite()) {
        bail!(
            "--settle-timeout must be above 0 (got {})",
            args.settle_timeout
        );
    }
    let (lo, hi) = soak::DEFAULT_LATENCY_MS;
    let [latency] = args.stream.latencies(LatencyMs { min: lo, max: hi })[..] else {
        bail!("--scene soak takes one --tile-latency-ms (MS or MIN-MAX)");
    };
    let mut stream = args
        .stream
        .settings_with(latency, soak::DEFAULT_FAIL_RATE)?;
    stream.faults.seed = args.seed;
    let fps = args.fps.unwrap_or(0.0);
    if !(fps >= 0.0 && fps.is_finite()) {
        bail!("--fps must be 0 or more (got {fps})");
    }
    if let Some(dir) = &args.mismatch_dir {
        std::fs::create_dir_all(dir)
            .with_context(|| format!("cannot create --mismatch-dir {}", dir.display()))?;
    }
    let ctx = GpuContext::headless().context("cannot benchmark without a graphics adapter")?;
    eprintln!("adapter: {}", ctx.adapter_description());
    let terrain = args.dem.open()?;
    eprintln!("terrain: {}", terrain.describe());
    let options = soak::SoakOptions {
        seconds,
        seed: args.seed,
        legs: globe::scenes::soak_path::LegSeconds::default(),
        width: args.width,
        height: args.height,
        settings: args.mesh.settings()?,
        stream,
        look: args.look.settings(),
        lod: args.lod.settings()?,
        frame_interval: (fps > 0.0).then(|| std::time::Duration::from_secs_f64(1.0 / fps)),
        settle_timeout: std::time::Duration::from_secs_f64(args.settle_timeout),
        rss_slack_bytes: soak::DEFAULT_RSS_SLACK_BYTES,
        mismatch_dir: args.mismatch_dir.clone(),
    };
    eprintln!(
        "soak: seed {}, {seconds} s, {}×{}, fail rate {}, latency {latency} ms, cache {} MiB, \
         {} GPU tiles",
        args.seed,
        args.width,
        args.height,
        stream.faults.fail_rate,
        stream.cache_bytes >> 20,
        stream.gpu_tiles
    );
    let mut progress = Progress::new("soak", seconds.ceil() as u64, Some("s"));
    let run = soak::run(&ctx, &terrain, &options, |p| {
        progress.note(format!(
            "{} frames, {} settle points ({} not equal), {} reads in frames",
            p.frames, p.settle_points, p.settle_points_bad, p.reads_in_frames
        ));
        progress.set(p.t_s as u64);
    })?;
    progress.finish();
    if let Some(path) = &args.csv {
        std::fs::write(path, run.frames_csv())
            .with_context(|| format!("cannot write {}", path.display()))?;
    }
    if let Some(path) = &args.plot {
        run.write_plot(path)
            .with_context(|| format!("cannot write {}", path.display()))?;
    }
    let f = run.findings();
    if args.json {
        println!("{}", run.to_json());
    } else {
        print_soak(&run, &f);
    }
    let failures = f.failures();
    if failures.is_empty() {
        Ok(ExitCode::SUCCESS)
    } else {
        for line in &failures {
            eprintln!("globe bench: soak failed: {line}");
        }
        Ok(ExitCode::FAILURE)
    }
}

pub fn print_soak(
    run: &globe::instruments::soak::SoakRun,
    f: &globe::instruments::soak::SoakFindings,
) {
    let mib = |b: u64| b as f64 / 1048576.0;
    let opt_mib = |b: Option<u64>| b.map_or("n/a".to_owned(), |b| format!("{:.1}", mib(b)));
    println!(
        "soak, seed {}: {:.0} s flown in {:.0} s, {} frames, {} legs ({} jumps; {})",
        run.options.seed,
        f.flown_s,
        f.wall_s,
        f.frames,
        f.legs,
        f.jumps,
        f.places
            .iter()
            .map(|(p, n)| format!("{} {n}", p.name()))
            .collect::<Vec<_>>()
            .join(", ")
    );
    println!(
        "  frames that read the file: {}; CPU ms per frame median {:.2}, p99 {:.2}, max {:.2}",
        f.frames_reading_the_file, f.cpu_ms_median, f.cpu_ms_p99, f.cpu_ms_max
    );
    println!(
        "  settle points: {}, not settled {}, differing from the fault-free render {} (max {} px, \
         visibly at most {:.3} % of the image); settle s median {:.2}, max {:.2}",
        f.settle_points,
        f.settle_failures,
        f.settle_points_differing,
        f.max_differing_px,
        100.0 * f.max_visibly_differing_share,
        f.settle_s_median,
        f.settle_s_max
    );
    for p in run.settles.iter().filter(|p| p.differing_px != Some(0)) {
        println!(
            "    leg {} ({}) at {:.1} s: {}",
            p.leg,
            p.place.name(),
            p.t_s,
            p.error.clone().unwrap_or_else(|| format!(
                "{} px differ, {} of them visibly (a channel by more than {})",
                p.differing_px.unwrap_or(0),
                p.visibly_differing_px.unwrap_or(0),
                globe::instruments::soak::VISIBLE_CHANNEL_DIFF
            ))
        );
        if let Some(m) = &p.mismatch {
            println!(
                "      a fresh renderer differs from the flying one by {} px, from the reference \
                 by {} px; triangles {:?}, levels {:?}, height above terrain {:?} m \
                 (flying, reference, fresh)",
                m.fresh_vs_flying_px,
                m.fresh_vs_reference_px,
                m.triangles,
                m.levels,
                m.height_above_terrain_m
            );
        }
    }
    println!(
        "  tiles loaded {}, failed reads {}, retries {}",
        f.tiles_loaded, f.tiles_failed, f.retries
    );
    println!(
        "  memory, MiB: cache max {:.1} of {:.1} (the frame's own tiles, kept beyond it: at most \
         {:.1}; frames over both: {}); GPU tiles max {} of {}; anonymous RSS max {} \
         of budget {} (first half's max {}, slope over the second half {} MiB/min); file-backed RSS max {}",
        mib(f.cache_bytes_max),
        mib(f.cache_budget),
        mib(f.cache_kept_bytes_max),
        f.frames_over_cache_budget,
        f.gpu_tiles_max,
        f.gpu_capacity,
        opt_mib(f.rss_anon_max),
        opt_mib(f.rss_anon_budget),
        opt_mib(f.rss_anon_baseline),
        f.rss_anon_slope_mib_per_min
            .map_or("n/a".to_owned(), |s| format!("{s:+.2}")),
        opt_mib(f.rss_file_max)
    );
    println!("  {}", if f.passed() { "PASSED" } else { "FAILED" });
}
