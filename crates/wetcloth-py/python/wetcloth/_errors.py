"""The package's exceptions (raised by the native module too)."""

from __future__ import annotations


class SceneError(ValueError):
    """A scene the command line would refuse: an unknown key, a value of the wrong type or out
    of range. The message is the command line's (file, line, key, value, what is allowed).

    Attributes: ``key`` (the dotted key path, e.g. ``"cloth.mass"``, or None), ``value`` (the
    value as written, or None), ``line`` (1-based line in the scene file, or None where the
    error has no line, as for ``Scene.set``).
    """

    def __init__(
        self,
        message: str,
        key: str | None = None,
        value: str | None = None,
        line: int | None = None,
    ) -> None:
        super().__init__(message)
        self.key = key
        self.value = value
        self.line = line


class Unstable(RuntimeError):
    """The simulation blew up (or went unphysical) at simulated time ``time`` (s); the message
    says why and what to try, as the command line does. The simulation refuses to step after.
    """

    def __init__(self, message: str, time: float) -> None:
        super().__init__(message)
        self.time = time
