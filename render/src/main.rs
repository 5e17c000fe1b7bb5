//! `mlrender`: the test renderer and instruments of manylights.

use clap::{Parser, Subcommand};
use manylights_render::{bench, sptd_accuracy, sptd_fit};
use std::path::PathBuf;

#[derive(Parser)]
#[command(
    name = "mlrender",
    version,
    about = "Test renderer and instruments of manylights"
)]
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
        /// Timed repetitions of each loop (the fastest is reported).
        #[arg(long, default_value_t = 3)]
        repeats: usize,
        /// Print one JSON object as the last line of stdout.
        #[arg(long)]
        json: bool,
    },
    /// Fit the SPTD parameters of GGX (MATH.md section 8) and write the core's generated
    /// table src/importance/sptd_ggx_table.rs.
    SptdFit {
        /// Where to write the table (default: the core's src/importance/sptd_ggx_table.rs).
        #[arg(long)]
        out: Option<PathBuf>,
        /// Re-fit K nodes spread over the committed table and compare (exit 1 on mismatch).
        #[arg(long, value_name = "K")]
        check: Option<usize>,
        /// Only fit and print these nodes, "i,j;i,j;..." (nothing is written).
        #[arg(long)]
        cells: Option<String>,
        /// Test caps per node.
        #[arg(long, default_value_t = 384)]
        caps: usize,
    },
    /// Accuracy of the GGX SPTD against MIS ground truth on random caps.
    SptdAccuracy {
        /// Number of random cases.
        #[arg(long, default_value_t = 500)]
        cases: usize,
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
    /// Unbiasedness, variance and time per estimate of the estimators (uniform, power, tl,
    /// tl-split, bl, mis-equal, full) against exact values, without visibility.
    Estimator(manylights_render::estimator::EstimatorArgs),
}

fn main() {
    let cli = Cli::parse();
    match cli.command {
        Command::Bench {
            lights,
            points,
            seed,
            repeats,
            json,
        } => {
            let report = bench::run(&bench::BenchConfig {
                lights,
                points,
                seed,
                repeats,
            });
            println!("{}", bench::table(&report));
            if json {
                println!("{report}");
            }
        }
        Command::SptdFit {
            out,
            check,
            cells,
            caps,
        } => std::process::exit(sptd_fit::run_cli(out, check, cells, caps)),
        Command::SptdAccuracy {
            cases,
            seed,
            grid,
            json,
        } => {
            let cfg = sptd_accuracy::AccuracyConfig { cases, seed, grid };
            let (cs, report) = sptd_accuracy::run(&cfg);
            println!("{}", sptd_accuracy::table(&cs, &report));
            if json {
                println!("{report}");
            }
        }
        Command::Estimator(args) => {
            std::process::exit(manylights_render::estimator::run_cli(&args))
        }
    }
}
