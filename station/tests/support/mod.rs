//! Test support: the virtual robot (`host-sim`'s) in the test's own process, behind the
//! station's [`Transport`], in lockstep.

use std::io;
use std::time::Duration;

use host_sim::serve::VirtualRobot;
use station::transport::Transport;

/// The virtual robot in this process, in lockstep: every `receive` runs it for one
/// control period, so a run's outcome does not depend on the host's speed.
pub struct InProcess<'r, 'a> {
    robot: &'r mut VirtualRobot<'a>,
}

impl<'r, 'a> InProcess<'r, 'a> {
    /// A pipe to `robot`.
    pub fn new(robot: &'r mut VirtualRobot<'a>) -> Self {
        Self { robot }
    }
}

impl Transport for InProcess<'_, '_> {
    fn send(&mut self, bytes: &[u8]) -> io::Result<()> {
        self.robot.receive(bytes);
        Ok(())
    }

    fn receive(&mut self, buf: &mut [u8], _timeout: Duration) -> io::Result<usize> {
        if self.robot.outgoing().is_empty() {
            self.robot.step();
        }
        let n = self.robot.outgoing().len().min(buf.len());
        buf[..n].copy_from_slice(&self.robot.outgoing()[..n]);
        self.robot.consume(n);
        Ok(n)
    }

    fn describe(&self) -> String {
        "virtual robot (in process)".to_string()
    }
}
