//! `mlmeasure`: the instruments of manylights: `bench`, `sptd-accuracy`, `estimator`,
//! `selection` and `vpl`.

use clap::{Parser, Subcommand};
use manylights_instruments::{bench, estimator, selection, sptd_accuracy, vpl};
use manylights_render::cli::{at_least_one, image_size, palette};
use manylights_render::params::ParamArgs;
use manylights_render::scene;

/// Counts the heap in use, for the build's peak in `mlmeasure bench`.
#[global_allocator]
static ALLOC: manylights_instruments::alloc_count::CountingAlloc =
    manylights_instruments::alloc_count::CountingAlloc;

#[derive(Parser)]
#[command(name = "mlmeasure", version, about = "Instruments of manylights")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Build time, memory, sampling throughput (4-wide vs binary baseline) and pmf exactness
    /// on a random scene, single-threaded.
    Bench {
        /// Number of lights.
        #[arg(long, default_value_t = 100_000)]
        lights: usize,
        /// Number of shading points, one sample each.
        #[arg(long, default_value_t = 1_000_000)]
        points: usize,
        /// Seed of the scene, shading points and uniform numbers.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Timed repetitions of each build and loop (the fastest is reported).
        #[arg(long, default_value_t = 3)]
        repeats: usize,
        /// The scene: the mixed one or point lights only.
        #[arg(long, value_enum, default_value_t = bench::SceneKinds::Mixed)]
        kinds: bench::SceneKinds,
        /// Measure the builds only (time, peak heap, size, shape): no sampling passes.
        #[arg(long)]
        build_only: bool,
        /// Print one JSON object as the last line of stdout.
        #[arg(long)]
        json: bool,
    },
    /// Accuracy of the GGX cap-integral model against MIS ground truth: random caps (overall)
    /// and small caps off the mirror direction at grazing views (grazing), reported separately.
    SptdAccuracy {
        /// Number of random cases (the overall stratum).
        #[arg(long, default_value_t = 500)]
        cases: usize,
        /// Number of grazing cases (the grazing stratum).
        #[arg(long, default_value_t = 500)]
        grazing_cases: usize,
        /// Seed of the cases and of the ground truth.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Ground truth from GRID² stratified MIS pairs per case.
        #[arg(long, default_value_t = 256)]
        grid: usize,
        /// Print one JSON object as the last line of stdout.
        #[arg(long)]
        json: bool,
    },
    /// Unbiasedness, variance and time per estimate of every technique against exact values,
    /// without visibility.
    Estimator(estimator::EstimatorArgs),
    /// The variance of the light choice (BRDF-oriented cut, TL descent, and two descents
    /// without a cut) at a scene's shading points, from every light's contribution and
    /// probability: where a cut fails; beside them the floors of a choice proportional to each
    /// light's unshadowed and to its shadowed contribution.
    Selection {
        /// Scene: cornell, exhibition, city, city-sun, stairs, or a path to an .obj file.
        #[arg(long, default_value = "city")]
        scene: String,
        /// Number of lights (cornell only; default 1,494).
        #[arg(long)]
        lights: Option<usize>,
        /// Shading points (jittered primary hits).
        #[arg(long, default_value_t = 4000, value_parser = at_least_one())]
        points: usize,
        /// Image width the pixel positions are drawn in.
        #[arg(long, default_value_t = 192, value_parser = image_size())]
        width: usize,
        /// Image height the pixel positions are drawn in.
        #[arg(long, default_value_t = 192, value_parser = image_size())]
        height: usize,
        /// Seed of the points.
        #[arg(long, default_value_t = 3)]
        seed: u64,
        /// The scene in grey.
        #[arg(long)]
        grey: bool,
        /// Print one JSON object as the last line of stdout.
        #[arg(long)]
        json: bool,
        /// The estimators' parameters (the cut's: `--bl-cut-*`).
        #[command(flatten)]
        params: ParamArgs,
    },
    /// Instant radiosity for the indirect diffuse light, plain and with probabilistic VPL
    /// acceptance (Georgiev & Slusallek 2010), gathered from all VPLs or through a light tree,
    /// against a cached converged reference: images under out/vpl/SCENE/, a table.
    Vpl(vpl::VplArgs),
}

fn main() {
    let cli = Cli::parse();
    match cli.command {
        Command::Bench {
            lights,
            points,
            seed,
            repeats,
            kinds,
            build_only,
            json,
        } => {
            let report = bench::run(&bench::BenchConfig {
                lights,
                points,
                seed,
                repeats,
                kinds,
                build_only,
            });
            println!("{}", bench::table(&report));
            if json {
                println!("{}", report.to_json());
            }
        }
        Command::SptdAccuracy {
            cases,
            grazing_cases,
            seed,
            grid,
            json,
        } => {
            let cfg = sptd_accuracy::AccuracyConfig {
                cases,
                seed,
                grid,
                grazing_cases,
            };
            let (cs, report) = sptd_accuracy::run(&cfg);
            println!("{}", sptd_accuracy::table(&cs, &report));
            if json {
                println!("{report}");
            }
        }
        Command::Selection {
            scene,
            lights,
            points,
            width,
            height,
            seed,
            grey,
            json,
            params,
        } => {
            let rs = scene::by_name_with(&scene, lights, palette(grey)).unwrap_or_else(|e| {
                eprintln!("{e}");
                std::process::exit(2)
            });
            let cfg = selection::SelectionConfig {
                points,
                width,
                height,
                seed,
                cut: params.params().bl_cut,
            };
            let report = selection::run(&rs, &cfg);
            print!("{}", report.table(&scene, &cfg));
            if json {
                println!("{}", report.json(&scene, &cfg));
            }
        }
        Command::Estimator(args) => std::process::exit(estimator::run_cli(&args)),
        Command::Vpl(args) => std::process::exit(vpl::run_cli(&args)),
    }
}
