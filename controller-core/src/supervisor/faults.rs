//! The latched faults: one bit per [`Fault`] in a 16-bit set.
//!
//! A set of bits rather than a struct of `bool`s because the flags cross the control step
//! several times (into the step's outputs, the actuation, telemetry) and are asked "any?"
//! in every step: on the Cortex-M4F a `u16` is one load and one store and "any?" one
//! compare, where twelve `bool`s were two byte-wise `memcpy` calls (about 60 instructions
//! each, found by single-stepping a control step under QEMU) and twelve loads. The serde
//! form is unchanged (a struct of named booleans, see `wire`), so the link's frames and
//! schema hash, host-sim's JSON and the station's records read as before.

use core::fmt;

use crate::controller::ControllerFaults;

/// One fault the supervisor latches. The discriminant is the fault's bit in [`Faults`]
/// (and in the lockstep protocol's fault word).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
#[repr(u8)]
pub enum Fault {
    /// A tick delta implied a wheel speed beyond the plausible maximum (the controller's).
    EncoderJump = 0,
    /// A pose, command or duty became NaN or infinite, or a duty left [−1, 1].
    NonFinite = 1,
    /// The control loop overran its period too many times in a row.
    Overrun = 2,
    /// The control loop missed too many ticks, or was blind too long.
    MissedTicks = 3,
    /// The left wheel did not follow its drive (see [`super::StallCheck`]).
    StallLeft = 4,
    /// The right wheel did not follow its drive (see [`super::StallCheck`]).
    StallRight = 5,
    /// A wheel loop kept hitting its limits (see [`super::SaturationCheck`]).
    Saturated = 6,
    /// The tracking error stayed above its bound (see [`super::DivergenceCheck`]).
    Divergence = 7,
    /// The estimated pose left the geofence around the start.
    Geofence = 8,
    /// The supply was below the battery's fault threshold (or unreadable).
    SupplyLow = 9,
    /// The supply was above what the bridge tolerates.
    SupplyHigh = 10,
    /// An emergency stop was commanded.
    EmergencyStop = 11,
    /// The gyro's and odometry's yaw rates disagreed persistently while armed, and the
    /// gyro's configuration says to stop ([`crate::gyro::GyroConfig::disagreement_stops`]).
    HeadingDisagreement = 12,
}

impl Fault {
    /// Every fault, in bit order.
    pub const ALL: [Fault; 13] = [
        Fault::EncoderJump,
        Fault::NonFinite,
        Fault::Overrun,
        Fault::MissedTicks,
        Fault::StallLeft,
        Fault::StallRight,
        Fault::Saturated,
        Fault::Divergence,
        Fault::Geofence,
        Fault::SupplyLow,
        Fault::SupplyHigh,
        Fault::EmergencyStop,
        Fault::HeadingDisagreement,
    ];

    /// The fault's name in reports and logs (`snake_case`, as in the serde form).
    pub const fn name(self) -> &'static str {
        match self {
            Fault::EncoderJump => "encoder_jump",
            Fault::NonFinite => "non_finite",
            Fault::Overrun => "overrun",
            Fault::MissedTicks => "missed_ticks",
            Fault::StallLeft => "stall_left",
            Fault::StallRight => "stall_right",
            Fault::Saturated => "saturated",
            Fault::Divergence => "divergence",
            Fault::Geofence => "geofence",
            Fault::SupplyLow => "supply_low",
            Fault::SupplyHigh => "supply_high",
            Fault::EmergencyStop => "emergency_stop",
            Fault::HeadingDisagreement => "heading_disagreement",
        }
    }

    /// The fault's bit in [`Faults::bits`].
    pub const fn bit(self) -> u16 {
        1 << self as u16
    }
}

/// Faults latched by the supervisor, one bit per [`Fault`]. Any set means the robot is
/// [`super::State::Faulted`].
#[derive(Clone, Copy, Default, PartialEq, Eq)]
#[cfg_attr(
    feature = "serde",
    derive(serde::Serialize, serde::Deserialize),
    serde(from = "wire::Faults", into = "wire::Faults")
)]
pub struct Faults(u16);

impl Faults {
    /// No fault.
    pub const NONE: Faults = Faults(0);

    /// Every bit a [`Fault`] uses.
    const MASK: u16 = (1 << Fault::ALL.len()) - 1;

    /// True when any fault is latched.
    pub const fn any(self) -> bool {
        self.0 != 0
    }

    /// True when `fault` is latched.
    pub const fn has(self, fault: Fault) -> bool {
        self.0 & fault.bit() != 0
    }

    /// Latches `fault`.
    pub fn set(&mut self, fault: Fault) {
        self.0 |= fault.bit();
    }

    /// Latches `fault` when `condition` holds (a latch: a false condition clears nothing).
    pub fn set_if(&mut self, fault: Fault, condition: bool) {
        self.0 |= fault.bit() * u16::from(condition);
    }

    /// These faults and `fault`.
    pub const fn with(self, fault: Fault) -> Faults {
        Faults(self.0 | fault.bit())
    }

    /// The set as bits, [`Fault`]'s discriminant giving each one's position.
    pub const fn bits(self) -> u16 {
        self.0
    }

    /// The set from [`Faults::bits`]; bits no fault uses are dropped.
    pub const fn from_bits(bits: u16) -> Faults {
        Faults(bits & Self::MASK)
    }

    /// The latched faults, in bit order.
    pub fn iter(self) -> impl Iterator<Item = Fault> {
        Fault::ALL.into_iter().filter(move |f| self.has(*f))
    }

    /// Latches the controller's own faults.
    pub fn latch_core(&mut self, core: ControllerFaults) {
        self.set_if(Fault::EncoderJump, core.encoder_jump);
        self.set_if(Fault::NonFinite, core.non_finite);
    }
}

impl fmt::Debug for Faults {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_set().entries(self.iter().map(Fault::name)).finish()
    }
}

#[cfg(feature = "defmt")]
impl defmt::Format for Faults {
    fn format(&self, f: defmt::Formatter<'_>) {
        defmt::write!(f, "Faults[");
        for (i, fault) in self.iter().enumerate() {
            if i > 0 {
                defmt::write!(f, ", ");
            }
            defmt::write!(f, "{=str}", fault.name());
        }
        defmt::write!(f, "]");
    }
}

#[cfg(feature = "serde")]
impl postcard_schema::Schema for Faults {
    const SCHEMA: &'static postcard_schema::schema::NamedType =
        <wire::Faults as postcard_schema::Schema>::SCHEMA;
}

/// The serde form of [`Faults`]: the struct of named booleans the flags were before they
/// became bits, so that everything serialized (the link's frames and schema hash, JSON)
/// is unchanged.
#[cfg(feature = "serde")]
mod wire {
    use super::Fault;
    use crate::controller::ControllerFaults;

    /// The faults as named booleans (the controller's own two in `core`).
    #[derive(Clone, Copy, serde::Serialize, serde::Deserialize, postcard_schema::Schema)]
    pub struct Faults {
        pub core: ControllerFaults,
        pub overrun: bool,
        pub missed_ticks: bool,
        pub stall_left: bool,
        pub stall_right: bool,
        pub saturated: bool,
        pub divergence: bool,
        pub geofence: bool,
        pub supply_low: bool,
        pub supply_high: bool,
        pub emergency_stop: bool,
        pub heading_disagreement: bool,
    }

    impl From<super::Faults> for Faults {
        fn from(f: super::Faults) -> Self {
            Faults {
                core: ControllerFaults {
                    encoder_jump: f.has(Fault::EncoderJump),
                    non_finite: f.has(Fault::NonFinite),
                },
                overrun: f.has(Fault::Overrun),
                missed_ticks: f.has(Fault::MissedTicks),
                stall_left: f.has(Fault::StallLeft),
                stall_right: f.has(Fault::StallRight),
                saturated: f.has(Fault::Saturated),
                divergence: f.has(Fault::Divergence),
                geofence: f.has(Fault::Geofence),
                supply_low: f.has(Fault::SupplyLow),
                supply_high: f.has(Fault::SupplyHigh),
                emergency_stop: f.has(Fault::EmergencyStop),
                heading_disagreement: f.has(Fault::HeadingDisagreement),
            }
        }
    }

    impl From<Faults> for super::Faults {
        fn from(w: Faults) -> Self {
            let flags = [
                (Fault::EncoderJump, w.core.encoder_jump),
                (Fault::NonFinite, w.core.non_finite),
                (Fault::Overrun, w.overrun),
                (Fault::MissedTicks, w.missed_ticks),
                (Fault::StallLeft, w.stall_left),
                (Fault::StallRight, w.stall_right),
                (Fault::Saturated, w.saturated),
                (Fault::Divergence, w.divergence),
                (Fault::Geofence, w.geofence),
                (Fault::SupplyLow, w.supply_low),
                (Fault::SupplyHigh, w.supply_high),
                (Fault::EmergencyStop, w.emergency_stop),
                (Fault::HeadingDisagreement, w.heading_disagreement),
            ];
            let mut faults = super::Faults::NONE;
            for (fault, set) in flags {
                faults.set_if(fault, set);
            }
            faults
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn each_fault_has_its_own_bit_in_order() {
        for (i, fault) in Fault::ALL.iter().enumerate() {
            assert_eq!(fault.bit(), 1 << i, "{fault:?}");
            let only = Faults::NONE.with(*fault);
            assert!(only.any() && only.has(*fault));
            assert_eq!(only.iter().collect::<Vec<_>>(), [*fault]);
            for other in Fault::ALL.iter().filter(|o| *o != fault) {
                assert!(!only.has(*other), "{fault:?} also sets {other:?}");
            }
        }
        assert!(!Faults::NONE.any());
        assert_eq!(Faults::default(), Faults::NONE);
    }

    #[test]
    fn set_if_latches_and_never_clears() {
        let mut f = Faults::NONE;
        f.set_if(Fault::Geofence, false);
        assert!(!f.any());
        f.set_if(Fault::Geofence, true);
        f.set_if(Fault::Geofence, false);
        assert!(f.has(Fault::Geofence));
        f.set(Fault::Overrun);
        assert_eq!(f.bits(), Fault::Geofence.bit() | Fault::Overrun.bit());
    }

    #[test]
    fn bits_round_trip_and_unused_bits_are_dropped() {
        let f = Faults::NONE
            .with(Fault::StallRight)
            .with(Fault::EmergencyStop);
        assert_eq!(Faults::from_bits(f.bits()), f);
        assert_eq!(Faults::from_bits(0xE000 | f.bits()), f);
        assert_eq!(Faults::from_bits(0xFFFF).iter().count(), Fault::ALL.len());
    }

    #[test]
    fn latch_core_adds_the_controllers_faults() {
        let mut f = Faults::NONE.with(Fault::Saturated);
        f.latch_core(ControllerFaults {
            encoder_jump: false,
            non_finite: true,
        });
        assert_eq!(
            f,
            Faults::NONE.with(Fault::Saturated).with(Fault::NonFinite)
        );
        f.latch_core(ControllerFaults::default());
        assert!(f.has(Fault::NonFinite));
    }

    #[test]
    fn with_adds_and_never_removes() {
        let once = Faults::NONE.with(Fault::Divergence);
        assert_eq!(
            once.with(Fault::Divergence),
            once,
            "adding a latched fault again"
        );
    }

    #[cfg(feature = "serde")]
    #[test]
    fn the_wire_form_round_trips_each_fault_in_its_own_field() {
        for fault in Fault::ALL {
            let only = Faults::NONE.with(fault);
            let form = wire::Faults::from(only);
            assert_eq!(Faults::from(form), only, "{fault:?}");
        }
        let all = Faults::from_bits(u16::MAX);
        assert_eq!(Faults::from(wire::Faults::from(all)), all);
    }

    #[test]
    fn debug_names_the_latched_faults() {
        let f = Faults::NONE.with(Fault::SupplyLow).with(Fault::EncoderJump);
        assert_eq!(format!("{f:?}"), r#"{"encoder_jump", "supply_low"}"#);
    }
}
