"""Identification from logs as real robots write them (unidyn.identification).

A robot's firmware holds each command from its time stamp until the next one,
its odometry arrives at 10-50 Hz, logs have gaps, several logs of one robot
exist, and CSV files come in odd encodings. The logs here are made by a
reference simulator written in this file, independent of the library: Eq. (2)
integrated by ``scipy.integrate.solve_ivp`` (DOP853, rtol 1e-10) restarted at
every instant where the command changes, with the command constant (held) or
linear in between, optionally delayed. The robots are not presets: their theta
comes from physical parameters (``RobotParameters.from_physical``):

* ``hauler``: 90 kg, centre of mass 0.3 m ahead of the axle, soft wheel servos:
  theta = (0.146, 0.203, 0.030, 1.220, 0.240, 1.110), time constants
  theta1/theta4 = 0.12 s and theta2/theta6 = 0.18 s (under two samples at 10 Hz);
  sizeable theta3 and theta5.
* ``cart``: 30 kg, centre of mass 5 cm ahead: theta = (0.269, 0.252, 0.0011,
  1.047, 0.0068, 1.008); theta3 and theta5 too small to identify from 120 s.

Velocity noise std 0.01 (m/s, rad/s), 120 s multisine logs from ``excitation``.
The noise-free response of each log is simulated once and the noise seeds vary.
"""

from __future__ import annotations

import functools

import numpy as np
import pytest
from test_identification import identify  # warnings asserted, not printed

from unidyn import RobotParameters, ValidationError
from unidyn import identification as ident
from unidyn.identification.replay import simulate_held

NOISE = 0.01
T = 120.0
ROBOTS = {
    "hauler": RobotParameters.from_physical(
        m=90.0, Iz=8.0, b=0.3, d=0.5, r=0.15, Ra=0.4, ka=0.9, kb=0.9, Be=0.2, Ie=0.02,
        kPT=30.0, kDT=3.0, kPR=15.0, kDR=2.0, name="hauler"),
    "cart": RobotParameters.from_physical(
        m=30.0, Iz=1.2, b=0.05, d=0.33, r=0.0975, Ra=0.71, ka=0.461, kb=0.461, Be=0.0,
        Ie=0.0027, kPT=100.0, kDT=16.0, kPR=100.0, kDR=16.0, name="cart"),
}
POSITIVE = [0, 1, 3, 5]


def reference_velocities(theta, t, u_ref, w_ref, v0=(0.0, 0.0), delay=0.0, linear=False):
    """u, w of Eq. (2) at the times t; the command stamped t_k acts from t_k + delay,
    held until the next (or linear towards it); solve_ivp restarted at every change."""
    from scipy.integrate import solve_ivp
    t1, t2, t3, t4, t5, t6 = theta
    brk = np.union1d(t, t[t + delay < t[-1]] + delay)
    out = np.empty((t.size, 2))
    out[0] = v0
    v = np.array(v0, dtype=float)
    k = 1
    for a, b in zip(brk[:-1], brk[1:]):
        j = max(int(np.searchsorted(t, a - delay + 1e-9 * (b - a), side="right")) - 1, 0)
        if linear and j + 1 < t.size and a - delay >= t[0]:
            s = 1.0 / (t[j + 1] - t[j])
            cu = lambda tt, j=j, s=s: u_ref[j] + (u_ref[j + 1] - u_ref[j]) * (tt - delay - t[j]) * s
            cw = lambda tt, j=j, s=s: w_ref[j] + (w_ref[j + 1] - w_ref[j]) * (tt - delay - t[j]) * s
        else:
            cu = lambda tt, j=j: u_ref[j]
            cw = lambda tt, j=j: w_ref[j]

        def rhs(tt, x, cu=cu, cw=cw):
            u, w = x
            return [(t3 * w * w - t4 * u + cu(tt)) / t1, (-t5 * u * w - t6 * w + cw(tt)) / t2]

        v = solve_ivp(rhs, (a, b), v, method="DOP853", rtol=1e-10, atol=1e-12).y[:, -1]
        while k < t.size and t[k] <= b + 1e-9 * (b - a):
            out[k] = v
            k += 1
    return out


@functools.lru_cache(maxsize=None)
def clean_log(robot, dt, seed=0, delay=0.0, linear=False, T=T):
    rp = ROBOTS[robot]
    exc = ident.excitation(T, dt, robot=rp, seed=seed)
    v = reference_velocities(rp.theta, exc["t"], exc["u_ref"], exc["w_ref"], delay=delay,
                             linear=linear)
    return {"t": exc["t"], "u_ref": exc["u_ref"], "w_ref": exc["w_ref"], "u": v[:, 0],
            "w": v[:, 1]}


def noisy(log, seed, std=NOISE):
    rng = np.random.default_rng(1000 + seed)
    n = log["t"].size
    return {**log, "u": log["u"] + std * rng.standard_normal(n),
            "w": log["w"] + std * rng.standard_normal(n)}


def rel_err(res, robot):
    truth = ROBOTS[robot].theta
    return (res.theta.theta - truth) / np.abs(truth)


# ------------------------------------------------------------------ the simulator

def test_compiled_simulation_matches_the_reference_held_linear_and_delayed():
    rp = ROBOTS["hauler"]
    exc = ident.excitation(20.0, 0.1, robot=rp, seed=3)
    t, ur, wr = exc["t"], exc["u_ref"], exc["w_ref"]
    for linear, delay in ((False, 0.0), (True, 0.0), (False, 0.13), (True, 0.05)):
        ref = reference_velocities(rp.theta, t, ur, wr, v0=(0.1, -0.2), delay=delay,
                                   linear=linear)
        got = simulate_held(rp.theta, t, ur, wr, [(0, t.size)], [[0.1, -0.2]], delay,
                                   linear)
        np.testing.assert_allclose(got, ref, atol=2e-7, err_msg=f"{linear=} {delay=}")
    # and the library's own log simulator (scipy's DOP853 restarted per sample)
    log = ident.simulate_log(rp, exc, commands="held", delay=0.13)
    ref = reference_velocities(rp.theta, t, ur, wr, delay=0.13)
    np.testing.assert_allclose(np.stack([log["u"], log["w"]], axis=1), ref, atol=1e-8)


# ------------------------------------------------------------------ accuracy

@pytest.mark.parametrize("dt,tol", [(0.1, 0.04), (0.05, 0.02), (0.02, 0.02)])
def test_held_commands_identified_within_the_targets(dt, tol):
    """10 Hz: theta1, 2, 4, 6 within 4 % on average over seeds; 20 and 50 Hz: 2 %."""
    errs, zs = [], []
    for seed in range(3):
        res = identify(noisy(clean_log("hauler", dt), seed), validate=False,
                       check_commands=False)
        errs.append(rel_err(res, "hauler"))
        zs.append((res.theta.theta - ROBOTS["hauler"].theta) / res.stderr)
        assert res.commands == "held" and res.delay == 0.0
    mean = np.mean(np.abs(errs), axis=0)
    assert np.all(mean[POSITIVE] < tol), f"mean relative errors {mean}"
    # the coupling terms are identified too (large here), and the intervals are honest
    assert np.all(mean[[2, 4]] < 0.15), f"theta3, theta5: {mean[[2, 4]]}"
    assert np.all(np.abs(zs) < 4.0), f"errors in standard errors {np.round(zs, 2)}"


def test_fast_time_constant_at_10_hz_is_warned_but_estimated():
    with pytest.warns(ident.IdentificationWarning, match="shorter than two sampling"):
        res = ident.identify(noisy(clean_log("hauler", 0.1), 0), validate=False,
                             check_commands=False)
    text = " ".join(res.warnings)
    assert "theta1/theta4" in text and "shorter than two sampling intervals" in text
    assert np.all(np.abs(rel_err(res, "hauler"))[POSITIVE] < 0.06)


def test_unidentifiable_coupling_terms_are_flagged():
    with pytest.warns(ident.IdentificationWarning, match="theta[35] is unidentified"):
        res = ident.identify(noisy(clean_log("cart", 0.1), 0), validate=False,
                             check_commands=False)
    text = " ".join(res.warnings)
    assert "theta3 is unidentified" in text and "theta5 is unidentified" in text
    assert np.all(np.abs(rel_err(res, "cart"))[POSITIVE] < 0.04)


# ------------------------------------------------------------------ the wrong convention

def test_wrong_convention_is_biased_and_warned():
    log = noisy(clean_log("hauler", 0.1), 0)
    right = identify(log, validate=False)
    wrong = identify(log, commands="linear", validate=False)
    # the old estimator's mistake: held commands read as smooth lag half a sample,
    # which adds about theta4 dt / 2 to theta1 (+40 % here)
    bias = 1.220 * 0.05 / 0.146
    assert rel_err(wrong, "hauler")[0] == pytest.approx(bias, rel=0.35)
    assert any("commands='held'" in w for w in wrong.warnings), wrong.warnings
    assert not any("commands='linear'" in w for w in right.warnings), right.warnings
    ee = identify(log, method="equation-error", validate=False)
    assert any("method='output-error'" in w for w in ee.warnings)


def test_linear_commands_identified_with_the_linear_convention():
    log = noisy(clean_log("cart", 0.05, linear=True), 1)
    res = identify(log, commands="linear", validate=False)
    assert np.all(np.abs(rel_err(res, "cart"))[POSITIVE] < 0.02)
    held = identify(log, validate=False)
    assert any("commands='linear'" in w for w in held.warnings), held.warnings


def test_input_delay_is_estimated():
    log = noisy(clean_log("cart", 0.05, delay=0.05), 2)     # one sample late
    res = identify(log, delay="auto", validate=False, check_commands=False)
    assert res.delay == pytest.approx(0.05, abs=0.01)
    assert 0 < res.delay_stderr < 0.01
    assert np.all(np.abs(rel_err(res, "cart"))[POSITIVE] < 0.02)
    given = identify(log, delay="1 samples", validate=False, check_commands=False)
    assert given.delay == pytest.approx(0.05, rel=1e-9)
    np.testing.assert_allclose(given.theta.theta[POSITIVE], res.theta.theta[POSITIVE], rtol=0.02)
    # ignoring the delay leaves coloured errors, which is said
    late = identify(log, validate=False)
    assert any("not white" in w for w in late.warnings), late.warnings


# ------------------------------------------------------------------ gaps and several logs

def test_a_gap_splits_the_log_and_does_not_bias():
    log = noisy(clean_log("hauler", 0.05), 3)
    keep = (log["t"] < 50.0) | (log["t"] >= 60.0)          # 10 s without samples
    cut = {k: v[keep] for k, v in log.items()}
    res = identify(cut, validate=False, check_commands=False)
    assert res.segments == 2
    assert np.all(np.abs(rel_err(res, "hauler"))[POSITIVE] < 0.03)
    # integrating across the gap as if it were one sample interval is what biased it
    one = identify(cut, gap=20.0, validate=False, check_commands=False)
    assert one.segments == 1
    assert np.max(np.abs(rel_err(one, "hauler"))[POSITIVE]) > \
        2 * np.max(np.abs(rel_err(res, "hauler"))[POSITIVE])


def test_several_logs_are_identified_together(tmp_path):
    a = noisy(clean_log("cart", 0.1), 4)
    b = noisy(clean_log("cart", 0.1, seed=1, T=60.0), 5)
    b = {**b, "t": b["t"] + 1000.0}
    one = identify(a, validate=False, check_commands=False)
    both = identify(a, b, validate=False, check_commands=False)
    assert both.n_logs == 2 and both.segments == 2 and both.n_samples == a["t"].size + \
        b["t"].size
    assert np.all(np.abs(rel_err(both, "cart"))[POSITIVE] < 0.04)
    assert np.all(both.stderr[POSITIVE] < one.stderr[POSITIVE])
    # the order of the logs does not matter; files work as well as arrays
    rev = identify(b, a, validate=False, check_commands=False)
    np.testing.assert_allclose(rev.theta.theta, both.theta.theta, rtol=1e-5, atol=1e-7)
    paths = []
    for i, lg in enumerate((a, b)):
        p = tmp_path / f"log{i}.csv"
        np.savetxt(p, np.column_stack([lg[k] for k in ident.COLUMNS]), delimiter=",",
                   header=",".join(ident.COLUMNS), comments="", fmt="%.17g")
        paths.append(str(p))
    np.testing.assert_allclose(identify(*paths, validate=False,
                                        check_commands=False).theta.theta,
                               both.theta.theta, rtol=1e-9)


# ------------------------------------------------------------------ files as they come

def _write(path, log, encoding="utf-8", sep=",", header=None, extra=True, comment=False):
    names = header or list(ident.COLUMNS)
    lines = []
    if comment:
        lines.append("# odometry log, vitesse m/s, café")
    lines.append(sep.join(names + (["remarque é"] if extra else [])))
    for k in range(log["t"].size):
        row = [repr(float(log[c][k])) for c in ident.COLUMNS]
        lines.append(sep.join(row + (["café ok"] if extra else [])))
    path.write_bytes(("\n".join(lines) + "\n").encode(encoding))
    return path


@pytest.fixture(scope="module")
def short_log():
    lg = noisy(clean_log("cart", 0.1), 6)
    return {k: v[:400] for k, v in lg.items()}


@pytest.mark.parametrize("encoding,sep", [("utf-8", ","), ("utf-8-sig", ","),
                                          ("latin-1", ","), ("cp1252", ";"),
                                          ("utf-16", "\t")])
def test_encodings_separators_comments_and_extra_columns(tmp_path, short_log, encoding, sep):
    ref = ident.load_log(short_log)
    p = _write(tmp_path / "log.csv", short_log, encoding=encoding, sep=sep, comment=True)
    got = ident.load_log(str(p))
    for k in ident.COLUMNS:
        np.testing.assert_array_equal(got[k], ref[k])


def test_bom_header_identifies_without_options(tmp_path, short_log):
    p = _write(tmp_path / "log.csv", short_log, encoding="utf-8-sig")
    assert p.read_bytes().startswith(b"\xef\xbb\xbft,")
    res = identify(str(p), validate=False, check_commands=False)
    np.testing.assert_allclose(res.theta.theta, identify(
        short_log, validate=False, check_commands=False).theta.theta, rtol=1e-12)


def test_undecodable_bytes_and_bad_cells_name_file_line_and_column(tmp_path, short_log):
    p = _write(tmp_path / "log.csv", short_log)
    lines = p.read_bytes().split(b"\n")
    lines[7] = lines[7] + b"\x81\x8d"            # neither UTF-8 nor Windows-1252
    bad = tmp_path / "bytes.csv"
    bad.write_bytes(b"\n".join(lines))
    with pytest.raises(ValidationError, match=r"bytes.csv line 8: bytes .* are not text"):
        ident.load_log(str(bad))
    text = p.read_text().splitlines()
    cells = text[12].split(",")
    cells[3] = "n/a"
    text[12] = ",".join(cells)
    bad = tmp_path / "cell.csv"
    bad.write_text("\n".join(text))
    with pytest.raises(ValidationError, match=r"cell.csv line 13, column 'u': 'n/a' is not a "
                                              r"number"):
        ident.load_log(str(bad))
    # a non-number in a column nobody asked for is no error
    text = p.read_text().splitlines()
    cells = text[14].split(",")
    cells[5] = "???"
    text[14] = ",".join(cells)
    ok = tmp_path / "extra.csv"
    ok.write_text("\n".join(text))
    assert ident.load_log(str(ok))["t"].size == short_log["t"].size
    short = tmp_path / "short.csv"
    short.write_text("t,u_ref,w_ref,u,w\n0,0,0,0,0\n0.1,0,0\n")
    with pytest.raises(ValidationError, match=r"short.csv line 3 has 3 field\(s\); column 'w'"):
        ident.load_log(str(short))


def test_missing_column_error_names_what_the_log_has(tmp_path, short_log):
    p = _write(tmp_path / "log.csv", short_log, header=["time", "u_ref", "w_ref", "u", "w"])
    with pytest.raises(ident.MissingColumnsError, match=r"missing column\(s\) 't'; it has "
                                                        r"'time', 'u_ref'") as info:
        ident.load_log(str(p))
    assert info.value.missing == ("t",) and "columns=" not in str(info.value)
    assert ident.load_log(str(p), columns={"t": "time"})["t"].size == short_log["t"].size


# ------------------------------------------------------------------ validation

def test_validate_false_skips_it_and_validation_is_the_model_response(short_log):
    res = identify(short_log, validate=False, check_commands=False)
    assert res.validation is None
    res = identify(short_log, check_commands=False)
    rep = res.validation
    clean = {k: v[:400] for k, v in clean_log("cart", 0.1).items()}
    ref = reference_velocities(res.theta.theta, clean["t"], clean["u_ref"], clean["w_ref"],
                               v0=(short_log["u"][0], short_log["w"][0]))
    np.testing.assert_allclose(np.stack([rep.u_sim, rep.w_sim], axis=1), ref, atol=1e-7)
    assert rep.rmse["u"] == pytest.approx(NOISE, rel=0.25)
    assert "in-sample simulation fit" in res.summary()


def test_validation_splits_at_gaps_and_restarts_from_the_measurement():
    lg = clean_log("cart", 0.1)
    keep = (lg["t"] < 30.0) | (lg["t"] >= 40.0)
    cut = {k: v[keep] for k, v in lg.items()}
    rep = ident.validate(ROBOTS["cart"], cut)
    # noise-free log, true theta: the simulation is the log itself in both pieces
    assert rep.rmse["u"] < 1e-6 and rep.rmse["w"] < 1e-6
    joined = ident.validate(ROBOTS["cart"], cut, gap=100.0)
    assert joined.rmse["u"] > 100 * rep.rmse["u"]


def test_bad_arguments_name_the_parameter(short_log):
    for kwargs, msg in (({"commands": "zoh"}, "commands"), ({"delay": -1}, "delay"),
                        ({"delay": "soon"}, "delay"), ({"method": "x"}, "method"),
                        ({"validate": "no"}, "validate"), ({"gap": 0}, "gap")):
        with pytest.raises(ValidationError, match=msg):
            identify(short_log, **kwargs)


# ------------------------------------------------------------------ coverage (slow tier)

@pytest.mark.slow
@pytest.mark.parametrize("dt", [0.1, 0.02])
def test_95_percent_intervals_cover_the_truth_at_least_85_percent_of_the_time(dt):
    """40 noise seeds on one held-command log of the hauler (all six identifiable)."""
    truth = ROBOTS["hauler"].theta
    covered, z = [], []
    for seed in range(40):
        res = identify(noisy(clean_log("hauler", dt), 100 + seed), validate=False,
                       check_commands=False)
        assert not any("unidentified" in w for w in res.warnings), res.warnings
        covered.append((res.ci95[:, 0] <= truth) & (truth <= res.ci95[:, 1]))
        z.append((res.theta.theta - truth) / res.stderr)
    rate = np.mean(covered, axis=0)
    assert np.all(rate >= 0.85), f"coverage {rate}"
    # the standard errors are the spread of the estimates, neither far too small nor large
    spread = np.std(z, axis=0)
    assert np.all((spread > 0.7) & (spread < 1.3)), f"std of the errors in stderrs {spread}"
