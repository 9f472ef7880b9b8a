"""`make test` installs facesynth with `.[all,test]`, which leaves out the [ros2] extra (250 MB),
and pytest imports every test module before it deselects the ros2 group. So no test module, and
no module a test module imports at its top, may import a ROS 2 package at module level: one such
import stopped CI's whole fast suite at collection."""

from __future__ import annotations

import ast
import re
import tomllib
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]


def ros2_only_modules() -> set[str]:
    """The import names of the [ros2] extra's packages (`ros-jazzy-std-msgs` → `std_msgs`)."""
    extras = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]
    names = set()
    for requirement in extras["optional-dependencies"]["ros2"]:
        match = re.match(r"ros-[a-z]+-([a-z0-9-]+)", requirement)
        assert match, f"not a ROS package from the index: {requirement}"
        names.add(match.group(1).replace("-", "_"))
    return names


def module_level_imports(source: str) -> set[str]:
    """The top-level package of every import a module runs when it is imported (its body, and
    the bodies of module-level if/try blocks; not functions' bodies)."""
    found: set[str] = set()
    pending = list(ast.parse(source).body)
    while pending:
        node = pending.pop()
        if isinstance(node, ast.Import):
            found.update(alias.name.split(".")[0] for alias in node.names)
        elif isinstance(node, ast.ImportFrom) and node.module and node.level == 0:
            found.add(node.module.split(".")[0])
        elif isinstance(node, ast.If | ast.Try | ast.With):
            pending.extend(ast.iter_child_nodes(node))
        elif isinstance(node, ast.ExceptHandler):
            pending.extend(node.body)
    return found


def test_the_ros2_extra_gives_its_import_names() -> None:
    assert {"rclpy", "std_msgs", "sensor_msgs", "trajectory_msgs"} <= ros2_only_modules()


def test_module_level_imports_finds_top_level_and_guarded_imports_only() -> None:
    source = (
        "import rclpy.node\nfrom std_msgs.msg import X\nif True:\n    import sensor_msgs\n"
        "try:\n    import a\nexcept ImportError:\n    import b\n"
        "def f():\n    import trajectory_msgs\nfrom . import c\n"
    )
    assert module_level_imports(source) == {"rclpy", "std_msgs", "sensor_msgs", "a", "b"}


def test_no_module_pytest_collects_or_facesynth_ships_imports_ros2_at_module_level() -> None:
    ros2 = ros2_only_modules()
    offenders = []
    for folder in ("tests", "facesynth", "services", "schemas", "tools"):
        for path in sorted((ROOT / folder).rglob("*.py")):
            used = module_level_imports(path.read_text()) & ros2
            if used:
                offenders.append(f"{path.relative_to(ROOT)}: {', '.join(sorted(used))}")
    assert not offenders, (
        "imports a ROS 2 package at module level (import it inside the function that needs it): "
        + "; ".join(offenders)
    )
