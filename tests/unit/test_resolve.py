"""Policy specs: every value is checked before a talk starts, with the config file's bounds."""

from __future__ import annotations

import importlib
import json
import re
import sys
from pathlib import Path
from typing import Any

import pytest

from prezence.config.model import SETTING_BOUNDS
from prezence.config.tomlconf import loads_config
from prezence.errors import ConfigError, UnknownName
from prezence.processor import make_policy, policy_names
from prezence.processor.anchors import RhemaPolicy
from prezence.processor.resolve import (
    NOT_SPEC_KEYS,
    POLICIES,
    ConflictPolicy,
    spec_bounds,
    split_spec,
    worker_imports,
)


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


# -- policies of one's own: MODULE:CLASS -------------------------------------------------------

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"


@pytest.fixture
def in_examples(monkeypatch: pytest.MonkeyPatch) -> None:
    """The current folder is examples/, as in docs/evaluation.md; sys.path is put back."""
    monkeypatch.chdir(EXAMPLES)
    monkeypatch.setattr(sys, "path", [p for p in sys.path if p not in ("", str(EXAMPLES))])
    monkeypatch.delitem(sys.modules, "own_policy", raising=False)


@pytest.mark.usefixtures("in_examples")
def test_a_policy_of_one_s_own_is_named_module_colon_class() -> None:
    p = make_policy("own_policy:BiggestNow:min_deviation=25,refractory_s=20")
    assert type(p).__name__ == "BiggestNow"
    assert (p.params["min_deviation"], p.params["refractory_s"]) == (25.0, 20.0)
    assert make_policy("own_policy:BiggestNow").params["min_deviation"] == 10.0


def test_an_unknown_policy_says_how_to_name_one_of_your_own() -> None:
    # 'evaluate --policies biggest_now' said only 'unknown policy', listing the built-in ones
    with pytest.raises(UnknownName, match=r"'biggest_now'; known: .* is named MODULE:CLASS"):
        make_policy("biggest_now")


def test_a_registered_name_is_never_read_as_a_module() -> None:
    assert split_spec("weighted:threshold=800") == ("weighted", "threshold=800")
    with pytest.raises(ConfigError, match="expected key=number after ':', found 'threshold'"):
        make_policy("weighted:threshold")


@pytest.mark.parametrize(
    ("spec", "message"),
    [
        ("nosuch_zz:Policy", "no module named 'nosuch_zz' (a policy of your own is MODULE:CLASS"),
        ("own_policy:BiggestNoww", "own_policy has no 'BiggestNoww'; did you mean 'BiggestNow'?"),
        ("own_policy:Nope", "own_policy has no 'Nope'; its policies: BiggestNow"),
        ("own_policy:Bound", "own_policy.Bound is a class, not a ConflictPolicy subclass"),
        ("own_policy:ConflictPolicy", "own_policy.ConflictPolicy does not implement choose()"),
        ("os:path", "os.path is a module, not a ConflictPolicy subclass"),
        ("own_policy:BiggestNow:min_deviation=-3",
         "min_deviation must be between 0 and 1000 %, found -3"),
        ("own_policy:BiggestNow:min_dev=3", "unknown parameter(s) min_dev"),
    ],
)  # fmt: skip
@pytest.mark.usefixtures("in_examples")
def test_a_module_or_class_that_is_not_a_policy_is_said_plainly(spec: str, message: str) -> None:
    with pytest.raises(ConfigError, match=re.escape(f"policy '{spec}': {message}")):
        make_policy(spec)


def test_a_policy_module_that_fails_to_import_is_said_with_its_error(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    (tmp_path / "broken_policy_zz.py").write_text("import nosuch_dependency_zz\n")
    (tmp_path / "raising_policy_zz.py").write_text("x = 1 / 0\n")
    monkeypatch.syspath_prepend(str(tmp_path))
    with pytest.raises(ConfigError, match="importing broken_policy_zz failed: No module named"):
        make_policy("broken_policy_zz:P")
    with pytest.raises(ConfigError, match="importing raising_policy_zz failed: ZeroDivisionError"):
        make_policy("raising_policy_zz:P")


@pytest.mark.slow
@pytest.mark.usefixtures("in_examples")
def test_a_policy_of_one_s_own_runs_and_replays_from_the_command_line(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from prezence.cli import main

    run = ["run", "fast_talker", "--policy", "own_policy:BiggestNow", "--no-report", "-q"]
    assert main([*run, "--out", str(tmp_path / "a")]) == 0
    replay = ["replay", str(tmp_path / "a"), "--policy", "own_policy:BiggestNow:min_deviation=25"]
    assert main([*replay, "--no-report", "-q", "--out", str(tmp_path / "b")]) == 0
    capsys.readouterr()
    meta = json.loads((tmp_path / "b" / "summary.json").read_text())
    assert meta["policy"] == "own_policy:BiggestNow:min_deviation=25"
    assert meta["counts"]["cues"] > 0


@pytest.mark.slow
@pytest.mark.usefixtures("in_examples")
def test_a_policy_of_one_s_own_runs_in_evaluate_s_worker_processes() -> None:
    from prezence.evaluate import csv_text, evaluate

    policies = ["none", "own_policy:BiggestNow", "own_policy:BiggestNow:min_deviation=25"]
    parallel = evaluate(["fast_talker"], policies, [0], jobs=2)
    assert csv_text(parallel) == csv_text(evaluate(["fast_talker"], policies, [0], jobs=1))
    cues = {r["policy"]: r["corrective"] for r in parallel}
    assert cues["none"] == 0 < cues["own_policy:BiggestNow:min_deviation=25"]
    assert cues["own_policy:BiggestNow:min_deviation=25"] <= cues["own_policy:BiggestNow"]


@pytest.mark.slow
def test_a_policy_registered_by_a_module_reaches_the_worker_processes(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    # the walkthrough's register_policy route: workers never had the name (BrokenProcessPool)
    from prezence.evaluate import evaluate

    (tmp_path / "registers_zz.py").write_text(
        "from prezence.processor import ConflictPolicy, register_policy\n"
        "@register_policy\n"
        "class Quiet(ConflictPolicy):\n"
        "    name = 'quiet_zz'\n"
        "    def choose(self, candidates, order):\n"
        "        return None\n"
    )
    monkeypatch.syspath_prepend(str(tmp_path))
    monkeypatch.setitem(POLICIES, "quiet_zz", POLICIES["none"])  # removed again afterwards
    importlib.import_module("registers_zz")
    assert worker_imports(["quiet_zz", "weighted", "own_policy:BiggestNow"]) == ["registers_zz"]
    (row,) = evaluate(["short_talk"], ["quiet_zz"], [0], jobs=2)
    assert (row["policy"], row["cues"]) == ("quiet_zz", 0)


def test_a_policy_registered_in_an_interactive_session_is_refused_for_workers(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    class Typed(ConflictPolicy):
        name = "typed_zz"

        def choose(self, candidates: Any, order: Any) -> None:
            return None

    Typed.__module__ = "__main__"
    monkeypatch.delattr(sys.modules["__main__"], "__file__", raising=False)
    monkeypatch.setitem(POLICIES, "typed_zz", Typed)
    with pytest.raises(ConfigError, match="interactive session.*MODULE:CLASS, or use jobs=1"):
        worker_imports(["typed_zz"])
