"""Cameras: the video devices of this host and the graph's camera, each opened as the sensor
opens it (:class:`~services.sensor.sources.camera.CameraSource`) and one frame read for its
resolution.

A device that cannot be opened (in use, not a capture node: many ``/dev/video*`` nodes are
metadata) is said so; a stream URL that nothing serves fails within the sensor's stream
timeout. Without OpenCV (the ``tracker`` extra) nothing can be opened, and that is the line.
"""

from __future__ import annotations

import re
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from facesynth.app.doctor.report import Finding

FAMILY = "camera"
_VIDEO = re.compile(r"video(\d+)")


@dataclass(frozen=True)
class CameraResult:
    """One camera looked at: its target (an index, a device path, a URL), what opened."""

    target: int | str
    size: tuple[int, int] | None = None
    problem: str | None = None


def video_devices(dev: Path = Path("/dev")) -> list[tuple[int, Path]]:
    """``(index, path)`` of the ``/dev/video*`` nodes, by index."""
    found = []
    for path in dev.glob("video*"):
        match = _VIDEO.fullmatch(path.name)
        if match:
            found.append((int(match.group(1)), path))
    return sorted(found)


def open_camera(target: int | str) -> CameraResult:
    """Open ``target`` as the sensor would and read one frame."""
    from facesynth.services.sensor.sources.base import SourceError, pixels
    from facesynth.services.sensor.sources.camera import CameraConfig, CameraSource

    try:
        source = CameraSource(CameraConfig(index=target))
    except SourceError as exc:
        return CameraResult(target, problem=str(exc))
    try:
        image, _ = next(iter(source.frames()))
    except (SourceError, StopIteration) as exc:
        return CameraResult(target, problem=str(exc) or "no frame")
    finally:
        source.close()
    if image is None:
        return CameraResult(target, problem="no frame")
    height, width = pixels(image).shape[:2]
    return CameraResult(target, size=(int(width), int(height)))


def have_opencv() -> bool:
    """Whether OpenCV can be imported."""
    try:
        import cv2  # noqa: F401
    except ImportError:
        return False
    return True


def camera_findings(
    devices: Sequence[tuple[int, Path]],
    results: Sequence[CameraResult],
    needed: Sequence[tuple[str, int | str]],
    *,
    opencv: bool,
) -> list[Finding]:
    """One line per camera (pure): the devices found, the graph's camera, what to fix."""
    wanted = {_key(target): node for node, target in needed}
    paths = dict(devices)
    findings: list[Finding] = []
    if not opencv:
        findings.append(
            Finding(
                FAMILY,
                "OpenCV",
                "not installed: cameras cannot be opened",
                good=False,
                needed=bool(needed),
                fix="pip install 'facesynth[tracker]'",
            )
        )
        findings.extend(
            Finding(FAMILY, _subject(index, paths), "found (its size needs OpenCV)", good=None)
            for index, _ in devices
        )
    elif not devices:
        findings.append(Finding(FAMILY, "/dev/video*", "no camera device on this host", good=None))
    for result in results:
        node = wanted.get(_key(result.target))
        subject = _subject(result.target, paths)
        if node is not None:
            subject += f" (sensor node {node})"
        if result.size is not None:
            width, height = result.size
            findings.append(Finding(FAMILY, subject, f"opens, {width}x{height}"))
            continue
        fix = "check it is connected and no other program uses it, or choose another with --camera"
        if not devices and _key(result.target).isdigit():
            fix = "plug a camera in, or give a stream URL with --camera (e.g. http://HOST:8090/camera.mjpg)"
        findings.append(
            Finding(
                FAMILY,
                subject,
                result.problem or "cannot be opened",
                good=False if node is not None else None,
                needed=node is not None,
                fix=fix,
            )
        )
    return findings


def _key(target: int | str) -> str:
    """Index 2, ``"2"`` and ``/dev/video2`` are one camera."""
    text = str(target).strip()
    match = _VIDEO.fullmatch(Path(text).name) if text.startswith("/dev/") else None
    return match.group(1) if match else text


def _subject(target: int | str, paths: dict[int, Path]) -> str:
    key = _key(target)
    if key.isdigit():
        return f"index {key} ({paths.get(int(key), Path(f'/dev/video{key}'))})"
    return str(target)


def cameras_to_open(
    devices: Sequence[tuple[int, Path]], needed: Sequence[tuple[str, int | str]]
) -> list[int | str]:
    """The graph's cameras, then every device not among them (each once; indexes as ints)."""
    targets: dict[str, int | str] = {}
    for _, target in needed:
        key = _key(target)
        targets.setdefault(key, int(key) if key.isdigit() else target)
    for index, _ in devices:
        targets.setdefault(str(index), index)
    return list(targets.values())
