//! The drawing pieces every figure is made of: a white SVG canvas, axes whose ticks
//! enclose the data, line styles, time panels with a legend, the colours. Plotters' SVG
//! backend writes text as SVG `<text>` and needs no font files.

use std::ops::Range;
use std::path::Path as FsPath;

use plotters::coord::ranged1d::{KeyPointHint, NoDefaultFormatting, Ranged, ValueFormatter};
use plotters::coord::types::RangedCoordf64;
use plotters::coord::Shift;
use plotters::element::DashedPathElement;
use plotters::prelude::*;

use super::FigureError;

/// A drawing area of an SVG figure.
pub type Canvas<'a> = DrawingArea<SVGBackend<'a>, Shift>;

/// Blue (the robot in Figs. 5–7; x_e, v).
pub const BLUE: RGBColor = RGBColor(31, 119, 180);
/// Orange (the right wheel).
pub const ORANGE: RGBColor = RGBColor(255, 127, 14);
/// Green (the left wheel; y_e).
pub const GREEN: RGBColor = RGBColor(44, 160, 44);
/// Red (θ_e, ω).
pub const RED: RGBColor = RGBColor(214, 39, 40);
/// Grey (the reference, set-points).
pub const GREY: RGBColor = RGBColor(120, 120, 120);
/// Colours of successive series (laws in a comparison, runs in a step comparison).
pub const PALETTE: [RGBColor; 4] = [RED, BLUE, GREEN, ORANGE];

/// `colour` at half its brightness: what a series' command or set-point is drawn in,
/// beside the series itself.
pub const fn darker(colour: RGBColor) -> RGBColor {
    RGBColor(colour.0 / 2, colour.1 / 2, colour.2 / 2)
}

/// How a series' line is drawn: its colour, width (px) and dash.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct LineStyle {
    /// Colour.
    pub colour: RGBColor,
    /// Stroke width, px.
    pub width: u32,
    /// Dashed: (dash, gap), px along the line; `None` is a solid line.
    pub dash: Option<(u32, u32)>,
}

impl LineStyle {
    /// A solid line.
    pub const fn solid(colour: RGBColor, width: u32) -> Self {
        Self {
            colour,
            width,
            dash: None,
        }
    }

    /// A dashed line: dashes of 8 px, gaps of 4 px.
    pub const fn dashed(colour: RGBColor, width: u32) -> Self {
        Self {
            colour,
            width,
            dash: Some((8, 4)),
        }
    }

    /// Plotters' stroke of this style.
    pub(super) fn stroke(self) -> ShapeStyle {
        self.colour.stroke_width(self.width)
    }

    /// The legend's sample of this style: a 24 px line at `(x, y)`, dashed as the line is
    /// (a solid one is one dash longer than the sample).
    pub(super) fn legend_sample(
        self,
        (x, y): (i32, i32),
    ) -> DashedPathElement<std::vec::IntoIter<(i32, i32)>, u32> {
        let (dash, gap) = self.dash.unwrap_or((25, 1));
        DashedPathElement::new(vec![(x, y), (x + 24, y)], dash, gap, self.stroke())
    }
}

/// How the runs of a comparison are drawn, in order: each narrower than the one before
/// and drawn over it, solid and dashed in turn, so that where their lines coincide every
/// one still shows (a wide red band, a blue dash inside it, a thin green line inside
/// that).
pub const RUN_STYLES: [LineStyle; 4] = [
    LineStyle::solid(RED, 7),
    LineStyle::dashed(BLUE, 4),
    LineStyle::solid(GREEN, 1),
    LineStyle::dashed(ORANGE, 1),
];

/// The style of the `i`-th run of a comparison ([`RUN_STYLES`], cycled).
pub const fn run_style(i: usize) -> LineStyle {
    RUN_STYLES[i % RUN_STYLES.len()]
}

/// A white SVG canvas of `size` (width, height) px that will be written to `file` by
/// [`present`].
pub fn svg_canvas(file: &FsPath, size: (u32, u32)) -> Result<Canvas<'_>, FigureError> {
    let root = SVGBackend::new(file, size).into_drawing_area();
    root.fill(&WHITE)?;
    Ok(root)
}

/// Writes `root`, made by [`svg_canvas`] for `file`, to its file.
pub fn present(root: &Canvas<'_>, file: &FsPath) -> Result<(), FigureError> {
    root.present().map_err(|source| FigureError::Write {
        file: file.to_path_buf(),
        source,
    })
}

/// An axis: its range, the values of its ticks and how they are written.
#[derive(Clone, Debug, PartialEq)]
pub struct Axis {
    /// The range shown, in the axis' unit.
    pub range: Range<f64>,
    /// Tick values, ascending: integer multiples of one step of 1, 2 or 5 × 10ᵏ.
    pub ticks: Vec<f64>,
    /// Decimals of every tick label (those of the step).
    decimals: usize,
}

/// Most ticks an axis is given.
const MAX_TICKS: usize = 10;

/// The step of 1, 2 or 5 × 10ᵏ that cuts `span` into at most `MAX_TICKS` − 1 intervals,
/// and its decimals.
fn tick_step(span: f64) -> (f64, usize) {
    let rough = (span / (MAX_TICKS - 1) as f64).max(1e-12);
    let k = rough.log10().floor();
    let unit = 10f64.powf(k);
    let mantissa = [1.0, 2.0, 5.0, 10.0]
        .into_iter()
        .find(|m| m * unit >= rough * (1.0 - 1e-9))
        .unwrap_or(10.0);
    let step = mantissa * unit;
    let decimals = (-step.log10().floor()).max(0.0) as usize;
    (step, decimals)
}

impl Axis {
    /// An axis from `lo` to `hi` widened to the nearest ticks on both sides, so that every
    /// value in [`lo`, `hi`] lies between the first tick and the last.
    pub fn enclosing(lo: f64, hi: f64) -> Self {
        let (lo, hi) = if hi > lo {
            (lo, hi)
        } else {
            (lo - 1.0, lo + 1.0)
        };
        let (step, decimals) = tick_step(hi - lo);
        let first = (lo / step).floor() as i64;
        let last = (hi / step).ceil() as i64;
        Self {
            range: first as f64 * step..last as f64 * step,
            ticks: (first..=last).map(|k| k as f64 * step).collect(),
            decimals,
        }
    }

    /// An axis showing exactly `range`, its ticks within it.
    pub fn within(range: Range<f64>) -> Self {
        let (step, decimals) = tick_step(range.end - range.start);
        let first = (range.start / step - 1e-9).ceil() as i64;
        let last = (range.end / step + 1e-9).floor() as i64;
        Self {
            ticks: (first..=last).map(|k| k as f64 * step).collect(),
            range,
            decimals,
        }
    }

    /// The label of tick `value`: the step's decimals, and zero as `0` (never `-0.0`).
    pub fn label(&self, value: f64) -> String {
        let shown = format!("{value:.*}", self.decimals);
        if shown
            .trim_start_matches('-')
            .trim_start_matches(['0', '.'])
            .is_empty()
        {
            "0".to_string()
        } else {
            shown
        }
    }
}

/// An [`Axis`] as a plotters coordinate: the axis' range, its ticks as the only key
/// points (no light mesh lines), its labels.
pub struct AxisCoord {
    linear: RangedCoordf64,
    axis: Axis,
}

impl From<Axis> for AxisCoord {
    fn from(axis: Axis) -> Self {
        Self {
            linear: axis.range.clone().into(),
            axis,
        }
    }
}

impl Ranged for AxisCoord {
    type FormatOption = NoDefaultFormatting;
    type ValueType = f64;

    fn map(&self, value: &f64, limit: (i32, i32)) -> i32 {
        self.linear.map(value, limit)
    }

    fn key_points<Hint: KeyPointHint>(&self, hint: Hint) -> Vec<f64> {
        if hint.weight().allow_light_points() {
            Vec::new()
        } else {
            self.axis.ticks.clone()
        }
    }

    fn range(&self) -> Range<f64> {
        self.axis.range.clone()
    }
}

impl ValueFormatter<f64> for AxisCoord {
    fn format_ext(&self, value: &f64) -> String {
        self.axis.label(*value)
    }
}

/// The finite extremes of `values`, `None` without any.
fn extremes(values: impl Iterator<Item = f64>) -> Option<(f64, f64)> {
    values
        .filter(|v| v.is_finite())
        .fold(None, |acc, v| match acc {
            None => Some((v, v)),
            Some((lo, hi)) => Some((lo.min(v), hi.max(v))),
        })
}

/// The y axis of `values`: 5 % of margin (at least 1e-3 in all) each side, then widened to
/// the enclosing ticks; −1…1 without a finite value.
fn value_axis(values: impl Iterator<Item = f64>) -> Axis {
    match extremes(values) {
        None => Axis::enclosing(-1.0, 1.0),
        Some((lo, hi)) => {
            let span = (hi - lo).max(1e-3);
            Axis::enclosing(lo - 0.05 * span, hi + 0.05 * span)
        }
    }
}

/// One series of a time panel: (label, line style, one value per time sample, in the
/// panel's unit). Series are drawn in order, each over the ones before.
pub type Series<'a> = (&'a str, LineStyle, Vec<f64>);

/// Draws one time panel on `area`: `series` against `t` (s), the y axis titled `y_desc`
/// (with its unit) and its ticks enclosing every value, a vertical dashed `marker` at
/// (t s, legend label; an empty label draws no legend entry), and the legend where the
/// data are not.
pub fn draw_panel(
    area: &Canvas<'_>,
    caption: &str,
    y_desc: &str,
    t: &[f64],
    series: &[Series<'_>],
    marker: Option<(f64, &str)>,
) -> Result<(), FigureError> {
    let t_axis = match extremes(t.iter().copied()) {
        Some((first, last)) => Axis::enclosing(first, last),
        None => Axis::enclosing(0.0, 1.0),
    };
    let y_axis = value_axis(series.iter().flat_map(|s| s.2.iter().copied()));
    let mut chart = ChartBuilder::on(area)
        .caption(caption, ("sans-serif", 15))
        .margin(8)
        .x_label_area_size(32)
        .y_label_area_size(60)
        .build_cartesian_2d(AxisCoord::from(t_axis), AxisCoord::from(y_axis))?;
    chart
        .configure_mesh()
        .x_desc("t (s)")
        .y_desc(y_desc)
        .light_line_style(WHITE.mix(0.0))
        .draw()?;
    for (label, style, values) in series {
        let style = *style;
        let points: Vec<(f64, f64)> = t.iter().copied().zip(values.iter().copied()).collect();
        let anno = match style.dash {
            Some((dash, gap)) => {
                chart.draw_series(DashedLineSeries::new(points, dash, gap, style.stroke()))?
            }
            None => chart.draw_series(LineSeries::new(points, style.stroke()))?,
        };
        anno.label(*label).legend(move |at| style.legend_sample(at));
    }
    let y = chart.y_range();
    if let Some((at, label)) = marker {
        let line = chart.draw_series(DashedLineSeries::new(
            vec![(at, y.start), (at, y.end)],
            4,
            4,
            BLACK.stroke_width(1),
        ))?;
        if !label.is_empty() {
            line.label(label).legend(|at| {
                LineStyle {
                    colour: BLACK,
                    width: 1,
                    dash: Some((4, 4)),
                }
                .legend_sample(at)
            });
        }
    }
    // Legend where the data are not: data late in the run high up → legend low.
    let late = t.len() * 13 / 20;
    let (mut sum, mut n) = (0.0, 0usize);
    for (_, _, values) in series {
        for v in values.iter().skip(late).filter(|v| v.is_finite()) {
            sum += v;
            n += 1;
        }
    }
    let high = n > 0 && sum / n as f64 > 0.5 * (y.start + y.end);
    chart
        .configure_series_labels()
        .position(if high {
            SeriesLabelPosition::LowerRight
        } else {
            SeriesLabelPosition::UpperRight
        })
        .background_style(WHITE.mix(0.85))
        .border_style(BLACK)
        .draw()?;
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn an_enclosing_axis_puts_every_value_between_its_first_and_last_tick() {
        // The paper law's y_e on the circle: −0.30 … +0.035 m, 5 % margin each side.
        let a = value_axis([-0.30, 0.035].into_iter());
        assert_eq!(a.ticks.first(), Some(&a.range.start));
        assert_eq!(a.ticks.last(), Some(&a.range.end));
        assert!(a.range.start <= -0.30 && a.range.end >= 0.035, "{a:?}");
        assert!(a.ticks.len() <= MAX_TICKS, "{a:?}");
        assert!((a.range.start + 0.35).abs() < 1e-12 && (a.range.end - 0.1).abs() < 1e-12);
    }

    #[test]
    fn zero_is_labelled_0_and_the_step_sets_the_decimals() {
        let a = Axis::enclosing(-0.52, 0.02);
        let labels: Vec<String> = a.ticks.iter().map(|&v| a.label(v)).collect();
        assert_eq!(
            labels,
            ["-0.6", "-0.5", "-0.4", "-0.3", "-0.2", "-0.1", "0", "0.1"]
        );
        assert_eq!(a.label(-0.0), "0");
        assert_eq!(a.label(-1e-17), "0");
        let t = Axis::enclosing(0.0, 30.0);
        assert_eq!(t.ticks, [0.0, 5.0, 10.0, 15.0, 20.0, 25.0, 30.0]);
        assert_eq!(t.label(0.0), "0");
        assert_eq!(t.label(5.0), "5");
        let w = Axis::within(-0.74..1.26);
        assert_eq!(w.ticks, [-0.5, 0.0, 0.5, 1.0]);
        assert_eq!(w.range, -0.74..1.26);
    }
}
