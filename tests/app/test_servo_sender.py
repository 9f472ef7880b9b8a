"""facesynth.app.servo_sender: a tool's own servo commands, numbered and stamped as sent."""

from __future__ import annotations

from facesynth.app.servo_sender import ServoSender
from facesynth.runtime.clock_host import clock_host
from facesynth.runtime.service import ServiceContext
from facesynth.runtime.testing import StageRun


async def test_commands_are_numbered_from_one_and_stamped_when_sent() -> None:
    sender = ServoSender("console/abc")

    async def body(ctx: ServiceContext) -> None:
        ctx.ready()
        started = ctx.clock.monotonic_ns()
        await ctx.clock.sleep(0.25)
        sender.send(ctx, {"jaw": 1500.0}, face=True, profile="head", started_ns=started)
        await ctx.clock.sleep(0.25)
        sender.send(ctx, {"jaw": 1600.0}, face=False, profile="head", started_ns=started)
        await ctx.clock.sleep(10)

    async with StageRun(body, service="console") as run:
        await run.advance(1.0)
        published = run.on("servo_commands")
        wall_offset = run.clock.time_ns() - run.clock.monotonic_ns()
    assert sender.sent == 2
    assert [p.message.seq for p in published] == [1, 2]
    for publication, t_media, face in zip(published, (0.25, 0.5), (True, False), strict=True):
        command = publication.message
        assert command.sender_seq == command.seq
        assert command.t_media_ns == round(t_media * 1e9)
        assert command.t_capture_ns == command.sent_ns == wall_offset + publication.t_ns
        assert (command.face, command.profile, command.sender) == (face, "head", "console/abc")
        assert command.sender_host == clock_host()
    assert [p.message.positions for p in published] == [{"jaw": 1500.0}, {"jaw": 1600.0}]
