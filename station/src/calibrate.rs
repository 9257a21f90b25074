//! UMBmark odometry calibration (Borenstein & Feng 1996), for paths with filleted
//! corners.
//!
//! # Procedure
//!
//! 1. The robot drives an L × L square (default 2 m) `n` times clockwise and `n` times
//!    counter-clockwise by odometry, from the same start, with the core's own path
//!    following. After each run the station asks for the true end point (and, if known,
//!    the heading) measured on the floor, or reads them from a file; the virtual robot's
//!    are its true end pose plus a stated measurement noise.
//! 2. The end errors ε = true − odometry give the wheel-diameter ratio E_d = R_right/R_left
//!    and the track-width factor E_b = L_true/L_believed (see below).
//! 3. The corrected geometry is sent; then a straight run against a tape gives the common
//!    scale of both radii (a square cannot see it); then everything is persisted.
//!
//! # The formulas, for filleted corners
//!
//! UMBmark's closed form assumes turns on the spot. The core's paths round each corner
//! with a fillet, so the error is fitted against a kinematic model instead (the
//! derivation that holds for any path): along the commanded path (odometry follows it),
//! every length ds with curvature κ asks the wheels for ds·(1 ∓ κ·L/2) of believed
//! travel; the true robot's wheels travel that times (1 ∓ d/2) (E_d = (1 + d/2)/(1 − d/2),
//! mean radius kept), and it turns by the difference over the true track L·E_b. The
//! predicted true end point minus the path's end, over all runs, is fitted to the
//! measured errors by Gauss–Newton in (d, E_b). With sharp corners and small errors the
//! model reduces to UMBmark's closed form, which is printed beside it as a cross-check
//! (α = (x_cw + x_ccw)/(−4L), β = (x_cw − x_ccw)/(−4L) in the frame of the start), as is
//! Jung & Chung's heading-based E_b when headings are measured. That one holds for any
//! corners: the odometry turned Θ (the path's arcs' sweeps, ±3π/2 for these squares of
//! three corners) along a length S, the robot truly turned (Θ + S·d/L)/E_b, so the
//! heading errors' difference θ_cw − θ_ccw = (Θ_cw − Θ_ccw)·(1/E_b − 1) gives E_b
//! whatever d. It is exact under the model the fit uses, and agrees with the fit to the
//! measurement noise.

use std::io::{BufRead, Write};
use std::sync::atomic::AtomicBool;

use controller_core::kinematics::{Point, Pose};
use controller_core::law::LawKind;
use controller_core::path::{Path, Segment};
use controller_core::reference::ReferenceMode;
use link::ParamSet;
use robot_files::rng::Rng;
use robot_files::scenario::Scenario;
use robot_files::truth::wrap_angle;

use crate::client::{Client, StationError};
use crate::record::{self, RunPlan};
use crate::transport::Transport;

/// `station calibrate`'s options.
#[derive(Clone, Debug, clap::Args)]
pub struct CalibrateArgs {
    /// Side of the square, m.
    #[arg(long, default_value_t = 2.0)]
    pub side_m: f64,
    /// Runs in each direction.
    #[arg(long, default_value_t = 5)]
    pub runs: u32,
    /// Length of the straight run for the common scale, m.
    #[arg(long, default_value_t = 2.0)]
    pub straight_m: f64,
    /// Read the measured end points from this file instead of asking: one line per run,
    /// `x_m y_m [theta_deg]`, in the order the runs are made (squares clockwise, then
    /// counter-clockwise, then the straight run's measured distance alone on its line).
    #[arg(long)]
    pub measurements: Option<std::path::PathBuf>,
    /// Against the virtual robot: take the end points from its ground truth, with this
    /// measurement noise (m, 1σ per coordinate; the tape's for the straight run).
    #[arg(long)]
    pub simulated_noise_m: Option<f64>,
    /// Send the corrected geometry but do not persist it.
    #[arg(long)]
    pub no_persist: bool,
}

/// Reference speed of the calibration runs, m/s (slow: the square's corners and the
/// start are gentle).
pub const SPEED_M_S: f32 = 0.25;
/// Fillet radius of the square's corners, m.
pub const CORNER_RADIUS_M: f32 = 0.1;
/// Time given to settle at the end of a run, s.
pub const SETTLE_S: f64 = 4.0;
/// The path ends this far before the start, so it is open and the reference stops, m.
pub const END_GAP_M: f32 = 0.05;

/// The UMBmark square of side `side_m` (m), starting at the origin heading +x, turning
/// left (counter-clockwise) or right, with filleted corners, ending `END_GAP_M` short of
/// the start; as a scenario on `base`'s robot.
pub fn square(base: &Scenario, side_m: f64, clockwise: bool) -> Result<Scenario, String> {
    let l = side_m as f32;
    let sign = if clockwise { -1.0 } else { 1.0 };
    let points = [
        Point::new(0.0, 0.0),
        Point::new(l, 0.0),
        Point::new(l, sign * l),
        Point::new(0.0, sign * l),
        Point::new(0.0, sign * END_GAP_M),
    ];
    let path = Path::polyline(&points, CORNER_RADIUS_M, false).map_err(|e| format!("{e:?}"))?;
    Ok(on_path(
        base,
        path,
        if clockwise {
            "umbmark-cw"
        } else {
            "umbmark-ccw"
        },
    ))
}

/// The straight run of `length_m` (m) along +x from the origin.
pub fn straight(base: &Scenario, length_m: f64) -> Result<Scenario, String> {
    let path =
        Path::line(Point::new(0.0, 0.0), 0.0, length_m as f32).map_err(|e| format!("{e:?}"))?;
    Ok(on_path(base, path, "umbmark-straight"))
}

fn on_path(base: &Scenario, path: Path, name: &str) -> Scenario {
    let mut s = base.clone();
    s.name = name.to_string();
    s.duration_s = f64::from(path.length_m() / SPEED_M_S) + SETTLE_S;
    s.path = path;
    s.reference_speed_m_s = SPEED_M_S;
    s.reference_mode = ReferenceMode::TimeIndexed {
        start_offset_m: 0.0,
    };
    s.start.x_m = 0.0;
    s.start.y_m = 0.0;
    s.start.theta_rad = 0.0;
    s.start.v_m_s = 0.0;
    s.start.omega_rad_s = 0.0;
    s.faults.clear();
    s
}

/// One run's end: the odometry's end pose and the measured true one (world frame, m and
/// rad; the heading may be unknown).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct EndPoint {
    /// Where the odometry ended.
    pub odometry: Pose,
    /// Where the robot truly ended (x, y in m).
    pub true_xy: (f64, f64),
    /// Its true heading, rad, if measured.
    pub true_heading: Option<f64>,
}

impl EndPoint {
    /// ε = true − odometry, m.
    pub fn error(&self) -> (f64, f64) {
        (
            self.true_xy.0 - f64::from(self.odometry.x_m),
            self.true_xy.1 - f64::from(self.odometry.y_m),
        )
    }
}

/// The true end point predicted for a robot that follows `path` exactly by odometry
/// (believed track `track_m`), whose true wheels travel (1 − d/2) and (1 + d/2) times
/// what they believe and whose true track is `track_m · e_b`: (x, y, θ) minus the
/// path's end, m and rad. Integrated segment by segment (each of constant curvature) in
/// steps of at most 2 mm, so the believed turn is the path's own.
pub fn predicted_error(path: &Path, track_m: f64, d: f64, e_b: f64) -> (f64, f64, f64) {
    let start = path.sample(0.0);
    let (mut x, mut y, mut th) = (
        f64::from(start.point.x_m),
        f64::from(start.point.y_m),
        f64::from(start.heading_rad),
    );
    for segment in path.segments() {
        let length = f64::from(segment.length_m());
        let kappa = f64::from(segment.sample(segment.length_m() / 2.0).curvature_per_m);
        let steps = (length / 0.002).ceil().max(1.0) as usize;
        let ds = length / steps as f64;
        let left = ds * (1.0 - kappa * track_m / 2.0) * (1.0 - d / 2.0);
        let right = ds * (1.0 + kappa * track_m / 2.0) * (1.0 + d / 2.0);
        let dist = (left + right) / 2.0;
        let dth = (right - left) / (track_m * e_b);
        for _ in 0..steps {
            let mid = th + dth / 2.0;
            x += dist * mid.cos();
            y += dist * mid.sin();
            th += dth;
        }
    }
    let end = path.sample(path.length_m());
    (
        x - f64::from(end.point.x_m),
        y - f64::from(end.point.y_m),
        wrap_angle(th - f64::from(end.heading_rad)),
    )
}

/// The total turn of `path`, rad (+ counter-clockwise): the sum of its arcs' sweeps.
pub fn total_turn(path: &Path) -> f64 {
    path.segments()
        .iter()
        .map(|segment| match segment {
            Segment::Arc { sweep_rad, .. } => f64::from(*sweep_rad),
            Segment::Line { .. } => 0.0,
        })
        .sum()
}

/// What the squares say about the geometry.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Estimate {
    /// E_d = R_right/R_left (true), fitted for the filleted square.
    pub e_d: f64,
    /// E_b = L_true/L_believed, fitted for the filleted square.
    pub e_b: f64,
    /// UMBmark's closed form (turns on the spot), for comparison: (E_d, E_b).
    pub closed_form: (f64, f64),
    /// Jung & Chung's heading-based E_b, when headings were measured: ΔΘ/(ΔΘ − Δθ), ΔΘ
    /// the paths' turns' difference (ccw − cw), Δθ the mean heading errors' (cw − ccw).
    pub jung_chung_e_b: Option<f64>,
    /// Centroids of the end errors, clockwise and counter-clockwise, m.
    pub centroids: [(f64, f64); 2],
    /// UMBmark's benchmark E_max,syst, m.
    pub e_max_syst_m: f64,
}

/// Fits E_d and E_b to the measured end points of the clockwise (`cw`) and
/// counter-clockwise (`ccw`) runs on `paths` ([cw, ccw]), believed track `track_m`.
pub fn estimate(
    paths: [&Path; 2],
    cw: &[EndPoint],
    ccw: &[EndPoint],
    track_m: f64,
    side_m: f64,
) -> Estimate {
    let centroid = |runs: &[EndPoint]| {
        let n = runs.len().max(1) as f64;
        let (sx, sy) = runs
            .iter()
            .map(EndPoint::error)
            .fold((0.0, 0.0), |a, e| (a.0 + e.0, a.1 + e.1));
        (sx / n, sy / n)
    };
    let c = [centroid(cw), centroid(ccw)];
    // Gauss–Newton on (d, e_b) against the four centroid coordinates.
    let (mut d, mut e_b) = (0.0, 1.0);
    let model = |d: f64, e_b: f64| {
        let a = predicted_error(paths[0], track_m, d, e_b);
        let b = predicted_error(paths[1], track_m, d, e_b);
        [a.0, a.1, b.0, b.1]
    };
    let measured = [c[0].0, c[0].1, c[1].0, c[1].1];
    for _ in 0..8 {
        let m0 = model(d, e_b);
        let (hd, hb) = (1e-5, 1e-5);
        let md = model(d + hd, e_b);
        let mb = model(d, e_b + hb);
        let (mut a11, mut a12, mut a22, mut g1, mut g2) = (0.0, 0.0, 0.0, 0.0, 0.0);
        for i in 0..4 {
            let jd = (md[i] - m0[i]) / hd;
            let jb = (mb[i] - m0[i]) / hb;
            let r = measured[i] - m0[i];
            a11 += jd * jd;
            a12 += jd * jb;
            a22 += jb * jb;
            g1 += jd * r;
            g2 += jb * r;
        }
        let det = a11 * a22 - a12 * a12;
        if det.abs() < 1e-18 {
            break;
        }
        d += (a22 * g1 - a12 * g2) / det;
        e_b += (a11 * g2 - a12 * g1) / det;
    }
    // UMBmark's closed form, in this start frame (x along the first side).
    let l = side_m;
    let alpha = (c[0].0 + c[1].0) / (-4.0 * l);
    let beta = (c[0].0 - c[1].0) / (-4.0 * l);
    let closed_e_d = if beta.abs() < 1e-12 {
        1.0
    } else {
        let r = (l / 2.0) / (beta / 2.0).sin();
        (r + track_m / 2.0) / (r - track_m / 2.0)
    };
    let closed_e_b = (std::f64::consts::FRAC_PI_2) / (std::f64::consts::FRAC_PI_2 - alpha);
    // Jung & Chung: mean heading errors per direction.
    let heading = |runs: &[EndPoint]| -> Option<f64> {
        let v: Option<Vec<f64>> = runs
            .iter()
            .map(|r| {
                r.true_heading
                    .map(|h| wrap_angle(h - f64::from(r.odometry.theta_rad)))
            })
            .collect();
        v.filter(|v| !v.is_empty())
            .map(|v| v.iter().sum::<f64>() / v.len() as f64)
    };
    // Jung & Chung, from the headings: a robot whose odometry turned Θ along a path of
    // length S truly turned (Θ + S·d/L)/E_b, so its heading error (true − odometry) is
    // Θ·(1/E_b − 1) + S·d/(L·E_b). The two squares are equally long and turn opposite
    // ways, so θ_cw − θ_ccw = (Θ_cw − Θ_ccw)·(1/E_b − 1) whatever d, and
    // E_b = ΔΘ/(ΔΘ − Δθ), ΔΘ = Θ_ccw − Θ_cw, Δθ = θ_cw − θ_ccw. With UMBmark's four
    // turns on the spot (ΔΘ = 4π) this is Jung & Chung's (π/2)/(π/2 − Δθ/8); the squares
    // here turn three filleted corners each (ΔΘ = 3π).
    let turned = total_turn(paths[1]) - total_turn(paths[0]);
    let jung_chung_e_b = match (heading(cw), heading(ccw)) {
        (Some(t_cw), Some(t_ccw)) if turned.abs() > 1e-9 => {
            Some(turned / (turned - (t_cw - t_ccw)))
        }
        _ => None,
    };
    Estimate {
        e_d: (1.0 + d / 2.0) / (1.0 - d / 2.0),
        e_b,
        closed_form: (closed_e_d, closed_e_b),
        jung_chung_e_b,
        centroids: c,
        e_max_syst_m: c[0].0.hypot(c[0].1).max(c[1].0.hypot(c[1].1)),
    }
}

/// `set` with the geometry corrected by `estimate` (mean radius kept), and the common
/// `scale` of both radii. A square measures the turn, (d_R − d_L)/L, so a common scale
/// error k of the radii looks like a track of L/k: the track is scaled with the radii.
pub fn corrected(set: &ParamSet, estimate: &Estimate, scale: f64) -> ParamSet {
    let mut out = *set;
    let r = &mut out.robot;
    let (left, right) = (
        f64::from(r.wheel_radius_left_m),
        f64::from(r.wheel_radius_right_m),
    );
    // True wheel travel per believed travel: left (1 − d/2), right (1 + d/2).
    let d = 2.0 * (estimate.e_d - 1.0) / (estimate.e_d + 1.0);
    r.wheel_radius_left_m = (left * (1.0 - d / 2.0) * scale) as f32;
    r.wheel_radius_right_m = (right * (1.0 + d / 2.0) * scale) as f32;
    r.track_width_m = (f64::from(r.track_width_m) * estimate.e_b * scale) as f32;
    out
}

/// Where the end points come from.
pub enum Measure<'a> {
    /// Asked of the operator, a question at a time: the function shows the question and
    /// returns the line they answer (the terminal, or a bring-up's answers).
    Asked(&'a mut dyn FnMut(&str) -> Result<String, String>),
    /// Lines of a file, one per run, read without waiting.
    File(std::vec::IntoIter<String>),
    /// The virtual robot's ground truth plus Gaussian noise of this σ (m; heading 0.2°).
    Simulated {
        /// 1σ per coordinate, m.
        noise_m: f64,
        /// The noise's source.
        rng: &'a mut Rng,
    },
}

impl Measure<'_> {
    /// Gives the operator `instruction` (where to put the robot) and waits until they
    /// say it is done; at once for a file or the virtual robot, whose path upload places
    /// it.
    fn ready(&mut self, instruction: &str) -> Result<(), String> {
        if let Measure::Asked(ask) = self {
            ask(&format!("{instruction}, then press Enter"))?;
        }
        Ok(())
    }

    /// The measured end of a run whose odometry ended at `odometry` (the truth is the
    /// virtual robot's).
    fn end_point(
        &mut self,
        odometry: Pose,
        truth: Option<Pose>,
        label: &str,
    ) -> Result<EndPoint, String> {
        match self {
            Measure::Simulated { noise_m, rng } => {
                let t =
                    truth.ok_or("no ground truth: --simulated-noise-m needs the virtual robot")?;
                Ok(EndPoint {
                    odometry,
                    true_xy: (
                        f64::from(t.x_m) + *noise_m * rng.normal(),
                        f64::from(t.y_m) + *noise_m * rng.normal(),
                    ),
                    true_heading: Some(f64::from(t.theta_rad) + 0.2f64.to_radians() * rng.normal()),
                })
            }
            Measure::File(lines) => {
                let line = lines
                    .next()
                    .ok_or(format!("the measurements file has no line for {label}"))?;
                parse_end(&line, odometry, label)
            }
            Measure::Asked(ask) => {
                let line = ask(&format!(
                    "{label}: odometry ended at x {:+.4} m, y {:+.4} m. Measured true end \
`x_m y_m [theta_deg]` (start frame)",
                    odometry.x_m, odometry.y_m
                ))?;
                parse_end(&line, odometry, label)
            }
        }
    }

    /// The tape's distance of the straight run, m, whose odometry says `odo_m`.
    fn tape_m(&mut self, odo_m: f64, truth: Option<Pose>) -> Result<f64, String> {
        match self {
            Measure::Simulated { noise_m, rng } => {
                let t = truth.ok_or("no ground truth")?;
                Ok(f64::from(t.x_m).hypot(f64::from(t.y_m)) + *noise_m * rng.normal())
            }
            Measure::File(lines) => lines
                .next()
                .and_then(|l| l.trim().parse().ok())
                .ok_or_else(|| "the measurements file has no distance for the straight run".into()),
            Measure::Asked(ask) => {
                let line = ask(&format!(
                    "straight run: odometry says {odo_m:.4} m. Distance on the tape, m"
                ))?;
                let first = line.split_whitespace().next().unwrap_or_default();
                first
                    .trim_end_matches('m')
                    .parse()
                    .map_err(|_| format!("not a distance: `{}`", line.trim()))
            }
        }
    }
}

/// Asks on the terminal: the question on standard error, the answer from standard input.
pub fn ask_on_terminal(question: &str) -> Result<String, String> {
    eprint!("{question}: ");
    let _ = std::io::stderr().flush();
    let mut line = String::new();
    std::io::stdin()
        .lock()
        .read_line(&mut line)
        .map_err(|e| e.to_string())?;
    Ok(line)
}

fn parse_end(line: &str, odometry: Pose, label: &str) -> Result<EndPoint, String> {
    let values: Result<Vec<f64>, _> = line.split_whitespace().map(str::parse::<f64>).collect();
    match values.as_deref() {
        Ok([x, y]) => Ok(EndPoint {
            odometry,
            true_xy: (*x, *y),
            true_heading: None,
        }),
        Ok([x, y, t]) => Ok(EndPoint {
            odometry,
            true_xy: (*x, *y),
            true_heading: Some(t.to_radians()),
        }),
        _ => Err(format!(
            "{label}: expected `x_m y_m [theta_deg]`, got `{}`",
            line.trim()
        )),
    }
}

/// What a calibration found and set.
#[derive(Clone, Copy, Debug)]
pub struct Outcome {
    /// From the squares.
    pub estimate: Estimate,
    /// Common scale from the straight run (true / odometry distance).
    pub scale: f64,
    /// The configuration before.
    pub before: ParamSet,
    /// The configuration set.
    pub after: ParamSet,
}

/// Why a calibration stopped. Nothing is persisted then, and the robot is given back
/// the configuration it had before (if the link still works).
#[derive(Debug, thiserror::Error)]
pub enum CalibrateError {
    /// A run did not end at its time limit, nor when driven once more.
    #[error(
        "calibration stopped: {run} did not end at its time limit (it ended by {first}), nor \
when driven again ({again}); nothing was persisted"
    )]
    RunCutShort {
        /// The run (`clockwise square 2/5`, `straight run`).
        run: String,
        /// What ended it the first time.
        first: String,
        /// What ended it the second time, or why it could not be driven again.
        again: String,
    },
    /// Anything else: the link, a measurement, the paths.
    #[error("calibration stopped: {0}; nothing was persisted")]
    Failed(String),
}

impl From<String> for CalibrateError {
    fn from(text: String) -> Self {
        CalibrateError::Failed(text)
    }
}

impl From<&str> for CalibrateError {
    fn from(text: &str) -> Self {
        CalibrateError::Failed(text.to_string())
    }
}

impl From<StationError> for CalibrateError {
    fn from(e: StationError) -> Self {
        CalibrateError::Failed(crate::error_text(&e))
    }
}

/// The whole procedure (module doc) on `client`'s robot, whose scenario-side settings
/// (plant, supervisor) come from `base`. `say` gets progress lines.
///
/// Every run must end at its time limit (the robot's `Disarmed(Timeout)`): a run that
/// ended otherwise (the heartbeat timeout, a fault, the button, a link failure) is driven
/// once more, and if that one does not end at its limit either, the calibration stops
/// with [`CalibrateError::RunCutShort`]. The end point of a run is measured only once
/// the run ended as asked, so a measurements file has one line per run whatever was
/// repeated. On any error nothing is persisted and the robot gets its configuration
/// from before the calibration back.
pub fn calibrate<T: Transport>(
    client: &mut Client<T>,
    base: &Scenario,
    args: &CalibrateArgs,
    measure: &mut Measure<'_>,
    say: &mut dyn FnMut(&str),
) -> Result<Outcome, CalibrateError> {
    let before = crate::ops::get_params(client)?;
    let outcome = procedure(client, base, args, measure, say, &before);
    if outcome.is_err() {
        // Best effort: the link may be what failed.
        if crate::ops::get_params(client).is_ok_and(|now| now != before) {
            let _ = crate::ops::set_params(client, before);
        }
    }
    outcome
}

fn procedure<T: Transport>(
    client: &mut Client<T>,
    base: &Scenario,
    args: &CalibrateArgs,
    measure: &mut Measure<'_>,
    say: &mut dyn FnMut(&str),
    before: &ParamSet,
) -> Result<Outcome, CalibrateError> {
    let cw_path = square(base, args.side_m, true)?;
    let ccw_path = square(base, args.side_m, false)?;
    let (mut cw, mut ccw) = (Vec::new(), Vec::new());
    for (scenario, ends, name) in [
        (&cw_path, &mut cw, "clockwise"),
        (&ccw_path, &mut ccw, "counter-clockwise"),
    ] {
        for i in 0..args.runs {
            let label = format!("{name} square {}/{}", i + 1, args.runs);
            measure.ready(&format!(
                "{label}: put the robot at the start mark, heading along the first side"
            ))?;
            let (odometry, truth) = drive(client, scenario, &label, measure, say)?;
            let end = measure.end_point(odometry, truth, &label)?;
            let (ex, ey) = end.error();
            say(&format!("{label}: end error ε = ({ex:+.4}, {ey:+.4}) m"));
            ends.push(end);
        }
    }
    let estimate = estimate(
        [&cw_path.path, &ccw_path.path],
        &cw,
        &ccw,
        f64::from(before.robot.track_width_m),
        args.side_m,
    );
    let geometry = corrected(before, &estimate, 1.0);
    crate::ops::set_params(client, geometry)?;
    // The straight run against the tape, with the corrected ratio and track.
    let line = straight(base, args.straight_m)?;
    measure.ready("straight run: put the robot at the tape's zero, heading along it")?;
    let (odometry, truth) = drive(client, &line, "straight run", measure, say)?;
    let odo_m = f64::from(odometry.x_m).hypot(f64::from(odometry.y_m));
    let tape_m = measure.tape_m(odo_m, truth)?;
    let scale = if odo_m > 0.0 { tape_m / odo_m } else { 1.0 };
    let after = corrected(before, &estimate, scale);
    crate::ops::set_params(client, after)?;
    if !args.no_persist {
        crate::ops::persist_params(client)?;
    }
    Ok(Outcome {
        estimate,
        scale,
        before: *before,
        after,
    })
}

/// Drives `scenario` (the run `label`); if it does not end at its time limit, says why
/// and drives it once more. Returns the odometry's and the true end pose of the run
/// that ended at its limit.
fn drive<T: Transport>(
    client: &mut Client<T>,
    scenario: &Scenario,
    label: &str,
    measure: &mut Measure<'_>,
    say: &mut dyn FnMut(&str),
) -> Result<(Pose, Option<Pose>), CalibrateError> {
    let interrupt = AtomicBool::new(false);
    let mut first: Option<String> = None;
    loop {
        if let Some(why) = &first {
            say(&format!(
                "{label}: the run ended by {why}, not at its time limit; driving it again \
from the start"
            ));
            measure.ready(&format!("{label}: put the robot back at its start"))?;
        }
        let mut progress = |_: u64, _: u64| {};
        let recorded = record::run(
            client,
            &mut RunPlan {
                scenario,
                law: LawKind::Tracking,
                telemetry_hz: 10,
                interrupt: &interrupt,
                progress: &mut progress,
            },
        );
        let again = match (recorded, &first) {
            (Ok(rec), _) if rec.ended_by.is_time_limit() => {
                let odometry = rec
                    .final_estimate
                    .ok_or(format!("{label}: no telemetry from the run"))?;
                return Ok((odometry, rec.final_truth));
            }
            (Ok(rec), None) => {
                first = Some(rec.ended_by.to_string());
                continue;
            }
            (Err(e), None) => return Err(e.into()),
            (Ok(rec), Some(_)) => format!("it ended by {}", rec.ended_by),
            (Err(e), Some(_)) => format!("it could not be driven: {}", crate::error_text(&e)),
        };
        return Err(CalibrateError::RunCutShort {
            run: label.to_string(),
            first: first.unwrap_or_default(),
            again,
        });
    }
}

/// The before/after table of an outcome, for the terminal.
pub fn table(o: &Outcome) -> String {
    let (b, a) = (&o.before.robot, &o.after.robot);
    let e = &o.estimate;
    let mut t = String::new();
    t += &format!(
        "end-error centroids: clockwise ({:+.4}, {:+.4}) m, counter-clockwise ({:+.4}, {:+.4}) m; E_max,syst {:.4} m\n",
        e.centroids[0].0, e.centroids[0].1, e.centroids[1].0, e.centroids[1].1, e.e_max_syst_m
    );
    t += &format!(
        "E_d = R_right/R_left {:.5} (UMBmark closed form {:.5}); E_b {:.5} (closed form {:.5}{}); common scale {:.5}\n",
        e.e_d,
        e.closed_form.0,
        e.e_b,
        e.closed_form.1,
        e.jung_chung_e_b.map_or(String::new(), |j| format!(", Jung & Chung {j:.5}")),
        o.scale
    );
    t += "            before        after\n";
    t += &format!(
        "R_left   {:.6} m  {:.6} m\n",
        b.wheel_radius_left_m, a.wheel_radius_left_m
    );
    t += &format!(
        "R_right  {:.6} m  {:.6} m\n",
        b.wheel_radius_right_m, a.wheel_radius_right_m
    );
    t += &format!(
        "L        {:.6} m  {:.6} m\n",
        b.track_width_m, a.track_width_m
    );
    t
}

/// `station calibrate`.
pub fn command<T: Transport>(
    client: anyhow::Result<Client<T>>,
    args: &CalibrateArgs,
) -> anyhow::Result<()> {
    let mut client = client?;
    let base = Scenario::load("square-waypoints")?;
    let mut rng = Rng::new(1);
    let mut measure = match (&args.measurements, args.simulated_noise_m) {
        (Some(file), _) => Measure::File(
            std::fs::read_to_string(file)?
                .lines()
                .filter(|l| !l.trim().is_empty() && !l.trim_start().starts_with('#'))
                .map(str::to_string)
                .collect::<Vec<_>>()
                .into_iter(),
        ),
        (None, Some(noise_m)) => Measure::Simulated {
            noise_m,
            rng: &mut rng,
        },
        (None, None) => Measure::Asked(&mut ask_on_terminal),
    };
    let mut say = |line: &str| eprintln!("{line}");
    let outcome = match calibrate(&mut client, &base, args, &mut measure, &mut say) {
        Ok(outcome) => outcome,
        Err(e @ CalibrateError::RunCutShort { .. }) => {
            return Err(crate::NotAsAsked(e.to_string()).into())
        }
        Err(e) => return Err(e.into()),
    };
    print!("{}", table(&outcome));
    println!(
        "{}",
        if args.no_persist {
            "sent (not persisted)"
        } else {
            "sent and persisted"
        }
    );
    Ok(())
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_heading_cross_check_agrees_with_the_fit_without_noise() {
        let base = Scenario::load("square-waypoints").expect("built in");
        let track = f64::from(base.robot.track_width_m);
        let cw = square(&base, 2.0, true).expect("a square");
        let ccw = square(&base, 2.0, false).expect("a square");
        for (d, e_b) in [(0.005, 1.0175), (-0.01, 0.97), (0.0, 1.03), (0.002, 1.0)] {
            // The robot follows each path exactly by odometry and ends where the model
            // says, its heading measured exactly.
            let end = |path: &Path| {
                let (ex, ey, eth) = predicted_error(path, track, d, e_b);
                let end = path.sample(path.length_m());
                EndPoint {
                    odometry: Pose::new(end.point.x_m, end.point.y_m, end.heading_rad),
                    true_xy: (f64::from(end.point.x_m) + ex, f64::from(end.point.y_m) + ey),
                    true_heading: Some(f64::from(end.heading_rad) + eth),
                }
            };
            let e = estimate(
                [&cw.path, &ccw.path],
                &[end(&cw.path)],
                &[end(&ccw.path)],
                track,
                2.0,
            );
            let jc = e.jung_chung_e_b.expect("headings measured");
            println!("d {d} E_b {e_b}: fit {:.6}, Jung & Chung {jc:.6}", e.e_b);
            assert!((e.e_b / e_b - 1.0).abs() < 1e-5, "fit {} for {e_b}", e.e_b);
            assert!((jc / e_b - 1.0).abs() < 1e-4, "Jung & Chung {jc} for {e_b}");
        }
    }
}
