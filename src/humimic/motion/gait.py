"""Locomotion as pure functions of time: a walking body (root path, heading, head bob and sway,
leg and arm swing at the step frequency) and a vertical jump (Sugiyama & Miura, Fig. 8).

Every profile is smooth (the ground truth differentiates it): waypoint-to-waypoint moves follow
the minimum-jerk profile (at rest at every waypoint) or a C2 spline through them; the gait
oscillations are sinusoids whose amplitude follows a smooth *activity* in [0, 1) that rises
with the walking speed and turning rate (``tanh``), so a person standing still does not bob;
the jump is a chain of quintic Hermite segments with a ballistic flight (acceleration exactly
-g), continuous in position, velocity and acceleration.

Walking numbers (defaults of :class:`~humimic.motion.config.WalkMotion`): 2 steps/s, a vertical
excursion of the body of 4 cm peak to peak at the step frequency (highest at mid-stance) and a
lateral sway of 4 cm at the stride frequency (half the step frequency), hips +-20 deg, knees up
to 60 deg in swing, arms +-15 deg in counter-phase (Winter, *Biomechanics and Motor Control of
Human Movement*, ch. 2 and 4; Perry & Burnfield, *Gait Analysis*).
"""

from __future__ import annotations

import numpy as np

GRAVITY = 9.81
#: Joint amplitudes of the gait at full activity (rad).
HIP_SWING = np.radians(20.0)
KNEE_SWING = np.radians(60.0)
ARM_SWING = np.radians(15.0)
#: Fraction of the foot's pitch the ankle cancels while walking (toes drop a little in swing).
ANKLE_LEVELLING = 0.6
#: Radius (m) at which a turn in place counts as walking at the same speed (feet step around).
TURN_RADIUS = 0.3


def activity(speed: np.ndarray, yaw_rate: np.ndarray, nominal_speed: float) -> np.ndarray:
    """Gait activity in [0, 1): ``tanh(sqrt(speed^2 + (r yaw_rate)^2) / nominal_speed)``."""
    s = np.hypot(speed, TURN_RADIUS * yaw_rate)
    return np.tanh(s / nominal_speed)


def bob_and_sway(t: np.ndarray, act: np.ndarray, step_frequency: float, bob: float,
                 sway: float) -> tuple[np.ndarray, np.ndarray]:
    """Vertical (down from standing, <= 0) and lateral (left +) body offsets (m): the body is
    lowest at double support, twice per stride, and sways over the stance foot once per stride;
    ``bob`` and ``sway`` are the peak-to-peak excursions at full activity."""
    w = 2 * np.pi * step_frequency * t
    return -0.5 * bob * act * (1.0 - np.cos(w)), 0.5 * sway * act * np.sin(0.5 * w)


def leg_swing(t: np.ndarray, act: np.ndarray, step_frequency: float) -> dict[str, np.ndarray]:
    """Hip flexion, knee flexion and ankle pitch (rad) per side ``r``/``l`` and the arms'
    shoulder flexion, in counter-phase: a leg swings forward with its knee bent while the other
    is in stance; the ankles keep the feet parallel to the floor. Signs as
    :func:`leg_rotvecs` takes them."""
    s = np.pi * step_frequency * t  # stride phase
    out = {}
    for side, sign in (("r", 1.0), ("l", -1.0)):
        hip = sign * HIP_SWING * act * np.sin(s)
        knee = KNEE_SWING * act * (1.0 + sign * np.cos(s)) ** 2 / 4.0
        out[f"{side}_hip"] = hip
        out[f"{side}_knee"] = knee
        # the foot would be level with -hip + knee + ankle = 0; the toes drop a little in swing
        out[f"{side}_ankle"] = ANKLE_LEVELLING * (hip - knee)
        out[f"{side}_arm"] = -sign * ARM_SWING * act * np.sin(s)
    return out


def squat_legs(drop: np.ndarray, leg: float) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Hip flexion, knee flexion and ankle pitch (rad) lowering the hip joints by ``drop``
    (m, >= 0) with the feet flat under them (thigh and shank of about equal length, ``leg``
    their sum): ``knee = 2 acos(1 - drop / leg)``, ``hip = knee / 2``, ``ankle = -knee / 2``."""
    c = np.clip(1.0 - np.maximum(drop, 0.0) / leg, -1.0, 1.0)
    knee = 2.0 * np.arccos(c)
    return 0.5 * knee, knee, -0.5 * knee


def flexion_rotvec(angle: np.ndarray) -> np.ndarray:
    """Ball-joint rotation vectors (avatar axes: x forward, y left, z up) of a flexion of a hip
    or shoulder: the limb swings forward, about -y."""
    z = np.zeros_like(angle)
    return np.stack([z, -angle, z], axis=-1)


def pitch_rotvec(angle: np.ndarray) -> np.ndarray:
    """Rotation vectors about +y (an ankle's pitch, signed as the knee's hinge)."""
    z = np.zeros_like(angle)
    return np.stack([z, angle, z], axis=-1)


# ---- the jump ---------------------------------------------------------------------------------
def quintic_hermite(x0, x1, T: float, tau: np.ndarray) -> tuple[np.ndarray, ...]:
    """Position, velocity, acceleration at ``tau`` in [0, T] of the quintic with boundary values
    ``x0 = (p, v, a)`` at 0 and ``x1`` at ``T``."""
    p0, v0, a0 = x0
    p1, v1, a1 = x1
    # coefficients of p(s) = sum c_k s^k on s in [0, T]
    A = np.array([[T**3, T**4, T**5], [3 * T**2, 4 * T**3, 5 * T**4],
                  [6 * T, 12 * T**2, 20 * T**3]])
    rhs = np.array([p1 - (p0 + v0 * T + 0.5 * a0 * T * T), v1 - (v0 + a0 * T), a1 - a0])
    c3, c4, c5 = np.linalg.solve(A, rhs)
    s = np.clip(tau, 0.0, T)
    p = p0 + v0 * s + 0.5 * a0 * s**2 + c3 * s**3 + c4 * s**4 + c5 * s**5
    v = v0 + a0 * s + 3 * c3 * s**2 + 4 * c4 * s**3 + 5 * c5 * s**4
    a = a0 + 6 * c3 * s + 12 * c4 * s**2 + 20 * c5 * s**3
    return p, v, a


def jump_phases(height: float, crouch: float, crouch_time: float, push_time: float,
                land_time: float, rise_time: float) -> list[tuple[str, float]]:
    """``[(phase, duration s)]`` of one jump: crouch, push, flight, landing, rise."""
    flight = 2.0 * np.sqrt(2.0 * height / GRAVITY)
    return [("crouch", crouch_time), ("push", push_time), ("flight", flight),
            ("land", land_time), ("rise", rise_time)]


def jump_profile(t: np.ndarray, t0: float, height: float, crouch: float,
                 crouch_time: float = 0.45, push_time: float = 0.22, land_time: float = 0.25,
                 rise_time: float = 0.6) -> np.ndarray:
    """Vertical offset (m) of the body from standing during a jump starting at ``t0``: crouch by
    ``crouch`` (minimum jerk), push up to standing height at the take-off speed
    ``sqrt(2 g height)`` with acceleration -g, fly ballistically to ``height`` and back, absorb
    the landing down to the crouch depth and rise; zero outside the jump. With the default
    phase times a 0.2 m jump from a 0.15 m crouch peaks at 2.3 g in the push and the body never
    dips below the crouch."""
    v0 = np.sqrt(2.0 * GRAVITY * height)
    rest, low = (0.0, 0.0, 0.0), (-crouch, 0.0, 0.0)
    take_off, touch_down = (0.0, v0, -GRAVITY), (0.0, -v0, -GRAVITY)
    z = np.zeros_like(np.asarray(t, float))
    start = t0
    for phase, dur in jump_phases(height, crouch, crouch_time, push_time, land_time,
                                  rise_time):
        tau = t - start
        inside = (tau >= 0.0) & (tau < dur)
        if phase == "flight":
            z = np.where(inside, v0 * tau - 0.5 * GRAVITY * tau * tau, z)
        else:
            x0, x1 = {"crouch": (rest, low), "push": (low, take_off),
                      "land": (touch_down, low), "rise": (low, rest)}[phase]
            z = np.where(inside, quintic_hermite(x0, x1, dur, tau)[0], z)
        start += dur
    return z


def jump_duration(height: float, crouch_time: float = 0.45, push_time: float = 0.22,
                  land_time: float = 0.25, rise_time: float = 0.6) -> float:
    """Total duration (s) of one jump of :func:`jump_profile`."""
    return sum(d for _, d in jump_phases(height, 0.0, crouch_time, push_time, land_time,
                                         rise_time))
