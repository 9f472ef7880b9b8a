"""Which payloads Zenoh sends through shared memory: only large ones (raw frames), unless the
user's Zenoh config file says otherwise."""

from __future__ import annotations

import json
from pathlib import Path

from facesynth.runtime.bus.zenoh_bus import (
    SHM_THRESHOLD,
    SHM_THRESHOLD_PATH,
    ZENOH_SHM_THRESHOLD,
    ZenohOptions,
)


def _threshold(options: ZenohOptions) -> int:
    return int(json.loads(options.build().get_json(SHM_THRESHOLD_PATH)))


def test_messages_of_the_chain_skip_shared_memory_and_raw_frames_take_it() -> None:
    assert _threshold(ZenohOptions(mode="client")) == SHM_THRESHOLD
    assert _threshold(ZenohOptions(mode="router")) == SHM_THRESHOLD
    assert ZENOH_SHM_THRESHOLD < 40_000 < SHM_THRESHOLD < 640 * 360 * 3  # JPEG vs raw frame


def test_a_config_files_own_threshold_is_kept(tmp_path: Path) -> None:
    path = tmp_path / "zenoh.json5"
    path.write_text(
        "{transport: {shared_memory: {transport_optimization: {message_size_threshold: 4096}}}}"
    )
    assert _threshold(ZenohOptions(mode="client", config_file=str(path))) == 4096
    assert _threshold(ZenohOptions(overrides={SHM_THRESHOLD_PATH: 8192})) == 8192
