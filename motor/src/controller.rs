//! The axis controller: a trapezoidal setpoint generator and a cascaded position (P) →
//! velocity (PI, anti-windup) → current loop, with acceleration and friction feed-forward
//! and the drive's current limit.
//!
//! Units are the axis' (m, m/s, m/s², A); the gains are derived from the plant constants
//! in [`crate::plant`]:
//!
//! * equivalent carriage mass `M_EQ = J_TOTAL / M_PER_RAD²` ≈ 33.6 kg, force constant
//!   `KF = KT / M_PER_RAD` ≈ 62.8 N/A, so the plant is `dv/dt ≈ (KF / M_EQ) · i`;
//! * velocity loop crossover ≈ 150 rad/s (24 Hz) at the 1 kHz control rate:
//!   `KP_VEL = 150 · M_EQ / KF`, integral corner at 30 rad/s;
//! * position loop 30 1/s, with velocity and acceleration feed-forward from the profile,
//!   so the following error stays in the tens of micrometres on a healthy axis.
//!
//! The **following error** is `profile position − measured position`.
//!
//! ```
//! use rtseq_motor::controller::{Profile, Limits};
//! let mut p = Profile::new(0.0, Limits::MOVE);
//! p.move_to(0.1);
//! let mut t = 0.0;
//! while !p.done() {
//!     p.step(0.001);
//!     t += 0.001;
//! }
//! assert_eq!(p.position(), 0.1);
//! // 0.1 m at 0.2 m/s and 2 m/s²: 0.1 s ramp up, 0.4 s cruise, 0.1 s ramp down.
//! assert!((t - 0.6f32).abs() < 0.01);
//! ```

use crate::plant::{clamp, COULOMB, I_MAX, J_TOTAL, KT, M_PER_RAD};

/// Equivalent carriage mass seen by the axis, kg.
pub const M_EQ: f32 = J_TOTAL / (M_PER_RAD * M_PER_RAD);
/// Force constant of the axis, N/A.
pub const KF: f32 = KT / M_PER_RAD;

/// Controller gains and limits (SI units).
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Gains {
    /// Position loop gain, (m/s)/m = 1/s.
    pub kp_pos: f32,
    /// Velocity loop proportional gain, A/(m/s).
    pub kp_vel: f32,
    /// Velocity loop integral gain, A/m.
    pub ki_vel: f32,
    /// Acceleration feed-forward, A/(m/s²).
    pub kff_acc: f32,
    /// Coulomb-friction feed-forward, A (applied in the direction of the profile velocity).
    pub kff_friction: f32,
    /// Current limit of the command, A.
    pub i_max: f32,
}

impl Gains {
    /// The tuned gains for the plant of [`crate::plant`] at a 1 kHz control rate.
    pub const DEFAULT: Gains = Gains {
        kp_pos: 30.0,
        kp_vel: 150.0 * M_EQ / KF,
        ki_vel: 150.0 * M_EQ / KF * 30.0,
        kff_acc: M_EQ / KF,
        kff_friction: COULOMB / KT,
        i_max: I_MAX,
    };
}

/// Velocity and acceleration limits of a profile.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct Limits {
    /// Maximum speed, m/s.
    pub v_max: f32,
    /// Acceleration and deceleration, m/s².
    pub a_max: f32,
}

impl Limits {
    /// Point-to-point moves: 0.2 m/s, 2 m/s².
    pub const MOVE: Limits = Limits {
        v_max: 0.2,
        a_max: 2.0,
    };
    /// Quick stop deceleration, m/s² (used by [`Profile::quick_stop`]).
    pub const QUICK_STOP_DECEL: f32 = 6.0;
}

/// What the fitted drive can deliver: the servo's current limit and the quick-stop
/// deceleration. Part of the control system's construction
/// ([`ControlSystem::with_drive`](crate::control_system::ControlSystem::with_drive)), so a
/// board with a weaker power stage than the simulated one configures its own (domain
/// review F2: with the simulated 4 A and 6 m/s² on a 1.4 A bridge the servo commanded
/// currents the bridge clipped, its integrator winding, and a quick stop took twice the
/// distance it planned).
///
/// ```
/// use rtseq_motor::controller::{DriveLimits, Limits, KF, M_EQ};
/// use rtseq_motor::plant::{COULOMB, I_MAX, M_PER_RAD};
/// let sim = DriveLimits::SIMULATED;
/// assert_eq!((sim.i_max, sim.quick_stop_decel), (I_MAX, Limits::QUICK_STOP_DECEL));
/// // A 1.4 A drive on the same axis: 2.25 m/s².
/// let a = DriveLimits::max_quick_stop_decel(1.4, KF, M_EQ, COULOMB / M_PER_RAD);
/// assert!((a - 2.245).abs() < 1e-3);
/// ```
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub struct DriveLimits {
    /// Current limit of the servo's command (and of its integrator), A: the drive's.
    pub i_max: f32,
    /// Deceleration of a quick stop ([`Profile::quick_stop_at`]), m/s²: at most what the
    /// drive can hold ([`max_quick_stop_decel`](Self::max_quick_stop_decel)).
    pub quick_stop_decel: f32,
}

impl DriveLimits {
    /// The simulated drive of [`crate::plant`]: [`I_MAX`] (4 A) and
    /// [`Limits::QUICK_STOP_DECEL`] (6 m/s²).
    pub const SIMULATED: DriveLimits = DriveLimits {
        i_max: I_MAX,
        quick_stop_decel: Limits::QUICK_STOP_DECEL,
    };

    /// The highest quick-stop deceleration, m/s², a drive limited to `i_max` (A) holds on
    /// an axis of force constant `kf` (N/A), equivalent mass `m_eq` (kg) and Coulomb
    /// friction force `friction` (N): `(kf·i_max − friction) / m_eq`. Conservative:
    /// friction in fact helps a stop; the current it saves (twice the friction current)
    /// is left to the servo's correction on top of the profile's feed-forward.
    pub const fn max_quick_stop_decel(i_max: f32, kf: f32, m_eq: f32, friction: f32) -> f32 {
        (kf * i_max - friction) / m_eq
    }

    /// Distance to stop from `v` (m/s) at [`quick_stop_decel`](Self::quick_stop_decel)
    /// when the stop starts `late` seconds after the cause, m: `v²/(2a) + v·late`.
    pub const fn stopping_distance(&self, v: f32, late: f32) -> f32 {
        v * v / (2.0 * self.quick_stop_decel) + v * late
    }
}

// The simulated drive holds its own quick stop (7.1 m/s² ≥ 6).
const _: () = assert!(
    DriveLimits::SIMULATED.quick_stop_decel
        <= DriveLimits::max_quick_stop_decel(I_MAX, KF, M_EQ, COULOMB / M_PER_RAD)
);

/// Distance the axis needs to stop from full speed ([`Limits::MOVE`]`.v_max`) at
/// [`Limits::QUICK_STOP_DECEL`] when the stop is detected one 1 ms control period late,
/// m: `v²/(2a) + v·t` = 3.33 + 0.2 = 3.53 mm. The soft travel limits lie at least this far
/// inside the end-stop switches, the hard stops at least this far beyond them
/// ([`HARD_STOP_MARGIN`](crate::plant::HARD_STOP_MARGIN)).
pub const STOPPING_DISTANCE: f32 = Limits::MOVE.v_max * Limits::MOVE.v_max
    / (2.0 * Limits::QUICK_STOP_DECEL)
    + Limits::MOVE.v_max * 0.001;

/// What the setpoint generator is doing.
#[derive(Clone, Copy, Debug, PartialEq)]
#[cfg_attr(feature = "defmt", derive(defmt::Format))]
pub enum ProfileMode {
    /// At rest, holding its position.
    Hold,
    /// Point-to-point move to a target position, m.
    Move(f32),
    /// Constant-velocity jog, m/s.
    Jog(f32),
    /// Decelerating to a standstill (then `Hold`); a held move can be resumed.
    Stop {
        /// Deceleration, m/s².
        decel: f32,
        /// The target of the interrupted move, to resume it (feed hold).
        resume: Option<f32>,
    },
}

/// An online trapezoidal setpoint generator: every period it accelerates towards the
/// limited speed, cruises, and decelerates so that it stops exactly at the target. Being
/// online, it can be redirected, stopped (feed hold) and resumed at any time.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Profile {
    pos: f32,
    vel: f32,
    acc: f32,
    mode: ProfileMode,
    limits: Limits,
}

impl Profile {
    /// A profile at rest at `pos`.
    pub const fn new(pos: f32, limits: Limits) -> Self {
        Profile {
            pos,
            vel: 0.0,
            acc: 0.0,
            mode: ProfileMode::Hold,
            limits,
        }
    }

    /// Starts a point-to-point move to `target` (m) from the current setpoint.
    pub fn move_to(&mut self, target: f32) {
        self.mode = ProfileMode::Move(target);
    }

    /// Jogs at `velocity` (m/s, limited to `v_max`).
    pub fn jog(&mut self, velocity: f32) {
        let v = self.limits.v_max;
        self.mode = ProfileMode::Jog(clamp(velocity, -v, v));
    }

    /// Decelerates to a standstill at the normal deceleration; a move in progress is
    /// remembered so that [`resume`](Self::resume) continues it (feed hold).
    pub fn stop(&mut self) {
        let resume = match self.mode {
            ProfileMode::Move(t) => Some(t),
            ProfileMode::Stop { resume, .. } => resume,
            _ => None,
        };
        self.mode = ProfileMode::Stop {
            decel: self.limits.a_max,
            resume,
        };
    }

    /// Continues a move interrupted by [`stop`](Self::stop); otherwise does nothing.
    pub fn resume(&mut self) {
        if let ProfileMode::Stop {
            resume: Some(t), ..
        } = self.mode
        {
            self.mode = ProfileMode::Move(t);
        }
    }

    /// Re-synchronises the setpoint with the measured state (`pos`, `vel`) and decelerates
    /// from there at [`Limits::QUICK_STOP_DECEL`]; the interrupted move is forgotten.
    pub fn quick_stop(&mut self, pos: f32, vel: f32) {
        self.quick_stop_at(pos, vel, Limits::QUICK_STOP_DECEL);
    }

    /// [`quick_stop`](Self::quick_stop) at the deceleration `decel` (m/s², the drive's:
    /// [`DriveLimits::quick_stop_decel`]).
    pub fn quick_stop_at(&mut self, pos: f32, vel: f32, decel: f32) {
        self.pos = pos;
        self.vel = vel;
        self.acc = 0.0;
        self.mode = ProfileMode::Stop {
            decel,
            resume: None,
        };
    }

    /// Jumps to rest at `pos` (e.g. after the encoder was zeroed or the drive enabled).
    pub fn reset(&mut self, pos: f32) {
        *self = Profile::new(pos, self.limits);
    }

    /// Advances the setpoint by `h` seconds.
    pub fn step(&mut self, h: f32) {
        if h.is_nan() || h <= 0.0 {
            return;
        }
        let a = self.limits.a_max;
        let dv_max = a * h;
        let (v_des, dv) = match self.mode {
            ProfileMode::Hold => {
                self.vel = 0.0;
                self.acc = 0.0;
                return;
            }
            ProfileMode::Move(target) => {
                let d = target - self.pos;
                if d.abs() <= 2.0 * dv_max * h && self.vel.abs() <= 2.0 * dv_max {
                    self.pos = target;
                    self.vel = 0.0;
                    self.acc = 0.0;
                    self.mode = ProfileMode::Hold;
                    return;
                }
                // The fastest speed after this step from which a ramp down at `a` still
                // stops at the target, for the trapezoidal position update below:
                // v²/2a + v·h/2 ≤ |d| − v_now·h/2.
                let toward = if d >= 0.0 { self.vel } else { -self.vel };
                let room = (d.abs() - 0.5 * toward * h).max(0.0);
                let half = 0.5 * dv_max;
                let v_stop = libm::sqrtf(half * half + 2.0 * a * room) - half;
                (self.limits.v_max.min(v_stop).copysign(d), dv_max)
            }
            ProfileMode::Jog(v) => (v, dv_max),
            ProfileMode::Stop { decel, resume } => {
                let dv = decel * h;
                if self.vel.abs() <= dv {
                    self.pos += self.vel * 0.5 * h;
                    self.vel = 0.0;
                    self.acc = 0.0;
                    if resume.is_none() {
                        self.mode = ProfileMode::Hold;
                    }
                    return;
                }
                (0.0, dv)
            }
        };
        let v_new = self.vel + clamp(v_des - self.vel, -dv, dv);
        self.acc = (v_new - self.vel) / h;
        self.pos += 0.5 * (self.vel + v_new) * h;
        self.vel = v_new;
    }

    /// Setpoint position, m.
    pub fn position(&self) -> f32 {
        self.pos
    }

    /// Setpoint velocity, m/s.
    pub fn velocity(&self) -> f32 {
        self.vel
    }

    /// Setpoint acceleration of the last step, m/s².
    pub fn acceleration(&self) -> f32 {
        self.acc
    }

    /// The current mode.
    pub fn mode(&self) -> ProfileMode {
        self.mode
    }

    /// True when at rest and not held mid-move: a move has reached its target, or a stop
    /// has ended.
    pub fn done(&self) -> bool {
        matches!(self.mode, ProfileMode::Hold)
    }

    /// The target of the current (or held) move.
    pub fn target(&self) -> Option<f32> {
        match self.mode {
            ProfileMode::Move(t) => Some(t),
            ProfileMode::Stop { resume, .. } => resume,
            _ => None,
        }
    }
}

/// The cascaded servo loop: position P → velocity PI (conditional-integration anti-windup)
/// → current command, limited to `i_max`.
///
/// ```
/// use rtseq_motor::controller::{Gains, Servo};
/// let mut servo = Servo::new();
/// // 1 mm behind the setpoint, at rest: a positive current command.
/// let i = servo.step(&Gains::DEFAULT, (0.001, 0.0, 0.0), 0.0, 0.001);
/// assert!(i > 0.0 && i <= Gains::DEFAULT.i_max);
/// ```
#[derive(Clone, Copy, Debug, PartialEq, Default)]
pub struct Servo {
    integral: f32,
    last_pos: Option<f32>,
    velocity: f32,
    command: f32,
}

impl Servo {
    /// A servo at rest with an empty integrator.
    pub const fn new() -> Self {
        Servo {
            integral: 0.0,
            last_pos: None,
            velocity: 0.0,
            command: 0.0,
        }
    }

    /// One control period: `setpoint` = (position, velocity, acceleration) of the profile,
    /// `measured` = encoder position, `h` = period (s). Returns the current command (A).
    pub fn step(&mut self, gains: &Gains, setpoint: (f32, f32, f32), measured: f32, h: f32) -> f32 {
        if h.is_nan() || h <= 0.0 {
            return self.command;
        }
        let (p_ref, v_ref, a_ref) = setpoint;
        self.velocity = match self.last_pos {
            Some(last) => (measured - last) / h,
            None => 0.0,
        };
        self.last_pos = Some(measured);
        let v_cmd = v_ref + gains.kp_pos * (p_ref - measured);
        let e_v = v_cmd - self.velocity;
        let friction = if v_ref > 0.0 {
            gains.kff_friction
        } else if v_ref < 0.0 {
            -gains.kff_friction
        } else {
            0.0
        };
        let feed_forward = gains.kff_acc * a_ref + friction;
        let unlimited = gains.kp_vel * e_v + self.integral + feed_forward;
        let limited = clamp(unlimited, -gains.i_max, gains.i_max);
        // Anti-windup: integrate only while not saturated, or when the error drives the
        // command back out of saturation.
        if limited == unlimited || (e_v > 0.0) != (unlimited > 0.0) {
            self.integral = clamp(
                self.integral + gains.ki_vel * e_v * h,
                -gains.i_max,
                gains.i_max,
            );
        }
        self.command = limited;
        limited
    }

    /// A period with the drive off: only the velocity estimate runs; integrator and
    /// command are zero.
    pub fn idle(&mut self, measured: f32, h: f32) {
        if h.is_nan() || h <= 0.0 {
            return;
        }
        self.velocity = match self.last_pos {
            Some(last) => (measured - last) / h,
            None => 0.0,
        };
        self.last_pos = Some(measured);
        self.integral = 0.0;
        self.command = 0.0;
    }

    /// Empties the integrator (keeps the velocity estimate).
    pub fn clear_integral(&mut self) {
        self.integral = 0.0;
    }

    /// Empties the integrator and forgets the last position (e.g. after a stop or zeroing).
    pub fn reset(&mut self) {
        *self = Servo::new();
    }

    /// Measured velocity (backward difference of the encoder position), m/s.
    pub fn velocity(&self) -> f32 {
        self.velocity
    }

    /// The last current command, A.
    pub fn command(&self) -> f32 {
        self.command
    }

    /// The integrator state, A.
    pub fn integral(&self) -> f32 {
        self.integral
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn profile_is_trapezoidal_and_exact() {
        let mut p = Profile::new(0.005, Limits::MOVE);
        p.move_to(-0.095);
        let mut vmax: f32 = 0.0;
        let mut n = 0;
        while !p.done() && n < 10_000 {
            p.step(0.001);
            vmax = vmax.max(p.velocity().abs());
            n += 1;
        }
        assert_eq!(p.position(), -0.095);
        assert!((vmax - 0.2).abs() < 1e-4, "{vmax}");
        assert!((590..=610).contains(&n), "{n}");
    }

    #[test]
    fn feed_hold_and_resume() {
        let mut p = Profile::new(0.0, Limits::MOVE);
        p.move_to(0.1);
        for _ in 0..200 {
            p.step(0.001);
        }
        p.stop();
        for _ in 0..200 {
            p.step(0.001);
        }
        assert_eq!(p.velocity(), 0.0);
        assert!(!p.done());
        let held = p.position();
        p.resume();
        for _ in 0..2000 {
            p.step(0.001);
        }
        assert!(held < 0.1);
        assert!(p.done());
        assert_eq!(p.position(), 0.1);
    }
}
