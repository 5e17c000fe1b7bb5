//! `sptd-fit`: fits the SPTD parameters of GGX (docs/formulas.md, section 8) and writes the
//! core's generated table `src/importance/sptd/table.rs`; [`fit`] says how.
//!
//! ```text
//! sptd-fit [--out PATH] [--caps N]  fit every node and write the table
//! sptd-fit --check K                re-fit K nodes spread over the committed table and compare
//! sptd-fit --cells "i,j;i,j;..."    fit and print these nodes only (nothing is written)
//! ```

mod fit;

use fit::{
    check, committed_node, default_table_path, fit_node, fit_table, neighbours_in, table_source,
    FitConfig,
};
use manylights::internals::sptd::{self, TABLE_SIZE};
use std::path::PathBuf;

/// The help text of `--help`.
const USAGE: &str = "\
Fit the SPTD parameters of GGX (docs/formulas.md, section 8) and write the core's generated
table src/importance/sptd/table.rs.

Usage: sptd-fit [OPTIONS]

Options:
      --out <OUT>      Where to write the table (default: the core's src/importance/sptd/table.rs)
      --check <K>      Re-fit K nodes spread over the committed table and compare (exit 1 on mismatch)
      --cells <CELLS>  Only fit and print these nodes, \"i,j;i,j;...\" (nothing is written)
      --caps <CAPS>    Test caps per node [default: 384]
  -h, --help           Print help
  -V, --version        Print version";

/// The command line.
#[derive(Debug, PartialEq)]
struct Args {
    /// `--out`: where to write the table.
    out: Option<PathBuf>,
    /// `--check K`.
    check: Option<usize>,
    /// `--cells`: the nodes to fit and print.
    cells: Option<String>,
    /// `--caps`: test caps per node.
    caps: usize,
}

/// What the command line asks for.
#[derive(Debug, PartialEq)]
enum Request {
    /// A fit, a check or some cells.
    Run(Args),
    /// `--help`.
    Help,
    /// `--version`.
    Version,
}

/// Parses the arguments after the program name (`--flag value` or `--flag=value`); the error
/// names the argument that is wrong.
fn parse_args(args: impl IntoIterator<Item = String>) -> Result<Request, String> {
    let mut parsed = Args {
        out: None,
        check: None,
        cells: None,
        caps: FitConfig::default().caps,
    };
    let mut it = args.into_iter();
    while let Some(arg) = it.next() {
        let (flag, inline) = match arg.split_once('=') {
            Some((f, v)) if f.starts_with("--") => (f.to_owned(), Some(v.to_owned())),
            _ => (arg, None),
        };
        let mut value = || {
            inline
                .clone()
                .or_else(|| it.next())
                .ok_or_else(|| format!("a value is required for '{flag}'"))
        };
        let count = |v: String| {
            v.trim()
                .parse::<usize>()
                .map_err(|_| format!("invalid value '{v}' for '{flag}': not a count"))
        };
        match flag.as_str() {
            "-h" | "--help" => return Ok(Request::Help),
            "-V" | "--version" => return Ok(Request::Version),
            "--out" => parsed.out = Some(PathBuf::from(value()?)),
            "--check" => parsed.check = Some(count(value()?)?),
            "--cells" => parsed.cells = Some(value()?),
            "--caps" => parsed.caps = count(value()?)?,
            _ => return Err(format!("unexpected argument '{flag}'")),
        }
    }
    Ok(Request::Run(parsed))
}

/// Parses `--cells`: `"i,j;i,j;..."` with `0 ≤ i, j < TABLE_SIZE`.
fn parse_cells(s: &str) -> Option<Vec<(usize, usize)>> {
    s.split(';')
        .filter(|p| !p.trim().is_empty())
        .map(|p| {
            let mut it = p.split(',').map(|x| x.trim().parse::<usize>().ok());
            match (it.next().flatten(), it.next().flatten(), it.next()) {
                (Some(i), Some(j), None) if i < TABLE_SIZE && j < TABLE_SIZE => Some((i, j)),
                _ => None,
            }
        })
        .collect()
}

/// Runs what `args` ask for; returns the process exit code.
fn run(args: Args) -> i32 {
    let t = std::time::Instant::now();
    if let Some(k) = args.check {
        let rows = check(k);
        for r in &rows {
            println!(
                "({:2},{:2}) {}\n   fit       {:?}\n   committed {:?}",
                r.fit.i,
                r.fit.j,
                if r.ok { "ok" } else { "MISMATCH" },
                r.fit.params,
                r.committed
            );
        }
        let bad = rows.iter().filter(|r| !r.ok).count();
        println!(
            "sptd-fit --check {k}: {} of {} nodes match the committed table ({:.1} s)",
            rows.len() - bad,
            rows.len(),
            t.elapsed().as_secs_f64()
        );
        return i32::from(bad > 0);
    }
    let cfg = FitConfig {
        caps: args.caps,
        ..FitConfig::default()
    };
    if let Some(list) = args.cells {
        let Some(nodes) = parse_cells(&list) else {
            eprintln!("sptd-fit: --cells wants \"i,j;i,j;...\" with 0 ≤ i, j < {TABLE_SIZE}");
            return 2;
        };
        for (i, j) in nodes {
            let f = fit_node(i, j, &neighbours_in(i, j, committed_node), &cfg);
            let (alpha, theta) = sptd::table_node(i, j);
            let p = f.params;
            println!(
                "({i},{j}) α {alpha:.4} θo {:.2}°: R {:.5} Gθ {:+.5} ρ {:.5} β {:.4} c_ref {:.4}  loss {:.5} median {:.4} ({} evals)",
                theta.to_degrees(),
                p.pivot_norm,
                p.pivot_elevation,
                p.albedo,
                p.lambert_weight,
                p.masking_cos,
                f.loss,
                f.median_rel_err,
                f.evals
            );
        }
        return 0;
    }
    let path = args.out.unwrap_or_else(default_table_path);
    let t_fit = fit_table(&cfg, true);
    let seconds = t.elapsed().as_secs_f64();
    let src = table_source(&t_fit, &cfg, &cfg.command());
    if let Err(e) = std::fs::write(&path, src) {
        eprintln!("sptd-fit: cannot write {}: {e}", path.display());
        return 1;
    }
    println!(
        "sptd-fit: wrote {} ({}×{} nodes, {:.1} s)",
        path.display(),
        TABLE_SIZE,
        TABLE_SIZE,
        seconds
    );
    0
}

fn main() {
    let code = match parse_args(std::env::args().skip(1)) {
        Ok(Request::Run(args)) => run(args),
        Ok(Request::Help) => {
            println!("{USAGE}");
            0
        }
        Ok(Request::Version) => {
            println!("sptd-fit {}", env!("CARGO_PKG_VERSION"));
            0
        }
        Err(e) => {
            eprintln!("error: {e}\n\n{USAGE}");
            2
        }
    };
    std::process::exit(code)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn parse(args: &[&str]) -> Result<Request, String> {
        parse_args(args.iter().map(|a| (*a).to_owned()))
    }

    #[test]
    fn flags_take_their_value_after_a_space_or_an_equals_sign() {
        assert_eq!(
            parse(&[
                "--check",
                "8",
                "--caps=96",
                "--out",
                "t.rs",
                "--cells=1,2;3,4"
            ]),
            Ok(Request::Run(Args {
                out: Some(PathBuf::from("t.rs")),
                check: Some(8),
                cells: Some("1,2;3,4".to_owned()),
                caps: 96,
            }))
        );
        let Ok(Request::Run(defaults)) = parse(&[]) else {
            panic!("no arguments: a fit with the default settings");
        };
        assert_eq!(defaults.caps, FitConfig::default().caps);
        assert_eq!(parse(&["--help"]), Ok(Request::Help));
    }

    #[test]
    fn bad_arguments_are_named() {
        let err = |args: &[&str]| parse(args).expect_err("rejected");
        assert!(err(&["--check"]).contains("--check"));
        assert!(err(&["--caps", "many"]).contains("'many'"));
        assert!(err(&["--fast"]).contains("--fast"));
        assert_eq!(parse_cells("1,2;63,0"), Some(vec![(1, 2), (63, 0)]));
        assert_eq!(parse_cells("1,2,3"), None);
        assert_eq!(parse_cells(&format!("0,{TABLE_SIZE}")), None);
    }
}
