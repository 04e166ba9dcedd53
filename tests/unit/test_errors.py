"""Every exception the product raises survives pickling: worker processes send them back."""

from __future__ import annotations

import importlib
import pickle
import pkgutil

import pytest

import prezence
from prezence.config.lines import RuleProblem
from prezence.errors import ConfigError, UnknownName
from prezence.modules.common import InputCutShort, ModuleInputError
from prezence.session import FolderInUse
from prezence.streams.codec import StreamLineError


def _examples() -> dict[type[BaseException], BaseException]:
    """One instance of each exception class of the product whose __init__ is its own."""
    out: dict[type[BaseException], BaseException] = {
        ConfigError: ConfigError("bad value", path="rules.toml", line=3, col=7, key="rules[0].min"),
        UnknownName: UnknownName("policy", "biggest_now", ["weighted"], hint="see the docs"),
        ModuleInputError: ModuleInputError("talk.flac", "the audio is damaged"),
        InputCutShort: InputCutShort("talk.wav", "the audio ends after 15.1 s", 15.1),
        RuleProblem: RuleProblem("low", "min must be below max"),
        StreamLineError: StreamLineError("not a number: 'abc'"),
        FolderInUse: FolderInUse("another prezence is writing into it now", path="sessions/demo"),
    }
    try:  # the vision module needs OpenCV (an extra)
        from prezence.modules.vision import VisionInputError
    except ImportError:
        pass
    else:
        out[VisionInputError] = VisionInputError("talk.mp4", "no video stream")
    return out


EXAMPLES = _examples()


def _exception_classes() -> set[type[BaseException]]:
    """Exception classes defined anywhere in prezence/ (every module imported)."""
    found: set[type[BaseException]] = set()
    for m in pkgutil.walk_packages(prezence.__path__, "prezence."):
        if m.name == "prezence.__main__":
            continue
        try:
            module = importlib.import_module(m.name)
        except ModuleNotFoundError as e:  # an extra not installed (the core-only CI run)
            if (e.name or "").startswith("prezence"):
                raise
            continue
        for obj in vars(module).values():
            if (
                isinstance(obj, type)
                and issubclass(obj, BaseException)
                and obj.__module__ == m.name
            ):
                found.add(obj)
    return found


def test_every_exception_with_its_own_init_has_an_example() -> None:
    own_init = {
        c
        for c in _exception_classes()
        if any("__init__" in vars(k) for k in c.__mro__ if k.__module__.startswith("prezence"))
    }
    assert own_init == set(EXAMPLES), "add the new class to EXAMPLES"


@pytest.mark.parametrize("error", list(EXAMPLES.values()), ids=lambda e: type(e).__name__)
def test_an_exception_pickles_with_its_message_and_attributes(error: BaseException) -> None:
    back = pickle.loads(pickle.dumps(error))
    assert type(back) is type(error)
    assert str(back) == str(error)
    assert vars(back) == vars(error)


def test_a_note_added_to_an_error_survives_pickling() -> None:
    e = UnknownName("policy", "x", ["y"])
    e.add_note("while starting the talk")
    assert pickle.loads(pickle.dumps(e)).__notes__ == ["while starting the talk"]
