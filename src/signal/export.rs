//! Writing plotted data out: the series a view shows as CSV, and as an SVG plot (polylines of
//! the data with axes, ticks, labels and a legend). Pure functions returning text; the caller
//! writes the file. Used by the desktop workbench's Export menu and testable without it.

/// One plotted series: `y` against `x`, equal lengths.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct Series {
    /// Legend name, e.g. `measured`.
    pub name: String,
    /// Abscissae (e.g. frequency in Hz).
    pub x: Vec<f64>,
    /// Ordinates.
    pub y: Vec<f64>,
}

/// What a plot shows: a title, axis labels with units, and its series.
#[derive(Debug, Clone, PartialEq, Default)]
pub struct PlotData {
    /// Title, e.g. `Envelope spectrum of X105_DE_time`.
    pub title: String,
    /// x-axis label with unit, e.g. `frequency (Hz)`.
    pub x_label: String,
    /// y-axis label with unit.
    pub y_label: String,
    /// The series.
    pub series: Vec<Series>,
}

/// A CSV field: quoted when it holds a comma, quote or line break.
fn field(s: &str) -> String {
    if s.contains([',', '"', '\n', '\r']) {
        format!("\"{}\"", s.replace('"', "\"\""))
    } else {
        s.to_string()
    }
}

/// The plot's data as CSV text.
///
/// When every series has the same `x` (e.g. measured and simulated on one frequency grid), one
/// wide table: `<x_label>,<series 1>,<series 2>,...`. Otherwise a long table
/// `series,<x_label>,<y_label>` with one row per point. Numbers are written with Rust's
/// shortest round-trip formatting, so reading them back gives the same `f64`. A series whose
/// `x` and `y` lengths differ is written up to the shorter length.
pub fn to_csv(p: &PlotData) -> String {
    let mut out = String::new();
    let shared = p.series.first().map(|s0| p.series.iter().all(|s| s.x == s0.x && s.y.len() == s.x.len())).unwrap_or(false);
    if shared {
        let s0 = &p.series[0];
        out.push_str(&field(&p.x_label));
        for s in &p.series {
            out.push(',');
            out.push_str(&field(&s.name));
        }
        out.push('\n');
        for (i, x) in s0.x.iter().enumerate() {
            out.push_str(&x.to_string());
            for s in &p.series {
                out.push(',');
                out.push_str(&s.y[i].to_string());
            }
            out.push('\n');
        }
    } else {
        out.push_str(&format!("series,{},{}\n", field(&p.x_label), field(&p.y_label)));
        for s in &p.series {
            let name = field(&s.name);
            for (x, y) in s.x.iter().zip(&s.y) {
                out.push_str(&format!("{name},{x},{y}\n"));
            }
        }
    }
    out
}

/// "Nice" tick positions covering `[lo, hi]` (about `n` of them, steps of 1, 2 or 5 × 10^k).
pub fn nice_ticks(lo: f64, hi: f64, n: usize) -> Vec<f64> {
    if !(lo.is_finite() && hi.is_finite()) || hi <= lo || n == 0 {
        return Vec::new();
    }
    let raw = (hi - lo) / n as f64;
    let mag = 10f64.powf(raw.log10().floor());
    let step = [1.0, 2.0, 5.0, 10.0].iter().map(|m| m * mag).find(|s| *s >= raw).unwrap_or(10.0 * mag);
    let first = (lo / step).ceil() as i64;
    let last = (hi / step).floor() as i64;
    (first..=last).map(|k| k as f64 * step).map(|t| if t.abs() < step * 1e-9 { 0.0 } else { t }).collect()
}

fn esc(s: &str) -> String {
    s.replace('&', "&amp;").replace('<', "&lt;").replace('>', "&gt;").replace('"', "&quot;")
}

/// A tick label: plain digits in 1e-3..1e5 (trailing zeros dropped), else `1.23e-5`.
pub fn tick_label(t: f64) -> String {
    let a = t.abs();
    if a != 0.0 && !(1e-3..1e5).contains(&a) {
        format!("{t:.2e}")
    } else {
        let s = format!("{t:.4}");
        let s = if s.contains('.') { s.trim_end_matches('0').trim_end_matches('.') } else { &s };
        if s == "-0" { "0".to_string() } else { s.to_string() }
    }
}

/// Colours of the series, in order (cycled).
const PALETTE: [&str; 6] = ["#3c78dc", "#e67828", "#2ca02c", "#c83c3c", "#9467bd", "#8c564b"];

/// The plot as a standalone SVG document `width_px × height_px`: a frame with nice ticks on both
/// axes, the axis labels, the title, a legend, and one polyline per series (NaN/inf points
/// break the line). Long series are reduced per horizontal pixel to their first, minimum,
/// maximum and last point in that pixel, so every peak stays in the drawing and the file stays
/// small. Returns an SVG with only the frame when there is nothing finite to draw.
pub fn to_svg(p: &PlotData, width_px: u32, height_px: u32) -> String {
    let (w, h) = (width_px.max(200) as f64, height_px.max(150) as f64);
    let (ml, mr, mt, mb) = (70.0, 20.0, 34.0, 46.0);
    let (pw, ph) = (w - ml - mr, h - mt - mb);
    let pts = p.series.iter().flat_map(|s| s.x.iter().zip(&s.y)).filter(|(x, y)| x.is_finite() && y.is_finite());
    let (mut x0, mut x1, mut y0, mut y1) = (f64::INFINITY, f64::NEG_INFINITY, f64::INFINITY, f64::NEG_INFINITY);
    for (&x, &y) in pts {
        x0 = x0.min(x);
        x1 = x1.max(x);
        y0 = y0.min(y);
        y1 = y1.max(y);
    }
    let mut svg = format!("<svg xmlns=\"http://www.w3.org/2000/svg\" width=\"{w}\" height=\"{h}\" viewBox=\"0 0 {w} {h}\" font-family=\"sans-serif\" font-size=\"11\">\n<rect width=\"100%\" height=\"100%\" fill=\"white\"/>\n");
    svg.push_str(&format!("<text x=\"{}\" y=\"20\" text-anchor=\"middle\" font-size=\"13\">{}</text>\n", w / 2.0, esc(&p.title)));
    svg.push_str(&format!("<rect x=\"{ml}\" y=\"{mt}\" width=\"{pw}\" height=\"{ph}\" fill=\"none\" stroke=\"#444\"/>\n"));
    svg.push_str(&format!("<text x=\"{}\" y=\"{}\" text-anchor=\"middle\">{}</text>\n", ml + pw / 2.0, h - 8.0, esc(&p.x_label)));
    svg.push_str(&format!("<text x=\"14\" y=\"{}\" text-anchor=\"middle\" transform=\"rotate(-90 14 {})\">{}</text>\n", mt + ph / 2.0, mt + ph / 2.0, esc(&p.y_label)));
    // Also when either is NaN (no finite point).
    if x0.partial_cmp(&x1) != Some(std::cmp::Ordering::Less) {
        x1 = x0 + 1.0;
    }
    if y0.partial_cmp(&y1) != Some(std::cmp::Ordering::Less) {
        let c = if y0.is_finite() { y0 } else { 0.0 };
        (y0, y1) = (c - 1.0, c + 1.0);
    }
    if !x0.is_finite() {
        svg.push_str("</svg>\n");
        return svg;
    }
    let pad = 0.04 * (y1 - y0);
    let (y0, y1) = (y0 - pad, y1 + pad);
    let sx = |x: f64| ml + (x - x0) / (x1 - x0) * pw;
    let sy = |y: f64| mt + ph - (y - y0) / (y1 - y0) * ph;
    for t in nice_ticks(x0, x1, 8) {
        let xp = sx(t);
        svg.push_str(&format!("<line x1=\"{xp:.1}\" y1=\"{:.1}\" x2=\"{xp:.1}\" y2=\"{:.1}\" stroke=\"#ddd\"/><text x=\"{xp:.1}\" y=\"{:.1}\" text-anchor=\"middle\">{}</text>\n", mt, mt + ph, mt + ph + 14.0, tick_label(t)));
    }
    for t in nice_ticks(y0, y1, 6) {
        let yp = sy(t);
        svg.push_str(&format!("<line x1=\"{ml}\" y1=\"{yp:.1}\" x2=\"{:.1}\" y2=\"{yp:.1}\" stroke=\"#ddd\"/><text x=\"{:.1}\" y=\"{:.1}\" text-anchor=\"end\">{}</text>\n", ml + pw, ml - 4.0, yp + 4.0, tick_label(t)));
    }
    for (k, s) in p.series.iter().enumerate() {
        let colour = PALETTE[k % PALETTE.len()];
        for run in reduce_per_pixel(s, x0, x1, pw) {
            if run.len() < 2 {
                continue;
            }
            let coords: Vec<String> = run.iter().map(|&(x, y)| format!("{:.1},{:.1}", sx(x), sy(y))).collect();
            svg.push_str(&format!("<polyline fill=\"none\" stroke=\"{colour}\" stroke-width=\"1.2\" points=\"{}\"/>\n", coords.join(" ")));
        }
        let ly = mt + 14.0 + 14.0 * k as f64;
        svg.push_str(&format!("<line x1=\"{:.1}\" y1=\"{ly:.1}\" x2=\"{:.1}\" y2=\"{ly:.1}\" stroke=\"{colour}\" stroke-width=\"2\"/><text x=\"{:.1}\" y=\"{:.1}\">{}</text>\n", ml + pw - 130.0, ml + pw - 112.0, ml + pw - 108.0, ly + 4.0, esc(&s.name)));
    }
    svg.push_str("</svg>\n");
    svg
}

/// Splits a series into finite runs and keeps, per horizontal pixel, the first, smallest,
/// largest and last point (in x order within the pixel).
fn reduce_per_pixel(s: &Series, x0: f64, x1: f64, width_px: f64) -> Vec<Vec<(f64, f64)>> {
    let mut runs: Vec<Vec<(f64, f64)>> = vec![Vec::new()];
    let mut bucket: Vec<(f64, f64)> = Vec::new();
    let mut current: Option<i64> = None;
    let flush = |bucket: &mut Vec<(f64, f64)>, run: &mut Vec<(f64, f64)>| {
        if bucket.len() <= 4 {
            run.append(bucket);
            return;
        }
        let first = bucket[0];
        let last = *bucket.last().unwrap_or(&first);
        let lo = bucket.iter().copied().fold(first, |a, b| if b.1 < a.1 { b } else { a });
        let hi = bucket.iter().copied().fold(first, |a, b| if b.1 > a.1 { b } else { a });
        let mut keep = vec![first, lo, hi, last];
        keep.dedup();
        run.extend(keep);
        bucket.clear();
    };
    for (&x, &y) in s.x.iter().zip(&s.y) {
        if !(x.is_finite() && y.is_finite()) {
            let run = runs.last_mut().expect("one run");
            flush(&mut bucket, run);
            runs.push(Vec::new());
            current = None;
            continue;
        }
        let px = ((x - x0) / (x1 - x0) * width_px).floor() as i64;
        if current != Some(px) {
            let run = runs.last_mut().expect("one run");
            flush(&mut bucket, run);
            current = Some(px);
        }
        bucket.push((x, y));
    }
    let run = runs.last_mut().expect("one run");
    flush(&mut bucket, run);
    runs
}

#[cfg(test)]
mod tests {
    use super::*;

    fn plot() -> PlotData {
        PlotData {
            title: "Envelope spectrum, measured & model".into(),
            x_label: "frequency (Hz)".into(),
            y_label: "amplitude (g)".into(),
            series: vec![Series { name: "measured".into(), x: vec![0.0, 0.5, 1.0], y: vec![1.0, 0.1 + 0.2, -2.5e-7] }, Series { name: "simulated, calibrated".into(), x: vec![0.0, 0.5, 1.0], y: vec![0.9, 0.2, f64::NAN] }],
        }
    }

    /// Same x: one wide table whose numbers read back bit for bit.
    #[test]
    fn csv_wide_round_trips_numbers() {
        let csv = to_csv(&plot());
        let lines: Vec<&str> = csv.lines().collect();
        assert_eq!(lines[0], "frequency (Hz),measured,\"simulated, calibrated\"");
        assert_eq!(lines.len(), 4);
        let row: Vec<f64> = lines[2].split(',').map(|x| x.parse().unwrap()).collect();
        assert_eq!(row, vec![0.5, 0.1 + 0.2, 0.2]);
        assert_eq!(lines[3].split(',').nth(1).unwrap().parse::<f64>().unwrap(), -2.5e-7);
        assert_eq!(lines[3].split(',').nth(2).unwrap(), "NaN");
    }

    /// Different x: a long table, one row per point.
    #[test]
    fn csv_long_when_grids_differ() {
        let mut p = plot();
        p.series[1].x = vec![0.0, 0.25, 0.75];
        let csv = to_csv(&p);
        let lines: Vec<&str> = csv.lines().collect();
        assert_eq!(lines[0], "series,frequency (Hz),amplitude (g)");
        assert_eq!(lines.len(), 7);
        assert_eq!(lines[5], "\"simulated, calibrated\",0.25,0.2");
    }

    #[test]
    fn ticks_are_nice() {
        assert_eq!(nice_ticks(0.0, 500.0, 5), vec![0.0, 100.0, 200.0, 300.0, 400.0, 500.0]);
        assert_eq!(nice_ticks(-0.13, 0.42, 5), vec![0.0, 0.2, 0.4]);
        assert_eq!(nice_ticks(-25.0, 12.0, 4), vec![-20.0, -10.0, 0.0, 10.0]);
        assert!(nice_ticks(1.0, 1.0, 5).is_empty());
        assert_eq!(tick_label(0.0), "0");
        assert_eq!(tick_label(0.5), "0.5");
        assert_eq!(tick_label(2000.0), "2000");
        assert_eq!(tick_label(6e-5), "6.00e-5");
    }

    /// The SVG names the axes and series, escapes text, draws one polyline per finite run, and
    /// keeps a one-sample spike of a 1-million-point series while staying small.
    #[test]
    fn svg_has_labels_lines_and_keeps_a_spike() {
        let svg = to_svg(&plot(), 640, 400);
        assert!(svg.starts_with("<svg xmlns=\"http://www.w3.org/2000/svg\""));
        assert!(svg.contains(">frequency (Hz)</text>") && svg.contains(">amplitude (g)</text>"));
        assert!(svg.contains("Envelope spectrum, measured &amp; model"));
        assert_eq!(svg.matches("<polyline").count(), 2, "measured, and the simulated run before its NaN");
        let n = 1_000_000;
        let mut y: Vec<f64> = (0..n).map(|i| 0.01 * ((i as f64) * 0.37).sin()).collect();
        y[654_321] = 7.0;
        let big = PlotData { title: "t".into(), x_label: "time (s)".into(), y_label: "a".into(), series: vec![Series { name: "x".into(), x: (0..n).map(|i| i as f64).collect(), y }] };
        let svg = to_svg(&big, 800, 400);
        assert!(svg.len() < 200_000, "{} bytes", svg.len());
        // the spike's ordinate is the top of the data range: y = mt + pad share of the plot height
        let top = 34.0 + (400.0 - 34.0 - 46.0) * (0.04 / 1.08);
        let want = format!(",{top:.1}");
        assert!(svg.contains(&want), "spike at y = {top:.1} kept");
    }
}
