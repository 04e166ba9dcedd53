"""The metric records: what the rest of the system reads about each metric."""

from __future__ import annotations

from pathlib import Path

import pytest

from prezence import metrics as M
from prezence.config.load import load_config
from prezence.config.model import Check, Config, Rule
from prezence.processor import Processor, make_policy
from prezence.samples import KNOWN_METRICS
from prezence.synthetic.presenters import PHYSICAL_RANGES


def test_records_agree_with_the_built_in_rules() -> None:
    """A record's band and scale are the shipped rule's: the two cannot drift apart."""
    for rule in load_config(None).rules:
        rec = M.METRICS[rule.metric]
        assert rec.band is not None, rule.metric
        check, low, high = rec.band
        assert Check(check) == rule.check and (low, high) == (rule.low, rule.high), rule.metric
        assert rec.scale == rule.scale, rule.metric


def test_every_module_metric_has_a_record_and_the_tables_read_them() -> None:
    from prezence.modules import speech

    assert M.INPUT_MODULES["speech"].metrics == tuple(speech.METRICS)
    assert set(KNOWN_METRICS) == set(M.METRICS)
    assert set(PHYSICAL_RANGES) == set(M.SYNTHETIC_METRICS)
    for rec in M.METRICS.values():
        assert rec.module in M.INPUT_MODULES and rec.cadence_s > 0


def _stale_after(metric: str) -> float:
    """The staleness the processor uses for a rule that sets none (config default: 6 s)."""
    cfg = Config(rules=(Rule(metric, Check.MIN, low=1.0, below="louder"),))
    assert cfg.processor.stale_after_s == 6.0
    return Processor(cfg, policy=make_policy("weighted")).state(metric).stale_after_s


def test_default_staleness_follows_the_writing_modules_cadence(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    # speech writes at most every 2 s: three missed writes = 6 s, the config's floor
    assert _stale_after("speech_speed") == 6.0
    slow = M.Metric("slow_metric", "1", "slow", "speech", cadence_s=5.0)
    monkeypatch.setitem(M.METRICS, "slow_metric", slow)  # type: ignore[index]
    assert _stale_after("slow_metric") == 15.0  # 3 x 5 s, not a constant that disagrees
    assert _stale_after("not_recorded") == 6.0  # your own module: the config's value


def test_a_rules_own_staleness_wins(monkeypatch: pytest.MonkeyPatch) -> None:
    slow = M.Metric("slow_metric", "1", "slow", "speech", cadence_s=5.0)
    monkeypatch.setitem(M.METRICS, "slow_metric", slow)  # type: ignore[index]
    rule = Rule("slow_metric", Check.MIN, low=1.0, below="louder", stale_after_s=4.0)
    proc = Processor(Config(rules=(rule,)), policy=make_policy("weighted"))
    assert proc.state("slow_metric").stale_after_s == 4.0


def test_a_metric_record_naming_no_module_record_is_an_error_with_a_did_you_mean() -> None:
    # session 22's walkthrough: Metric(..., "filler", ...) for the module "fillers" was taken
    # without a word: its metric was never started, waited for, or named when it failed
    fillers = M.InputModule("fillers", "fillers_stub", "--audio", (), M.DEFAULT_HANG_S)
    typo = M.Metric("speech_fillers", "fillers/min", "filler words", "filler", 1.0)
    assert M.record_problems({"speech_fillers": typo}, {"fillers": fillers}) == [
        "prezence/metrics.py: Metric 'speech_fillers' names module 'filler', which has no "
        "InputModule record in INPUT_MODULES; did you mean 'fillers'?"
    ]
    right = M.Metric("speech_fillers", "fillers/min", "filler words", "fillers", 1.0)
    assert M.record_problems({"speech_fillers": right}, {"fillers": fillers}) == []
    assert M.record_problems(M.METRICS, M.INPUT_MODULES) == []  # the shipped records


def test_a_metric_record_naming_no_module_record_stops_prezence_at_import(
    tmp_path: Path,
) -> None:
    import shutil
    import subprocess
    import sys

    copy = tmp_path / "prezence"
    shutil.copytree(Path(M.__file__).parent, copy, ignore=shutil.ignore_patterns("__pycache__"))
    metrics = copy / "metrics.py"
    text = metrics.read_text()
    # the vision module's record, and cv_headYaw's record names it "vison"
    assert text.count('Metric("cv_headYaw", "degrees", "head turn", "vision", _VISION)') == 1
    metrics.write_text(
        text.replace(
            'Metric("cv_headYaw", "degrees", "head turn", "vision", _VISION)',
            'Metric("cv_headYaw", "degrees", "head turn", "vison", _VISION)',
        )
    )
    done = subprocess.run(
        [sys.executable, "-c", "import prezence.metrics"],
        cwd=tmp_path,
        env={"PYTHONPATH": str(tmp_path), "PYTHONDONTWRITEBYTECODE": "1"},
        capture_output=True,
        text=True,
        check=False,
    )
    assert done.returncode == 1
    assert done.stderr.rstrip().endswith(
        "ValueError: prezence/metrics.py: Metric 'cv_headYaw' names module 'vison', which has "
        "no InputModule record in INPUT_MODULES; did you mean 'vision'?"
    ), done.stderr
