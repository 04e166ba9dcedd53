"""CoachEnv: the Gymnasium checker, determinism under reset(seed), busy robot, rewards."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("pybullet")
gym = pytest.importorskip("gymnasium")

from gymnasium.utils.env_checker import check_env  # noqa: E402

from sim.gym_env import ENV_ID, METRIC_FEATURES, CoachEnv  # noqa: E402
from sim.policies import RuleBaseline, ThresholdPolicy, mean_return, run_episode  # noqa: E402


def rollout(env: CoachEnv, seed: int, actions: list[int]) -> list[tuple[object, ...]]:
    obs, info = env.reset(seed=seed)
    out: list[tuple[object, ...]] = [(obs.tobytes(), info["scenario"], info["presenter_seed"])]
    for a in actions:
        obs, r, term, trunc, info = env.step(a)
        out.append((obs.tobytes(), r, term, trunc, info["cue"], info["ignored"]))
    return out


def test_env_checker_passes() -> None:
    env = CoachEnv("demo")
    check_env(env, skip_render_check=True)


def test_the_docstring_gives_the_default_action_space() -> None:
    import re

    env = CoachEnv()
    doc = CoachEnv.__doc__ or ""
    said = re.search(
        r"default configuration ``K = (\d+)`` \(``Discrete\((\d+)\)``\): ([^(]+)\(", doc
    )
    assert said is not None
    k, n, names = int(said[1]), int(said[2]), " ".join(said[3].split())
    assert env.action_space == gym.spaces.Discrete(n) and n == k + 1
    assert names.rstrip(", ").split(", ") == [c for c, _ in env.actions[1:]]


def test_make_by_id_after_import() -> None:
    env = gym.make(ENV_ID, scenarios="ideal")
    obs, _ = env.reset(seed=0)
    assert env.observation_space.contains(obs)
    env.close()


def test_make_with_module_prefix_needs_no_import() -> None:
    code = (
        "import gymnasium; e = gymnasium.make('sim.gym_env:prezence/Coach-v0', scenarios='ideal');"
        "print(e.unwrapped.action_space)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.strip().startswith("Discrete(")


def test_same_seed_same_episode() -> None:
    rng = np.random.default_rng(7)
    actions = [int(a) for a in rng.integers(0, 10, size=300) * (rng.random(300) < 0.05)]
    a = rollout(CoachEnv(), 123, actions)
    b = rollout(CoachEnv(), 123, actions)
    assert a == b


def test_seeds_choose_scenario_and_presenter() -> None:
    env = CoachEnv()
    firsts = {env.reset(seed=s)[1]["presenter_seed"] for s in range(5)}
    assert len(firsts) == 5


def test_robot_is_busy_for_the_planned_duration_and_ignores_cues() -> None:
    env = CoachEnv("demo")
    env.reset(seed=0)
    look_up = env.action_index("lookUp", "cv_headGaze")
    *_, info = env.step(look_up)
    planned = info["cue"]["planned_s"]
    assert planned > 0
    steps = 0
    while True:
        *_, info = env.step(look_up)
        if not info["robot_busy"]:
            break
        assert info["ignored"] and info["cue"] is None
        steps += 1
    assert steps * env.step_s < planned <= (steps + 2) * env.step_s


def test_cueing_an_in_range_metric_costs_cue_and_penalty() -> None:
    env = CoachEnv("ideal", cue_cost=0.01, in_range_penalty=0.02)
    env.reset(seed=0)
    _, quiet, *_ = env.step(0)
    _, cued, *_ = env.step(env.action_index("slowDown", "speech_speed"))
    assert cued == pytest.approx(quiet - 0.03)


class Silent:
    """An agent that never cues."""

    def reset(self, env: CoachEnv, seed: int) -> None:
        pass

    def act(self, obs: object, info: object) -> int:
        return 0


def test_rule_baseline_and_tuned_policy_beat_silence_on_the_demo_talk() -> None:
    env = CoachEnv("demo")

    seeds = [0, 1]
    silent = mean_return(env, Silent(), seeds)
    assert mean_return(env, RuleBaseline(), seeds) > silent
    assert mean_return(env, ThresholdPolicy(), seeds) > silent
    assert run_episode(env, RuleBaseline(), 0)["cues"] >= 4


@pytest.mark.parametrize(
    "imports", ["import sim, gymnasium", "import gymnasium, sim", "import sim.backend, gymnasium"]
)
def test_import_sim_registers_the_env_with_a_step_limit(imports: str) -> None:
    code = (
        f"{imports}; s = gymnasium.spec('prezence/Coach-v0');"
        "print(s.entry_point, s.max_episode_steps)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.split() == ["sim.gym_env:CoachEnv", "2400"]


def test_the_sim_backend_does_not_import_gymnasium() -> None:
    """``prezence demo --backend sim`` imports the package ``sim`` for its backend: Gymnasium
    (a tenth of the whole run) is imported only by those who use it."""
    code = (
        "import sys; from prezence.backends.registry import make_backend;"
        "b = make_backend('sim'); b.open(); b.close(); print('gymnasium' in sys.modules)"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    assert out.stdout.split()[-1] == "False"


def test_a_talk_cut_short_is_truncated_not_terminated() -> None:
    env = gym.make(ENV_ID, scenarios="ideal", max_episode_steps=4)
    env.reset(seed=0)
    flags = [env.step(0)[2:4] for _ in range(4)]
    assert flags[:3] == [(False, False)] * 3
    assert flags[3] == (False, True)  # cut short: truncated
    env.close()


def test_a_talk_that_ends_is_terminated() -> None:
    env = CoachEnv("ideal", step_s=60.0)
    env.reset(seed=0)
    done = [env.step(0)[2] for _ in range(int(env.scenarios[0].duration_s // 60) + 1)]
    assert done[-1] and not any(done[:-1])


def test_rgb_array_shows_the_pybullet_nao_moving() -> None:
    env = CoachEnv("demo", render_mode="rgb_array", render_size=(96, 96))
    env.reset(seed=0)
    still = env.render()
    assert isinstance(still, np.ndarray) and still.shape == (96, 96, 3) and still.dtype == np.uint8
    assert still.std() > 5  # not a blank picture: the robot and the floor
    env.step(env.action_index("lookUp", "cv_headGaze"))
    for _ in range(3):
        env.step(0)
    moved = env.render()
    assert np.abs(moved.astype(int) - still.astype(int)).sum() > 0  # the gesture shows
    env.close()


def test_env_checker_passes_with_rendering() -> None:
    env = gym.make(ENV_ID, scenarios="demo", render_mode="rgb_array", render_size=(48, 48))
    check_env(env.unwrapped)
    env.close()


AUDIO_ONLY = """\
format = 1
name = "audio_only"
description = "Speech only: no camera, so no head gaze and no gestures."
duration_s = 120
seed = 0

[metrics.speech_speed]
baseline = 200.0
noise = 6.0

[metrics.speech_volume]
baseline = 67.0

[metrics.speech_accuracy]
baseline = 0.9
"""


@pytest.fixture
def audio_only(tmp_path: Path) -> str:
    path = tmp_path / "audio_only.toml"
    path.write_text(AUDIO_ONLY)
    return str(path)


def test_a_cue_about_a_metric_the_persona_lacks_is_refused(audio_only: str) -> None:
    """An audio-only persona (scenarios/README allows it): lookUp used to raise UnknownName
    ('cv_headGaze') from inside step(). It is now a no-op that costs nothing, said in info."""
    env = CoachEnv(audio_only)
    _, info = env.reset(seed=0)
    camera = {env.action_index(c, m) for c, m in env.actions if m in ("cv_headGaze", "cv_gestures")}
    assert len(camera) == 3
    assert [i for i, ok in enumerate(info["action_mask"]) if not ok] == sorted(camera)
    assert info["action_mask"].dtype == np.int8
    quiet = CoachEnv(audio_only)
    quiet.reset(seed=0)
    for a in sorted(camera):
        *_, want, _, _, _ = quiet.step(0)
        _, reward, _, _, info = env.step(a)
        assert info["invalid_action"] and info["cue"] is None and not info["ignored"]
        assert reward == want
    look_up = env.action_index("lookUp", "cv_headGaze")
    assert not env.action_masks()[look_up]


def test_a_random_agent_runs_a_persona_without_camera_to_the_end(audio_only: str) -> None:
    env = CoachEnv(audio_only)
    check_env(env, skip_render_check=True)
    obs, info = env.reset(seed=0)
    rng = np.random.default_rng(0)
    done, invalid = False, 0
    while not done:
        obs, _, term, trunc, info = env.step(int(rng.integers(env.action_space.n)))
        assert env.observation_space.contains(obs)
        invalid += info["invalid_action"]
        done = term or trunc
    assert invalid > 0


def test_the_action_mask_says_which_actions_the_robot_would_give() -> None:
    env = CoachEnv("demo")
    _, info = env.reset(seed=3)
    rng = np.random.default_rng(3)
    given = refused = 0
    for _ in range(600):
        mask = info["action_mask"]
        a = int(rng.integers(1, env.action_space.n))
        assert mask[0] == 1
        _, _, term, _, info = env.step(a)
        assert (info["cue"] is not None) == bool(mask[a])
        given += info["cue"] is not None
        refused += not mask[a]
        if term:
            break
    assert given > 5 and refused > 5


def test_time_is_the_step_index_times_step_s_and_does_not_drift() -> None:
    """Adding step_s 2400 times reached 479.9999999999813; each step's time is now k × step_s,
    as the headless runner's decision points are (SteppedClock.points)."""
    from prezence.talk import SteppedClock

    env = CoachEnv("ideal", step_s=0.2)
    _, info = env.reset(seed=0)
    assert info["t"] == 0.0
    points = SteppedClock(0.2).points(2400 * 0.2)
    times, cue_times = [], []
    for k in range(2400):
        before = info["t"]
        _, _, _, _, info = env.step(env.action_index("timeLeft", None) if k % 300 == 0 else 0)
        times.append(info["t"])
        if info["cue"] is not None:
            cue_times.append(info["cue"]["t"])
            assert info["cue"]["t"] == before
    assert times == points and times[-1] == 480.0 and env.now == 480.0
    assert cue_times == [k * 0.2 for k in range(0, 2400, 300)]


def test_the_first_observation_is_what_the_docstring_says() -> None:
    """Before the first sample a two-sided rule shows its band's midpoint and a one-sided rule
    its bound (a value in range, deviation 0, fresh 0), as the Observation Space table says."""
    env = CoachEnv("demo")
    obs, _ = env.reset(seed=0)
    k = len(METRIC_FEATURES)
    one_sided = 0
    for i, r in enumerate(env.rules):
        value, signed, weight, fresh = (float(x) for x in obs[i * k : (i + 1) * k])
        if r.low is not None and r.high is not None:
            assert value == pytest.approx((r.low + r.high) / 2)
        else:
            one_sided += 1
            bound = r.low if r.low is not None else r.high
            assert value == pytest.approx(bound)
            assert r.side(value) is None  # in range
        assert (signed, weight, fresh) == (0.0, 0.0, 0.0)
    assert one_sided >= 3
    doc = " ".join((CoachEnv.__doc__ or "").split())
    assert "the band's midpoint, or a one-sided rule's bound, before the first" in doc


def test_run_episode_splits_the_return_into_time_in_range_and_cue_costs() -> None:
    env = CoachEnv("demo")

    quiet = run_episode(env, Silent(), 0)
    assert quiet["return"] == pytest.approx(quiet["time_in_range"], abs=1e-12)
    rules = run_episode(env, RuleBaseline(), 0)
    assert rules["time_cues"] == 2  # the two timeLeft warnings of a 10-minute talk
    costs = rules["time_in_range"] - rules["return"]
    assert costs >= env.cue_cost * rules["cues"] - 1e-12
    assert rules["time_in_range"] > quiet["time_in_range"]


@pytest.mark.parametrize("scenario", ["demo", "fast_talker", "quiet_speaker", "overrunning"])
def test_the_rule_baseline_gives_the_headless_talks_cues(scenario: str, tmp_path: Path) -> None:
    """RuleBaseline in the env is the seed's processor: with praise off (it has no action) its
    cues are a headless ``weighted`` talk's, cue for cue, so its return is the processor's."""
    import dataclasses

    from prezence.config.load import load_config
    from prezence.synthetic.runner import run_talk

    base = load_config(None)
    cfg = dataclasses.replace(
        base, processor=dataclasses.replace(base.processor, praise_command=None)
    )
    env = CoachEnv(config=cfg)
    obs, info = env.reset(seed=5, options={"scenario": scenario})
    policy = RuleBaseline()
    policy.reset(env, 5)
    got, done = [], False
    while not done:
        obs, _, term, trunc, info = env.step(policy.act(obs, info))
        if info["cue"] is not None:
            got.append((info["cue"]["t"], info["cue"]["command"], info["cue"]["metric"]))
        done = term or trunc
    head = run_talk(
        scenario, out=tmp_path / "s", seed=info["presenter_seed"], config=cfg, policy="weighted"
    )
    assert got == [(c["t"], c["command"], c.get("metric")) for c in head.cues]
    assert len(got) >= 2


def test_a_speed_at_which_a_gesture_takes_too_long_is_refused_by_the_constructor() -> None:
    # the env took speed_fraction=0.05 and played 19 s gestures, in which no other cue could
    # be given; a talk on the command line is refused at that speed, and so is the env
    with pytest.raises(ValueError, match=r"the lowest speed at which every built-in gesture") as e:
        CoachEnv("short_talk", speed_fraction=0.05)
    assert str(e.value).startswith("--speed 0.05: 10 built-in gestures would take longer than")
