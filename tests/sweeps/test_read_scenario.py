"""unidyn.read_scenario: a scenario file as unidyn run reads it."""

from pathlib import Path

import pytest

import unidyn
from unidyn import Scenario, ValidationError
from unidyn.model.trajectories import Circle

EXAMPLE = Path(__file__).resolve().parents[2] / "examples" / "scenario.toml"


def test_the_example_file_gives_the_scenario_it_writes():
    sc = unidyn.read_scenario(EXAMPLE)
    want = Scenario(name="adaptive on a circle", case="adaptive", robot="p3dx_laser", a=0.2,
                    x0=(1.2, 0.0, 1.5708), T=30.0, kx=0.5, ky=0.5, adapt_from=0.0,
                    trajectory=Circle(radius=1.0, omega=0.2, center=(0.0, 0.0), phase=0.0),
                    noise={"position_std": 0.01, "velocity_std": 0.0141, "seed": 0})
    assert sc == want


def test_fields_under_a_scenario_table_and_the_sweep_keys(tmp_path):
    f = tmp_path / "s.toml"
    f.write_text('[scenario]\ncase = "compensated"\nT = 20.0\nkxy = 0.7\n'
                 'theta_hat_scale = 0.9\n', encoding="utf-8")
    sc = unidyn.read_scenario(str(f))
    assert (sc.case, sc.T, sc.kx, sc.ky) == ("compensated", 20.0, 0.7, 0.7)
    assert sc.theta_hat0 == sc.robot.scaled(0.9)


def test_a_bad_field_is_named_with_the_file(tmp_path):
    f = tmp_path / "bad.toml"
    f.write_text("kx = -1\n", encoding="utf-8")
    with pytest.raises(ValidationError) as err:
        unidyn.read_scenario(f)
    msg = str(err.value)
    assert str(f) in msg and "kx" in msg and "\n" not in msg


def test_an_unknown_field_and_malformed_toml_are_refused(tmp_path):
    f = tmp_path / "typo.toml"
    f.write_text("kxx = 1\n", encoding="utf-8")
    with pytest.raises(ValidationError, match="did you mean 'kx'"):
        unidyn.read_scenario(f)
    f.write_text("robot = p3dx\n", encoding="utf-8")
    with pytest.raises(ValidationError, match="malformed TOML"):
        unidyn.read_scenario(f)


def test_a_missing_file_is_named(tmp_path):
    with pytest.raises(FileNotFoundError, match="nothing.toml"):
        unidyn.read_scenario(tmp_path / "nothing.toml")
