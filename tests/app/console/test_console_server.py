"""The console's server with C on an in-memory bus: a page with the token jogs servos through
C (clamped, speed-limited, back to neutral when the page goes), one page holds the servos at a
time, other origins and host names are refused, bad messages get clear errors, a save
writes a profile that reloads identically and restarts C with it, and a stop cancelled
meanwhile stops C all the same."""

from __future__ import annotations

import asyncio
import itertools
import json
from collections.abc import Callable
from pathlib import Path
from typing import Any

import aiohttp
import pytest
from console_token import TOKEN

from facesynth.app.console.protocol import MAX_MESSAGE
from facesynth.app.console.server import TOKEN_HEADER, ConsoleServer
from facesynth.runtime import codec
from facesynth.runtime.profiles import load_profile
from facesynth.schemas.messages import ServoCommands

FIRST = load_profile("head16_hardware").servos[0]


class Page:
    """A page's WebSocket, reading the server's messages as they come."""

    def __init__(self, ws: aiohttp.ClientWebSocketResponse) -> None:
        self.ws = ws
        self.messages: list[dict[str, Any]] = []

    async def send(self, **message: Any) -> None:
        await self.ws.send_str(json.dumps(message))

    async def until(self, test: Callable[[dict[str, Any]], bool], timeout: float = 5.0) -> Any:
        async with asyncio.timeout(timeout):
            while True:
                for message in self.messages:
                    if test(message):
                        self.messages.remove(message)
                        return message
                msg = await self.ws.receive()
                if msg.type != aiohttp.WSMsgType.TEXT:
                    return msg
                self.messages.append(json.loads(msg.data))

    async def reply(self, kind: str) -> dict[str, Any]:
        message: dict[str, Any] = await self.until(lambda m: m["type"] == kind)
        return message


async def _page(http: aiohttp.ClientSession, server: ConsoleServer, token: str = TOKEN) -> Page:
    ws = await http.ws_connect(f"http://127.0.0.1:{server.port}/ws", origin=_origin(server))
    page = Page(ws)
    await page.reply("hello")
    await page.send(type="hello", token=token)
    return page


def _origin(server: ConsoleServer) -> str:
    return f"http://127.0.0.1:{server.port}"


def _commands(tmp_path: Path) -> list[dict[str, float]]:
    lines = (tmp_path / "commands.jsonl").read_text().splitlines()
    rows = [json.loads(line) for line in lines if line.strip()]
    return [row["servos"] for row in rows if "servos" in row]


async def test_the_page_shows_measured_positions_and_faults_beside_the_commanded(
    console: ConsoleServer,
) -> None:
    """A servo_state with read-back tables (from a smart-servo driver) reaches the page."""
    profile = console.session.core.active
    names = [s.name for s in profile.servos]
    state = ServoCommands(
        seq=0,
        t_capture_ns=0,
        t_media_ns=0,
        face=False,
        profile=profile.name,
        positions={names[0]: 1600.0},
        move="report",
        measured={names[0]: 1587.0},
        faults={names[1]: "overheating"},
    )
    async with aiohttp.ClientSession() as http:
        page = await _page(http, console)
        for _ in range(50):  # C's own reports interleave: publish until the page shows ours
            console.session.bus.publish("facesynth/t/servo_state", codec.encode(state))
            shown = await page.until(lambda m: m["type"] == "state")
            if shown["measured"][0] == 1587.0:
                break
            await asyncio.sleep(0.02)
        assert shown["measured"][0] == 1587.0 and shown["faults"][1] == "overheating"
        assert shown["measured"][1] is None and shown["faults"][0] == ""
        assert len(shown["measured"]) == len(shown["faults"]) == len(names)


async def test_a_jog_moves_a_servo_through_c_and_it_returns_to_neutral(
    console: ConsoleServer, tmp_path: Path
) -> None:
    async with aiohttp.ClientSession() as http:
        page = await _page(http, console)
        assert (await page.reply("welcome"))["trusted"] is True
        await page.send(type="jog", servo=0, us=1700.0)
        state = await page.until(lambda m: m["type"] == "state" and m["positions"][0] == 1700.0)
        assert state["held_by"] == "you" and state["holding"]
        await page.send(type="jog", servo=0, us=5000.0)  # beyond max: clamped
        await page.until(lambda m: m["type"] == "state" and m["positions"][0] == FIRST.max_us)
        await page.ws.close()
    sent = [c[FIRST.name] for c in _commands(tmp_path)]
    steps = [abs(b - a) for a, b in itertools.pairwise(sent)]
    assert max(sent) == FIRST.max_us
    assert max(steps) < 500  # C's speed limit (3000 µs/s) split the move into steps
    async with asyncio.timeout(5):  # nobody holds the servos: C's watchdog brings them back
        while console.session.core.here(0) != FIRST.neutral_us:
            await asyncio.sleep(0.05)
    assert not console.session.core.holding and console.owner is None


async def test_without_the_token_a_page_only_watches(console: ConsoleServer) -> None:
    async with aiohttp.ClientSession() as http:
        watcher = await _page(http, console, token="")
        assert (await watcher.reply("welcome"))["trusted"] is False
        await watcher.send(type="jog", servo=0, us=1700.0)
        assert "this page has no token" in (await watcher.reply("error"))["message"]
        await watcher.send(type="save")
        assert "no token" in (await watcher.reply("error"))["message"]
        wrong = await _page(http, console, token="guess")
        assert "wrong token" in (await wrong.reply("error"))["message"]
        await wrong.send(type="take")
        assert "no token" in (await wrong.reply("error"))["message"]
    assert not console.session.core.holding


async def test_one_page_holds_the_servos_at_a_time(console: ConsoleServer) -> None:
    async with aiohttp.ClientSession() as http:
        first = await _page(http, console)
        second = await _page(http, console)
        await first.send(type="take")
        await first.until(lambda m: m["type"] == "state" and m["held_by"] == "you")
        await second.send(type="jog", servo=0, us=1600.0)
        error = await second.reply("error")
        assert "another console page holds the servos" in error["message"]
        await second.until(lambda m: m["type"] == "state" and m["held_by"] == "other")
        await second.send(type="stop")  # but any page with the token may stop them
        await first.ws.close()
        await second.send(type="jog", servo=0, us=1600.0)
        await second.until(lambda m: m["type"] == "state" and m["held_by"] == "you")


async def test_while_another_service_sends_servo_commands_the_console_lets_go(
    console: ConsoleServer,
) -> None:
    """A translator starting on the rig while a page holds the servos: the console lets go
    (rather than alternate with it in C) and refuses to move them until it stops."""
    bus = console.session.bus

    def translator_command(seq: int) -> None:
        command = ServoCommands(
            seq=seq, t_capture_ns=0, t_media_ns=0, face=True, profile=FIRST.name,
            positions={}, sender="translator/abc", sender_seq=seq,
        )  # fmt: skip
        bus.publish("facesynth/t/servo_commands", codec.encode(command))

    async with aiohttp.ClientSession() as http:
        page = await _page(http, console)
        await page.send(type="take")
        await page.until(lambda m: m["type"] == "state" and m["holding"])
        translator_command(1)
        error = await page.reply("error")
        assert "translator/abc started sending servo commands" in error["message"]
        await page.until(lambda m: m["type"] == "state" and not m["holding"])
        for kind in ("take", "stop"):
            translator_command(2)
            await page.send(type=kind)
            refusal = await page.reply("error")
            assert "translator/abc is sending servo commands on this rig" in refusal["message"]
        translator_command(3)
        response = await http.post(
            f"http://127.0.0.1:{console.port}/api/stop", headers={TOKEN_HEADER: TOKEN}
        )
        assert response.status == 409
    assert not console.session.core.holding


async def test_the_page_and_its_files_are_served(console: ConsoleServer) -> None:
    url = f"http://127.0.0.1:{console.port}/"
    async with aiohttp.ClientSession() as http:
        for path, kind, needle in (
            ("", "text/html", '<script src="frames.js">'),
            ("console.js", "text/javascript", "pageLink(state"),
            ("link.js", "text/javascript", "new WebSocket"),  # these four: the
            ("frames.js", "text/javascript", "createImageBitmap"),  # live face page's
            ("bars.js", "text/javascript", "function servoBar"),
            ("stages.js", "text/javascript", "function showStages"),
            ("console.css", "text/css", "banner"),
        ):
            async with http.get(url + path) as response:
                assert response.status == 200
                assert response.content_type == kind
                assert response.headers["Cache-Control"] == "no-store"
                assert needle in await response.text()
        async with http.get(url + "favicon.ico") as response:
            assert response.status == 204  # no icon, and no 404 logged for it


async def test_other_origins_and_host_names_are_refused(console: ConsoleServer) -> None:
    url = f"http://127.0.0.1:{console.port}"
    async with aiohttp.ClientSession() as http:
        with pytest.raises(aiohttp.WSServerHandshakeError) as refused:
            await http.ws_connect(f"{url}/ws", origin="http://evil.example")
        assert refused.value.status == 403
        headers = {TOKEN_HEADER: TOKEN, "Origin": "http://evil.example"}
        async with http.post(f"{url}/api/stop", headers=headers) as response:
            assert response.status == 403
            assert "cross-origin" in (await response.json())["error"]
        rebinding = {TOKEN_HEADER: TOKEN, "Host": f"evil.example:{console.port}"}
        async with http.post(f"{url}/api/stop", headers=rebinding) as response:
            assert response.status == 403
            assert "listens on loopback" in (await response.json())["error"]
        async with http.post(f"{url}/api/stop") as response:
            assert response.status == 401
            assert TOKEN_HEADER in (await response.json())["error"]
        async with http.post(f"{url}/api/stop", headers={TOKEN_HEADER: TOKEN}) as response:
            assert response.status == 200
    assert console.refused == 4
    assert console.session.core.holding  # stopped: held where they stand
    async with aiohttp.ClientSession() as http:  # until a page with the token lets go
        page = await _page(http, console)
        await page.send(type="release")
        await page.reply("released")
    assert not console.session.core.holding


MALFORMED = [
    ("not json", "not JSON"),
    ("[1, 2]", "not a console message"),
    ('{"type": "dance"}', "not a console message (Invalid value 'dance'"),
    ('{"type": "jog", "servo": 0}', "missing required field `us`"),
    ('{"type": "jog", "servo": "a", "us": 1}', "Expected `int`, got `str` - at `$.servo`"),
    ('{"type": "jog", "servo": 99, "us": 1500}', "no servo 99"),
    ('{"type": "take", "extra": 1}', "unknown field `extra`"),
    ('{"type": "limit", "servo": 0, "which": "top"}', "Invalid enum value 'top'"),
    ('{"type": "limit", "servo": 0, "which": "min", "us": 1700}', "min_us"),
    ('{"type": "rename", "servo": 0, "name": "a b"}', "letters, digits"),
    ('{"type": "calibrate", "name": "x"}', "start the console with --camera N or --video"),
]


async def test_a_malformed_message_gets_a_clear_error(console: ConsoleServer) -> None:
    async with aiohttp.ClientSession() as http:
        page = await _page(http, console)
        for text, error in MALFORMED:
            await page.ws.send_str(text)
            message = (await page.reply("error"))["message"]
            assert error in message, (text, message)
            await page.send(type="ping", t=1.5)  # the page stays connected
            assert (await page.reply("pong"))["t"] == 1.5
    assert console.refused == len(MALFORMED)
    assert console.session.core.draft == console.session.core.active  # nothing changed


async def test_binary_and_oversized_messages_close_the_page(console: ConsoleServer) -> None:
    async with aiohttp.ClientSession() as http:
        page = await _page(http, console)
        await page.ws.send_bytes(b"\x00\x01")
        closed = await page.until(lambda m: False)
        assert closed.type == aiohttp.WSMsgType.CLOSE and closed.data == 1003
        page = await _page(http, console)
        await page.ws.send_str(
            json.dumps({"type": "rename", "servo": 0, "name": "x" * MAX_MESSAGE})
        )
        closed = await page.until(lambda m: False)
        assert closed.type == aiohttp.WSMsgType.CLOSE and closed.data == 1009
    assert console.refused >= 2


async def test_a_save_reloads_identically_and_c_runs_the_new_limits(
    console: ConsoleServer, tmp_path: Path
) -> None:
    path = tmp_path / "head.toml"
    before = path.read_text()
    async with aiohttp.ClientSession() as http:
        page = await _page(http, console)
        await page.send(type="jog", servo=0, us=1800.0)
        await page.until(lambda m: m["type"] == "state" and m["positions"][0] == 1800.0)
        await page.send(type="limit", servo=0, which="max")  # from where it stands
        await page.send(type="limit", servo=0, which="min", us=900.0)  # widened: after a save
        hello = await page.until(lambda m: m["type"] == "hello" and m["servos"][0]["min"] == 900)
        assert hello["servos"][0]["max"] == 1800.0
        await page.send(type="save")
        saved = await page.reply("saved")
        assert saved["path"] == str(path) and saved["backup"] == f"{path}.bak"
        assert Path(saved["backup"]).read_text() == before
        assert load_profile(str(path)) == console.session.core.active
        spec = load_profile(str(path)).servos[0]
        assert (spec.min_us, spec.max_us) == (900.0, 1800.0)
        await page.until(lambda m: m["type"] == "state" and m["control"] == "running")
        await page.send(type="jog", servo=0, us=850.0)  # C now allows 900
        await page.until(lambda m: m["type"] == "state" and m["positions"][0] == 900.0, 8)
    assert min(c[FIRST.name] for c in _commands(tmp_path)) == 900.0


async def test_the_stage_table_lists_c_and_the_console(console: ConsoleServer) -> None:
    async with aiohttp.ClientSession() as http:
        page = await _page(http, console)
        table = await page.until(
            lambda m: (
                m["type"] == "stats"
                and {"control", "console"} <= {row["service"] for row in m["services"]}
            ),
            timeout=6,
        )
    rows = {row["service"]: row for row in table["services"]}
    assert rows["control"]["status"] == "running"
    assert set(rows["control"]) >= {"rate_hz", "p50_ms", "dropped", "rejected", "stale", "note"}


async def test_frames_are_followed_only_while_a_page_shows_them(console: ConsoleServer) -> None:
    assert not console.session.watching
    async with aiohttp.ClientSession() as http:
        page = await _page(http, console)
        await page.reply("welcome")
        assert console.session.watching
        await page.send(type="hello", token=TOKEN, frames=False)
        await page.reply("welcome")
        assert not console.session.watching
        await page.ws.close()
    assert not console.session.watching


async def test_http_save_with_the_token(console: ConsoleServer, tmp_path: Path) -> None:
    url = f"http://127.0.0.1:{console.port}"
    console.session.core.set_limit(2, "max", 1900.0)
    async with aiohttp.ClientSession() as http:
        async with http.get(f"{url}/state") as response:
            state = await response.json()
            assert state["dirty"] and not state["locked"] and state["control"] == "running"
        async with http.post(f"{url}/api/save", headers={TOKEN_HEADER: "nope"}) as response:
            assert response.status == 401
        async with http.post(f"{url}/api/save", headers={TOKEN_HEADER: TOKEN}) as response:
            assert response.status == 200
            saved = await response.json()
    assert saved["path"] == str(tmp_path / "head.toml")
    assert load_profile(saved["path"]).servos[2].max_us == 1900.0
    assert load_profile(saved["path"]) == console.session.core.active
    assert not console.session.core.dirty


async def test_a_stop_cancelled_meanwhile_still_stops_c_then_ends_cancelled(
    console: ConsoleServer,
) -> None:
    # A second Ctrl-C while the console stops: C is stopped all the same (it returns the face
    # to neutral), and the stop ends cancelled, so that Ctrl-C reaches asyncio.run.
    (control,) = [task for task in asyncio.all_tasks() if task.get_name() == "control"]
    stopper = asyncio.create_task(console.session.stop())
    await asyncio.sleep(0)  # the stop waits for the console's own tasks
    stopper.cancel()
    await asyncio.wait([stopper])
    assert stopper.cancelled()
    assert control.done()
