//! The instruments of manylights, run by the `mlmeasure` binary: each measures the core on its
//! own terms and reports a table and, with `--json`, one JSON object on the last line of stdout.
//! Scenes, ray casts and the render loop are the renderer's ([`manylights_render`]).
//!
//! - [`bench`](mod@bench): sampling throughput, tree size and build time (`mlmeasure bench`),
//!   the build's peak heap counted by [`alloc_count`];
//! - [`estimator`]: unbiasedness, variance and cost per estimate against exact values
//!   (`mlmeasure estimator`);
//! - [`selection`]: the variance of the light choice of the BRDF-oriented cut and of TL at a
//!   scene's shading points, beside the floors of a choice proportional to each light's
//!   unshadowed and shadowed contribution (`mlmeasure selection`);
//! - [`sptd_accuracy`]: the accuracy of the fitted SPTD table (`mlmeasure sptd-accuracy`), with
//!   the f64 GGX reference [`manylights_testkit::ggx`];
//! - [`vpl`]: instant radiosity with and without probabilistic VPL acceptance against a
//!   converged reference (`mlmeasure vpl`).

pub mod alloc_count;
pub mod bench;
pub mod estimator;
pub mod selection;
pub mod sptd_accuracy;
pub mod vpl;
