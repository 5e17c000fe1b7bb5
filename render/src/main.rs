//! `mlrender`: the test renderer of manylights: `render`, `reference` and `compare`.

use clap::{Parser, Subcommand};
use manylights::Technique;
use manylights_render::cli::{at_least_one, image_size, palette};
use manylights_render::params::{ParamArgs, TechniqueArg};
use manylights_render::{compare, image, render, scene};
use std::path::PathBuf;

#[derive(Parser)]
#[command(name = "mlrender", version, about = "Test renderer of manylights")]
struct Cli {
    #[command(subcommand)]
    command: Command,
}

#[derive(Subcommand)]
enum Command {
    /// Render a built-in scene (direct illumination) with one technique to a PNG, or to a
    /// linear OpenEXR file when the output name ends in .exr.
    Render {
        /// Scene: cornell, exhibition, city, city-sun, stairs, office, market, billboard, or a path
        /// to an .obj file (with its .mtl).
        #[arg(long, default_value = "cornell")]
        scene: String,
        /// Number of lights (cornell only; default 1,494).
        #[arg(long)]
        lights: Option<usize>,
        /// The technique (default: the core's `Technique::DEFAULT`).
        #[arg(long, value_enum, default_value_t = TechniqueArg(Technique::DEFAULT))]
        technique: TechniqueArg,
        /// Estimates per pixel.
        #[arg(long, default_value_t = 16, value_parser = at_least_one())]
        spp: usize,
        /// Image width (default: a pbrt file's `Film` resolution, else 256).
        #[arg(long, value_parser = image_size())]
        width: Option<usize>,
        /// Image height (default: a pbrt file's `Film` resolution, else 256).
        #[arg(long, value_parser = image_size())]
        height: Option<usize>,
        /// Seed of the estimates.
        #[arg(long, default_value_t = 1)]
        seed: u64,
        /// Output image: linear 32-bit float RGB OpenEXR if the name ends in .exr, otherwise
        /// PNG (8-bit sRGB, values clamped to [0, 1]).
        #[arg(short, long, default_value = "out.png")]
        output: PathBuf,
        /// One shading point per pixel (its centre), its set-up reused by every estimate
        /// (default: a new jittered shading point and set-up for every estimate).
        #[arg(long)]
        fixed_point: bool,
        /// The scene in grey (every light and albedo grey, as the scalar scenes were).
        #[arg(long)]
        grey: bool,
        /// The camera instead of the scene's: `eye,target,up,fov` as ten comma-separated
        /// numbers (eye x, y, z, the point looked at, the up direction, the vertical field of
        /// view in degrees). An OBJ file's default frames its bounding sphere from +z.
        #[arg(long, value_parser = scene::Camera::parse, allow_hyphen_values = true)]
        camera: Option<scene::Camera>,
        /// The estimators' parameters.
        #[command(flatten)]
        params: ParamArgs,
    },
    /// Compute (or load) the cached reference of a scene under out/reference/ and check that
    /// tl-split at a quarter of its spp converges to the same image average (a progress bar
    /// with the time left on stderr when it is a terminal).
    Reference {
        #[command(flatten)]
        image: ImageArgs,
        /// Estimates per pixel of the reference (default 1,024, 256 with --quick: the
        /// reference `compare` uses at its default spp).
        #[arg(long, value_parser = at_least_one())]
        ref_spp: Option<usize>,
    },
    /// Every technique on a built-in scene at equal spp and equal time against a cached
    /// reference (out/reference/): PNG and linear EXR images, side-by-side images with crops,
    /// convergence plot (SVG) and RMSE tables (Markdown, table.md) under
    /// `out/compare/<scene>-<lights>/`. Prints a short summary (one line per technique; the
    /// full tables with --full).
    ///
    /// Times are busy CPU time summed over the render threads (each image row timed by its
    /// thread's CPU clock; about wall time × threads on idle cores, and not inflated by other
    /// processes). The equal-time budget per technique is what `full` took at the equal spp,
    /// or --time SECONDS; each technique then renders at
    /// max(1, round((budget − fixed) / per-spp time)) spp, with its fixed time measured by a
    /// render at 0 spp and its per-spp time by its equal-spp render.
    Compare {
        #[command(flatten)]
        image: ImageArgs,
        /// Estimates per pixel at equal spp (default 16, 4 with --quick).
        #[arg(long, value_parser = at_least_one())]
        spp: Option<usize>,
        /// Equal-time budget per technique, in busy seconds summed over the render threads
        /// (about SECONDS / threads of wall time each) instead of what `full` took at the
        /// equal spp; the equal-spp renders keep the default spp (conflicts with --spp).
        #[arg(
            long,
            value_name = "SECONDS",
            conflicts_with = "spp",
            allow_negative_numbers = true,
            value_parser = parse_time
        )]
        time: Option<f64>,
        /// Estimates per pixel of the reference (default 64 × spp).
        #[arg(long, value_parser = at_least_one())]
        ref_spp: Option<usize>,
        /// Skip the convergence plot (renders at 1, 2, 4, … 4 × spp per technique).
        #[arg(long)]
        no_plot: bool,
        /// Render only these techniques (comma-separated; default all). They must include
        /// tl-mis, bl and the default, and full unless --time gives the budget.
        #[arg(long, value_enum, value_delimiter = ',')]
        techniques: Vec<TechniqueArg>,
        /// Print the full tables (those of table.md: per-class splits, the RMSEs with the
        /// reference's variance removed) before the short summary.
        #[arg(long)]
        full: bool,
        /// Print one JSON object as the last line of stdout.
        #[arg(long)]
        json: bool,
    },
}

/// The scene and image arguments `reference` and `compare` share.
#[derive(clap::Args)]
struct ImageArgs {
    /// Scene: cornell, exhibition, city, city-sun, stairs, office, market, billboard, or a path
    /// to an .obj file (with its .mtl).
    #[arg(long, default_value = "cornell")]
    scene: String,
    /// Number of lights (cornell only; default 1,494).
    #[arg(long)]
    lights: Option<usize>,
    /// Image width (default 256, 96 with --quick; a pbrt file's `Film` resolution without
    /// --quick).
    #[arg(long, value_parser = image_size())]
    width: Option<usize>,
    /// Image height (default 256, 96 with --quick; a pbrt file's `Film` resolution without
    /// --quick).
    #[arg(long, value_parser = image_size())]
    height: Option<usize>,
    /// Small resolution and sample counts (those of `compare --quick`).
    #[arg(long)]
    quick: bool,
    /// The scene in grey (every light and albedo grey, as the scalar scenes were).
    #[arg(long)]
    grey: bool,
    /// Seed of the estimates.
    #[arg(long, default_value_t = 1)]
    seed: u64,
    /// Output root folder.
    #[arg(long, default_value = "out")]
    out: PathBuf,
    /// One shading point per pixel (its centre), its set-up reused by every estimate:
    /// isolates the light-sampling error (default: a new jittered shading point and set-up
    /// for every estimate, as in a renderer).
    #[arg(long)]
    fixed_point: bool,
    /// The camera instead of the scene's: `eye,target,up,fov` (see `render --help`).
    #[arg(long, value_parser = scene::Camera::parse, allow_hyphen_values = true)]
    camera: Option<scene::Camera>,
    /// The estimators' parameters.
    #[command(flatten)]
    params: ParamArgs,
}

impl ImageArgs {
    /// The named scene; exits with status 2 on an unknown name or a bad light count.
    fn scene(&self) -> (scene::RenderScene, Option<(usize, usize)>) {
        let (mut s, film) = scene::by_name_with_film(&self.scene, self.lights, palette(self.grey))
            .unwrap_or_else(|e| {
                eprintln!("{e}");
                std::process::exit(2)
            });
        if let Some(c) = self.camera {
            s.camera = c;
        }
        (s, film)
    }

    /// The render settings at `spp` with a reference of `ref_spp` and an equal-time budget of
    /// `time` busy seconds (`None`: what `full` takes at `spp`).
    fn config(
        &self,
        spp: usize,
        ref_spp: usize,
        plot: bool,
        time: Option<f64>,
        film: Option<(usize, usize)>,
    ) -> compare::CompareConfig {
        let (w, h) = match film {
            Some(f) if !self.quick => f,
            _ if self.quick => (96, 96),
            _ => (256, 256),
        };
        compare::CompareConfig {
            width: self.width.unwrap_or(w),
            height: self.height.unwrap_or(h),
            spp,
            ref_spp,
            seed: self.seed,
            out: self.out.clone(),
            progress: true,
            plot,
            time,
            protocol: protocol(self.fixed_point),
            params: self.params.params(),
            learn: self.params.learn(),
            techniques: Vec::new(),
        }
    }
}

/// The protocol of `--fixed-point`.
fn protocol(fixed_point: bool) -> render::Protocol {
    if fixed_point {
        render::Protocol::FixedPoint
    } else {
        render::Protocol::Jittered
    }
}

/// The parser of `--time`: a positive, finite number of seconds.
fn parse_time(s: &str) -> Result<f64, String> {
    let v: f64 = s
        .trim()
        .parse()
        .map_err(|_| format!("not a number of seconds: {s:?}"))?;
    compare::check_time(v)
}

fn main() {
    let cli = Cli::parse();
    match cli.command {
        Command::Render {
            scene,
            lights,
            technique,
            spp,
            width,
            height,
            seed,
            output,
            fixed_point,
            grey,
            camera,
            params,
        } => {
            let learn = params.learn();
            let code = run_render(
                &scene,
                lights,
                palette(grey),
                technique.0,
                spp,
                width,
                height,
                seed,
                &output,
                protocol(fixed_point),
                camera,
                params.params(),
                learn,
            );
            std::process::exit(code)
        }
        Command::Reference { image, ref_spp } => {
            let (scene, film) = image.scene();
            let ref_spp = ref_spp.unwrap_or(if image.quick { 256 } else { 1024 });
            let cfg = image.config(1, ref_spp, false, None, film);
            match compare::check_reference(&scene, &cfg) {
                Ok((img, rel, se, rmse)) => {
                    println!(
                        "{} ({} lights, {}x{}): reference average {:.5} (full, {} spp); tl-split at {} spp: relative difference {:.3} % (± {:.3} %), RMSE {:.5}",
                        scene.name,
                        scene.lights.len(),
                        img.width,
                        img.height,
                        img.average(),
                        img.spp,
                        (img.spp / 4).max(1),
                        100.0 * rel,
                        100.0 * se,
                        rmse
                    );
                    if rel > 0.01 {
                        eprintln!("the two techniques differ by more than 1 %");
                        std::process::exit(1)
                    }
                }
                Err(e) => {
                    eprintln!("reference failed: {e}");
                    std::process::exit(1)
                }
            }
        }
        Command::Compare {
            image,
            spp,
            time,
            ref_spp,
            no_plot,
            techniques,
            full,
            json,
        } => {
            let (scene, film) = image.scene();
            let spp = spp.unwrap_or(if image.quick { 4 } else { 16 });
            let mut cfg = image.config(spp, ref_spp.unwrap_or(64 * spp), !no_plot, time, film);
            cfg.techniques = techniques.iter().map(|t| t.0).collect();
            match compare::run(&scene, &cfg) {
                Ok(report) => {
                    if full {
                        println!("{}", report.table());
                    }
                    print!("{}", report.summary());
                    if json {
                        println!("{}", report.json());
                    }
                }
                Err(e) => {
                    eprintln!("compare failed: {e}");
                    std::process::exit(1)
                }
            }
        }
    }
}

#[allow(clippy::too_many_arguments)]
fn run_render(
    scene: &str,
    lights: Option<usize>,
    palette: scene::Palette,
    technique: Technique,
    spp: usize,
    width: Option<usize>,
    height: Option<usize>,
    seed: u64,
    output: &std::path::Path,
    protocol: render::Protocol,
    camera: Option<scene::Camera>,
    params: manylights::Params,
    learn: Option<render::Learn>,
) -> i32 {
    let (mut scene, film) = match scene::by_name_with_film(scene, lights, palette) {
        Ok(s) => s,
        Err(e) => {
            eprintln!("{e}");
            return 2;
        }
    };
    if let Some(c) = camera {
        scene.camera = c;
    }
    let (fw, fh) = film.unwrap_or((256, 256));
    let (width, height) = (width.unwrap_or(fw), height.unwrap_or(fh));
    let img = render::render(
        &scene,
        &render::RenderConfig {
            width,
            height,
            spp,
            technique,
            seed,
            progress: true,
            protocol,
            params,
            learn,
        },
    );
    if let Err(e) = image::write_image(output, width, height, &img.mean) {
        eprintln!("cannot write the image: {e}");
        return 1;
    }
    image::warn_failed("the render", img.failed);
    println!(
        "{} {} lights {}x{} {} spp {}: {:.2} s wall ({:.2} s busy over threads), average {:.4}, written to {}",
        scene.name,
        scene.lights.len(),
        width,
        height,
        spp,
        technique.name(),
        img.wall_seconds,
        img.seconds,
        img.average(),
        output.display()
    );
    0
}
