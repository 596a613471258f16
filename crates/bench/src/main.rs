//! `accel-bench`: one tool for the accel crate's measurements.
//!
//! `cargo run -p accel-bench --profile dev -- SUITE [--quick] [--json FILE] [--plots DIR]
//! [--overlays-off] [--panel-closed] [--compute-threads N] [--scene N/PCT/CAMERA[/INDEX]]`
//!
//! Suites of the core crate: `stress` (correctness under numerically hostile input; exits
//! non-zero on any miss, leak, panic or NaN), `build` (build time against tree quality),
//! `update` (upkeep time under motion against quality loss), `rays` (ray time against error,
//! with peers), `meshes` (mesh BVH build and refit time against tree quality, with peers),
//! `preview` (the ray-traced preview's image error against time, per top-level
//! index), `walks` (the shared walks' time per query through every tree, against a linear
//! scan). Suites of the plugin, in headless Bevy apps against Bevy's own systems: `frame`
//! (the whole `App::update`; `--overlays-off` adds the overlays' cost while off,
//! `--panel-closed` the closed panel's), `culling`
//! (the culling system alone; a false negative is a failure), `lights` (the shadow views'
//! culling against bevy_light's; a missing caster is a failure), `picking` (per-ray time of
//! mesh and bounds casts against `MeshRayCast`; a wrong mesh hit is a failure), `sync` (the
//! trees' upkeep per frame for each index choice, against the least any upkeep of the same
//! movers costs) and `scenery` (streaming static scenery in
//! and out against plain Bevy; an entity lost or kept is a failure). More suites of the core
//! crate: `geometry` (the cost of one geometric test, against its f64 error), `structures`
//! (the loose octree and the uniform grid against the dynamic BVH, the quadtree against
//! rstar) and `triangles` (the kd-tree against the mesh BVH and kdtree-ray, the BSP tree).
//! `all` runs
//! every suite. Each prints a table, and optionally writes JSON and draws SVG plots of time
//! against error or quality with the Pareto front marked. `--quick` shrinks every suite so
//! that `all --quick` is a fast check (CI runs it for the failure counts).

mod json;
mod machine;
mod pareto;
mod plot;
mod progress;
mod suites;
mod table;
mod timing;

use std::path::PathBuf;
use std::process::ExitCode;

/// What the command line asked for.
#[derive(Clone, Debug)]
pub struct Options {
    /// The suites to run, in order.
    pub suites: Vec<String>,
    /// Small sizes, for a check in about a minute.
    pub quick: bool,
    /// Where to write the JSON report of every suite run.
    pub json: Option<PathBuf>,
    /// Where to draw the SVG plots.
    pub plots: Option<PathBuf>,
    /// The frame suite also runs the BVH app with Bevy's gizmos, and with the overlays
    /// plugin, every overlay off.
    pub overlays_off: bool,
    /// The frame suite also runs the BVH app with bevy_egui, and with bevy_egui and the
    /// panel plugin, the panel closed.
    pub panel_closed: bool,
    /// Threads of Bevy's compute pool for the plugin suites (Bevy's default otherwise: what
    /// is left of the cores after one each for I/O and async work, at least one).
    pub compute_threads: Option<usize>,
    /// The frame suite runs only this scene (`1000000/25/strategy`), and with a fourth part
    /// (`/Grid`) only that index beside the floor and Bevy: one cell, for a profiler.
    pub frame_scene: Option<String>,
}

const SUITES: &[&str] = &[
    "stress",
    "build",
    "update",
    "rays",
    "meshes",
    "preview",
    "frame",
    "culling",
    #[cfg(feature = "light_culling")]
    "lights",
    "picking",
    "sync",
    "scenery",
    "walks",
    "geometry",
    "structures",
    "triangles",
];

const USAGE: &str = "usage: accel-bench SUITE [--quick] [--json FILE] [--plots DIR] \
    [--overlays-off] [--panel-closed] [--compute-threads N] [--scene N/PCT/CAMERA[/INDEX]]\n\
    SUITE: stress | build | update | rays | meshes | preview | frame | culling | lights | picking | sync |\n\
    scenery | walks | geometry | structures | triangles | all\n\
    --overlays-off: the frame suite also times the overlays plugin with every overlay off\n\
    --panel-closed: the frame suite also times the panel plugin with the panel closed\n\
    --compute-threads N: Bevy's compute pool gets N threads in the plugin suites\n\
    --scene N/PCT/CAMERA[/INDEX]: the frame suite runs that scene only (1000000/25/strategy),\n\
      and with INDEX (Bvh, Grid, Automatic, ...) only that index beside the floor and Bevy";

fn parse(args: impl IntoIterator<Item = String>) -> Result<Options, String> {
    let mut opts = Options {
        suites: Vec::new(),
        quick: false,
        json: None,
        plots: None,
        overlays_off: false,
        panel_closed: false,
        compute_threads: None,
        frame_scene: None,
    };
    let mut args = args.into_iter();
    while let Some(arg) = args.next() {
        match arg.as_str() {
            "--quick" => opts.quick = true,
            "--overlays-off" => opts.overlays_off = true,
            "--panel-closed" => opts.panel_closed = true,
            "--compute-threads" => {
                let n = args.next().ok_or("--compute-threads needs a count")?;
                let n = n.parse().ok().filter(|&n: &usize| n >= 1).ok_or(format!(
                    "--compute-threads needs a count of 1 or more, not {n:?}"
                ))?;
                opts.compute_threads = Some(n);
            }
            "--scene" => {
                let scene = args.next().ok_or("--scene needs N/PCT/CAMERA")?;
                suites::frame::parse_scene(&scene)?;
                opts.frame_scene = Some(scene);
            }
            "--json" => opts.json = Some(args.next().ok_or("--json needs a file")?.into()),
            "--plots" => opts.plots = Some(args.next().ok_or("--plots needs a folder")?.into()),
            "-h" | "--help" => return Err(String::new()),
            "all" => opts.suites.extend(SUITES.iter().map(|s| s.to_string())),
            s if SUITES.contains(&s) => opts.suites.push(s.to_string()),
            other => return Err(format!("unknown argument {other:?}")),
        }
    }
    if opts.suites.is_empty() {
        return Err("no suite given".into());
    }
    Ok(opts)
}

fn main() -> ExitCode {
    let opts = match parse(std::env::args().skip(1)) {
        Ok(o) => o,
        Err(e) => {
            if !e.is_empty() {
                eprintln!("{e}");
            }
            eprintln!("{USAGE}");
            return ExitCode::from(2);
        }
    };
    if let Some(n) = opts.compute_threads {
        // Bevy's pools are made once per process, by the first app unless made before it.
        let mut pools = bevy::app::TaskPoolOptions::default();
        pools.compute.min_threads = n;
        pools.compute.max_threads = n;
        pools.create_default_pools();
    }
    let started = std::time::Instant::now();
    let mut reports = Vec::new();
    for suite in &opts.suites {
        let t = std::time::Instant::now();
        let mut report = suites::run(suite, &opts);
        report.seconds = t.elapsed().as_secs_f64();
        pareto::mark(&mut report.points);
        table::print_report(&report);
        if let Some(dir) = &opts.plots
            && let Err(e) = plot::draw_report(&report, dir)
        {
            eprintln!("plots of {suite}: {e}");
            return ExitCode::from(2);
        }
        reports.push(report);
    }
    if let Some(path) = &opts.json
        && let Err(e) = json::write(path, &reports)
    {
        eprintln!("{}: {e}", path.display());
        return ExitCode::from(2);
    }
    let failures: u64 = reports.iter().map(json::Report::failures).sum();
    println!(
        "\n{} suite(s) in {:.1} s; failures: {failures}",
        reports.len(),
        started.elapsed().as_secs_f64()
    );
    if failures > 0 {
        ExitCode::FAILURE
    } else {
        ExitCode::SUCCESS
    }
}
