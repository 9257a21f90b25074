//! Step 2: the button and the LED. A long press while disarmed is the pose command (the
//! robot says so with `PoseSet`), so pressing it moves nothing; the LED blinks once a
//! second while disarmed, which only the user can see.

use controller_core::supervisor::Event;

use super::signals::{wait_event, Heard};
use super::{BringupError, Finding, Session};
use crate::transport::Transport;

/// Control steps the station waits for the press's event after `done`.
const PRESS_WAIT_STEPS: u32 = 2000;

/// Runs the step.
pub fn run<T: Transport>(s: &mut Session<'_, T>) -> Result<Finding, BringupError> {
    let mut heard = Heard::default();
    s.answers.until_done(
        s.out,
        "press the robot's button and hold it for two seconds (a long press), then release it",
    )?;
    let pose_set = wait_event(s.client, PRESS_WAIT_STEPS, &mut heard, |e| {
        *e == Event::PoseSet
    })?;
    if pose_set.is_none() {
        return Err(BringupError::Found(format!(
            "the robot saw no long press (it reported {:?}): check the button's wiring (it \
             pulls the input low when pressed) and hold it for two seconds",
            heard.events
        )));
    }
    let blinks = s
        .answers
        .yes_no(s.out, "does the robot's LED blink briefly once a second?")?;
    if !blinks {
        return Err(BringupError::Found(
            "the LED does not blink as it should while disarmed: check the LED's pin and \
             its polarity"
                .into(),
        ));
    }
    Ok(Finding::only(
        "the button works (a long press set the pose) and the LED blinks",
    ))
}
