//! The project's instruments: each measures the core on its own terms and reports a table and,
//! with `--json`, one JSON object on the last line of stdout.
//!
//! - [`bench`](mod@bench): sampling throughput, tree size and build time (`mlrender bench`);
//! - [`estimator`]: unbiasedness, variance and cost per estimate against exact values
//!   (`mlrender estimator`);
//! - [`selection`]: the variance of the light choice of the BRDF-oriented cut and of TL at a
//!   scene's shading points (`mlrender selection`);
//! - [`sptd_accuracy`]: the accuracy of the fitted SPTD table (`mlrender sptd-accuracy`), with
//!   the f64 GGX reference [`manylights_testkit::ggx`].

pub mod bench;
pub mod estimator;
pub mod selection;
pub mod sptd_accuracy;
pub mod vpl;
