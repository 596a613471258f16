//! `accel-bench`: one tool for the accel crate's measurements.
//!
//! `cargo run -p accel-bench --profile dev -- SUITE... [--quick] [--json FILE] [--plots DIR]
//! [--overlays-off] [--panel-closed] [--compute-threads N[,N...]] [--scene SCENE]`
//!
//! The suites run in the order given (`all` for every suite). `-h` prints a summary of the
//! arguments, `--help` each suite and flag at length; a bad argument exits with code 2 and the
//! usage (clap reads the command line).
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
//! mesh and bounds casts against `MeshRayCast`; a wrong mesh hit is a failure), `skinned`
//! (picking walking characters at their posed vertices: the frame with skinned picking on and
//! off, the time per pick against `MeshRayCast` and against baking the posed mesh per cast),
//! `sync` (the
//! trees' upkeep per frame for each index choice, against the least any upkeep of the same
//! movers costs) and `scenery` (streaming static scenery in
//! and out against plain Bevy; an entity lost or kept is a failure). More suites of the core
//! crate: `geometry` (the cost of one geometric test, against its f64 error), `structures`
//! (the loose octree and the uniform grid against the dynamic BVH, the quadtree against
//! rstar) and `triangles` (the kd-tree against the mesh BVH and kdtree-ray, the BSP tree).
//! `all` runs
//! every suite. Each prints a table, and optionally writes JSON (`--json`) and draws SVG plots
//! (`--plots`) of time against error or quality with the Pareto front marked. `--quick`
//! shrinks every suite so that `all --quick` is a fast check (CI runs it for the failure
//! counts). `--compute-threads N` (1 or more) gives Bevy's compute pool N threads in the
//! plugin suites, and a list (`1,2`) runs the tool once per count; `--scene
//! N/PCT/CAMERA[/INDEX]` runs the frame suite on that field scene only
//! (`1000000/25/strategy`), `--scene city/N/CAMERA[/INDEX]` on that city scene, and with
//! INDEX (`Bvh`, `Grid`, `Automatic`, ...) only that index beside the floor and Bevy.

mod json;
mod machine;
mod pareto;
mod plot;
mod progress;
mod suites;
mod table;
mod timing;

use clap::builder::{PossibleValue, PossibleValuesParser};
use clap::error::{ContextKind, ContextValue};
use clap::{CommandFactory, Parser};
use std::path::PathBuf;
use std::process::ExitCode;

/// One tool for the accel crates' measurements: each suite prints a table, and optionally
/// writes JSON and draws SVG plots of time against error or quality with the Pareto front
/// marked. The exit code is non-zero where a suite counted failures.
#[derive(Clone, Debug, Parser)]
#[command(name = "accel-bench", args_override_self = true)]
pub struct Options {
    /// The suites to run, in order (`all`: every suite).
    #[arg(value_name = "SUITE", required = true, value_parser = suite_names())]
    pub suites: Vec<String>,
    /// Small sizes, for a check in about a minute.
    #[arg(long)]
    pub quick: bool,
    /// Where to write the JSON report of every suite run.
    #[arg(long, value_name = "FILE")]
    pub json: Option<PathBuf>,
    /// Where to draw the SVG plots.
    #[arg(long, value_name = "DIR")]
    pub plots: Option<PathBuf>,
    /// The frame suite also runs the BVH app with Bevy's gizmos, and with the overlays
    /// plugin, every overlay off.
    #[arg(long)]
    pub overlays_off: bool,
    /// The frame suite also runs the BVH app with bevy_egui, and with bevy_egui and the
    /// panel plugin, the panel closed.
    #[arg(long)]
    pub panel_closed: bool,
    /// Threads of Bevy's compute pool for the plugin suites, the same for every app (Bevy's
    /// default otherwise: what is left of the cores after one each for I/O and async work,
    /// at least one). A list (`1,2`) sweeps: the tool runs once per count, each run in a
    /// process of its own (Bevy makes its pools once per process), its JSON file and plots
    /// named for the count.
    #[arg(long, value_name = "N[,N...]", value_parser = thread_count, value_delimiter = ',')]
    pub compute_threads: Vec<usize>,
    /// The frame suite runs only this scene: a field (`1000000/25/strategy`: entities,
    /// percent moving, camera) or a city (`city/100000/ground`), and with a last part
    /// (`/Grid`, or another index: `Bvh`, `Automatic`, ...) only that index beside the floor
    /// and Bevy: one cell, for a profiler.
    #[arg(long = "scene", value_name = "[city/]N[/PCT]/CAMERA[/INDEX]", value_parser = frame_scene)]
    pub frame_scene: Option<String>,
    /// With `--scene`, the frames measured (the size's own count otherwise): small worlds
    /// need thousands for a ratio steady to a hundredth.
    #[arg(long, value_name = "N", requires = "frame_scene")]
    pub frames: Option<usize>,
}

/// The suites, in the order `all` runs them, each with its line of `--help`.
const SUITES: &[(&str, &str)] = &[
    (
        "stress",
        "correctness under numerically hostile input (fails on any miss, leak, panic or NaN)",
    ),
    ("build", "build time against tree quality"),
    ("update", "upkeep time under motion against quality loss"),
    ("rays", "ray time against error, with peers"),
    (
        "meshes",
        "mesh BVH build and refit time against tree quality, with peers",
    ),
    (
        "preview",
        "the ray-traced preview's image error against time, per top-level index",
    ),
    (
        "frame",
        "the plugin's whole `App::update` against Bevy's (see --overlays-off, --panel-closed, --scene)",
    ),
    (
        "culling",
        "the culling system alone against Bevy's (a false negative is a failure)",
    ),
    #[cfg(feature = "light_culling")]
    (
        "lights",
        "the shadow views' culling against bevy_light's (a missing caster is a failure)",
    ),
    (
        "picking",
        "per-ray time of mesh and bounds casts against `MeshRayCast` (a wrong mesh hit is a failure)",
    ),
    (
        "skinned",
        "picking animated characters at their posed vertices against `MeshRayCast` and baking",
    ),
    (
        "selection",
        "box selection through the trees against projecting every unit's box, per mode",
    ),
    (
        "sync",
        "the trees' upkeep per frame for each index choice, against the least any upkeep costs",
    ),
    (
        "scenery",
        "streaming static scenery in and out against plain Bevy (an entity lost or kept is a failure)",
    ),
    (
        "walks",
        "the shared walks' time per query through every tree, against a linear scan",
    ),
    (
        "geometry",
        "the cost of one geometric test, against its f64 error",
    ),
    (
        "structures",
        "the loose octree and the uniform grid against the dynamic BVH, the quadtree against rstar",
    ),
    (
        "triangles",
        "the kd-tree against the mesh BVH and kdtree-ray, the BSP tree",
    ),
];

/// The names a `SUITE` argument may take: every suite, and `all`.
fn suite_names() -> PossibleValuesParser {
    SUITES
        .iter()
        .map(|&(name, help)| PossibleValue::new(name).help(help))
        .chain([PossibleValue::new("all").help("every suite above, in this order")])
        .into()
}

/// `--compute-threads`: a count of 1 or more.
fn thread_count(text: &str) -> Result<usize, String> {
    text.parse()
        .ok()
        .filter(|&n: &usize| n >= 1)
        .ok_or(format!("needs a count of 1 or more, not {text:?}"))
}

/// `--scene`: refused here when the frame suite could not read it.
fn frame_scene(text: &str) -> Result<String, String> {
    suites::frame::parse_scene(text)?;
    Ok(text.to_string())
}

/// The options of a command line (`args`, the program's name first), with `all` replaced by
/// every suite.
fn parse_from<I, T>(args: I) -> Result<Options, clap::Error>
where
    I: IntoIterator<Item = T>,
    T: Into<std::ffi::OsString> + Clone,
{
    let mut opts = Options::try_parse_from(args)?;
    opts.suites = opts
        .suites
        .iter()
        .flat_map(|s| match s.as_str() {
            "all" => SUITES.iter().map(|&(name, _)| name.to_string()).collect(),
            _ => vec![s.clone()],
        })
        .collect();
    Ok(opts)
}

/// The options of this process's command line; on bad input, clap's message and the usage
/// on stderr and exit code 2 (`--help` on stdout, exit code 0).
fn parse() -> Options {
    parse_from(std::env::args_os()).unwrap_or_else(|mut e| {
        // Clap shows the usage with some errors only (a missing or unknown argument, not a
        // bad value).
        if e.use_stderr() && e.get(ContextKind::Usage).is_none() {
            let usage = Options::command().render_usage();
            e.insert(ContextKind::Usage, ContextValue::StyledStr(usage));
        }
        e.exit()
    })
}

/// Runs this tool once per count of `counts`, each in a child process with that count alone
/// (and its JSON file and plots named for it); the worst exit code.
fn sweep_threads(opts: &Options, counts: &[usize]) -> ExitCode {
    let exe = match std::env::current_exe() {
        Ok(exe) => exe,
        Err(e) => {
            eprintln!("the sweep needs this tool's own path: {e}");
            return ExitCode::from(2);
        }
    };
    let mut worst = ExitCode::SUCCESS;
    for &n in counts {
        println!("\n==== {n} compute thread(s)");
        let mut child = std::process::Command::new(&exe);
        child
            .args(&opts.suites)
            .arg("--compute-threads")
            .arg(n.to_string());
        for (flag, on) in [
            ("--quick", opts.quick),
            ("--overlays-off", opts.overlays_off),
            ("--panel-closed", opts.panel_closed),
        ] {
            if on {
                child.arg(flag);
            }
        }
        if let Some(scene) = &opts.frame_scene {
            child.arg("--scene").arg(scene);
        }
        if let Some(frames) = opts.frames {
            child.arg("--frames").arg(frames.to_string());
        }
        if let Some(json) = &opts.json {
            child
                .arg("--json")
                .arg(json.with_extension(format!("threads-{n}.json")));
        }
        if let Some(plots) = &opts.plots {
            child.arg("--plots").arg(plots.join(format!("threads-{n}")));
        }
        match child.status() {
            Ok(status) if status.success() => {}
            Ok(status) => {
                eprintln!("the run with {n} compute thread(s) ended with {status}");
                worst = ExitCode::FAILURE;
            }
            Err(e) => {
                eprintln!("the run with {n} compute thread(s) did not start: {e}");
                return ExitCode::from(2);
            }
        }
    }
    worst
}

fn main() -> ExitCode {
    let opts = parse();
    if opts.compute_threads.len() > 1 {
        return sweep_threads(&opts, &opts.compute_threads);
    }
    if let Some(&n) = opts.compute_threads.first() {
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

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(args: &str) -> Result<Options, clap::Error> {
        parse_from(std::iter::once("accel-bench").chain(args.split_whitespace()))
    }

    #[test]
    fn suites_in_order_between_flags_and_all_expanded() {
        let o = parse("geometry --quick all --json f.json build").unwrap();
        let mut want = vec!["geometry".to_string()];
        want.extend(SUITES.iter().map(|&(name, _)| name.to_string()));
        want.push("build".into());
        assert_eq!(o.suites, want);
        assert!(o.quick);
        assert_eq!(o.json, Some(PathBuf::from("f.json")));
    }

    #[test]
    fn flags_and_values() {
        let o = parse(
            "picking --json f.json --plots dir --compute-threads 2 --overlays-off --panel-closed",
        )
        .unwrap();
        assert_eq!(o.suites, ["picking"]);
        assert_eq!(o.plots, Some(PathBuf::from("dir")));
        assert_eq!(o.compute_threads, [2]);
        assert!(o.overlays_off && o.panel_closed && !o.quick);
        let o = parse("frame --compute-threads 1,2").unwrap();
        assert_eq!(o.compute_threads, [1, 2]);
        let o = parse("frame --scene 1000000/25/strategy --quick --quick").unwrap();
        assert_eq!(o.frame_scene.as_deref(), Some("1000000/25/strategy"));
        let o = parse("frame --scene 1000/25/ground/Grid --json a --json b").unwrap();
        assert_eq!(o.frame_scene.as_deref(), Some("1000/25/ground/Grid"));
        assert_eq!(o.json, Some(PathBuf::from("b")));
    }

    #[test]
    fn bad_input_is_refused_with_exit_code_2() {
        for args in [
            "",
            "--quick",
            "nosuch",
            "build --nosuch",
            "build --compute-threads 0",
            "build --compute-threads many",
            "build --compute-threads 1,0",
            "frame --scene 1000/25",
            "frame --scene 1000/101/strategy",
            "frame --scene 1000/25/strategy/NoSuchIndex",
            "frame --scene city/1000/25/strategy",
            "build --json",
        ] {
            let e = parse(args)
                .err()
                .unwrap_or_else(|| panic!("{args:?} accepted"));
            assert_eq!(e.exit_code(), 2, "{args:?}");
        }
        for args in ["-h", "--help", "build -h"] {
            let e = parse(args)
                .err()
                .unwrap_or_else(|| panic!("{args:?} accepted"));
            assert_eq!(e.exit_code(), 0, "{args:?}");
        }
    }
}
