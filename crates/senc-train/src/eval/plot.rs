//! The error-against-run-time plot (SVG, drawn with plotters): one panel per garment (each
//! garment's states differ, so its gaps are not comparable with another's), one colour per
//! method with a legend, milliseconds per frame on a log axis, and the energy gap on a
//! symmetric log axis, so that an answer ending *below* the converged reference (a negative
//! gap) shows below the zero line instead of folding onto the positive side.

use plotters::prelude::*;

use super::runtime::{CurvePoint, Series};
use crate::error::TrainError;

/// Width of one garment's panel and the height, pixels.
const PANEL: (u32, u32) = (560, 460);

/// Colours of the networks' series, in order of first appearance (the solver is black).
const COLOURS: [RGBColor; 8] = [
    RGBColor(31, 119, 180),
    RGBColor(214, 39, 40),
    RGBColor(44, 160, 44),
    RGBColor(255, 127, 14),
    RGBColor(148, 103, 189),
    RGBColor(140, 86, 75),
    RGBColor(227, 119, 194),
    RGBColor(23, 190, 207),
];

/// A symmetric log scale with linear part |y| < `c` (a power of ten): `t = y / c` there,
/// `±(1 + log10(|y| / c))` outside, so integer `t` are 0, ±c, ±10c, ±100c, ...
#[derive(Debug, Clone, Copy)]
struct SymLog {
    c: f64,
}

impl SymLog {
    /// A scale whose linear part ends at the power of ten at or below the smallest
    /// non-zero |value| (within 1e-9 .. 1).
    fn fitting(values: impl Iterator<Item = f64>) -> Self {
        let smallest = values.map(f64::abs).filter(|v| *v > 0.0 && v.is_finite()).fold(f64::INFINITY, f64::min);
        let c = if smallest.is_finite() { 10f64.powf(smallest.log10().floor()).clamp(1e-9, 1.0) } else { 1.0 };
        Self { c }
    }

    fn t(&self, y: f64) -> f64 {
        if y.abs() < self.c {
            y / self.c
        } else {
            y.signum() * (1.0 + (y.abs() / self.c).log10())
        }
    }

    fn y(&self, t: f64) -> f64 {
        if t.abs() < 1.0 {
            t * self.c
        } else {
            t.signum() * self.c * 10f64.powf(t.abs() - 1.0)
        }
    }

    /// The label of an integer `t` ("0", "1e-2", "-1e3"); empty between them.
    fn label(&self, t: f64) -> String {
        if (t - t.round()).abs() > 1e-6 {
            return String::new();
        }
        let y = self.y(t.round());
        if y == 0.0 {
            return "0".into();
        }
        format!("{}1e{}", if y < 0.0 { "-" } else { "" }, y.abs().log10().round() as i32)
    }
}

fn plot_error(e: impl std::fmt::Display) -> TrainError {
    TrainError::Invalid(format!("drawing the error-against-run-time plot: {e}"))
}

fn unique<'a, T: PartialEq + ?Sized>(items: impl Iterator<Item = &'a T>) -> Vec<&'a T> {
    let mut out: Vec<&T> = Vec::new();
    for i in items {
        if !out.contains(&i) {
            out.push(i);
        }
    }
    out
}

/// The label of one point beside its marker: the solver's iterations ("4 it"), or a
/// network's refinement ("+2 it"; nothing for the network alone).
fn point_label(p: &CurvePoint) -> String {
    match &p.series {
        Series::Solver => p.method.strip_prefix("solver ").unwrap_or(&p.method).to_string(),
        Series::Network(label) => match p.method.strip_prefix(label.as_str()).map(|r| r.trim_start_matches(" + ")) {
            Some(r) if !r.is_empty() => format!("+{r}"),
            _ => String::new(),
        },
    }
}

/// The plot of `curve` as SVG text.
pub fn runtime_svg(curve: &[CurvePoint]) -> Result<String, TrainError> {
    let garments = unique(curve.iter().map(|p| p.garment.as_str()));
    let solver = Series::Solver;
    let series = unique(
        std::iter::once(&solver)
            .filter(|s| curve.iter().any(|p| p.series == **s))
            .chain(curve.iter().map(|p| &p.series)),
    );
    let colour = |s: &Series| -> RGBColor {
        let networks: Vec<&&Series> = series.iter().filter(|n| ***n != Series::Solver).collect();
        match networks.iter().position(|n| **n == s) {
            Some(i) => COLOURS[i % COLOURS.len()],
            None => BLACK,
        }
    };
    let mut svg = String::new();
    {
        let size = (PANEL.0 * garments.len().max(1) as u32, PANEL.1);
        let root = SVGBackend::with_string(&mut svg, size).into_drawing_area();
        root.fill(&WHITE).map_err(plot_error)?;
        let panels = root.split_evenly((1, garments.len().max(1)));
        for (panel, garment) in panels.iter().zip(&garments) {
            let pts: Vec<&CurvePoint> = curve.iter().filter(|p| p.garment == *garment).collect();
            let scale = SymLog::fitting(pts.iter().map(|p| p.energy_gap));
            let ms = pts.iter().map(|p| p.ms_per_frame.max(1e-3));
            let (lo, hi) = ms.fold((f64::INFINITY, 0.0f64), |(a, b), v| (a.min(v), b.max(v)));
            let (x0, x1) = (10f64.powf(lo.log10().floor()), 10f64.powf(hi.log10().ceil()).max(10.0 * lo));
            let ts = pts.iter().map(|p| scale.t(p.energy_gap));
            let (t0, t1) = ts.fold((0.0f64, 0.0f64), |(a, b), t| (a.min(t), b.max(t)));
            // Room above the data for the legend (upper right): one line per series plus
            // the reference line, about 18 px each, in a plot about 360 px tall.
            let legend_px = 18.0 * (series.len() + 1) as f64 + 16.0;
            let span = (t1 - t0 + 0.6).max(1.0);
            let headroom = span * legend_px / (360.0 - legend_px);
            let (t0, t1) = ((t0 - 0.3).floor(), (t1 + 0.3 + headroom).ceil());
            let mut chart = ChartBuilder::on(panel)
                .caption(format!("{garment}: energy gap against run time"), ("sans-serif", 17))
                .margin(12)
                .x_label_area_size(45)
                .y_label_area_size(60)
                .build_cartesian_2d((x0..x1).log_scale(), t0..t1)
                .map_err(plot_error)?;
            chart
                .configure_mesh()
                .x_desc("milliseconds per frame (log)")
                .y_desc("E − E(converged), J (symmetric log)")
                .y_labels(((t1 - t0) as usize + 1).min(12))
                .y_label_formatter(&|t| scale.label(*t))
                .x_label_formatter(&|x| if *x >= 1.0 { format!("{x:.0}") } else { format!("{x}") })
                .light_line_style(WHITE)
                .draw()
                .map_err(plot_error)?;
            chart
                .draw_series(LineSeries::new([(x0, 0.0), (x1, 0.0)], BLACK.mix(0.5).stroke_width(1)))
                .map_err(plot_error)?
                .label("converged reference (gap 0)")
                .legend(|(x, y)| PathElement::new([(x, y), (x + 20, y)], BLACK.mix(0.5)));
            for s in &series {
                let mine: Vec<&&CurvePoint> = pts.iter().filter(|p| p.series == **s).collect();
                if mine.is_empty() {
                    continue;
                }
                let c = colour(s);
                let xy: Vec<(f64, f64)> =
                    mine.iter().map(|p| (p.ms_per_frame.max(1e-3), scale.t(p.energy_gap))).collect();
                let name = s.name();
                chart
                    .draw_series(LineSeries::new(xy.clone(), c.stroke_width(2)))
                    .map_err(plot_error)?
                    .label(name.to_string())
                    .legend(move |(x, y)| PathElement::new([(x, y), (x + 20, y)], c.stroke_width(2)));
                chart
                    .draw_series(mine.iter().zip(&xy).map(|(p, &(x, t))| {
                        EmptyElement::at((x, t))
                            + Circle::new((0, 0), 4, c.filled())
                            + Text::new(point_label(p), (6, -14), ("sans-serif", 11).into_font().color(&c))
                    }))
                    .map_err(plot_error)?;
            }
            chart
                .configure_series_labels()
                .position(SeriesLabelPosition::UpperRight)
                .background_style(WHITE.mix(0.85))
                .border_style(BLACK.mix(0.3))
                .label_font(("sans-serif", 12))
                .draw()
                .map_err(plot_error)?;
        }
        root.present().map_err(plot_error)?;
    }
    Ok(svg)
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn symlog_keeps_the_sign_and_labels_powers_of_ten() {
        let s = SymLog::fitting([0.03, -2.0, 150.0, 0.0].into_iter());
        assert_eq!(s.c, 0.01);
        for y in [-150.0, -2.0, -0.005, 0.0, 0.005, 0.03, 150.0] {
            assert!((s.y(s.t(y)) - y).abs() < 1e-9 * y.abs().max(1.0), "{y}");
            assert_eq!(s.t(y) < 0.0, y < 0.0, "{y}");
        }
        assert_eq!(s.label(0.0), "0");
        assert_eq!(s.label(1.0), "1e-2");
        assert_eq!(s.label(-3.0), "-1e0");
        assert_eq!(s.label(0.5), "");
    }

    #[test]
    fn the_svg_has_a_panel_per_garment_and_a_legend_entry_per_method() {
        let p = |method: &str, series: &str, garment: &str, ms: f64, gap: f64| CurvePoint {
            method: method.into(),
            garment: garment.into(),
            ms_per_frame: ms,
            energy_gap: gap,
            series: if series == "solver" { Series::Solver } else { Series::Network(series.into()) },
            volume_cm3: 0.0,
        };
        let curve = vec![
            p("solver 1 it", "solver", "tshirt", 50.0, 30.0),
            p("solver 4 it", "solver", "tshirt", 200.0, 0.5),
            p("SENC", "SENC", "tshirt", 20.0, 12.0),
            p("SENC + 2 it", "SENC", "tshirt", 120.0, -0.2),
            p("solver 1 it", "solver", "skirt", 10.0, 3.0),
            p("baseline", "baseline", "skirt", 5.0, 40.0),
        ];
        let svg = runtime_svg(&curve).unwrap();
        for text in ["tshirt: energy", "skirt: energy", "SENC", "baseline", "reference solver", "-1e"] {
            assert!(svg.contains(text), "{text} missing");
        }
        assert_eq!(point_label(&curve[3]), "+2 it");
        assert_eq!(point_label(&curve[2]), "");
        assert_eq!(point_label(&curve[1]), "4 it");
    }
}
