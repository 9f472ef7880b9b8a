"""Stopping a group of asyncio tasks: cancel them all, then wait until every one has ended.

What a server, a session or a chain does with its helper tasks when it stops, in one place.
Every task is awaited, so none is left running or with its failure unretrieved ("Task exception
was never retrieved"), even after another one failed. The caller's own cancellation arriving
while it waits does not cut the stop short: the wait goes on to the next task. Once every task
has ended, that cancellation is raised (:exc:`asyncio.CancelledError`), as asyncio asks of a
cancelled task: it ends cancelled (a second Ctrl-C reaches ``asyncio.run``, a timeout around
the stop fires). So what a caller must do after the stop even then (closing a file, stopping C,
which returns the face to neutral) belongs in a ``finally``.
"""

from __future__ import annotations

import asyncio
import contextlib
from collections.abc import Iterable
from typing import Any

__all__ = ["cancel_and_wait", "stop_tasks"]


async def cancel_and_wait(tasks: Iterable[asyncio.Future[Any]]) -> list[Exception]:
    """Cancel every task, then await each in turn; what they raised other than their
    cancellation, in the tasks' order (for a caller that logs or drops it).

    Raises :exc:`asyncio.CancelledError` after every task has ended when the caller itself was
    cancelled meanwhile (a cancellation already under way when it was called, a ``finally``
    stopping the tasks of a cancelled caller, is left to go on as it was)."""
    tasks = list(tasks)
    for task in tasks:
        task.cancel()
    caller = asyncio.current_task()
    before = caller.cancelling() if caller is not None else 0
    errors: list[Exception] = []
    for task in tasks:
        try:
            with contextlib.suppress(asyncio.CancelledError):
                await task
        except Exception as exc:
            errors.append(exc)
    if caller is not None and caller.cancelling() > before:
        raise asyncio.CancelledError() from (errors[0] if errors else None)
    return errors


async def stop_tasks(tasks: Iterable[asyncio.Future[Any]]) -> None:
    """:func:`cancel_and_wait`, then raise the first task's failure, if one failed."""
    errors = await cancel_and_wait(tasks)
    if errors:
        raise errors[0]
