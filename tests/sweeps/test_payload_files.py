"""The payload schedule in scenario and sweep files and on the command line's --set."""

import pytest

from unidyn import ValidationError
from unidyn.sweeps.sweep import Sweep
from unidyn.sweeps.sweep_files import parse_toml_value, read_scenario_table, scenario_from_layers

SWEEP = '''
name = "load mass"
[base]
case = "adaptive"
T = 20.0
noise = "off"
[grid]
payload = [[[10.0, 1.0]], [[10.0, 2.0]], [[5.0, 1.5], [10.0, 3.0]]]
'''


def test_sweep_file_grid_over_schedules(tmp_path):
    path = tmp_path / "sweep.toml"
    path.write_text(SWEEP)
    points = Sweep.from_toml(path).points()
    assert [p.scenario.payload for p in points] == [
        ((10.0, 1.0),), ((10.0, 2.0),), ((5.0, 1.5), (10.0, 3.0))]


def test_bad_schedule_in_a_sweep_file_names_the_field(tmp_path):
    path = tmp_path / "sweep.toml"
    path.write_text(SWEEP.replace("[[10.0, 2.0]]", "[[10.0, 2.0], [3.0, 1.0]]"))
    with pytest.raises(ValidationError, match="payload: a schedule's times increase") as err:
        Sweep.from_toml(path).points()
    assert "\n" not in str(err.value)


def test_scenario_file_and_set(tmp_path):
    path = tmp_path / "sc.toml"
    path.write_text('case = "compensated"\npayload = [[100.0, 2.0]]\n')
    table = read_scenario_table(path)
    sc = scenario_from_layers([("file", table)])
    assert sc.payload == ((100.0, 2.0),)
    sc = scenario_from_layers([("file", table),
                               ("--set", {"payload": parse_toml_value("[[50, 1.5]]")})])
    assert sc.payload == ((50.0, 1.5),)
    with pytest.raises(ValidationError, match=r"--set.*payload\[0\] mass scale must be > 0"):
        scenario_from_layers([("file", table), ("--set", {"payload": [[50, -1]]})])
