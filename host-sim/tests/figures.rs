//! The figures of real runs, read back from their SVG: each law distinct where the lines
//! coincide, the paper law's lag on the path, axes that contain their data and fit it,
//! commands distinct from the truth, and no `-0.0` on an axis.

use std::path::PathBuf;

use controller_core::law::LawKind;
use host_sim::{run_scenario, RunResult};
use robot_files::figures::{compare, fig5_path, fig6_errors, fig7_inputs};
use robot_files::scenario::Scenario;

/// Colours as the SVG writes them: the paper, tracking and Kanayama laws in a comparison
/// (red, blue, green), and the darker blue of Fig. 7's commanded v.
const RED: &str = "#D62728";
const BLUE: &str = "#1F77B4";
const GREEN: &str = "#2CA02C";
const DARK_BLUE: &str = "#0F3B5A";

/// One `<polyline>`: its stroke colour, width (px) and points (px).
struct Polyline {
    stroke: String,
    width: u32,
    points: Vec<(i32, i32)>,
}

/// One `<text>`: its anchor point (px), `text-anchor` and text.
struct Text {
    x: i32,
    y: i32,
    anchor: String,
    text: String,
}

/// The value of attribute `name` in the element text `element`.
fn attribute<'a>(element: &'a str, name: &str) -> Option<&'a str> {
    let start = element.find(&format!(" {name}=\""))? + name.len() + 3;
    let len = element[start..].find('"')?;
    Some(&element[start..start + len])
}

fn polylines(svg: &str) -> Vec<Polyline> {
    svg.split("<polyline")
        .skip(1)
        .map(|rest| {
            let element = &rest[..rest.find("/>").unwrap()];
            Polyline {
                stroke: attribute(element, "stroke").unwrap().to_string(),
                width: attribute(element, "stroke-width").unwrap().parse().unwrap(),
                points: attribute(element, "points")
                    .unwrap()
                    .split_whitespace()
                    .map(|p| {
                        let (x, y) = p.split_once(',').unwrap();
                        (x.parse().unwrap(), y.parse().unwrap())
                    })
                    .collect(),
            }
        })
        .collect()
}

fn texts(svg: &str) -> Vec<Text> {
    svg.split("<text")
        .skip(1)
        .map(|rest| {
            let open = &rest[..rest.find('>').unwrap()];
            let body = &rest[rest.find('>').unwrap() + 1..rest.find("</text>").unwrap()];
            Text {
                x: attribute(open, "x").unwrap().parse().unwrap(),
                y: attribute(open, "y").unwrap().parse().unwrap(),
                anchor: attribute(open, "text-anchor").unwrap_or("").to_string(),
                text: body.trim().to_string(),
            }
        })
        .collect()
}

/// The numbers of the y axis' tick labels (right-aligned, left of the plot) whose
/// anchor lies in `rows` (px), with their y (px).
fn y_ticks(svg: &str, rows: std::ops::Range<i32>) -> Vec<(i32, f64)> {
    texts(svg)
        .into_iter()
        .filter(|t| t.anchor == "end" && t.x < 80 && rows.contains(&t.y))
        .filter_map(|t| Some((t.y, t.text.parse().ok()?)))
        .collect()
}

/// The numbers of the x axis' tick labels (centred, below the plot) in `rows` (px).
fn x_ticks(svg: &str, rows: std::ops::Range<i32>) -> Vec<f64> {
    texts(svg)
        .into_iter()
        .filter(|t| t.anchor == "middle" && rows.contains(&t.y))
        .filter_map(|t| t.text.parse().ok())
        .collect()
}

fn span(values: &[f64]) -> f64 {
    let max = values.iter().copied().fold(f64::MIN, f64::max);
    let min = values.iter().copied().fold(f64::MAX, f64::min);
    max - min
}

/// A fresh directory for one test's figures, removed when dropped.
struct OutDir(PathBuf);

impl OutDir {
    fn join(&self, file: &str) -> PathBuf {
        self.0.join(file)
    }
}

impl Drop for OutDir {
    fn drop(&mut self) {
        let _ = std::fs::remove_dir_all(&self.0);
    }
}

fn out_dir(test: &str) -> OutDir {
    let dir = std::env::temp_dir().join(format!("host-sim-figures-{}-{test}", std::process::id()));
    std::fs::create_dir_all(&dir).unwrap();
    OutDir(dir)
}

fn run(scenario: &Scenario, law: LawKind) -> RunResult {
    run_scenario(scenario, law).unwrap()
}

fn paper_circle_comparison(dir: &OutDir) -> String {
    let s = Scenario::load("paper-circle").unwrap();
    let results: Vec<(LawKind, RunResult)> = LawKind::ALL
        .into_iter()
        .map(|law| (law, run(&s, law)))
        .collect();
    let runs: Vec<(&str, &[robot_files::trace::TraceRow])> = results
        .iter()
        .map(|(law, r)| (law.name(), r.trace.as_slice()))
        .collect();
    let file = dir.join("compare.svg");
    compare(&file, &s.name, &s.path, &runs).unwrap();
    std::fs::read_to_string(file).unwrap()
}

/// Where the laws' lines coincide (on the circle once they have settled) each still
/// shows: each law has its own stroke width, and the middle one is dashed over the wider
/// one under it. Every line was 2 px and solid, and Kanayama's covered the tracking law's.
#[test]
fn compare_draws_each_law_in_its_own_width_and_dash() {
    let svg = paper_circle_comparison(&out_dir("compare-styles"));
    let lines = polylines(&svg);
    let widths = |colour: &str| {
        let mut w: Vec<u32> = lines
            .iter()
            .filter(|l| l.stroke == colour)
            .map(|l| l.width)
            .collect();
        w.sort_unstable();
        w.dedup();
        w
    };
    let count = |colour: &str| lines.iter().filter(|l| l.stroke == colour).count();
    let (paper, tracking, kanayama) = (widths(RED), widths(BLUE), widths(GREEN));
    assert_eq!(paper.len(), 1, "paper: {paper:?}");
    assert_eq!(tracking.len(), 1, "tracking: {tracking:?}");
    assert_eq!(kanayama.len(), 1, "kanayama: {kanayama:?}");
    // Each narrower than the one drawn before it, so the one under it shows beside it.
    assert!(paper[0] > tracking[0] && tracking[0] > kanayama[0]);
    // Solid: the path, the error and a sample in each panel's legend. Dashed: hundreds
    // of dashes.
    assert!(count(RED) <= 4, "{}", count(RED));
    assert!(count(GREEN) <= 4, "{}", count(GREEN));
    assert!(count(BLUE) > 100, "{}", count(BLUE));
}

/// The paper's law trails its reference along the circle, where its line lies on the
/// reference path: every law's robot is marked every 2 s and joined to the reference
/// point of that instant. Only the start was marked.
#[test]
fn compare_marks_every_robot_against_its_reference_point() {
    let svg = paper_circle_comparison(&out_dir("compare-lag"));
    let dots = |colour: &str| {
        svg.split("<circle")
            .filter(|c| c.contains(&format!("fill=\"{colour}\"")))
            .count()
    };
    // 30 s every 2 s: 15 dots, the start marker, the legend's (grey) aside.
    for colour in [RED, BLUE, GREEN] {
        assert!(dots(colour) >= 15, "{colour}: {} dots", dots(colour));
    }
    // The links: 2-point black lines; the paper law's, once it has settled 0.25 m behind,
    // are long (at this scale, 0.25 m is over 60 px), the others' collapse to a point.
    let links: Vec<f64> = polylines(&svg)
        .into_iter()
        .filter(|l| l.stroke == "#000000" && l.width == 1 && l.points.len() == 2)
        .map(|l| {
            let [(x0, y0), (x1, y1)] = [l.points[0], l.points[1]];
            f64::from(x1 - x0).hypot(f64::from(y1 - y0))
        })
        .collect();
    let long = links.iter().filter(|&&d| d > 50.0).count();
    assert!(long >= 12, "{long} long links of {}", links.len());
}

/// Fig. 6 of the paper's law on the circle: y_e settles at +0.025 m, above the axis' top
/// tick (0) before; every panel's ticks now enclose its data.
#[test]
fn fig6_axes_contain_their_data() {
    let dir = out_dir("fig6");
    let s = Scenario::load("paper-circle").unwrap();
    let r = run(&s, LawKind::Paper);
    let file = dir.join("fig6.svg");
    fig6_errors(&file, "t", &r.trace, None).unwrap();
    let svg = std::fs::read_to_string(file).unwrap();
    // Three panels in 800 px.
    for (panel, rows) in [0..267, 267..534, 534..800].into_iter().enumerate() {
        let ticks: Vec<f64> = y_ticks(&svg, rows).into_iter().map(|(_, v)| v).collect();
        let data: Vec<f64> = r.trace.iter().map(|row| row.true_tracking[panel]).collect();
        let (lo, hi) = (
            data.iter().copied().fold(f64::MAX, f64::min),
            data.iter().copied().fold(f64::MIN, f64::max),
        );
        let (first, last) = (
            ticks.iter().copied().fold(f64::MAX, f64::min),
            ticks.iter().copied().fold(f64::MIN, f64::max),
        );
        assert!(
            first <= lo && hi <= last,
            "panel {panel}: data {lo}…{hi}, ticks {ticks:?}"
        );
    }
    // The y_e of the paper law ends positive: above zero, below the top tick.
    assert!(r.trace.last().unwrap().true_tracking[1] > 0.02);
}

/// No axis of any figure of the paper's experiments is labelled `-0.0` (zero is `0`).
#[test]
fn no_axis_is_labelled_minus_zero() {
    let dir = out_dir("zero");
    let mut zeros = 0;
    for name in ["paper-circle", "paper-line"] {
        let s = Scenario::load(name).unwrap();
        for law in LawKind::ALL {
            let r = run(&s, law);
            let settle = r.summary.headline_error().settle_time_s;
            let files = [
                dir.join(&format!("{name}-{}-5.svg", law.name())),
                dir.join(&format!("{name}-{}-6.svg", law.name())),
                dir.join(&format!("{name}-{}-7.svg", law.name())),
            ];
            fig5_path(&files[0], "t", &s.path, &r.trace).unwrap();
            fig6_errors(&files[1], "t", &r.trace, settle).unwrap();
            fig7_inputs(&files[2], "t", &r.trace, settle).unwrap();
            for file in files {
                let svg = std::fs::read_to_string(&file).unwrap();
                for t in texts(&svg) {
                    assert!(
                        !(t.text.starts_with("-0") && t.text.parse::<f64>() == Ok(0.0)),
                        "{}: label {:?}",
                        file.display(),
                        t.text
                    );
                    zeros += usize::from(t.text == "0");
                }
            }
        }
    }
    assert!(zeros > 0, "no zero label at all");
}

/// The line experiment's manoeuvre is 0.5 m across (from y = −0.5 m onto y = 0) on a
/// 10 m path: the path panel's y axis spans under 1 m (it spanned 5 m at equal scale),
/// and says it is stretched; the x axis still covers the path.
#[test]
fn the_line_experiments_path_panel_fits_its_data() {
    let dir = out_dir("line");
    let s = Scenario::load("paper-line").unwrap();
    let r = run(&s, LawKind::Paper);
    let file = dir.join("fig5.svg");
    fig5_path(&file, "t", &s.path, &r.trace).unwrap();
    let svg = std::fs::read_to_string(file).unwrap();
    let y: Vec<f64> = y_ticks(&svg, 0..10_000)
        .into_iter()
        .map(|(_, v)| v)
        .collect();
    let x = x_ticks(&svg, 0..10_000);
    assert!(span(&y) >= 0.5 && span(&y) < 1.0, "y ticks {y:?}");
    assert!(span(&x) >= 10.0, "x ticks {x:?}");
    assert!(svg.contains("y (m, scale ×"), "the stretch is not stated");
}

/// Fig. 7: the commanded v is dashed in its own (darker) colour and drawn over the true
/// v, which is solid; they differed only in width, the command under the truth.
#[test]
fn fig7_tells_command_from_truth_by_dash_and_colour() {
    let dir = out_dir("fig7");
    let s = Scenario::load("paper-line").unwrap();
    let r = run(&s, LawKind::Paper);
    let file = dir.join("fig7.svg");
    fig7_inputs(&file, "t", &r.trace, None).unwrap();
    let svg = std::fs::read_to_string(file).unwrap();
    let lines = polylines(&svg);
    let truth: Vec<usize> = (0..lines.len())
        .filter(|&i| lines[i].stroke == BLUE)
        .collect();
    let command: Vec<usize> = (0..lines.len())
        .filter(|&i| lines[i].stroke == DARK_BLUE)
        .collect();
    // The truth: one line in the panel and the legend's sample.
    assert!(!truth.is_empty() && truth.len() <= 2, "{truth:?}");
    // The command: dashed, and after (over) the truth.
    assert!(command.len() > 50, "{} command polylines", command.len());
    assert!(command[0] > truth[0]);
}
