//! The command-line form of the core's [`Params`], shared by `render` and `compare` and by the
//! instruments' `estimator` and `selection`.

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
    /// BRDF-oriented cut: split clusters whose cap's sine is at least this
    /// (BlCutOptions::split_sin; 1: only clusters holding the point).
    #[arg(long)]
    pub bl_cut_split_sin: Option<f32>,
    /// Light samples per estimate of `bl-mis` (Params::bl_light_samples).
    #[arg(long)]
    pub bl_light_samples: Option<u32>,
    /// The `mis-equal` and `full` cut's δ (Params::mixture_cut).
    #[arg(long)]
    pub mixture_cut_delta: Option<f32>,
    /// Largest `mis-equal` and `full` cut (Params::mixture_cut).
    #[arg(long)]
    pub mixture_cut_max_size: Option<usize>,
    /// The `mis-equal` and `full` cut's wide-cap rule (Params::mixture_cut).
    #[arg(long)]
    pub mixture_cut_split_sin: Option<f32>,
    /// Nmax of the BRDF-aware budget.
    #[arg(long)]
    pub n_max: Option<u32>,
    /// What `full` does at Lambert-only points.
    #[arg(long, value_enum, default_value_t = LambertArg::default())]
    pub lambert: LambertArg,
    /// The MIS heuristic between the techniques.
    #[arg(long, value_enum, default_value_t = HeuristicArg::default())]
    pub heuristic: HeuristicArg,
    /// Learn visibility while rendering (a `VisibilityCache`, committed between passes of
    /// 1, 1, 2, 4, … samples per pixel) for the techniques with a BRDF-oriented cut.
    #[arg(long)]
    pub learn: bool,
    /// The learning's grid cell, as a fraction of the scene's extent (with --learn).
    #[arg(long)]
    pub learn_cell: Option<f32>,
    /// The learning's table size in cells, a power of two (with --learn).
    #[arg(long)]
    pub learn_cells: Option<u32>,
    /// The counters per cell, a power of two (with --learn).
    #[arg(long)]
    pub learn_slots: Option<u32>,
    /// The smallest factor learning may scale a cluster's weight by (with --learn).
    #[arg(long)]
    pub learn_floor: Option<f32>,
}

impl ParamArgs {
    /// The learned visibility of `--learn` (`None` without it).
    pub fn learn(&self) -> Option<crate::render::Learn> {
        if !self.learn {
            return None;
        }
        let mut l = crate::render::Learn::default();
        if let Some(v) = self.learn_cell {
            l.cell = v;
        }
        if let Some(v) = self.learn_cells {
            l.cells = v;
        }
        if let Some(v) = self.learn_slots {
            l.slots = v;
        }
        if let Some(v) = self.learn_floor {
            l.floor = v;
        }
        Some(l)
    }

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
        if let Some(v) = self.bl_cut_split_sin {
            p.bl_cut.split_sin = v;
        }
        if let Some(v) = self.bl_light_samples {
            p.bl_light_samples = v;
        }
        if let Some(v) = self.mixture_cut_delta {
            p.mixture_cut.delta = v;
        }
        if let Some(v) = self.mixture_cut_max_size {
            p.mixture_cut.max_size = v;
        }
        if let Some(v) = self.mixture_cut_split_sin {
            p.mixture_cut.split_sin = v;
        }
        if let Some(v) = self.n_max {
            p.n_max = v;
        }
        p.lambert = self.lambert.0;
        p.heuristic = self.heuristic.0;
        p
    }
}

/// A core enum as a clap value enum: its values are the core's names (`name()`), in the order
/// of its `ALL` (`$first` is any value, to fill the array before it is copied).
macro_rules! value_enum {
    ($(#[$doc:meta])* $arg:ident($core:ty), $all:expr, $first:expr) => {
        $(#[$doc])*
        #[derive(Clone, Copy, Debug, PartialEq, Eq)]
        pub struct $arg(pub $core);

        impl $arg {
            const ALL: [$arg; $all.len()] = {
                let mut a = [$arg($first); $all.len()];
                let mut i = 0;
                while i < a.len() {
                    a[i] = $arg($all[i]);
                    i += 1;
                }
                a
            };
        }

        impl ValueEnum for $arg {
            fn value_variants<'a>() -> &'a [Self] {
                &Self::ALL
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
    Technique::ALL,
    Technique::Uniform
);

value_enum!(
    /// A [`LambertMode`] on the command line.
    #[derive(Default)]
    LambertArg(LambertMode),
    LambertMode::ALL,
    LambertMode::TlOnly
);

value_enum!(
    /// A [`Heuristic`] on the command line.
    #[derive(Default)]
    HeuristicArg(Heuristic),
    Heuristic::ALL,
    Heuristic::Power
);

#[cfg(test)]
mod tests {
    use super::*;

    /// The command-line names of a value enum's values.
    fn names<T: ValueEnum>() -> Vec<String> {
        T::value_variants()
            .iter()
            .map(|v| v.to_possible_value().unwrap().get_name().to_string())
            .collect()
    }

    /// Every value of the core's enums is a command-line value, under its core name.
    #[test]
    fn value_enums_cover_the_core_enums() {
        let want: Vec<String> = Technique::ALL.iter().map(|t| t.name().into()).collect();
        assert_eq!(names::<TechniqueArg>(), want);
        let want: Vec<String> = LambertMode::ALL.iter().map(|m| m.name().into()).collect();
        assert_eq!(names::<LambertArg>(), want);
        let want: Vec<String> = Heuristic::ALL.iter().map(|h| h.name().into()).collect();
        assert_eq!(names::<HeuristicArg>(), want);
    }
}
