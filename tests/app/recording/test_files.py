"""Session files: read back with the mcap reader, validated against the schemas; torn, damaged
and foreign files give one clear error or are recovered."""

from __future__ import annotations

import json
import time
from collections.abc import Callable
from pathlib import Path

import jsonschema
import pytest
from mcap.reader import make_reader
from mcap.writer import Writer
from mcap_protobuf.decoder import DecoderFactory
from messages_sample import messages

from facesynth.app.recording.check import describe, recover, scan
from facesynth.app.recording.layout import PROFILE, Layout
from facesynth.app.recording.reader import Recording, RecordingError
from facesynth.app.recording.writer import RecordingFileError, SessionWriter, WriterThread


class FakeClock:
    def __init__(self) -> None:
        self.now = 0.0

    def __call__(self) -> float:
        return self.now


def write_session(path: Path, frames: int, **options: object) -> list[tuple[str, bytes]]:
    """A session of ``frames`` frames' worth of every message; returns what was written."""
    layout = Layout()
    written = []
    writer = SessionWriter(path, metadata={"rig": "default"}, fsync=False, **options)  # type: ignore[arg-type]
    for seq in range(frames):
        for index, (key, payload) in enumerate(messages(seq)):
            log_time = 1_000_000_000 + seq * 1_000_000 + index
            for entry in layout.entries(key, payload, log_time, seq * 10 + index):
                writer.write(entry)
            written.append((key, payload))
    writer.close()
    return written


def test_files_read_back_with_the_mcap_reader_and_match_the_schemas(tmp_path: Path) -> None:
    path = tmp_path / "s.mcap"
    write_session(path, 20)
    with open(path, "rb") as handle:
        reader = make_reader(handle, decoder_factories=[DecoderFactory()])
        header = reader.get_header()
        assert header.profile == PROFILE and header.library.startswith("facesynth")
        summary = reader.get_summary()
        assert summary is not None and summary.statistics is not None
        assert summary.statistics.message_count > 0 and summary.chunk_indexes
        (session,) = [m for m in reader.iter_metadata() if m.name == "facesynth.session"]
        assert session.metadata["rig"] == "default"
        validators = {}
        checked = 0
        for schema, channel, message in reader.iter_messages():
            assert schema is not None or channel.message_encoding == "msgpack"
            if channel.message_encoding == "json":
                assert schema is not None and schema.encoding == "jsonschema"
                validator = validators.setdefault(
                    schema.id, jsonschema.Draft202012Validator(json.loads(schema.data))
                )
                validator.validate(json.loads(message.data))
                checked += 1
        protobuf = [c.topic for c in summary.channels.values() if c.message_encoding == "protobuf"]
        decoded = [m for _, _, _, m in reader.iter_decoded_messages(topics=protobuf)]
        assert decoded and all(hasattr(m, "timestamp") for m in decoded)
    assert checked == 20 * 9


def test_a_recording_gives_back_every_payload_in_order(tmp_path: Path) -> None:
    path = tmp_path / "s.mcap"
    written = write_session(path, 12, chunk_bytes=4096)
    with Recording(path) as recording:
        assert recording.rig == "default"
        assert recording.stages() == [
            "input",
            "points",
            "features",
            "servo_commands",
            "servo_state",
        ]
        got = [(p.key, p.payload) for p in recording.payloads(recording.bus_keys())]
        assert recording.count("facesynth/default/input") == 36
    assert got == written


def test_chunks_are_cut_by_size_and_by_time(tmp_path: Path) -> None:
    clock = FakeClock()
    writer = SessionWriter(
        tmp_path / "t.mcap",
        metadata={},
        chunk_bytes=1 << 20,
        chunk_seconds=1.0,
        clock=clock,
        fsync=False,
    )
    layout = Layout()
    for entry in layout.entries(*messages(0)[6], 1, 0):
        writer.write(entry)
    size = (tmp_path / "t.mcap").stat().st_size
    clock.now = 0.5
    assert not writer.tick()
    clock.now = 1.01
    assert writer.tick() and writer.chunks == 1
    assert (tmp_path / "t.mcap").stat().st_size > size, "a cut chunk is on disk at once"
    assert not writer.tick(), "an empty chunk is not cut"
    writer.close()
    small = SessionWriter(tmp_path / "u.mcap", metadata={}, chunk_bytes=2048, fsync=False)
    for entry in layout.entries(*messages(0)[0], 1, 0):  # a JPEG frame: more than 2 KiB
        small.write(entry)
    assert small.chunks == 1
    small.close()


def test_the_writer_thread_writes_everything_and_reports_a_failing_disk(tmp_path: Path) -> None:
    path = tmp_path / "threaded.mcap"
    writer = SessionWriter(path, metadata={}, chunk_bytes=4096, fsync=False)
    sink = WriterThread(writer)
    layout = Layout()
    written = []
    for seq in range(20):
        for key, payload in messages(seq):
            for entry in layout.entries(key, payload, 1_000 + seq, seq):
                sink.write(entry)
            written.append((key, payload))
    sink.close()
    assert sink.refused == 0
    with Recording(path) as recording:
        assert [(p.key, p.payload) for p in recording.payloads(recording.bus_keys())] == written
    broken = SessionWriter(tmp_path / "broken.mcap", metadata={}, chunk_bytes=2048, fsync=False)
    broken._file.close()  # the disk goes away under the writer
    failing = WriterThread(broken)
    with pytest.raises(RecordingFileError, match="cannot write"):
        for entry in layout.entries(*messages(0)[0], 1, 0) * 50:
            failing.write(entry)
            time.sleep(0.001)
        failing.close()


def test_writer_options_and_existing_files_are_clear_errors(tmp_path: Path) -> None:
    path = tmp_path / "s.mcap"
    path.write_bytes(b"precious")
    with pytest.raises(RecordingFileError, match=r"exists .*--overwrite"):
        SessionWriter(path, metadata={})
    assert path.read_bytes() == b"precious"
    with pytest.raises(RecordingFileError, match="unknown compression"):
        SessionWriter(tmp_path / "x.mcap", metadata={}, compression="gzip")
    with pytest.raises(RecordingFileError, match="cannot create"):
        SessionWriter(tmp_path / "no" / "such" / "dir.mcap", metadata={})


def _foreign(path: Path) -> None:
    with open(path, "wb") as handle:
        writer = Writer(handle)
        writer.start(profile="ros2", library="rosbag2")
        writer.finish()


@pytest.mark.parametrize(
    ("make", "expected"),
    [
        (lambda p: p.write_bytes(b""), "not an MCAP file (an empty file)"),
        (lambda p: p.write_text("frame,face\n1,1\n"), "not an MCAP file (starts with"),
        (_foreign, "is an MCAP file but not a facesynth recording (profile 'ros2'"),
    ],
    ids=["empty", "text", "foreign MCAP"],
)
def test_foreign_files_are_one_clear_error(tmp_path: Path, make, expected: str) -> None:  # type: ignore[no-untyped-def]
    path = tmp_path / "f.mcap"
    make(path)
    with pytest.raises(RecordingError, match=expected.replace("(", r"\(").replace(")", r"\)")):
        Recording(path)
    with pytest.raises(RecordingError, match="cannot read"):
        Recording(tmp_path / "missing.mcap")


def test_a_torn_file_names_the_command_that_recovers_it(tmp_path: Path) -> None:
    path = tmp_path / "s.mcap"
    write_session(path, 5)
    data = path.read_bytes()
    path.write_bytes(data[: len(data) - 100])
    with pytest.raises(RecordingError, match=r"torn .* facesynth record --check"):
        Recording(path)


def test_recovery_keeps_every_intact_chunk_wherever_the_file_ends(tmp_path: Path) -> None:
    path = tmp_path / "s.mcap"
    written = write_session(path, 30, chunk_bytes=8192)
    data = path.read_bytes()
    complete = scan(path)
    assert complete.complete and complete.chunks > 10
    with open(path, "rb") as handle:
        summary = make_reader(handle).get_summary()
    assert summary is not None
    first_chunk = summary.chunk_indexes[0].chunk_start_offset  # header and metadata before it
    previous = -1
    for cut in range(first_chunk, len(data), len(data) // 23):
        torn = tmp_path / f"torn-{cut}.mcap"
        torn.write_bytes(data[:cut])
        result = scan(torn)
        assert not result.complete and result.problem, cut
        assert "TORN" in describe(result)
        out = recover(torn, tmp_path / f"rec-{cut}.mcap")
        with Recording(tmp_path / f"rec-{cut}.mcap") as recording:
            got = [(p.key, p.payload) for p in recording.payloads(recording.bus_keys())]
        assert got == written[: len(got)], "the recovered messages are the first ones, unchanged"
        assert len(got) >= previous
        previous = len(got)
        assert out.messages == result.messages
    assert previous > len(written) * 0.8


def test_a_damaged_chunk_is_skipped_and_the_rest_recovered(tmp_path: Path) -> None:
    path = tmp_path / "s.mcap"
    written = write_session(path, 30, chunk_bytes=8192)
    with open(path, "rb") as handle:
        summary = make_reader(handle).get_summary()
    assert summary is not None
    middle = summary.chunk_indexes[len(summary.chunk_indexes) // 2]
    data = bytearray(path.read_bytes())
    spot = middle.chunk_start_offset + middle.chunk_length - 40
    data[spot] ^= 0xFF
    damaged = tmp_path / "damaged.mcap"
    damaged.write_bytes(bytes(data))
    result = recover(damaged, tmp_path / "rec.mcap")
    assert result.damaged_chunks == 1 and "damaged chunk" in result.problem
    with Recording(tmp_path / "rec.mcap") as recording:
        got = {(p.key, p.payload) for p in recording.payloads(recording.bus_keys())}
    assert got <= set(written) and len(got) > len(set(written)) * 0.8


def test_recovery_never_overwrites_its_source(tmp_path: Path) -> None:
    path = tmp_path / "s.mcap"
    write_session(path, 2)
    with pytest.raises(RecordingError, match="must not overwrite"):
        recover(path, path)


def _damage_chunk(path: Path, patch: Callable[[bytearray, int], None]) -> None:
    """Apply ``patch`` to the first chunk record (at its start offset) of ``path``."""
    with open(path, "rb") as handle:
        summary = make_reader(handle).get_summary()
    assert summary is not None
    data = bytearray(path.read_bytes())
    patch(data, summary.chunk_indexes[0].chunk_start_offset)
    path.write_bytes(bytes(data))


def test_a_chunk_claiming_exabytes_is_a_damaged_file_not_a_memory_error(tmp_path: Path) -> None:
    """A damaged length made the mcap reader allocate it (MemoryError; found by tests/fuzz)."""
    path = tmp_path / "s.mcap"
    written = write_session(path, 3, chunk_bytes=2048)

    def huge_data_length(data: bytearray, start: int) -> None:
        body = start + 9  # opcode, record length
        compression = int.from_bytes(data[body + 28 : body + 32], "little")
        at = body + 32 + compression
        data[at : at + 8] = (2**62).to_bytes(8, "little")

    _damage_chunk(path, huge_data_length)
    with Recording(path) as recording:
        try:  # the chunk's data now runs to the end of the file: it may still decompress
            got = [(p.key, p.payload) for p in recording.payloads(recording.bus_keys())]
        except RecordingError as exc:
            assert "damaged" in str(exc)
        else:
            assert got == written


def test_a_chunk_that_does_not_decompress_is_a_damaged_file(tmp_path: Path) -> None:
    """zstd's own error went through the reader (found by tests/fuzz)."""
    path = tmp_path / "s.mcap"
    write_session(path, 3, chunk_bytes=2048)

    def garbled_data(data: bytearray, start: int) -> None:
        body = start + 9
        compression = int.from_bytes(data[body + 28 : body + 32], "little")
        at = body + 32 + compression + 8
        data[at : at + 8] = b"\x00" * 8

    _damage_chunk(path, garbled_data)
    with Recording(path) as recording, pytest.raises(RecordingError, match="damaged"):
        list(recording.payloads(recording.bus_keys()))


def test_check_says_what_it_counts(tmp_path: Path) -> None:
    """Issue 20: the bus's messages and the Foxglove views apart (the recorder logs the first)."""
    path = tmp_path / "s.mcap"
    written = write_session(path, 5)
    result = scan(path)
    views = sum(f.count for f in result.channels.values() if f.view)
    assert views > 0 and result.messages == len(written) + views
    first = describe(result).splitlines()[0]
    assert (
        f"{result.messages} MCAP messages: {len(written)} from the bus and {views} Foxglove "
        "views of them (frame images, landmark annotations)"
    ) in first
