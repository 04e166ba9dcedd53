"""Conflict resolution policies: given the candidates of one decision point, choose one.

The seed's policy (:class:`WeightedPolicy`) is the default. The others are the simpler
strategies the design report names (Bullinaria's list), kept so that closed-loop evaluation can
measure the seed's choice against them, and the anchors of :mod:`prezence.processor.anchors`
(other systems' published rules: ``pz16``, ``presentation_trainer``, ``rhema``).

A policy is named by a *spec*: its name, optionally followed by ``:`` and ``key=value`` pairs
that override the processor's settings or set the policy's own parameters, e.g.
``weighted:threshold=800,escalate_after=3``. Every command that takes ``--policy`` (run,
replay, evaluate, the Gym env) goes through :func:`make_policy`.

A policy of one's own (a :class:`ConflictPolicy` subclass in any module) is named
``MODULE:CLASS[:key=value,…]``, e.g. ``own_policy:BiggestNow:min_deviation=25``
(``examples/own_policy.py``): the module is imported by name wherever the spec is used, so
it works from the command line and in ``evaluate``'s worker processes alike
(:func:`split_spec` says why the form cannot be mistaken for a name with parameters). A name
added with :func:`register_policy` is known in the process that imported its module (and in
``evaluate``'s workers, which import that module too: :func:`worker_imports`), not on the
command line.

Processor keys a spec may set (any policy): the fields of
:class:`~prezence.config.model.ProcessorSettings` (``threshold``, ``decay_half_life_s``,
``min_gap_s``, ``refractory_s``, ``stale_after_s``, ``praise_after_s``), plus
``persistence_s`` (time constant of a metric's persistence, see
:mod:`prezence.processor.state`; 0 = off), ``escalate_after`` (N unheeded cues about one metric
stop its cues for the rest of the talk; 0 = never) and ``effect_s`` (seconds back in range that
count as an effect and reset the unheeded count).

Every value is checked before the talk starts (:meth:`ConflictPolicy.check_params`): a
processor setting against the bounds the config file holds it to
(:data:`~prezence.config.model.SETTING_BOUNDS`), the other keys against :data:`PROCESSOR_BOUNDS`
and each policy's :attr:`~ConflictPolicy.bounds`. ``decision_period_s`` (the talk loop's, for
every policy alike) and ``praise_command`` (a command, not a number) are set in the config
file's ``[processor]`` only.
"""

from __future__ import annotations

import abc
import dataclasses
import importlib
import inspect
import math
import os
import re
import sys
from collections.abc import Callable, Iterable, Mapping, Sequence
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np

from prezence.errors import ConfigError, UnknownName, did_you_mean
from prezence.processor.types import Candidate, Cue, Kind

if TYPE_CHECKING:
    from prezence.config.model import Config, ProcessorSettings, Rule

#: Spec keys that are not ProcessorSettings fields but processor features every policy has.
PROCESSOR_KEYS = ("persistence_s", "escalate_after", "effect_s")


@dataclasses.dataclass(frozen=True)
class Bound:
    """The values a spec key may take: a number from ``lo`` to ``hi``.

    Attributes:
        lo: the smallest value.
        hi: the largest (``inf``: no upper bound).
        unit: said in the message (``s``).
        whole: only whole numbers (a count).
        zero_off: 0 is allowed too, meaning "off".

    Example:
        >>> str(Bound(0.1, 86400, "s")), str(Bound(0, whole=True))
        ('between 0.1 and 86400 s', 'a whole number, 0 or more')
    """

    lo: float
    hi: float = math.inf
    unit: str = ""
    whole: bool = False
    zero_off: bool = False

    def __str__(self) -> str:
        if self.lo == -math.inf and self.hi == math.inf and not self.whole:
            return "a finite number"
        if self.whole and (self.lo, self.hi) == (0, 1):
            return "0 or 1"
        u = f" {self.unit}" if self.unit else ""
        span = (
            f"between {self.lo:g} and {self.hi:g}{u}"
            if math.isfinite(self.hi)
            else f"{self.lo:g}{u} or more"
        )
        if self.whole:
            span = "a whole number, " + span
        return span + (" (or 0: off)" if self.zero_off else "")

    def admits(self, x: float) -> bool:
        """Whether ``x`` is allowed (never NaN or an infinity)."""
        if not math.isfinite(x):
            return False
        if self.zero_off and x == 0:
            return True
        return self.lo <= x <= self.hi and not (self.whole and x != int(x))


#: The processor keys that are not config-file settings: 0 turns persistence and escalation off.
PROCESSOR_BOUNDS: dict[str, Bound] = {
    "persistence_s": Bound(0.0, 86400.0, "s"),
    "escalate_after": Bound(0.0, whole=True),
    "effect_s": Bound(0.0, 86400.0, "s"),
}

#: Settings a spec cannot hold, and where to set them instead.
NOT_SPEC_KEYS: dict[str, str] = {
    "decision_period_s": "it is how often the talk loop asks for a decision, the same for every "
    "policy; set it in a --config file: [processor] decision_period_s (between 0.02 and 10 s)",
    "praise_command": "it names a command, not a number; set it in a --config file: "
    '[processor] praise_command = "encourage" (or false: no praise)',
}


def _setting_bounds() -> dict[str, Bound]:
    """The config file's bounds of the processor settings a spec may set."""
    from prezence.config.model import SETTING_BOUNDS, ZERO_IS_OFF, ProcessorSettings

    out = {}
    for f in dataclasses.fields(ProcessorSettings):
        if f.name in SETTING_BOUNDS and f.name not in NOT_SPEC_KEYS:
            lo, hi = SETTING_BOUNDS[f.name]
            unit = "%·s" if f.name == "threshold" else "s"
            out[f.name] = Bound(lo, hi, unit, zero_off=f.name in ZERO_IS_OFF)
    return out


class ConflictPolicy(abc.ABC):
    """Chooses at most one candidate. Subclasses fill in :meth:`choose`."""

    name: str = "base"

    #: If True the processor offers every out-of-range metric (the rule's condition holds now),
    #: not only those whose seed firing condition (strict / weight over threshold) holds.
    wants_all_out_of_range: bool = False

    #: A *whole* policy keeps its own books and timing (:meth:`feed`, :meth:`decide`); the
    #: processor's weights, refractory and minimum gap do not apply to it.
    whole: bool = False

    #: Defaults of the spec keys this policy understands (overridden by ``name:key=value``).
    defaults: ClassVar[Mapping[str, float]] = {}

    #: The values each of the policy's own keys may take; a key not here takes any finite
    #: number. Processor keys are held to :func:`spec_bounds`'s bounds whatever the policy.
    bounds: ClassVar[Mapping[str, Bound]] = {}

    #: Overrides from the spec (processor settings and the policy's own parameters).
    params: dict[str, float]

    def __init__(self, **params: float) -> None:
        self.params = {**self.defaults, **params}
        self.check_params(self.params)

    @classmethod
    def check_params(cls, params: Mapping[str, float]) -> None:
        """Refuse a value its key does not allow (a policy with rules between its keys adds
        them here, calling this first).

        Args:
            params: the defaults with the spec's values applied.

        Raises:
            ConfigError: ``window_s must be between 0.1 and 86400 s, found 0``.
        """
        bounds = spec_bounds(cls)
        for key, x in params.items():
            b = bounds.get(key, Bound(-math.inf))
            if not b.admits(x):
                raise ConfigError(f"{key} must be {b}, found {x:g}")

    @property
    def spec(self) -> str:
        """The name with the parameters that differ from the defaults (as given)."""
        extra = {k: v for k, v in self.params.items() if self.defaults.get(k) != v}
        return self.name + (
            ":" + ",".join(f"{k}={v:g}" for k, v in sorted(extra.items())) if extra else ""
        )

    def settings(self, base: ProcessorSettings) -> ProcessorSettings:
        """``base`` with this policy's processor-setting overrides applied."""
        names = {f.name for f in dataclasses.fields(base)}
        over: dict[str, Any] = {k: v for k, v in self.params.items() if k in names}
        return dataclasses.replace(base, **over) if over else base

    def start(self, config: Config) -> None:  # noqa: B027 - optional hook
        """The talk's rules are known (called by the processor)."""

    def feed(self, rule: Rule, t: float, value: float) -> None:  # noqa: B027 - whole policies
        """A whole policy's input: one accepted sample (each metric in time order)."""

    def decide(self, now: float, robot_free: bool) -> Candidate | None:
        """A whole policy's decision at ``now``; a cue only when ``robot_free``."""
        return None

    def cue_dropped(self, cue: Cue) -> None:  # noqa: B027 - optional hook
        """The robot could not give the cue just chosen."""

    @abc.abstractmethod
    def choose(self, candidates: Sequence[Candidate], order: Sequence[str]) -> Candidate | None:
        """Pick one of ``candidates`` (all allowed now), or None for no cue.

        Args:
            candidates: allowed candidates (refractory and stale metrics already removed).
            order: metric names in config order.
        """

    def reset(self, seed: int | None = None) -> None:  # noqa: B027 - optional hook
        """Start a new talk (policies with chance reseed here)."""

    def explain(
        self, chosen: Candidate, candidates: Sequence[Candidate], order: Sequence[str]
    ) -> str | None:
        """What this policy chose ``chosen`` (a metric's candidate) on, for its cue's reason, in
        brackets after the metric's deviation: ``(the first rule out of range, in the rules'
        order)``. None (the default): the weighted policy's words, ``(weight 767 >= 600)``
        when its weight reached the threshold, and the other candidates' weights."""
        return None


def _contenders(candidates: Sequence[Candidate]) -> list[Candidate]:
    """The candidates an eager strategy chooses among: every metric out of range (no praise)."""
    return [c for c in candidates if c.kind != Kind.PRAISE and (c.eligible or c.metric)]


def _seed_key(c: Candidate) -> tuple[float, float, float]:
    # strict classes first; then the biggest priority; then the most recent data.
    return (float(c.kind), -c.weight, -c.recency)


class WeightedPolicy(ConflictPolicy):
    """The seed's policy: time warnings, then strict rules, then the non-strict rule with the
    highest weight (∝ deviation % × time); ties go to the most recent data."""

    name = "weighted"
    #: persistence_s: ours (see prezence.processor.state): a held deviation reaches full weight
    #: in a few seconds, a 1-in-2 s flicker never does; tuned by the closed-loop evaluation.
    defaults: ClassVar[Mapping[str, float]] = {
        "persistence_s": 5.0,
        "escalate_after": 2.0,
        "effect_s": 20.0,
    }

    def choose(self, candidates: Sequence[Candidate], order: Sequence[str]) -> Candidate | None:
        ok = [c for c in candidates if c.eligible]
        return min(ok, key=_seed_key) if ok else None


class FirstRulePolicy(ConflictPolicy):
    """Fire the first satisfied rule in config order (a flat production system)."""

    name = "first_rule"
    wants_all_out_of_range = True

    def choose(self, candidates: Sequence[Candidate], order: Sequence[str]) -> Candidate | None:
        rank = {m: i for i, m in enumerate(order)}

        def key(c: Candidate) -> tuple[int, int]:
            if c.kind == Kind.TIME:
                return (0, 0)
            return (1, rank.get(c.metric or "", len(rank)))

        ok = [c for c in candidates if c.eligible or c.kind in (Kind.WEIGHTED, Kind.STRICT)]
        ok = [c for c in ok if c.kind != Kind.PRAISE]
        return min(ok, key=key) if ok else None

    def explain(
        self, chosen: Candidate, candidates: Sequence[Candidate], order: Sequence[str]
    ) -> str | None:
        return "the first rule out of range, in the rules' order"


class RecentPolicy(ConflictPolicy):
    """Respond to the most recent out-of-range data only."""

    name = "recent"
    wants_all_out_of_range = True

    def choose(self, candidates: Sequence[Candidate], order: Sequence[str]) -> Candidate | None:
        ok = [c for c in candidates if c.kind != Kind.PRAISE and (c.eligible or c.metric)]
        return max(ok, key=lambda c: (c.recency, -float(c.kind))) if ok else None

    def explain(
        self, chosen: Candidate, candidates: Sequence[Candidate], order: Sequence[str]
    ) -> str | None:
        return f"the most recent out-of-range sample, at {chosen.recency:.1f} s"


class RandomPolicy(ConflictPolicy):
    """Pick uniformly among out-of-range rules (seeded)."""

    name = "random"
    wants_all_out_of_range = True

    def __init__(self, seed: int = 0, **params: float) -> None:
        super().__init__(**params)
        self._rng = np.random.default_rng(seed)

    def reset(self, seed: int | None = None) -> None:
        self._rng = np.random.default_rng(seed)

    def choose(self, candidates: Sequence[Candidate], order: Sequence[str]) -> Candidate | None:
        ok = [c for c in candidates if c.kind != Kind.PRAISE and (c.eligible or c.metric)]
        if not ok:
            return None
        return ok[int(self._rng.integers(len(ok)))]

    def explain(
        self, chosen: Candidate, candidates: Sequence[Candidate], order: Sequence[str]
    ) -> str | None:
        n = len(_contenders(candidates))
        return "the only metric out of range" if n == 1 else f"drawn at random of {n} out of range"


class MostConditionsPolicy(ConflictPolicy):
    """Prefer the rule with the most conditions met: out of range now, out of range for at least
    the threshold's worth of time, strict, and weight over the threshold (Bullinaria's 4th)."""

    name = "most_conditions"
    wants_all_out_of_range = True

    def choose(self, candidates: Sequence[Candidate], order: Sequence[str]) -> Candidate | None:
        ok = [c for c in candidates if c.kind != Kind.PRAISE and (c.eligible or c.metric)]
        if not ok:
            return None

        return max(ok, key=lambda c: (len(self._met(c)), c.recency))

    @staticmethod
    def _met(c: Candidate) -> list[str]:
        """The conditions ``c`` meets, in words."""
        conditions = (
            (c.deviation > 0, "out of range now"),
            (c.kind in (Kind.STRICT, Kind.TIME), "strict"),
            (c.eligible, "weight over the threshold"),
            (c.onset is not None, "an onset"),
        )
        return [words for holds, words in conditions if holds]

    def explain(
        self, chosen: Candidate, candidates: Sequence[Candidate], order: Sequence[str]
    ) -> str | None:
        met = self._met(chosen)
        return f"the most conditions met, {len(met)} of 4: {', '.join(met) or 'none'}"


class SilentPolicy(ConflictPolicy):
    """No feedback at all (the control condition)."""

    name = "none"

    def choose(self, candidates: Sequence[Candidate], order: Sequence[str]) -> Candidate | None:
        return None


#: Registered policies: name → class. Extend with :func:`register_policy`.
POLICIES: dict[str, type[ConflictPolicy]] = {
    p.name: p
    for p in (
        WeightedPolicy,
        FirstRulePolicy,
        RecentPolicy,
        RandomPolicy,
        MostConditionsPolicy,
        SilentPolicy,
    )
}

#: Other names for registered policies (``pt`` for ``presentation_trainer``).
ALIASES: dict[str, str] = {}


def register_policy(cls: type[ConflictPolicy], *aliases: str) -> type[ConflictPolicy]:
    """Add a policy class under its ``name`` (and ``aliases``); returns it (a decorator)."""
    POLICIES[cls.name] = cls
    for a in aliases:
        ALIASES[a] = cls.name
    return cls


#: The class part of an import spec: a Python name, dotted for a class inside a class.
_ATTR = re.compile(r"[A-Za-z_]\w*(?:\.[A-Za-z_]\w*)*")


def split_spec(spec: str) -> tuple[str, str]:
    """A spec → (the policy: a registered name or ``MODULE:CLASS``, its ``key=value`` text).

    The import form ``MODULE:CLASS[:key=value,…]`` names a policy of one's own. It cannot be
    read as a name with parameters: after a name's ``:`` every pair has an ``=``, a class name
    has none; and a registered name (with its alias) is always read as the name.

    Example:
        >>> split_spec("weighted:threshold=800")
        ('weighted', 'threshold=800')
        >>> split_spec("own_policy:BiggestNow:min_deviation=25")
        ('own_policy:BiggestNow', 'min_deviation=25')
    """
    import prezence.processor.anchors  # noqa: F401 - registers the anchors

    head, colon, rest = spec.strip().partition(":")
    if colon and head not in POLICIES and head not in ALIASES:
        attr, _, params = rest.partition(":")
        if _ATTR.fullmatch(attr.strip()):
            return f"{head.strip()}:{attr.strip()}", params
    return head, rest


def parse_spec(spec: str) -> tuple[str, dict[str, float]]:
    """``"name:key=value,key=value"`` (or ``"MODULE:CLASS:key=value,…"``) → (name, {key: value}).

    Raises:
        ConfigError: a pair that is not ``key=number``.

    Example:
        >>> parse_spec("weighted:threshold=800,escalate_after=3")
        ('weighted', {'threshold': 800.0, 'escalate_after': 3.0})
    """
    name, rest = split_spec(spec)
    params: dict[str, float] = {}
    for part in filter(None, (x.strip() for x in rest.split(","))):
        key, eq, raw = part.partition("=")
        try:
            if not eq:
                raise ValueError
            params[key.strip()] = float(raw)
        except ValueError:
            raise ConfigError(
                f"policy {spec!r}: expected key=number after ':', found {part!r}"
            ) from None
    return ALIASES.get(name, name), params


def load_policy_class(ref: str, *, spec: str | None = None) -> type[ConflictPolicy]:
    """The class a ``MODULE:CLASS`` reference names: ``MODULE`` is imported as Python
    imports it (installed packages, ``PYTHONPATH``), then from the current folder.

    Raises:
        ConfigError: the module cannot be imported, or has no such class, or it is not a
            :class:`ConflictPolicy` subclass that implements :meth:`~ConflictPolicy.choose`.
    """
    module_name, _, attr = ref.partition(":")
    where = f"policy {spec or ref!r}"
    try:
        module = _import_from_here(module_name)
    except ModuleNotFoundError as e:
        if e.name is None or not (module_name + ".").startswith(e.name + "."):
            raise ConfigError(f"{where}: importing {module_name} failed: {e}") from e
        raise ConfigError(
            f"{where}: no module named {e.name!r} (a policy of your own is MODULE:CLASS, "
            "MODULE importable from the current folder or PYTHONPATH)"
        ) from None
    except Exception as e:  # the policy's own module failed: say so, keep its traceback
        raise ConfigError(
            f"{where}: importing {module_name} failed: {type(e).__name__}: {e}"
        ) from e
    obj: Any = module
    for part in attr.split("."):
        if not hasattr(obj, part):
            policies = [
                k
                for k, v in vars(module).items()
                if isinstance(v, type)
                and issubclass(v, ConflictPolicy)
                and not inspect.isabstract(v)
                and v.__module__ == module.__name__
            ]
            hint = did_you_mean(attr, policies) or (
                "; its policies: " + ", ".join(policies)
                if policies
                else "; it defines no ConflictPolicy subclass"
            )
            raise ConfigError(f"{where}: {module_name} has no {attr!r}{hint}")
        obj = getattr(obj, part)
    if not (isinstance(obj, type) and issubclass(obj, ConflictPolicy)):
        what = type(obj).__name__ if not isinstance(obj, type) else "class"
        raise ConfigError(
            f"{where}: {module_name}.{attr} is a {what}, not a ConflictPolicy subclass "
            "(from prezence.processor import ConflictPolicy)"
        )
    if inspect.isabstract(obj):
        raise ConfigError(f"{where}: {module_name}.{attr} does not implement choose()")
    return obj


def _import_from_here(module_name: str) -> Any:
    """Import ``module_name``; if Python cannot find it, look in the current folder too (put
    last on ``sys.path``, so that it shadows nothing installed)."""
    try:
        return importlib.import_module(module_name)
    except ModuleNotFoundError as e:
        top = module_name.partition(".")[0]
        here = os.getcwd()
        if e.name != top or here in sys.path or "" in sys.path:
            raise
        sys.path.append(here)
        return importlib.import_module(module_name)


def make_policy(name: str, *, seed: int = 0) -> ConflictPolicy:
    """Build a policy from its spec (``weighted``, ``first_rule``, ``recent``, ``random``,
    ``most_conditions``, ``none``, ``pz16``, ``presentation_trainer``/``pt``, ``rhema``, or a
    policy of one's own as ``MODULE:CLASS``, optionally with ``:key=value,…``; see the module
    doc).

    Raises:
        UnknownName: no such policy.
        ConfigError: a malformed or unknown parameter, a value out of its range, or a
            ``MODULE:CLASS`` that cannot be imported or is not a policy.
    """
    import prezence.processor.anchors  # noqa: F401 - registers the anchors

    base, params = parse_spec(name)
    if ":" in base:
        cls = load_policy_class(base, spec=name)
    else:
        try:
            cls = POLICIES[base]
        except KeyError:
            raise UnknownName(
                "policy",
                base,
                [*POLICIES, *ALIASES],
                hint="a policy of your own is named MODULE:CLASS, see docs/evaluation.md",
            ) from None
    for key in params:
        if key in NOT_SPEC_KEYS:
            raise ConfigError(
                f"policy {name!r}: {key} is not a policy parameter: {NOT_SPEC_KEYS[key]}"
            )
    known = set(spec_bounds(cls)) | set(cls.defaults)
    bad = sorted(set(params) - known)
    if bad:
        raise ConfigError(
            f"policy {name!r}: unknown parameter(s) {', '.join(bad)} "
            f"(known: {', '.join(sorted(known))})"
        )
    try:
        cls.check_params({**cls.defaults, **params})
    except ConfigError as e:
        raise ConfigError(f"policy {name!r}: {e.reason}") from None
    make: Callable[..., ConflictPolicy] = cls
    if issubclass(cls, RandomPolicy):
        return cls(seed, **params)
    return make(**params)


def canonical_spec(spec: str) -> str:
    """The one spelling of a policy spec: its canonical name (an alias resolved, ``pt`` →
    ``presentation_trainer``), then the parameters that differ from the policy's defaults,
    sorted by key. Two specs with the same canonical spelling run the same policy.

    Raises:
        UnknownName, ConfigError: as :func:`make_policy`.

    Example:
        >>> canonical_spec("pt"), canonical_spec("rhema:window_s=20")
        ('presentation_trainer', 'rhema')
        >>> canonical_spec("weighted:threshold=800,escalate_after=3")
        'weighted:escalate_after=3,threshold=800'
    """
    make_policy(spec)  # the same errors, and the class is known (imported) below
    base, params = parse_spec(spec)
    cls = load_policy_class(base, spec=spec) if ":" in base else POLICIES[base]
    extra = {k: v for k, v in params.items() if cls.defaults.get(k) != v}

    def num(x: float) -> str:
        short = f"{x:g}"
        return short if float(short) == x else repr(x)

    return base + (
        ":" + ",".join(f"{k}={num(v)}" for k, v in sorted(extra.items())) if extra else ""
    )


def worker_imports(specs: Iterable[str]) -> list[str]:
    """The modules a worker process must import to know the registered policies among
    ``specs`` (those registered by a module of one's own, not by Prezence).

    ``MODULE:CLASS`` specs need nothing: a worker imports them by name. A policy registered
    in a script's ``__main__`` needs nothing either (a spawned worker runs the script again,
    as ``__mp_main__``).

    Raises:
        ConfigError: a policy registered where no other process can import it (a notebook,
            ``python -c``, an interactive session).
    """
    out: list[str] = []
    for spec in specs:
        base, _ = parse_spec(spec)
        cls = POLICIES.get(base)
        if cls is None or cls.__module__.partition(".")[0] == "prezence":
            continue
        if cls.__module__ == "__main__":
            if getattr(sys.modules["__main__"], "__file__", None) is None:
                raise ConfigError(
                    f"policy {spec!r} is registered in __main__ of an interactive session, "
                    "which worker processes cannot import: put the class in a module and "
                    "name it MODULE:CLASS, or use jobs=1"
                )
            continue
        if cls.__module__ not in out:
            out.append(cls.__module__)
    return out


def spec_bounds(cls: type[ConflictPolicy]) -> dict[str, Bound]:
    """Every key a spec of ``cls`` may set, with the values it may take: the processor's
    settings (the config file's bounds), :data:`PROCESSOR_BOUNDS`, then the policy's own."""
    return {**_setting_bounds(), **PROCESSOR_BOUNDS, **cls.bounds}


def policy_names() -> list[str]:
    """Every registered policy name (anchors included), for help texts and ``evaluate``."""
    import prezence.processor.anchors  # noqa: F401 - registers the anchors

    return list(POLICIES)


__all__ = [
    "ALIASES",
    "NOT_SPEC_KEYS",
    "PROCESSOR_BOUNDS",
    "POLICIES",
    "PROCESSOR_KEYS",
    "Bound",
    "ConflictPolicy",
    "canonical_spec",
    "make_policy",
    "parse_spec",
    "policy_names",
    "load_policy_class",
    "register_policy",
    "spec_bounds",
    "split_spec",
    "worker_imports",
]
