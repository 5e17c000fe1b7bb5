//! The command-line form of the core's [`Params`], shared by `render`, `compare` and
//! `estimator`.

use clap::builder::PossibleValue;
use clap::ValueEnum;
use manylights::direct::{LambertMode, Params, Technique};
use manylights::Heuristic;

/// The estimators' parameters ([`Params`]); each left out keeps the core's default.
#[derive(Clone, Debug, Default, clap::Args)]
pub struct ParamArgs {
    /// Split-sampling threshold (SplitCutOptions::threshold).
    #[arg(long)]
    pub split_threshold: Option<f32>,
    /// Largest split cut (SplitCutOptions::max_size).
    #[arg(long)]
    pub split_max_size: Option<usize>,
    /// BRDF-oriented cut δ (BlCutOptions::delta).
    #[arg(long)]
    pub bl_cut_delta: Option<f32>,
    /// Largest BRDF-oriented cut (BlCutOptions::max_size).
    #[arg(long)]
    pub bl_cut_max_size: Option<usize>,
    /// Nmax of the BRDF-aware budget.
    #[arg(long)]
    pub n_max: Option<u32>,
    /// What `full` does at Lambert-only points.
    #[arg(long, value_enum, default_value_t = LambertArg::default())]
    pub lambert: LambertArg,
    /// The MIS heuristic between the techniques.
    #[arg(long, value_enum, default_value_t = HeuristicArg::default())]
    pub heuristic: HeuristicArg,
}

impl ParamArgs {
    /// The parameters: the core's defaults with the given options applied.
    pub fn params(&self) -> Params {
        let mut p = Params::default();
        if let Some(v) = self.split_threshold {
            p.split_cut.threshold = v;
        }
        if let Some(v) = self.split_max_size {
            p.split_cut.max_size = v;
        }
        if let Some(v) = self.bl_cut_delta {
            p.bl_cut.delta = v;
        }
        if let Some(v) = self.bl_cut_max_size {
            p.bl_cut.max_size = v;
        }
        if let Some(v) = self.n_max {
            p.n_max = v;
        }
        p.lambert = self.lambert.0;
        p.heuristic = self.heuristic.0;
        p
    }
}

/// A core enum as a clap value enum: its values are the core's names (`name()`), listed in
/// the order of its `ALL`.
macro_rules! value_enum {
    ($(#[$doc:meta])* $arg:ident($core:ty), [$($value:expr),+ $(,)?]) => {
        $(#[$doc])*
        #[derive(Clone, Copy, Debug, PartialEq, Eq)]
        pub struct $arg(pub $core);

        impl ValueEnum for $arg {
            fn value_variants<'a>() -> &'a [Self] {
                &[$($arg($value)),+]
            }

            fn to_possible_value(&self) -> Option<PossibleValue> {
                Some(PossibleValue::new(self.0.name()))
            }
        }

        impl std::fmt::Display for $arg {
            fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
                f.write_str(self.0.name())
            }
        }
    };
}

value_enum!(
    /// A [`Technique`] on the command line (every one, by [`Technique::name`]).
    TechniqueArg(Technique),
    [
        Technique::Uniform,
        Technique::Power,
        Technique::Tl,
        Technique::TlSplit,
        Technique::Bl,
        Technique::MisEqual,
        Technique::Full,
        Technique::TlMis,
        Technique::BlMis,
        Technique::TlMisPinf,
    ]
);

value_enum!(
    /// A [`LambertMode`] on the command line.
    #[derive(Default)]
    LambertArg(LambertMode),
    [
        LambertMode::TlOnly,
        LambertMode::TbBudget,
        LambertMode::TbOne,
        LambertMode::BlTb,
    ]
);

value_enum!(
    /// A [`Heuristic`] on the command line.
    #[derive(Default)]
    HeuristicArg(Heuristic),
    [Heuristic::Balance, Heuristic::Power]
);

#[cfg(test)]
mod tests {
    use super::*;

    /// Every value of the core's enums is a command-line value, under its core name.
    #[test]
    fn value_enums_cover_the_core_enums() {
        let names = |v: &[PossibleValue]| -> Vec<String> {
            v.iter().map(|p| p.get_name().to_string()).collect()
        };
        let values = |all: Vec<Option<PossibleValue>>| -> Vec<PossibleValue> {
            all.into_iter().map(Option::unwrap).collect()
        };
        let t = values(
            TechniqueArg::value_variants()
                .iter()
                .map(|v| v.to_possible_value())
                .collect(),
        );
        let want: Vec<String> = Technique::ALL
            .iter()
            .map(|t| t.name().to_string())
            .collect();
        assert_eq!(names(&t), want);
        let l = values(
            LambertArg::value_variants()
                .iter()
                .map(|v| v.to_possible_value())
                .collect(),
        );
        let want: Vec<String> = LambertMode::ALL
            .iter()
            .map(|m| m.name().to_string())
            .collect();
        assert_eq!(names(&l), want);
        let h = values(
            HeuristicArg::value_variants()
                .iter()
                .map(|v| v.to_possible_value())
                .collect(),
        );
        let want: Vec<String> = Heuristic::ALL
            .iter()
            .map(|m| m.name().to_string())
            .collect();
        assert_eq!(names(&h), want);
    }
}
