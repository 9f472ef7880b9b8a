"""Stopping a group of tasks: every one cancelled and awaited, failures kept, not swallowed, and
the caller's own cancellation meanwhile raised once they have all ended."""

from __future__ import annotations

import asyncio

import pytest

from facesynth.runtime.tasks import cancel_and_wait, stop_tasks


async def _forever(ended: list[str], name: str) -> None:
    try:
        await asyncio.Event().wait()
    finally:
        ended.append(name)


async def _fail(message: str) -> None:
    raise RuntimeError(message)


def test_every_task_is_cancelled_and_has_ended_when_it_returns() -> None:
    async def main() -> tuple[list[BaseException], list[str], list[bool]]:
        ended: list[str] = []
        tasks = [asyncio.create_task(_forever(ended, name)) for name in "abc"]
        await asyncio.sleep(0)  # each task is waiting
        errors = await cancel_and_wait(task for task in tasks)  # any iterable
        return errors, ended, [task.cancelled() for task in tasks]

    errors, ended, cancelled = asyncio.run(main())
    assert errors == []
    assert sorted(ended) == ["a", "b", "c"]
    assert cancelled == [True, True, True]


def test_failures_are_returned_in_task_order_and_every_task_still_ends() -> None:
    async def main() -> tuple[list[str], list[str]]:
        ended: list[str] = []
        tasks = [
            asyncio.create_task(_fail("first")),
            asyncio.create_task(_forever(ended, "waiting")),
            asyncio.create_task(_fail("second")),
        ]
        await asyncio.sleep(0)  # the two failures happen before the stop
        errors = await cancel_and_wait(tasks)
        return [str(error) for error in errors], ended

    messages, ended = asyncio.run(main())
    assert messages == ["first", "second"]
    assert ended == ["waiting"]


def test_stop_tasks_raises_the_first_failure_after_every_task_ended() -> None:
    async def main() -> list[str]:
        ended: list[str] = []
        tasks = [
            asyncio.create_task(_forever(ended, "before")),
            asyncio.create_task(_fail("broken")),
            asyncio.create_task(_forever(ended, "after")),
        ]
        await asyncio.sleep(0)
        with pytest.raises(RuntimeError, match="broken"):
            await stop_tasks(tasks)
        assert all(task.done() for task in tasks)
        return ended

    assert sorted(asyncio.run(main())) == ["after", "before"]


def test_nothing_to_stop_and_tasks_already_done() -> None:
    async def main() -> list[BaseException]:
        await stop_tasks([])
        done = asyncio.create_task(asyncio.sleep(0, result="value"))
        await done
        return await cancel_and_wait([done])

    assert asyncio.run(main()) == []


async def _slow_to_stop(name: str, events: list[str]) -> None:
    try:
        await asyncio.Event().wait()
    except asyncio.CancelledError:
        await asyncio.sleep(0.01)  # still cleaning up when its stopper is cancelled
    finally:
        events.append(f"{name} ended")


def test_the_callers_cancellation_meanwhile_waits_for_the_stop_then_goes_through() -> None:
    # What follows a stop in a finally (closing a file, stopping C) runs even when the stopper
    # is cancelled while a helper is still cleaning up: the stop waits for every helper first.
    # Then the stopper ends cancelled, as asyncio asks of a cancelled task.
    async def main() -> tuple[list[str], bool]:
        events: list[str] = []
        helpers = [asyncio.create_task(_slow_to_stop(name, events)) for name in ("a", "b")]

        async def owner() -> None:
            try:
                await stop_tasks(helpers)
                events.append("went on as if not cancelled")
            finally:
                events.append("after the stop")

        task = asyncio.create_task(owner())
        await asyncio.sleep(0)
        await asyncio.sleep(0)  # the owner waits for its first helper
        task.cancel()
        await asyncio.wait([task])
        assert all(helper.done() for helper in helpers)
        return events, task.cancelled()

    assert asyncio.run(main()) == (["a ended", "b ended", "after the stop"], True)


def test_a_timeout_around_a_stop_fires_once_the_stop_is_done() -> None:
    async def main() -> list[str]:
        events: list[str] = []
        helper = asyncio.create_task(_slow_to_stop("helper", events))
        await asyncio.sleep(0)
        with pytest.raises(TimeoutError):
            async with asyncio.timeout(0.001):
                await cancel_and_wait([helper])
        return events

    assert asyncio.run(main()) == ["helper ended"]


def test_a_stop_in_the_finally_of_a_cancelled_task_adds_no_cancellation_of_its_own() -> None:
    # The owner's own cancellation is under way when it stops its helpers: the stop returns
    # (what they raised), and that one cancellation goes on.
    async def main() -> tuple[list[object], bool, int]:
        events: list[object] = []
        helpers = [asyncio.create_task(_fail("broken"))]

        async def owner() -> None:
            try:
                await asyncio.Event().wait()
            finally:
                errors = await cancel_and_wait(helpers)
                events.append([str(error) for error in errors])

        task = asyncio.create_task(owner())
        await asyncio.sleep(0)
        task.cancel()
        await asyncio.wait([task])
        return events, task.cancelled(), task.cancelling()

    assert asyncio.run(main()) == ([["broken"]], True, 1)
