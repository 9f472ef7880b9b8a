"""With rclpy installed: doctor's line names Fast DDS and this test's discovery settings, and
a topic or node name ROS 2 refuses is one line at start, from the driver and the source."""

from __future__ import annotations

import pytest

from facesynth.app.cli import main
from facesynth.app.doctor.report import Status
from facesynth.app.doctor.ros2 import ros2_findings


def test_doctor_says_rclpy_imports_and_which_rmw(ros2_host: int) -> None:
    (finding,) = ros2_findings(True)
    assert finding.status is Status.OK
    assert finding.text == (
        "imports (ROS 2 jazzy 7.1.6); RMW rmw_fastrtps_cpp (default); "
        f"ROS_DOMAIN_ID {ros2_host}, discovery range LOCALHOST"
    )


@pytest.mark.parametrize(
    ("argv", "expected"),
    [
        (
            ["control", "--driver", "ros2", "--profile", "paper16", "--ros2-topic", "bad topic"],
            "facesynth control: error: --ros2-topic 'bad topic': Invalid topic name: topic name "
            "must not contain characters other than alphanumerics, '_', '~', '{', or '}'",
        ),
        (
            ["control", "--driver", "ros2", "--profile", "paper16", "--ros2-node", "face-synth"],
            "facesynth control: error: --ros2-node 'face-synth': Invalid node name: node name "
            "must not contain characters other than alphanumerics or '_'",
        ),
        (
            ["sensor", "--ros2-image-topic", "/camera/9image"],
            "facesynth sensor: error: ros2 source: Invalid topic name: topic name token must not "
            "start with a number",
        ),
    ],
    ids=["driver-topic", "driver-node", "source-topic"],
)
def test_a_name_ros2_refuses_is_one_line(
    argv: list[str], expected: str, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(argv) == 2
    err = capsys.readouterr().err
    assert err.strip().splitlines()[-1] == expected
    assert "Traceback" not in err
