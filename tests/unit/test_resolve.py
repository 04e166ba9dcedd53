"""Policy specs: every value is checked before a talk starts, with the config file's bounds."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

from prezence.config.model import SETTING_BOUNDS
from prezence.config.tomlconf import loads_config
from prezence.errors import ConfigError
from prezence.processor import make_policy, policy_names
from prezence.processor.anchors import RhemaPolicy
from prezence.processor.resolve import NOT_SPEC_KEYS, POLICIES, spec_bounds


@pytest.mark.parametrize("window", ["0", "-1", "0.01"])
def test_a_rhema_window_that_would_never_end_is_refused(window: str) -> None:
    # window_s=0 looped for ever in RhemaPolicy.decide (the talk hung)
    message = f"window_s must be between 0.1 and 86400 s, found {window}"
    with pytest.raises(ConfigError, match=re.escape(message)):
        make_policy(f"rhema:window_s={window}")


def test_a_policy_built_directly_checks_its_values_too() -> None:
    with pytest.raises(ConfigError, match="window_s"):
        RhemaPolicy(window_s=0.0)


@pytest.mark.parametrize(
    ("spec", "message"),
    [
        ("weighted:threshold=-5", "threshold must be between 0.001 and 1e+09 %·s, found -5"),
        ("weighted:refractory_s=nan", "refractory_s must be between 0 and 86400 s, found nan"),
        ("weighted:min_gap_s=inf", "min_gap_s must be between 0 and 86400 s, found inf"),
        ("weighted:escalate_after=0.5", "escalate_after must be a whole number, 0 or more, "
                                        "found 0.5"),
        ("weighted:escalate_after=-1", "escalate_after must be a whole number, 0 or more, "
                                       "found -1"),
        ("weighted:persistence_s=-2", "persistence_s must be between 0 and 86400 s, found -2"),
        ("weighted:praise_after_s=0.5", "praise_after_s must be between 1 and 86400 s "
                                        "(or 0: off), found 0.5"),
        ("pz16:expire_s=0", "expire_s must be between 0.1 and 86400 s, found 0"),
        ("pt:praise=0.5", "praise must be 0 or 1, found 0.5"),
        ("rhema:max_samples=0", "max_samples must be a whole number, between 1 and 1e+06, "
                                "found 0"),
        ("rhema:hits=20", "hits must be less than max_samples (20)"),
    ],
)  # fmt: skip
def test_a_value_outside_its_key_s_range_is_refused_naming_both(spec: str, message: str) -> None:
    with pytest.raises(ConfigError, match=re.escape(f"policy '{spec}': {message}")):
        make_policy(spec)


@pytest.mark.parametrize("key", sorted(NOT_SPEC_KEYS))
def test_a_setting_of_the_loop_or_a_command_is_not_a_policy_parameter(key: str) -> None:
    # decision_period_s=5 was accepted and recorded in the policy's name but changed nothing;
    # praise_command=1 (a command name) ended the talk in a TypeError
    with pytest.raises(ConfigError, match=rf"{key} is not a policy parameter.*\[processor\] {key}"):
        make_policy(f"weighted:{key}=1")


def test_values_inside_the_ranges_are_kept() -> None:
    p = make_policy("weighted:threshold=800,escalate_after=3,praise_after_s=0,min_gap_s=0")
    assert (p.params["threshold"], p.params["escalate_after"]) == (800.0, 3.0)
    assert make_policy("rhema:window_s=0.1,hits=0").params["window_s"] == 0.1


@pytest.mark.parametrize("name", sorted(policy_names()))
def test_every_policy_s_defaults_are_inside_its_ranges(name: str) -> None:
    cls = POLICIES[name]
    cls.check_params(cls.defaults)


RULE = '[[rules]]\nmetric = "speech_speed"\ncheck = "min"\nlow = 140\nbelow = "speedUp"\n'


def _config_takes(key: str, x: float) -> bool:
    try:
        loads_config(f"format = 1\n[processor]\n{key} = {x!r}\n{RULE}", path=Path("c.toml"))
    except ConfigError:
        return False
    return True


def _spec_takes(key: str, x: float) -> bool:
    try:
        make_policy(f"weighted:{key}={x!r}")
    except ConfigError:
        return False
    return True


SPEC_SETTINGS = sorted(spec_bounds(POLICIES["weighted"]).keys() & SETTING_BOUNDS.keys())


@pytest.mark.parametrize("key", SPEC_SETTINGS)
def test_a_spec_takes_a_setting_exactly_when_the_config_file_does(key: str) -> None:
    lo, hi = SETTING_BOUNDS[key]
    for x in (lo, hi, lo - 1e-3 * max(1.0, abs(lo)), hi * 1.01, 0.0, 0.5, -1.0):
        assert _spec_takes(key, x) == _config_takes(key, x), (key, x)


def test_a_refused_spec_is_an_error_line_and_writes_no_folder(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from prezence.cli import main

    out = tmp_path / "pc"
    assert main(["run", "demo", "--policy", "weighted:praise_command=1", "--out", str(out)]) == 2
    err = capsys.readouterr().err
    assert "error: policy 'weighted:praise_command=1': praise_command is not a policy" in err
    assert "Traceback" not in err
    assert not out.exists()
