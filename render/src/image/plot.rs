//! Convergence plots (SVG).

/// A log-log SVG plot of RMSE against busy seconds ([`Image::seconds`](super::Image::seconds)), one polyline per
/// named series of `(seconds, rmse)` points.
pub fn convergence_svg(title: &str, series: &[(&str, Vec<(f64, f64)>)]) -> String {
    const COLORS: [&str; 7] = [
        "#1f77b4", "#ff7f0e", "#2ca02c", "#d62728", "#9467bd", "#8c564b", "#e377c2",
    ];
    let (pw, ph, ml, mr, mt, mb) = (640.0, 420.0, 70.0, 130.0, 30.0, 50.0);
    let pts = series
        .iter()
        .flat_map(|s| s.1.iter())
        .filter(|p| p.0 > 0.0 && p.1 > 0.0);
    let (mut x0, mut x1, mut y0, mut y1) = (f64::MAX, f64::MIN, f64::MAX, f64::MIN);
    for &(x, y) in pts {
        x0 = x0.min(x.log10());
        x1 = x1.max(x.log10());
        y0 = y0.min(y.log10());
        y1 = y1.max(y.log10());
    }
    if x0 > x1 {
        (x0, x1, y0, y1) = (0.0, 1.0, 0.0, 1.0);
    }
    let (x0, x1, y0, y1) = (
        x0.floor(),
        x1.ceil().max(x0.floor() + 1.0),
        y0.floor(),
        y1.ceil().max(y0.floor() + 1.0),
    );
    let fx = |x: f64| ml + (x.log10() - x0) / (x1 - x0) * (pw - ml - mr);
    let fy = |y: f64| mt + (y1 - y.log10()) / (y1 - y0) * (ph - mt - mb);
    let mut s = format!(
        "<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{pw}\" height=\"{ph}\" font-family=\"sans-serif\" font-size=\"12\">\n<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n<text x=\"{}\" y=\"18\" text-anchor=\"middle\">{title}</text>\n",
        pw / 2.0
    );
    let (l, r, t, b) = (ml, pw - mr, mt, ph - mb);
    s.push_str(&format!(
        "<rect x=\"{l}\" y=\"{t}\" width=\"{}\" height=\"{}\" fill=\"none\" stroke=\"black\"/>\n",
        r - l,
        b - t
    ));
    for e in (x0 as i32)..=(x1 as i32) {
        let x = fx(10f64.powi(e));
        s.push_str(&format!(
            "<line x1=\"{x}\" y1=\"{t}\" x2=\"{x}\" y2=\"{b}\" stroke=\"#ddd\"/><text x=\"{x}\" y=\"{}\" text-anchor=\"middle\">1e{e}</text>\n",
            b + 16.0
        ));
    }
    for e in (y0 as i32)..=(y1 as i32) {
        let y = fy(10f64.powi(e));
        s.push_str(&format!(
            "<line x1=\"{l}\" y1=\"{y}\" x2=\"{r}\" y2=\"{y}\" stroke=\"#ddd\"/><text x=\"{}\" y=\"{}\" text-anchor=\"end\">1e{e}</text>\n",
            l - 6.0,
            y + 4.0
        ));
    }
    s.push_str(&format!(
        "<text x=\"{}\" y=\"{}\" text-anchor=\"middle\">busy CPU time (s, summed over threads)</text>\n<text x=\"16\" y=\"{}\" transform=\"rotate(-90 16 {})\" text-anchor=\"middle\">RMSE</text>\n",
        (l + r) / 2.0,
        ph - 10.0,
        (t + b) / 2.0,
        (t + b) / 2.0
    ));
    for (i, (name, points)) in series.iter().enumerate() {
        let c = COLORS[i % COLORS.len()];
        let poly: Vec<String> = points
            .iter()
            .filter(|p| p.0 > 0.0 && p.1 > 0.0)
            .map(|&(x, y)| format!("{:.1},{:.1}", fx(x), fy(y)))
            .collect();
        s.push_str(&format!(
            "<polyline points=\"{}\" fill=\"none\" stroke=\"{c}\" stroke-width=\"2\"/>\n",
            poly.join(" ")
        ));
        let ly = t + 10.0 + 18.0 * i as f64;
        s.push_str(&format!(
            "<line x1=\"{}\" y1=\"{ly}\" x2=\"{}\" y2=\"{ly}\" stroke=\"{c}\" stroke-width=\"2\"/><text x=\"{}\" y=\"{}\">{name}</text>\n",
            r + 10.0,
            r + 30.0,
            r + 36.0,
            ly + 4.0
        ));
    }
    s.push_str("</svg>\n");
    s
}
