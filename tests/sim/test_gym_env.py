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
        "import gymnasium; e = gymnasium.make('sim.gym_env:prezence/Coach-v1', scenarios='ideal');"
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
        f"{imports}; s = gymnasium.spec('prezence/Coach-v1');"
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


# -- session 22, an RL researcher's walkthrough ------------------------------------------------


def _config_file(path: Path, **processor: object) -> Path:
    """The built-in configuration with ``processor`` settings changed, written as TOML."""
    import dataclasses

    from prezence.config.load import load_config
    from prezence.config.tomlconf import dumps_config

    base = load_config(None)
    path.write_text(
        dumps_config(
            dataclasses.replace(base, processor=dataclasses.replace(base.processor, **processor))
        )
    )
    return path


def _baseline_cues(
    env: CoachEnv, policy: str, scenario: str
) -> tuple[list[tuple[float, str]], float]:
    """RuleBaseline(policy)'s cues (t, command) in one episode, and its time in range."""
    obs, info = env.reset(seed=0, options={"scenario": scenario})
    baseline = RuleBaseline(policy)
    baseline.reset(env, 0)
    cues: list[tuple[float, str]] = []
    in_range, done = 0.0, False
    while not done:
        obs, _, term, trunc, info = env.step(baseline.act(obs, info))
        in_range += info["in_range"] * env.step_s / env.scenario.duration_s
        if info["cue"] is not None:
            cues.append((info["cue"]["t"], info["cue"]["command"]))
        done = term or trunc
    return cues, in_range


@pytest.mark.parametrize("policy", ["presentation_trainer", "weighted"])
@pytest.mark.parametrize("scenario", ["stiff_presenter", "quiet_speaker"])
def test_the_rule_baseline_is_prezence_run_cue_for_cue_praise_included(
    policy: str, scenario: str, tmp_path: Path
) -> None:
    """With the default configuration (praise on) the env's presentation_trainer gave 2 cues
    on stiff_presenter where ``prezence run`` gives 14 (time in range 0.828 against 0.988):
    its praise became "no cue", while its processor believed it given. Praise has an action
    now, and the env's baseline is ``prezence run --policy P --seed <presenter seed>``."""
    import json

    from prezence.cli import main

    env = CoachEnv()
    assert ("encourage", None) in env.actions
    got, in_range = _baseline_cues(env, policy, scenario)
    seed = env.presenter_seed
    out = tmp_path / "run"
    argv = ["-q", "run", scenario, "--seed", str(seed), "--policy", policy]
    # 3: the scenario's expectations not met (quiet_speaker's under presentation_trainer)
    assert main([*argv, "--out", str(out), "--no-report"]) in (0, 3)
    summary = json.loads((out / "summary.json").read_text())
    # cue for cue, to the end (a headless talk gives no cue at its last instant either)
    run = [(c["t"], c["command"]) for c in summary["cues"]]
    assert got == run
    if policy == "presentation_trainer":  # a praise after every mistake on show
        assert sum(c == "encourage" for _, c in got) >= 3
    truth = [m["truth_time_in_range"] for m in summary["metrics"].values()]
    assert in_range == pytest.approx(sum(truth) / len(truth), abs=0.001)


def test_a_praise_cue_is_given_and_costs_the_cue_cost_only() -> None:
    env = CoachEnv("ideal", cue_cost=0.01, in_range_penalty=0.02)
    env.reset(seed=0)
    _, quiet, *_ = env.step(0)
    _, praised, _, _, info = env.step(env.action_index("encourage", None))
    assert info["cue"]["command"] == "encourage" and info["cue"]["kind"] == "praise"
    assert praised == pytest.approx(quiet - 0.01)


def test_a_config_without_praise_has_no_praise_action(tmp_path: Path) -> None:
    cfg = _config_file(tmp_path / "nopraise.toml", praise_command=None)
    env = CoachEnv("demo", config=str(cfg))
    assert env.config.processor.praise_command is None
    assert env.action_space == gym.spaces.Discrete(10)
    assert all(c != "encourage" for c, _ in env.actions)


def test_config_may_be_a_path_as_every_commands_config_file(tmp_path: Path) -> None:
    """``config='file.toml'`` raised AttributeError: 'str' object has no attribute 'processor'."""
    cfg = _config_file(tmp_path / "slow.toml", decision_period_s=1.0)
    for given in (str(cfg), cfg):
        env = gym.make(ENV_ID, scenarios="ideal", config=given).unwrapped
        assert env.step_s == 1.0
    with pytest.raises(TypeError, match=r"config must be a Config, a path to a config file"):
        CoachEnv("ideal", config=42)  # type: ignore[arg-type]


@pytest.mark.parametrize(
    ("options", "said"),
    [
        (
            {"senario": "demo"},
            r"unknown reset option 'senario'; did you mean 'scenario'\? "
            r"\(the options are: presenter_seed, scenario\)",
        ),
        ({"seed": 3}, r"unknown reset option 'seed'.*presenter_seed, scenario"),
        ("demo", r"options must be a dict \(keys: presenter_seed, scenario\) or None, got str"),
        ({"scenario": None}, r"options\['scenario'\] must be a scenario name or path, got None"),
        ({"presenter_seed": -1}, r"options\['presenter_seed'\] must be an integer >= 0"),
        ({"presenter_seed": 1.5}, r"options\['presenter_seed'\] must be an integer >= 0"),
    ],
)
def test_reset_refuses_unknown_or_ill_typed_options(options: object, said: str) -> None:
    """A misspelt key ran the whole experiment on random scenarios without a word."""
    env = CoachEnv()
    with pytest.raises(ValueError, match=said):
        env.reset(seed=0, options=options)  # type: ignore[arg-type]


def test_reset_options_may_give_the_presenter_seed() -> None:
    """``prezence evaluate --first-seed K`` talks can be met in the env directly."""
    env = CoachEnv()
    _, info = env.reset(seed=3, options={"scenario": "demo", "presenter_seed": 1826701614})
    assert info["presenter_seed"] == env.presenter_seed == 1826701614
    after_given = env.reset()[1]["presenter_seed"]
    env.reset(seed=3, options={"scenario": "demo"})
    assert env.reset()[1]["presenter_seed"] == after_given  # the generator did not move
    quiet = CoachEnv()
    quiet.reset(seed=99, options={"scenario": "demo", "presenter_seed": 1826701614})
    a = [env.reset(options={"scenario": "demo", "presenter_seed": 1826701614})[0].tobytes()]
    b = [quiet.reset(options={"scenario": "demo", "presenter_seed": 1826701614})[0].tobytes()]
    for _ in range(200):
        a.append(env.step(0)[0].tobytes())
        b.append(quiet.step(0)[0].tobytes())
    assert a == b


@pytest.mark.parametrize(
    ("kwargs", "said"),
    [
        ({"cue_cost": float("nan")}, r"cue_cost must be a finite number, got nan"),
        ({"cue_cost": -1}, r"cue_cost must be >= 0 \(a cost, subtracted from the reward\), got -1"),
        ({"in_range_penalty": float("inf")}, r"in_range_penalty must be a finite number, got inf"),
        ({"in_range_penalty": -0.01}, r"in_range_penalty must be >= 0"),
        ({"step_s": float("inf")}, r"step_s must be a finite number, got inf"),
        ({"render_size": (0, 0)}, r"render_size must be two positive integers \(width, height\)"),
        ({"render_size": (96.5, 96)}, r"render_size must be two positive integers"),
        ({"render_size": 96}, r"render_size must be two positive integers"),
        ({"scenarios": []}, r"scenarios is empty"),
    ],
)
def test_the_constructor_refuses_bad_reward_and_render_settings(
    kwargs: dict[str, object], said: str
) -> None:
    """cue_cost=-1 made every cue earn +1, nan made every reward nan; render_size=(0, 0)
    failed only at render() with ZeroDivisionError."""
    with pytest.raises(ValueError, match=said):
        CoachEnv(**{"scenarios": "ideal", **kwargs})  # type: ignore[arg-type]


def test_copying_or_pickling_the_env_is_refused_cleanly() -> None:
    """deepcopy shared the working folder (closing the copy broke the original) and printed
    'Exception ignored in FolderLock.__del__' at exit; pickle failed on a local function."""
    code = (
        "import copy, pickle\n"
        "from sim.gym_env import CoachEnv\n"
        "e = CoachEnv('short_talk'); e.reset(seed=0)\n"
        "for f in (copy.copy, copy.deepcopy, pickle.dumps):\n"
        "    try:\n"
        "        f(e)\n"
        "    except TypeError as x:\n"
        "        print(type(x).__name__, x)\n"
        "done = False\n"
        "while not done:\n"
        "    done = e.step(0)[2]\n"
        "e.close(); print('closed')\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    lines = out.stdout.splitlines()
    assert len(lines) == 4 and lines[-1] == "closed"
    assert all(x.startswith("TypeError a CoachEnv cannot be copied or pickled") for x in lines[:3])
    assert out.stderr == ""


@pytest.mark.parametrize("ending", ["del env; gc.collect()", "pass"])
def test_an_env_not_closed_leaves_no_folder_behind(ending: str) -> None:
    """/tmp held 1526 prezence-gym-* folders: an env dropped (or alive at exit) without close()
    kept its folder."""
    code = (
        "import gc, gymnasium, sim\n"
        "env = gymnasium.make('prezence/Coach-v1', scenarios='ideal'); env.reset(seed=0)\n"
        "env.step(0); folder = env.unwrapped.talk.session.root.parent\n"
        "print(folder, flush=True)\n"
        f"{ending}\n"
        "print(folder.exists())\n"
    )
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, check=True)
    folder, exists = out.stdout.split()
    assert Path(folder).name.startswith("prezence-gym-")
    assert exists == ("False" if "del" in ending else "True")
    assert not Path(folder).exists()  # gone at exit in both cases
    assert out.stderr == ""


def test_the_working_folder_says_the_agent_chose_the_cues() -> None:
    """session.json said "policy": "none" though the agent cued."""
    env = CoachEnv("ideal")
    env.reset(seed=0)
    assert env.talk.session.read_meta()["policy"] == "agent"
    env.close()


def test_a_step_after_the_end_of_the_talk_is_refused() -> None:
    """It went on, and still cued (charged) after the talk ended: a loop on info['t'] never
    ended."""
    env = CoachEnv("short_talk")
    env.reset(seed=0)
    done = False
    while not done:
        _, _, done, _, info = env.step(0)
    for action in (0, 1):
        with pytest.raises(RuntimeError, match=r"the episode ended at 40 s .*call reset\(\)"):
            env.step(action)
    assert env.render() is None and env.now == 40.0  # the episode can still be looked at
    env.reset(seed=1)
    env.step(0)  # a new one runs


@pytest.mark.parametrize(
    ("action", "error"),
    [
        (2.7, TypeError),
        (3.0, TypeError),
        ("3", TypeError),
        (None, TypeError),
        (np.float32("nan"), TypeError),
        (np.array([2]), TypeError),
        (2**70, ValueError),
        (11, ValueError),
        (-1, ValueError),
        (np.uint8(255), ValueError),
    ],
)
def test_an_action_that_is_not_in_the_space_is_one_clear_error(
    action: object, error: type[Exception]
) -> None:
    """2.7 was taken as 2 and '3' as 3; None and 2**70 raised int()'s own errors; nan printed a
    numpy RuntimeWarning before its ValueError."""
    import warnings

    env = CoachEnv("demo")
    env.reset(seed=0)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        with pytest.raises(error, match=r"^action .* is not in Discrete\(11\)"):
            env.step(action)  # type: ignore[arg-type]


def test_integer_actions_of_every_kind_are_taken() -> None:
    env = CoachEnv("demo")
    env.reset(seed=0)
    for action in (0, np.int64(0), np.uint8(0), np.array(0), np.array(0, dtype=np.int32)):
        env.step(action)  # type: ignore[arg-type]


def test_a_step_limit_that_cuts_the_talks_short_is_warned_about() -> None:
    """step_s=0.1 ended every talk at 240 s (2400 steps), truncated, without a word."""
    with pytest.warns(
        UserWarning,
        match=r"max_episode_steps=2400 \(steps, not seconds\).*240 s.*"
        r"pass max_episode_steps=6900",
    ):
        env = gym.make(ENV_ID, step_s=0.1)
        env.reset(seed=0)
    import warnings

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        gym.make(ENV_ID).reset(seed=0)  # the default step covers every built-in talk
        CoachEnv(step_s=0.1).reset(seed=0)  # made directly: no step limit


@pytest.mark.parametrize(
    ("args", "said"),
    [
        (["--test", "0"], "argument --test: at least 1 seed is needed, got 0"),
        (["--train", "0"], "argument --train: at least 1 seed is needed, got 0"),
        (
            ["--scenarios", "fast_taker"],
            "unknown scenario 'fast_taker'; did you mean 'fast_talker'?",
        ),
    ],
)
def test_the_example_refuses_bad_arguments_in_one_line(args: list[str], said: str) -> None:
    """--test 0: ZeroDivisionError; --train 0: nan and a 'tuned' policy; an unknown scenario:
    a traceback."""
    example = Path(__file__).parents[2] / "examples" / "coach_env.py"
    out = subprocess.run([sys.executable, str(example), *args], capture_output=True, text=True)
    assert out.returncode == 2
    assert out.stderr.splitlines()[-1] == f"coach_env.py: error: {said}"
    assert "Traceback" not in out.stderr and out.stdout == ""


def test_the_old_id_points_to_the_new_version() -> None:
    """v1 (session 22) changed the action space (a praise action) and the talk's last instant:
    an agent trained on v0 is told, not silently given other actions."""
    import sim  # noqa: F401  (registers the environment)

    with (
        pytest.warns(DeprecationWarning, match="upgrading to version `v1`"),
        pytest.raises(gym.error.DeprecatedEnv, match="prezence/Coach-v1"),
    ):
        gym.make("prezence/Coach-v0")


#: lookUp as one short nod (the built-in one is longer)
NOD = """format = 1
[gestures.look_up]
description = "A short nod up."
[[gestures.look_up.keyframes]]
pose = { HeadPitch = -10.0 }
"""


def test_a_gesture_library_of_ones_own_is_played_and_checked(tmp_path: Path) -> None:
    # Session 23's gesture designer: CoachEnv(gestures=…) raised TypeError, so an agent could
    # not be trained with the gestures it would play on the robot.
    def planned(env: CoachEnv) -> float:
        env.reset(seed=0)
        *_, info = env.step(env.action_index("lookUp", "cv_headGaze"))
        return float(info["cue"]["planned_s"])

    mine = tmp_path / "nod.toml"
    mine.write_text(NOD)
    assert planned(CoachEnv("demo", gestures=mine)) < planned(CoachEnv("demo"))
    bad = tmp_path / "bad.toml"
    bad.write_text(NOD.replace("HeadPitch = -10.0", "HeadPitch = -95.0"))
    with pytest.raises(ValueError, match=r"bad\.toml:4: .*HeadPitch"):
        CoachEnv("demo", gestures=bad)
