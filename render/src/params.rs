//! The command-line form of the core's [`Params`], shared by `render`, `compare` and
//! `estimator`.

use manylights::direct::{LambertMode, Params};

/// The estimators' parameters ([`Params`]); each left out keeps the core's default.
#[derive(Clone, Debug, Default, clap::Args)]
pub struct ParamArgs {
    /// Split-sampling threshold (SplitOptions::threshold).
    #[arg(long)]
    pub split_threshold: Option<f32>,
    /// Largest split cut (SplitOptions::max_size).
    #[arg(long)]
    pub split_max_size: Option<usize>,
    /// BL cut δ (CutOptions::delta).
    #[arg(long)]
    pub cut_delta: Option<f32>,
    /// Largest BL cut (CutOptions::max_size).
    #[arg(long)]
    pub cut_max_size: Option<usize>,
    /// Nmax of the BRDF-aware budget.
    #[arg(long)]
    pub n_max: Option<u32>,
    /// What `full` does at Lambert-only points: tl-only, tb-budget, tb-one or bl-tb.
    #[arg(long, value_parser = parse_lambert, default_value = "tl-only")]
    pub lambert: LambertMode,
    /// Balance heuristic between TL and the BRDF-aware mixture (default: power, β = 2).
    #[arg(long)]
    pub balance_heuristic: bool,
}

impl ParamArgs {
    /// The parameters: the core's defaults with the given options applied.
    pub fn params(&self) -> Params {
        let mut p = Params::default();
        if let Some(v) = self.split_threshold {
            p.split.threshold = v;
        }
        if let Some(v) = self.split_max_size {
            p.split.max_size = v;
        }
        if let Some(v) = self.cut_delta {
            p.cut.delta = v;
        }
        if let Some(v) = self.cut_max_size {
            p.cut.max_size = v;
        }
        if let Some(v) = self.n_max {
            p.n_max = v;
        }
        p.lambert = self.lambert;
        p.power = !self.balance_heuristic;
        p
    }
}

/// A [`LambertMode`] from its name (`tl-only`, `tb-budget`, `tb-one`, `bl-tb`).
fn parse_lambert(name: &str) -> Result<LambertMode, String> {
    LambertMode::from_name(name).ok_or_else(|| {
        let names: Vec<&str> = LambertMode::ALL.iter().map(|m| m.name()).collect();
        format!("unknown mode {name:?} (known: {})", names.join(", "))
    })
}
