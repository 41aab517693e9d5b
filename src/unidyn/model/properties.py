r"""Numerical checks of the model's properties and of the parameters' linear independence.

Martins, Sarcinelli-Filho, Carelli, "A Velocity-Based Dynamic Model and Its
Properties for Differential Drive Mobile Robots", J Intell Robot Syst (2017),
Section 3.

:func:`check_properties` evaluates properties 1-7 of the matrix form (Eq. 6)

.. math:: H\dot v + C(v) v + F(v) v = v_{ref}

for one parameter set over the speed range :math:`|u| \le u_{max}` (Section 3.2),
and verifies the power balance of Theorem 1 (Eq. 7),
:math:`\dot V = v^T v_{ref} - v^T F(v) v` with :math:`V = \tfrac12 v^T H v`.

:func:`rank_test` repeats the linear-independence test of Section 3: the rank of
a K x 6 matrix of theta vectors computed from random physical parameters.

Everything here is pure numpy; nothing imports bdsim.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from numbers import Integral

import numpy as np

from .._validate import ValidationError, integer, positive
from . import robots, unicycle
from .parameters import THETA_NAMES, RobotParameters

__all__ = ["PropertyResult", "PropertyReport", "check_properties",
           "RankTestResult", "rank_test", "DEFAULT_U_MAX", "DEFAULT_W_MAX",
           "CONSTANT_F_TOLERANCE", "PHYSICAL_RANGES"]

#: Speed limit (m/s) used when the robot is not one of the presets with a limit
#: in :data:`unidyn.model.robots.SPEED_LIMITS` (the paper's value for the Pioneers).
DEFAULT_U_MAX = 1.2
#: Angular-speed range (rad/s) of the grid used for properties 5 and 7: the
#: limit of the paper's simulations (Section 5, :data:`unidyn.PAPER_LIMITS`).
DEFAULT_W_MAX = float(unicycle.PAPER_LIMITS.steer_max)
#: Property 6 reads :math:`\theta_6 \gg |(\theta_5 - \theta_3) u|`; it is reported as
#: holding when :math:`\max |(\theta_5 - \theta_3) u| / \theta_6` over the speed range
#: is below this.
CONSTANT_F_TOLERANCE = 0.1

# Relative tolerance of the identities (properties 4, 5 and Theorem 1's balance),
# which hold exactly up to rounding.
_RTOL = 1e-9

_NAMES = {
    1: "H = H^T > 0",
    2: "H^-1 exists and H^-1 > 0",
    3: "F(v) = F^T > 0 over the speed range",
    4: "H constant",
    5: "C(v) skew-symmetric",
    6: "F(v) approximately constant",
    7: "v_ref -> v strictly output passive",
}


# ----------------------------------------------------------------------------- properties

@dataclass(frozen=True)
class PropertyResult:
    """The outcome of one property of Section 3 of the paper.

    :param number: the property's number in the paper's list (1-7)
    :param name: a short statement of the property
    :param holds: whether it holds over the checked range
    :param margin: the property's numeric margin (its meaning is in ``detail``
        and in :func:`check_properties`)
    :param detail: how the margin was obtained, with the numbers
    """

    number: int
    name: str
    holds: bool
    margin: float
    detail: str

    def as_dict(self) -> dict:
        """The fields as plain Python types (for JSON)."""
        return {"number": int(self.number), "name": self.name, "holds": bool(self.holds),
                "margin": float(self.margin), "detail": self.detail}


@dataclass(frozen=True)
class PropertyReport:
    r"""Properties 1-7 of Section 3 for one parameter set, from :func:`check_properties`.

    :param robot: the parameter set's name
    :param theta: theta1..theta6
    :param u_max: the linear-speed range checked, \|u\| <= u_max, m/s
    :param w_max: the angular-speed range of the grid, \|w\| <= w_max, rad/s
    :param u_max_source: where ``u_max`` comes from
    :param results: one :class:`PropertyResult` per property, numbers 1 to 7 in order
    :param power_balance_residual: the largest relative mismatch in Theorem 1's
        power balance (Eq. 7) over the samples; ~1e-16 when the model is consistent
    :param samples: the number of (v, v_ref) samples of the grid
    """

    robot: str
    theta: tuple
    u_max: float
    w_max: float
    u_max_source: str
    results: tuple
    power_balance_residual: float
    samples: int

    @property
    def all_hold(self) -> bool:
        """True when every one of properties 1-7 holds."""
        return all(r.holds for r in self.results)

    def result(self, number: int) -> PropertyResult:
        """The :class:`PropertyResult` of property ``number`` (1-7)."""
        number = integer("number", number, 1, 7)
        return self.results[number - 1]

    @property
    def failed(self) -> list:
        """The numbers of the properties that do not hold."""
        return [r.number for r in self.results if not r.holds]

    def as_dict(self) -> dict:
        """The report as plain Python types (``json.dumps`` accepts it)."""
        return {
            "robot": self.robot,
            "theta": {k: float(v) for k, v in zip(THETA_NAMES, self.theta)},
            "u_max": float(self.u_max),
            "w_max": float(self.w_max),
            "u_max_source": self.u_max_source,
            "all_hold": self.all_hold,
            "power_balance_residual": float(self.power_balance_residual),
            "samples": int(self.samples),
            "properties": [r.as_dict() for r in self.results],
        }

    def __str__(self) -> str:
        th = ", ".join(f"{v:.6g}" for v in self.theta)
        head = [f"Model properties (Martins et al. 2017, Section 3) of {self.robot}",
                f"theta = [{th}]",
                f"|u| <= {self.u_max:g} m/s ({self.u_max_source}), |w| <= {self.w_max:g} rad/s, "
                f"{self.samples} samples"]
        rows = [(str(r.number), r.name, "yes" if r.holds else "NO", f"{r.margin:.6g}", r.detail)
                for r in self.results]
        hdr = ("#", "property", "holds", "margin", "detail")
        widths = [max(len(h), *(len(row[i]) for row in rows)) for i, h in enumerate(hdr[:4])]

        def line(cells):
            left = "  ".join(c.ljust(w) for c, w in zip(cells[:4], widths))
            return f"{left}  {cells[4]}"

        body = [line(hdr), line(tuple("-" * w for w in widths) + ("-" * 6,))]
        body += [line(row) for row in rows]
        tail = [f"Theorem 1 power balance, max relative residual: {self.power_balance_residual:.3g}",
                "all properties hold" if self.all_hold
                else "properties not holding: " + ", ".join(map(str, self.failed))]
        return "\n".join(head + body + tail)


def _default_u_max(params: RobotParameters) -> tuple[float, str]:
    name = params.name
    if name in robots.SPEED_LIMITS:
        try:
            preset = robots.get(name)
        except ValidationError:  # pragma: no cover - SPEED_LIMITS names are presets
            preset = None
        if preset is not None and preset == params:
            return float(robots.SPEED_LIMITS[name]), "the paper's limit for this robot, Section 3.2"
    return DEFAULT_U_MAX, f"default {DEFAULT_U_MAX:g} m/s"


def check_properties(robot, u_max=None, w_max=DEFAULT_W_MAX, n: int = 41,
                     constant_tolerance: float = CONSTANT_F_TOLERANCE,
                     seed: int = 0) -> PropertyReport:
    r"""Check properties 1-7 of the paper (Section 3) for one parameter set.

    The matrices are those of Eq. (6), taken from :mod:`unidyn.model.unicycle`:
    :math:`H = \mathrm{diag}(\theta_1, \theta_2)`,
    :math:`C(v) = \theta_3 w \begin{bmatrix}0 & -1\\ 1 & 0\end{bmatrix}`,
    :math:`F(v) = \mathrm{diag}(\theta_4, \theta_6 + (\theta_5 - \theta_3) u)`.
    They are evaluated on an ``n`` x ``n`` grid of velocities
    :math:`v = [u, w]`, :math:`|u| \le u_{max}`, :math:`|w| \le w_{max}` (the grid
    includes the corners), each paired with a command :math:`v_{ref}` drawn
    uniformly from :math:`|u_{ref}| \le 2 u_{max}`, :math:`|w_{ref}| \le 2 w_{max}`
    by a generator seeded with ``seed``.

    Margins (all floats; the paper's numbering):

    1. smallest eigenvalue of H (s); holds if H is symmetric and that is > 0.
    2. smallest eigenvalue of H^-1 (1/s); holds if H H^-1 = I, H^-1 is
       symmetric and that is > 0.
    3. :math:`\min_{|u| \le u_{max}} \theta_6 + (\theta_5 - \theta_3) u
       = \theta_6 - |\theta_5 - \theta_3| u_{max}` (dimensionless; the condition
       :math:`\theta_6 > -(\theta_5 - \theta_3) u` of Section 3); holds if it is
       > 0 and :math:`\theta_4 > 0`.
    4. largest deviation, over the grid, of :math:`\partial v_{ref}/\partial\dot v`
       of :func:`unidyn.model.unicycle.inverse_dynamics` from H (0: H does not depend on v).
    5. largest :math:`|v^T C(v) v|` over the grid (0 for skew-symmetric C); the
       detail also gives the largest :math:`\|C + C^T\|`.
    6. :math:`\max_{|u| \le u_{max}} |(\theta_5 - \theta_3) u| / \theta_6`; F is
       "approximately constant" (:math:`\theta_6 \gg |(\theta_5 - \theta_3) u|`)
       when this is below ``constant_tolerance``.
    7. the passivity margin :math:`\inf \lambda_{min}(F)` over the range (Eq. 9);
       holds if property 3 holds, Theorem 1's power balance (Eq. 7)
       :math:`v^T H \dot v = v^T v_{ref} - v^T F v`, with :math:`\dot v` from
       :func:`unidyn.model.unicycle.dynamics` (Eq. 2), is met to rounding on every sample,
       and :math:`v^T F v \ge \lambda_{min} \|v\|^2` on every sample.

    :param robot: a preset name (:func:`unidyn.model.robots.names`), a
        :class:`~unidyn.RobotParameters`, six numbers or a ``.json`` file
    :param u_max: linear-speed range, m/s, > 0; default: the paper's limit
        (:data:`unidyn.model.robots.SPEED_LIMITS`, Section 3.2) for a preset that has
        one, else :data:`DEFAULT_U_MAX` = 1.2 m/s
    :type u_max: float or None
    :param w_max: angular-speed range of the grid, rad/s, > 0 (default 1.745 rad/s)
    :type w_max: float
    :param n: grid points per axis, integer in [2, 1001]
    :type n: int
    :param constant_tolerance: threshold of property 6's ratio, > 0 (default 0.1)
    :type constant_tolerance: float
    :param seed: seed of the commands' generator, integer >= 0
    :type seed: int
    :return: :class:`PropertyReport`
    :raises ValidationError: for an unknown robot or an argument out of range
    """
    params = robots.resolve(robot, "robot")
    if u_max is None:
        u_max, source = _default_u_max(params)
    else:
        u_max = positive("u_max", u_max)
        source = "given"
    w_max = positive("w_max", w_max)
    n = integer("n", n, 2, 1001)
    tol6 = positive("constant_tolerance", constant_tolerance)
    seed = integer("seed", seed, 0)

    theta = params.theta
    t1, t2, t3, t4, t5, t6 = theta
    uu, ww = np.meshgrid(np.linspace(-u_max, u_max, n), np.linspace(-w_max, w_max, n),
                         indexing="ij")
    v = np.stack([uu.ravel(), ww.ravel()], axis=-1)                 # (N, 2)
    N = v.shape[0]
    rng = np.random.default_rng(seed)
    v_ref = rng.uniform(-2.0, 2.0, size=(N, 2)) * np.array([u_max, w_max])

    H = unicycle.inertia(theta)
    Cv = unicycle.coriolis(v, theta)                                    # (N, 2, 2)
    Fv = unicycle.damping(v, theta)                                     # (N, 2, 2)
    results = []

    # 1. H = H^T > 0
    asym = float(np.max(np.abs(H - H.T)))
    lam_H = float(np.min(np.linalg.eigvalsh(H)))
    results.append(PropertyResult(
        1, _NAMES[1], bool(asym == 0.0 and lam_H > 0), lam_H,
        f"min eig(H) = {lam_H:.6g} s, ||H - H^T|| = {asym:.3g}"))

    # 2. H^-1 exists and is > 0
    try:
        Hinv = np.linalg.inv(H)
        inv_err = float(np.max(np.abs(H @ Hinv - np.eye(2))))
        inv_asym = float(np.max(np.abs(Hinv - Hinv.T)))
        lam_Hinv = float(np.min(np.linalg.eigvalsh(Hinv)))
        ok2 = bool(inv_err <= _RTOL and inv_asym <= _RTOL * np.max(np.abs(Hinv)) and lam_Hinv > 0)
        det2 = (f"min eig(H^-1) = {lam_Hinv:.6g} 1/s, ||H H^-1 - I|| = {inv_err:.3g}, "
                f"||H^-1 - H^-T|| = {inv_asym:.3g}")
    except np.linalg.LinAlgError:  # pragma: no cover - theta1, theta2 > 0 by construction
        lam_Hinv, ok2, det2 = float("-inf"), False, "H is singular"
    results.append(PropertyResult(2, _NAMES[2], ok2, lam_Hinv, det2))

    # 3. F = F^T > 0 over |u| <= u_max
    f22 = Fv[:, 1, 1]
    f_asym = float(np.max(np.abs(Fv - np.swapaxes(Fv, -1, -2))))
    m3 = float(np.min(f22))
    u_at = float(v[int(np.argmin(f22)), 0])
    ok3 = bool(m3 > 0 and t4 > 0 and f_asym == 0.0)
    results.append(PropertyResult(
        3, _NAMES[3], ok3, m3,
        f"min theta6 + (theta5 - theta3) u = {m3:.6g} at u = {u_at:+.4g} m/s "
        f"(theta5 - theta3 = {t5 - t3:.6g} s/m); theta4 = {t4:.6g}"))

    # 4. H constant: the matrix multiplying v' in Eq. 6 at every grid velocity
    zero = unicycle.inverse_dynamics(v, np.zeros_like(v), theta)
    cols = [unicycle.inverse_dynamics(v, np.broadcast_to(e, v.shape), theta) - zero
            for e in np.eye(2)]
    H_id = np.stack(cols, axis=-1)                                    # (N, 2, 2)
    dev4 = float(np.max(np.abs(H_id - H)))
    ok4 = bool(dev4 <= _RTOL * max(1.0, float(np.max(np.abs(zero)))))
    results.append(PropertyResult(
        4, _NAMES[4], ok4, dev4,
        f"max |dv_ref/dv' - H| over the grid = {dev4:.3g} (H depends on theta only; "
        "constant while the physical parameters do not change)"))

    # 5. C skew-symmetric
    vCv = np.einsum("ni,nij,nj->n", v, Cv, v)
    m5 = float(np.max(np.abs(vCv)))
    skew = float(np.max(np.abs(Cv + np.swapaxes(Cv, -1, -2))))
    scale5 = max(1.0, abs(t3) * w_max * float(np.max(np.abs(v))) ** 2)
    ok5 = bool(skew == 0.0 and m5 <= _RTOL * scale5)
    results.append(PropertyResult(
        5, _NAMES[5], ok5, m5,
        f"max |v^T C v| = {m5:.3g}, max ||C + C^T|| = {skew:.3g}"))

    # 6. F approximately constant: theta6 >> |(theta5 - theta3) u|
    ratio = float(np.max(np.abs(f22 - t6)) / t6)
    ok6 = bool(ratio < tol6)
    word = "approximately constant" if ok6 else "not approximately constant"
    results.append(PropertyResult(
        6, _NAMES[6], ok6, ratio,
        f"max |(theta5 - theta3) u| / theta6 = {ratio:.4g} ({word}; threshold {tol6:g})"))

    # 7. strict output passivity (Theorem 1)
    lam_F = np.linalg.eigvalsh(Fv)                                    # (N, 2)
    m7 = float(np.min(lam_F))
    vdot = unicycle.dynamics(v, v_ref, theta)
    Vdot = np.einsum("ni,ij,nj->n", v, H, vdot)
    # the same derivative from the storage function, by an exact central difference
    h = 0.5
    Vdot_s = (unicycle.storage(v + h * vdot, theta) - unicycle.storage(v - h * vdot, theta)) / (2 * h)
    supply = np.einsum("ni,ni->n", v, v_ref)
    dissip = np.einsum("ni,nij,nj->n", v, Fv, v)
    scale7 = max(1.0, float(np.max(np.abs(supply))), float(np.max(np.abs(dissip))))
    resid = float(max(np.max(np.abs(Vdot - (supply - dissip))),
                      np.max(np.abs(Vdot_s - (supply - dissip)))) / scale7)
    vv = np.einsum("ni,ni->n", v, v)
    ineq = bool(np.all(dissip >= m7 * vv - _RTOL * scale7))
    ok7 = bool(ok3 and resid <= _RTOL and ineq)
    results.append(PropertyResult(
        7, _NAMES[7], ok7, m7,
        f"inf lambda_min(F) = {m7:.6g}; V' = v^T v_ref - v^T F v to {resid:.2g} (relative)"
        + ("" if ok3 else "; property 3 fails, F is not > 0 over the range")))

    return PropertyReport(
        robot=params.name, theta=tuple(float(x) for x in theta), u_max=float(u_max),
        w_max=float(w_max), u_max_source=source, results=tuple(results),
        power_balance_residual=resid, samples=int(N))


# ----------------------------------------------------------------------------- rank test

#: Uniform sampling ranges (low, high) of the physical parameters of
#: :meth:`unidyn.RobotParameters.from_physical` used by :func:`rank_test`. They
#: span robots from a Khepera III (0.69 kg) to a wheelchair carrying a person:
#: m kg, Iz kg·m², Ra Ohm, ka N·m/A, kb V·s/rad, Be N·m·s/rad, Ie kg·m², r m,
#: b m (either sign), d m, kPT and kPR (servo proportional gains, > 0), kDT and
#: kDR (servo derivative gains, >= 0).
PHYSICAL_RANGES = {
    "m": (0.5, 150.0),
    "Iz": (0.001, 20.0),
    "Ra": (0.5, 10.0),
    "ka": (0.01, 0.5),
    "kb": (0.01, 0.5),
    "Be": (0.0, 0.1),
    "Ie": (1e-5, 0.05),
    "r": (0.02, 0.2),
    "b": (-0.2, 0.2),
    "d": (0.05, 0.7),
    "kPT": (1.0, 200.0),
    "kPR": (1.0, 200.0),
    "kDT": (0.0, 10.0),
    "kDR": (0.0, 10.0),
}
# strictly positive in from_physical; the others are >= 0 except b
_STRICT = {"m", "Ra", "ka", "r", "d", "kPT", "kPR"}
_ANY_SIGN = {"b"}


@dataclass(frozen=True)
class RankTestResult:
    """The outcome of :func:`rank_test` (Section 3 of the paper).

    :param K: number of random physical parameter sets (rows)
    :param seed: seed of the generator (None: unseeded)
    :param ranks: rank of the normalised, truncated K x 6 matrix for each
        number of decimals kept
    :param ranges: the sampling ranges used, name -> (low, high)
    """

    K: int
    seed: int | None
    ranks: dict = field(hash=False)
    ranges: dict = field(hash=False, repr=False)

    @property
    def full_rank(self) -> bool:
        """True when the rank is 6 for every truncation (theta1..theta6 independent)."""
        return all(r == 6 for r in self.ranks.values())

    def as_dict(self) -> dict:
        """The result as plain Python types (for JSON)."""
        return {"K": self.K, "seed": self.seed, "full_rank": self.full_rank,
                "ranks": {str(d): int(r) for d, r in self.ranks.items()},
                "ranges": {k: [float(lo), float(hi)] for k, (lo, hi) in self.ranges.items()}}

    def __str__(self) -> str:
        lines = [f"Linear independence of theta1..theta6 (Martins et al. 2017, Section 3): "
                 f"K = {self.K} random physical parameter sets, seed = {self.seed}"]
        for d, r in self.ranks.items():
            lines.append(f"  truncated to {d} decimals: rank {r} of 6")
        lines.append("full rank: the six parameters are linearly independent" if self.full_rank
                     else "rank deficient for some truncation")
        return "\n".join(lines)


def _check_ranges(ranges) -> dict:
    out = dict(PHYSICAL_RANGES)
    if ranges is None:
        return out
    if not isinstance(ranges, dict):
        raise ValidationError(f"ranges must be a dict name -> (low, high), got {ranges!r}")
    for k, val in ranges.items():
        if k not in PHYSICAL_RANGES:
            raise ValidationError(
                f"ranges: unknown physical parameter {k!r}; known: {', '.join(PHYSICAL_RANGES)}")
        try:
            lo, hi = (float(x) for x in val)
        except (TypeError, ValueError):
            raise ValidationError(f"ranges[{k!r}] must be a pair (low, high), got {val!r}") from None
        if not (np.isfinite(lo) and np.isfinite(hi)) or lo > hi:
            raise ValidationError(
                f"ranges[{k!r}] must be finite with low <= high, got ({lo!r}, {hi!r})")
        if k in _STRICT and lo <= 0:
            raise ValidationError(f"ranges[{k!r}] low must be > 0, got {lo!r}")
        if k not in _STRICT and k not in _ANY_SIGN and lo < 0:
            raise ValidationError(f"ranges[{k!r}] low must be >= 0, got {lo!r}")
        out[k] = (lo, hi)
    return out


def _check_decimals(decimals) -> tuple:
    if isinstance(decimals, Integral) and not isinstance(decimals, bool):
        decimals = (decimals,)
    try:
        items = tuple(decimals)
    except TypeError:
        raise ValidationError(
            f"decimals must be a positive integer or a sequence of them, got {decimals!r}") from None
    if not items:
        raise ValidationError("decimals must hold at least one positive integer, got ()")
    for d in items:
        if isinstance(d, bool) or not isinstance(d, Integral) or d < 1 or d > 15:
            raise ValidationError(
                f"decimals must be positive integers in [1, 15], got {decimals!r}")
    return tuple(int(d) for d in items)


def rank_test(K: int = 1000, decimals=(2, 3, 4), seed: int | None = 0,
              ranges: dict | None = None) -> RankTestResult:
    r"""The linear-independence test of theta1..theta6 (Section 3 of the paper).

    Draws ``K`` physical parameter sets uniformly from ``ranges`` (default
    :data:`PHYSICAL_RANGES`; units there) with ``numpy.random.default_rng(seed)``,
    computes theta for each with :meth:`unidyn.RobotParameters.from_physical`
    (the formulas of Section 2), stacks them into the K x 6 matrix
    :math:`[\theta_j(k)]`, divides each column by its largest absolute value,
    truncates (towards zero, not rounding) every entry to ``d`` decimal digits for
    each ``d`` in ``decimals`` and takes :func:`numpy.linalg.matrix_rank`. The
    paper reports rank 6 for K = 1000 and K = 5000 at 4, 3 and 2 decimals.

    :param K: number of random parameter sets, integer in [6, 1000000]
    :type K: int
    :param decimals: numbers of decimal digits kept, positive integers (<= 15)
    :type decimals: int or sequence of int
    :param seed: generator seed, integer >= 0, or None for fresh entropy
    :type seed: int or None
    :param ranges: overrides of :data:`PHYSICAL_RANGES`, name -> (low, high)
    :type ranges: dict or None
    :return: :class:`RankTestResult`
    :raises ValidationError: for an argument out of range
    """
    K = integer("K", K, 6, 1_000_000)
    decs = _check_decimals(decimals)
    if seed is not None:
        seed = integer("seed", seed, 0)
    rngs = _check_ranges(ranges)

    gen = np.random.default_rng(seed)
    names = list(PHYSICAL_RANGES)
    lows = np.array([rngs[k][0] for k in names])
    highs = np.array([rngs[k][1] for k in names])
    draws = gen.uniform(lows, highs, size=(K, len(names)))
    T = np.empty((K, 6))
    for i, row in enumerate(draws):
        T[i] = RobotParameters.from_physical(**dict(zip(names, row.tolist()))).theta

    colmax = np.max(np.abs(T), axis=0)
    colmax[colmax == 0] = 1.0          # an all-zero column (e.g. b fixed at 0) stays zero
    Tn = T / colmax
    ranks = {}
    for d in decs:
        s = 10.0 ** d
        ranks[d] = int(np.linalg.matrix_rank(np.trunc(Tn * s) / s))
    return RankTestResult(K=K, seed=seed, ranks=ranks, ranges=rngs)
