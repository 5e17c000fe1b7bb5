//! MIS weights (`mis::balance`, `mis::power`, `CombinedWeights`, `SequentialWeights`) on bad
//! inputs: negative, NaN and infinite densities and counts give weights in [0, 1], never NaN,
//! that still sum to 1; ordinary inputs give the plain formulas.

use manylights::internals::mis::{balance, power, CombinedWeights, SequentialWeights};
use manylights::Heuristic;
use std::f32::consts::PI;

/// Values every check combines: ordinary, zero, tiny, huge, and bad.
const VALUES: [f32; 12] = [
    0.0,
    -0.0,
    1e-40,
    0.5,
    PI,
    2.0,
    3e38,
    f32::MAX,
    -1.0,
    f32::NAN,
    f32::INFINITY,
    f32::NEG_INFINITY,
];

fn in_unit(w: f32) -> bool {
    (0.0..=1.0).contains(&w)
}

/// Regression: `balance` returned −1.467 for `balance(−1, π, [(1, −1), (π, 2)])`, and
/// values outside [0, 1] or NaN for other negative or non-finite densities. Now a negative or
/// NaN density or count counts as 0 and +∞ takes the whole weight (shared among the infinite
/// techniques); the weights of all techniques still sum to 1 whenever one is positive (within
/// 1e-6: a few f32 roundings of values ≤ 1).
#[test]
fn balance_and_power_stay_in_unit_range() {
    assert_eq!(balance(-1.0, PI, &[(1.0, -1.0), (PI, 2.0)]), 0.0);
    assert_eq!(balance(1.0, -1.0, &[(-1.0, PI), (PI, 2.0)]), 0.0);
    assert_eq!(balance(PI, 2.0, &[(-1.0, PI), (1.0, -1.0)]), 1.0);
    assert_eq!(balance(1.0, f32::INFINITY, &[(1.0, 2.0)]), 1.0);
    assert_eq!(balance(1.0, 2.0, &[(1.0, f32::INFINITY)]), 0.0);
    assert_eq!(balance(1.0, f32::INFINITY, &[(2.0, f32::INFINITY)]), 0.5);
    assert_eq!(balance(f32::INFINITY, 0.0, &[(1.0, 2.0)]), 0.0);
    // Finite terms whose f32 sum overflows are summed in f64.
    assert_eq!(balance(f32::MAX, 1.0, &[(f32::MAX, 1.0)]), 0.5);
    assert!((power(3e38, 1.0, &[(1e38, 1.0)]) - 0.9).abs() < 1e-6);
    for heuristic in [balance, power] {
        for &n0 in &VALUES {
            for &p0 in &VALUES {
                for &(n1, p1) in &[(1.0, 0.5), (-1.0, 2.0), (2.0, f32::NAN), (1.0, 3e38)] {
                    let techniques = [(n0, p0), (n1, p1), (PI, 2.0)];
                    let ws: Vec<f32> = (0..3)
                        .map(|i| {
                            let others: Vec<(f32, f32)> =
                                (0..3).filter(|&j| j != i).map(|j| techniques[j]).collect();
                            heuristic(techniques[i].0, techniques[i].1, &others)
                        })
                        .collect();
                    for &w in &ws {
                        assert!(in_unit(w), "{techniques:?}: weights {ws:?}");
                    }
                    let sum: f32 = ws.iter().sum();
                    assert!((sum - 1.0).abs() <= 1e-6, "{techniques:?}: weights {ws:?}");
                }
            }
        }
    }
}

/// Ordinary finite non-negative inputs give exactly the plain formulas.
#[test]
fn balance_and_power_of_ordinary_inputs_are_the_formulas() {
    let cases = [
        (1.0f32, 0.7f32, [(1.0f32, 0.2f32), (3.0, 0.05)]),
        (2.0, 0.0, [(1.0, 0.3), (0.0, 5.0)]),
        (1.0, 1e-6, [(50.0, 3.0), (1.0, 2.0)]),
        (4.0, 1e15, [(1.0, 1e-20), (2.0, 1e10)]),
    ];
    for (n, p, others) in cases {
        let a = n * p;
        let sum = a + others.iter().map(|&(n, p)| n * p).sum::<f32>();
        assert_eq!(balance(n, p, &others), a / sum);
        let sum2 = a * a + others.iter().map(|&(n, p)| (n * p) * (n * p)).sum::<f32>();
        assert_eq!(power(n, p, &others), a * a / sum2);
    }
    assert_eq!(balance(1.0, 0.0, &[(1.0, 0.0)]), 0.0);
}

/// Regression: `CombinedWeights::weights(−1e30, 1e30, 0)` gave (−0.909, 1.909). Every
/// combination of bad densities (and `p_ref` out of range) now gives two weights in [0, 1]
/// that sum to 1 (within 1e-6), or (0, 0) when every density is 0 or bad.
#[test]
fn combined_weights_stay_in_unit_range() {
    let w = CombinedWeights {
        n_tl: 1.0,
        n_mixture: 10.0,
        p_ref: 0.1,
        heuristic: Heuristic::Balance,
    };
    let (a, b) = w.weights(-1e30, 1e30, 0.0);
    assert_eq!((a, b), (0.0, 1.0));
    for heuristic in Heuristic::ALL {
        for p_ref in [0.0, 0.1, 1.0, -0.5, 2.0, f32::NAN] {
            for n_tl in [1.0, 0.0, -1.0, f32::NAN, f32::INFINITY] {
                let w = CombinedWeights {
                    n_tl,
                    n_mixture: 10.0,
                    p_ref,
                    heuristic,
                };
                for &t in &VALUES {
                    for &bl in &VALUES {
                        for &tb in &VALUES {
                            let (a, b) = w.weights(t, bl, tb);
                            let ctx = format!("{w:?} at ({t}, {bl}, {tb}): ({a}, {b})");
                            assert!(in_unit(a) && in_unit(b), "{ctx}");
                            assert!((a, b) == (0.0, 0.0) || (a + b - 1.0).abs() <= 1e-6, "{ctx}");
                            let any = [t, bl, tb].iter().any(|&x| x > 0.0);
                            assert!(any || (a, b) == (0.0, 0.0), "{ctx}");
                        }
                    }
                }
            }
        }
    }
}

/// `SequentialWeights` follows the same rule: TL's weight in [0, 1], the terms finite and
/// non-negative, for every combination of bad densities and recorded probabilities.
#[test]
fn sequential_weights_stay_in_unit_range() {
    for heuristic in Heuristic::ALL {
        let mut w = SequentialWeights::new(4, 1.0, heuristic);
        for p in [0.1, f32::NAN, -1.0, 2.0] {
            w.record(p);
        }
        for &t in &VALUES {
            for &bl in &VALUES {
                for &tb in &VALUES {
                    let ctx = format!("{heuristic:?} at ({t}, {bl}, {tb})");
                    let r = w.tl_weight(t, bl, tb);
                    assert!(in_unit(r), "{ctx}: tl_weight {r}");
                    let v = w.tl_term(1.0, t, bl, tb);
                    assert!(v.is_finite() && v >= 0.0, "{ctx}: tl_term {v}");
                    for p in [0.0, 0.5, 1.0, f32::NAN] {
                        let v = w.mixture_term(1.0, p, t, bl, tb);
                        assert!(v.is_finite() && v >= 0.0, "{ctx}: mixture_term {v}");
                    }
                }
            }
        }
    }
}
