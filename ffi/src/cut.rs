//! Light cuts: the BRDF-oriented cut (Liu et al. 2019, section 4.1) and the split-sampling cut
//! (Conty & Kulla), their sampling, pmfs, size, IB(x) and one sample per cluster. A cut holds
//! the tree's distant and environment lights that can contribute as clusters of their own.

use crate::arg;
use crate::error::{ml_status, Error, Result};
use crate::ffi_fn;
use crate::tree::{bl_importance, check_light, ml_tree, tree_arg, TreeData};
use crate::types::{ml_sampled_light, ml_shading_point, ml_tl_point, tl_point, unit};
use manylights::cut::CUT_CAPACITY;
use manylights::{BlCutOptions, BlImportance, LightCut, SplitCutOptions, TlImportance};
use std::sync::Arc;

/// The largest cut: clusters a cut may hold, `ML_MAX_CUT_SIZE` of the node tree and one for
/// each light at infinity (a tree has at most 16); what a host sizes the arrays of
/// `ml_cut_sample_clusters` by.
pub const ML_CUT_CAPACITY: usize = 80;
const _: () = assert!(ML_CUT_CAPACITY == CUT_CAPACITY);

/// `*cluster` of `ml_cut_pmf_in` for a light in no cluster of the cut.
pub const ML_NO_CLUSTER: u32 = u32::MAX;

/// Options of the BRDF-oriented cut (`ml_bl_cut_options_default` fills the defaults).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ml_bl_cut_options {
    /// Split a cluster whose BRDF integral over its cap exceeds δ (finite, ≥ 0; default 0.3).
    pub delta: f32,
    /// Most clusters of the node tree, in [`ML_MIN_CUT_SIZE`, `ML_MAX_CUT_SIZE`] = [4, 64]
    /// (default 64); each light at infinity that can contribute adds one.
    pub max_size: usize,
    /// Split a cluster whose cap is wide: its bounding sphere's radius r at least `split_sin`
    /// times its distance d from the shading point (the sine of the cap's half-angle). In
    /// [0, 1] (default 0.9); 1 splits only the clusters whose sphere holds the point, as Liu
    /// et al. 2019 do.
    pub split_sin: f32,
}

/// Options of the split-sampling cut (`ml_split_cut_options_default` fills the defaults).
#[repr(C)]
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct ml_split_cut_options {
    /// Split while the cluster's share of the variance exceeds this (finite, ≥ 0; default
    /// 1e-3).
    pub threshold: f32,
    /// Most clusters of the node tree, in [`ML_MIN_CUT_SIZE`, `ML_MAX_CUT_SIZE`] = [4, 64]
    /// (default 32); each light at infinity that can contribute adds one.
    pub max_size: usize,
}

/// The importance a cut was built with (its sampling and pmfs use the same one). It lives in
/// the [`ml_cut`] that owns it and is rebuilt there in place, so the size of the BL variant
/// (its 4-wide constants) is not boxed: boxing would allocate at every build.
#[derive(Clone, Copy, Debug)]
#[allow(clippy::large_enum_variant)]
enum CutImportance {
    None,
    Tl(TlImportance),
    Bl(BlImportance),
}

/// A light cut (opaque): per-thread state, rebuilt for each shading point. It keeps the tree
/// it was last built on alive. Not to be used by two threads at once.
pub struct ml_cut {
    tree: Option<Arc<TreeData>>,
    cut: LightCut,
    imp: CutImportance,
}

impl ml_cut {
    fn built(&self) -> Result<(&TreeData, &LightCut, &CutImportance)> {
        match (&self.tree, &self.imp) {
            (Some(t), imp) if !matches!(imp, CutImportance::None) => Ok((t, &self.cut, imp)),
            _ => Err(Error::state(
                "cut: not built yet (call ml_cut_build_bl or ml_cut_build_split first)",
            )),
        }
    }
}

// The checks name the field as `{name}.{field}`, formatted only for an error: the options are
// checked at every call that takes them (`ml_direct_estimate` among them).

fn max_size(v: usize, name: &str, field: &str) -> Result<usize> {
    if (crate::limits::ML_MIN_CUT_SIZE..=crate::limits::ML_MAX_CUT_SIZE).contains(&v) {
        Ok(v)
    } else {
        Err(Error::invalid(format_args!(
            "{name}.{field} must be in [4, 64], ML_MIN_CUT_SIZE to ML_MAX_CUT_SIZE (got {v})"
        )))
    }
}

fn non_negative(v: f32, name: &str, field: &str) -> Result<f32> {
    if v.is_finite() && v >= 0.0 {
        Ok(v)
    } else {
        Err(Error::invalid(format_args!(
            "{name}.{field} must be finite and non-negative (got {v})"
        )))
    }
}

fn unit_interval(v: f32, name: &str, field: &str) -> Result<f32> {
    if (0.0..=1.0).contains(&v) {
        Ok(v)
    } else {
        Err(Error::invalid(format_args!(
            "{name}.{field} must be in [0, 1] (got {v})"
        )))
    }
}

/// Fills `*out` with the default BRDF-oriented cut options (δ = 0.3, 64 clusters, caps with
/// a sine above 0.9 split).
///
/// Errors: `ML_ERR_NULL` if `out` is NULL.
#[no_mangle]
pub extern "C" fn ml_bl_cut_options_default(out: *mut ml_bl_cut_options) -> ml_status {
    ffi_fn!("ml_bl_cut_options_default", {
        let d = BlCutOptions::default();
        arg::out(out, "out")?.write(ml_bl_cut_options {
            delta: d.delta,
            max_size: d.max_size,
            split_sin: d.split_sin,
        });
        Ok(())
    })
}

/// Fills `*out` with the default split-sampling options (threshold 1e-3, 32 clusters).
///
/// Errors: `ML_ERR_NULL` if `out` is NULL.
#[no_mangle]
pub extern "C" fn ml_split_cut_options_default(out: *mut ml_split_cut_options) -> ml_status {
    ffi_fn!("ml_split_cut_options_default", {
        let d = SplitCutOptions::default();
        arg::out(out, "out")?.write(ml_split_cut_options {
            threshold: d.threshold,
            max_size: d.max_size,
        });
        Ok(())
    })
}

/// The core's cut options of checked C options (NULL: defaults).
pub(crate) fn cut_options(o: Option<&ml_bl_cut_options>, name: &str) -> Result<BlCutOptions> {
    Ok(match o {
        None => BlCutOptions::default(),
        Some(o) => BlCutOptions {
            delta: non_negative(o.delta, name, "delta")?,
            max_size: max_size(o.max_size, name, "max_size")?,
            split_sin: unit_interval(o.split_sin, name, "split_sin")?,
        },
    })
}

/// The core's split options of checked C options (NULL: defaults).
pub(crate) fn split_options(
    o: Option<&ml_split_cut_options>,
    name: &str,
) -> Result<SplitCutOptions> {
    Ok(match o {
        None => SplitCutOptions::default(),
        Some(o) => SplitCutOptions {
            threshold: non_negative(o.threshold, name, "threshold")?,
            max_size: max_size(o.max_size, name, "max_size")?,
        },
    })
}

/// Creates an empty cut. Free it with `ml_cut_free`.
///
/// Errors: `ML_ERR_NULL` if `out` is NULL.
#[no_mangle]
pub extern "C" fn ml_cut_create(out: *mut *mut ml_cut) -> ml_status {
    ffi_fn!("ml_cut_create", {
        let out = arg::out(out, "out")?;
        out.write(arg::into_handle(ml_cut {
            tree: None,
            cut: LightCut::new(),
            imp: CutImportance::None,
        }));
        Ok(())
    })
}

/// Frees a cut (NULL: nothing).
#[no_mangle]
pub extern "C" fn ml_cut_free(cut: *mut ml_cut) -> ml_status {
    ffi_fn!("ml_cut_free", { arg::free_handle(cut, "cut") })
}

/// Builds the BRDF-oriented light cut of `tree` at `sp` (Liu et al. 2019, section 4.1: a
/// cluster is split while x is inside its bounding sphere or its BRDF integral exceeds δ), with
/// `options` (NULL: defaults). The cut is unchanged on error. Each distant or environment
/// light that can contribute at `sp` is a cluster of its own, after the node tree's clusters
/// (at most `options.max_size` of them), so the cut holds every light that can contribute.
///
/// Errors: `ML_ERR_NULL` (`cut`, `tree`, `sp`); `ML_ERR_INVALID_ARGUMENT` (a bad shading point
/// or option).
#[no_mangle]
pub extern "C" fn ml_cut_build_bl(
    cut: *mut ml_cut,
    tree: *const ml_tree,
    sp: *const ml_shading_point,
    options: *const ml_bl_cut_options,
) -> ml_status {
    ffi_fn!("ml_cut_build_bl", {
        let cut = arg::get_mut(cut, "cut")?;
        let data = tree_arg(tree)?;
        let sp = arg::get(sp, "sp")?;
        let opts = cut_options(arg::opt(options, "options")?, "options")?;
        let imp = bl_importance(sp, &|| "sp".into())?;
        cut.cut = LightCut::build_bl(data.tree(), &imp, &opts);
        cut.imp = CutImportance::Bl(imp);
        if !cut.tree.as_ref().is_some_and(|t| Arc::ptr_eq(t, data)) {
            cut.tree = Some(Arc::clone(data));
        }
        Ok(())
    })
}

/// Builds the split-sampling cut of `tree` at `point` (Conty & Kulla: a cluster is split while
/// its share of the variance is large, and always when the point is inside it), with
/// `options` (NULL: defaults). The cut is unchanged on error. Each distant or environment
/// light that can contribute at `point` is a cluster of its own (pmf 1 in it), after the node
/// tree's clusters (at most `options.max_size` of them). Its clusters hold every light
/// that can contribute at `point`, not every light with `ml_tree_pmf_tl` > 0: below a slot
/// whose child's slots all have importance 0, the tree's descent falls back to energies and
/// gives those lights (which cannot contribute: behind the surface, outside their cones) a
/// TL pmf > 0, while a cut that opens the slot leaves them out (`ML_NO_CLUSTER`, pmf 0).
///
/// Errors: `ML_ERR_NULL` (`cut`, `tree`, `point`); `ML_ERR_INVALID_ARGUMENT` (a non-finite
/// point, a bad `point.receiver`, a bad option).
#[no_mangle]
pub extern "C" fn ml_cut_build_split(
    cut: *mut ml_cut,
    tree: *const ml_tree,
    point: *const ml_tl_point,
    options: *const ml_split_cut_options,
) -> ml_status {
    ffi_fn!("ml_cut_build_split", {
        let cut = arg::get_mut(cut, "cut")?;
        let data = tree_arg(tree)?;
        let point = arg::get(point, "point")?;
        let opts = split_options(arg::opt(options, "options")?, "options")?;
        let imp = tl_point(point, &|| "point".into())?;
        cut.cut = LightCut::build_split(data.tree(), &imp, &opts);
        cut.imp = CutImportance::Tl(imp);
        if !cut.tree.as_ref().is_some_and(|t| Arc::ptr_eq(t, data)) {
            cut.tree = Some(Arc::clone(data));
        }
        Ok(())
    })
}

/// The number of clusters of the cut, the lights at infinity's among them (0 when no light can
/// contribute; at most `ML_CUT_CAPACITY`).
///
/// Errors: `ML_ERR_NULL` (`cut`, `out`); `ML_ERR_STATE` (never built).
#[no_mangle]
pub extern "C" fn ml_cut_size(cut: *const ml_cut, out: *mut usize) -> ml_status {
    ffi_fn!("ml_cut_size", {
        let cut = arg::get(cut, "cut")?;
        let out = arg::out(out, "out")?;
        let (_, c, _) = cut.built()?;
        out.write(c.len());
        Ok(())
    })
}

/// `max_score()` of a cut built by `ml_cut_build_bl` (`bl`) or by `ml_cut_build_split`.
fn score(cut: *const ml_cut, out: *mut f32, bl: bool) -> Result<()> {
    let cut = arg::get(cut, "cut")?;
    let out = arg::out(out, "out")?;
    let (_, c, imp) = cut.built()?;
    match (imp, bl) {
        (CutImportance::Bl(_), true) | (CutImportance::Tl(_), false) => {
            out.write(c.max_score());
            Ok(())
        }
        (_, true) => Err(Error::state(
            "cut: IB(x) is of a BRDF-oriented cut (built by ml_cut_build_bl); this one is a split cut (ml_cut_max_variance)",
        )),
        (_, false) => Err(Error::state(
            "cut: the normalised variance is of a split cut (built by ml_cut_build_split); this one is BRDF-oriented (ml_cut_ib)",
        )),
    }
}

/// IB(x) of a BRDF-oriented cut: the largest BRDF integral over its clusters (Liu et al.
/// 2019, section 4.2), what the BRDF-aware sample budget is computed from.
///
/// Errors: `ML_ERR_NULL` (`cut`, `out`); `ML_ERR_STATE` (never built, or built by
/// `ml_cut_build_split`: see `ml_cut_max_variance`).
#[no_mangle]
pub extern "C" fn ml_cut_ib(cut: *const ml_cut, out: *mut f32) -> ml_status {
    ffi_fn!("ml_cut_ib", { score(cut, out, true) })
}

/// The largest normalised variance over the clusters of a split cut (Conty & Kulla's
/// splitting criterion `ρ · (I_C / I_total)²` of the clusters it kept; +∞ where the shading
/// point is inside a cluster that could not be split).
///
/// Errors: `ML_ERR_NULL` (`cut`, `out`); `ML_ERR_STATE` (never built, or built by
/// `ml_cut_build_bl`: see `ml_cut_ib`).
#[no_mangle]
pub extern "C" fn ml_cut_max_variance(cut: *const ml_cut, out: *mut f32) -> ml_status {
    ffi_fn!("ml_cut_max_variance", { score(cut, out, false) })
}

/// Samples one light of the whole cut with `u` in [0, 1): a cluster in proportion to its
/// weight, then a light in it; the pmf is the product (`ML_NO_LIGHT` for an empty cut). With
/// distant or environment lights the choice is first made between the node tree's clusters
/// (their weights' sum) and each light at infinity (its weight), as the estimators make it;
/// a light at infinity has that choice's probability as its pmf (for the environment the host
/// then samples its own environment), and a light of the node tree whose product would be
/// below `ML_MIN_PMF` is never returned (`ML_NO_LIGHT`, pmf 0).
///
/// Errors: `ML_ERR_NULL` (`cut`, `out`); `ML_ERR_INVALID_ARGUMENT` (`u` outside [0, 1));
/// `ML_ERR_STATE` (never built).
#[no_mangle]
pub extern "C" fn ml_cut_sample(
    cut: *const ml_cut,
    u: f32,
    out: *mut ml_sampled_light,
) -> ml_status {
    ffi_fn!("ml_cut_sample", {
        let cut = arg::get(cut, "cut")?;
        let out = arg::out(out, "out")?;
        let (t, c, imp) = cut.built()?;
        let u = unit(u, &|| "u".into())?;
        let s = match imp {
            CutImportance::Tl(i) => c.sample(t.tree(), i, u),
            CutImportance::Bl(i) => c.sample(t.tree(), i, u),
            CutImportance::None => None,
        };
        out.write(s.into());
        Ok(())
    })
}

/// The probability that `ml_cut_sample` returns `light`: exactly the pmf it reports.
///
/// Errors: `ML_ERR_NULL` (`cut`, `out`); `ML_ERR_INVALID_ARGUMENT` (`light` out of range);
/// `ML_ERR_STATE` (never built).
#[no_mangle]
pub extern "C" fn ml_cut_pmf(cut: *const ml_cut, light: u32, out: *mut f32) -> ml_status {
    ffi_fn!("ml_cut_pmf", {
        let cut = arg::get(cut, "cut")?;
        let out = arg::out(out, "out")?;
        let (t, c, imp) = cut.built()?;
        check_light(light, t.tree().light_count() as usize, "light")?;
        let p = match imp {
            CutImportance::Tl(i) => c.pmf(t.tree(), i, light),
            CutImportance::Bl(i) => c.pmf(t.tree(), i, light),
            CutImportance::None => 0.0,
        };
        out.write(p);
        Ok(())
    })
}

/// Split sampling: one light in each cluster, `out[i]` for cluster i with `us[i]` in [0, 1),
/// its pmf relative to the cluster (the estimate sums each cluster's contribution divided by
/// it). `count` must be the cut's size (at most `ML_CUT_CAPACITY`). A distant or environment
/// light's cluster gives that light with pmf 1. The descents run four at a time, interleaved.
///
/// Errors: `ML_ERR_NULL` (`cut`; `us`, `out` when `count` > 0); `ML_ERR_INVALID_ARGUMENT`
/// (`count` not the cut's size, `us[i]` outside [0, 1)); `ML_ERR_STATE` (never built).
#[no_mangle]
pub extern "C" fn ml_cut_sample_clusters(
    cut: *const ml_cut,
    us: *const f32,
    count: usize,
    out: *mut ml_sampled_light,
) -> ml_status {
    ffi_fn!("ml_cut_sample_clusters", {
        let cut = arg::get(cut, "cut")?;
        let us = arg::slice(us, count, "us")?;
        let mut out = arg::out_slice(out, count, "out")?;
        let (t, c, imp) = cut.built()?;
        if count != c.len() {
            return Err(Error::invalid(format_args!(
                "count must be the cut's size, {} (got {count})",
                c.len()
            )));
        }
        for (i, &u) in us.iter().enumerate() {
            unit(u, &|| format!("us[{i}]"))?;
        }
        let mut res = [None; CUT_CAPACITY];
        match imp {
            CutImportance::Tl(i) => c.sample_each(t.tree(), i, us, &mut res[..count]),
            CutImportance::Bl(i) => c.sample_each(t.tree(), i, us, &mut res[..count]),
            CutImportance::None => {}
        }
        for (i, r) in res[..count].iter().enumerate() {
            out.set(i, (*r).into());
        }
        Ok(())
    })
}

/// The cluster of the cut holding `light` (`ML_NO_CLUSTER` if none) and the light's pmf
/// within it (what `ml_cut_sample_clusters` reports for it; 0 with `ML_NO_CLUSTER`, which a
/// host combining TL and split pmfs takes as a density of 0: see `ml_cut_build_split`).
///
/// Errors: `ML_ERR_NULL` (`cut`, `cluster`, `pmf`); `ML_ERR_INVALID_ARGUMENT` (`light` out of
/// range); `ML_ERR_STATE` (never built).
#[no_mangle]
pub extern "C" fn ml_cut_pmf_in(
    cut: *const ml_cut,
    light: u32,
    cluster: *mut u32,
    pmf: *mut f32,
) -> ml_status {
    ffi_fn!("ml_cut_pmf_in", {
        let cut = arg::get(cut, "cut")?;
        let cluster = arg::out(cluster, "cluster")?;
        let pmf = arg::out(pmf, "pmf")?;
        let (t, c, imp) = cut.built()?;
        check_light(light, t.tree().light_count() as usize, "light")?;
        let r = match imp {
            CutImportance::Tl(i) => c.pmf_in(t.tree(), i, light),
            CutImportance::Bl(i) => c.pmf_in(t.tree(), i, light),
            CutImportance::None => None,
        };
        let (k, p) = r.map_or((ML_NO_CLUSTER, 0.0), |(k, p)| (k as u32, p));
        cluster.write(k);
        pmf.write(p);
        Ok(())
    })
}
