//! `mlrender`: the test renderer and instruments of manylights.

use clap::{Parser, Subcommand};
use manylights_render::bench;

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
    }
}
