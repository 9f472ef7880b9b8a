"""A Zenoh liveliness token behind the bus's :class:`~facesynth.runtime.bus.base.Token`."""

from __future__ import annotations

import contextlib
from typing import Any

import zenoh

from facesynth.runtime.bus.base import Token


class ZenohToken(Token):
    """A liveliness token of a Zenoh session, which can be declared anew."""

    def __init__(self, session: zenoh.Session, key: str) -> None:
        self.key = key
        self._session = session
        self._token: Any = session.liveliness().declare_token(key)

    @property
    def declared(self) -> bool:
        """Whether the token is declared (not closed)."""
        return self._token is not None

    def declare_anew(self) -> None:
        """Undeclare the token and declare it again (the router lost it)."""
        old, self._token = self._token, None
        if old is None:
            return
        with contextlib.suppress(Exception):  # the session is already closed
            old.undeclare()
        self._token = self._session.liveliness().declare_token(self.key)

    def close(self) -> None:
        token, self._token = self._token, None
        if token is not None:
            with contextlib.suppress(Exception):  # the session is already closed
                token.undeclare()
