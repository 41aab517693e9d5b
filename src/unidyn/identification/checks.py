"""Checks of a log and of an estimate of theta: one clear line for what cannot be
identified (constant commands, a non-physical estimate, a log whose fit needs more
memory than there is), and the warnings about an estimate that can be made but not
trusted as it stands (unidentified or ill-conditioned parameters, implausible time
constants)."""

from __future__ import annotations

import contextlib
import math

import numpy as np

from .._validate import ValidationError
from ..model import robots
from .equation_error import ROW_PARAMS, coupling
from .intervals import Z95
from .logs import TIME_UNITS
from .output_error import TAU_MIN_SAMPLES
from .results import THETA_NAMES

#: theta1, theta2 or a velocity time constant above this (s) is flagged as
#: implausible for a wheeled robot (a log whose time is not in seconds)
MAX_TIME_CONSTANT = 60.0
# the shortest sampling step (s) of a robot's log: 10 kHz
_MIN_STEP = 1e-4
_UNIT_NAMES = {"ms": "milliseconds", "us": "microseconds", "ns": "nanoseconds"}
# memory the output-error fit holds per row of the log beyond the log's own columns,
# bytes (its single-precision Jacobian, simulated and measured velocities, residuals,
# the validation's copies: 2.2 GB in all for 10^7 rows), and per parameter fitted
# beyond the first eight
_BYTES_PER_ROW = 250
_BYTES_PER_ROW_PARAM = 8


def _available_memory() -> float | None:
    """Bytes of memory the system can give this process now (Linux), else None."""
    try:
        with open("/proc/meminfo") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return float(line.split()[1]) * 1024
    except OSError:
        pass
    return None


def _memory_needed(rows: int, pieces: int = 1) -> float:
    """Bytes the output-error fit of a log of ``rows`` rows in ``pieces`` pieces
    needs beyond the log itself (about 250 a row)."""
    extra = max(2 * pieces - 2, 0)
    return rows * (_BYTES_PER_ROW + _BYTES_PER_ROW_PARAM * extra)


def check_memory(lg, method):
    """Refuse, before the fit, a log whose fit would not fit in the memory available."""
    if method != "output-error":
        return
    need = _memory_needed(lg.D["t"].size, len(lg.segs))
    have = _available_memory()
    if have is not None and need > have:
        raise ValidationError(
            f"the log's {lg.D['t'].size} rows need about {need / 1e9:.2g} GB of memory to "
            f"identify from and {have / 1e9:.2g} GB are available: identify from a part "
            f"(split_log), or on a machine with more memory")


@contextlib.contextmanager
def fit_refused(what: str = "the fit of theta"):
    """One line, naming the likely causes, for a fit that is singular or does not
    converge (``numpy.linalg.LinAlgError``), in place of a traceback."""
    try:
        yield
    except np.linalg.LinAlgError as err:
        raise ValidationError(
            f"{what} failed ({err}): the log's measured velocities do not follow its "
            f"commands through Eq. (2). Likely causes: u_ref and w_ref, or u and w, "
            f"exchanged or in different units or signs, a time stamp offset between "
            f"them, or too little excitation; check the log and its columns") from None


def check_excitation(u_ref, w_ref):
    """Refuse logs whose command u_ref or w_ref (m/s, rad/s) is constant: nothing excites
    the parameters of its row of Eq. (11)."""
    for k, v, unit, params in (("u_ref", u_ref, "m/s", "theta1, theta3, theta4"),
                               ("w_ref", w_ref, "rad/s", "theta2, theta5, theta6")):
        spread = float(np.ptp(v))
        if spread <= 1e-9 * max(1.0, float(np.max(np.abs(v)))):
            raise ValidationError(
                f"log column {k!r} is constant ({v[0]:g} {unit}) throughout: no excitation, "
                f"{params} cannot be identified; vary the command (see excitation())")


def check_physical(theta, stderr):
    """Refuse an estimate with theta1, theta2, theta4 or theta6 not > 0 (no physical robot
    has one, Section 2), naming the likely causes; ``stderr`` is shown beside each."""
    bad = [(k, theta[i], stderr[i]) for i, k in enumerate(THETA_NAMES)
           if i in (0, 1, 3, 5) and not theta[i] > 0]
    if bad:
        desc = ", ".join(f"{k} = {v:.4g} (stderr {s:.2g})" for k, v, s in bad)
        raise ValidationError(
            f"identified {desc}: theta1, theta2, theta4 and theta6 must be > 0 for any physical "
            f"robot (Section 2). Likely causes: commands and measured velocities swapped or in "
            f"different units or signs, a time stamp offset between them, saturated commands "
            f"or accelerations, or too little excitation; check the log and its columns")


#: A gain from a command to its measured velocity (1/theta4, 1/theta6) further than
#: this factor from 1 is not a velocity-controlled robot's (the presets' lie within
#: 1/6.5 and 1.05): it is refused as commands and velocities in different units
UNIT_GAIN = 10.0
#: An estimate beyond this factor outside the presets' range is flagged
ENVELOPE_FACTOR = 5.0
# units a column of linear or angular velocity is often logged in, as the factor
# from m/s or rad/s
_UNITS = {3: ((100.0, "cm/s"), (1000.0, "mm/s"), (3.6, "km/h")),
          5: ((180 / math.pi, "deg/s"), (60 / (2 * math.pi), "rpm"), (1000.0, "mrad/s"))}
_CHANNEL = {3: ("u_ref", "u", "m/s", "linear"), 5: ("w_ref", "w", "rad/s", "angular")}
_UNIT_OF = {0: "s", 1: "s", 2: "s·m/rad²", 3: "", 4: "s/m", 5: ""}


def _envelope() -> dict:
    """For each parameter, the presets' (smallest, largest) value (magnitude for
    theta3 and theta5) and the robots that have them."""
    sets = [robots.get(n) for n in robots.names()]
    out = {}
    for i in range(6):
        vals = [(abs(r.theta[i]) if i in (2, 4) else r.theta[i], r) for r in sets]
        lo, hi = min(vals, key=lambda v: v[0]), max(vals, key=lambda v: v[0])
        out[i] = (lo[0], lo[1].source.split(";")[0], hi[0], hi[1].source.split(";")[0])
    return out


def _value(i, v) -> str:
    unit = _UNIT_OF[i]
    return f"{v:.4g}" + (f" {unit}" if unit else "")


def check_units(theta, stderr):
    """Refuse an estimate whose gain from a command to its measured velocity (1/theta4
    for u_ref to u, 1/theta6 for w_ref to w) is further than :data:`UNIT_GAIN` from 1,
    where a velocity-controlled robot's is near 1: the command and the velocity are
    in different units. The message names the likely units and the ``scale`` that
    fixes it, whichever side is scaled."""
    for i in (3, 5):
        g = float(theta[i])
        if not (g > UNIT_GAIN or g < 1 / UNIT_GAIN):
            continue
        cmd, meas, si, kind = _CHANNEL[i]
        ratio = g if g > 1 else 1 / g
        big, small = (cmd, meas) if g > 1 else (meas, cmd)
        factor, unit = min(_UNITS[i], key=lambda fu: abs(math.log(ratio / fu[0])))
        if abs(math.log(ratio / factor)) > math.log(1.5):  # none of the usual units
            factor, unit = ratio, None
        cause = (f"{big} in {unit} beside {small} in {si}?" if unit else
                 f"{big} and {small} in different units, or a gain between them?")
        raise ValidationError(
            f"identified {THETA_NAMES[i]} = {g:.4g} (stderr {stderr[i]:.2g}): the steady "
            f"gain from the {kind}-velocity command {cmd} to the measured {meas} is "
            f"1/{THETA_NAMES[i]} = {1 / g:.3g}, where a velocity-controlled robot's is near 1 "
            f"(the presets' {THETA_NAMES[i]}: {_envelope()[i][0]:.3g} to "
            f"{_envelope()[i][2]:.3g}): {big} is about {ratio:.3g} times {small}, so they are "
            f"likely in different units ({cause}). Pass scale={{'{big}': {1 / factor:.4g}}} "
            f"to bring {big} to {si}, and identify again")


#: A wheeled robot of the kind identified here moves at most this fast, m/s, and
#: turns at most this fast, rad/s (the presets' limits are 1.5 m/s and a few rad/s;
#: 5 rad/s is 0.8 turns a second): a log whose velocities go beyond in 1 % of its rows
#: reads as velocities in smaller units, both sides alike
U_MAX, W_MAX = 3.0, 5.0
#: |theta3|/theta1 <= |b| (Section 2: theta3/theta1 = m b r^2 / (m r^2 + 2 Ie + 2 r kDT)),
#: and a centre of mass is never this far (m) from the wheel axle
B_MAX = 1.0
#: sqrt(|theta3 theta2 / (theta1 theta5)|) is a length (m/rad: about the radius of
#: gyration about the wheel axle, sqrt(Iz/m + b^2), Section 2), which lies within
#: 0.06 m (khepera3) and 0.65 m (wheelchair_55kg) for the presets; outside these bounds it reads as other units
L_MIN, L_MAX = 0.02, 3.0
_LINEAR = ((100.0, "cm/s"), (1000.0, "mm/s"))
_ANGULAR = ((180 / math.pi, "deg/s"), (60 / (2 * math.pi), "rpm"))


def shared_unit_warnings(theta, stderr, u, w, pose=None) -> list:
    """Where the commands and the measured velocities share a wrong unit (u_ref and u
    both in cm/s, w_ref and w both in deg/s), which the steady gains (:func:`check_units`)
    cannot show: the warnings naming the likely units and the ``scale`` that fixes
    each. The evidence does not depend on the unit used: the velocities' own range
    (:data:`U_MAX`, :data:`W_MAX`), the offset of the centre of mass that theta3/theta1
    bounds (:data:`B_MAX`) and the length sqrt(|theta3 theta2 / (theta1 theta5)|)
    (:data:`L_MIN`, :data:`L_MAX`), where theta3 and theta5 are identified; with both
    sides in one unit theta1, theta2, theta4 and theta6 do not change, theta3 scales as
    the linear unit over the square of the angular one and theta5 as one over the
    linear unit."""
    theta, stderr = np.asarray(theta, float), np.asarray(stderr, float)
    known = [bool(abs(theta[i]) > 0 and stderr[i] <= 0.3 * abs(theta[i])) for i in range(6)]
    q_u = float(np.quantile(np.abs(u), 0.99)) if np.size(u) else 0.0
    q_w = float(np.quantile(np.abs(w), 0.99)) if np.size(w) else 0.0
    b = abs(theta[2]) / theta[0] if theta[0] > 0 else math.nan
    length = (math.sqrt(abs(theta[2] * theta[1] / (theta[0] * theta[4])))
              if known[2] and known[4] and theta[0] > 0 else math.nan)
    linear, angular = [], []
    k_u, k_w = pose if pose is not None else (math.nan, math.nan)
    near = lambda k, units: any(abs(math.log(k / f)) < math.log(1.5)  # noqa: E731
                                for f, _ in units) if k > 0 else False
    if near(k_u, _LINEAR):
        linear.append(f"|u| is {k_u:.3g} times the path's speed from the pose x, y, as "
                      f"from a pose in m")
    if near(k_w, _ANGULAR):
        angular.append(f"w is {k_w:.3g} times the heading's rate from psi, as from a "
                       f"heading in radians")
    if q_u > U_MAX:
        linear.append(f"|u| reaches {q_u:.3g} in 1 % of the rows, where a robot moves at "
                      f"most about {U_MAX:g} m/s")
    if known[2] and b > B_MAX:
        linear.append(f"|theta3|/theta1 = {b:.3g} (m if u is in m/s), which bounds the centre "
                      f"of mass's offset from the wheel axle (Section 2), is over {B_MAX:g} m")
    if length > L_MAX:
        linear.append(f"sqrt(|theta3 theta2/(theta1 theta5)|) = {length:.3g}, about the "
                      f"robot's radius of gyration, is over {L_MAX:g} m")
    if q_w > W_MAX:
        angular.append(f"|w| reaches {q_w:.3g} in 1 % of the rows ({q_w / (2 * math.pi):.2g} "
                       f"turns a second if rad/s), where a robot turns at most about "
                       f"{W_MAX:g} rad/s")
    if length < L_MIN:
        angular.append(f"sqrt(|theta3 theta2/(theta1 theta5)|) = {length:.3g}, about the "
                       f"robot's radius of gyration, is under {L_MIN:g} m")
    out = []
    for said, units, (cmd, meas, si), peak, typical, off in (
            (linear, _LINEAR, _CHANNEL[3][:3], q_u, 0.6,
             "theta3 is off by its factor and theta5 by its inverse"),
            (angular, _ANGULAR, _CHANNEL[5][:3], q_w, 1.2,
             "theta3 is off by the inverse of its factor squared")):
        if not said:
            continue
        ranked = sorted(units, key=lambda fu: abs(math.log(max(peak, 1e-12) / fu[0] / typical)))
        fixes = " or ".join(f"in {unit}? pass scale={{'{cmd}': {1 / f:.6g}, '{meas}': "
                            f"{1 / f:.6g}}}" for f, unit in ranked)
        out.append(f"{cmd} and {meas} look like they are both in a unit other than {si} "
                   f"({'; '.join(said)}), so {off}: {fixes}, and identify again")
    return out


def envelope_warnings(theta) -> list:
    """Where an estimate lies outside the presets' range (a Khepera III to a robotic
    wheelchair carrying 125 kg, and the RobuLAB-10) by more than
    :data:`ENVELOPE_FACTOR`: which parameter, by how much, and the likely causes
    (theta1 or theta2 over :data:`MAX_TIME_CONSTANT` has its own warning)."""
    env, out = _envelope(), []
    for i in range(6):
        lo, lo_robot, hi, hi_robot = env[i]
        v = abs(theta[i]) if i in (2, 4) else float(theta[i])
        if i in (0, 1) and v > MAX_TIME_CONSTANT:  # its own warning says why
            continue
        if v > ENVELOPE_FACTOR * hi:
            where = f"{v / hi:.3g} times the largest{' magnitude' if i in (2, 4) else ''}"
            near = f"{_value(i, hi)}, {hi_robot}"
        elif i not in (2, 4) and 0 < v < lo / ENVELOPE_FACTOR:
            where, near = f"1/{lo / v:.3g} of the smallest", f"{_value(i, lo)}, {lo_robot}"
        else:
            continue
        out.append(f"{THETA_NAMES[i]} = {_value(i, float(theta[i]))} is {where} among the "
                   f"preset robots ({near}), outside the range of physical robots: check "
                   f"the units of the log's columns (scale=) and of its time (time_unit=), "
                   f"and that u and w are not exchanged")
    return out


def estimate_warnings(theta, stderr, conds, u, w, dt, rel_max, pose=None) -> list:
    """The warnings about an estimate ``theta`` with standard errors ``stderr`` from a log
    of velocities u (m/s), w (rad/s) sampled every ``dt`` s: theta3 or theta5 unidentified
    (standard error above ``rel_max`` of its size), ill-conditioned rows (condition
    numbers ``conds``), theta4 or theta6 well below 1, time constants the sampling does
    not resolve or too long for a wheeled robot, theta1 or theta2 barely determined."""
    out = []
    rms = lambda a: float(np.sqrt(np.mean(np.square(a))))  # noqa: E731
    w2, uw = coupling(u, w)
    turning = (f"rms(w^2) = {rms(w2):.3g} rad²/s², rms(u*w) = {rms(uw):.3g} "
               f"m·rad/s², "
               f"rms(u) = {rms(u):.3g} m/s, rms(w) = {rms(w):.3g} rad/s")
    for i, term in ((2, "-w^2 (centripetal)"), (4, "u*w (Coriolis)")):
        k = THETA_NAMES[i]
        if not stderr[i] <= rel_max * abs(theta[i]):
            half = Z95 * stderr[i]
            what = ("is not distinguishable from zero" if half >= abs(theta[i]) else
                    f"is poorly determined (+/- {100 * half / abs(theta[i]):.0f} %)")
            out.append(
                f"{k} is unidentified: {theta[i]:.3g} +/- {half:.2g} (95 %) {what}. Either the "
                f"centre of mass is close to the wheel axle (b ~ 0, so {k} ~ 0), or the log has "
                f"too little turning at speed to excite the {term} term ({turning}); excite "
                f"with simultaneous linear and angular speed (see excitation()) before relying "
                f"on {k}")
    for row, c in enumerate(conds):
        if c > 1e4:
            ps = ", ".join(THETA_NAMES[p] for p in ROW_PARAMS[row])
            out.append(f"the regression for {ps} is ill-conditioned (condition number {c:.3g} "
                       f"after column scaling): their estimates are strongly correlated")
    for i in (3, 5):
        if theta[i] < 0.8:
            out.append(f"{THETA_NAMES[i]} = {theta[i]:.4g} is well below 1; Section 2 gives "
                       f"{THETA_NAMES[i]} = 1 + (Ra/ka)(ka kb/Ra + Be)(...) >= 1 (identified sets "
                       f"reach 0.956): check the scale of the measured velocities against "
                       f"the commands")
    out += shared_unit_warnings(theta, stderr, u, w, pose)
    out += envelope_warnings(theta)
    for i, j in ((0, 3), (1, 5)):
        tau = theta[i] / theta[j] if theta[j] > 0 else math.nan
        if tau <= 1.05 * TAU_MIN_SAMPLES * dt:
            out.append(f"the time constant {THETA_NAMES[i]}/{THETA_NAMES[j]} is not resolvable at this "
                       f"sampling rate: the fit reached the shortest one it explores, "
                       f"{tau:.3g} s (1/{1 / TAU_MIN_SAMPLES:g} of the {dt:g} s sample "
                       f"interval), so the response settles within one sample; {THETA_NAMES[i]} "
                       f"is only known to be about this small or smaller (its interval is "
                       f"not meaningful): log faster to identify it")
        elif tau < 2 * dt:
            out.append(f"the time constant {THETA_NAMES[i]}/{THETA_NAMES[j]} = {tau:.3g} s is shorter "
                       f"than two sampling intervals (2 x {dt:g} s): the log barely resolves "
                       f"it, so {THETA_NAMES[i]} rests on the command convention and delay being "
                       f"right; log faster if you can")
    for i, j in ((0, 3), (1, 5)):
        tau = max(theta[i], theta[i] / theta[j] if theta[j] > 0 else 0.0)
        if tau > MAX_TIME_CONSTANT:
            unit = next((u for u in ("ms", "us", "ns") if tau * TIME_UNITS[u] <= 10.0), "ns")
            # time in another unit also shows as steps that, in that unit, are a robot's
            # sampling (at most 10 kHz); a log at a robot's rate read in seconds is not
            # in another unit: the log, not its unit, is what is wrong
            why = (f"is t in {_UNIT_NAMES[unit]}? pass time_unit='{unit}'"
                   if dt * TIME_UNITS[unit] >= _MIN_STEP
                   else "the log does not determine it: check that the measured velocities "
                        "respond to the commands (units, signs, the frame of the odometry) "
                        "and that the commands vary (see excitation())")
            out.append(f"{THETA_NAMES[i]} = {theta[i]:.4g} s and {THETA_NAMES[i]}/{THETA_NAMES[j]} = "
                       f"{theta[i] / theta[j]:.4g} s: a time constant over "
                       f"{MAX_TIME_CONSTANT:g} s is implausible for a wheeled robot (tenths of a "
                       f"second to seconds); {why}")
    for i in (0, 1):
        if theta[i] > 0 and 2 * stderr[i] > theta[i]:
            out.append(f"{THETA_NAMES[i]} = {theta[i]:.3g} s has a standard error of "
                       f"{stderr[i]:.2g} s: the log has too little acceleration to "
                       f"identify it")
    return out
