"""The NAOqi backend: a real NAO (or the virtual one in ``sim.virtual_nao``) through ``qi``.

Gestures go to ``ALMotion.angleInterpolation(names, angleLists, timeLists, True)`` with the
project's own keyframe times (:class:`~prezence.feedback.trajectory.Trajectory`), phrases to
``ALTextToSpeech.say``; both as ``_async=True`` calls whose futures :meth:`advance` polls.

libqi has no timeouts of its own (a hung host or a frozen robot leaves a call running for
ever), so every remote call here has a deadline:

- connecting: ``connect_timeout_s``; setting up (services, wake-up): ``call_timeout_s`` per call
  (``wake_timeout_s`` for ``wakeUp`` and the move to the neutral pose, which move the robot);
- a gesture or phrase: its planned duration plus ``motion_margin_s`` (phrases: twice the
  planned duration, since the robot's voice rate is not ours); past it the motion fails, the
  call is cancelled and the robot's task killed;
- a heartbeat (``getAngles``) every ``heartbeat_s`` must answer within ``call_timeout_s``, or the
  link counts as lost: this is how a frozen robot or a dead network is noticed.

**A lost robot drops cues.** When the session disconnects (``disconnected`` signal, a
"Session closed"/"Socket is not connected" error, or a missed heartbeat) the running motions
finish with ``ok=False``, and :meth:`play`/:meth:`say` raise
:class:`~prezence.errors.BackendUnavailable` until the robot is back (the coach records a
dropped cue and goes on; nothing is queued). Meanwhile :meth:`advance` reconnects in the
background (a worker thread, so ``advance`` never blocks), with exponential backoff from
``reconnect_initial_s`` to ``reconnect_max_s``, and fetches fresh proxies (old ones stay dead).

What the backend changes on the robot at :meth:`open`: it claims the robot (ALMemory
``CLAIM_KEY``, refreshed while the talk runs, removed at close; a live claim of another talk
refuses the open), turns off the autonomous abilities that move joints and are on
(``BackgroundMovement``, ``BasicAwareness``, ``ListeningMovement``, ``SpeakingMovement``, read
with ``ALAutonomousLife.getAutonomousAbilityEnabled``; one it cannot read is left alone; or
pauses ``ALBasicAwareness`` on older NAOqi), calls ``ALMotion.wakeUp()`` (stiffness on,
standing), disables breathing and the idle posture (those on), and then moves the head and arms
to the gesture library's neutral pose (the pose
every gesture is planned from; ``angleInterpolationWithSpeed`` at ``neutral_speed_fraction``,
waiting up to ``wake_timeout_s``), so the first gesture starts where its timing assumed. The
legs stay as ``wakeUp`` stood them: no gesture moves them and balance is the robot's. Each of the
optional steps is skipped, with a log line, where the robot lacks it (wakeUp and the move to
neutral are required). At :meth:`close` (every close, an interrupted one too) head and arms go
back to the neutral pose, then what it turned off is turned back on: the state the *first*
connection found (a reconnect reads back its own "off"). A gesture killed at its deadline is
followed by the same move back to neutral (``busy`` until there). A motion running when the link
is lost ends with ``ok=False`` and ``info["outcome"] = "unknown"``: the robot may finish it.
**Stiffness policy:** the backend never sets stiffness to 0 on a standing robot (it would fall);
stiffness stays on at close unless ``rest_on_close=True``, which calls ``ALMotion.rest()``
(crouch, then motors off).

**Too fast.** A gesture whose planned peak speed of some joint (exact, from the trajectory's
profile) exceeds the robot's own velocity limit (``ALMotion.getLimits``) by more than
``TOO_FAST_TOLERANCE`` is logged and counted as ``too_fast`` in :meth:`stats`; it is sent as it
is (NAOqi does not document what it does with it).

Time: the ``now`` passed to :meth:`play`/:meth:`say`/:meth:`advance` stamps the motions; the
deadlines and latencies use the host's monotonic clock, because the robot keeps real time
whatever the caller's clock does. A talk on this backend is paced to the wall clock
(:attr:`realtime`), ``--realtime`` or not.
"""

from __future__ import annotations

import collections
import concurrent.futures
import json
import logging
import os
import socket
import threading
import time
import uuid
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

from prezence.backends.base import Backend, Motion, MotionKind
from prezence.errors import BackendUnavailable, ConfigError, UnknownName
from prezence.feedback.trajectory import Trajectory

log = logging.getLogger(__name__)

#: The autonomous abilities (NAOqi 2.4+) that move joints and would fight our gestures.
AUTONOMOUS_ABILITIES = (
    "BackgroundMovement",
    "BasicAwareness",
    "ListeningMovement",
    "SpeakingMovement",
)
#: Eye colour while a cue runs, and at rest (0x00RRGGBB, as ALLeds.fadeRGB takes it).
CUE_RGB = 0x00FF8C00
IDLE_RGB = 0x00FFFFFF
#: A planned peak speed up to this fraction over the robot's limit is not too fast (the robot
#: reports its limits as 32-bit floats; the planner works at exactly 100 % of the URDF's).
TOO_FAST_TOLERANCE = 0.01
#: Default share of the velocity limits for the move to the neutral pose at open: slow and safe.
NEUTRAL_SPEED_FRACTION = 0.2
#: The chains moved to the library's neutral pose at open (the legs are left standing).
NEUTRAL_CHAINS = ("Head", "LArm", "RArm")
#: The highest gesture speed fraction advised on a real NAO: the URDF's velocity limits the
#: planner uses are no-load values that a loaded real joint does not reach; the reference
#: (nao_facts.md §4, velocities) advises derating them to about 0.7 or less.
REAL_NAO_SPEED_MAX = 0.7
#: The ALMemory key where a talk claims the robot: JSON with pid, host, start and refresh times
#: (the host's wall clock, seconds since the epoch), removed at close.
CLAIM_KEY = "Prezence/Talk"
#: How often a talk refreshes its claim, and after how long without a refresh a claim is stale
#: (its talk died without removing it); both in seconds of the hosts' wall clocks.
CLAIM_REFRESH_S = 2.0
CLAIM_STALE_S = 15.0
#: Error texts with which libqi reports a dead connection.
_LOST_MARKERS = (
    "Session closed",
    "Socket is not connected",
    "Session not connected",
    "disconnected",
)


def _import_qi() -> Any:
    try:
        import qi
    except ImportError as e:
        raise BackendUnavailable('naoqi needs qi: pip install "prezence[naoqi]"') from e
    # libqi logs to stdout, where a talk prints its timeline or its --json summary: its
    # warnings ("[W] … qi.path.sdklayout: No Application was created …" at every connect) only
    # with -vv, its errors always
    qi.logging.setLevel(qi.logging.WARNING if log.isEnabledFor(logging.DEBUG) else qi.logging.ERROR)
    return qi


def robot_url(url: str) -> str:
    """The NAOqi address ``url`` as ``tcp://HOST:PORT``; ``HOST``, ``HOST:PORT`` and
    ``tcp://HOST`` are completed with NAOqi's port 9559.

    libqi itself reads a port it cannot parse (``tcp://nao:99999``, ``tcp://nao:9559/x``) as no
    port and connects to 9559, i.e. to whatever else listens there, so such an address is
    refused here, as are other schemes and ``tcps://`` (NAOqi 2.9+, not supported yet).

    Raises:
        ConfigError: not such an address, naming what is wrong.

    Example:
        >>> robot_url("192.168.1.12"), robot_url("tcp://nao.local:9600")
        ('tcp://192.168.1.12:9559', 'tcp://nao.local:9600')
    """
    text = url.strip() if isinstance(url, str) else ""
    want = "want a NAOqi address like tcp://HOST:9559"
    if not text:
        raise ConfigError(f"robot URL {url!r}: {want}")
    scheme, sep, rest = text.partition("://")
    if not sep:
        scheme, rest = "tcp", text
    if scheme.lower() == "tcps":
        raise ConfigError(
            f"robot URL {text}: tcps:// (NAOqi 2.9+, with an authenticator) is not supported by "
            "this backend yet; NAO6 on NAOqi 2.8 and older NAOs use tcp://HOST:9559"
        )
    if scheme.lower() != "tcp":
        raise ConfigError(f"robot URL {text}: the scheme must be tcp://, not {scheme}://; {want}")
    if rest.startswith("["):  # [IPv6]:PORT
        close = rest.find("]")
        host, port = rest[: close + 1], rest[close + 1 :]
        if close < 0 or (port and not port.startswith(":")):
            raise ConfigError(f"robot URL {text}: {want}")
        port = port[1:] if port else ""
    else:
        host, colon, port = rest.partition(":")
    if not host or any(c in host for c in "/?#@ \t"):
        raise ConfigError(f"robot URL {text}: no host name or address before the port; {want}")
    given = port or (":" in rest.rpartition("]")[2])
    if given and not (port.isascii() and port.isdigit() and 1 <= int(port) <= 65535):
        misread = "" if port == "0" else " (libqi would ignore it and connect to port 9559)"
        raise ConfigError(
            f"robot URL {text}: the port must be a number from 1 to 65535, got {port!r}{misread}"
        )
    return f"tcp://{host}:{int(port) if port else 9559}"


def _looks_lost(error: str) -> bool:
    return any(m in error for m in _LOST_MARKERS)


def _first_line(error: str) -> str:
    return error.strip().splitlines()[0] if error.strip() else "unknown error"


def _percentile(values: list[float], q: float) -> float:
    ordered = sorted(values)
    k = min(len(ordered) - 1, max(0, round(q / 100.0 * (len(ordered) - 1))))
    return ordered[k]


@dataclass
class _Link:
    """One connection to the robot and the proxies fetched on it (proxies die with it)."""

    session: Any
    motion: Any
    tts: Any
    leds: Any | None
    joints: tuple[str, ...]
    velocity: dict[str, float]
    lost: threading.Event
    reason: list[str]
    #: what this link's set-up turned off: (service name, method, args) that turn it back on
    restore: list[tuple[str, str, tuple[Any, ...]]] = field(default_factory=list)
    proxies: dict[str, Any] = field(default_factory=dict)


@dataclass
class _Call:
    """A gesture or phrase the robot is performing."""

    motion: Motion
    future: Any
    sent: float
    deadline: float
    joints: tuple[str, ...]
    done_at: list[float]


class NaoqiBackend(Backend):
    """Drives a NAO over NAOqi (``qi``).

    Args:
        url: the robot, ``tcp://HOST:9559`` (``HOST`` or ``HOST:PORT`` work too; checked and
            completed by :func:`robot_url`, which raises ConfigError for a bad one).
        connect_timeout_s: how long connecting may take before the robot counts as unreachable.
        call_timeout_s: deadline for short calls (set-up, heartbeat, kills).
        wake_timeout_s: deadline for ``wakeUp`` (the robot may stand up first) and for the move
            to the neutral pose.
        neutral_speed_fraction: fraction of the velocity limits for the move to the neutral
            pose at open, in (0, 1].
        leds: colour the eyes while a cue runs (needs ALLeds; skipped if the robot lacks it).
        motion_margin_s: slack added to a motion's planned duration before it fails.
        heartbeat_s: seconds between liveness checks while connected.
        reconnect_initial_s: first wait before reconnecting after a loss.
        reconnect_max_s: the wait doubles after each failed attempt, up to this.
        rest_on_close: call ``ALMotion.rest()`` at close (crouch and motors off).
    """

    name = "naoqi"
    realtime = True
    physical = True

    def __init__(
        self,
        *,
        url: str,
        connect_timeout_s: float = 5.0,
        call_timeout_s: float = 2.0,
        wake_timeout_s: float = 15.0,
        neutral_speed_fraction: float = NEUTRAL_SPEED_FRACTION,
        leds: bool = False,
        motion_margin_s: float = 1.0,
        heartbeat_s: float = 1.0,
        reconnect_initial_s: float = 0.5,
        reconnect_max_s: float = 10.0,
        rest_on_close: bool = False,
    ) -> None:
        super().__init__()
        url = robot_url(url)
        for key, value in (
            ("connect_timeout_s", connect_timeout_s),
            ("call_timeout_s", call_timeout_s),
            ("wake_timeout_s", wake_timeout_s),
            ("heartbeat_s", heartbeat_s),
            ("reconnect_initial_s", reconnect_initial_s),
        ):
            if not value > 0:
                raise ValueError(f"{key} must be > 0, got {value!r}")
        if not motion_margin_s >= 0:
            raise ValueError(f"motion_margin_s must be >= 0, got {motion_margin_s!r}")
        if not 0 < neutral_speed_fraction <= 1:
            raise ValueError(
                f"neutral_speed_fraction must be in (0, 1], got {neutral_speed_fraction!r}"
            )
        if not reconnect_max_s >= reconnect_initial_s:
            raise ValueError("reconnect_max_s must be >= reconnect_initial_s")
        if neutral_speed_fraction > REAL_NAO_SPEED_MAX:
            # as for a talk's --speed: the URDF's velocities are no-load values
            log.warning(
                "neutral_speed_fraction %.2g moves to the neutral pose at %.0f%% of the joints' "
                "maximum speed, which a loaded real NAO joint does not reach; use %.1f or less "
                "on a real robot (docs/naoqi.md)",
                neutral_speed_fraction,
                100 * neutral_speed_fraction,
                REAL_NAO_SPEED_MAX,
            )
        self.url = url
        self.connect_timeout_s = float(connect_timeout_s)
        self.call_timeout_s = float(call_timeout_s)
        self.wake_timeout_s = float(wake_timeout_s)
        self.neutral_speed_fraction = float(neutral_speed_fraction)
        self.leds = leds
        self.motion_margin_s = float(motion_margin_s)
        self.heartbeat_s = float(heartbeat_s)
        self.reconnect_initial_s = float(reconnect_initial_s)
        self.reconnect_max_s = float(reconnect_max_s)
        self.rest_on_close = rest_on_close
        self._qi: Any = None
        self._link: _Link | None = None
        self._calls: list[_Call] = []
        self._aside: list[Any] = []  # fire-and-forget futures, kept alive until they finish
        # after a gesture killed at its deadline: the kill's future, then the move back to the
        # neutral pose (the next gesture is planned from there); busy until both have ended
        self._homing: list[Any] = []
        self._homing_kind = ""  # "kill" or "home"
        self._homing_until = 0.0
        self._lost_reason = ""
        self._backoff = self.reconnect_initial_s
        self._next_attempt = 0.0
        self._attempt: concurrent.futures.Future[_Link] | None = None
        self._executor: concurrent.futures.ThreadPoolExecutor | None = None
        self._ping: tuple[Any, float, list[float]] | None = None
        self._next_ping = 0.0
        self._eyes_on = False
        self._restore: list[tuple[str, str, tuple[Any, ...]]] = []
        self._claim = {
            "id": uuid.uuid4().hex,
            "pid": os.getpid(),
            "host": socket.gethostname(),
            "started": time.time(),
        }
        self._next_claim = 0.0
        self._rtt_ms: collections.deque[float] = collections.deque(maxlen=2000)
        self._counts = {
            "connects": 0,
            "disconnects": 0,
            "dropped": 0,
            "failed": 0,
            "timeouts": 0,
            "too_fast": 0,
        }

    # -- state ---------------------------------------------------------------------------------
    @property
    def connected(self) -> bool:
        """True while a live session with fresh proxies is in use."""
        return self._link is not None and not self._link.lost.is_set()

    def stats(self) -> dict[str, Any]:
        """Connection counts, dropped/failed/timed-out motions and heartbeat round trips (ms)."""
        rtt = list(self._rtt_ms)
        return {
            "url": self.url,
            "connected": self.connected,
            **self._counts,
            "call_rtt_n": len(rtt),
            "call_rtt_ms_p50": round(_percentile(rtt, 50), 3) if rtt else None,
            "call_rtt_ms_p99": round(_percentile(rtt, 99), 3) if rtt else None,
        }

    # -- connecting ------------------------------------------------------------------------------
    def _open(self) -> None:
        self._qi = _import_qi()
        self._install(self._connect())

    def _install(self, link: _Link) -> None:
        self._link = link
        # the robot's own state is what the FIRST link read: a reconnect reads back the values
        # this backend set (off), so its list adds only what a rebooted robot turned on again
        for entry in link.restore:
            if entry not in self._restore:
                self._restore.append(entry)
        self._counts["connects"] += 1
        self._backoff = self.reconnect_initial_s
        self._next_ping = time.monotonic() + self.heartbeat_s
        self._eyes_on = False
        log.info("connected to NAOqi at %s (%d joints)", self.url, len(link.joints))

    def _wait(self, fut: Any, what: str, timeout_s: float) -> Any:
        """The future's value, or BackendUnavailable when it fails or misses its deadline."""
        qi = self._qi
        state = fut.wait(int(timeout_s * 1000))
        if state == qi.FutureState.FinishedWithValue:
            return fut.value()
        if state == qi.FutureState.FinishedWithError:
            raise BackendUnavailable(f"{what} failed on {self.url}: {_first_line(fut.error())}")
        fut.cancel()
        raise BackendUnavailable(f"{what}: no answer from {self.url} within {timeout_s:g} s")

    def _connect(self) -> _Link:
        """Connect, fetch proxies, prepare the robot; blocking but bounded by the deadlines."""
        qi = self._qi
        session = qi.Session()
        fut = session.connect(self.url, _async=True)
        state = fut.wait(int(self.connect_timeout_s * 1000))
        if state != qi.FutureState.FinishedWithValue:
            why = (
                _first_line(fut.error())
                if state == qi.FutureState.FinishedWithError
                else f"no answer within {self.connect_timeout_s:g} s"
            )
            session.close(_async=True)  # also abandons a connect that hangs
            raise BackendUnavailable(
                f"no NAOqi robot at {self.url}: {why} (is the robot on and on this network? "
                "press its chest button once to hear its IP address)"
            )
        lost = threading.Event()
        reason: list[str] = []

        def on_disconnected(why: str) -> None:
            reason.append(str(why))
            lost.set()

        session.disconnected.connect(on_disconnected)
        try:
            link = self._set_up(session, lost, reason)
        except BackendUnavailable:
            session.close(_async=True)
            raise
        if self._closed:  # closed while this ran in the reconnect thread
            session.close(_async=True)
            raise BackendUnavailable("backend closed")
        return link

    def _service(self, session: Any, name: str, *, required: bool) -> Any | None:
        try:
            return self._wait(session.service(name, _async=True), name, self.call_timeout_s)
        except BackendUnavailable as e:
            if required:
                raise BackendUnavailable(f"the robot at {self.url} has no {name}: {e}") from e
            log.info("%s: not available (%s); skipped", name, e)
            return None

    def _optional(self, proxy: Any | None, method: str, *args: Any) -> tuple[bool, Any]:
        """Call ``proxy.method(*args)`` if the robot has it; (done, value)."""
        if proxy is None or not hasattr(proxy, method):
            log.info("robot has no %s: skipped", method)
            return False, None
        try:
            fut = getattr(proxy, method)(*args, _async=True)
            return True, self._wait(fut, method, self.call_timeout_s)
        except (BackendUnavailable, RuntimeError) as e:
            log.info("%s%r: %s; skipped", method, args, e)
            return False, None

    def _claim_text(self) -> str:
        return json.dumps({**self._claim, "refreshed": time.time()})

    def _take_claim(self, memory: Any | None) -> None:
        """Claim the robot in ALMemory (``CLAIM_KEY``); refuse it when another talk holds a
        live claim (refreshed within ``CLAIM_STALE_S``). Skipped when the robot has no ALMemory."""
        if memory is None:
            return
        try:
            held = self._wait(
                memory.getData(CLAIM_KEY, _async=True), "ALMemory.getData", self.call_timeout_s
            )
        except BackendUnavailable:
            held = None  # no claim (getData raises for a key it does not have)
        other: dict[str, Any] = {}
        if isinstance(held, str) and held:
            try:
                loaded = json.loads(held)
            except ValueError:
                loaded = {}
            other = loaded if isinstance(loaded, dict) else {}
        if other and other.get("id") != self._claim["id"]:
            age = time.time() - float(other.get("refreshed") or 0.0)
            if abs(age) <= CLAIM_STALE_S:  # (a claim from the future: a host's clock is off)
                started = time.strftime(
                    "%H:%M:%S", time.localtime(float(other.get("started") or 0.0))
                )
                raise BackendUnavailable(
                    f"the robot at {self.url} is in use by another Prezence talk (pid "
                    f"{other.get('pid')} on {other.get('host')}, started {started}, last seen "
                    f"{max(0.0, age):.0f} s ago): two talks on one robot disturb each other; "
                    f"wait until it ends (a talk that died without closing frees the robot "
                    f"{CLAIM_STALE_S:g} s after its last sign of life)"
                )
            log.warning(
                "taking over a stale claim on the robot (pid %s on %s, not refreshed for %.0f s)",
                other.get("pid"),
                other.get("host"),
                age,
            )
        self._optional(memory, "insertData", CLAIM_KEY, self._claim_text())

    def _set_up(self, session: Any, lost: threading.Event, reason: list[str]) -> _Link:
        motion: Any = self._service(session, "ALMotion", required=True)
        tts: Any = self._service(session, "ALTextToSpeech", required=True)
        memory = self._service(session, "ALMemory", required=False)
        if self._counts["connects"] == 0:  # a reconnect finds its own claim, or none
            self._take_claim(memory)
        else:
            self._optional(memory, "insertData", CLAIM_KEY, self._claim_text())
        leds = self._service(session, "ALLeds", required=False) if self.leds else None
        # what to put back at close, by service name (proxies die with their link); only what
        # was read as on, and only what could be read: what cannot be put back is left alone
        restore: list[tuple[str, str, tuple[Any, ...]]] = []
        proxies: dict[str, Any] = {"ALMotion": motion, "ALMemory": memory}
        life = self._service(session, "ALAutonomousLife", required=False)
        if life is not None and hasattr(life, "setAutonomousAbilityEnabled"):
            proxies["ALAutonomousLife"] = life
            for ability in AUTONOMOUS_ABILITIES:
                read, was = self._optional(life, "getAutonomousAbilityEnabled", ability)
                if not read:
                    log.warning(
                        "could not read the autonomous ability %s: left as it is (it may move "
                        "joints during gestures)",
                        ability,
                    )
                    continue
                if not was:
                    continue
                done, _ = self._optional(life, "setAutonomousAbilityEnabled", ability, False)
                if done:
                    restore.append(
                        ("ALAutonomousLife", "setAutonomousAbilityEnabled", (ability, True))
                    )
        else:
            awareness = self._service(session, "ALBasicAwareness", required=False)
            done, _ = self._optional(awareness, "pauseAwareness")
            if done:
                proxies["ALBasicAwareness"] = awareness
                restore.append(("ALBasicAwareness", "resumeAwareness", ()))
        self._wait(motion.wakeUp(_async=True), "ALMotion.wakeUp", self.wake_timeout_s)
        for setter, getter in (
            ("setBreathEnabled", "getBreathEnabled"),
            ("setIdlePostureEnabled", "getIdlePostureEnabled"),
        ):
            read, was = self._optional(motion, getter, "Body")
            if not read:
                log.warning("could not read %s: left as it is", getter)
                continue
            if not was:
                continue
            done, _ = self._optional(motion, setter, "Body", False)
            if done:
                restore.append(("ALMotion", setter, ("Body", True)))
        names = self._wait(
            motion.getBodyNames("Body", _async=True), "ALMotion.getBodyNames", self.call_timeout_s
        )
        limits = self._wait(
            motion.getLimits("Body", _async=True), "ALMotion.getLimits", self.call_timeout_s
        )
        joints = tuple(str(n) for n in names)
        self._check_body(joints)
        velocity = {n: float(lim[2]) for n, lim in zip(joints, limits, strict=False)}
        self._go_neutral(motion)
        return _Link(session, motion, tts, leds, joints, velocity, lost, reason, restore, proxies)

    def _go_neutral(self, motion: Any) -> None:
        """Move head and arms to the library's neutral pose, slowly, and wait until there."""
        names, angles = neutral_targets()
        started = time.monotonic()
        self._wait(
            motion.angleInterpolationWithSpeed(
                names, angles, self.neutral_speed_fraction, _async=True
            ),
            "moving to the neutral pose (ALMotion.angleInterpolationWithSpeed)",
            self.wake_timeout_s,
        )
        log.info(
            "at the neutral pose (%d joints) after %.2f s", len(names), time.monotonic() - started
        )

    def _check_body(self, joints: tuple[str, ...]) -> None:
        """The robot must have every head and arm joint of the project's NAO model."""
        from prezence.feedback.limits import load_limits

        chains = load_limits().chains
        needed = [n for c in ("Head", "LArm", "RArm") for n in chains[c]]
        missing = [n for n in needed if n not in joints]
        if missing:
            raise BackendUnavailable(
                f"the robot at {self.url} lacks joints {', '.join(missing)}: is it a NAO?"
            )

    # -- actions -------------------------------------------------------------------------------
    def _usable(self, what: str) -> _Link:
        link = self._link
        if link is None or link.lost.is_set():
            self._counts["dropped"] += 1
            why = self._lost_reason or "disconnected"
            raise BackendUnavailable(f"{what} dropped: robot at {self.url} is lost ({why})")
        return link

    def _start_gesture(self, traj: Trajectory, motion: Motion) -> None:
        link = self._usable(f"gesture {traj.name!r}")
        for j in traj.joints:
            if j not in link.joints:
                raise UnknownName("joint", j, link.joints)
        self._check_speed(traj, link)
        names = list(traj.joints)
        angles = [[float(p[k]) for p in traj.positions] for k in range(len(names))]
        times = [[float(t) for t in traj.times] for _ in names]
        self._send(
            motion,
            link,
            lambda: link.motion.angleInterpolation(names, angles, times, True, _async=True),
            joints=traj.joints,
            budget_s=traj.duration + self.motion_margin_s,
        )

    def _start_speech(self, text: str, motion: Motion) -> None:
        link = self._usable(f"phrase {text!r}")
        self._send(
            motion,
            link,
            lambda: link.tts.say(text, _async=True),
            joints=(),
            budget_s=2.0 * motion.planned_s + self.motion_margin_s,
        )

    def _send(
        self,
        motion: Motion,
        link: _Link,
        call: Callable[[], Any],
        *,
        joints: tuple[str, ...],
        budget_s: float,
    ) -> None:
        sent = time.monotonic()
        try:
            fut = call()
        except RuntimeError as e:
            self._lose(str(e), motion.started_at)
            self._counts["dropped"] += 1
            raise BackendUnavailable(f"robot at {self.url} is lost: {_first_line(str(e))}") from e
        done_at: list[float] = []
        fut.addCallback(lambda _f: done_at.append(time.monotonic()))
        self._calls.append(_Call(motion, fut, sent, sent + budget_s, joints, done_at))
        motion.info["sent_mono"] = sent
        if link.leds is not None and not self._eyes_on:
            self._eyes_on = True
            self._aside.append(link.leds.fadeRGB("FaceLeds", CUE_RGB, 0.1, _async=True))

    def _check_speed(self, traj: Trajectory, link: _Link) -> None:
        """Count the gesture as ``too_fast`` when a joint's planned peak speed exceeds the
        robot's own velocity limit by more than ``TOO_FAST_TOLERANCE`` (logged, not changed)."""
        over = [
            (float(peak) / link.velocity[j], j, float(peak))
            for j, peak in zip(traj.joints, traj.peak_velocities(), strict=True)
            if link.velocity.get(j, 0.0) > 0.0
            and peak > link.velocity[j] * (1.0 + TOO_FAST_TOLERANCE)
        ]
        if not over:
            return
        self._counts["too_fast"] += 1
        ratio, j, peak = max(over)
        log.warning(
            "gesture %r: %s planned at %.2f rad/s, %.0f%% of the robot's limit %.2f rad/s "
            "(%d joint(s) over); NAOqi may slow or clip it",
            traj.name,
            j,
            peak,
            100 * ratio,
            link.velocity[j],
            len(over),
        )

    # -- polling -------------------------------------------------------------------------------
    def _advance(self, now: float) -> None:
        mono = time.monotonic()
        link = self._link
        if link is not None and link.lost.is_set():
            self._lose(link.reason[0] if link.reason else "disconnected", now)
        for call in list(self._calls):
            # a call that failed with a lost link fails every other call with it (``_lose``)
            if call in self._calls:
                self._poll_call(call, now, mono)
        self._home(mono)
        self._refresh_claim(mono)
        self._heartbeat(mono, now)
        if self._link is None and not self._closed:
            self._reconnect(mono)
        self._aside = [f for f in self._aside if not f.isFinished()]
        link = self._link
        if link is not None and link.leds is not None and self._eyes_on and not self._calls:
            self._eyes_on = False
            self._aside.append(link.leds.fadeRGB("FaceLeds", IDLE_RGB, 0.3, _async=True))

    def _poll_call(self, call: _Call, now: float, mono: float) -> None:
        fut, m = call.future, call.motion
        if fut.isFinished():
            self._calls.remove(call)
            measured = (call.done_at[0] if call.done_at else mono) - call.sent
            end = min(now, m.started_at + measured)
            if fut.isCanceled():
                self._fail(m, end, "cancelled")
            elif fut.hasError():
                error = _first_line(fut.error())
                lost = _looks_lost(error)
                self._fail(m, end, error, unknown=lost)
                if lost:
                    self._lose(error, now)
            else:
                m.finish(end, ok=True, measured_s=measured, lag_s=measured - m.planned_s)
        elif mono > call.deadline:
            self._calls.remove(call)
            fut.cancel()
            self._counts["timeouts"] += 1
            self._fail(m, now, f"no end within {call.deadline - call.sent:.1f} s")
            link = self._link
            if link is not None:  # stop the robot's task too (cancel may not reach it)
                if m.kind is MotionKind.GESTURE:
                    kill = link.motion.killTasksUsingResources(list(call.joints), _async=True)
                    # the kill leaves the joints mid-gesture: back to neutral once it is done
                    self._homing.append(kill)
                    self._homing_kind = "kill"
                    self._homing_until = mono + self.call_timeout_s
                else:
                    kill = link.tts.stopAll(_async=True)
                    self._aside.append(kill)

    def _refresh_claim(self, mono: float) -> None:
        link = self._link
        memory = link.proxies.get("ALMemory") if link is not None else None
        if memory is None or mono < self._next_claim:
            return
        self._next_claim = mono + CLAIM_REFRESH_S
        try:
            self._aside.append(memory.insertData(CLAIM_KEY, self._claim_text(), _async=True))
        except RuntimeError as e:
            log.info("could not refresh the claim on the robot: %s", _first_line(str(e)))

    def _home(self, mono: float) -> None:
        """After a killed gesture: once the kill has ended, move head and arms back to the
        neutral pose (slowly, ``neutral_speed_fraction``); ``busy`` until they are there."""
        if not self._homing or not all(f.isFinished() for f in self._homing):
            return
        was_kill = self._homing_kind == "kill"
        self._homing = []
        self._homing_kind = ""
        link = self._link
        if not was_kill or link is None:
            return
        names, angles = neutral_targets()
        try:
            fut = link.motion.angleInterpolationWithSpeed(
                names, angles, self.neutral_speed_fraction, _async=True
            )
        except RuntimeError as e:
            log.warning("could not move back to the neutral pose: %s", _first_line(str(e)))
            return
        log.info("gesture killed: moving head and arms back to the neutral pose")
        self._homing = [fut]
        self._homing_kind = "home"
        self._homing_until = mono + self.wake_timeout_s

    @property
    def busy(self) -> bool:
        """True while a gesture or phrase runs, or head and arms return to neutral after a
        killed gesture (the next gesture is planned from the neutral pose)."""
        if self._homing and time.monotonic() > self._homing_until:
            log.warning("no end of the return to the neutral pose within %g s", self.wake_timeout_s)
            for f in self._homing:
                f.cancel()
            self._homing = []
            self._homing_kind = ""
        return super().busy or bool(self._homing)

    def _fail(self, m: Motion, at: float, error: str, *, unknown: bool = False) -> None:
        """``m`` ends with ``ok=False``; ``unknown``: the link was lost while it ran, so the
        robot may well have finished it (``info["outcome"] = "unknown"``)."""
        self._counts["failed"] += 1
        log.warning("%s %r failed: %s", m.kind.value, m.name, error)
        extra = {"outcome": "unknown"} if unknown else {}
        m.finish(max(at, m.started_at), ok=False, error=error, **extra)

    def _heartbeat(self, mono: float, now: float) -> None:
        link = self._link
        if link is None:
            return
        if self._ping is None:
            if mono >= self._next_ping:
                try:
                    fut = link.motion.getAngles("HeadYaw", True, _async=True)
                except RuntimeError as e:
                    self._lose(str(e), now)
                    return
                done_at: list[float] = []
                fut.addCallback(lambda _f: done_at.append(time.monotonic()))
                self._ping = (fut, mono, done_at)
            return
        fut, sent, ping_done = self._ping
        if fut.isFinished():
            self._ping = None
            self._next_ping = mono + self.heartbeat_s
            if fut.hasError():
                self._lose(_first_line(fut.error()), now)
            else:
                self._rtt_ms.append(1000.0 * ((ping_done or [mono])[0] - sent))
        elif mono - sent > self.call_timeout_s:
            self._ping = None
            fut.cancel()
            self._lose(f"no heartbeat answer within {self.call_timeout_s:g} s", now)

    def _lose(self, reason: str, now: float) -> None:
        """The link is dead: fail what runs, drop the proxies, schedule a reconnect."""
        link = self._link
        if link is None:
            return
        self._link = None
        self._ping = None
        self._lost_reason = _first_line(reason)
        self._counts["disconnects"] += 1
        log.warning("lost the robot at %s: %s", self.url, self._lost_reason)
        for call in self._calls:
            call.future.cancel()
            self._fail(call.motion, now, f"robot lost: {self._lost_reason}", unknown=True)
        self._calls.clear()
        self._homing, self._homing_kind = [], ""  # a reconnect moves to neutral (``_set_up``)
        self._aside.append(link.session.close(_async=True))
        self._backoff = self.reconnect_initial_s
        self._next_attempt = time.monotonic() + self._backoff

    def _reconnect(self, mono: float) -> None:
        if self._attempt is None:
            if mono >= self._next_attempt:
                if self._executor is None:
                    self._executor = concurrent.futures.ThreadPoolExecutor(
                        max_workers=1, thread_name_prefix="naoqi-reconnect"
                    )
                self._attempt = self._executor.submit(self._connect)
            return
        if not self._attempt.done():
            return
        attempt, self._attempt = self._attempt, None
        try:
            link = attempt.result()
        except BackendUnavailable as e:
            self._backoff = min(2.0 * self._backoff, self.reconnect_max_s)
            self._next_attempt = time.monotonic() + self._backoff
            log.info("reconnect failed (%s); next try in %.1f s", e, self._backoff)
            return
        self._lost_reason = ""
        self._install(link)

    # -- helpers for callers that may block ------------------------------------------------------
    def wait_idle(self, timeout_s: float, clock: Callable[[], float]) -> bool:
        """Block until the running motions end (or ``timeout_s``); True when not busy.

        For scripts, tests and the end-of-talk summary: it waits on the calls' futures, then
        calls :meth:`advance` with ``clock()``.
        """
        end = time.monotonic() + timeout_s
        while True:
            for call in list(self._calls):
                left = min(end, call.deadline) - time.monotonic()
                if left > 0:
                    call.future.wait(max(1, int(left * 1000)))
            for fut in list(self._homing):  # a killed gesture's return to neutral
                left = min(end, self._homing_until) - time.monotonic()
                if left > 0:
                    fut.wait(max(1, int(left * 1000)))
            self.advance(clock())
            if not self.busy or time.monotonic() >= end:
                break
            time.sleep(0.005)  # a call at its deadline, not yet past it
        return not self.busy

    def wait_connected(self, timeout_s: float, clock: Callable[[], float]) -> bool:
        """Keep advancing (reconnecting) until connected or ``timeout_s``; True when connected."""
        end = time.monotonic() + timeout_s
        pause = threading.Event()
        while True:
            self.advance(clock())
            if self.connected:
                return True
            left = end - time.monotonic()
            if left <= 0:
                return False
            if self._attempt is not None:
                concurrent.futures.wait([self._attempt], timeout=left)
            else:
                pause.wait(min(left, max(0.0, self._next_attempt - time.monotonic())))

    # -- closing -------------------------------------------------------------------------------
    def _close(self) -> None:
        cut = sorted({j for call in self._calls for j in call.joints})
        for call in self._calls:
            call.future.cancel()
            self._fail(call.motion, call.motion.started_at, "backend closed")
        self._calls.clear()
        self._homing, self._homing_kind = [], ""
        if self._attempt is not None:
            self._attempt.cancel()
        if self._executor is not None:
            self._executor.shutdown(wait=False, cancel_futures=True)
        link, self._link = self._link, None
        if link is None or link.lost.is_set():
            if self._restore:
                log.warning(
                    "closing without the robot at %s: could not turn back on %s",
                    self.url,
                    ", ".join(
                        str(args[0]) if args else method for _, method, args in self._restore
                    ),
                )
            return
        try:
            # never leave the robot mid-gesture (arms forward, hands open, stiff): stop what a
            # cancelled gesture still runs on the robot (cancel may not reach it), then move head
            # and arms back to the neutral pose, slowly; on every close, an interrupted one too
            if cut:
                self._optional(link.motion, "killTasksUsingResources", cut)
            try:
                self._go_neutral(link.motion)
            except BackendUnavailable as e:
                log.warning("closing: could not return to the neutral pose: %s", e)
            if link.leds is not None:
                self._optional(link.leds, "fadeRGB", "FaceLeds", IDLE_RGB, 0.1)
            for service, method, args in self._restore:
                self._optional(link.proxies.get(service), method, *args)
            memory = link.proxies.get("ALMemory")
            _, held = self._optional(memory, "getData", CLAIM_KEY)
            if isinstance(held, str) and str(self._claim["id"]) in held:  # ours, not a newer talk's
                self._optional(memory, "removeData", CLAIM_KEY)
            if self.rest_on_close:
                self._wait(link.motion.rest(_async=True), "ALMotion.rest", self.wake_timeout_s)
        except BackendUnavailable as e:
            log.warning("closing: %s", e)
        finally:
            close = link.session.close(_async=True)
            close.wait(int(self.call_timeout_s * 1000))


def neutral_targets() -> tuple[list[str], list[float]]:
    """The library's neutral pose for the head and arm joints: (names, angles), NAOqi order.

    The pose :func:`~prezence.feedback.gestures.build_trajectory` plans every gesture from
    (hands: opening fraction, as ``ALMotion`` takes them).
    """
    from prezence.feedback.gestures import load_library
    from prezence.feedback.limits import load_limits

    limits = load_limits()
    neutral = load_library(limits).neutral
    names = [n for c in NEUTRAL_CHAINS for n in limits.chains[c]]
    return names, [float(neutral[n]) for n in names]
