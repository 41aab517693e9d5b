"""The exceptions a user meets are public: importable as ``unidyn.<Name>`` and shown
under that name in a traceback, while ``unidyn._errors`` stays importable."""

import pickle
import subprocess
import sys
import traceback

import pytest

import unidyn
from unidyn import _errors


@pytest.mark.parametrize("cls", _errors.PUBLIC, ids=lambda c: c.__name__)
def test_each_exception_is_unidyn_name(cls):
    assert getattr(unidyn, cls.__name__) is cls and cls.__name__ in unidyn.__all__
    assert f"{cls.__module__}.{cls.__qualname__}" == f"unidyn.{cls.__name__}"


def test_a_raised_error_reads_unidyn_validationerror_and_survives_pickling():
    with pytest.raises(unidyn.ValidationError) as info:
        unidyn.Scenario(T=-1)
    shown = traceback.format_exception_only(info.type, info.value)[-1]
    assert shown.startswith("unidyn.ValidationError: T must be > 0"), shown
    again = pickle.loads(pickle.dumps(info.value))
    assert type(again) is unidyn.ValidationError and str(again) == str(info.value)
    err = pickle.loads(pickle.dumps(unidyn.Interrupted("3 of 8 points kept")))
    assert type(err) is unidyn.Interrupted and err.kept == "3 of 8 points kept"


@pytest.mark.slow
def test_an_uncaught_error_in_a_script_names_unidyn_validationerror():
    p = subprocess.run([sys.executable, "-c", "import unidyn; unidyn.Scenario(T=-1)"],
                       capture_output=True, text=True, timeout=120)
    assert p.returncode == 1
    assert p.stderr.splitlines()[-1] == "unidyn.ValidationError: T must be > 0, got -1.0"
    assert "unidyn._errors" not in p.stderr
