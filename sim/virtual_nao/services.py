"""The NAOqi services of the virtual NAO: ALMotion, ALTextToSpeech, ALLeds, ALRobotPosture,
ALMemory and ALAutonomousLife, each a thin layer over :class:`sim.virtual_nao.robot.VirtualNao`.
"""

from __future__ import annotations

import logging
import re
from typing import Any

import numpy as np
import qi

from prezence.backends.base import estimate_speech_s
from prezence.errors import did_you_mean
from prezence.feedback.trajectory import Trajectory
from sim.virtual_nao.planning import _per_joint, plan_keyframes
from sim.virtual_nao.robot import BODY, GROUPS, LED_GROUPS, VirtualNao, _is_seq, _num

log = logging.getLogger("sim.virtual_nao")  # the package's logger, as before the split
#: Logger of the phrases said (INFO, one line per ``say``): enable it to watch the robot talk.
SPEECH_LOGGER = "sim.virtual_nao.speech"
say_log = logging.getLogger(SPEECH_LOGGER)

#: Postures for ``ALRobotPosture``: rounded values in the spirit of NAOqi's (arms down and
#: slightly bent; legs straight since the simulated NAO stands on a fixed base). Approximate:
#: they are not NAOqi's joint values.
_ARMS_DOWN = {
    "HeadYaw": 0.0,
    "HeadPitch": 0.0,
    "LShoulderPitch": 1.4,
    "LShoulderRoll": 0.3,
    "LElbowYaw": -1.2,
    "LElbowRoll": -0.5,
    "LWristYaw": 0.0,
    "LHand": 0.25,
    "RShoulderPitch": 1.4,
    "RShoulderRoll": -0.3,
    "RElbowYaw": 1.2,
    "RElbowRoll": 0.5,
    "RWristYaw": 0.0,
    "RHand": 0.25,
}
POSTURES: dict[str, dict[str, float]] = {
    "StandInit": {**_ARMS_DOWN},
    "Stand": {**_ARMS_DOWN},
    "StandZero": {n: 0.0 for n in BODY},
    "Crouch": {**_ARMS_DOWN, "LShoulderPitch": 0.9, "RShoulderPitch": 0.9},
}


LED_COLORS = {
    "white": 0xFFFFFF,
    "red": 0xFF0000,
    "green": 0x00FF00,
    "blue": 0x0000FF,
    "yellow": 0xFFFF00,
    "magenta": 0xFF00FF,
    "cyan": 0x00FFFF,
}
_TTS_TAG = re.compile(r"\\[a-zA-Z]+=?[^\\]*\\")


class ALMotion:
    """ALMotion on the virtual NAO (joint control, stiffness, motion tasks)."""

    def __init__(self, robot: VirtualNao) -> None:
        self._r = robot

    # -- reactive ----------------------------------------------------------------------------
    def setAngles(self, names: object, angles: object, fractionMaxSpeed: object) -> None:
        """Non-blocking: retarget joints at fractionMaxSpeed × their velocity limit."""
        self._set("setAngles", names, angles, fractionMaxSpeed, relative=False)

    def changeAngles(self, names: object, changes: object, fractionMaxSpeed: object) -> None:
        """Non-blocking: like setAngles, relative to the current angles."""
        self._set("changeAngles", names, changes, fractionMaxSpeed, relative=True)

    @qi.nobind
    def _set(
        self, method: str, names: object, angles: object, frac: object, *, relative: bool
    ) -> None:
        r = self._r
        joints = r.expand(names, method)
        values = (
            [_num(a, "angle") for a in angles]
            if _is_seq(angles)
            else [_num(angles, "angle")] * (1 if len(joints) == 1 else 0)
        )
        if len(values) != len(joints):
            raise ValueError(f"ALMotion.{method}: {len(values)} angles for {len(joints)} joints")
        fracs = [_num(f, "fractionMaxSpeed") for f in frac] if _is_seq(frac) else None
        if fracs is not None and len(fracs) != len(joints):
            raise ValueError(f"ALMotion.{method}: {len(fracs)} speeds for {len(joints)} joints")
        speeds = fracs or [_num(frac, "fractionMaxSpeed")] * len(joints)
        if any(not f > 0.0 for f in speeds):
            raise ValueError(f"ALMotion.{method}: fractionMaxSpeed must be > 0")
        speeds = [min(f, 1.0) for f in speeds]
        with r.lock:
            pose = dict(zip(BODY, r.model.positions(list(BODY)), strict=True))
            if relative:
                values = [v + pose[j] for v, j in zip(values, joints, strict=True)]
            wanted = {j: v for j, v in zip(joints, values, strict=True) if r.stiffness[j] > 0.0}
            if not wanted:
                return
            speed_of = dict(zip(joints, speeds, strict=True))
            # NAOqi clips to the ranges, applies head anti-collision and the one-motor hip rule
            clipped = r.limits.clip(wanted, pose=pose)
            names_k = list(clipped)
            r.model.set_targets(
                names_k,
                [clipped[n] for n in names_k],
                [speed_of.get(n, max(speeds)) for n in names_k],
            )
            r.commanded.update(clipped)

    # -- animation (blocking) ------------------------------------------------------------------
    def angleInterpolation(
        self,
        names: object,
        angleLists: object,
        timeLists: object,
        isAbsolute: object,
    ) -> Any:
        """Blocking: follow timed keyframes (seconds from the call's start).

        Keyframes are clipped like ``setAngles`` targets and slowed down where too fast for a
        joint's velocity limit (:func:`plan_keyframes`); the call returns at the last key time
        played, with one warning when it had to slow down.
        """
        r = self._r
        joints = r.expand(names, "angleInterpolation")
        angles = _per_joint(angleLists, len(joints), "angle", "angleInterpolation")
        times = _per_joint(timeLists, len(joints), "time", "angleInterpolation")
        for j, a, t in zip(joints, angles, times, strict=True):
            if len(a) != len(t):
                raise ValueError(
                    f"ALMotion.angleInterpolation: {j}: {len(a)} angles, {len(t)} times"
                )
            if not t or any(not b > a_ for a_, b in zip([0.0, *t], t, strict=False)):
                raise ValueError(
                    f"ALMotion.angleInterpolation: {j}: times must increase from > 0, got {t}"
                )
        absolute = bool(isAbsolute)
        info: dict[str, Any] = {"joints": joints}

        def begin(now: float) -> float:
            pose = dict(zip(BODY, r.model.positions(list(BODY)), strict=True))
            stiff = [k for k, j in enumerate(joints) if r.stiffness[j] > 0.0]
            if not stiff:
                return max(t[-1] for t in times)
            plan = plan_keyframes(
                r.limits,
                [joints[k] for k in stiff],
                [[a + (0.0 if absolute else pose[joints[k]]) for a in angles[k]] for k in stiff],
                [times[k] for k in stiff],
                pose,
            )
            if plan.capped is not None:
                joint, asked, limit = plan.capped
                log.warning(
                    "ALMotion.angleInterpolation: %s asked for %.3g rad/s, over its limit of "
                    "%.3g rad/s; slowed down to the limit: %.2f s instead of %.2f s",
                    joint,
                    asked,
                    limit,
                    plan.duration_s,
                    plan.asked_s,
                )
                info.update(asked_s=plan.asked_s, capped=joint, asked_speed=round(asked, 6))
            info["planned_s"] = round(plan.duration_s, 6)
            groups: dict[tuple[float, ...], list[int]] = {}
            for k, j in enumerate(plan.joints):
                if r.stiffness[j] > 0.0:
                    groups.setdefault(plan.times[k], []).append(k)
            for ts, ks in groups.items():
                names_g = tuple(plan.joints[k] for k in ks)
                pos = tuple(tuple(plan.angles[k][i] for k in ks) for i in range(len(ts)))
                traj = Trajectory(
                    "angleInterpolation", names_g, ts, pos, tuple(pose[n] for n in names_g)
                )
                r.model.follow(traj, start=now)
                r.commanded.update(zip(names_g, pos[-1], strict=True))
            return plan.duration_s

        return r.submit("angleInterpolation", frozenset(joints), begin, info=info)

    def angleInterpolationWithSpeed(
        self,
        names: object,
        targetAngles: object,
        maxSpeedFraction: object,
    ) -> Any:
        """Blocking: move to one target per joint at maxSpeedFraction × the velocity limits."""
        r = self._r
        joints = r.expand(names, "angleInterpolationWithSpeed")
        targets = [
            v[0]
            for v in _per_joint(targetAngles, len(joints), "angle", "angleInterpolationWithSpeed")
        ]
        frac = _num(maxSpeedFraction, "maxSpeedFraction")
        if not frac > 0:
            raise ValueError("ALMotion.angleInterpolationWithSpeed: maxSpeedFraction must be > 0")
        return self._move_to("angleInterpolationWithSpeed", joints, targets, min(frac, 1.0))

    @qi.nobind
    def _move_to(
        self, call: str, joints: list[str], targets: list[float], frac: float, value: Any = None
    ) -> Any:
        """A blocking move to targets that returns when the joints have arrived (NAOqi's
        ``angleInterpolationWithSpeed``): no earlier than the speed-capped estimate, and as
        soon as the joints are within 0.01 rad of the goal or have stopped moving."""
        r = self._r
        state: dict[str, Any] = {}

        def begin(now: float) -> float:
            keep = [i for i, j in enumerate(joints) if r.stiffness[j] > 0.0]
            if not keep:
                return 0.0
            pose = dict(zip(BODY, r.model.positions(list(BODY)), strict=True))
            # NAOqi clips to the ranges, applies head anti-collision and the one-motor hip rule
            clipped = r.limits.clip({joints[i]: targets[i] for i in keep}, pose=pose)
            names_k = [n for n in clipped if r.stiffness[n] > 0.0]
            goal = [clipped[n] for n in names_k]
            cur = [pose[n] for n in names_k]
            r.model.set_targets(names_k, goal, frac)
            r.commanded.update(zip(names_k, goal, strict=True))
            estimate = max(
                abs(g - q) / (frac * r.specs[n].velocity)
                for n, g, q in zip(names_k, goal, cur, strict=True)
            )
            state.update(names=names_k, goal=np.asarray(goal), last=np.asarray(cur))
            return estimate

        def arrived() -> bool:
            if not state:
                return True
            q = np.asarray(r.model.positions(state["names"]))
            still = float(np.max(np.abs(q - state["last"]))) < 1e-4
            state["last"] = q
            return still or float(np.max(np.abs(q - state["goal"]))) < 0.01

        return r.submit(
            call,
            frozenset(joints),
            begin,
            value=value,
            info={"joints": joints},
            arrived=arrived,
            grace_s=2.0,  # the physics may lag the estimate; never hang for ever
        )

    def openHand(self, handName: str) -> Any:
        """Blocking: open ``LHand`` or ``RHand``."""
        return self._hand("openHand", handName, 1.0)

    def closeHand(self, handName: str) -> Any:
        """Blocking: close ``LHand`` or ``RHand``."""
        return self._hand("closeHand", handName, 0.0)

    @qi.nobind
    def _hand(self, call: str, hand: object, value: float) -> Any:
        if hand not in ("LHand", "RHand"):
            raise ValueError(f"ALMotion.{call}: expected 'LHand' or 'RHand', got {hand!r}")
        return self._move_to(call, [str(hand)], [value], 0.5)

    # -- reading -------------------------------------------------------------------------------
    @qi.bind(qi.List(qi.Float), (qi.Dynamic, qi.Bool), "getAngles")
    def getAngles(self, names: object, useSensors: bool) -> list[float]:
        """Measured angles (useSensors) or the last commanded ones; float32 like the robot."""
        r = self._r
        joints = r.expand(names, "getAngles")
        with r.lock:
            if useSensors:
                return r.model.positions(joints)
            return [r.commanded.get(j, 0.0) for j in joints]

    @qi.bind(qi.List(qi.List(qi.Float)), (qi.String,), "getLimits")
    def getLimits(self, name: str) -> list[list[float]]:
        """``[[min, max, maxVelocity, maxTorque], …]``, one inner list per joint."""
        r = self._r
        return [
            [s.lower, s.upper, s.velocity, s.effort]
            for s in (r.specs[j] for j in r.expand(name, "getLimits"))
        ]

    def getBodyNames(self, name: str) -> list[str]:
        """Joint names of a joint, chain or group (``"Chains"`` lists the chains)."""
        if name == "Chains":
            return list(GROUPS["Chains"])
        return self._r.expand(name, "getBodyNames")

    def getJointNames(self, name: str) -> list[str]:
        """Deprecated alias of getBodyNames."""
        return self.getBodyNames(name)

    def getMotionCycleTime(self) -> int:
        """ALMotion's cycle, in ms (NAOqi: 20)."""
        return 20

    # -- stiffness and life cycle ------------------------------------------------------------------
    def setStiffnesses(self, names: object, stiffnesses: object) -> None:
        """Set stiffness 0..1 (a scalar for all, or one per joint)."""
        r = self._r
        joints = r.expand(names, "setStiffnesses")
        values = (
            [_num(s, "stiffness") for s in stiffnesses]
            if _is_seq(stiffnesses)
            else [_num(stiffnesses, "stiffness")] * len(joints)
        )
        if len(values) != len(joints):
            raise ValueError(
                f"ALMotion.setStiffnesses: {len(values)} values for {len(joints)} joints"
            )
        with r.lock:
            for j, v in zip(joints, values, strict=True):
                r.stiffness[j] = min(max(v, 0.0), 1.0)

    def stiffnessInterpolation(
        self, names: object, stiffnessLists: object, timeLists: object
    ) -> Any:
        """Blocking: reach the last stiffness of each list after its last time (stepwise here)."""
        r = self._r
        joints = r.expand(names, "stiffnessInterpolation")
        values = _per_joint(stiffnessLists, len(joints), "stiffness", "stiffnessInterpolation")
        times = _per_joint(timeLists, len(joints), "time", "stiffnessInterpolation")

        def begin(now: float) -> float:
            for j, v in zip(joints, values, strict=True):
                r.stiffness[j] = min(max(v[-1], 0.0), 1.0)
            return max(t[-1] for t in times)

        return r.submit("stiffnessInterpolation", frozenset(), begin)

    def getStiffnesses(self, names: object) -> list[float]:
        r = self._r
        joints = r.expand(names, "getStiffnesses")
        with r.lock:
            return [r.stiffness[j] for j in joints]

    def wakeUp(self) -> None:
        """Motors on (the simulated NAO already stands)."""
        with self._r.lock:
            for j in self._r.stiffness:
                self._r.stiffness[j] = 1.0

    @qi.bind(qi.Dynamic, (), "rest")
    def rest0(self) -> None:
        """Kill the motion tasks and switch every motor off."""
        self._rest("Body")

    @qi.bind(qi.Dynamic, (qi.String,), "rest")
    def rest1(self, chain: str) -> None:
        """Switch one chain's motors off."""
        self._rest(chain)

    @qi.nobind
    def _rest(self, chain: str) -> None:
        r = self._r
        joints = r.expand(chain, "rest")
        with r.lock:
            done = r.kill_locked(frozenset(joints))
            for j in joints:
                r.stiffness[j] = 0.0
        r.settle(done)

    def robotIsWakeUp(self) -> bool:
        with self._r.lock:
            return any(v > 0.0 for v in self._r.stiffness.values())

    # -- tasks ---------------------------------------------------------------------------------
    def killAll(self) -> None:
        """Kill every motion task (their blocking calls return)."""
        r = self._r
        with r.lock:
            done = r.kill_locked(None)
        r.settle(done)

    def killTasksUsingResources(self, resourceNames: object) -> None:
        """Kill the motion tasks that hold any of these joints."""
        r = self._r
        joints = frozenset(r.expand(resourceNames, "killTasksUsingResources"))
        with r.lock:
            done = r.kill_locked(joints)
        r.settle(done)

    def areResourcesAvailable(self, resourceNames: object) -> bool:
        r = self._r
        joints = frozenset(r.expand(resourceNames, "areResourcesAvailable"))
        with r.lock:
            return not r.busy_locked(joints)

    def getTaskList(self) -> list[list[Any]]:
        """``[[name, id], …]`` for the motion tasks running or waiting."""
        r = self._r
        with r.lock:
            return r.motion_tasks_locked()

    # -- idle animations (no-ops here, remembered for the getters) -----------------------------
    def setBreathEnabled(self, chainName: str, isEnabled: bool) -> None:
        self._r.expand(chainName, "setBreathEnabled")
        self._r.breath[chainName] = bool(isEnabled)

    def getBreathEnabled(self, chainName: str) -> bool:
        return self._r.breath.get(chainName, False)

    def setIdlePostureEnabled(self, chainName: str, isEnabled: bool) -> None:
        self._r.expand(chainName, "setIdlePostureEnabled")
        self._r.idle_posture[chainName] = bool(isEnabled)

    def getIdlePostureEnabled(self, chainName: str) -> bool:
        return self._r.idle_posture.get(chainName, False)


class ALTextToSpeech:
    """ALTextToSpeech on the virtual NAO: ``say`` takes as long as the planner's estimate."""

    def __init__(self, robot: VirtualNao) -> None:
        self._r = robot

    @qi.bind(qi.Dynamic, (qi.String,), "say")
    def say1(self, text: str) -> Any:
        """Blocking: say ``text`` (queued after the sentence being spoken)."""
        return self._say(text, self._r.language)

    @qi.bind(qi.Dynamic, (qi.String, qi.String), "say")
    def say2(self, text: str, language: str) -> Any:
        """Blocking: say ``text`` in ``language``."""
        return self._say(text, language)

    @qi.nobind
    def _say(self, text: object, language: str) -> Any:
        if not isinstance(text, str):
            raise TypeError(f"ALTextToSpeech.say: text must be a string, got {text!r}")
        r = self._r
        plain = _TTS_TAG.sub(" ", text)
        duration = estimate_speech_s(plain) * 100.0 / max(r.tts_params["speed"], 1.0)
        say_log.info("say (%s, %.1f s): %s", language, duration, " ".join(plain.split()))

        def begin(now: float) -> float:
            r.memory["ALTextToSpeech/TextStarted"] = 1
            r.memory["ALTextToSpeech/CurrentSentence"] = text
            return duration

        def finish(ok: bool) -> None:
            r.memory["ALTextToSpeech/TextStarted"] = 0
            r.memory["ALTextToSpeech/TextDone" if ok else "ALTextToSpeech/TextInterrupted"] = 1

        return r.submit(
            "say",
            frozenset({"tts"}),
            begin,
            finish=finish,
            info={"text": text, "language": language, "planned_s": round(duration, 6)},
        )

    def stopAll(self) -> None:
        """Stop the sentence being said and drop the queued ones."""
        r = self._r
        with r.lock:
            done = r.kill_locked(frozenset({"tts"}))
        r.settle(done)

    def setVolume(self, volume: object) -> None:
        """0.0 … 1.0."""
        v = _num(volume, "volume")
        if not 0.0 <= v <= 1.0:
            raise ValueError(f"ALTextToSpeech.setVolume: volume must be in 0..1, got {v}")
        self._r.tts_params["volume"] = v

    def getVolume(self) -> float:
        """0 … 100, as NAOqi describes it."""
        return self._r.tts_params["volume"] * 100.0

    def setParameter(self, parameter: str, value: object) -> None:
        """``speed`` (percent; 50–400 accepted here), ``pitchShift``, ``doubleVoice``…"""
        v = _num(value, parameter)
        if parameter == "speed" and not 50.0 <= v <= 400.0:
            raise ValueError(f"ALTextToSpeech.setParameter: speed must be in 50..400, got {v}")
        self._r.tts_params[str(parameter)] = v

    def getParameter(self, parameter: str) -> float:
        try:
            return self._r.tts_params[parameter]
        except KeyError:
            raise ValueError(
                f"ALTextToSpeech.getParameter: unknown parameter '{parameter}'"
            ) from None

    def resetSpeed(self) -> None:
        self._r.tts_params["speed"] = 100.0

    def setLanguage(self, language: str) -> None:
        if language not in self.getAvailableLanguages():
            raise ValueError(f"ALTextToSpeech.setLanguage: language '{language}' is not installed")
        self._r.language = language

    def getLanguage(self) -> str:
        return self._r.language

    def getAvailableLanguages(self) -> list[str]:
        return ["English", "French", "German", "Spanish", "Italian", "Japanese", "Chinese"]


class ALLeds:
    """ALLeds on the virtual NAO: remembers each group's colour; fades take their duration."""

    def __init__(self, robot: VirtualNao) -> None:
        self._r = robot

    def fadeRGB(self, *args: Any) -> Any:
        """Blocking fade.

        Forms: ``(name, 0xRRGGBB, secs)``, ``(name, colorName, secs)``, ``(name, r, g, b, secs)``.
        """
        if len(args) == 3:
            name, color, duration = args
            if isinstance(color, str):
                if color not in LED_COLORS:
                    raise ValueError(
                        f"ALLeds.fadeRGB: unknown colour '{color}'"
                        + did_you_mean(color, LED_COLORS)
                    )
                rgb = LED_COLORS[color]
            else:
                rgb = int(_num(color, "rgb"))
        elif len(args) == 5:
            name, red, green, blue, duration = args
            ch = [min(max(_num(c, "channel"), 0.0), 1.0) for c in (red, green, blue)]
            rgb = (round(ch[0] * 255) << 16) | (round(ch[1] * 255) << 8) | round(ch[2] * 255)
        else:
            raise TypeError(f"ALLeds.fadeRGB: expected 3 or 5 arguments, got {len(args)}")
        self._check(name)
        secs = _num(duration, "duration")
        r = self._r

        def begin(now: float) -> float:
            r.leds[name] = rgb & 0xFFFFFF
            return max(secs, 0.0)

        return r.submit("fadeRGB", frozenset(), begin, info={"group": name, "rgb": rgb})

    @qi.nobind
    def _check(self, name: object) -> None:
        if name not in LED_GROUPS:
            raise ValueError(
                f"ALLeds: unknown LED group {name!r}" + did_you_mean(str(name), LED_GROUPS)
            )

    def getColor(self, name: str) -> int:
        """The group's colour as 0x00RRGGBB (virtual NAO only: a test hook)."""
        self._check(name)
        return self._r.leds[name]

    def reset(self, name: str) -> None:
        self._check(name)
        self._r.leds[name] = 0xFFFFFF

    def listGroups(self) -> list[str]:
        return sorted(LED_GROUPS)


class ALRobotPosture:
    """ALRobotPosture on the virtual NAO (approximate postures, see :data:`POSTURES`)."""

    def __init__(self, robot: VirtualNao, motion: ALMotion) -> None:
        self._r = robot
        self._motion = motion

    def goToPosture(self, postureName: str, maxSpeedFraction: object) -> Any:
        """Blocking: move every joint of the posture; returns True when reached."""
        pose = self._pose(postureName)
        frac = _num(maxSpeedFraction, "maxSpeedFraction")
        if not frac > 0:
            raise ValueError("ALRobotPosture.goToPosture: maxSpeedFraction must be > 0")
        self._r.posture = postureName
        return self._motion._move_to(
            "goToPosture", list(pose), list(pose.values()), min(frac, 1.0), True
        )

    def applyPosture(self, postureName: str, maxSpeedFraction: object) -> Any:
        return self.goToPosture(postureName, maxSpeedFraction)

    @qi.nobind
    def _pose(self, name: object) -> dict[str, float]:
        if name not in POSTURES:
            raise ValueError(
                f"ALRobotPosture: unknown posture {name!r}" + did_you_mean(str(name), POSTURES)
            )
        return POSTURES[str(name)]

    def getPostureList(self) -> list[str]:
        return list(POSTURES)

    def getPosture(self) -> str:
        return self._r.posture


class ALMemory:
    """A minimal ALMemory: a key-value store (the TTS writes its events here)."""

    def __init__(self, robot: VirtualNao) -> None:
        self._r = robot

    def getData(self, key: str) -> Any:
        try:
            return self._r.memory[key]
        except KeyError:
            raise KeyError(f"ALMemory.getData: data not found: '{key}'") from None

    def insertData(self, key: str, value: Any) -> None:
        self._r.memory[str(key)] = value

    def getListData(self, keys: list[str]) -> list[Any]:
        return [self._r.memory.get(k) for k in keys]

    def getDataList(self, filter: str) -> list[str]:
        return sorted(k for k in self._r.memory if filter in k)

    def raiseEvent(self, name: str, value: Any) -> None:
        self._r.memory[str(name)] = value

    def removeData(self, key: str) -> None:
        self._r.memory.pop(str(key), None)


#: NAO's autonomous abilities and their defaults (all on, as on a NAO out of the box).
AUTONOMOUS_ABILITIES: dict[str, bool] = {
    "AutonomousBlinking": True,
    "BackgroundMovement": True,
    "BasicAwareness": True,
    "ListeningMovement": True,
    "SpeakingMovement": True,
}
#: ALAutonomousLife's states; a NAO boots into "solitary".
LIFE_STATES = ("solitary", "interactive", "safeguard", "disabled")


class ALAutonomousLife:
    """ALAutonomousLife with NAOqi's method names; remembers states, moves nothing.

    The abilities' effects (head tracking, breathing-like movements) are not simulated: this
    only lets a client read and set them as on a real NAO.
    """

    def __init__(self, robot: VirtualNao) -> None:
        self._r = robot
        self._abilities = dict(AUTONOMOUS_ABILITIES)
        self._state = "solitary"

    def _ability(self, name: object, method: str) -> str:
        if name not in self._abilities:
            raise ValueError(
                f"ALAutonomousLife.{method}: unknown ability {name!r}"
                f"{did_you_mean(str(name), list(self._abilities))}"
            )
        return str(name)

    def getAutonomousAbilityEnabled(self, autonomousAbility: str) -> bool:
        return self._abilities[self._ability(autonomousAbility, "getAutonomousAbilityEnabled")]

    def setAutonomousAbilityEnabled(self, autonomousAbility: str, enabled: bool) -> None:
        name = self._ability(autonomousAbility, "setAutonomousAbilityEnabled")
        self._abilities[name] = bool(enabled)
        log.info("autonomous ability %s %s", name, "on" if enabled else "off")

    def getAutonomousAbilitiesStatus(self) -> list[list[Any]]:
        return [[n, on] for n, on in self._abilities.items()]

    def getState(self) -> str:
        return self._state

    def setState(self, state: str) -> None:
        if state not in LIFE_STATES:
            raise ValueError(f"ALAutonomousLife.setState: unknown state {state!r}")
        self._state = str(state)
