//! UMBmark odometry calibration.

use crate::client::Client;
use crate::transport::Transport;

/// `station calibrate`'s options.
#[derive(Clone, Debug, clap::Args)]
pub struct CalibrateArgs {
    /// Side of the square, m.
    #[arg(long, default_value_t = 2.0)]
    pub side_m: f64,
}

/// `station calibrate`.
pub fn command<T: Transport>(
    client: anyhow::Result<Client<T>>,
    _args: &CalibrateArgs,
) -> anyhow::Result<()> {
    let _client = client?;
    anyhow::bail!("not yet")
}
