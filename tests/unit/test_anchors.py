"""The anchors (pz16, presentation_trainer, rhema) as policies of the processor."""

from __future__ import annotations

import subprocess
import sys
from collections.abc import Callable
from pathlib import Path

import pytest

from prezence.config.load import load_config
from prezence.config.model import Config
from prezence.errors import ConfigError, UnknownName
from prezence.peers import load_folder, reference_cues, replay_fixed_busy
from prezence.processor import Cue, Kind, make_policy, policy_names
from prezence.samples import Sample

PEERS = Path(__file__).resolve().parents[2].parent / "shared" / "peers"
PAIRS = {"pz16": "pz16", "pt": "presentation_trainer", "rhema": "rhema"}


def builtin() -> Config:
    return load_config(None).with_allocated(None)


def drive(
    cfg: Config, samples: list[Sample], policy: str, *, end: float | None = None
) -> list[Cue]:
    """The peers' harness: a decision every 0.5 s, the robot busy 4 s per cue."""
    return replay_fixed_busy(cfg, samples, policy, duration=4.0, tick=0.5, end=end)


def series(until: float, **signals: Callable[[float], float]) -> list[Sample]:
    return sorted(
        (Sample(m, float(t), f(float(t))) for m, f in signals.items() for t in range(int(until))),
        key=lambda s: s.t,
    )


OK = {
    "speech_speed": lambda t: 160.0,
    "speech_volume": lambda t: 66.0,
    "speech_accuracy": lambda t: 0.8,
    "cv_headGaze": lambda t: 0.0,
    "cv_gestures": lambda t: 6.0,
}


def test_the_anchors_are_registered_under_their_names() -> None:
    names = policy_names()
    for name in ("pz16", "presentation_trainer", "rhema"):
        assert name in names
        assert make_policy(name).name == name
    assert make_policy("pt").name == "presentation_trainer"
    assert make_policy("rhema:window_s=30").params["window_s"] == 30.0


def test_a_bad_spec_names_the_problem() -> None:
    with pytest.raises(UnknownName):
        make_policy("rhemaa")
    with pytest.raises(ConfigError, match="unknown parameter"):
        make_policy("rhema:windows=3")
    with pytest.raises(ConfigError, match="key=number"):
        make_policy("weighted:threshold")


def test_pz16_waits_for_more_concerns_than_the_allowance_and_prefers_low_priority() -> None:
    # Gaze (allowance 2, priority 2) and speed (allowance 1, priority 4) both out from 20 s:
    # speed is eligible first (2 concerns > 1, at 21 s; gaze needs 3); at the next chance,
    # after the 10 s robot delay, both are and gaze's lower priority number wins.
    sig = dict(OK, speech_speed=lambda t: 230.0 if t >= 20 else 160.0)
    sig["cv_headGaze"] = lambda t: -30.0 if t >= 20 else 0.0
    cs = drive(builtin(), series(60, **sig), "pz16")
    assert (cs[0].t, cs[0].command) == (21.0, "slowDown")
    assert cs[1].command == "lookUp"
    assert all(b.t - a.t > 10.0 for a, b in zip(cs, cs[1:], strict=False))


def test_pz16_is_silent_in_its_warm_up() -> None:
    sig = dict(OK, speech_speed=lambda t: 230.0)
    cs = drive(builtin(), series(30, **sig), "pz16")
    assert cs and cs[0].t >= 9.0


def test_presentation_trainer_praises_when_the_mistake_on_show_ends() -> None:
    sig = dict(OK, speech_speed=lambda t: 230.0 if 10 <= t < 20 else 160.0)
    cs = drive(builtin(), series(40, **sig), "presentation_trainer")
    assert [c.command for c in cs] == ["slowDown", "encourage"]
    assert cs[1].kind == Kind.PRAISE and cs[1].metric is None
    assert 20.0 <= cs[1].t <= 21.5


def test_rhema_decides_once_per_window_on_the_majority() -> None:
    # Too fast for 15 of the 20 samples of the second window, for 8 of the third's: one cue,
    # at the end of the second window.
    sig = dict(OK, speech_speed=lambda t: 230.0 if 25 <= t < 48 else 160.0)
    cs = drive(builtin(), series(80, **sig), "rhema")
    assert [(c.t, c.command) for c in cs] == [(40.0, "slowDown")]


def test_rhema_per_second_counts_seconds_not_samples_of_a_slow_metric() -> None:
    # Gestures written every 5 s (0.2 Hz, as every scenario writes them) and far too few from
    # 20 s on: 4 samples a window can never be more than 11 of them, so the default (the
    # peers' reference, counting samples) is silent, while the original's 20 one-second
    # chunks (per_second=1) see 20 of 20 out and cue at the end of each whole window.
    samples = sorted(
        [
            Sample(m, float(t), f(float(t)))
            for m, f in OK.items()
            if m != "cv_gestures"
            for t in range(100)
        ]
        + [Sample("cv_gestures", float(t), 6.0 if t < 20 else 0.5) for t in range(0, 100, 5)],
        key=lambda s: s.t,
    )
    assert drive(builtin(), samples, "rhema") == []
    cs = drive(builtin(), samples, "rhema:per_second=1")
    assert [c.command for c in cs] and {c.command for c in cs} == {"gestureMore"}
    assert [c.t for c in cs][:2] == [40.0, 60.0]


def test_rhema_per_second_is_the_default_on_one_hertz_data() -> None:
    sig = dict(OK, speech_speed=lambda t: 230.0 if 25 <= t < 48 else 160.0)
    sig["cv_headGaze"] = lambda t: -30.0 if (t // 7) % 2 else 0.0
    got = drive(builtin(), series(200, **sig), "rhema:per_second=1")
    assert [(c.t, c.command) for c in got] == [
        (c.t, c.command) for c in drive(builtin(), series(200, **sig), "rhema")
    ]


def test_the_anchors_ignore_the_processor_refractory() -> None:
    # 40 s refractory in the config; PT's own 3.5 s pace sets its rhythm instead.
    sig = dict(OK, speech_speed=lambda t: 230.0 if (t // 5) % 2 else 160.0)
    cs = drive(builtin(), series(60, **sig), "presentation_trainer")
    slow = [c.t for c in cs if c.command == "slowDown"]
    assert len(slow) >= 4


@pytest.mark.skipif(
    not (PEERS / "replay.py").is_file(),
    reason=f"the peers' reference replay is not at {PEERS} (it lives outside the repository)",
)
@pytest.mark.parametrize("peer", sorted(PAIRS))
def test_cue_counts_match_the_peers_reference_on_the_shared_workload(
    peer: str, tmp_path: Path
) -> None:
    folder = tmp_path / "load"
    subprocess.run(
        [sys.executable, str(PEERS / "mkload.py"), str(folder), "20000"],
        check=True,
        capture_output=True,
    )
    ref = reference_cues(PEERS, folder, peer, duration=4.0, tick=0.5)
    cfg, samples = load_folder(folder)
    got = drive(cfg, samples, PAIRS[peer])
    assert len(ref) > 50
    assert abs(len(got) - len(ref)) <= 0.03 * len(ref)
    by_metric_ref: dict[str, int] = {}
    by_metric_got: dict[str, int] = {}
    for c in ref:
        by_metric_ref[c["command"]] = by_metric_ref.get(c["command"], 0) + 1
    for g in got:
        key = "good" if g.kind == Kind.PRAISE else g.command
        by_metric_got[key] = by_metric_got.get(key, 0) + 1
    for cmd, n in by_metric_ref.items():
        assert abs(by_metric_got.get(cmd, 0) - n) <= max(2, 0.05 * n), cmd


@pytest.mark.slow
@pytest.mark.parametrize("name", ["pz16", "pt", "rhema"])
def test_the_anchors_coach_in_the_gym_env_by_name(name: str) -> None:
    pytest.importorskip("gymnasium")
    from sim.gym_env import CoachEnv
    from sim.policies import RuleBaseline, run_episode

    env = CoachEnv(scenarios=["fast_talker"])
    try:
        ep = run_episode(env, RuleBaseline(name), seed=0)
    finally:
        env.close()
    assert ep["cues"] > 0 and ep["ignored"] == 0


@pytest.mark.parametrize("name", ["pz16", "presentation_trainer", "rhema"])
def test_an_anchors_cue_does_not_claim_the_weighted_threshold(name: str) -> None:
    # the anchors fire by their own rules: a reason "(weight 20 >= 600)" would be false
    sig = dict(OK, speech_speed=lambda t: 230.0 if t >= 5 else 160.0)
    cs = drive(builtin(), series(120, **sig), name)
    assert cs, f"{name} gave no cue on two minutes of speech far too fast"
    for c in cs:
        assert ">=" not in c.reason and "weight" not in c.reason, c.reason
        assert c.reason.endswith(f"[{name}]"), c.reason
